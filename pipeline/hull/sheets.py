"""Whether a plate's development fits a sheet of the stock (the adaptive plan's last check).

The plan holds a plate's region on the hull to ``plan.stock`` (girth x length), but the shop
cuts the development, and a long plate on a hull that turns in plan view develops into a
curved shape whose rectangle on the sheet is wider than its girth: KVLCC2's strip
``S08_B02-1-2`` of the yard's plan, 4 m in girth, needs 4790 x 5717 mm where the widest sheet
is 4500 mm. The check takes the development's smallest rectangle (any rotation), adds the
cut's largest allowance and the stock margin on every side, and asks for a sheet of
``shop.stock`` that holds it. It judges the development the plan has, not the cut: the
shop's own check (:func:`pipeline.shop.plate.stock_check`) measures the cut outline traced
from the exact development, whose corners an allowance mitres out further at acute angles
(up to ten allowances), so the two can differ by a few millimetres where a plate needs
nearly a whole sheet, and the shop's check stays the judge (and warns).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Sheets:
    """The stock sheets a plate is cut from: ``sizes`` ((width, length) mm each, width <=
    length) and ``clearance`` (mm kept on every side of the development: the stock margin
    plus the largest cut allowance)."""

    sizes: tuple
    clearance: float

    @classmethod
    def of_shop(cls, shop) -> Sheets:
        """The sheets of a run's ``shop`` settings (:class:`pipeline.config.Shop`)."""
        sizes = tuple(tuple(sorted((float(a), float(b)))) for a, b in shop.stock)
        return cls(sizes, float(shop.stock_margin) + max(shop.allowance().values()))

    def need(self, outline_mm: np.ndarray) -> np.ndarray:
        """(short, long) mm of the smallest rectangle holding the outline (N, 2) mm, any
        rotation, with the clearance on every side."""
        import shapely

        rect = shapely.minimum_rotated_rectangle(shapely.MultiPoint(np.asarray(outline_mm, dtype=float)))
        corners = np.asarray(rect.exterior.coords)[:3] if rect.geom_type == "Polygon" else _segment(rect)
        sides = np.sort(np.linalg.norm(np.diff(corners, axis=0), axis=1))
        return sides + 2.0 * self.clearance

    def holding(self, need: np.ndarray) -> tuple | None:
        """The smallest sheet (by area) that holds a rectangle ``need`` (short, long) mm, or None."""
        fits = [(w * h, (w, h)) for w, h in self.sizes if need[0] <= w and need[1] <= h]
        return min(fits)[1] if fits else None


def _segment(line) -> np.ndarray:
    """A degenerate rectangle (the outline's points on a line): its ends, twice."""
    ends = np.asarray(line.coords)[[0, -1]]
    return np.array([ends[0], ends[1], ends[1]])


def development_need(result, sheets: Sheets, mm_per_unit: float) -> np.ndarray | None:
    """(short, long) mm a plate's development needs on a sheet (:meth:`Sheets.need`), or None
    when it has none (a failed plate, or one whose development is still owed)."""
    pattern = getattr(result, "pattern", None)
    if pattern is None or pattern.outline is None or len(pattern.outline) < 3:
        return None
    outline = np.asarray(pattern.outline, dtype=float)
    if not np.all(np.isfinite(outline)):
        return None
    return sheets.need(outline * mm_per_unit)
