"""Junctions of plates: where formed plates' corners meet the ends of flat or strip plates' edges.

A flat or strip plate is delivered within the fit tolerance of the hull, its corners too, so
at a junction of four plates two flat or strip plates' corners may lie a few millimetres
apart even where each meets its edge neighbour within the step limit. A formed plate's corner
there is shaped to one point, and each neighbour across its edges steps from it by that
point's distance from the neighbour's own corner. Sent to the end of one neighbour's edge, it
steps from its other flat or strip neighbour there by their whole spread; the point that
makes the larger of the two steps smallest is the centre of the smallest ball holding their
ends (:func:`smallest_ball`). A formed corner with no flat or strip neighbour at the junction
(its neighbours there formed, the flat or strip plate across from it diagonal) goes where its
formed neighbours' corners go, so that they meet. Where a formed plate's only flat or strip
neighbour there steps from another flat or strip plate (their own pair), each formed plate
still meets its own neighbour: sent between them, both would step where now neither does.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from flatten.metrics import closest_on_polyline

JUNCTION_RULE = ("a formed plate's corner within reach (twice the fit tolerance) of the ends of its flat or strip "
                 "neighbours' edges (a junction) is moved to the centre of the smallest ball holding those ends; a "
                 "formed corner with no flat or strip neighbour there to where its formed neighbours' corners go")


def smallest_ball(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (3,) and radius of the smallest ball holding points (N, 3), N small (the corners
    of a junction: every ball through one, two or three of them is tried; four points on a
    hull are nearly coplanar, where a sphere through them is ill-conditioned and the smallest
    ball is one of those anyway)."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) == 1:
        return points[0].copy(), 0.0
    candidates = [0.5 * (points[i] + points[j]) for i, j in combinations(range(len(points)), 2)]
    candidates += [c for c in (_circumcentre(*points[list(k)]) for k in combinations(range(len(points)), 3))
                   if c is not None]
    centres = np.array(candidates)
    radii = np.linalg.norm(points[None, :, :] - centres[:, None, :], axis=2).max(axis=1)
    best = int(np.argmin(radii))
    return centres[best], float(radii[best])


def _circumcentre(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray | None:
    """The centre of the circle through three points (3,) in space, None when they are (nearly)
    on a line."""
    u, v = b - a, c - a
    w = np.cross(u, v)
    ww = float(w @ w)
    if ww <= 1e-24 * float(u @ u) * float(v @ v):
        return None
    return a + (float(u @ u) * np.cross(v, w) + float(v @ v) * np.cross(w, u)) / (2.0 * ww)


def junction_moves(corners: np.ndarray, reach: np.ndarray, plates: list, neighbours: list, ends: np.ndarray,
                   owners: list) -> tuple[np.ndarray, np.ndarray]:
    """Where formed plates' corners go at junctions. Corners (K, 3), each with its reach (K,),
    its plate's name (K) and the plates its plate shares an edge with (K sets of names); the
    ends (E, 3) of flat and strip plates' edges with the plate each is of (E names); model
    units. A corner with ends of its own neighbours within its reach goes to the centre of the
    smallest ball holding them; then a corner with none, within reach of corners of its
    neighbours that went somewhere, to the centre of the smallest ball holding their targets.
    A ball whose radius exceeds half the corner's reach leaves the corner alone: with the
    reach twice the fit tolerance, ends further apart than the reach are further apart than
    two corners within the tolerance of the hull's one corner can be (two junctions a short
    edge apart). Returns (which corners (K,) bool, their targets (K, 3))."""
    from scipy.spatial import cKDTree

    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 3)
    reach = np.asarray(reach, dtype=np.float64).reshape(-1)
    ends = np.asarray(ends, dtype=np.float64).reshape(-1, 3)
    found = np.zeros(len(corners), dtype=bool)
    targets = np.zeros_like(corners)
    if not len(corners) or not len(ends):
        return found, targets
    for k, hits in enumerate(cKDTree(ends).query_ball_point(corners, r=reach)):
        mine = [e for e in hits if owners[e] in neighbours[k]]
        if mine:
            centre, radius = smallest_ball(ends[mine])
            found[k], targets[k] = radius <= 0.5 * reach[k], centre
    first = found.copy()
    for k, hits in enumerate(cKDTree(corners).query_ball_point(corners, r=reach)):
        mine = [j for j in hits if first[j] and plates[j] in neighbours[k]]
        if not found[k] and mine:
            centre, radius = smallest_ball(targets[mine])
            found[k], targets[k] = radius <= 0.5 * reach[k], centre
    return found, np.where(found[:, None], targets, 0.0)


@dataclass(frozen=True)
class JunctionStep:
    """Two flat or strip plates that both share an edge with a formed plate, whose edges end
    further apart than twice the step limit: at its corner, where they share no edge (the
    formed corner between them, :func:`junction_moves`, steps from each by more than the
    limit), or along its edge where they share one that ends there and does not step itself
    (a T: one of the two overshoots the other along their shared edge, and the formed plate's
    edge, one curve through grid points each formed to meet one of them, steps from one by up
    to their ends' whole distance: counted whole, over the limit). Read as
    a stepping pair by :func:`.follow._hold_stepping` (holding either plate takes the step)."""

    a: str
    b: str
    side_a: str  # the edge of plate a it shares with the formed plate ...
    side_b: str  # ... and of plate b
    step_max: float  # mm: what the formed plate may step from one: half the ends' distance (a corner), all of it (a T)
    limit: float  # mm: the smaller of the two edges' step limits
    formed: str  # the formed plate at whose corner (or along whose edge) they part
    label: str = "junction"
    where: str = "corner"  # "edge": the two share an edge that ends on the formed plate's (a T)
    mismatch: float = 0.0  # no shared edge, no developed lengths to compare


def junction_steps(records: dict, pairs: list, mm: float, formed: str = "formed",
                   movable: tuple = ("flat", "developable")) -> list:
    """[JunctionStep] of the shell's formed plates' corners (the ends of their edges) whose
    flat or strip neighbours' edges (``pairs``: the shared edges) end within reach of it (twice
    the fit tolerance) and more than twice the step limit apart (mm per model unit ``mm``),
    or whose edges run past it within that reach (their closest points count), and of two such
    neighbours that share an edge within its limit (a T on the formed plate's edge) whose
    edges along the formed plate end within reach of each other and more than the limit
    apart; the worst per pair of plates. ``records``: {plate: (PlateEdges, part)}."""
    around: dict = {}
    for q in pairs:
        for me, other, side in ((q.a, q.b, q.side_b), (q.b, q.a, q.side_a)):
            if records[me][0].klass == formed and records[other][0].klass in movable:
                around.setdefault(me, []).append((other, side, q.limit))
    # the pairs that share an edge, with its step: one within the limit can still end apart
    own = {}
    for q in pairs:
        key = frozenset((q.a, q.b))
        own[key] = max(own.get(key, 0.0), float(getattr(q, "step_max", 0.0)))
    worst: dict = {}
    for name, neighbours in sorted(around.items()):
        edges, part = records[name]
        reach = 2.0 * part.hull.fit_tolerance
        corners = np.array([p for edge in edges.edges for p in (edge.points3[0], edge.points3[-1])])
        for (a, side_a, limit_a), (b, side_b, limit_b) in combinations(sorted(neighbours), 2):
            ends_a, ends_b = (records[n][0].edge(s) for n, s in ((a, side_a), (b, side_b)))
            if a == b or ends_a is None or ends_b is None:
                continue
            line_a, line_b = ends_a.points3, ends_b.points3
            ends_a, ends_b = line_a[[0, -1]], line_b[[0, -1]]
            limit, key = min(limit_a, limit_b), (a, b)
            if frozenset((a, b)) in own:
                # a T: the edge the two share ends on the formed plate's edge, whose one point
                # there cannot lie at both their ends (their own step, along their shared
                # edge, may be nil where one overshoots the other along it)
                if own[frozenset((a, b))] > limit:
                    continue  # their own step says it
                gap = float(np.linalg.norm(ends_a[:, None] - ends_b[None], axis=2).min())
                # the formed edge's grid points near the T each meet one of the two (their
                # closest claim, :func:`.follow._anchor`): between them it steps by up to the
                # whole spread (3.2 mm for 5.5 on KVLCC2, 5.7 for 5.9 on KCS), so counted whole
                steps = [(gap * mm, "edge")] if gap <= reach else []
            else:  # the formed corner between them steps by half their spread from each
                steps = []
                for corner in corners:
                    near_a, near_b = (_near(ends, line, corner, reach) for ends, line in ((ends_a, line_a),
                                                                                          (ends_b, line_b)))
                    if len(near_a) and len(near_b):
                        steps.append((0.5 * float(np.linalg.norm(near_a[:, None] - near_b[None], axis=2).min()) * mm,
                                      "corner"))
            for step, where in steps:
                if step > limit and step > (worst[key].step_max if key in worst else 0.0):
                    worst[key] = JunctionStep(a, b, side_a, side_b, step, limit, name, where=where)
    return [worst[key] for key in sorted(worst)]


def _near(ends: np.ndarray, line: np.ndarray, corner: np.ndarray, reach: float) -> np.ndarray:
    """The points (M, 3) of a neighbour's edge that meet a formed plate's corner: its ends
    (2, 3) within ``reach`` of it, else, where the corner lies along the edge (staggered butts
    a few centimetres apart: the edge runs past the corner), the edge's (polyline ``line``,
    (N, 3)) closest point to it when within reach."""
    near = ends[np.linalg.norm(ends - corner, axis=1) <= reach]
    if len(near):
        return near
    foot, gap = closest_on_polyline(corner, line)
    return foot[None] if gap <= reach else near
