"""A plate's region on the hull, the building blocks of every plan (hand-laid strake or
adaptive): seams as curves in the surface's parameters (:class:`Girth`), butt planes, the
hull surface as the file gives it, and the plate record (:class:`HullPlate`) with the curve
pair a strip is solved between (the seams, extended past the butts).

The strake planner (:mod:`.plan`) and the adaptive planner (:mod:`.planner`) both build on it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from flatten import NurbsCurve
from flatten.closest import SurfaceDistance
from flatten.plane import Plane, plane_crossings
from flatten.surface import NurbsSurface

from ..config import Part
from ..io.iges import IgesError, iges_surface, read_iges
from ..io.sources import SourceError, pick_entity, source_path

MAX_FRAMES_PER_PLATE = 1000


def butt_plane(spec) -> Plane:
    """A butt given as x (a float) or as {point, normal}; the normal is turned towards +x."""
    if isinstance(spec, (int, float)):
        return Plane((1.0, 0.0, 0.0), float(spec))
    n = np.asarray(spec.normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    if n[0] < 0:
        n = -n
    return Plane(tuple(float(v) for v in n), float(n @ np.asarray(spec.point, dtype=np.float64)))


@dataclass(frozen=True)
class Girth:
    """A seam in the surface's parameters: girth parameter g as a function of the
    longitudinal parameter s (piecewise linear through samples; constant for iso seams)."""

    s: tuple
    g: tuple

    @staticmethod
    def iso(value: float) -> "Girth":
        return Girth((0.0, 1.0), (float(value), float(value)))

    def __call__(self, s):
        s = np.asarray(s, dtype=float)
        if len(self.s) == 2 and self.g[0] == self.g[1]:
            return np.full(s.shape, self.g[0])
        return np.interp(s, self.s, self.g)

    def between(self, other: "Girth", fraction: float) -> "Girth":
        s = np.union1d(self.s, other.s) if len(self.s) > 2 or len(other.s) > 2 else np.array([0.0, 1.0])
        return Girth(tuple(s), tuple(self(s) + fraction * (other(s) - self(s))))

    def is_iso(self) -> bool:
        return len(self.s) == 2 and self.g[0] == self.g[1]


@dataclass
class HullPlate:
    """What a hull plate knows beyond its two seams: the hull, its region, its butts."""

    surface: NurbsSurface
    butts: tuple  # (Plane | None, Plane | None); None is the hull's end (stem or stern)
    frames: list[float] = field(default_factory=list)
    seam_names: tuple[str, str] = ("", "")
    butt_names: tuple[str, str] = ("", "")
    fit_tolerance: float = 5.0
    long_axis: int = 0  # 0: u runs along the hull, 1: v does
    girths: tuple | None = None  # (Girth, Girth) the seams in the surface's parameters
    distance: SurfaceDistance | None = None  # shared by every plate of the hull
    developable: bool = True  # a strip between the seams can be tried (both butts are planes)
    note: str = ""  # why no strip is tried, when it is not
    resolution: float = 200.0  # patch mesh spacing (model units)
    result: object = None  # filled by an adaptive plan that evaluated the plate already
    surface_note: str = ""  # e.g. a trim of the surface that is not honoured
    inside_trim: float = 1.0  # share of the region's area inside the surface's IGES trim
    trim: object = None  # the face's trim (pipeline.hull.trims.Trim) when the region reaches past it
    x_limits: tuple = (None, None)  # where a plan cut the face (overlapping another): the x range it keeps
    face_trim: object = None  # the surface's trim whatever the plate's region (a planned shell's coverage)
    edge_tolerance: float | None = None  # most a flat or strip plate's edges may leave the hull (else a patch)
    # a fit-up repair's verdict: developed on the hull as a patch (its edges on it) because its
    # edge stepped from a neighbour's ({reason, class_before, edge_deviation_before, ...})
    held: dict | None = None
    # the fit-up by forming's moves of a formed plate's region grid onto its flat and strip
    # neighbours' edges ({offsets (R, C, 3) model units, neighbours, largest_move_mm, verdict: its
    # strips' verdict from before or None}: pipeline.hull.follow)
    follow: dict | None = None
    # the plane the fit-up chose for a flat plate together with its neighbours' ({normal, point},
    # model units: pipeline.hull.joint); the plate is projected on it when it holds the region
    plane: dict | None = None
    # the fit-up's request that a flat plate be delivered as a strip instead (its plane stepped
    # from a flat or strip neighbour's beyond the limit: {step_mm, neighbours}): no plane is tried
    as_strip: dict | None = None
    # the adaptive plan's record of the plate: its depth of splits, the class it was planned
    # with and why it stopped splitting ({depth, class_for_plan, method, stopped}: planner._settle)
    plan: dict | None = None


def load_surface(spec, base: Path, mm_per_unit: float, scale: float = 1.0) -> NurbsSurface:
    """The entity-128 surface, in config units times ``scale``."""
    return load_surface_noted(spec, base, mm_per_unit, scale)[0]


def load_surface_noted(spec, base: Path, mm_per_unit: float, scale: float = 1.0) -> tuple[NurbsSurface, str]:
    """The surface and a note when the file trims it (entity 143 / 144 pointing at it): a
    hand-laid strake does not honour the trim, its plates cover the untrimmed surface."""
    surface, trim, note = load_surface_trimmed(spec, base, mm_per_unit, scale)
    if trim is not None:
        note = (f"{note.split(';')[0]}; the trim is ignored by a hand-laid strake: plates cover the untrimmed "
                f"surface")
    return surface, note


def load_surface_trimmed(spec, base: Path, mm_per_unit: float, scale: float = 1.0):
    """(surface, trim or None, note). A trim that is the whole parameter rectangle is no
    trim; a trim whose loops cannot be read is ignored, and the note says so."""
    from .trims import read_trim

    if getattr(spec, "model", None) is not None:
        return _model_face(spec, base, mm_per_unit, scale)
    path = source_path(base, spec.iges)
    try:
        iges = read_iges(path)
        entity = pick_entity(iges.of_type(128), spec, str(path), "entity-128 surface")
        surface = iges_surface(iges, entity, scale * iges.unit_mm / mm_per_unit, f"hull D{entity.directory}")
    except IgesError as exc:
        raise SourceError(str(exc)) from None
    try:
        trim = read_trim(iges, entity.directory)
    except (IgesError, ValueError, IndexError) as exc:
        return surface, None, (f"{path.name}: surface D{entity.directory} is trimmed but its trim cannot be read "
                               f"({exc}); the trim is ignored: plates cover the untrimmed surface")
    if trim is None or trim.covers_rectangle(surface.domain_u, surface.domain_v):
        return surface, None, ""
    return surface, trim, (f"{path.name}: surface D{entity.directory} is trimmed (entity {trim.entity}); the trim is "
                           f"honoured by area: plates wholly outside it are not planned, a plate partly outside keeps "
                           f"its untrimmed region and reports the share inside (inside_trim)")


def _model_face(spec, base: Path, mm_per_unit: float, scale: float):
    """(surface, trim or None, note) of a hull model's face (IGES, STEP, .3dm), read through
    OpenCascade or rhino3dm: the model is in mm, the surface in config units times ``scale``."""
    path, model = _read_model(spec, base)
    if getattr(spec, "faces", None):
        surface, note, _ = _model_shell(model, path, spec.faces, mm_per_unit, scale)
        return surface, None, note
    return _face_of(model, path, spec.face, mm_per_unit, scale)


def _read_model(spec, base: Path):
    """(path, HullModel) of a model source; an unreadable file is a SourceError."""
    from ..io.hullmodel import HullModelError, read_hull_model

    path = source_path(base, spec.model)
    try:
        return path, read_hull_model(path)
    except HullModelError as exc:
        raise SourceError(str(exc)) from None


def _face_of(model, path: Path, index: int, mm_per_unit: float, scale: float):
    """(surface, trim or None, note) of face ``index`` of a read model, in config units times ``scale``."""
    from flatten.surface import nurbs_surface

    from .trims import Trim

    if not index < len(model.faces):
        raise SourceError(f"{path}: face {index} asked for; the model has {len(model.faces)} faces (0 to "
                          f"{len(model.faces) - 1})")
    face = model.faces[index]
    s = face.surface
    factor = scale / mm_per_unit
    surface = nurbs_surface(s.degree_u, s.degree_v, s.poles * factor, s.knots_u, s.knots_v, s.weights,
                            name=f"hull {path.name} face {index}")
    if not face.trimmed:
        return surface, None, (f"{path.name}: face {index}: {face.trim_note}" if face.trim_note else "")
    trim = Trim(index, face.outer, face.inner, 0)
    return surface, trim, (f"{path.name}: face {index} is trimmed; the trim is honoured by area: plates wholly "
                           f"outside it are not planned, a plate partly outside keeps its untrimmed region and reports "
                           f"the share inside (inside_trim)")


SHELL_STATIONS = 250  # stations of a lofted shell over its length
SHELL_TOLERANCE_MM = 0.5  # at ship scale: the loft's target distance to the faces' sections
SHELL_REMAINDER = 1e-3  # of the loft's length: a face reaching less beyond the loft is not planned on its own
SHELL_JUNCTION_MM = 1.0  # in the model's mm: a face's edge this near another face meets it
# at ship scale: the loft ends where its end stations bridge a wider gap between faces (the
# chord across a gap lies up to half of it off each face: 3 mm, the step a butt may have)
SHELL_GAP_MM = 6.0
BEYOND_STATIONS = 24  # stations of the faces beyond a loft's end, lofted together over that range
BEYOND_REACH = 0.05  # of that range: faces that chain over less of it are planned alone


def _model_shell(model, path: Path, indices, mm_per_unit: float, scale: float):
    """(surface, note, limits) of several faces lofted into one shell surface (pipeline.hull.shell),
    in config units times ``scale``; ``limits``: each face's (lo, hi) x range kept where faces
    lying on each other were cut (None: no cut), config units. Faces that meet at a knuckle
    are refused: a knuckle is a seam or a butt, not a plate to cross."""
    from flatten.closest import SurfaceDistance
    from flatten.surface import nurbs_surface

    from ..io.hullmodel import HullModel
    from .coverage import x_range_region
    from .sewing import junctions_of, overlap_cuts
    from .shell import ShellError, shell_surface
    from .trims import Trim

    missing = [k for k in indices if not 0 <= k < len(model.faces)]
    if missing:
        raise SourceError(f"{path}: faces {missing} asked for; the model has {len(model.faces)} faces (0 to "
                          f"{len(model.faces) - 1})")
    faces = [model.faces[k] for k in indices]
    sub = HullModel(path, model.format, tuple(faces))
    trims = [Trim(f.index, f.outer, f.inner, 0) if f.trimmed else None for f in faces]
    regions = [None if t is None else t.face_region(f.surface) for f, t in zip(faces, trims)]
    # faces lying on each other (DTMB 5415's bow and main hull) are cut where their sections
    # come closest, each keeping its side, before they are lofted: every station then crosses one
    limits, overlaps = overlap_cuts([f.surface for f in faces], trims, SHELL_JUNCTION_MM)
    for k, (face, lim) in enumerate(zip(faces, limits)):
        if any(x is not None for x in lim):
            s = face.surface
            kept = x_range_region(s, long_axis_of(s), lim)
            regions[k] = kept if regions[k] is None else regions[k].intersection(kept)
    overlapping = {tuple(o.faces) for o in overlaps}  # their meeting is the overlap, cut above
    junctions = [j for j in junctions_of(sub, [SurfaceDistance(f.surface, grid=60) for f in faces], SHELL_JUNCTION_MM)
                 if tuple(j["faces"]) not in overlapping]
    knuckles = [j for j in junctions if j["kind"].startswith("knuckle")]
    if knuckles:
        j = knuckles[0]
        a, b = (indices[k] for k in j["faces"])
        raise SourceError(f"{path}: faces {a} and {b} meet at a knuckle (normals {j['p95_angle_deg']:.2f} deg apart, "
                          f"p95, along {j['length_mm']:.0f} mm at x {j['x_mm'][0]:.1f}..{j['x_mm'][1]:.1f}): a seam "
                          f"or a butt must lie on it; give them as separate surfaces, not as one shell")
    cuts = [f"faces {indices[o.faces[0]]} and {indices[o.faces[1]]} lie on each other over x "
            f"{o.x_range_mm[0] * scale:.0f}..{o.x_range_mm[1] * scale:.0f} mm: cut at x = {o.cut_x_mm * scale:.0f} mm "
            f"before lofting (step {o.step_at_cut_mm * scale:.3g} mm there, which the loft smooths)" for o in overlaps]
    length = max(float(np.ptp(f.surface.grid(np.linspace(*f.surface.domain_u, 9),
                                             np.linspace(*f.surface.domain_v, 9))[..., 0])) for f in faces)
    try:
        shell = shell_surface([f.surface for f in faces], regions, indices, length / SHELL_STATIONS,
                              SHELL_TOLERANCE_MM / scale, f"hull {path.name} shell", SHELL_GAP_MM / scale)
    except ShellError as exc:
        raise SourceError(f"{path}: {exc}") from None
    s = shell.surface
    factor = scale / mm_per_unit
    surface = nurbs_surface(s.degree_u, s.degree_v, s.poles * factor, s.knots_u * factor, s.knots_v, s.weights,
                            name=s.name)
    smooth = [f"faces {indices[j['faces'][0]]} and {indices[j['faces'][1]]} meet smoothly "
              f"({j['p95_angle_deg']:.2f} deg)" for j in junctions]
    note = shell.note(path.name, scale) + (f" (model scale 1:{scale:g})" if scale != 1 else "")
    kept = [tuple(None if x is None else x * factor for x in lim) for lim in limits]
    return surface, note + "".join(f"; {line}" for line in smooth + cuts), kept


@dataclass(frozen=True)
class PlanSurface:
    """A surface a plan lays plates on: the surface (config units), its trim (or None), the
    note the plates carry, and the x range a plan keeps of it (None: its own end)."""

    surface: NurbsSurface
    trim: object
    note: str
    x_limits: tuple = (None, None)
    fixed: bool = False  # x_limits set by a shell loft (not to be cut again where faces overlap)


def load_plan_surfaces(sources, base: Path, mm_per_unit: float, scale: float = 1.0) -> list[PlanSurface]:
    """Every surface of a plan, in order: each source's surface, and after a shell of several
    faces (``faces``) those faces' parts beyond the loft's x range (a bulb, a stern where the
    faces do not chain into one girth curve), each kept beyond the loft's end plane so that the
    shell is covered once. Several faces beyond the same end that chain there are lofted into
    one surface of their own (:func:`_beyond_shell`), each face planned alone otherwise."""
    out = []
    for spec in sources:
        if not getattr(spec, "faces", None):
            out.append(PlanSurface(*load_surface_trimmed(spec, base, mm_per_unit, scale)))
            continue
        path, model = _read_model(spec, base)
        surface, note, cut = _model_shell(model, path, spec.faces, mm_per_unit, scale)
        out.append(PlanSurface(surface, None, note))
        loft = len(out) - 1
        x0, x1 = surface.domain_u  # the loft's u is x
        faces = [_face_of(model, path, k, mm_per_unit, scale) for k in spec.faces]
        factor = scale / mm_per_unit
        beyond = []  # (is_aft, keep, PlanSurface of the face alone, (index, model face, trim, x extent))
        # faces the loft cut where they lie on each other keep their side of the cut here too
        for k, (face, face_trim, face_note), (cut_lo, cut_hi) in zip(spec.faces, faces, cut):
            extent = _x_extent(model.faces[k].surface, face_trim)  # model units, as the faces are lofted
            lo, hi = (x * factor for x in extent)
            lo, hi = max(lo, cut_lo if cut_lo is not None else lo), min(hi, cut_hi if cut_hi is not None else hi)
            gap = SHELL_REMAINDER * (x1 - x0)  # the loft's first station is this near the faces' end
            aft = (cut_lo, x0 if cut_hi is None else min(x0, cut_hi))
            fore = (x1 if cut_lo is None else max(x1, cut_lo), cut_hi)
            for keep, reaches, is_aft in ((aft, lo < x0 - gap, True), (fore, hi > x1 + gap, False)):
                if not reaches or (None not in keep and keep[0] >= keep[1]):
                    continue
                where = f"x < {x0:.0f}" if is_aft else f"x > {x1:.0f}"
                part, part_note = _trimmed_part(face, face_trim, keep, f"{face.name} ({where})")
                beyond.append((is_aft, keep, PlanSurface(part, face_trim, f"face {k} beyond the shell's loft "
                                                         f"({where}): planned on the face" + part_note +
                                                         (f"; {face_note}" if face_note else ""), keep, True),
                               (k, model.faces[k].surface, face_trim, extent)))
                # the loft ends at the same plane: a butt of both sides, not the hull's end
                ends = list(out[loft].x_limits)
                ends[0 if is_aft else 1] = x0 if is_aft else x1
                out[loft] = replace(out[loft], x_limits=tuple(ends))
        joined = {}
        for is_aft in (True, False):
            group = [b for b in beyond if b[0] == is_aft]
            if len(group) > 1 and len({b[1] for b in group}) == 1:
                joined[is_aft] = _beyond_shell(path, [b[3] for b in group], group[0][1], mm_per_unit, scale,
                                               f"x < {x0:.0f}" if is_aft else f"x > {x1:.0f}")
        placed = set()  # ends whose lofted faces are listed (in the place of their first face)
        for is_aft, keep, alone, _ in beyond:
            lofted = joined.get(is_aft)
            if lofted is None:
                out.append(alone)
            elif is_aft not in placed:
                placed.add(is_aft)
                out.append(PlanSurface(lofted[0], None, lofted[1], keep, True))
    return out


def _beyond_shell(path: Path, members: list, keep: tuple, mm_per_unit: float, scale: float, where: str):
    """(surface, note) of faces beyond a loft's end (``members``: index, surface in model
    units, trim, x extent of each) lofted into one surface over ``keep`` (x range in config
    units times ``scale``, one end None), or None when their
    sections do not chain there (the faces part: each is planned alone). The girth is arc
    length, without the main loft's knot where faces meet: beyond KVLCC2's stern end plane the
    flat of bottom shrinks from 33 mm of girth to nothing; planned alone it was a plate 33 mm x
    1190 mm that stepped 5.5 mm (fit_up: report) to 5.98 mm (follow, pulls and holds) from face
    10's plate beside it."""
    from flatten.surface import nurbs_surface

    from .coverage import x_range_region
    from .shell import ShellError, shell_surface

    factor = scale / mm_per_unit
    indices, faces, trims, extents = zip(*members)
    lo = min(e[0] for e in extents) if keep[0] is None else keep[0] / factor
    hi = max(e[1] for e in extents) if keep[1] is None else keep[1] / factor
    spacing = (hi - lo) / BEYOND_STATIONS
    # the faces' regions reach a spacing past the loft's end plane: cut at it, the station
    # there (on a sampled cut) lost pieces, and the surface ended 0.04 mm short of KVLCC2's
    reach = (lo, hi + spacing) if keep[0] is None else (lo - spacing, hi)
    regions = []
    for s, trim in zip(faces, trims):
        kept = x_range_region(s, long_axis_of(s), reach)
        regions.append(kept if trim is None else trim.face_region(s).intersection(kept))
    try:
        shell = shell_surface(list(faces), regions, indices, spacing,
                              SHELL_TOLERANCE_MM / scale, f"hull {path.name} beyond the shell's loft ({where})",
                              SHELL_GAP_MM / scale, x_range=(lo, hi), junction_knots=False)
    except ShellError:
        return None
    x = shell.stations
    if x[-1] - x[0] < (1.0 - BEYOND_REACH) * (hi - lo):
        return None  # the faces chain over part of the range only: each is planned alone
    s = shell.surface
    surface = nurbs_surface(s.degree_u, s.degree_v, s.poles * factor, s.knots_u * factor, s.knots_v, s.weights,
                            name=s.name)
    faces_text = "+".join(str(k) for k in indices)
    note = (f"faces {faces_text} beyond the shell's loft ({where}): lofted as one surface through {len(x)} stations, "
            f"x {x[0] * scale:.1f}..{x[-1] * scale:.1f} mm, within {shell.deviation_max * scale:.3f} mm of the faces' "
            f"sections (p95 {shell.deviation_p95 * scale:.3f} mm); its girth is arc length, with no knot where the "
            f"faces meet (a face's girth there shrinks to nothing)")
    return surface, note


