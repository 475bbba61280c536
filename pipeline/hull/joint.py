"""Fit-up by fitting: the flat plates' planes chosen together, so that shared edges meet.

A flat plate is cut planar and fits the hull on any plane within the fit tolerance of its
region; the minimax plane is one of many. Its edges are its region's edges projected on that
plane, so two flat neighbours, each on its own minimax plane, step from each other at their
shared edge by the difference of their distances from the hull there, up to twice the
tolerance; a flat plate beside a strip steps by the difference of the two plates' distances.
The planes are free within the tolerance, so they are chosen together: one linear programme
over all the shell's flat plates, the strips' edges held where they are.

Each flat plate's plane is z = a x + b y + h in the frame of its present plane (x, y along
it, z along its normal): a vertical distance is never less than the perpendicular one, so
|z_i - a x_i - b y_i - h| <= tolerance at the region's points (the vertices of their convex
hull suffice: the constraint is convex) keeps the plate within the tolerance of the hull in
truth. An edge point then moves along the normal by a x + b y + h (the plane's tilt turns the
direction of projection by a fraction of a milliradian: a few micrometres). At points of
every shared edge of a flat plate with a flat or strip neighbour (both ways, the common part
as :mod:`.fitup` measures it) the gap vector between the edges, taken across the edge (the
part along it is no step), is held inside an octagon (the circle it holds is within 0.92 of
its sides' distance) whose sides stand at 0.45 of the step limit plus two slacks of the
edge: the first up to 0.9 of the limit (no misfit yet), the second beyond it. The programme
minimises the sum over the edges of the second slacks (mm: how far each edge's largest step
exceeds the limit, which is what makes a pair misfit), then, at a tenth of the weight, the
first ones (steps brought well inside the limit where the tolerance allows), and, far below
both, how far the planes move (planes that need not move stay). HiGHS (``scipy.optimize.linprog``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .fitup import SAMPLE_MM, _common, _dense, closest_on

FLAT = "flat"
FIXED_NEIGHBOURS = ("developable",)  # their edges are held: a strip's is its development's
INSIDE_LIMIT = 0.9  # the octagon's sides at this share of the step limit: within it, no misfit
AIM = 0.45  # ... and below this share, no cost: steps are brought down to it where the tolerance allows
NEAR_WEIGHT = 0.1  # a millimetre between the aim and the limit, against one over the limit
POINT_MM = 100.0  # edge points this far apart carry the step constraints
MOVE_WEIGHT = 1e-4  # how far the planes move (model units), against mm of an edge's step excess
RULE = ("the flat plates' planes are chosen together (one linear programme, HiGHS): each within the fit tolerance "
        "of its region, the steps at their shared edges with flat and strip neighbours within the step limit where "
        "the tolerance allows and as little over it as it allows elsewhere; strips are held")


@dataclass(frozen=True)
class _Flat:
    """A flat plate's frame (its present plane) and the points that bound its planes."""

    origin: np.ndarray  # (3,)
    axes: np.ndarray  # (2, 3) in-plane
    normal: np.ndarray  # (3,)
    scale: float  # model units: the plate's size, so that a and b are turns over it
    column: int  # its first variable
    bounding: np.ndarray  # (K, 3) local coordinates of the region's points that bound its planes (convex hull)
    tolerance: float


