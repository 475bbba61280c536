"""Fit-up by forming: a formed plate is formed to meet its flat and strip neighbours' edges.

A flat or strip plate is delivered within the fit tolerance of the hull, its edges too, and a
formed plate developed on the hull has its edges on it: where the two meet, the step is the
flat or strip plate's own distance from the hull there, up to the tolerance (5 mm), more
than a butt or seam may be misaligned by (IACS Rec. 47: 0.15 t, at most 3 mm). Holding the
flat or strip plate on the hull (:mod:`.repair`) costs it its development. A formed plate,
though, is shaped in the shop to whatever its pin jig and templates say, so it can take the
step instead: its target shape is the hull moved, at each point of its edge shared with a
flat or strip neighbour, onto that neighbour's edge, and elsewhere by the harmonic blend of
those moves. The blend is one discrete Laplace equation over the region grids of all the
shell's formed plates joined where they meet: each point on an edge two formed plates share
takes the other plate's row inside that edge, interpolated at its closest point, as its
neighbour across it, so that formed neighbours move together and meet (exactly where the
moves vary linearly, to the discretisation elsewhere); two formed plates that step as
developed by more than the limit (two faces that disagree where a plan cut them) are not
joined but each formed to meet the other halfway, at most the tolerance, where no flat or
strip neighbour holds the point; the shell's free edges stay on the hull. The blend takes its largest value where it is
given (maximum principle), so every formed plate stays within the tolerance of the hull
wherever its flat and strip neighbours do; a move that would end further from the hull than
the tolerance is shortened to end at it (the tolerance bounds the plate's distance from the
hull, not how far it moves along it: a move is at most twice it), and a plate whose blended
moves leave the hull further anywhere is moved less as a whole (:func:`_within_tolerance`). Where two flat or strip plates that step from each other meet at a corner of formed
plates, each formed plate meets its own flat neighbour there, so the formed plates' shared
edge takes the flat plates' step at its end, and within a grid cell or two no longer (the
discrete Laplace equation damps a difference along a joined edge by about 0.27 per point).
A formed plate's corner between two flat or strip neighbours whose corners part goes between
them, and a formed corner whose neighbours there are formed goes where theirs go
(:mod:`.junction`); a formed plate's edge that runs past such a junction (a T) passes
through it.
A formed plate stays formed: the strips and the flat plates left flat keep their
developments, the formed ones that move are developed again from their moved shape (pin jig, templates and heating
lines follow it). Before the forming, a flat plate that misfits a flat or strip neighbour
is developed again as a strip where one fits (:func:`_flats_as_strips`: a strip through
its seams lies on the hull along them), and then the flat plates' planes and the strips'
places (a small rigid motion each) are chosen together (:mod:`.joint`, :mod:`.rigid`), so
that flat and strip neighbours step as little as their tolerance allows; the formed plates
then meet them where they lie. With ``strake.hold_steps`` the pairs of flat or strip plates
that still step over the limit then have plates held on the hull (:func:`_hold_stepping`):
those become formed plates, and the forming shapes them to meet their neighbours too.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .fitup import (
    SAMPLE_MM,
    SIDES,
    TRIM,
    EdgeMeasures,
    _dense,
    _grid_ring,
    closest_on,
    kept_edges,
    shared_edges,
)
from .joint import RULE as JOINT_RULE
from .joint import joint_moves
from .junction import (
    JUNCTION_RULE,
    JunctionStep,
    junction_moves,
    junction_steps,
    smallest_ball,
)
from .ownsurface import hull_distance
from .plateshop import formed_verdict
from .pull import RULE as PULL_RULE
from .pull import pull_stepping

FORMED = "formed"
AS_STRIP_RULE = ("a flat plate that steps from a flat or strip neighbour by more than the limit is developed again "
                 "as a strip (no plane tried): kept as the strip where one fits within the tolerance and steps less "
                 "from those neighbours than its plane did, else flat as before; the joint programme then places the "
                 "plates as they are")
MOVABLE_NEIGHBOURS = ("flat", "developable")  # the neighbours a formed plate is formed to meet
SLIDE = 2.0  # a formed plate's point moves at most this many fit tolerances (within one of the hull)
SHARES = (1.0, 0.75, 0.5, 0.25)  # of a strip's joint move, tried in turn until the plate stays within its tolerance
CODES = {"seam0": 0, "seam1": 1, "butt0": 2, "butt1": 3}
HOLD_ROUNDS = 2  # hold, evaluate, measure again: a plate held twice is developed on the hull
HOLD_RULE = ("strake.hold_steps: of the pairs of flat or strip plates that still step by more than the limit after the "
             "joint programme, the plates holding one of every pair in the fewest square metres (greedy: pairs per "
             "m2) are held as strake.fit_up: repair holds a plate (flat on the plane, or the strip between its seams, "
             "that keeps its edges within half the limit of the hull, else developed on the hull: a formed plate, "
             "which the forming then shapes to meet its neighbours); a plate held twice is developed on the hull; "
             "measured again after each round")
RULE = ("the formed plates are formed to meet their flat and strip neighbours: their edge points moved onto the "
        "neighbour's edge (closest points; a corner at a junction as junction_rule says; each move at most "
        "the fit tolerance), the rest by the harmonic blend of "
        "those moves over all formed plates joined at their shared edges (the shell's free edges stay on the "
        "hull; two formed plates that step as developed by more than the limit each moved halfway to the "
        "other's edge instead); strips and flat plates keep their development")


@dataclass
class FollowReport:
    """What the fit-up by forming did: the misfit pairs found, the flat plates delivered as
    strips (and those kept flat, with why), the planes and strips the joint programme moved,
    the formed plates moved (name -> largest move, mm, and the neighbours they meet) and the
    misfit pairs no formed plate could take (two flat or strip plates)."""

    misfits: int = 0
    moved: dict = field(default_factory=dict)
    untaken: list = field(default_factory=list)  # (plate a, plate b, edge label, step mm)
    planes: dict = field(default_factory=dict)  # flat plate -> largest shift of its region's points (mm)
    strips: dict = field(default_factory=dict)  # strip moved rigidly -> its largest move (mm)
    refused: list = field(default_factory=list)  # plates whose move would take them off the tolerance
    shortened: dict = field(default_factory=dict)  # strip -> the share of its move it took (the whole left it)
    joint_error: str | None = None  # why the joint programme moved nothing, if it failed
    as_strips: dict = field(default_factory=dict)  # flat plate delivered as a strip -> {step_mm, neighbours, step_after_mm}
    kept_flat: dict = field(default_factory=dict)  # flat plate asked for as a strip that no strip fits -> why
    pulled: dict = field(default_factory=dict)  # plate pulled at erection (strake.pull_steps) -> its pull's figures
    pull_refused: dict = field(default_factory=dict)  # plate whose pull was refused -> why
    held: dict = field(default_factory=dict)  # plate held for a step (strake.hold_steps) -> its record and class after
    hold_failed: dict = field(default_factory=dict)  # plate whose held development failed (kept as it was) -> why

    def as_dict(self) -> dict:
        return {"rule": RULE, "junction_rule": JUNCTION_RULE, "misfits_found": self.misfits, "plates_moved": len(self.moved),
                "moved": self.moved, "joint_rule": JOINT_RULE, "flat_planes_moved": len(self.planes),
                "planes": self.planes, "strips_moved": len(self.strips), "strips": self.strips,
                "moves_refused": self.refused, "strip_moves_shortened": self.shortened,
                "joint_error": self.joint_error, "flats_as_strips_rule": AS_STRIP_RULE,
                "flats_as_strips": self.as_strips, "kept_flat": self.kept_flat,
                **({"pull_rule": PULL_RULE, "pulled": self.pulled, "pull_refused": self.pull_refused}
                   if self.pulled or self.pull_refused else {}),
                **({"hold_rule": HOLD_RULE, "held": self.held, "hold_failed": self.hold_failed}
                   if self.held or self.hold_failed else {}),
                "untaken": [{"plates": [a, b], "edge": label, "step_max_mm": step}
                            for a, b, label, step in self.untaken]}

    def one_line(self) -> str:
        return (f"fit-up by forming: {self.misfits} misfit pair(s) found, {len(self.as_strips)} flat plate(s) "
                f"delivered as strips, {len(self.planes)} flat plate(s) on planes "
                f"and {len(self.strips)} strip(s) moved, chosen together, {len(self.moved)} formed plate(s) formed to "
                f"meet their flat and strip neighbours, {len(self.untaken)} pair(s) of flat or strip plates left"
                + (f" ({len(self.pulled)} flat or strip plate(s) pulled at erection, {len(self.pull_refused)} "
                   f"refused)" if self.pulled or self.pull_refused else "")
                + (f" ({len(self.held)} plate(s) held for their steps, {self._held_developable()} of them still flat "
                   f"or strips)" if self.held else "")
                + (f" (the joint programme failed: {self.joint_error})" if self.joint_error else ""))

    def _held_developable(self) -> int:
        return sum(h["class_after"] in ("flat", "developable") for h in self.held.values())


def follow_fitup(parts: list, evaluate_many, mm_per_unit: float, thickness_mm: float,
                 joint: bool = True, strips: bool = True, as_strips: bool = True, hold: bool = False,
                 pull: bool = False, workers=None) -> FollowReport:
    """Form the shell's formed plates to meet their flat and strip neighbours, the flat plates'
    planes and the strips' places first chosen together (:mod:`.joint`; ``joint=False``: each
    stays as developed; ``strips=False``: only the planes). ``parts``: the run's parts; hull
    plates without an evaluated result are evaluated first (``evaluate_many(parts) ->
    results``). A plate that moves is evaluated again with ``part.hull.follow`` (a formed
    plate: with its strips' verdict from before, :func:`.plateshop.formed_verdict`, so that
    only its moved patch is developed) or ``part.hull.plane`` (a flat one) set, a strip is moved as delivered
    (:mod:`.rigid`); ``part.hull.result`` is its new result. First (``as_strips``), a flat
    plate that misfits a flat or strip neighbour is developed again as a strip
    (:func:`_flats_as_strips`). After the joint programme, a pair of flat or strip plates
    that still steps over the limit is pulled together at erection (``pull``,
    :mod:`.pull`), and one that steps still has a plate held on the hull (``hold``,
    :func:`_hold_stepping`). ``workers``: the evaluator's workers, for measuring the shell
    (:class:`.fitup.EdgeMeasures`), or None."""
    plates = [p for p in parts if getattr(p, "hull", None) is not None]
    missing = [p for p in plates if p.hull.result is None]
    if missing:
        for part, result in zip(missing, evaluate_many(missing)):
            part.hull.result = result
    records = _records(plates)
    # each step below moves few plates: the pairs of plates it leaves in place are not measured again
    measures = EdgeMeasures(SAMPLE_MM / mm_per_unit, workers)
    pairs, _ = shared_edges(records, mm_per_unit, thickness_mm, measures)
    report = FollowReport(misfits=sum(q.misfit for q in pairs))
    if joint and as_strips:
        records = _flats_as_strips(plates, records, pairs, evaluate_many, mm_per_unit, thickness_mm, report, measures)
        if report.as_strips:
            pairs, _ = shared_edges(records, mm_per_unit, thickness_mm, measures)
    if joint and _move_jointly(plates, records, pairs, evaluate_many, mm_per_unit, strips, report):
        # the flat plates and strips where they now lie: the formed plates meet them there
        records = _records(plates, records, set(report.planes) | set(report.strips))
        pairs, _ = shared_edges(records, mm_per_unit, thickness_mm, measures)
    if pull:
        results, report.pulled, report.pull_refused = pull_stepping(records, pairs, mm_per_unit, thickness_mm,
                                                                    measures)
        if results:
            for part in plates:
                part.hull.result = results.get(part.name, part.hull.result)
            records = _records(plates, records, set(results))
            pairs, _ = shared_edges(records, mm_per_unit, thickness_mm, measures)
    if hold:
        records, pairs = _hold_stepping(plates, records, pairs, evaluate_many, mm_per_unit, thickness_mm, report,
                                        measures)
    report.untaken = [(q.a, q.b, q.label, q.step_max) for q in pairs if q.misfit and FORMED not in (
        records[q.a][0].klass, records[q.b][0].klass)]
    grids = {}
    for name, (edges, part) in records.items():
        shape = tuple((part.hull.result.figures.get("region") or {}).get("grid") or ())
        if edges.klass == FORMED and len(shape) == 2 and part.hull.result.mesh is not None:
            grids[name] = _PlateGrid(name, np.asarray(part.hull.result.mesh[0], dtype=np.float64).reshape(*shape, 3),
                                     part.hull)
    moves = shell_moves(grids, pairs, records, mm_per_unit)
    by_name = {p.name: p for p in plates}
    moved = []
    for name, offsets in sorted(moves.items()):
        size = np.linalg.norm(offsets, axis=2)
        if size.max() <= 1e-6 * by_name[name].hull.fit_tolerance:
            continue
        part = by_name[name]
        offsets, off = _within_tolerance(grids[name].points, _welded(grids[name].points, offsets), part.hull)
        size = np.linalg.norm(offsets, axis=2)
        neighbours = sorted({q.b if q.a == name else q.a for q in pairs if name in (q.a, q.b)
                             and records[q.b if q.a == name else q.a][0].klass in MOVABLE_NEIGHBOURS})
        largest = float(size.max()) * mm_per_unit
        part.hull.follow = {"offsets": offsets, "neighbours": neighbours, "largest_move_mm": largest,
                            "largest_distance_mm": off * mm_per_unit, "verdict": formed_verdict(part.hull.result)}
        part.hull.result = None
        report.moved[name] = {"largest_move_mm": largest, "largest_distance_mm": off * mm_per_unit,
                              "neighbours": neighbours}
        moved.append(part)
    if moved:
        for part, result in zip(moved, evaluate_many(moved)):
            part.hull.result = result
    return report


def _within_tolerance(points: np.ndarray, offsets: np.ndarray, hull) -> tuple[np.ndarray, float]:
    """The plate's moves (R, C, 3) scaled down where the moved grid would leave the hull by
    more than the fit tolerance, and the moved grid's largest distance from the hull (model
    units). Every given move ends within the tolerance (:func:`_held`) and the blend of them
    stays within their largest along the hull's normal where the hull bends little over a
    plate; where it bends more, the whole field is scaled (the distance is about linear in
    it: the grid lies on the hull)."""
    distance = hull_distance(hull)
    flat = points.reshape(-1, 3)
    off = float(distance(flat + offsets.reshape(-1, 3)).max())
    if off > hull.fit_tolerance:
        offsets = offsets * (hull.fit_tolerance / off)
        off = float(distance(flat + offsets.reshape(-1, 3)).max())
    return offsets, off


def _flats_as_strips(plates: list, records: dict, pairs: list, evaluate_many, mm_per_unit: float,
                     thickness_mm: float, report: FollowReport, measures: EdgeMeasures | None = None) -> dict:
    """Flat plates that step from a flat or strip neighbour by more than the limit developed
    again as strips (``part.hull.as_strip``): kept where one fits and steps less from those
    neighbours than the plane did (the worst step first, against the neighbours as they are
    then), else flat as before. The records with the strips kept.

    Two flat plates over a hull that twists step at their shared corners by about twice
    their planes' distance from it there, whatever planes the joint programme picks within
    the tolerance (their residuals change sign across the edge); a strip through the plate's
    seams lies on the hull along them, and a nearly flat plate's strip bends little (a
    best-fit strip, or one whose rulings run butt to butt, does not: hence the measure). The
    flat + strip share is unchanged; the plate is rolled instead of cut flat."""
    from .planner import honest_class

    wanted: dict = {}
    for q in pairs:
        kinds = (records[q.a][0].klass, records[q.b][0].klass)
        if q.step_max <= q.limit or FORMED in kinds:
            continue
        for name, other, kind in ((q.a, q.b, kinds[0]), (q.b, q.a, kinds[1])):
            # a plate cut at its face's trim stays flat: a strip is not cut at a trim (its
            # outline is the trimmed strip's), so it would be delivered past the trim
            if kind == "flat" and records[name][1].hull.trim is None:
                entry = wanted.setdefault(name, {"step_mm": 0.0, "neighbours": []})
                entry["step_mm"] = max(entry["step_mm"], float(q.step_max))
                entry["neighbours"] = sorted({*entry["neighbours"], other})
    asked = sorted((p for p in plates if p.name in wanted), key=lambda p: (-wanted[p.name]["step_mm"], p.name))
    if not asked:
        return records
    neighbours = {p.name: {q.b if q.a == p.name else q.a for q in pairs if p.name in (q.a, q.b)} for p in asked}
    developed = {p.name: (p.hull.result, p.hull.plane) for p in asked}
    for part in asked:
        part.hull.as_strip, part.hull.plane, part.hull.result = wanted[part.name], None, None
    current = dict(records)
    for part, result in zip(asked, evaluate_many(asked)):
        strip = honest_class(result) == "developable"
        edges = kept_edges(result) if strip else None
        if edges is None:
            klass = result.figures.get("plate_class") or {}
            why = klass.get("strip_not_delivered_because") or result.reason or f"delivered {klass.get('class')}"
        else:
            before = _worst_step(current, part.name, neighbours[part.name], mm_per_unit, thickness_mm, measures)
            trial = dict(current, **{part.name: (edges, part)})
            after = _worst_step(trial, part.name, neighbours[part.name], mm_per_unit, thickness_mm, measures)
            if after < before:
                part.hull.result, current = result, trial
                report.as_strips[part.name] = dict(wanted[part.name], step_after_mm=after)
                continue
            why = (f"its strip steps {after:.3g} mm from a flat or strip neighbour, its plane {before:.3g} mm "
                   f"(the limit {min(q.limit for q in pairs if part.name in (q.a, q.b)):.3g} mm)")
        part.hull.as_strip = None
        part.hull.result, part.hull.plane = developed[part.name]
        report.kept_flat[part.name] = why
    return current


def _hold_stepping(plates: list, records: dict, pairs: list, evaluate_many, mm_per_unit: float,
                   thickness_mm: float, report: FollowReport,
                   measures: EdgeMeasures | None = None) -> tuple[dict, list]:
    """Plates held on the hull for the steps the joint programme left between flat and strip
    neighbours (``part.hull.held``, as :mod:`.repair` holds them), the fewest square metres
    that hold one plate of every such pair (:func:`_cover`). A plate held the first time stays
    flat or a strip where that keeps its edges within half the pair's limit of the hull; held
    again, or else, it is developed on the hull, a formed plate the forming then shapes to
    meet its neighbours, so its steps go with it. HOLD_ROUNDS rounds, measured again after
    each. The records and pairs after."""
    from .planner import honest_class
    from .repair import held_record

    by_name = {p.name: p for p in plates}
    for round_no in range(1, HOLD_ROUNDS + 1):
        stepping = [q for q in pairs if q.step_max > q.limit and FORMED not in (records[q.a][0].klass,
                                                                                records[q.b][0].klass)]
        stepping += junction_steps(records, pairs, mm_per_unit, FORMED, MOVABLE_NEIGHBOURS)
        chosen = {name: held_record(pair, side, records, mm_per_unit, round_no, "strake.hold_steps (fit_up: follow)",
                                    "held for a step (strake.hold_steps)", _meets(pair, side))
                  for name, (pair, side) in _cover(stepping, records, mm_per_unit, set(report.hold_failed)).items()}
        if not chosen:
            break
        held_parts = [by_name[name] for name in sorted(chosen)]
        before = {p.name: (p.hull.result, p.hull.plane, p.hull.held) for p in held_parts}
        for part in held_parts:
            part.hull.held, part.hull.plane, part.hull.result = chosen[part.name], None, None
        for part, result in zip(held_parts, evaluate_many(held_parts)):
            if not result.ok or kept_edges(result) is None:
                # a plate that cannot be developed held stays as it was (the pair stays untaken)
                part.hull.result, part.hull.plane, part.hull.held = before[part.name]
                report.hold_failed[part.name] = result.reason or "the held plate has no edges to measure"
                continue
            part.hull.result = result
            held = chosen[part.name]
            # what the joint programme or the flat-as-strip step made of it is gone with its development
            was = [what for what, entries in (("joint_plane", report.planes), ("strip_moved", report.strips),
                                              ("strip_move_shortened", report.shortened),
                                              ("flat_as_strip", report.as_strips),
                                              ("erection_pull", report.pulled)) if entries.pop(part.name, None)]
            report.held[part.name] = {"round": round_no, "class_before": held["class_before"],
                                      "class_after": honest_class(result), "edge": held["edge"],
                                      "neighbour": held["neighbour"], "step_mm": held["step_mm"],
                                      "edge_deviation_before_mm": held["edge_deviation_before_mm"],
                                      "undone": was, **({"junction": held["junction"]} if "junction" in held else {})}
        records = _records(plates, records, set(chosen))
        pairs, _ = shared_edges(records, mm_per_unit, thickness_mm, measures)
    return records, pairs


def _meets(pair, side: tuple) -> str | None:
    """How a held plate's record says it meets the other plate of a junction step (None: the
    pair's shared edge)."""
    if not isinstance(pair, JunctionStep):
        return None
    if pair.where == "edge":  # a T: the step counted is the ends' whole distance
        return (f"ends {pair.step_max:.2f} mm from {side[3]}'s, where the edge they share meets formed plate "
                f"{pair.formed}'s, whose edge steps from one of them by up to that")
    return (f"ends {2.0 * pair.step_max:.2f} mm from {side[3]}'s at formed plate {pair.formed}'s corner, which "
            "takes between them")