TRIMMED_PART_PAD = 0.01  # of a face's parameter range along the hull: its part beyond a loft reaches past the end plane


def _trimmed_part(face: NurbsSurface, trim, keep: tuple, name: str) -> tuple[NurbsSurface, str]:
    """(surface, note) a trimmed face is planned on beyond a loft's end plane: the face cut
    down (exactly) to the parameter box of its trimmed region within ``keep`` (x range, None
    open), so that its plates cover that region and not the untrimmed surface around it.
    KVLCC2's flat of bottom (face 11) keeps 33 mm of its 26.6 m girth aft of x = 15090 mm:
    planned on the whole face, its plate there was a 3.8 m strip of the bottom's plane cut to
    33 mm only in its flat outline, its 3D edge running flat under the bilge (178 mm below the
    lofted plates' edge at the end plane). Along the hull the box reaches TRIMMED_PART_PAD of
    the range past the region (the end plane's butt cuts it exactly). An untrimmed face, or a
    region filling the rectangle, is the face itself."""
    from .coverage import x_range_region
    from .trims import sub_surface

    if trim is None:
        return face, ""
    (u0, u1), (v0, v1) = face.domain_u, face.domain_v
    axis = long_axis_of(face)
    region = trim.face_region(face).intersection(x_range_region(face, axis, keep))
    if region.is_empty:
        return face, ""
    bu0, bv0, bu1, bv1 = region.bounds
    pad_u, pad_v = (TRIMMED_PART_PAD, 1e-6) if axis == 0 else (1e-6, TRIMMED_PART_PAD)
    bu0, bu1 = max(u0, bu0 - pad_u * (u1 - u0)), min(u1, bu1 + pad_u * (u1 - u0))
    bv0, bv1 = max(v0, bv0 - pad_v * (v1 - v0)), min(v1, bv1 + pad_v * (v1 - v0))
    share = (bu1 - bu0) * (bv1 - bv0) / ((u1 - u0) * (v1 - v0))
    if share > 1.0 - 1e-9:
        return face, ""
    return sub_surface(face, (bu0, bu1), (bv0, bv1), name), (
        f" cut down to its trimmed region's parameter box (u {bu0:.6g}..{bu1:.6g}, v {bv0:.6g}..{bv1:.6g}, "
        f"{100 * share:.3g} % of its rectangle)")


