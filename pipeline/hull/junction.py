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
    """Two flat or strip plates that share no edge but both share one with a formed plate,
    whose edges end at its corner further apart than twice the step limit: the formed corner
    between them (:func:`junction_moves`) steps from each by more than the limit. Read as a
    stepping pair by :func:`.follow._hold_stepping` (holding either plate takes the step)."""

    a: str
    b: str
    side_a: str  # the edge of plate a it shares with the formed plate ...
    side_b: str  # ... and of plate b
    step_max: float  # mm: half the ends' distance, what the formed corner steps from each
    limit: float  # mm: the smaller of the two edges' step limits
    formed: str  # the formed plate at whose corner they part
    label: str = "junction"
    mismatch: float = 0.0  # no shared edge, no developed lengths to compare


def junction_steps(records: dict, pairs: list, mm: float, formed: str = "formed",
                   movable: tuple = ("flat", "developable")) -> list:
    """[JunctionStep] of the shell's formed plates' corners (the ends of their edges) whose
    flat or strip neighbours' edges (``pairs``: the shared edges) end within reach of it (twice
    the fit tolerance) and more than twice the step limit apart (mm per model unit ``mm``),
    the worst per pair of plates. ``records``: {plate: (PlateEdges, part)}."""
    around: dict = {}
    for q in pairs:
        for me, other, side in ((q.a, q.b, q.side_b), (q.b, q.a, q.side_a)):
            if records[me][0].klass == formed and records[other][0].klass in movable:
                around.setdefault(me, []).append((other, side, q.limit))
    paired = {frozenset((q.a, q.b)) for q in pairs}
    worst: dict = {}
    for name, neighbours in sorted(around.items()):
        edges, part = records[name]
        reach = 2.0 * part.hull.fit_tolerance
        corners = np.array([p for edge in edges.edges for p in (edge.points3[0], edge.points3[-1])])
        for (a, side_a, limit_a), (b, side_b, limit_b) in combinations(sorted(neighbours), 2):
            if a == b or frozenset((a, b)) in paired:
                continue
            ends_a, ends_b = (records[n][0].edge(s) for n, s in ((a, side_a), (b, side_b)))
            if ends_a is None or ends_b is None:
                continue
            ends_a, ends_b = ends_a.points3[[0, -1]], ends_b.points3[[0, -1]]
            for corner in corners:
                near_a = ends_a[np.linalg.norm(ends_a - corner, axis=1) <= reach]
                near_b = ends_b[np.linalg.norm(ends_b - corner, axis=1) <= reach]
                if not len(near_a) or not len(near_b):
                    continue
                spread = float(np.linalg.norm(near_a[:, None] - near_b[None], axis=2).min()) * mm
                limit = min(limit_a, limit_b)
                key = (a, b)
                if 0.5 * spread > limit and 0.5 * spread > (worst[key].step_max if key in worst else 0.0):
                    worst[key] = JunctionStep(a, b, side_a, side_b, 0.5 * spread, limit, name)
    return [worst[key] for key in sorted(worst)]
