"""Fit-up repair: neighbours whose edges step further than a weld may be misaligned are
brought onto the hull, one plate at a time.

A flat or strip plate is delivered within the fit tolerance of the hull, its edges too: two
neighbours off the hull in opposite directions step by up to twice the tolerance at their
shared edge, more than a butt or seam may be misaligned by (IACS Rec. 47: 0.15 t, at most
3 mm). A plate developed on the hull as a patch has its edges on it, so its step with any
neighbour is the neighbour's own distance from the hull there.

The repair takes every misfit pair of the measured fit-up (:func:`.fitup.shared_edges`): the
plate whose edge lies further from the hull is held; when the other's edge is still further
from it than the pair's limit, that plate too. A plate held the first time keeps what keeps
its edges within half the pair's limit of the hull: a flat plate the plane that does, an
interior plate held for a step the strip between its seams (its seam edges are the seams, on
the hull) when that fits; else, and when held again, it is developed on the hull. A pair
whose developed lengths disagree (two isometric plates) is repaired the same way: a patch is
not held to its neighbour's length. The plates held change their other edges too (they now lie on the hull),
so the pairs are measured again, for a few rounds. A pair of which neither plate can be held
(both patches already: plates on two faces that do not meet) stays as the fit-up reports it.

Compared with ``strake.edge_tolerance``, which holds every plate whose edges leave the hull
further than a set distance, only plates that step from a neighbour lose their flat or strip
development, and only the worse of two when the other is close enough.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flatten.closest import SurfaceDistance

from .fitup import SAMPLE_MM, EdgeMeasures, plate_edges, shared_edges
from .planner import honest_class

ROUNDS = 4  # measure, hold, evaluate again: rounds at most
HOLDABLE = ("flat", "developable")  # classes whose edges may leave the hull (a patch's lie on it)
RULE = ("a plate whose edge steps from a neighbour's by more than min(0.15 t, 3 mm), or two flat/strip "
        "neighbours whose developed lengths differ by more than 1 mm: the plate whose edge lies further from the "
        "hull is held, and the other too when its edge is still further from the hull than the pair's limit; a plate "
        "held the first time stays flat on the plane that keeps its edges within half the pair's limit, or (an "
        "interior plate held for a step) becomes the strip between its seams if that fits and keeps them so, else "
        "it is developed on the hull (a patch); measured again after each round")


@dataclass
class RepairReport:
    """What the repair did: per round the misfit pairs found and the plates held (their
    names and why), and the misfit pairs it could not repair."""

    rounds: list = field(default_factory=list)
    unrepaired: list = field(default_factory=list)  # (plate a, plate b, edge label, step mm)
    kept: list = field(default_factory=list)  # held plates delivered flat or as a strip in the end (edges held)

    @property
    def held(self) -> list:
        return [name for r in self.rounds for name in r["held"]]

    def as_dict(self) -> dict:
        return {"rule": RULE, "plates_held": len(set(self.held)), "held_kept_flat_or_strip": self.kept,
                "rounds": self.rounds,
                "unrepaired": [{"plates": [a, b], "edge": label, "step_max_mm": step}
                               for a, b, label, step in self.unrepaired]}

    def one_line(self) -> str:
        misfits = self.rounds[0]["misfits"] if self.rounds else 0
        plates = len(set(self.held))
        return (f"fit-up repair: {misfits} misfit pair(s) found, {plates} plate(s) held in "
                f"{sum(1 for r in self.rounds if r['held'])} round(s) ({len(self.kept)} kept flat or as a strip with "
                f"their edges near the hull, {plates - len(self.kept)} developed on it), "
                f"{len(self.unrepaired)} pair(s) left")


def repair_fitup(parts: list, evaluate_many, mm_per_unit: float, thickness_mm: float,
                 workers=None) -> RepairReport:
    """Hold plates on the hull until no shared edge misfits (or ROUNDS rounds). ``parts``:
    the run's parts; hull plates without an evaluated result are evaluated first
    (``evaluate_many(parts) -> results``, spread over the workers). Each held plate is
    evaluated again with ``part.hull.held`` set, and ``part.hull.result`` is its new result.
    ``workers``: the evaluator's workers, for measuring the shell
    (:class:`.fitup.EdgeMeasures`), or None."""
    plates = [p for p in parts if getattr(p, "hull", None) is not None]
    _evaluate([p for p in plates if p.hull.result is None], evaluate_many)
    report = RepairReport()
    by_name = {p.name: p for p in plates}
    measured: dict = {}  # plate name -> (its result, its edges): only plates held since are measured again
    measures = EdgeMeasures(SAMPLE_MM / mm_per_unit, workers)  # and only their shared edges
    for round_no in range(1, ROUNDS + 1):
        records = {}
        for part in plates:
            result = part.hull.result
            if result is None:
                continue
            if part.name not in measured or measured[part.name][0] is not result:
                measured[part.name] = (result, plate_edges(result))
            edges = measured[part.name][1]
            if edges is not None:
                records[part.name] = (edges, part)
        pairs, _ = shared_edges(records, mm_per_unit, thickness_mm, measures)
        misfits = [q for q in pairs if q.misfit]
        chosen: dict = {}
        report.unrepaired = []
        for pair in sorted(misfits, key=lambda q: -q.step_max):
            picked = _to_hold(pair, records, mm_per_unit, round_no)
            if not picked:
                report.unrepaired.append((pair.a, pair.b, pair.label, pair.step_max))
            for name, held in picked:
                chosen.setdefault(name, held)
        report.rounds.append({"round": round_no, "misfits": len(misfits), "held": sorted(chosen)})
        if not chosen:
            break
        for name, held in chosen.items():
            by_name[name].hull.held = held
            by_name[name].hull.result = None
        _evaluate([by_name[name] for name in chosen], evaluate_many)
    report.kept = sorted(name for name in set(report.held) if honest_class(by_name[name].hull.result) in HOLDABLE)
    return report


def _evaluate(parts: list, evaluate_many) -> None:
    if parts:
        for part, result in zip(parts, evaluate_many(parts)):
            part.hull.result = result


def _to_hold(pair, records: dict, mm: float, round_no: int) -> list:
    """[(plate name, held record)] of the misfit pair: the plate whose edge is further from
    the hull; the other too when its edge is further than the pair's limit (a step misfit)."""
    sides = holdable_sides(pair, records, mm)
    stepped = pair.step_max > pair.limit
    keep = sides[:1] + [s for s in sides[1:] if stepped and s[0] > pair.limit]
    return [(side[1], held_record(pair, side, records, mm, round_no)) for side in keep]