def _x_extent(surface: NurbsSurface, trim, n: int = 65, boundary: int = 2048) -> tuple[float, float]:
    """The x range of a surface inside its trim: an n x n grid of it, and for a trimmed face
    its trim's boundary at ``boundary`` points along each loop's length. The grid alone placed
    a trim's end up to a 64th of the face's length off (a flat of bottom trimmed from x = 40 mm
    of a 20 m face read from x = 312 mm, and its part aft of a loft starting at 80 mm was
    neither lofted nor planned)."""
    u, v = np.linspace(*surface.domain_u, n), np.linspace(*surface.domain_v, n)
    x = surface.grid(u, v)[..., 0]
    if trim is None:
        return float(x.min()), float(x.max())
    import shapely

    uu, vv = np.meshgrid(u, v, indexing="ij")
    inside = trim.inside(uu, vv)
    x = x[inside] if inside.any() else x
    region = trim.face_region(surface)
    if region.is_empty:
        return float(x.min()), float(x.max())
    loops = shapely.get_parts(region.boundary)[:, None]  # every loop of the trimmed region
    uv = shapely.get_coordinates(shapely.line_interpolate_point(loops, np.linspace(0.0, 1.0, boundary),
                                                               normalized=True))
    edge = surface(uv[:, 0], uv[:, 1])[:, 0]
    return float(min(x.min(), edge.min())), float(max(x.max(), edge.max()))


