"""Run configuration: YAML validated into typed models (pydantic v2).

Every error names the file, the line where YAML has one, the field path and the value.
The one module that reads YAML (within the limits of :mod:`pipeline.inputs`).
"""

from __future__ import annotations

import datetime
import re
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
import yaml
from pydantic import (BaseModel, ConfigDict, Discriminator, Field, StrictInt, Tag, ValidationError,
                      ValidationInfo, field_validator, model_validator)

from flatten import InvalidCurveError, NurbsCurve, nurbs_curve
from flatten.errors import DevflatError

UNIT_TO_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}
# part names become file names: no path separator, no leading dot (hidden files, "..")
NAME_PATTERN = r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$"
MAX_RULINGS_AUTO = 20_000  # choose_rulings' default max_rulings
MAX_MESH_VERTICES = 2_100_000  # ~0.5 GB of strip, check mesh and development at the peak


class ConfigError(DevflatError, ValueError):
    """A configuration file is unreadable or invalid; the message names file, line, field, value."""


_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


def _boolean_inside(value, where: str = "") -> str | None:
    """Index path ('', '[1][0]') of the first boolean in a value or its lists, else None."""
    if isinstance(value, bool):
        return where
    if isinstance(value, (list, tuple)):
        for k, item in enumerate(value):
            found = _boolean_inside(item, f"{where}[{k}]")
            if found is not None:
                return found
    return None


class _Strict(BaseModel):
    # no inf/NaN anywhere (thickness .inf, a NaN normal); ints are StrictInt where a bool
    # would otherwise pass as 0/1
    # defer_build: a model's validator is built when it is first used, not at import
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, defer_build=True)

    @field_validator("*", mode="before")
    @classmethod
    def _no_booleans_for_numbers(cls, value, info: ValidationInfo):
        """YAML's true/false would pass as 1/0 for a number (degree: true, thickness: true)."""
        if "bool" not in str(cls.model_fields[info.field_name].annotation):
            where = _boolean_inside(value)
            if where is not None:
                raise ValueError(f"{info.field_name}{where} is a boolean where a number is expected")
        return value

    @field_validator("*", mode="after")
    @classmethod
    def _printable(cls, value, info: ValidationInfo):
        """Texts end up in DXF groups and file names: no newline or other control character."""
        if isinstance(value, str) and _CONTROL.search(value):
            raise ValueError(f"control character {_CONTROL.search(value).group()!r} in {info.field_name}")
        return value

    def _given(self, *names: str) -> list[str]:
        """Which of the named alternative fields this model was given."""
        return [k for k in names if getattr(self, k) is not None]


class CurveSpec(_Strict):
    degree: StrictInt = Field(3, ge=1, le=9)  # flatten.nurbs.MAX_DEGREE
    control_points: list[tuple[float, float, float]] = Field(min_length=2)
    weights: list[float] | None = None
    knots: list[float] | None = None


class IsoSpec(_Strict):
    u: float | None = None
    v: float | None = None

    @model_validator(mode="after")
    def _one(self):
        if len(self._given("u", "v")) != 1:
            raise ValueError("iso gives exactly one of u, v")
        return self


class PlaneSpec(_Strict):
    """A plane through a point (config units) with a normal."""

    point: tuple[float, float, float]
    normal: tuple[float, float, float]

    @field_validator("normal")
    @classmethod
    def _non_zero(cls, value):
        if not any(value):
            raise ValueError("the normal must not be the zero vector")
        return value


class SurfaceSource(_Strict):
    """An IGES entity picked by its index among entities of its type (default 0), its
    directory number or its label; the path is relative to the config file. As it stands:
    an entity-128 surface."""

    iges: str
    entity: StrictInt | None = Field(None, ge=0)
    directory: StrictInt | None = Field(None, ge=1)
    label: str | None = None

    @model_validator(mode="after")
    def _pick(self):
        given = self._given("entity", "directory", "label")
        if len(given) > 1:
            raise ValueError(f"pick the entity by one of entity, directory, label; got {given}")
        if not given:
            object.__setattr__(self, "entity", 0)
        return self


class ModelSurfaceSource(_Strict):
    """A face of a hull model read through OpenCascade (IGES, STEP) or rhino3dm (Rhino .3dm),
    by its index in the file (``devflat hull inspect FILE`` lists the faces); the path is
    relative to the config file. The face's trim comes with it. ``faces``: several faces that
    meet smoothly, expanded as one shell surface (seams, butts and plates cross their boundaries)."""

    model: str
    face: StrictInt = Field(0, ge=0)
    faces: list[StrictInt] | None = Field(
        None, min_length=2, max_length=64, description="faces expanded as one shell: lofted through their plane "
        "sections into one surface that plates cross (pipeline.hull.shell); face is then not used")

    @model_validator(mode="after")
    def _one_way(self):
        if self.faces is not None and "face" in self.model_fields_set:
            raise ValueError(f"give face (one face) or faces (a shell of several), not both: face {self.face}, "
                             f"faces {self.faces}")
        if self.faces is not None and (min(self.faces) < 0 or len(set(self.faces)) != len(self.faces)):
            raise ValueError(f"faces must be distinct face indices >= 0, got {self.faces}")
        return self


def _surface_kind(value) -> str:
    if isinstance(value, dict):
        return "Model" if "model" in value else "Iges"
    return "Model" if isinstance(value, ModelSurfaceSource) else "Iges"


HullSurfaceSource = Annotated[Union[Annotated[SurfaceSource, Tag("Iges")], Annotated[ModelSurfaceSource, Tag("Model")]],
                              Discriminator(_surface_kind)]


class IgesCurveSource(SurfaceSource):
    """Entity 126 of an IGES file, or an iso-curve (iso) or a plane section (section, fitted
    within tolerance) of an entity 128 surface, picked as in :class:`SurfaceSource`."""

    iso: IsoSpec | None = None
    section: "PlaneSpec | None" = None
    tolerance: float | None = Field(None, gt=0, description="fit tolerance of a plane section (config units; "
                                    "default 0.5 mm whatever the units)")
    segment: tuple[float, float] | None = None

    @model_validator(mode="after")
    def _one_kind(self):
        if self.iso is not None and self.section is not None:
            raise ValueError("give either iso or section, not both")
        return self


class DxfCurveSource(_Strict):
    """A SPLINE (taken exactly) or a polyline (fitted within tolerance) of a DXF file."""

    dxf: str
    layer: str | None = None
    handle: str | None = None
    tolerance: float | None = Field(None, gt=0, description="fit tolerance of a polyline (config units; default "
                                    "0.1 mm whatever the units)")

    @model_validator(mode="after")
    def _pick(self):
        if len(self._given("layer", "handle")) != 1:
            raise ValueError("pick the DXF entity by exactly one of layer, handle")
        return self


