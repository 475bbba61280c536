"""Plans made again after the fit-up: the plates ``strake.hold_steps`` held, split.

A plate held for a step keeps its edges on the hull; it stays flat or a strip only where a
plane or the strip between its seams does that (:func:`.follow._hold_stepping`). On the 160 m
hull most held plates are strips laid butt to butt: their seam edges are straight rulings
beside a seam that bows by more than half the step limit over the plate's length, so they are
delivered formed. ``plan.replan_held`` plans the hull again with each such plate counted as one
that does not fit (:func:`.planner.plan_hull`'s ``lost``), so that the plan splits it as it
splits any plate that does not fit: where and whether by its own rules (the split chooser, the
minimum stock sizes, ``max_splits``, the yard's rules, an objective's weld budget). Its halves
are strips of their own, with edges of their own beside their neighbours'. A split only across
the edge that held the plate (a butt for a seam edge, to shorten the chord) was tried first:
most held plates of the 160 m hull are 3.4-5 m long, so no butt keeps both halves within the
3 m minimum length, and the share rose 0.41 points against 2.03 with either kind (bench/).
The new plan is fitted up again, and the plan whose delivered flat + strip share is the
highest is kept; the others are reported.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .cost import SHARE_NAMES
from .hullplots import display_class, shell_area

KEPT_CLASSES = ("flat", "developable")
RULE = ("plan.replan_held: the plan is made again with each plate that strake.hold_steps held and delivered neither "
        "flat nor a strip (in any plan before) counted as a plate that does not fit, split by the plan's own rules; "
        "the new plan is fitted up again, and the plan whose delivered flat + strip share of the shell is the "
        "highest is kept (the first on a tie)")


def lost_plates(held: dict) -> frozenset:
    """The names of the plates a fit-up held that were flat or strips and are delivered as
    neither (``held``: :attr:`.follow.FollowReport.held`)."""
    return frozenset(name for name, record in held.items()
                     if record["class_before"] in KEPT_CLASSES and record["class_after"] not in KEPT_CLASSES)


def delivered_share(parts: list) -> float:
    """The flat + strip share of the shell area the hull plates of ``parts`` deliver (their
    results, as the plan's cost counts them: :func:`.cost.plan_cost`)."""
    results = [p.hull.result for p in parts if getattr(p, "hull", None) is not None and p.hull.result is not None]
    areas = [(SHARE_NAMES[display_class(r)], shell_area(r)) for r in results]
    total = sum(a for _, a in areas)
    return sum(a for kind, a in areas if kind in ("flat", "strip")) / total if total > 0 else 0.0


@dataclass
class ReplanReport:
    """Each plan made (the first as planned, then one per ``plan.replan_held``): its plates,
    the plates its fit-up held and lost, and its delivered flat + strip share; which was kept."""

    plans: list = field(default_factory=list)
    kept: int = 0
    stopped: str = ""

    def add(self, parts: list, lost: frozenset, asked: frozenset) -> None:
        """The plan of ``parts`` after its fit-up: ``lost`` the plates that fit-up held and lost,
        ``asked`` the lost plates of the plan before that this plan was asked to split."""
        names = {p.name for p in parts}
        self.plans.append({
            "plates": sum(getattr(p, "hull", None) is not None for p in parts),
            "delivered_flat_strip": delivered_share(parts),
            "held_lost": sorted(lost),
            "asked_split": sorted(asked),
            "asked_not_split": sorted(n for n in asked if n in names),
        })

    def as_dict(self) -> dict:
        return {"rule": RULE, "kept": self.kept, "stopped": self.stopped, "plans": self.plans}

    def one_line(self) -> str:
        shares = ", ".join(f"{100 * p['delivered_flat_strip']:.2f} %" for p in self.plans)
        return (f"replan: {len(self.plans)} plan(s), flat + strip after fit-up {shares}; plan {self.kept + 1} kept"
                + (f" ({self.stopped})" if self.stopped else ""))
