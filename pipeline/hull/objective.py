"""What the adaptive plan optimises (``plan.objective``) and the record of the plans it tried.

``{maximise: flat_strip, weld_factor: F}``: the flat + strip share of the shell, with the weld
length (seams and butts between plates) at most F times the weld of the plan's uniform layout.
The splits the plan could make are ranked by the area they are expected to deliver flat or as
a strip per metre of weld they add (best gain per weld metre first) and taken while the weld
stays within the budget; a split whose halves, once evaluated, deliver no more flat or strip
area than the plate did is rejected (its weld goes back to the budget, the plate stays whole).
The expectation is a coarse estimate (pipeline/hull/splitting.py), the verdict the strip
solve's: once no split expected to pay can be taken (none is left, or none fits the budget
left), that budget goes to the splits expected to gain nothing, those whose halves' estimates are nearest the tolerance first, and they are kept or
undone by the same rule.

``{weights: {weld_m: a, plate: b, formed_m2: c}}``: the plan of least cost
a * weld metres + b * plates + c * m^2 not delivered flat or strip; a split is taken when it is
expected to lower the cost (c * gain - a * weld - b > 0) and kept when it does.

The record (:class:`PlanRecord`) holds every plan state the planner evaluated: after each
round of splits the plan with all of them applied (before the rejections) and the plan kept,
each with its plates, weld length (m) and flat + strip share; its Pareto front (the states no
other beats in both share and weld) is what ``bench/bench_hull.py`` prints.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field


@dataclass(frozen=True)
class PlanPoint:
    """One plan the planner evaluated: plates, weld metres (seams and butts between plates,
    the uniform layout's measured on the hull plus each split's new weld), the flat + strip
    share of the shell area, and whether the planner kept it (``kept``) or tried it."""

    round: int
    plates: int
    weld_m: float
    flat_strip: float
    kept: bool


@dataclass
class PlanRecord:
    """What an adaptive plan evaluated: its candidate plans, the plate evaluations it asked for
    (``evaluations``; a cache may answer some), the uniform layout's weld (m) and the budget."""

    points: list = field(default_factory=list)
    evaluations: int = 0
    uniform_weld_m: float | None = None
    weld_budget_m: float | None = None
    splits_taken: int = 0
    splits_rejected: int = 0

    def add(self, round_: int, plates: int, weld_m: float, flat_strip: float, kept: bool) -> None:
        self.points.append(PlanPoint(round_, plates, float(weld_m), float(flat_strip), kept))

    def pareto(self) -> list[PlanPoint]:
        """The points no other point beats in both (more share, less weld), by weld length."""
        front = []
        for p in sorted(self.points, key=lambda q: (q.weld_m, -q.flat_strip, not q.kept, q.round)):
            if not front or p.flat_strip > front[-1].flat_strip + 1e-12:
                front.append(p)
        return front

    def as_dict(self) -> dict:
        return {"evaluations": self.evaluations, "uniform_weld_m": self.uniform_weld_m,
                "weld_budget_m": self.weld_budget_m, "splits_taken": self.splits_taken,
                "splits_rejected": self.splits_rejected, "candidates": [asdict(p) for p in self.points],
                "pareto": [asdict(p) for p in self.pareto()]}


def split_priority(objective, gain_m2: float, weld_m: float) -> float:
    """Higher first: expected flat/strip m^2 per weld metre (maximise), or the expected fall of
    the weighted cost (weights)."""
    if objective.weights is None:
        return gain_m2 / max(weld_m, 1e-9)
    return worth(objective, gain_m2, weld_m)


def worth(objective, gain_m2: float, weld_m: float) -> float:
    """The fall of the weighted cost a split brings (> 0: worth taking); for ``maximise`` the
    flat/strip area it adds."""
    w = objective.weights
    if w is None:
        return gain_m2
    return w.formed_m2 * gain_m2 - w.weld_m * weld_m - w.plate