class PointsCurveSource(_Strict):
    """Offsets / a point list, fitted to a cubic B-spline within tolerance (config units)."""

    points: list[tuple[float, float, float]] = Field(min_length=4)
    tolerance: float | None = Field(None, gt=0, description="config units; default 0.5 mm whatever the units")


def _curve_kind(value) -> str:
    """Which curve source a mapping describes, by its one distinguishing key."""
    if isinstance(value, dict):
        for key, tag in (("iges", "Iges"), ("dxf", "Dxf"), ("points", "Points")):
            if key in value:
                return tag
    elif isinstance(value, BaseModel):
        return {IgesCurveSource: "Iges", DxfCurveSource: "Dxf", PointsCurveSource: "Points"}.get(type(value), "Inline")
    return "Inline"


# tags are capitalised so that error locations can drop them (they are no input keys)
CurveSource = Annotated[Union[Annotated[CurveSpec, Tag("Inline")], Annotated[IgesCurveSource, Tag("Iges")],
                              Annotated[DxfCurveSource, Tag("Dxf")], Annotated[PointsCurveSource, Tag("Points")]],
                        Discriminator(_curve_kind)]


class CurvesSpec(_Strict):
    c: CurveSource
    d: CurveSource


DEFAULT_CHORD_TOLERANCE_MM = 0.5
# physical defaults of the other tolerances, taken in mm whatever ``units:`` (a config in
# metres must not fit its curves to 0.5 m); a value given in the config is in its units
DEFAULT_TOLERANCES_MM = {IgesCurveSource: 0.5, DxfCurveSource: 0.1, PointsCurveSource: 0.5}
DEFAULT_FIT_TOLERANCE_MM = 5.0


class Resolution(_Strict):
    """Rulings of the computation: a chord tolerance (config units; when neither is given,
    0.5 mm whatever the units) or a count."""

    chord_tolerance: float | None = Field(None, gt=0)
    rulings: StrictInt | None = Field(None, ge=2, le=200_000)
    samples_per_ruling: StrictInt = Field(5, ge=3, le=101)

    def tolerance(self, mm_per_unit: float) -> float | None:
        """The chord tolerance in config units, None when a ruling count is given."""
        if self.rulings is not None:
            return None
        return self.chord_tolerance if self.chord_tolerance is not None else DEFAULT_CHORD_TOLERANCE_MM / mm_per_unit

    @model_validator(mode="after")
    def _one_of(self):
        if self.chord_tolerance is not None and self.rulings is not None:
            raise ValueError("give either chord_tolerance or rulings, not both")
        # the chord_tolerance route stops at MAX_RULINGS_AUTO rulings (flatten.strip)
        vertices = (self.rulings or MAX_RULINGS_AUTO) * self.samples_per_ruling
        if vertices > MAX_MESH_VERTICES:
            raise ValueError(f"rulings x samples_per_ruling = {vertices} mesh vertices, more than the "
                             f"{MAX_MESH_VERTICES} a part may have")
        return self


class Steel(_Strict):
    thickness: float = Field(10.0, gt=0, description="mm")
    material: str = Field("S355", max_length=80)
    density: float = Field(7850.0, gt=0, description="kg/m^3")
    marked_side: str = Field("moulded", max_length=80)


class Check(_Strict):
    max_residual: float = Field(1e-9, gt=0)
    max_curvature: float = Field(1e-6, gt=0, description="max |K| times the squared part size")
    min_coverage: float = Field(0.5, ge=0, le=1)


class Layers(_Strict):
    cut: str = "CUT_OUTER"
    bend: str = "MARK_BEND"
    text: str = "MARK_TEXT"
    frame: str = "MARK_FRAME"
    edge: str = "MARK_EDGE"  # edge names (seams, butts) and bevel texts
    net: str = "MARK_NET"  # the net line when an excess / shrinkage allowance is cut outside it
    shrink: str = "MARK_SHRINK"  # formed plates: areas to shrink (heat) when forming
    stretch: str = "MARK_STRETCH"  # formed plates: areas to stretch when forming
    heat: str = "MARK_HEAT"  # formed plates: heating lines (pipeline.shop.heating)

    @field_validator("cut", "bend", "text", "frame", "edge", "net", "shrink", "stretch", "heat")
    @classmethod
    def _layer_name(cls, value: str) -> str:
        bad = set('<>/\\":;?*|=`') & set(value)
        if not value or bad or len(value) > 255:
            raise ValueError(f"invalid DXF layer name {value!r}")
        return value


class SeamAllowance(_Strict):
    """Per-edge widths (config units): the c edge, the d edge, the start and end rulings."""

    c: float = Field(10.0, ge=0)
    d: float = Field(10.0, ge=0)
    start: float = Field(10.0, ge=0)
    end: float = Field(10.0, ge=0)


NotchType = Literal["slit", "v", "t", "castle", "check", "u"]


class NotchSpec(_Strict):
    """Notches at arc lengths along a boundary curve, measured from the curve's own start
    (so that neighbouring pieces sharing the curve get matching notches), or at both
    ends of a ruling of this piece."""

    curve: StrictInt | Literal["c", "d"] | None = None
    at: list[float] = Field(default_factory=list)
    ruling: StrictInt | None = Field(None, ge=0)
    # the notch type of this seam (ASTM D6673 layers 4, 80-83) and its size; None: the
    # textile section's notch_type, notch_length and notch_width
    type: NotchType | None = None
    depth: float | None = Field(None, gt=0)
    width: float | None = Field(None, gt=0)

    @model_validator(mode="after")
    def _one(self):
        if len(self._given("curve", "ruling")) != 1:
            raise ValueError("a notch gives either curve + at (arc lengths) or ruling")
        if self.curve is not None and not self.at:
            raise ValueError("a notch on a curve needs at least one arc length in 'at'")
        return self


class MatchMarks(_Strict):
    """Match marks along every seam two pieces share: notches at ``spacing`` (config units)
    from the seam's sewable start, the same arc lengths on both pieces; their notch type
    and size default to the textile section's."""

    spacing: float = Field(gt=0)
    type: NotchType | None = None
    depth: float | None = Field(None, gt=0)
    width: float | None = Field(None, gt=0)


class Grain(_Strict):
    """Grain line: along a ruling, a 3D direction projected onto the piece, or an angle
    (degrees) against the piece's x axis."""

    ruling: StrictInt | None = Field(None, ge=0)
    direction: tuple[float, float, float] | None = None
    angle: float | None = None

    @model_validator(mode="after")
    def _one(self):
        given = self._given("ruling", "direction", "angle")
        if len(given) != 1:
            raise ValueError(f"grain needs exactly one of ruling, direction, angle; got {given or 'none'}")
        if self.direction is not None and not np.any(self.direction):
            raise ValueError("grain direction must not be the zero vector")
        return self


