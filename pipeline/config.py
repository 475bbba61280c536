"""Run configuration: YAML validated into typed models (pydantic v2).

Every error names the file, the line where YAML has one, the field path and the value.
The one module that reads YAML.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from flatten import InvalidCurveError, NurbsCurve, nurbs_curve
from flatten.errors import DevflatError

UNIT_TO_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}


class ConfigError(DevflatError, ValueError):
    """A configuration file is unreadable or invalid; the message names file, line, field, value."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class CurveSpec(_Strict):
    degree: int = Field(3, ge=1, le=9)
    control_points: list[tuple[float, float, float]] = Field(min_length=2)
    weights: list[float] | None = None
    knots: list[float] | None = None


class CurvesSpec(_Strict):
    c: CurveSpec
    d: CurveSpec


class Resolution(_Strict):
    chord_tolerance: float | None = Field(None, gt=0)
    rulings: int | None = Field(None, ge=2, le=200_000)
    samples_per_ruling: int = Field(5, ge=3, le=101)

    @model_validator(mode="after")
    def _one_of(self):
        if self.chord_tolerance is None and self.rulings is None:
            object.__setattr__(self, "chord_tolerance", 0.5)
        if self.chord_tolerance is not None and self.rulings is not None:
            raise ValueError("give either chord_tolerance or rulings, not both")
        return self


class Steel(_Strict):
    thickness: float = Field(10.0, gt=0, description="mm")
    material: str = "S355"
    density: float = Field(7850.0, gt=0, description="kg/m^3")
    marked_side: str = "moulded"


class Check(_Strict):
    max_residual: float = Field(1e-9, gt=0)
    max_curvature: float = Field(1e-6, gt=0, description="max |K| times the squared part size")
    min_coverage: float = Field(0.5, ge=0, le=1)


class Layers(_Strict):
    cut: str = "CUT_OUTER"
    bend: str = "MARK_BEND"
    text: str = "MARK_TEXT"

    @field_validator("cut", "bend", "text")
    @classmethod
    def _layer_name(cls, value: str) -> str:
        bad = set('<>/\\":;?*|=`') & set(value)
        if not value or bad:
            raise ValueError(f"invalid DXF layer name {value!r}")
        return value


class Output(_Strict):
    dxf: bool = True
    obj: bool = True
    png: bool = True
    layers: Layers = Layers()


class PartSpec(_Strict):
    name: str = Field(pattern=r"^[A-Za-z0-9_.-]+$", max_length=80)
    curves: CurvesSpec
    steel: Steel | None = None


class RunSpec(_Strict):
    units: Literal["mm", "cm", "m", "in"] = "mm"
    profile: Literal["steel"] = "steel"
    resolution: Resolution = Resolution()
    steel: Steel = Steel()
    check: Check = Check()
    output: Output = Output()
    # single-part form
    name: str | None = Field(None, pattern=r"^[A-Za-z0-9_.-]+$", max_length=80)
    curves: CurvesSpec | None = None
    # several parts
    parts: list[PartSpec] | None = None

    @model_validator(mode="after")
    def _parts(self):
        single = self.name is not None or self.curves is not None
        if single and self.parts is not None:
            raise ValueError("give either name + curves (one part) or parts (several), not both")
        if not single and not self.parts:
            raise ValueError("no part: give name + curves, or a non-empty parts list")
        if single and (self.name is None or self.curves is None):
            raise ValueError("a single part needs both name and curves")
        names = [p.name for p in self.parts] if self.parts else []
        if len(names) != len(set(names)):
            raise ValueError(f"part names must be unique, got {names}")
        return self


class Part:
    """One part ready to run: validated curves and the settings that apply to it."""

    def __init__(self, name: str, c: NurbsCurve, d: NurbsCurve, steel: Steel):
        self.name, self.c, self.d, self.steel = name, c, d, steel


class RunConfig:
    """A validated run: the spec, its parts with built curves, and the source file."""

    def __init__(self, spec: RunSpec, parts: list[Part], source: Path):
        self.spec, self.parts, self.source = spec, parts, source

    @property
    def mm_per_unit(self) -> float:
        return UNIT_TO_MM[self.spec.units]


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


def _lookup(data: Any, loc) -> Any:
    for part in loc:
        try:
            data = data[part]
        except (KeyError, IndexError, TypeError):
            return "<missing>"
    return data


def _line_of(lines: dict, loc) -> int | None:
    loc = tuple(p for p in loc if isinstance(p, (str, int)))
    while loc and loc not in lines:
        loc = loc[:-1]
    return lines.get(loc)


def load_config(path: str | Path) -> RunConfig:
    """Read and validate a run configuration; raise ConfigError on the first problem."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read the configuration: {exc}") from None
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f":{mark.line + 1}" if mark is not None else ""
        raise ConfigError(f"{path}{where}: malformed YAML: {getattr(exc, 'problem', exc)}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: the configuration must be a mapping of fields, got {type(data).__name__}")
    lines = _line_index(root) if root is not None else {}
    try:
        spec = RunSpec.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = err["loc"]
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
    return RunConfig(spec, _build_parts(spec, path, lines), path)


def _build_parts(spec: RunSpec, path: Path, lines: dict) -> list[Part]:
    if spec.parts is None:
        entries = [((), spec.name, spec.curves, None)]
    else:
        entries = [(("parts", k), p.name, p.curves, p.steel) for k, p in enumerate(spec.parts)]
    parts = []
    for prefix, name, curves, steel in entries:
        built = {}
        for key in ("c", "d"):
            cs: CurveSpec = getattr(curves, key)
            loc = prefix + ("curves", key)
            try:
                built[key] = nurbs_curve(np.array(cs.control_points, dtype=float), cs.degree,
                                         cs.weights, cs.knots, name=_format_path(loc))
            except InvalidCurveError as exc:
                line = _line_of(lines, loc)
                raise ConfigError(f"{path}{':' + str(line) if line else ''}: {exc}") from None
        parts.append(Part(name, built["c"], built["d"], steel or spec.steel))
    return parts
