"""IGES reader for rational B-spline curves (entity 126) and surfaces (entity 128).

A reader of our own, limited to what devflat needs: pyiges 0.3.4 stops on the NAPA exports
of the real data (a blank directory status field) and misreads the parameter range of
entity 128. The global section's unit is honoured (parameter 14, flag; 15, name).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flatten import InvalidCurveError, NurbsCurve, nurbs_curve
from flatten.errors import DevflatError
from flatten.surface import NurbsSurface, nurbs_surface

# IGES unit flags (global parameter 14) in millimetres
UNIT_FLAG_MM = {1: 25.4, 2: 1.0, 3: None, 4: 304.8, 5: 1609344.0, 6: 1000.0, 7: 1.0e6, 8: 0.0254,
                9: 1.0e-3, 10: 10.0, 11: 1.0e-7}


class IgesError(DevflatError, ValueError):
    """An IGES file is unreadable or an entity in it is malformed (message names file and entity)."""


@dataclass(frozen=True)
class IgesEntity:
    """One directory entry: type, form, level, label, subscript and its raw parameters."""

    index: int  # 0-based order among all entities of the file
    directory: int  # sequence number of the first directory line (odd)
    type: int
    form: int
    level: int
    label: str
    subscript: int
    parameters: tuple


@dataclass(frozen=True)
class IgesFile:
    path: Path
    unit_mm: float
    unit_name: str
    entities: tuple[IgesEntity, ...]

    def of_type(self, entity_type: int) -> list[IgesEntity]:
        return [e for e in self.entities if e.type == entity_type]


def _split_global(text: str, delim: str, record: str) -> list[str]:
    """Split the global section, honouring Hollerith strings (nH...)."""
    out, k, field = [], 0, ""
    while k < len(text):
        ch = text[k]
        if ch.isdigit() and not field.strip():
            j = k
            while j < len(text) and text[j].isdigit():
                j += 1
            if j < len(text) and text[j] == "H":
                n = int(text[k:j])
                out.append(text[j + 1: j + 1 + n])
                k = j + 1 + n
                while k < len(text) and text[k] not in (delim, record):
                    k += 1
                k += 1
                field = ""
                continue
        if ch in (delim, record):
            out.append(field.strip())
            field = ""
            if ch == record:
                break
        else:
            field += ch
        k += 1
    return out


def _number(token: str) -> float:
    return float(token.strip().replace("D", "E").replace("d", "e"))


def read_iges(path: str | Path) -> IgesFile:
    """Parse the directory and parameter sections of an IGES file."""
    from .inputs import InputFileError, read_input_file

    path = Path(path)
    try:
        raw = read_input_file(path, "IGES").decode("latin-1")
    except InputFileError as exc:
        raise IgesError(str(exc)) from None
    sections: dict[str, list[str]] = {"S": [], "G": [], "D": [], "P": [], "T": []}
    for number, line in enumerate(raw.splitlines(), 1):
        if not line.strip():
            continue
        line = line.ljust(80)
        key = line[72]
        if key not in sections:
            raise IgesError(f"{path}:{number}: not an IGES fixed-format line (section letter {key!r})")
        sections[key].append(line)
    if not sections["D"] or not sections["P"]:
        raise IgesError(f"{path}: no directory or parameter section: not an IGES file")
    global_text = "".join(line[:72] for line in sections["G"])
    delim = global_text[2] if global_text[:2] == "1H" else ","
    record = global_text[6] if global_text[4:6] == "1H" else ";"
    fields = _split_global(global_text, delim, record)
    try:
        flag = int(float(fields[13])) if len(fields) > 13 and fields[13] else 2
    except (ValueError, OverflowError):
        raise IgesError(f"{path}: global parameter 14 (unit flag) is {fields[13]!r}, not a number") from None
    unit_name = fields[14] if len(fields) > 14 else ""
    unit_mm = UNIT_FLAG_MM.get(flag)
    if unit_mm is None:
        named = {"IN": 25.4, "INCH": 25.4, "MM": 1.0, "FT": 304.8, "M": 1000.0, "CM": 10.0, "KM": 1e6}
        unit_mm = named.get(unit_name.strip().upper())
        if unit_mm is None:
            raise IgesError(f"{path}: unknown unit (flag {flag}, name {unit_name!r})")
    params = {}
    p_lines = sections["P"]
    for line in p_lines:  # keyed by the P sequence number, which directory entries point to
        try:
            params[int(line[73:80])] = line[:64]
        except ValueError:
            raise IgesError(f"{path}: parameter line without a sequence number: {line.rstrip()!r}") from None
    entities = []
    d_lines = sections["D"]
    for k in range(0, len(d_lines) - 1, 2):
        first, second = d_lines[k], d_lines[k + 1]
        try:
            entity_type = int(first[0:8])
            pointer = int(first[8:16])
            count = int(second[24:32] or 1)
            level = int(first[32:40] or 0) if first[32:40].strip() else 0
            form = int(second[32:40]) if second[32:40].strip() else 0
            subscript = int(second[64:72]) if second[64:72].strip() else 0
            sequence = int(first[73:80])
        except ValueError:
            raise IgesError(f"{path}: directory entry D{k + 1} is malformed: {first[:72].rstrip()!r}") from None
        if not 0 < count <= len(p_lines):
            raise IgesError(f"{path}: directory entry D{sequence} claims {count} parameter lines "
                            f"({len(p_lines)} in the file)")
        text = "".join(params.get(pointer + j, "") for j in range(count))
        tokens = text.split(record)[0].split(delim)
        entities.append(IgesEntity(len(entities), sequence, entity_type, form, level, second[56:64].strip(),
                                   subscript, tuple(t.strip() for t in tokens)))
    return IgesFile(path, unit_mm, unit_name, tuple(entities))


def _numbers(entity: IgesEntity, path: Path) -> np.ndarray:
    try:
        return np.array([_number(t) for t in entity.parameters[1:] if t != ""], dtype=np.float64)
    except ValueError:
        raise IgesError(f"{path}: entity {entity.type} at D{entity.directory}: a parameter is not a number") from None


def iges_curve(iges: IgesFile, entity: IgesEntity, scale: float, name: str) -> NurbsCurve:
    """Entity 126 as a NURBS curve, coordinates multiplied by ``scale``."""
    where = f"{iges.path}: entity 126 at D{entity.directory}"
    p = _numbers(entity, iges.path)
    try:
        k, m = int(p[0]), int(p[1])
        n = k + 1
        knots = p[6: 6 + n + m + 1]
        weights = p[6 + n + m + 1: 6 + n + m + 1 + n]
        points = p[6 + 2 * n + m + 1: 6 + 2 * n + m + 1 + 3 * n].reshape(n, 3)
        t0, t1 = p[6 + 5 * n + m + 1: 6 + 5 * n + m + 3]
    except (IndexError, ValueError, OverflowError):
        raise IgesError(f"{where}: too few or malformed parameters for a rational B-spline curve") from None
    try:
        curve = nurbs_curve(points * scale, m, weights, knots, name=name)
        lo, hi = curve.domain
        if lo < t0 < hi or lo < t1 < hi:  # the entity uses only part of its spline
            curve = curve.segment(max(lo, t0), min(hi, t1))
        return curve
    except InvalidCurveError as exc:
        raise IgesError(f"{where}: {exc}") from None


def iges_surface(iges: IgesFile, entity: IgesEntity, scale: float, name: str) -> NurbsSurface:
    """Entity 128 as a NURBS surface (u: first index, v: second), coordinates times ``scale``."""
    where = f"{iges.path}: entity 128 at D{entity.directory}"
    p = _numbers(entity, iges.path)
    try:
        k1, k2, m1, m2 = (int(x) for x in p[:4])
        n1, n2 = k1 + 1, k2 + 1
        at = 9
        knots_u = p[at: at + n1 + m1 + 1]
        at += n1 + m1 + 1
        knots_v = p[at: at + n2 + m2 + 1]
        at += n2 + m2 + 1
        weights = p[at: at + n1 * n2].reshape(n2, n1).T
        at += n1 * n2
        poles = p[at: at + 3 * n1 * n2].reshape(n2, n1, 3).transpose(1, 0, 2)
    except (IndexError, ValueError, OverflowError):
        raise IgesError(f"{where}: too few or malformed parameters for a rational B-spline surface") from None
    try:
        return nurbs_surface(m1, m2, poles * scale, knots_u, knots_v, weights, name=name)
    except InvalidCurveError as exc:
        raise IgesError(f"{where}: {exc}") from None
