"""Remnants: the usable offcuts of steel stock plates, kept in a CSV inventory that the next
`devflat nest` takes as stock first (AVEVA's "restplates").

A plate is filled from its start (x = 0) and its parts end before ``used_length`` (the last
part's end plus the edge margin), so one straight cut across the plate there (or a kerf
further, when the spacing is the larger) frees the rectangle [used_length, length] x
[0, width] without touching a part. That rectangle is a
remnant when it is at least ``min_length`` long and ``min_width`` wide. The inventory
holds one row per remnant (mm, as the cutting list): its id, thickness, material, size and
where it came from. A nest reads an inventory, uses some of its remnants (each at most
once: a used remnant is not in the inventory the nest writes) and adds the offcuts of its
own plates, remnants included, under new ids.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass
from pathlib import Path

from ..config import ConfigError

COLUMNS = ("remnant", "thickness_mm", "material", "width_mm", "length_mm", "origin")
ID_PATTERN = re.compile(r"^R(\d{4,})$")


@dataclass(frozen=True)
class Remnant:
    """A remnant plate: width x length (model units), thickness (mm) and material."""

    id: str
    thickness_mm: float
    material: str
    width: float
    length: float
    origin: str = ""

    def fits_group(self, info: dict) -> bool:
        """Whether parts of this nesting group (thickness and material) may be cut from it."""
        return math.isclose(self.thickness_mm, info["thickness_mm"], rel_tol=1e-9) and \
            self.material == info["material"]


def read_inventory(path: Path, scale: float) -> list[Remnant]:
    """The remnants of an inventory CSV (sizes in mm; ``scale`` mm per model unit). Bad
    input (ConfigError) names the file, the row, the column and the value."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read the remnant inventory: {exc}") from None
    reader = csv.DictReader(io.StringIO(text))
    missing = [c for c in COLUMNS if c not in (reader.fieldnames or [])]
    if missing:
        raise ConfigError(f"{path}: remnant inventory: missing column(s) {', '.join(missing)} "
                          f"(columns: {', '.join(reader.fieldnames or [])})")
    out, seen = [], set()
    for k, row in enumerate(reader, start=2):  # row 1 is the header
        ident = (row["remnant"] or "").strip()
        if not ID_PATTERN.match(ident):
            raise ConfigError(f"{path}: row {k}: remnant = {ident!r}: not a remnant id (R and 4 or more digits)")
        if ident in seen:
            raise ConfigError(f"{path}: row {k}: remnant = {ident!r} appears twice")
        seen.add(ident)
        numbers = {}
        for column in ("thickness_mm", "width_mm", "length_mm"):
            value = row[column]
            try:
                number = float(value)
            except (TypeError, ValueError):
                number = math.nan
            if not (math.isfinite(number) and number > 0):
                raise ConfigError(f"{path}: row {k}: {column} = {value!r}: must be a number > 0")
            numbers[column] = number
        material = (row["material"] or "").strip()
        if not material:
            raise ConfigError(f"{path}: row {k}: material = {row['material']!r}: empty")
        out.append(Remnant(ident, numbers["thickness_mm"], material, numbers["width_mm"] / scale,
                           numbers["length_mm"] / scale, (row["origin"] or "").strip()))
    return out


def next_ids(taken: list[str], count: int) -> list[str]:
    """``count`` new remnant ids after the highest of ``taken``: R0001, R0002, ..."""
    top = max((int(ID_PATTERN.match(t).group(1)) for t in taken if ID_PATTERN.match(t)), default=0)
    return [f"R{top + k:04d}" for k in range(1, count + 1)]


def offcut(sheet_row: dict, min_length: float, min_width: float, edge_margin: float = 0.0,
           spacing: float = 0.0) -> tuple[float, float, float] | None:
    """(x where the cut goes, width, length) of a plate's offcut (model units), from its
    cutting-list row (``used_length``: the last part's end plus the edge margin;
    ``length``, ``width``), or None when it is smaller than min_length x min_width. The cut
    keeps the larger of the edge margin and the spacing (kerf) from the last part."""
    start = float(sheet_row["used_length"]) - edge_margin + max(edge_margin, spacing)
    length = float(sheet_row["length"]) - start
    width = float(sheet_row["width"])
    if length + 1e-9 * float(sheet_row["length"]) < min_length or width < min_width:
        return None
    return start, width, length


def inventory_csv(remnants: list[Remnant], scale: float) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(COLUMNS)
    for r in remnants:
        # rounded down: a remnant is never listed larger than the steel there is
        writer.writerow([r.id, f"{r.thickness_mm:g}", r.material, f"{math.floor(r.width * scale * 10) / 10:.1f}",
                         f"{math.floor(r.length * scale * 10) / 10:.1f}", r.origin])
    return buffer.getvalue()