def joint_planes(records: dict, pairs: list, mm_per_unit: float) -> dict:
    """New planes {flat plate: {"normal": (3,), "point": (3,), "largest_shift_mm"}} for the
    flat plates whose plane the joint programme moves (others keep theirs). ``records``:
    {plate: (PlateEdges, part)} with ``part.hull.result`` evaluated; ``pairs``: their shared
    edges (:func:`.fitup.shared_edges`)."""
    flats, column = {}, 0
    for name, (edges, part) in sorted(records.items()):
        frame = _frame(edges, part, column)
        if frame is not None:
            flats[name] = frame
            column += 3
    if not flats:
        return {}
    normal_of = np.repeat(np.array([flat.normal for flat in flats.values()]), 3, axis=0)  # by column
    rows, rhs, limits = [], [], []
    for pair in pairs:
        ka, kb = records[pair.a][0].klass, records[pair.b][0].klass
        if FLAT not in (ka, kb) or any(k not in (FLAT, *FIXED_NEIGHBOURS) for k in (ka, kb)):
            continue
        ea, eb = records[pair.a][0].edge(pair.side_a), records[pair.b][0].edge(pair.side_b)
        if ea is None or eb is None:
            continue
        limit, slacks = pair.limit / mm_per_unit, len(limits)
        for here, there in ((pair.a, pair.b), (pair.b, pair.a)):
            mine, theirs = (ea, eb) if here == pair.a else (eb, ea)
            got = _gaps(mine, theirs, mm_per_unit)
            if got is None:
                continue
            points, feet, across = got
            for k in range(len(points)):
                row = {}
                for name, point, sign in ((here, points[k], 1.0), (there, feet[k], -1.0)):
                    if name in flats:
                        _add(row, flats[name], point, sign)
                gap = points[k] - feet[k]
                for direction in across[k]:  # the octagon: |(gap + moves) . d| <= aim + the two slacks
                    coeffs = {c: v * float(normal_of[c] @ direction) for c, v in row.items()}
                    base = float(gap @ direction)
                    for sign in (1.0, -1.0):
                        rows.append(({c: sign * v for c, v in coeffs.items()}, slacks))
                        rhs.append(AIM * limit - sign * base)
        limits.append(limit)  # the edge's slacks: how far its largest step exceeds the aim, the limit
    if not limits:
        return {}
    return _solve(flats, rows, rhs, np.asarray(limits), column, mm_per_unit)


def _frame(edges, part, column: int) -> _Flat | None:
    result = part.hull.result
    klass = (result.figures.get("plate_class") or {}) if result is not None else {}
    if edges.klass != FLAT or result.mesh is None or klass.get("normal") is None or klass.get("plane_point") is None:
        return None
    normal = np.asarray(klass["normal"], dtype=np.float64)
    normal = normal / np.linalg.norm(normal)
    origin = np.asarray(klass["plane_point"], dtype=np.float64)
    helper = np.eye(3)[int(np.argmin(np.abs(normal)))]
    first = np.cross(normal, helper)
    first /= np.linalg.norm(first)
    axes = np.array([first, np.cross(normal, first)])
    points = np.asarray(result.mesh[0], dtype=np.float64) - origin
    local = np.column_stack([points @ axes.T, points @ normal])
    scale = float(max(np.ptp(local[:, :2], axis=0).max(), 1e-12))
    from scipy.spatial import ConvexHull, QhullError

    try:
        bounding = local[ConvexHull(local).vertices]
    except QhullError:  # a degenerate set (a region on one plane, say): every point bounds the planes
        bounding = local
    return _Flat(origin, axes, normal, scale, column, bounding, float(part.hull.fit_tolerance))


def _add(row: dict, flat: _Flat, point: np.ndarray, sign: float) -> None:
    """The point's move along the plate's normal, a x + b y + h, into ``row`` {column: coefficient}."""
    x, y = (point - flat.origin) @ flat.axes.T / flat.scale
    for offset, value in enumerate((x, y, 1.0)):
        row[flat.column + offset] = row.get(flat.column + offset, 0.0) + sign * value