class Printout(_Strict):
    """Tiled 1:1 printout: paper, orientation, the overlap of neighbouring pages and the
    printer's unprintable border on every side (both mm)."""

    paper: Literal["A4", "A3", "Letter"] = "A4"
    orientation: Literal["portrait", "landscape"] = "portrait"
    overlap: float = Field(10.0, ge=0, le=50)
    border: float = Field(8.0, ge=3, le=30)
    # a roll plotter's paper width (mm; e.g. 914, 1067, 1524): NAME_roll.pdf lays the
    # pieces on it at 1:1 in rows, besides the tiled pages
    roll_width: float | None = Field(None, ge=300, le=5000)


class Aama(_Strict):
    """The AAMA / ASTM D6673 DXF: which flavour readers get (see README, "DXF flavours")."""

    flavour: Literal["aama-r12", "astm-2010", "r10-compat"] = "aama-r12"


class Plotter(_Strict):
    """HPGL file for pen plotters and cutters (NAME.plt): the pen of each kind of line."""

    cut: StrictInt = Field(1, ge=1, le=8)
    sew: StrictInt = Field(2, ge=1, le=8)
    notch: StrictInt = Field(3, ge=1, le=8)
    text: StrictInt = Field(4, ge=1, le=8)


class Textile(_Strict):
    seam_allowance: float | SeamAllowance = 10.0
    notches: list[NotchSpec] = Field(default_factory=list)
    match_marks: MatchMarks | None = None
    notch_length: float = Field(6.0, gt=0)
    notch_type: NotchType = "slit"
    notch_width: float = Field(3.0, gt=0, description="opening of a V notch at the cut line")
    grain: Grain = Grain(angle=0.0)
    size: str = Field("M", pattern=r"^[A-Za-z0-9.-]+$")
    quantity: StrictInt = Field(1, ge=1, le=1_000_000)
    fabric: str = Field("fabric", max_length=80)
    internal_rulings: bool = False
    sew_line_layer: Literal[8, 14] | None = 8
    seams: Literal["match", "report", "require_full"] = "match"
    printout: bool | Printout = True
    aama: Aama = Aama()
    plotter: bool | Plotter = False

    def plotter_options(self) -> Plotter | None:
        """The HPGL plotter file's options, or None when none is wanted."""
        if self.plotter is False:
            return None
        return Plotter() if self.plotter is True else self.plotter

    def printout_options(self) -> Printout | None:
        """The printout's options, or None when no printout is wanted."""
        if self.printout is False:
            return None
        return Printout() if self.printout is True else self.printout

    @field_validator("seam_allowance")
    @classmethod
    def _non_negative(cls, value):
        if isinstance(value, float) and value < 0:
            raise ValueError(f"seam allowance must be >= 0, got {value}")
        return value

    def allowances(self) -> SeamAllowance:
        a = self.seam_allowance
        return a if isinstance(a, SeamAllowance) else SeamAllowance(c=a, d=a, start=a, end=a)


class EdgeTexts(_Strict):
    """Per-edge texts (bevel / edge preparation): the c and d edges, the start and end edges
    (the first and last rulings; for a hull plate its aft and fore butts)."""

    c: str = Field("", max_length=40)
    d: str = Field("", max_length=40)
    start: str = Field("", max_length=40)
    end: str = Field("", max_length=40)


class EdgeLengths(_Strict):
    """Per-edge lengths in mm: the c and d edges (a hull plate's lower and upper seams),
    the start and end edges (the first and last rulings; a hull plate's aft and fore butts)."""

    c: float = Field(0.0, ge=0, le=1000, description="mm")
    d: float = Field(0.0, ge=0, le=1000, description="mm")
    start: float = Field(0.0, ge=0, le=1000, description="mm")
    end: float = Field(0.0, ge=0, le=1000, description="mm")


def _edge_lengths(value) -> EdgeLengths:
    return value if isinstance(value, EdgeLengths) else EdgeLengths(c=value, d=value, start=value, end=value)


class Shop(_Strict):
    """Shop-floor output of steel plates. Every length here is in mm, whatever ``units:``."""

    outline_tolerance: float = Field(0.05, gt=0, le=10, description="mm, cut outline vs exact development")
    bend_spacing: float = Field(400.0, gt=0, description="mm between bending lines")
    no_roll_radius: float | None = Field(
        None, gt=0, description="mm: no bending line where the radius across it is larger (taken elastically when "
        "the plate is pulled into place); default from thickness and yield stress, pipeline.shop.rolling")
    frame_clearance: float = Field(50.0, ge=0, description="mm: a frame nearer a butt is not marked")
    template_spacing: float = Field(3500.0, gt=0, le=3500, description="mm: most between templates across the rulings "
                                    "of a plate without frames")
    template_margin: float = Field(100.0, ge=50, le=1000, description="mm: template ends inside the plate's edges")
    pin_spacing: float = Field(800.0, ge=100, description="mm between the pins of a pin jig along a row (and between "
                               "rows where there are no frames)")
    shortest_pin: float = Field(250.0, gt=0, description="mm: the pin jig's shortest pin")
    text_height: tuple[float, float] = Field((5.0, 40.0), description="mm, smallest and largest text")
    mirror: bool = Field(False, description="also write the mirrored plate of the other side (P/S in the id)")
    bevel: EdgeTexts = EdgeTexts()
    stock: list[tuple[float, float]] = Field(
        default_factory=lambda: [(2500.0, 12000.0), (3000.0, 16000.0), (3500.0, 18000.0)],
        description="stock plates, width x length in mm")
    stock_margin: float = Field(10.0, ge=0, description="mm kept free around the part on a stock plate")
    excess: Annotated[float, Field(ge=0, le=1000)] | EdgeLengths = Field(
        0.0, description="mm added outside the net line per edge (one number: every edge), trimmed at erection")
    shrinkage: Annotated[float, Field(ge=0, le=1000)] | EdgeLengths = Field(
        0.0, description="mm added outside the net line per edge for weld shrinkage")
    # formed plates (pipeline.shop.heating): AVEVA Hull's workshop method Contraction / Expansion /
    # NoDeformation as the development's scale; "none" keeps the minimal-strain development as
    # it was (every formed plate's outline unchanged), "contraction" is AVEVA's default
    workshop_method: Literal["contraction", "expansion", "none"] = Field(
        "none", description="formed plates: developed larger (forming only shrinks), smaller (only stretches) or "
        "as the minimal-strain development")
    heat_input: float = Field(2000.0, gt=0, le=100000, description="J/mm: net heat a heating line puts into the "
                              "plate per mm of line (its shrinkage: alpha Q / (c rho h))")
    heat_shrinkage: float | None = Field(None, gt=0, le=10, description="mm a heating line shrinks the plate across "
                                         "it, measured by the yard (replaces the model)")
    heat_strain: float = Field(1e-3, gt=0, le=0.1, description="required shrink strain above which a formed plate "
                               "gets heating lines")
    heat_spacing: float = Field(100.0, ge=20, le=5000, description="mm: closest heating lines")
    heat_margin: float = Field(50.0, ge=0, le=1000, description="mm: heating lines end this far inside the edges")

    def allowance(self) -> dict:
        """{edge key: excess + shrinkage in mm} for c, d, start, end."""
        ex, sh = _edge_lengths(self.excess), _edge_lengths(self.shrinkage)
        return {k: getattr(ex, k) + getattr(sh, k) for k in ("c", "d", "start", "end")}

    def allowances(self) -> dict:
        """The excess and shrinkage per edge (mm), as the report states them."""
        return {"excess": _edge_lengths(self.excess).model_dump(), "shrinkage": _edge_lengths(self.shrinkage).model_dump()}

    @field_validator("text_height")
    @classmethod
    def _heights(cls, value):
        if not 0 < value[0] <= value[1]:
            raise ValueError(f"text_height needs 0 < min <= max, got {list(value)}")
        return value

    @field_validator("stock")
    @classmethod
    def _stock(cls, value):
        if any(w <= 0 or h <= 0 for w, h in value):
            raise ValueError(f"stock sizes must be positive, got {value}")
        return value