def long_axis_of(surface: NurbsSurface) -> int:
    """0 when the u-curves (v fixed) span more of the hull's length (x) than the v-curves."""
    u = np.linspace(*surface.domain_u, 33)
    v = np.linspace(*surface.domain_v, 33)
    pts = surface.grid(u, v)
    along_u = np.ptp(pts[:, :, 0], axis=0).mean()
    along_v = np.ptp(pts[:, :, 0], axis=1).mean()
    return 0 if along_u >= along_v else 1


def extended_segment(seam: NurbsCurve, planes: tuple[Plane, Plane], margin: float, name: str,
                     crossings: dict | None = None) -> NurbsCurve:
    """The seam between the butts, extended past each by ``margin`` times the plate length
    (or to the seam's end where it ends first). ``crossings``: a dict kept by the caller
    for the seams' crossings with the butt planes (a strake's plates share each seam with
    a neighbouring strake and each butt with a neighbouring plate: four plates ask for
    every crossing)."""
    lo, hi = seam.domain
    cross_lo, cross_hi = (_known_crossings(seam, plane, crossings) for plane in planes)
    if len(cross_lo) != 1 or len(cross_hi) != 1:
        raise SourceError(f"seam {name} crosses the butt planes {planes[0].describe()} and {planes[1].describe()} "
                          f"{len(cross_lo)} and {len(cross_hi)} times (once each expected)")
    t1, t2 = cross_lo[0], cross_hi[0]
    p1, p2 = seam(np.array([t1, t2]))
    extra = margin * float(np.linalg.norm(p2 - p1))
    ext1 = plane_crossings(seam, planes[0].shifted(-extra))
    ext2 = plane_crossings(seam, planes[1].shifted(extra))
    e1 = ext1[0] if len(ext1) == 1 else usable_end(seam, lo if t1 < t2 else hi, t1)
    e2 = ext2[0] if len(ext2) == 1 else usable_end(seam, hi if t2 > t1 else lo, t2)
    a, b = sorted((e1, e2))
    seg = seam.segment(a, b)
    return NurbsCurve(seg.degree, seg.control_points, seg.weights, seg.knots, name)