def _gaps(mine, theirs, mm_per_unit: float):
    """(points (N, 3) of ``mine`` along the common part, their closest points on ``theirs``
    (N, 3), the four directions across the edge at each (N, 4, 3)); None when the edges do
    not overlap."""
    spacing = SAMPLE_MM / mm_per_unit
    dm, dt = _dense(mine, spacing), _dense(theirs, spacing)
    lo, hi = _common(dm, dt)
    if hi - lo <= 0.0:
        return None
    count = int(np.clip(np.ceil((hi - lo) * mm_per_unit / POINT_MM) + 1, 2, 400))
    s = np.linspace(lo, hi, count)
    points = np.column_stack([np.interp(s, dm.s3, dm.p3[:, k]) for k in range(3)])
    feet, arc = closest_on(points, dt)
    tangent = np.column_stack([np.interp(arc + 1e-3 * spacing, dt.s3, dt.p3[:, k])
                               - np.interp(arc - 1e-3 * spacing, dt.s3, dt.p3[:, k]) for k in range(3)])
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-300)
    helper = np.eye(3)[np.argmin(np.abs(tangent), axis=1)]
    first = np.cross(tangent, helper)
    first /= np.linalg.norm(first, axis=1, keepdims=True)
    second = np.cross(tangent, first)
    angles = np.pi / 4.0 * np.arange(4)
    across = np.cos(angles)[None, :, None] * first[:, None, :] + np.sin(angles)[None, :, None] * second[:, None, :]
    return points, feet, across


def _solve(flats: dict, rows: list, rhs: list, limits: np.ndarray, planes: int, mm_per_unit: float) -> dict:
    from scipy.optimize import linprog
    from scipy.sparse import coo_matrix

    # variables: the planes' (a, b, h) as differences of non-negative parts, then per edge the
    # step's excess over the aim up to the limit's octagon, and its excess beyond that
    slacks = len(limits)
    n = 2 * planes + 2 * slacks
    r_, c_, v_ = [], [], []
    bound = []
    line = 0
    for coeffs, slack in rows:
        for c, v in coeffs.items():
            r_ += [line, line]
            c_ += [c, planes + c]
            v_ += [v, -v]
        r_ += [line, line]
        c_ += [2 * planes + slack, 2 * planes + slacks + slack]
        v_ += [-1.0, -1.0]
        line += 1
    bound += rhs
    for flat in flats.values():  # |z_i - (a x_i + b y_i + h)| <= tolerance at the hull's vertices
        x, y, z = (flat.bounding[:, 0] / flat.scale, flat.bounding[:, 1] / flat.scale, flat.bounding[:, 2])
        for sign in (1.0, -1.0):
            for k in range(len(z)):
                for offset, value in enumerate((x[k], y[k], 1.0)):
                    r_ += [line, line]
                    c_ += [flat.column + offset, planes + flat.column + offset]
                    v_ += [sign * value, -sign * value]
                bound.append(flat.tolerance * (1.0 - 1e-9) + sign * z[k])
                line += 1
    matrix = coo_matrix((v_, (r_, c_)), shape=(line, n)).tocsr()
    cost = np.r_[np.full(2 * planes, MOVE_WEIGHT), np.full(slacks, NEAR_WEIGHT * mm_per_unit),
                 np.full(slacks, mm_per_unit)]
    bounds = [(0, None)] * (2 * planes) + [(0, (INSIDE_LIMIT - AIM) * limit) for limit in limits] + [(0, None)] * slacks
    got = linprog(cost, A_ub=matrix, b_ub=np.asarray(bound), bounds=bounds, method="highs")
    if not got.success:
        return {}
    x = got.x[:planes] - got.x[planes:2 * planes]
    out = {}
    for name, flat in flats.items():
        a, b, h = x[flat.column:flat.column + 3]
        x_, y_ = flat.bounding[:, 0] / flat.scale, flat.bounding[:, 1] / flat.scale
        shift = float(np.abs(a * x_ + b * y_ + h).max())
        if shift <= 1e-6 * flat.tolerance:
            continue
        normal = flat.normal - (a * flat.axes[0] + b * flat.axes[1]) / flat.scale
        normal /= np.linalg.norm(normal)
        out[name] = {"normal": normal.tolist(), "point": (flat.origin + h * flat.normal).tolist(),
                     "largest_shift_mm": shift * mm_per_unit}
    return out