class Issue(_Strict):
    """The drawings' issue as their title blocks give it (ISO 7200's revision index and date
    of issue, and who drew and approved them); without it a title block says DEVFLAT drew it."""

    revision: str = Field(pattern=r"^[A-Za-z0-9.-]{1,8}$")
    date: datetime.date
    drawn_by: str | None = Field(None, min_length=1, max_length=40)
    approved_by: str | None = Field(None, min_length=1, max_length=40)

    def text(self) -> str:
        """One line for a title block: REV B   ISSUED 2026-12-08   DRAWN BY ...   APPROVED BY ..."""
        parts = [f"REV {self.revision}", f"ISSUED {self.date.isoformat()}"]
        parts += [f"{what} {who}" for what, who in (("DRAWN BY", self.drawn_by), ("APPROVED BY", self.approved_by))
                  if who]
        return "   ".join(parts).upper()


class Output(_Strict):
    dxf: bool = True
    obj: bool = True
    png: bool = True  # images: false for none at all
    # each part's PNG previews (flat pattern, solution diagram); default: on for the parts a
    # config lists, off for the plates of a strake or hull (two images a plate cost more than
    # the plate: opt in with true); the run's own images (sheet, hull, classes) follow png
    part_previews: bool | None = None
    # one-page PDF shop drawing per steel plate (NAME_drawing.pdf); default: as png (the
    # previews), so a single part gets it and a hull run without previews does not pay for it
    drawing: bool | None = None
    # a hull's shell expansion also as NAME_expansion_tiles.pdf: its A1 / A0 sheet on A3 or A4
    # pages at full size, overlapping, to print at 100 % and tape together (pipeline.io.tiled)
    expansion_tiles: Literal["A3", "A4"] | None = None
    # the drawings' revision and date of issue in their title blocks (shop drawings, expansion)
    issue: Issue | None = None
    layers: Layers = Layers()

    @model_validator(mode="after")
    def _previews_need_images(self):
        if self.part_previews and not self.png:
            raise ValueError("part_previews: true needs png: true (png: false writes no image)")
        if self.expansion_tiles and not self.png:
            raise ValueError("expansion_tiles needs png: true (png: false writes no expansion PDF to tile)")
        return self


class StockSize(_Strict):
    """A stock plate size (config units); ``name`` labels it in the cutting list."""

    width: float = Field(gt=0)
    length: float = Field(gt=0)
    name: str | None = Field(None, pattern=r"^[A-Za-z0-9_.-]+$", max_length=40)


class Remnants(_Strict):
    """Offcuts of steel stock plates kept as remnants (``devflat nest``): the rectangle beyond
    a plate's last part, across its width, when it is at least ``min_length`` long and
    ``min_width`` wide (config units). ``inventory``: a remnant CSV (a NAME_remnants.csv an
    earlier nest wrote; relative to the config's folder) whose plates are used first."""

    min_length: float = Field(500.0, gt=0)
    min_width: float = Field(500.0, gt=0)
    inventory: str | None = Field(None, min_length=1, max_length=4096)


class NestingSpec(_Strict):
    """Nesting of the run's parts (``devflat nest``): a fabric marker (textile profile, on a
    roll ``fabric_width`` wide) or stock plates (steel profile, sizes ``stock``). Lengths in
    config units; ``time`` is the engine's budget in seconds; ``orientations`` are degrees
    (textile: against the grain line laid along the roll) or ``free``."""

    time: int = Field(10, ge=1, le=86_400, description="seconds")
    seed: int = Field(0, ge=0, lt=2**63)
    workers: int = Field(1, ge=1, le=256)
    spacing: float = Field(0.0, ge=0, description="smallest gap between parts (kerf, knife)")
    edge_margin: float = Field(0.0, ge=0, description="smallest gap between a part and the roll/plate edge")
    orientations: list[float] | Literal["free"] | None = None
    quantities: dict[str, int] = Field(default_factory=dict)
    fabric_width: float | None = Field(None, gt=0)
    stock: StockSize | list[StockSize] | None = None
    pairs: bool = False
    developed_side: Literal["port", "starboard"] = "starboard"
    remnants: Remnants | None = None

    @field_validator("orientations")
    @classmethod
    def _orientations(cls, value):
        if isinstance(value, list) and not value:
            raise ValueError("give at least one orientation, or 'free'")
        return value

    @field_validator("quantities")
    @classmethod
    def _quantities(cls, value):
        bad = {k: v for k, v in value.items() if v < 0}
        if bad:
            raise ValueError(f"quantities must be >= 0, got {bad}")
        return value

    @field_validator("stock")
    @classmethod
    def _stock(cls, value):
        if isinstance(value, list) and not value:
            raise ValueError("give at least one stock size")
        return value

    def stock_sizes(self) -> list[StockSize]:
        s = self.stock
        return [] if s is None else (list(s) if isinstance(s, list) else [s])


class PartSpec(_Strict):
    name: str = Field(pattern=NAME_PATTERN, max_length=80)
    curves: CurvesSpec
    steel: Steel | None = None


class SeamSpec(_Strict):
    """A seam: an iso-curve of the strake's surface, or a given curve (any curve source)."""

    iso: IsoSpec | None = None
    curve: "CurveSource | None" = None

    @model_validator(mode="after")
    def _one(self):
        if len(self._given("iso", "curve")) != 1:
            raise ValueError("a seam is either iso or curve")
        return self


