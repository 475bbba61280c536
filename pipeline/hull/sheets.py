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
        """(short, long) mm of the smallest rectangle holding the closed outline (N, 2) mm,
        any rotation, with the clearance on every side (as the shop's stock check measures a
        cut outline, :func:`pipeline.shop.plate.part_rectangle`)."""
        from ..shop.plate import part_rectangle

        return part_rectangle(np.asarray(outline_mm, dtype=float)) + 2.0 * self.clearance

    def holding(self, need: np.ndarray) -> tuple | None:
        """The smallest sheet (by area) that holds a rectangle ``need`` (short, long) mm, or None."""
        from ..shop.plate import smallest_sheet

        return smallest_sheet(need, self.sizes)

    def excess(self, need: np.ndarray | None) -> float:
        """How far (mm) a rectangle ``need`` is from the nearest sheet: the least, over the
        sheets, of its larger overhang (0: a sheet holds it; 0 for None, a plate without a
        development: nothing to judge it by)."""
        if need is None:
            return 0.0
        return min((max(need[0] - w, need[1] - h, 0.0) for w, h in self.sizes), default=float("inf"))


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
