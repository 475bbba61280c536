"""Shop data of a steel plate: exact cut outline, bending lines, marks and labels, in mm.

Runs after the pattern stage for the steel profile; the DXF, the previews and the shop
drawing draw what it holds. Every length of a :class:`ShopPlate` is in mm.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .outline import Outline, exact_outline


@dataclass(frozen=True)
class ShopPlate:
    """A plate as the shop gets it (mm, the pattern's placed coordinates scaled).

    outline : the net outline (exact development within outline.tolerance)
    """

    outline: Outline


def _scaled(outline: Outline, factor: float) -> Outline:
    return Outline(outline.points * factor, outline.edges, outline.max_deviation * factor,
                   outline.tolerance * factor, outline.alignment_error * factor)


def stage_shop(result, config) -> None:
    """Exact outline (and the shop marks) of a solved steel plate; sets ``result.shop``,
    replaces the pattern's outline by the exact one and records the figures."""
    scale = config.mm_per_unit
    shop = config.spec.shop
    hull = result.part.hull
    planes = hull.butts if hull is not None else ()
    outline = exact_outline(result.part, result.solution, result.strip, result.pattern, planes,
                            shop.outline_tolerance / scale)
    result.pattern = dataclasses.replace(result.pattern, outline=outline.points)
    outline_mm = _scaled(outline, scale)
    result.shop = ShopPlate(outline_mm)
    result.figures["outline"] = {
        "units": "mm",
        "vertices": len(outline_mm.points),
        "tolerance": outline_mm.tolerance,
        "max_deviation": outline_mm.max_deviation,
        "deviation_measured_at": "3 points per segment (1/4, 1/2, 3/4) on the exact development",
        "alignment_error": outline_mm.alignment_error,
        "area_m2": outline_mm.area() / 1e6,
        "edges": {name: int(outline.edges.count(name)) for name in sorted(set(outline.edges))},
    }
    if outline_mm.max_deviation > outline_mm.tolerance:
        result.warnings.append(f"cut outline deviates {outline_mm.max_deviation:.3g} mm from the exact development "
                               f"(tolerance {outline_mm.tolerance:g} mm): the sampling limit was reached")