def _known_crossings(curve: NurbsCurve, plane: Plane, crossings: dict | None) -> np.ndarray:
    """:func:`plane_crossings`, looked up in ``crossings`` first (keyed by the curve, which
    hashes by identity and is kept alive by the key, and the plane) and stored there."""
    if crossings is None:
        return plane_crossings(curve, plane)
    key = (curve, plane.normal, plane.offset)
    if key not in crossings:
        crossings[key] = plane_crossings(curve, plane)
    return crossings[key]


def usable_end(seam: NurbsCurve, end: float, inner: float) -> float:
    """The seam's end, or a little short of it when the seam stands still there (a doubled
    end pole, a collapsed keel end): a strip cannot start on a zero-speed end, and the plate
    itself never needs it (it lies between ``inner`` and the other butt)."""
    speed = np.linalg.norm(seam.derivatives(np.array([end, 0.5 * (end + inner)]), 1)[1], axis=1)
    if speed[0] > 1e-6 * speed[1]:
        return end
    return end + 0.02 * (inner - end)


def frames_between(frames, lo: float, hi: float, name: str = "") -> list[float]:
    if frames is None:
        return []
    if not hi - lo <= MAX_FRAMES_PER_PLATE * frames.spacing:
        raise SourceError(f"frames.spacing = {frames.spacing:g} puts more than {MAX_FRAMES_PER_PLATE} frames on "
                          f"plate {name}")
    first = int(np.ceil((lo - frames.start) / frames.spacing))
    last = int(np.floor((hi - frames.start) / frames.spacing))
    return [frames.start + k * frames.spacing for k in range(first, last + 1)
            if lo < frames.start + k * frames.spacing < hi]


