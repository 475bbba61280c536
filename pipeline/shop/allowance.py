"""Excess and shrinkage allowance: the cut line outside the net line, edge by edge (mm).

The net outline is the exact development; the shop cuts the plate larger by an allowance
per edge (excess to be trimmed at erection, shrinkage taken up by welding). Each edge of
the net outline is buffered outwards by its own allowance (a one-sided shapely buffer,
mitred joins along the edge) and the corners between two edges are closed by the mitre:
the two offset edges produced along their end tangents until they meet. On a rectangle
with allowances a_c (bottom), a_end (right), a_d (top), a_start (left) the cut line is
the rectangle [-a_start, W + a_end] x [-a_c, H + a_d].
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon

MITRE_LIMIT = 10.0  # a corner's mitre reaches at most this many allowances from the net corner
OVERLAP = 1e-4  # a corner's wedge overlaps its neighbours by this many allowances (far above round-off)


def edge_runs(edges: tuple) -> list[tuple[str, np.ndarray]]:
    """The outline's segments grouped into maximal runs of one edge name, in outline order:
    [(name, segment indices)], the runs following each other around the ring."""
    edges = np.asarray(edges)
    n = len(edges)
    change = np.flatnonzero(edges != np.roll(edges, 1))
    if change.size == 0:
        return [(str(edges[0]), np.arange(n))]
    runs = []
    for k, start in enumerate(change):
        stop = change[(k + 1) % len(change)]
        length = (stop - start) % n or n
        runs.append((str(edges[start]), (start + np.arange(length)) % n))
    return runs


def _signed_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / max(float(np.linalg.norm(v)), 1e-300)


def cut_outline(points: np.ndarray, edges: tuple, allowance: dict) -> np.ndarray:
    """The cut line (M, 2) around the net outline ``points`` (N, 2, not closed, mm) whose
    segment i -> i + 1 lies on edge ``edges[i]``; ``allowance`` {edge name: mm >= 0}
    (missing names: 0). The net outline itself when every allowance is 0. The ring keeps
    the net outline's orientation and starts near its first vertex."""
    widths = {k: float(v) for k, v in allowance.items() if v and v > 0}
    runs = edge_runs(edges)
    if not any(name in widths for name, _ in runs):
        return points
    ccw = _signed_area(points) > 0
    n = len(points)
    pieces = [Polygon(points)]
    # outward = right of the direction of travel on a counter-clockwise ring
    side = -1.0 if ccw else 1.0
    for k, (name, segs) in enumerate(runs):
        width = widths.get(name, 0.0)
        line = points[np.append(segs, (segs[-1] + 1) % n)]
        if width > 0:
            if len(runs) == 1:  # one edge all round: the closed ring's mitred buffer
                return _oriented(np.asarray(Polygon(points).buffer(width, join_style="mitre",
                                                                   mitre_limit=MITRE_LIMIT).exterior.coords)[:-1],
                                 ccw, points[0])
            pieces.append(LineString(line).buffer(side * width, single_sided=True, join_style="mitre",
                                                  mitre_limit=MITRE_LIMIT, cap_style="flat"))
        # the corner at this run's end: the mitre of the two offset edges
        nxt_name, nxt = runs[(k + 1) % len(runs)]
        w2 = widths.get(nxt_name, 0.0)
        if width == 0 and w2 == 0:
            continue
        corner = line[-1]
        t1 = _unit(line[-1] - line[-2])
        t2 = _unit(points[(nxt[0] + 1) % n] - points[nxt[0]])
        turn = t1[0] * t2[1] - t1[1] * t2[0]
        if (turn > 0) != ccw or abs(turn) < 1e-12:  # a concave corner (the buffers overlap) or none
            continue
        n1 = side * np.array([-t1[1], t1[0]])
        n2 = side * np.array([-t2[1], t2[0]])
        p1, p2 = corner + width * n1, corner + w2 * n2
        # p1 + s t1 = p2 - u t2
        s, _ = np.linalg.solve(np.column_stack([t1, t2]), p2 - p1)
        mitre = p1 + s * t1
        limit = MITRE_LIMIT * max(width, w2)
        # the wedge reaches OVERLAP back into both edges' strips and into the net: pieces
        # that only abut along a side computed twice (here and by GEOS) leave a crack of
        # round-off in the union, which then drops the wedge or pinches the cut line
        reach = min(OVERLAP * max(width, w2), 0.25 * float(np.linalg.norm(line[-1] - line[-2])),
                    0.25 * float(np.linalg.norm(points[(nxt[0] + 1) % n] - points[nxt[0]])))
        inner, back, ahead = corner - reach * (n1 + n2), p1 - reach * t1, p2 + reach * t2
        # a needle corner whose mitre would reach farther than the limit is bevelled
        wedge = [inner, back, ahead] if np.linalg.norm(mitre - corner) > limit else [inner, back, mitre, ahead]
        pieces.append(Polygon(wedge).buffer(0))
    union = shapely.unary_union([p for p in pieces if not p.is_empty])
    polygons = [g for g in getattr(union, "geoms", [union]) if g.geom_type == "Polygon"]
    outer = max(polygons, key=lambda g: g.area)
    # the pieces share the net's vertices exactly; a seam of round-off between them would
    # leave a sliver hole, never part of the cut line (the exterior)
    ring = np.asarray(shapely.remove_repeated_points(outer.exterior, 1e-9).coords)[:-1]
    return _oriented(_collinear_free(ring), ccw, points[0])


def _collinear_free(ring: np.ndarray) -> np.ndarray:
    """Drop vertices lying on the straight line of their neighbours (to 1e-9 mm), which
    the union leaves where two pieces meet along a straight edge."""
    prev, nxt = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
    a, b = ring - prev, nxt - ring
    cross = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    straight = (cross <= 1e-9 * np.maximum(np.linalg.norm(a, axis=1) + np.linalg.norm(b, axis=1), 1e-300)) & \
        (np.einsum("ij,ij->i", a, b) > 0)
    return ring[~straight] if (~straight).sum() >= 3 else ring


def _oriented(ring: np.ndarray, ccw: bool, start: np.ndarray) -> np.ndarray:
    if (_signed_area(ring) > 0) != ccw:
        ring = ring[::-1]
    first = int(np.argmin(np.linalg.norm(ring - start, axis=1)))
    return np.roll(ring, -first, axis=0)