class FrameSpec(_Strict):
    """Frame planes x = start + k * spacing (config units), marked on the plates they cross."""

    spacing: float = Field(gt=0)
    start: float = 0.0


class WaterlineSpec(_Strict):
    """Waterlines on the shell expansion: planes z = base line + k * spacing (config units,
    z up), named by their height above the base line; ``design``: the design waterline's
    height above it, drawn and named DWL."""

    spacing: float = Field(gt=0)
    design: float | None = Field(None, gt=0)


class DeckSpec(_Strict):
    """A deck where it meets the shell (the deck at side), on the shell expansion: at one
    ``height`` above the base line all along the hull, through ``at_side`` points [x, height]
    (config units, x ascending: a sheer, the deck ending where they end), or along a
    ``curve`` of the model (any curve source: the deck-at-side line; its height read against x)."""

    name: str = Field(min_length=1, max_length=40)
    height: float | None = None
    at_side: list[tuple[float, float]] | None = Field(None, min_length=2, max_length=10000)
    curve: CurveSource | None = None

    @model_validator(mode="after")
    def _one(self):
        given = self._given("height", "at_side", "curve")
        if len(given) != 1:
            raise ValueError(f"a deck is given by exactly one of height, at_side, curve; {self.name!r} gives "
                             f"{', '.join(given) if given else 'none'}")
        if self.at_side is not None:
            xs = [x for x, _ in self.at_side]
            for k in range(1, len(xs)):
                if not xs[k] > xs[k - 1]:
                    raise ValueError(f"deck {self.name!r}: at_side x must ascend, got {xs[k - 1]:g} then "
                                     f"{xs[k]:g} (points {k - 1} and {k})")
        return self


class StockSpec(_Strict):
    """Plate sizes a plan must respect (config units): the developed plate's length along
    the hull and its width across it."""

    max_length: float = Field(14000.0, gt=0)
    max_width: float = Field(3500.0, gt=0)
    min_length: float = Field(2000.0, gt=0)
    min_width: float = Field(800.0, gt=0)

    @model_validator(mode="after")
    def _ordered(self):
        if self.min_length > self.max_length or self.min_width > self.max_width:
            raise ValueError(f"stock minimum sizes exceed the maximum ones: {self.min_length} x {self.min_width} "
                             f"against {self.max_length} x {self.max_width}")
        return self


class ObjectiveWeights(_Strict):
    """A weighted cost of a plan (any consistent currency): per metre of weld (seams and
    butts between plates), per plate, per m^2 of shell not delivered flat or as devflat's
    strip (rolled, formed or failed). A split is taken when it lowers the cost."""

    weld_m: float = Field(0.0, ge=0)
    plate: float = Field(0.0, ge=0)
    formed_m2: float = Field(0.0, ge=0)


class ObjectiveSpec(_Strict):
    """What the adaptive plan optimises: ``{maximise: flat_strip, weld_factor: F}`` (the flat +
    strip area, with the weld length at most F times the plan's uniform layout's), or
    ``{weights: {weld_m, plate, formed_m2}}`` (the least weighted cost)."""

    maximise: Literal["flat_strip"] | None = None
    weld_factor: float | None = Field(None, ge=1.0, le=10.0)
    weights: ObjectiveWeights | None = None

    @model_validator(mode="after")
    def _one(self):
        if (self.maximise is None) == (self.weights is None):
            raise ValueError("an objective gives either maximise (with weld_factor) or weights")
        if self.maximise is not None and self.weld_factor is None:
            raise ValueError("maximise: flat_strip needs weld_factor (the weld length allowed, times the uniform "
                             "layout's)")
        if self.weights is not None and self.weld_factor is not None:
            raise ValueError("weld_factor belongs to maximise, not to weights")
        return self


class PlanSpec(_Strict):
    """Seams and butts chosen by devflat. ``uniform``: strakes of equal girth at the widest
    section and equally spaced butt planes within the stock sizes; ``adaptive``: the same,
    then every plate that is neither flat nor developable within the fit tolerance is split
    (at mid length or mid girth) while the halves stay above the minimum sizes. The surfaces
    listed after ``strake.surface`` belong to the same hull (plates stay on one surface)."""

    method: Literal["uniform", "adaptive"] = "adaptive"
    stock: StockSpec = StockSpec()
    surfaces: list[HullSurfaceSource] = Field(default_factory=list, max_length=64)
    max_splits: int = Field(3, ge=0, le=6, description="depth of the adaptive splitting")
    seams: Literal["iso", "least_curvature"] = Field("iso", description="seams along iso-parameter lines, or "
                                                     "traced along the hull's direction of least curvature")
    objective: ObjectiveSpec | None = None
    block_joints: list[float] = Field(default_factory=list, max_length=256, description="x of the block joints "
                                      "(config units): butts of neighbouring strakes may align only there")
    butt_stagger: float | None = Field(None, gt=0, description="least distance between butts of neighbouring "
                                       "strakes off the block joints (config units; default 300 mm)")
    overlaps: Literal["cut", "fair"] = Field("cut", description="faces that lie on each other: each keeps its "
                                             "side of a transverse cut (cut), or one is also faired into the "
                                             "other over the overlap so that the two meet at the cut (fair)")
    junctions: Literal["keep", "fair"] = Field("keep", description="untrimmed faces that meet along a side of one "
                                               "of them with a gap: kept as the file gives them (keep), or that "
                                               "side faired onto the other face so that they meet (fair; "
                                               "pipeline.hull.fairing.fair_junctions)")
    replan_held: int = Field(0, ge=0, le=3, description="plans made again after the fit-up (adaptive, with "
                             "strake.hold_steps): each counts the plates a fit-up held that lost their flat or "
                             "strip class as plates that do not fit, so that the plan splits them, then fits up "
                             "again; the plan whose delivered flat + strip share is the highest is kept "
                             "(pipeline.hull.replan)")