def seam_curve(surface: NurbsSurface, long_axis: int, girth: Girth, name: str) -> NurbsCurve:
    """The seam as a NURBS curve on the surface: exact for an iso seam, else a cubic fit."""
    if girth.is_iso():
        return surface.iso_v(girth.g[0], name) if long_axis == 0 else surface.iso_u(girth.g[0], name)
    from ..io.sources import fit_points

    dom = surface.domain_u if long_axis == 0 else surface.domain_v
    s = np.linspace(*dom, 200)
    g = girth(s)
    u, v = (s, g) if long_axis == 0 else (g, s)
    curve, _ = fit_points(surface(u, v), 0.05, name)
    return curve


def plate_x_range(planes, surface=None, long_axis: int = 0, girths=None) -> tuple[float, float]:
    """The x range a plate spans: between its butt planes; an end plate (a None plane: the
    hull's end before or after its butt) from its butt to the farthest x its region reaches
    on that side (the stem or the stern; sampled on 9 girth lines across the region, 801
    points each, and on the surface's end edges between the seams, 401 points each: a transom
    can reach farther aft between the seams than on them), so its frames are marked like any
    plate's."""
    if all(p is not None for p in planes):
        xs = [p.offset for p in planes]
        return min(xs), max(xs)
    s = np.linspace(*(surface.domain_u if long_axis == 0 else surface.domain_v), 801)
    lines = [girths[0].between(girths[1], f)(s) for f in np.linspace(0.0, 1.0, 9)]
    x = np.concatenate([surface(*((s, g) if long_axis == 0 else (g, s)))[:, 0] for g in lines])
    # and across the surface's two ends between the seams, densely: a sloped transom or stem
    # reaches its farthest x between two of the girth lines (12 mm past a frame on the 160 m hull)
    for end in s[[0, -1]]:
        g = np.linspace(girths[0](end), girths[1](end), 401)
        e = np.full_like(g, end)
        x = np.concatenate([x, surface(*((e, g) if long_axis == 0 else (g, e)))[:, 0]])
    if all(p is None for p in planes):
        return float(x.min()), float(x.max())
    butt = next(p for p in planes if p is not None)
    return (float(x.min()), butt.offset) if planes[0] is None else (butt.offset, float(x.max()))