def _cover(stepping: list, records: dict, mm_per_unit: float, failed: set = frozenset()) -> dict:
    """{plate: (the worst stepping pair it was chosen to cover, its side of it)}: plates that
    hold one plate of every stepping pair they can, chosen greedily by stepping pairs covered
    per square metre of region (a plate between two stepping neighbours covers both pairs: the
    steel a step costs is the held plate's share of flat or strip; ties to the name); none of
    the ``failed`` ones (held before, their development failed). A plate whose region reports
    no area counts as 1 m2."""
    from .repair import holdable_sides

    options: dict = {}
    for index, pair in enumerate(stepping):
        for side in holdable_sides(pair, records, mm_per_unit):
            if side[1] not in failed:
                options.setdefault(side[1], []).append((index, pair, side))
    area = {name: float((records[name][1].hull.result.figures.get("region") or {}).get("area_m2") or 1.0)
            for name in options}
    left, chosen = set(range(len(stepping))), {}
    while left:
        count = {name: sum(i in left for i, _, _ in entries) for name, entries in options.items() if name not in chosen}
        name = max((n for n in count if count[n]), key=lambda n: (count[n] / area[n], n), default=None)
        if name is None:
            break
        mine = [(i, pair, side) for i, pair, side in options[name] if i in left]
        _, pair, side = max(mine, key=lambda entry: entry[1].step_max)
        chosen[name] = (pair, side)
        left -= {i for i, _, _ in mine}
    return chosen