class StrakeSpec(_Strict):
    """Plates of a strake: between consecutive seams (iso-curves of the hull surface) and
    consecutive butts (planes x = const given as numbers, or planes {point, normal}, config
    units; listed from aft to fore), each computed on its seams extended
    past the butts by ``margin`` times the plate length and trimmed by the butt planes.
    With ``plan``, devflat lays the seams and butts over the whole surface instead."""

    surface: HullSurfaceSource
    seams: list[SeamSpec] | None = Field(None, min_length=2)
    butts: list[float | PlaneSpec] | None = Field(None, min_length=2)
    plan: PlanSpec | None = None
    frames: FrameSpec | None = None
    base_line: float | None = Field(None, description="z of the moulded base line (config units), from which "
                                    "waterlines and deck heights are measured; default: the shell's lowest point")
    waterlines: WaterlineSpec | None = None
    decks: list[DeckSpec] = Field(default_factory=list, max_length=64)
    bow: Literal["high", "low"] | None = Field(None, description="the end of the hull's length (high or low x) the "
                                               "bow is at: the shell expansion marks FWD and names its fore and aft "
                                               "bodies; default: it marks +x")
    margin: float = Field(0.1, ge=0, le=1)
    fit_tolerance: float | None = Field(None, gt=0, description="largest distance from the hull surface (config "
                                        "units; default 5 mm whatever the units)")
    edge_tolerance: float | None = Field(None, gt=0, description="largest distance of a plate's edges from the hull "
                                         "(config units): a flat or strip plate whose edges leave it further is "
                                         "developed on the hull instead (a patch), so that two neighbours step by at "
                                         "most twice it (IACS Rec. 47: 0.15 t, at most 3 mm); default: no limit "
                                         "beyond the fit tolerance")
    fit_up: Literal["report", "repair", "follow"] = Field(
        "report", description="report: the run measures the steps between neighbours' edges; repair: a plate whose "
        "edge steps from a neighbour's by more than min(0.15 t, 3 mm) (IACS Rec. 47) is developed on the hull (a "
        "patch: its edges on the hull), the plate further off first, until no step exceeds it; follow: the flat "
        "plates' planes and the strips' places (a small rigid motion) are chosen together, each within the fit "
        "tolerance, so that their edges meet, then a formed plate is formed to meet its flat and strip neighbours' "
        "edges (a formed plate stays formed; a flat plate may become a strip: flats_as_strips)")
    flats_as_strips: bool = Field(True, description="with fit_up: follow, a flat plate whose edge misfits a flat or "
                                  "strip neighbour's is first developed again as a strip (rolled instead of cut flat; "
                                  "the flat + strip share unchanged), kept where one fits within the tolerance: a strip "
                                  "through its seams lies on the hull along them, where two planes over a twisting "
                                  "hull step by twice their distance from it; kept only where it steps less. Off, the "
                                  "rest of follow is unchanged (formed plates that step as developed still meet halfway)")
    hold_steps: bool = Field(False, description="with fit_up: follow, the pairs of flat or strip plates that still "
                             "step by more than min(0.15 t, 3 mm) after their planes and places are chosen together "
                             "(or part by twice that at a formed neighbour's corner, which would step from both) "
                             "have plates held as fit_up: repair holds them, the fewest square metres that hold one "
                             "plate of every pair (flat on the plane, or the strip between its seams, that keeps its "
                             "edges within half the limit of the hull, else developed on the hull: a formed plate, "
                             "which the forming then shapes to meet its neighbours); trades flat + strip share for "
                             "the steps. Off (default): such pairs are reported and left")
    pull_steps: bool = Field(False, description="with fit_up: follow, the flat and strip plates that still step from "
                             "a flat or strip neighbour by more than min(0.15 t, 3 mm) after their planes and places "
                             "are chosen together are pulled together at erection (strongbacks and wedges): each by a "
                             "smooth displacement of degree 3 in its in-plane coordinates, chosen together so that "
                             "their shared edges meet along the normal, each keeping its lengths and drawn toward the "
                             "hull, taken only as far as it stays within the fit tolerance of the hull, bends the "
                             "plate to at most a quarter of its yield stress and stretches it at most 1e-4 (cut and "
                             "rolled as developed, pulled elastically into place: class and share unchanged; "
                             "pipeline.hull.pull); before hold_steps, which then holds what still steps. Off "
                             "(default): not pulled")
    patch_spacing: float | None = Field(None, gt=0, description="mesh spacing of the hull patch of flat and formed "
                                        "plates (config units; default 200 mm)")
    scale: float = Field(1.0, gt=0, le=1e4, description="scale of the hull surfaces (a model-scale hull "
                         "to the ship: 24.824 for the DTMB 5415 model)")

    @model_validator(mode="after")
    def _layout(self):
        if self.plan is None and (self.seams is None or self.butts is None):
            raise ValueError("a strake gives seams and butts, or a plan")
        if self.plan is not None and (self.seams is not None or self.butts is not None):
            raise ValueError("a strake gives either seams and butts or a plan, not both")
        if self.pull_steps and self.fit_up != "follow":
            raise ValueError(f"pull_steps: true pulls the plates that fit_up: follow leaves stepping, got fit_up: "
                             f"{self.fit_up} (set fit_up: follow, or drop pull_steps)")
        if self.hold_steps and self.fit_up != "follow":
            raise ValueError(f"hold_steps: true holds the plates that fit_up: follow leaves stepping, got fit_up: "
                             f"{self.fit_up} (set fit_up: follow, or drop hold_steps)")
        if self.plan is not None and self.plan.replan_held and not self.hold_steps:
            raise ValueError(f"plan.replan_held: {self.plan.replan_held} splits the plates hold_steps holds, got "
                             "hold_steps: false (set hold_steps: true, or drop replan_held)")
        if self.plan is not None and self.plan.replan_held and self.plan.method != "adaptive":
            raise ValueError(f"plan.replan_held: {self.plan.replan_held} plans again adaptively, got plan.method: "
                             f"{self.plan.method} (set method: adaptive, or drop replan_held)")
        return self

    @field_validator("butts")
    @classmethod
    def _increasing(cls, value):
        if value is None:
            return value
        xs = [b if isinstance(b, (int, float)) else None for b in value]
        if all(x is not None for x in xs) and any(b <= a for a, b in zip(xs, xs[1:])):
            raise ValueError(f"butts must increase, got {value}")
        return value