def holdable_sides(pair, records: dict, mm: float) -> list:
    """[(how far its edge lies off the hull (mm), plate name, edge label, the other plate,
    its class)] of the pair's plates that may still be held, the further off first."""
    sides = []
    for name, side, other in ((pair.a, pair.side_a, pair.b), (pair.b, pair.side_b, pair.a)):
        edges, part = records[name]
        edge = edges.edge(side)
        held = part.hull.held
        if edges.klass not in HOLDABLE or edge is None or (held and held.get("edge_limit") is None):
            continue  # a patch already, or held on the hull as one
        distance = part.hull.distance or SurfaceDistance(part.hull.surface)
        off = float(np.max(distance(edge.points3))) * mm
        sides.append((off, name, edge.label, other, edges.klass))
    return sorted(sides, reverse=True)


def held_record(pair, side: tuple, records: dict, mm: float, round_no: int,
                rule: str = "strake.fit_up: repair", why_held: str = "fit-up repair", meets: str | None = None) -> dict:
    """What ``part.hull.held`` says of a plate held for the pair (``side``: its entry of
    :func:`holdable_sides`): why, and the edge limit a plate held the first time may keep
    its flat or strip development within. ``meets``: how its edge meets the other plate's,
    said before the step (default: it meets the other plate's edge with it)."""
    off, name, label, other, klass = side
    stepped = pair.step_max > pair.limit
    why = (f"step {pair.step_max:.2f} mm (limit {pair.limit:.2f} mm)" if stepped else
           f"developed lengths differ by {pair.mismatch:.2f} mm")
    meets = meets or f"meets {other}'s with"
    held = {"rule": rule, "round": round_no, "class_before": klass,
            "edge_deviation_before_mm": off, "edge": label, "neighbour": other, "step_mm": pair.step_max,
            "step_limit_mm": pair.limit,
            "reason": f"{why_held}: its {klass} edge {label} lies {off:.2f} mm off the hull and {meets} a {why}"}
    if getattr(pair, "formed", None):  # a junction step: the formed plate at whose corner the two part
        held["junction"] = pair.formed
    if not records[name][1].hull.held and (klass == "flat" or stepped):
        # a plate held the first time first tries what keeps its edges nearest the hull, a
        # flat one the plane that does, an interior one the strip between its seams (they
        # lie on the hull): within half the pair's limit, two such neighbours stay within
        # it. (A strip held for its developed length alone would come back the same strip.)
        held["edge_limit"] = 0.5 * pair.limit / mm
    return held