def _worst_step(records: dict, name: str, neighbours: set, mm_per_unit: float, thickness_mm: float,
                measures: EdgeMeasures | None = None) -> float:
    """The largest step (mm) of plate ``name`` from its flat and strip ``neighbours`` as
    ``records`` has them."""
    near = {n: records[n] for n in {name, *neighbours}
            if n in records and (n == name or records[n][0].klass in MOVABLE_NEIGHBOURS)}
    pairs, apart = shared_edges(near, mm_per_unit, thickness_mm, measures)
    return max((q.step_max for q in pairs + apart if name in (q.a, q.b)), default=0.0)


def _move_jointly(plates: list, records: dict, pairs: list, evaluate_many, mm_per_unit: float, strips: bool,
                  report: FollowReport) -> bool:
    """The joint programme's moves applied: flat plates evaluated again on their planes,
    strips moved as delivered (unless the move takes one beyond its tolerance). Whether any
    plate moved."""
    from .rigid import moved_rigidly, shortened

    try:
        moves = joint_moves(records, pairs, mm_per_unit, strips=strips)
    except Exception as exc:  # noqa: BLE001 - the plates stay as developed; the run says why
        report.joint_error = f"{type(exc).__name__}: {exc}"
        return False
    flats, developed = [], {}
    for part in plates:
        move = moves.get(part.name)
        if move is None:
            continue
        if move["kind"] == "plane":
            developed[part.name] = part.hull.result
            part.hull.plane = {"normal": move["normal"], "point": move["point"]}
            part.hull.result = None
            flats.append(part)
            continue
        # the programme holds a strip's grid of points within the tolerance, to first order:
        # where the whole plate would leave it, as much of the move as keeps it within
        for share in SHARES:
            moved = moved_rigidly(part.hull.result, shortened(move, share) if share < 1.0 else move)
            if moved.figures["hull_fit"]["passed"]:
                part.hull.result = moved
                report.strips[part.name] = moved.figures["rigid_move"]["largest_move_mm"]
                if share < 1.0:
                    report.shortened[part.name] = share
                break
        else:
            report.refused.append(part.name)
    for part, result in zip(flats, evaluate_many(flats)):
        if result.ok and (result.figures.get("plate_class") or {}).get("joint_plane"):
            part.hull.result = result
            report.planes[part.name] = moves[part.name]["largest_move_mm"]
        else:  # not flat on its plane after all (round-off at the tolerance): as developed
            part.hull.plane, part.hull.result = None, developed[part.name]
            report.refused.append(part.name)
    return bool(report.planes or report.strips)