class RunSpec(_Strict):
    units: Literal["mm", "cm", "m", "in"] = "mm"
    profile: Literal["steel", "textile"] = "steel"
    resolution: Resolution = Resolution()
    steel: Steel = Steel()
    textile: Textile = Textile()
    check: Check = Check()
    shop: Shop = Shop()
    output: Output = Output()
    nesting: NestingSpec | None = None
    # single-part form
    name: str | None = Field(None, pattern=NAME_PATTERN, max_length=80)
    curves: CurvesSpec | None = None
    # consecutive curves c0, c1, ..., ck: one part per neighbouring pair, named NAME_1..NAME_k
    sequence: list[CurveSource] | None = Field(None, min_length=2)
    # several parts
    parts: list[PartSpec] | None = None
    # the plates of a hull strake
    strake: StrakeSpec | None = None

    @field_validator("nesting")
    @classmethod
    def _nesting_profile(cls, value, info):
        """The roll width belongs to a marker, the stock sizes to steel plates."""
        profile = info.data.get("profile", "steel")
        if value is None:
            return value
        if profile == "textile" and value.fabric_width is None:
            raise ValueError("a textile marker needs fabric_width (the usable roll width)")
        if profile == "steel" and value.stock is None:
            raise ValueError("steel nesting needs stock: {width, length} or a list of sizes")
        if profile == "textile" and value.stock is not None:
            raise ValueError("stock is for the steel profile; a textile marker takes fabric_width")
        if profile == "steel" and value.fabric_width is not None:
            raise ValueError("fabric_width is for the textile profile; steel nesting takes stock")
        if profile == "textile" and value.remnants is not None:
            raise ValueError("remnants are offcuts of steel stock plates; a textile marker has none")
        return value

    @model_validator(mode="after")
    def _physical_defaults(self):
        """Tolerances left out get their mm defaults, converted to the config's units (the
        models are frozen: set once here, before anyone reads them)."""
        mm = UNIT_TO_MM[self.units]
        sources = list(self.sequence or [])
        if self.curves is not None:
            sources += [self.curves.c, self.curves.d]
        for part in self.parts or []:
            sources += [part.curves.c, part.curves.d]
        if self.strake is not None:
            sources += [seam.curve for seam in self.strake.seams or [] if seam.curve is not None]
            sources += [deck.curve for deck in self.strake.decks if deck.curve is not None]
            if self.strake.fit_tolerance is None:
                object.__setattr__(self.strake, "fit_tolerance", DEFAULT_FIT_TOLERANCE_MM / mm)
        for source in sources:
            default = DEFAULT_TOLERANCES_MM.get(type(source))
            if default is not None and source.tolerance is None:
                object.__setattr__(source, "tolerance", default / mm)
        return self

    @model_validator(mode="after")
    def _parts(self):
        forms = [self.curves is not None, self.sequence is not None, self.parts is not None,
                 self.strake is not None]
        if sum(forms) != 1:
            raise ValueError("give exactly one of curves (one part), sequence (consecutive curves), "
                             "parts (several) or strake (hull plates)")
        if (self.curves is not None or self.sequence is not None or self.strake is not None) and self.name is None:
            raise ValueError("curves, sequence and strake need a name")
        names = [p.name for p in self.parts] if self.parts else []
        if len(names) != len(set(names)):
            raise ValueError(f"part names must be unique, got {names}")
        return self


# no model_rebuild() here: with defer_build the schemas (forward references included) are
# built at the first validation, only for the models a run uses (~0.05 s less per command)


class Part:
    """One part ready to run: validated curves and the settings that apply to it.

    curve_ids : the identities of c and d for notches ('c'/'d', or sequence indices)
    """

    def __init__(self, name: str, c: NurbsCurve, d: NurbsCurve, steel: Steel, curve_ids=("c", "d"), fits=None,
                 hull=None):
        self.name, self.c, self.d, self.steel = name, c, d, steel
        self.curve_ids = curve_ids
        self.fits = fits or {}
        self.hull = hull  # a pipeline.plan.HullPlate for plates of a strake


class RunConfig:
    """A validated run: the spec, its parts with built curves, and the source file."""

    def __init__(self, spec: RunSpec, parts: list[Part], source: Path, lines: dict | None = None):
        self.spec, self.parts, self.source = spec, parts, source
        self.lines = lines or {}  # key path -> line of the YAML source, for later messages
        self.plan_record = None  # what an adaptive plan evaluated (pipeline.hull.planner.PlanRecord)
        self.plan_fairings = None  # what plan.overlaps / plan.junctions: fair did, one dict each (pipeline.hull.fairing)
        self.fitup_repair = None  # what strake.fit_up: repair held on the hull (pipeline.hull.repair)
        self.fitup_follow = None  # what strake.fit_up: follow formed to meet (pipeline.hull.follow)
        self.fitup_seconds = None  # (wall, CPU) s of that fit-up, its plates' evaluations aside
        self.replan = None  # the plans made again after the fit-up, plan.replan_held (pipeline.hull.replan)
        self.plan_cost = None  # what the plan costs a yard, as its summary says (pipeline.hull.cost.PlanCost.as_dict)
        self.decks = ()  # strake.decks as heights along the hull (pipeline.hull.levels.DeckProfile)

    @property
    def mm_per_unit(self) -> float:
        return UNIT_TO_MM[self.spec.units]

    @property
    def part_previews(self) -> bool:
        """Whether each part gets its PNG previews (``output.part_previews``; by default the
        listed parts do and the plates of a strake or hull do not)."""
        out = self.spec.output
        if not out.png:
            return False
        return out.part_previews if out.part_previews is not None else self.spec.strake is None


def _line_index(node, path=()) -> dict[tuple, int]:
    """Map every key path of a composed YAML tree to its 1-based line."""
    out = {path: node.start_mark.line + 1}
    if isinstance(node, yaml.MappingNode):
        for key, value in node.value:
            out.update(_line_index(value, path + (key.value,)))
            out[path + (key.value,)] = key.start_mark.line + 1
    elif isinstance(node, yaml.SequenceNode):
        for k, value in enumerate(node.value):
            out.update(_line_index(value, path + (k,)))
    return out


def _format_path(loc) -> str:
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


_UNION_TAG = re.compile(r"^(float|int|str|bool|none|literal\[.*\]|[A-Z]\w*)$")


def _input_path(data: Any, loc) -> tuple:
    """A pydantic error location without the union member tags ('float',
    'SeamAllowance', "literal['c','d']"), which are not keys of the input."""
    path = []
    for part in loc:
        if isinstance(part, str) and _UNION_TAG.match(part) and not (isinstance(data, dict) and part in data):
            continue
        path.append(part)
        if isinstance(data, dict):
            data = data.get(part)
        elif isinstance(data, list) and isinstance(part, int) and part < len(data):
            data = data[part]
        else:
            data = None
    return tuple(path)


def _line_of(lines: dict, loc) -> int | None:
    loc = tuple(p for p in loc if isinstance(p, (str, int)))
    while loc and loc not in lines:
        loc = loc[:-1]
    return lines.get(loc)


