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
3 m minimum length, and the share rose 0.41 points against 2.33 with either kind (bench/).
The new plan is fitted up again. The plan kept is the one whose fit-up left the fewest pairs
of flat or strip plates stepping over the limit (``untaken``: the holds did not take them, so
they count as flat or strips in the share), then the highest delivered flat + strip share.

A lost plate is known by its name and its region (seams and butt planes): a name says only
where a plate sits in the plan's tree of splits, and under the yard's rules a neighbour's new
split can move the butts a plate of the same name is split at.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .cost import class_areas

FLAT_OR_STRIP = ("flat", "developable")
SHARE_DIGITS = 6  # shares compared to a millionth of the shell (0.004 m^2 of the 160 m hull's)
RULE = ("plan.replan_held: the plan is made again with each plate that strake.hold_steps held and delivered neither "
        "flat nor a strip (in any plan before, known by its name and region) counted as a plate that does not fit, "
        "split by the plan's own rules; the new plan is fitted up again, and the plan kept is the one whose fit-up "
        "left the fewest pairs of flat or strip plates stepping over the limit, then the one whose delivered flat + "
        "strip share of the shell is the highest (the first on a tie)")


def region_key(hull) -> tuple:
    """A plate's region as the plan laid it: its seams (girth curves in the surface's
    parameters) and its butt planes (None: the hull's end)."""
    return (tuple((tuple(map(float, g.s)), tuple(map(float, g.g))) for g in hull.girths),
            tuple(None if p is None else (*map(float, p.normal), float(p.offset)) for p in hull.butts))


def plate_keys(parts: list) -> frozenset:
    """(name, :func:`region_key`) of each hull plate of ``parts``."""
    return frozenset((p.name, region_key(p.hull)) for p in parts if getattr(p, "hull", None) is not None)


def lost_plates(held: dict, parts: list) -> frozenset:
    """(name, :func:`region_key`) of the plates of ``parts`` a fit-up held that were flat or
    strips and are delivered as neither (``held``: :attr:`.follow.FollowReport.held`)."""
    by_name = {p.name: p for p in parts if getattr(p, "hull", None) is not None}
    return frozenset((name, region_key(by_name[name].hull)) for name, record in held.items()
                     if name in by_name and record["class_before"] in FLAT_OR_STRIP
                     and record["class_after"] not in FLAT_OR_STRIP)


def delivered_share(parts: list) -> float:
    """The flat + strip share of the shell area the hull plates of ``parts`` deliver (their
    results, as the plan's cost counts them: :func:`.cost.plan_cost`)."""
    area = class_areas([p.hull.result for p in parts
                        if getattr(p, "hull", None) is not None and p.hull.result is not None])
    total = sum(area.values())
    return (area["flat"] + area["strip"]) / total if total > 0 else 0.0


@dataclass
class ReplanReport:
    """Each plan made (the first as planned, then one per ``plan.replan_held`` round): its
    plates, the plates its fit-up held and lost, the pairs it left stepping and its delivered
    flat + strip share; which was kept, and why the rounds stopped."""

    plans: list = field(default_factory=list)
    kept: int = 0
    stopped: str = ""

    def add(self, parts: list, here: frozenset, follow, lost: frozenset, asked: frozenset) -> tuple:
        """The plan of ``parts`` (their :func:`plate_keys` ``here``) after its fit-up
        (``follow``): ``lost`` the plates that fit-up held and lost, ``asked`` the plates lost
        in the plans before, counted as not fitting in this one. Returns the plan's standing
        (larger is better)."""
        self.plans.append({
            "plates": len(here),
            "delivered_flat_strip": delivered_share(parts),
            "untaken": len(follow.untaken),
            "held_lost": sorted(name for name, _ in lost),
            "asked_split": sorted(name for name, _ in asked),
            "asked_not_split": sorted(name for name, region in asked if (name, region) in here),
        })
        return standing(self.plans[-1])

    def as_dict(self) -> dict:
        return {"rule": RULE, "kept": self.kept, "stopped": self.stopped, "plans": self.plans}

    def one_line(self) -> str:
        shares = ", ".join(f"{100 * p['delivered_flat_strip']:.2f} %" for p in self.plans)
        return (f"replan: {len(self.plans)} plan(s), flat + strip after fit-up {shares}; plan {self.kept + 1} kept"
                + (f" ({self.stopped})" if self.stopped else ""))


def standing(plan: dict) -> tuple:
    """A plan's rank among those made (larger is better): fewer pairs of flat or strip
    plates left stepping, then a higher delivered flat + strip share (to a millionth: two
    plans that deliver the same plates differ in the last digits of their sums)."""
    return (-plan["untaken"], round(plan["delivered_flat_strip"], SHARE_DIGITS))


def plan_again(rounds: int, first: tuple, replan, fit_up) -> tuple:
    """The plan kept of ``first`` and up to ``rounds`` plans made again, and the
    :class:`ReplanReport`. ``first``: (parts, plan record, fairings, follow report) of the plan
    as made and fitted up; ``replan(lost) -> (parts, plan record, fairings)`` plans the hull
    with the plates ``lost`` (:func:`lost_plates`) counted as not fitting; ``fit_up(parts) ->
    follow report`` fits a plan up. A round whose plan is the plan before (no lost plate could
    be split) is not fitted up again; one that raises ends the rounds, the plans before kept."""
    report = ReplanReport()
    best = first
    lost, asked, last = lost_plates(first[3].held, first[0]), frozenset(), plate_keys(first[0])
    best_standing = report.add(first[0], last, first[3], lost, asked)
    for _ in range(rounds):
        if not lost:
            report.stopped = "the last fit-up held no plate that lost its flat or strip class"
            break
        asked = asked | lost  # a plate lost once stays counted as not fitting
        try:
            parts, record, fairings = replan(asked)
            here = plate_keys(parts)
            if here == last:
                report.stopped = "the plan made again is the plan before: no plate lost could be split"
                break
            follow = fit_up(parts)
        except Exception as exc:  # noqa: BLE001 - a plan made again that fails leaves the plans before standing
            report.stopped = f"plan {len(report.plans) + 1} failed: {type(exc).__name__}: {exc}"
            break
        lost, last = lost_plates(follow.held, parts), here
        standing_here = report.add(parts, here, follow, lost, asked)
        if standing_here > best_standing:
            best, best_standing, report.kept = (parts, record, fairings, follow), standing_here, len(report.plans) - 1
    else:
        report.stopped = f"plan.replan_held = {rounds} plans made again"
    return best, report