def _records(plates: list, known: dict | None = None, changed: set = frozenset()) -> dict:
    """{plate: (PlateEdges, part)} of the plates whose result has edges; those in ``known``
    and not ``changed`` are taken from it."""
    records = {}
    for part in plates:
        if known is not None and part.name not in changed:
            if part.name in known:
                records[part.name] = known[part.name]
            continue
        result = part.hull.result
        edges = None if result is None else kept_edges(result)
        if edges is not None:
            records[part.name] = (edges, part)
    return records


def _welded(points: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Moves (R, C, 3) with the grid points that are one point (a collapsed seam end: the
    plate's mesh welds them, :func:`flatten.patch.weld`) given one move, their first point's:
    the developed mesh and the pin jig's mesh then move alike."""
    from flatten.patch import weld

    rows, cols = points.shape[:2]
    flat = points.reshape(-1, 3)
    size = float(np.ptp(flat, axis=0).max())
    faces = np.arange(rows * cols).reshape(rows, cols)
    faces = np.column_stack([faces[:-1, :-1].ravel(), faces[:-1, 1:].ravel(), faces[1:, 1:].ravel()])
    _, _, index = weld(flat, faces, 1e-9 * size)
    first = first_of_groups(index)
    return offsets.reshape(-1, 3)[first[index]].reshape(offsets.shape)


def first_of_groups(index: np.ndarray) -> np.ndarray:
    """For each group number 0..G-1 of ``index`` (N,), the first position holding it (G,)."""
    _, first = np.unique(index, return_index=True)
    return first


class _PlateGrid:
    """A formed plate's region grid (R, C, 3) on the hull, its boundary ring and side codes,
    and the grid line (flat indices, in order, corners included) of each of its sides."""

    def __init__(self, name: str, points: np.ndarray, hull):
        self.name, self.points, self.hull = name, points, hull
        self.distance = hull_distance(hull)  # resolved once: every anchor of the plate measures with it
        rows, cols = points.shape[:2]
        self.ring, self.codes = _grid_ring(points, hull, hull.fit_tolerance)
        idx = np.arange(rows * cols).reshape(rows, cols)
        self.lines = {"seam0": idx[0], "seam1": idx[-1]}
        for column, inward in ((0, 1), (cols - 1, cols - 2)):
            on = self.codes[(self.ring % cols == column) & (self.codes >= 2) & (self.codes <= 3)]
            if len(on):
                self.lines[SIDES_BY_CODE[int(np.bincount(on).argmax())]] = idx[:, column]
        self.inward = {"seam0": cols, "seam1": -cols, 0: 1, cols - 1: -1}
        self.flat = points.reshape(-1, 3)
        self.corners = np.unique([0, cols - 1, (rows - 1) * cols, rows * cols - 1])  # flat indices

    def free_corners(self, paired: set) -> list:
        """Flat indices of the grid's corners on a side that meets no neighbour (``paired``:
        the sides that do; an end column that is no butt is the hull's end)."""
        rows, cols = self.points.shape[:2]
        column_side = {int(line[0] % cols): side for side, line in self.lines.items() if side.startswith("butt")}
        out = []
        for row, seam in ((0, "seam0"), (rows - 1, "seam1")):
            for column in (0, cols - 1):
                if seam not in paired or column_side.get(column) not in paired:
                    out.append(row * cols + column)
        return out

    def inward_of(self, side: str, index: np.ndarray) -> np.ndarray:
        """The grid points one row (a seam) or column (a butt) inside the given points of a side."""
        cols = self.points.shape[1]
        if side in ("seam0", "seam1"):
            return index + self.inward[side]
        column = int(self.lines[side][0] % cols)
        return index + self.inward[column]


SIDES_BY_CODE = {code: side for side, code in CODES.items()}


def shell_moves(grids: dict, pairs: list, records: dict, mm_per_unit: float) -> dict:
    """{formed plate: moves (R, C, 3), model units} of every formed plate's region grid: its
    edge points on a flat or strip neighbour's edge moved onto it (ending within the fit
    tolerance of the hull, :func:`_held`),
    those on a formed neighbour's edge that steps from it over the limit as developed moved
    halfway to it where no flat or strip neighbour holds them, corners at junctions and the
    edge points beside a junction on an edge as :func:`_junction_corners` and
    :func:`_edges_through_junctions` say, the shell's free edges still, and the
    discrete Laplace equation everywhere else, over all the formed plates' grids joined at
    their other shared edges."""
    names = sorted(grids)
    start, total = {}, 0
    for name in names:
        start[name] = total
        total += grids[name].flat.shape[0]
    if not total:
        return {}
    fixed = np.zeros(total, dtype=bool)
    value = np.zeros((total, 3))
    best = np.full(total, np.inf)
    across = {}  # unknown -> its neighbour across a shared edge: ((another plate's unknown, weight), ...)
    paired = {name: set() for name in names}  # the sides each plate shares with a neighbour
    halfways = []  # (plate, side, the formed neighbour's edge, offset, reach, share): two formed plates that step
    for pair in pairs:
        # two formed plates that step as developed (two faces that disagree where a plan cut
        # them; rows of one face that part at a trim or the grids' chords): each is formed to
        # meet the other halfway, not joined as it lies (joined, they would keep the step)
        halfway = pair.a in grids and pair.b in grids and pair.step_max > pair.limit
        for me, mine, other, theirs in ((pair.a, pair.side_a, pair.b, pair.side_b),
                                        (pair.b, pair.side_b, pair.a, pair.side_a)):
            if me not in grids or mine not in CODES:
                # (a formed plate's TRIM edge cuts through its grid: no grid line to form onto
                # the neighbour's edge; the plate stays on the hull there)
                continue
            paired[me].add(mine)
            plate = grids[me]
            if records[other][0].klass in MOVABLE_NEIGHBOURS:
                _anchor(plate, mine, records[other][0].edge(theirs), mm_per_unit, start[me], fixed, value, best)
            elif halfway:  # their corners too: the step may exceed twice the tolerance
                reach = max(4.0 * plate.hull.fit_tolerance, 1.01 * pair.step_max / mm_per_unit)
                # all the way where the other cannot move: a formed plate's TRIM edge (no grid line)
                share = 0.5 if theirs in CODES else 1.0
                halfways.append((plate, mine, records[other][0].edge(theirs), start[me], reach, share))
            elif other in grids and theirs in grids[other].lines and mine in plate.lines:
                _join(plate, mine, grids[other], theirs, start[me], start[other], across)
    junctions = _junction_corners(grids, names, start, pairs, records, fixed, value, best)
    _edges_through_junctions(grids, names, start, junctions, paired, records, fixed, value)
    # after the flat and strip neighbours' claims, which they keep: a formed plate is shaped to
    # meet those, and can meet its formed neighbour halfway only where nothing else holds it
    best = np.where(fixed, -np.inf, best)
    for plate, mine, edge, offset, reach, share in halfways:
        _anchor(plate, mine, edge, mm_per_unit, offset, fixed, value, best, share=share, reach=reach,
                corner_reach=reach)
    # the ring's points that meet nobody (the shell's free edges) stay on the hull, and so do
    # the corners on a free edge that the plate's other side joins to a formed neighbour
    for name in names:
        plate = grids[name]
        ring = start[name] + plate.ring
        free = ~fixed[ring] & (np.array([r not in across for r in ring]) | np.isin(plate.ring,
                                                                                   plate.free_corners(paired[name])))
        fixed[ring[free]] = True
        # a plate cut at its trim keeps the corners where its TRIM edge ends on the hull: moved
        # (to a neighbour's edge end at a junction), they would carry the cut off the trim line
        # that the plate across the trim meets (KVLCC2's 33 mm leftover: 6.7 mm along its butt)
        pinned = start[name] + _trim_corners(plate, records[name][0] if name in records else None)
        fixed[pinned] = True
        value[pinned] = 0.0
    return _solve(grids, names, start, total, fixed, value, across)


TRIM_CORNER = 0.1  # fit tolerances: a grid corner this near where a plate's TRIM edge ends is that end


def _trim_corners(plate: _PlateGrid, edges) -> np.ndarray:
    """Flat indices of the plate's grid corners where its TRIM edge ends (none without one;
    the edge's end is an outline vertex cut from the region in (u, v), a round-off or a
    cell's chord off the corner: 0.02 mm on KVLCC2's leftover)."""
    trim = None if edges is None else edges.edge(TRIM)
    if trim is None:
        return np.zeros(0, dtype=int)
    corners = plate.corners
    gap = np.linalg.norm(plate.flat[corners][:, None, :] - trim.points3[[0, -1]][None], axis=2).min(axis=1)
    return corners[gap <= TRIM_CORNER * plate.hull.fit_tolerance]


def _junction_corners(grids: dict, names: list, start: dict, pairs: list, records: dict, fixed, value,
                      best) -> list:
    """The formed plates' corners at junctions with flat or strip plates' edge ends moved to
    one point each (:func:`.junction.junction_moves`), in place of what one edge's end claimed
    for them (:func:`_anchor`): two flat or strip corners a few millimetres apart at one
    junction would otherwise leave a formed plate stepping by the whole spread from one of
    them, or two formed plates from each other. Each move ends within the tolerance of the
    hull (:func:`_held`). Returns the junctions a formed plate's edge may run past, each as
    (the formed plate whose corner went there or None, the point (3,)): each corner moved,
    where it now lies, and each meeting of flat or strip plates' edge ends, at the centre of
    the smallest ball holding them."""
    ends, owners = [], []
    for name, (edges, _) in records.items():
        if edges.klass in MOVABLE_NEIGHBOURS:
            for edge in (edges.edge(side) for side in SIDES):
                if edge is not None:
                    ends += [edge.points3[0], edge.points3[-1]]
                    owners += [name, name]
    if not ends:
        return []
    welded = {name: set() for name in names}
    for q in pairs:
        for me, other in ((q.a, q.b), (q.b, q.a)):
            if me in welded:
                welded[me].add(other)
    index, points, reach, tolerance, plates, neighbours = [], [], [], [], [], []
    for name in names:
        plate = grids[name]
        for k in plate.corners:
            index.append(start[name] + k)
            points.append(plate.flat[k])
            reach.append(2.0 * plate.hull.fit_tolerance)
            tolerance.append(plate.hull.fit_tolerance)
            plates.append(name)
            neighbours.append(welded[name])
    points, tolerance, index, reach = np.array(points), np.array(tolerance), np.array(index), np.array(reach)
    found, targets = junction_moves(points, reach, plates, neighbours, np.array(ends), owners)
    move = targets[found] - points[found]
    size = np.linalg.norm(move, axis=1)
    owner = np.array(plates)[found]
    for name in np.unique(owner):
        mine = owner == name
        plate = grids[name]
        move[mine] = _held(points[found][mine], move[mine], plate.hull.fit_tolerance, plate.distance)
    where = index[found]
    fixed[where] = True
    value[where] = move
    best[where] = np.minimum(size, tolerance[found])
    return [*zip(owner, points[found] + move), *_end_junctions(np.array(ends), owners, float(reach.max()))]


def _end_junctions(ends: np.ndarray, owners: list, reach: float) -> list:
    """(None, the centre of the smallest ball holding them (3,)) of each group of flat or strip
    plates' edge ends (E, 3): the ends within ``reach`` (model units) of one end, of two
    plates or more, in a ball of radius at most half of it (as :func:`.junction.junction_moves`)."""
    from scipy.spatial import cKDTree

    out, seen = [], set()
    for hits in cKDTree(ends).query_ball_point(ends, r=reach):
        group = tuple(sorted(hits))
        if group in seen or len({owners[k] for k in group}) < 2:
            continue
        seen.add(group)
        centre, radius = smallest_ball(ends[list(group)])
        if radius <= 0.5 * reach:
            out.append((None, centre))
    return out


def _edges_through_junctions(grids: dict, names: list, start: dict, junctions: list, paired: dict, records: dict,
                             fixed, value) -> None:
    """A formed plate's edge that runs past a junction (:func:`_junction_corners`: where a
    formed plate's corner went, or where flat or strip plates' edge ends meet, on this
    plate's edge: a T) passes through it: its edge point nearer the junction is moved so
    that the chord to the next point meets it (the move's part along the chord left out: it
    would only slide the point), where no flat or strip neighbour claims that point (the
    point nearest the junction finds its closest point at their edges' ends, which are
    another neighbour's). Left to the Laplace equation, the point is a mean of its
    neighbours while the corners beside it are held: KCS's formed plate above a formed plate
    and a strip that end together on its seam stepped 4.39 mm from both at the junction, its
    point 12.7 mm short of it; in KCS's yard plan a formed plate across a butt from two strips
    that end together there, 5.43 mm. Only a side the plate shares with a neighbour
    (``paired``) runs past a junction: the shell's free edges stay on the hull, and so do the
    corners where a plate's TRIM edge ends. ``junctions``: (the formed plate whose corner
    went there or None, the point (3,))."""
    if not junctions:
        return
    reach = np.array([2.0 * grids[n].hull.fit_tolerance for n in names])[:, None]
    low = np.array([grids[n].flat[grids[n].ring].min(axis=0) for n in names]) - reach
    high = np.array([grids[n].flat[grids[n].ring].max(axis=0) for n in names]) + reach
    edges = {}  # a plate's ring segments, worked out once for all the junctions near it
    for owner, target in junctions:
        for k in np.flatnonzero(np.all((low <= target) & (target <= high), axis=1)):
            name = names[k]
            if name == owner:
                continue
            plate = grids[name]
            if name not in edges:
                edges[name] = _ring_segments(plate, paired[name], records[name][0] if name in records else None)
            a, ab, length, usable, pinned, size = edges[name]
            f = np.clip(np.einsum("ij,ij->i", target - a, ab) / np.maximum(length**2, 1e-300), 0.0, 1.0)
            feet = a + f[:, None] * ab
            gap = np.where(usable, np.linalg.norm(feet - target, axis=1), np.inf)
            segment = int(np.argmin(gap))
            if gap[segment] > reach[k, 0]:
                continue  # the junction is not on this plate's edge
            ring = plate.ring
            near, far, w = ring[segment], ring[(segment + 1) % len(ring)], float(f[segment])
            if w > 0.5:
                near, far, w = far, near, 1.0 - w
            at, beyond = start[name] + near, start[name] + far
            at_corner = np.linalg.norm(plate.flat[plate.corners] - plate.flat[near], axis=1).min() <= 1e-9 * size
            if at_corner or fixed[at] or np.isin([near, far], pinned).any():
                continue  # a corner is the junction rule's, a claim made stands, a trim's corner stays
            far_moved = plate.flat[far] + (value[beyond] if fixed[beyond] else target - feet[segment])
            mine = (target - w * far_moved) / (1.0 - w) - plate.flat[near]
            along = ab[segment] / length[segment]
            mine = mine - (mine @ along) * along
            fixed[at] = True
            value[at] = _held(plate.flat[near][None], mine[None], plate.hull.fit_tolerance, plate.distance)[0]


def _ring_segments(plate: _PlateGrid, paired: set, edges) -> tuple:
    """A formed plate's ring segments (each from a ring point to the next): their starts (N, 3),
    vectors (N, 3) and lengths (N,), which of them lie on a side the plate shares with a
    neighbour (``paired``; both ends, and not a collapsed seam end's run of one point), the
    grid corners where its TRIM edge ends (``edges``: its PlateEdges) and the ring's size."""
    ring = plate.ring
    a = plate.flat[ring]
    ab = plate.flat[np.roll(ring, -1)] - a
    length = np.linalg.norm(ab, axis=1)
    size = float(np.ptp(a, axis=0).max())
    sides = [CODES[side] for side in paired if side in CODES]
    usable = np.isin(plate.codes, sides) & np.isin(np.roll(plate.codes, -1), sides) & (length > 1e-9 * size)
    return a, ab, length, usable, _trim_corners(plate, edges), size


def _held(points: np.ndarray, move: np.ndarray, tolerance: float, distance) -> np.ndarray:
    """Moves (N, 3) of hull points (N, 3) shortened so that each ends within the fit
    tolerance of the hull (a formed plate stays within it) and is at most SLIDE tolerances
    long. The tolerance bounds the distance from the hull, not the move: a strip placed by
    the joint programme lies up to 0.95 of it off the hull and up to all of it along the
    hull, so its edge can lie 1.4 tolerances from the formed plate's edge point it meets
    while within the tolerance of the hull (a move shortened to the tolerance left KCS's
    and KVLCC2's formed plates stepping 3-5 mm from strips there). ``distance``: the plate's
    :func:`hull_distance`."""
    size = np.linalg.norm(move, axis=1)
    move = move * np.minimum(1.0, SLIDE * tolerance / np.maximum(size, 1e-300))[:, None]
    off = distance(points + move)
    # the points lie on the hull, so a move's distance from it is about its normal part
    return move * np.minimum(1.0, tolerance / np.maximum(off, 1e-300))[:, None]


def _anchor(plate: _PlateGrid, side: str, edge, mm_per_unit: float, offset: int, fixed, value, best,
            share: float = 1.0, reach: float | None = None, corner_reach: float | None = None) -> None:
    """Moves of the plate's points on ``side`` (and its corners) onto a flat or strip
    neighbour's edge: closest points, kept where the closest point is not the edge's end
    (a point beyond it is another neighbour's) and within ``reach`` (default four
    tolerances: a plate and a neighbour that part further are not one edge there), a corner
    within ``corner_reach`` (default twice the tolerance: its end, the neighbour's corner, up
    to the tolerance off the hull and along it), and moved to the edge's end itself when that
    end is within ``corner_reach`` (a junction of plates); ``share`` of the way (a half: two formed
    plates meeting halfway), each move ending within the tolerance of the hull (:func:`_held`);
    the smaller claim where two
    neighbours claim a point."""
    if edge is None:
        return
    hull = plate.hull
    reach = 4.0 * hull.fit_tolerance if reach is None else reach
    corner_reach = 2.0 * hull.fit_tolerance if corner_reach is None else corner_reach
    corner = np.isin(plate.ring, plate.corners)
    mine = np.flatnonzero((plate.codes == CODES[side]) | corner)
    dense = _dense(edge, SAMPLE_MM / mm_per_unit)
    points = plate.flat[plate.ring[mine]]
    feet, s = closest_on(points, dense)
    # a corner where the neighbour's edge ends (four plates' junction, the neighbour's corner
    # within reach) goes to that end: the closest point along the edge there need not be
    # where the plate across the other edge meets its own neighbour (a strip's butt edge can
    # pass within 1 mm of the hull's corner while its corner lies 5 mm off it), and two
    # formed plates sent to different points of one junction step by their distance
    ends = dense.p3[[0, -1]]
    to_end = np.linalg.norm(points[:, None, :] - ends[None], axis=2)
    nearest_end = np.argmin(to_end, axis=1)
    at_end = corner[mine] & (to_end[np.arange(len(points)), nearest_end] <= corner_reach)
    feet = np.where(at_end[:, None], ends[nearest_end], feet)
    apart = np.linalg.norm(feet - points, axis=1)
    inside = (s > dense.s3[0] + 1e-9 * dense.s3[-1]) & (s < dense.s3[-1] * (1.0 - 1e-9))
    taken = np.where(corner[mine], apart <= corner_reach,
                     inside & (plate.codes[mine] == CODES[side]) & (apart <= reach))
    move, size = share * (feet - points), share * apart
    move = _held(points, move, hull.fit_tolerance, plate.distance)
    where = offset + plate.ring[mine]
    better = taken & (size < best[where])
    fixed[where[better]] = True
    value[where[better]] = move[better]
    best[where[better]] = size[better]


def _join(plate: _PlateGrid, side: str, other: _PlateGrid, other_side: str, offset: int, other_offset: int,
          across: dict) -> None:
    """Neighbours across the edge of the plate's points on a side it shares with another
    formed plate, into ``across`` ({point: ((index, weight), (index, weight))}): the other
    plate's two points one row inside its edge at the ends of the edge segment nearest the
    point, weighted as the point's foot on that segment. A point is joined when the segment
    passes within the tolerance plus a quarter of its length (the chord of a curved edge
    stands off it by its sagitta, 5 mm for 200 mm at a 1 m radius), and beyond the edge's
    ends within the tolerance."""
    line, theirs = plate.lines[side], other.lines[other_side]
    a, b = other.flat[theirs[:-1]], other.flat[theirs[1:]]
    points = plate.flat[line]
    ab = b - a
    f = np.clip(np.einsum("pij,ij->pi", points[:, None, :] - a[None], ab)
                / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
    gap = np.linalg.norm(a[None] + f[..., None] * ab[None] - points[:, None, :], axis=2)
    segment = np.argmin(gap, axis=1)
    here = np.arange(len(line))
    foot = f[here, segment]
    beyond = ((segment == 0) & (foot <= 0.0)) | ((segment == len(theirs) - 2) & (foot >= 1.0))
    reach = plate.hull.fit_tolerance + np.where(beyond, 0.0, 0.25 * np.linalg.norm(ab[segment], axis=1))
    near = gap[here, segment] <= reach
    inner = other_offset + other.inward_of(other_side, theirs)
    for mine, k, w in zip(offset + line[near], segment[near], foot[near]):
        across.setdefault(int(mine), ((int(inner[k]), 1.0 - float(w)), (int(inner[k + 1]), float(w))))


def _solve(grids: dict, names: list, start: dict, total: int, fixed, value, across: dict) -> dict:
    """The joined discrete Laplace equation: fixed points keep their value, every other point
    is the mean of its grid neighbours (and of its neighbour across a shared edge)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import spsolve

    rows_, cols_ = [], []
    degree = np.zeros(total)
    for name in names:
        r, c = grids[name].points.shape[:2]
        idx = start[name] + np.arange(r * c).reshape(r, c)
        for a, b in ((idx[:, :-1], idx[:, 1:]), (idx[:-1, :], idx[1:, :])):
            a, b = a.ravel(), b.ravel()
            rows_ += [a, b]
            cols_ += [b, a]
            np.add.at(degree, a, 1.0)
            np.add.at(degree, b, 1.0)
    weights_ = [np.ones(sum(len(r) for r in rows_))]
    if across:
        links = [(mine, there, w) for mine, pair in across.items() for there, w in pair]
        mine = np.array([m for m, _, _ in links], dtype=np.int64)
        rows_.append(mine)
        cols_.append(np.array([t for _, t, _ in links], dtype=np.int64))
        weights_.append(np.array([w for _, _, w in links]))
        np.add.at(degree, np.fromiter(across.keys(), dtype=np.int64), 1.0)
    a = np.concatenate(rows_)
    b = np.concatenate(cols_)
    weight = np.concatenate(weights_)
    free = ~fixed
    number = np.full(total, -1)
    unknown = np.flatnonzero(free)
    number[unknown] = np.arange(len(unknown))
    out = np.where(fixed[:, None], value, 0.0)
    if len(unknown):
        use = free[a]
        a, b, weight = a[use], b[use], weight[use]
        inner = free[b]
        matrix = coo_matrix((np.r_[degree[unknown], -weight[inner]],
                             (np.r_[np.arange(len(unknown)), number[a[inner]]], np.r_[np.arange(len(unknown)),
                                                                                       number[b[inner]]])),
                            shape=(len(unknown), len(unknown))).tocsc()
        rhs = np.zeros((len(unknown), 3))
        np.add.at(rhs, number[a[~inner]], weight[~inner, None] * value[b[~inner]])
        out[unknown] = spsolve(matrix, rhs).reshape(len(unknown), 3)
    return {name: out[start[name]:start[name] + grids[name].flat.shape[0]].reshape(grids[name].points.shape)
            for name in names}