def load_config(path: str | Path) -> RunConfig:
    """Read and validate a run configuration; raise ConfigError on the first problem."""
    from .io.inputs import InputFileError, YamlLimitError, load_yaml, read_input_file

    path = Path(path)
    try:
        text = read_input_file(path, "configuration").decode("utf-8")
    except InputFileError as exc:
        raise ConfigError(str(exc)) from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: cannot read the configuration: not UTF-8 text ({exc.reason} at byte "
                          f"{exc.start})") from None
    try:
        data, root = load_yaml(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f":{mark.line + 1}" if mark is not None else ""
        raise ConfigError(f"{path}{where}: malformed YAML: {getattr(exc, 'problem', exc)}") from None
    except YamlLimitError as exc:
        raise ConfigError(f"{path}{':' + str(exc.line) if exc.line else ''}: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: the configuration must be a mapping of fields, got {type(data).__name__}")
    lines = _line_index(root) if root is not None else {}
    try:
        spec = RunSpec.model_validate(data)
    except ValidationError as exc:
        # the most specific error (a union reports one per member); drop the member tags
        err = max(exc.errors(), key=lambda e: len(_input_path(data, e["loc"])))
        loc = _input_path(data, err["loc"])
        line = _line_of(lines, loc)
        field = _format_path(loc) or "<top level>"
        value = err.get("input") if loc else None
        if err["type"] == "extra_forbidden":
            message = "unknown field"
        else:
            message = err["msg"]
        value_text = "" if not loc else f" (value: {value!r})"
        more = f" [+{len(exc.errors()) - 1} more]" if len(exc.errors()) > 1 else ""
        raise ConfigError(f"{path}{':' + str(line) if line else ''}: {field}: {message}{value_text}{more}") from None
    parts = _build_parts(spec, path, lines)
    _check_part_sizes(spec, parts, path, lines)
    _check_notch_curves(spec, parts, path, lines)
    return RunConfig(spec, parts, path, lines)


# A part is a plate or a piece: its extent (the diagonal of the box around both curves), in mm
# after ``units:``, lies between these; outside them its numbers are taken for another unit
# (a 2.9 km plate is 2.9 m of mm numbers under ``units: m``).
MIN_PART_MM = 1.0
MAX_PART_MM = 1.0e6  # 1 km


def _part_extent(part: Part, samples: int = 129) -> float:
    """Diagonal of the bounding box of c and d sampled at ``samples`` parameters each, model units."""
    points = np.vstack([curve(np.linspace(*curve.domain, samples)) for curve in (part.c, part.d)])
    return float(np.linalg.norm(np.ptp(points, axis=0)))


def _check_part_sizes(spec: RunSpec, parts: list[Part], path: Path, lines: dict) -> None:
    """Every part's extent, in mm, is within [MIN_PART_MM, MAX_PART_MM]: else its numbers are
    in another unit than ``units:`` says, and the message says which units would fit."""
    mm = UNIT_TO_MM[spec.units]
    for k, part in enumerate(parts):
        size = _part_extent(part)
        if MIN_PART_MM <= size * mm <= MAX_PART_MM:
            continue
        if spec.sequence is not None:
            loc, fields = ("sequence", k), f"sequence[{k}] and sequence[{k + 1}]"
        else:
            loc = (("parts", k) if spec.parts is not None else ()) + ("curves",)
            fields = f"{_format_path(loc)}.c and {_format_path(loc)}.d"
        line = _line_of(lines, loc)
        fits = [f"as {unit}: {_length_text(size * factor)}" for unit, factor in UNIT_TO_MM.items()
                if MIN_PART_MM <= size * factor <= MAX_PART_MM]
        hint = f" (read {'; '.join(fits)})" if fits else ""
        raise ConfigError(
            f"{path}{':' + str(line) if line else ''}: part {part.name}: {fields} span {size:.6g} under "
            f"units: {spec.units}, a part of {_length_text(size * mm)}; expected a part between {MIN_PART_MM:g} mm "
            f"and {MAX_PART_MM / 1e6:g} km (the diagonal of the box around both curves, in mm after units): "
            f"the numbers look like another unit{hint}")


def _length_text(mm: float) -> str:
    """A length in mm as text in mm, m or km, whichever reads best."""
    if mm >= 1e6:
        return f"{mm / 1e6:.4g} km"
    return f"{mm / 1e3:.4g} m" if mm >= 1e3 else f"{mm:.4g} mm"


def _check_notch_curves(spec: RunSpec, parts: list[Part], path: Path, lines: dict) -> None:
    """Every notch names a curve of the run and lies on it (0 <= at <= its length)."""
    curves = {}
    for part in parts:
        curves[part.curve_ids[0]] = part.c
        curves[part.curve_ids[1]] = part.d
    for k, notch in enumerate(spec.textile.notches):
        loc = ("textile", "notches", k)
        where = f"{path}{':' + str(_line_of(lines, loc)) if _line_of(lines, loc) else ''}"
        if notch.curve is None:
            continue
        if notch.curve not in curves:
            raise ConfigError(f"{where}: textile.notches[{k}].curve: no curve {notch.curve!r} in this run "
                              f"(curves: {sorted(map(str, curves))})")
        length = curves[notch.curve].length
        for j, s in enumerate(notch.at):
            if not 0.0 <= s <= length:
                raise ConfigError(f"{where}: textile.notches[{k}].at[{j}] = {s} lies outside the edge: "
                                  f"curve {notch.curve!r} is {length:.6g} long")


def _curve(cs, loc: tuple, path: Path, lines: dict, mm_per_unit: float, fits: dict) -> NurbsCurve:
    """Build a curve from any source; errors name the config file and line as well."""
    from .io.sources import SourceError, dxf_source, fit_points, iges_source

    name = _format_path(loc)
    line = _line_of(lines, loc)
    where = f"{path}{':' + str(line) if line else ''}"
    try:
        if isinstance(cs, CurveSpec):
            return nurbs_curve(np.array(cs.control_points, dtype=float), cs.degree, cs.weights, cs.knots, name=name)
        if isinstance(cs, IgesCurveSource):
            curve, report = iges_source(cs, path.parent, mm_per_unit, name)
            if report is not None:
                fits[name] = report
            return curve
        if isinstance(cs, DxfCurveSource):
            curve, report = dxf_source(cs, path.parent, name)
        else:
            curve, report = fit_points(np.array(cs.points, dtype=float), cs.tolerance, name)
        if report is not None:
            fits[name] = report
        return curve
    except InvalidCurveError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    except SourceError as exc:
        raise ConfigError(f"{where}: {name}: {exc}") from None


def _build_parts(spec: RunSpec, path: Path, lines: dict) -> list[Part]:
    mm = UNIT_TO_MM[spec.units]
    fits: dict = {}
    if spec.strake is not None:  # plates come from the planning layer (pipeline.plan.load_run)
        return []
    if spec.sequence is not None:
        curves = [_curve(cs, ("sequence", k), path, lines, mm, fits) for k, cs in enumerate(spec.sequence)]
        return [Part(f"{spec.name}_{k + 1}", curves[k], curves[k + 1], spec.steel, (k, k + 1), fits)
                for k in range(len(curves) - 1)]
    if spec.parts is None:
        entries = [((), spec.name, spec.curves, None)]
    else:
        entries = [(("parts", k), p.name, p.curves, p.steel) for k, p in enumerate(spec.parts)]
    parts = []
    for prefix, name, curves, steel in entries:
        c = _curve(curves.c, prefix + ("curves", "c"), path, lines, mm, fits)
        d = _curve(curves.d, prefix + ("curves", "d"), path, lines, mm, fits)
        parts.append(Part(name, c, d, steel or spec.steel, fits=fits))
    return parts