def plate_part(name, surface, axis, girths, curves, planes, spec_steel, strake, distance, seam_names, butt_names,
           resolution, surface_note="", crossings: dict | None = None) -> Part:
    """One plate: its curve pair (the seams, extended past plane butts) and its HullPlate;
    ``crossings``: see :func:`extended_segment`."""
    developable, note = all(p is not None for p in planes), ""
    c = d = None
    if developable:
        try:
            c = extended_segment(curves[0], planes, strake.margin, f"{name}.{seam_names[0]}", crossings)
            d = extended_segment(curves[1], planes, strake.margin, f"{name}.{seam_names[1]}", crossings)
        except SourceError as exc:
            developable, note = False, str(exc)
    else:
        note = "end plate: bounded by the hull's end, not by two butt planes"
    if c is None:  # the seams themselves, under this plate's names (its neighbours may share the curves)
        c, d = (NurbsCurve(s.degree, s.control_points, s.weights, s.knots, f"{name}.{n}")
                for s, n in zip(curves, seam_names))
    frames = frames_between(strake.frames, *plate_x_range(planes, surface, axis, girths), name) if strake.frames else []
    hull = HullPlate(surface, tuple(planes), frames, seam_names, butt_names, strake.fit_tolerance, axis,
                     tuple(girths), distance, developable, note, resolution, None, surface_note)
    hull.edge_tolerance = getattr(strake, "edge_tolerance", None)
    return Part(name, c, d, spec_steel, ("c", "d"), {}, hull)
