"""Fit-up by fitting: the flat plates' planes and the strips' places chosen together, so
that shared edges meet.

A flat plate is cut planar and fits the hull on any plane within the fit tolerance of its
region; the minimax plane is one of many. Its edges are its region's edges projected on that
plane, so two flat neighbours, each on its own minimax plane, step from each other at their
shared edge by the difference of their distances from the hull there, up to twice the
tolerance. A strip, likewise, is one developable surface within the tolerance of its region;
moved rigidly (its development unchanged) it stays one as long as it stays within the
tolerance. So both are chosen together: one linear programme over all the shell's flat and
strip plates, the formed plates left to the forming that follows (:mod:`.follow`).

A flat plate's plane is z = a x + b y + h in the frame of its present plane (x, y along it, z
along its normal): a vertical distance is never less than the perpendicular one, so
|z_i - a x_i - b y_i - h| <= 0.98 of the tolerance at the region's points (the vertices of
their convex hull suffice: the constraint is convex; the margin is for the hull between the
points) keeps the plate within the tolerance of the hull in truth, and an edge point moves
along the normal by a x + b y + h. A strip moves by a small rigid motion, a point p by
v + w x (p - centre): its signed distances from the hull, at a grid of its points spread over
it, change by that move's part along the hull's normal and stay within 0.95 of the tolerance
(or their present distance, if larger: the plate as it is is always allowed); its move along
the hull stays within the tolerance in each of two directions across each other (a strip
does not slide along the shell). At points every 300 mm of every shared edge of two such
plates (on one of them, over the common part as :mod:`.fitup` measures it) the gap vector
between the edges, taken across the edge (the part along it is no step), is held inside an
octagon (which reaches 1.08 times its sides' distance at its corners) whose sides stand at
the sum of two slacks of the edge: up to 0.45 of the limit, and beyond. Where both edges end
together (a corner at a junction of three or four plates), the part along the edge of the
gap between their ends is held likewise, with slacks of its own: it is a gap across the
edge of the plate beyond the junction. The programme
minimises the sum over the edges of the second slacks (mm: how far each edge's largest step
exceeds 0.45 of the limit: the pairs that misfit are those past the limit), at a hundredth of
the weight the first ones (no step made larger for nothing), and, far below both, how far the
plates move. HiGHS (``scipy.optimize.linprog``), on the programme's dual. The moves are first
order in the turns (a few milliradians): the moved plates are measured again after
(:mod:`.rigid`, :mod:`.plates`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flatten.patchflat import plane_through
from flatten.plane import perpendicular_pair

from .fitup import SAMPLE_MM, _common, _dense, closest_on

FLAT = "flat"
STRIP = "developable"
# an edge's largest step (its octagon's side, a share of the step limit) in tiers, each (its
# width as a share of the limit, its weight per mm): up to 0.45 of the limit nearly free (no
# step made larger for nothing), beyond it at full weight. On the 160 m hull this leaves fewer
# misfits (90 of 346 flat and strip pairs) than a third tier of ten times the weight beyond 0.9
# of the limit (99): pulling every step toward 0.45 of the limit clears more of them
TIERS = ((0.45, 0.001), (np.inf, 0.1))
MOVE_WEIGHT = 1e-4  # how far the plates move (model units), against mm of an edge's step
POINT_MM = 300.0  # edge points this far apart carry the step constraints
JUNCTION_REACH = 2.0  # two edges' ends this many fit tolerances apart end together (a corner at a junction)
STRIP_GRID = (5, 8)  # a strip's points held within the tolerance: 5 across its girth, 8 along its length
STRIP_SHARE = 0.95  # of the tolerance, for a strip's points (its mesh between them, the turns' second order)
# of the tolerance, for a flat plate's region points: the hull between them bulges past a
# plane that touches the tolerance at them (by the grid cells' sagitta: 0.25 mm for 200 mm at 20 m)
PLANE_SHARE = 0.98
RULE = ("the flat plates' planes and the strips' places are chosen together (one linear programme, HiGHS): each "
        "flat plate within the fit tolerance of its region, each strip moved rigidly within it (its development "
        "unchanged), the steps at their shared edges within the step limit where the tolerance allows and as little "
        "over it as it allows elsewhere")


@dataclass(frozen=True)
class _Body:
    """A flat or strip plate in the programme: its variables from ``column`` (3 for a plane:
    a, b, h; 6 for a rigid move: v and w times ``scale``), its frame, and the rows that keep
    it within the tolerance (``rows`` @ x <= ``limits``)."""

    name: str
    kind: str  # "plane" or "rigid"
    column: int
    origin: np.ndarray  # (3,) a point of the plane, or the strip's centre
    axes: np.ndarray  # (2, 3) the plane's in-plane axes (unused for a strip)
    normal: np.ndarray  # (3,) the plane's normal (unused for a strip)
    scale: float  # model units: the plate's size, so that the turns are lengths at its ends
    rows: np.ndarray  # (K, size)
    limits: np.ndarray  # (K,)
    tolerance: float

    @property
    def size(self) -> int:
        return 3 if self.kind == "plane" else 6

    def basis(self, points: np.ndarray) -> np.ndarray:
        """(N, 3, size): each point's move per unit of each variable."""
        r = (np.asarray(points, dtype=np.float64) - self.origin) / self.scale
        if self.kind == "plane":
            x, y = r @ self.axes.T[:, 0], r @ self.axes.T[:, 1]
            return self.normal[None, :, None] * np.stack([x, y, np.ones_like(x)], axis=1)[:, None, :]
        out = np.zeros((len(r), 3, 6))
        out[:, [0, 1, 2], [0, 1, 2]] = 1.0
        # w x r as a matrix acting on w
        out[:, 0, 4], out[:, 0, 5] = r[:, 2], -r[:, 1]
        out[:, 1, 3], out[:, 1, 5] = -r[:, 2], r[:, 0]
        out[:, 2, 3], out[:, 2, 4] = r[:, 1], -r[:, 0]
        return out


def joint_moves(records: dict, pairs: list, mm_per_unit: float, strips: bool = True) -> dict:
    """Moves {plate: move} for the flat and strip plates the joint programme moves (others
    stay): a flat plate's ``{"kind": "plane", "normal", "point", "largest_move_mm"}``, a
    strip's ``{"kind": "rigid", "rotation" (3, 3), "turn" (3,) (its axis times its angle),
    "translation" (3,), "centre" (3,), "largest_move_mm"}`` (p -> centre + rotation (p - centre) + translation). ``records``:
    {plate: (PlateEdges, part)} with ``part.hull.result`` evaluated; ``pairs``: their shared
    edges (:func:`.fitup.shared_edges`); ``strips``: False holds the strips where they are."""
    bodies, column = {}, 0
    for name, (edges, part) in sorted(records.items()):
        body = _plane_body(name, part, column) if edges.klass == FLAT else (
            _rigid_body(name, part, column) if strips and edges.klass == STRIP else None)
        if body is not None:
            bodies[name] = body
            column += body.size
    if not bodies:
        return {}
    triplets, rhs, limits = [], [], []
    for pair in pairs:
        kinds = (records[pair.a][0].klass, records[pair.b][0].klass)
        if not (pair.a in bodies or pair.b in bodies) or any(k not in (FLAT, STRIP) for k in kinds):
            continue
        ea, eb = records[pair.a][0].edge(pair.side_a), records[pair.b][0].edge(pair.side_b)
        if ea is None or eb is None:
            continue
        reach = JUNCTION_REACH * max(records[pair.a][1].hull.fit_tolerance, records[pair.b][1].hull.fit_tolerance)
        got = _gaps(ea, eb, mm_per_unit, reach)  # one way: the common part is the same edge seen from either side
        # the ends' gap along the edge has slacks of its own: two flat plates' ends part along
        # the edge however their planes turn, and that must not excuse their steps across it
        for points, feet, directions in got or ():
            _edge_rows(bodies.get(pair.a), bodies.get(pair.b), points, feet, directions, len(limits), triplets, rhs)
            limits.append(pair.limit / mm_per_unit)
    if not limits:
        return {}
    return _solve(bodies, column, triplets, rhs, np.asarray(limits), mm_per_unit)


def _plane_body(name: str, part, column: int) -> _Body | None:
    result = part.hull.result
    klass = (result.figures.get("plate_class") or {}) if result is not None else {}
    if result is None or result.mesh is None or klass.get("normal") is None or klass.get("plane_point") is None:
        return None
    plane = plane_through(result.mesh[0], klass["normal"], klass["plane_point"])
    local = np.column_stack([plane.project(result.mesh[0]), plane.distances])
    scale = float(max(np.ptp(local[:, :2], axis=0).max(), 1e-12))
    from scipy.spatial import ConvexHull, QhullError

    try:
        local = local[ConvexHull(local).vertices]
    except QhullError:  # a degenerate set (a region on one plane, say): every point bounds the planes
        pass
    tol = float(part.hull.fit_tolerance)
    shift = np.column_stack([local[:, :2] / scale, np.ones(len(local))])  # the move a x + b y + h
    allowed = np.maximum(PLANE_SHARE * tol, np.abs(local[:, 2]))
    rows = np.vstack([shift, -shift])  # |z - move| <= tolerance
    return _Body(name, "plane", column, plane.centroid, plane.axes, plane.normal, scale, rows,
                 np.r_[allowed + local[:, 2], allowed - local[:, 2]], tol)


def _rigid_body(name: str, part, column: int) -> _Body | None:
    result = part.hull.result
    if result is None:
        return None
    points = _strip_points(result)
    if points is None:
        return None
    hull = part.hull
    from flatten.closest import SurfaceDistance

    # on the plate's own face (a shell's distance holds every face; its first need not be this one)
    distance = hull.distance if hull.distance is not None else SurfaceDistance(hull.surface)
    face = next((k for k, surface in enumerate(distance.surfaces) if surface is hull.surface), None)
    if face is None:
        distance, face = SurfaceDistance(hull.surface), 0
    params, _ = distance.closest(points, face, converged=1e-9)
    foot, normal, along = _hull_frames(hull.surface, params)
    signed = np.einsum("ij,ij->i", points - foot, normal)
    centre = points.mean(axis=0)
    scale = float(max(np.ptp(points, axis=0).max(), 1e-12))
    tol = float(hull.fit_tolerance)
    probe = _Body(name, "rigid", column, centre, np.zeros((2, 3)), np.zeros(3), scale, np.zeros((0, 6)),
                  np.zeros(0), tol)
    basis = probe.basis(points)
    across = np.cross(normal, along)
    rows, limits = [], []
    allowed = np.maximum(STRIP_SHARE * tol, np.abs(signed))
    for direction, hi, lo in ((normal, allowed - signed, allowed + signed), (along, tol, tol), (across, tol, tol)):
        coeff = np.einsum("ni,nij->nj", direction, basis)
        rows += [coeff, -coeff]
        limits += [np.broadcast_to(hi, len(points)), np.broadcast_to(lo, len(points))]
    return _Body(name, "rigid", column, centre, np.zeros((2, 3)), np.zeros(3), scale, np.vstack(rows),
                 np.concatenate(limits), tol)


def _strip_points(result) -> np.ndarray | None:
    """(K, 3) points of a delivered strip spread over it: STRIP_GRID across its girth and along
    its length, corners included. Its rulings are taken nearest to even positions of their
    midpoints along the plate's long axis (a strip trimmed at its butts has a fan of rulings
    cut to each butt: even in index, most would lie on the butts), the region mesh it is cut
    to at even rows (girth) and columns (length, evenly spaced already)."""
    across, along = STRIP_GRID
    if result.strip is not None and result.strip.trim is not None:
        m = len(result.strip.samples)
        grid = np.asarray(result.strip.vertices, dtype=np.float64).reshape(-1, m, 3)  # (rulings, along a ruling)
        middle = grid[:, m // 2]
        centred = middle - middle.mean(axis=0)
        length = centred @ np.linalg.svd(centred, full_matrices=False)[2][0]  # along the plate's long axis
        targets = np.linspace(length.min(), length.max(), along)
        rulings = np.unique(np.abs(length[:, None] - targets[None, :]).argmin(axis=0))
        samples = np.unique(np.linspace(0, m - 1, across).round().astype(int))
        return grid[np.ix_(rulings, samples)].reshape(-1, 3)
    if result.mesh is not None:
        shape = tuple((result.figures.get("region") or {}).get("grid") or ())
        v3 = np.asarray(result.mesh[0], dtype=np.float64)
        if len(shape) != 2 or shape[0] * shape[1] != len(v3):
            return None
        grid = v3.reshape(*shape, 3)  # (rows across the girth, columns along the length)
        rows = np.unique(np.linspace(0, shape[0] - 1, across).round().astype(int))
        cols = np.unique(np.linspace(0, shape[1] - 1, along).round().astype(int))
        return grid[np.ix_(rows, cols)].reshape(-1, 3)
    return None


def _hull_frames(surface, params: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The hull's points (N, 3), unit normals (N, 3) and a unit tangent (N, 3) at parameters (N, 2)."""
    u, v = params[:, 0], params[:, 1]
    su, sv = surface.partials(u, v)
    normal = np.cross(su, sv)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    along = su / np.maximum(np.linalg.norm(su, axis=1, keepdims=True), 1e-300)
    return surface(u, v), normal, along


def _edge_rows(here: _Body | None, there: _Body | None, points, feet, across, edge: int, triplets: list,
               rhs: list) -> None:
    """The octagon rows of one edge's points: |(gap + move here - move there) . d| <= the
    edge's slacks, as sparse (row, column, value) triplets (column -1 - ``edge``: its slacks)."""
    gap = np.einsum("nj,nkj->nk", points - feet, across)  # (N, 4)
    start = sum(len(r) for r in rhs)
    count = gap.size
    for sign in (1.0, -1.0):
        line = start + np.arange(count)
        for body, at, factor in ((here, points, 1.0), (there, feet, -1.0)):
            if body is None:
                continue
            coeff = factor * sign * np.einsum("nkj,nji->nki", across, body.basis(at))  # (N, 4, size)
            triplets.append((np.repeat(line, body.size), np.tile(body.column + np.arange(body.size), count),
                             coeff.reshape(-1)))
        triplets.append((line, np.full(count, -1 - edge), np.full(count, -1.0)))  # the slacks, placed in _solve
        rhs.append(-sign * gap.reshape(-1))
        start += count


def _gaps(mine, theirs, mm_per_unit: float, reach: float):
    """The gaps an edge's octagons hold, as (points (N, 3) of ``mine``, their closest points on
    ``theirs`` (N, 3), directions (N, K, 3)): along the common part, its points and the four
    directions across the edge at each; at each end where both edges end together (within
    ``reach``, model units: a corner at a junction), the two ends and the direction along
    the edge. Two strips whose seam neighbours are formed slide along their shared butt
    unheld otherwise, and there the part of the gap along the butt is a gap across the third
    plate's edge: KVLCC2's strips of strake 10, each within the tolerance, ended 10 mm apart
    on seam 11, and the formed plate above them, formed to meet both, stepped 9.56 mm.
    None when the edges do not overlap."""
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
    first, second = perpendicular_pair(tangent)
    angles = np.pi / 4.0 * np.arange(4)
    across = np.cos(angles)[None, :, None] * first[:, None, :] + np.sin(angles)[None, :, None] * second[:, None, :]
    out = [(points, feet, across)]
    ends = _junction_ends(dm.p3, dt.p3, reach)
    if ends is not None:
        out.append(ends)
    return out


def _junction_ends(mine: np.ndarray, theirs: np.ndarray, reach: float):
    """(ends of ``mine`` (M, 3), the ends of ``theirs`` they meet (M, 3), the direction along
    ``mine`` there (M, 1, 3)) for the ends of two edges' points (N, 3) that lie within
    ``reach`` of each other, the edges taken the way round that pairs their ends nearest
    (each end of one meets at most one end of the other); None where no end meets one or
    either edge is shorter than twice the reach (its two ends are one junction)."""
    ends, tangents = mine[[0, -1]], mine[[1, -1]] - mine[[0, -2]]
    other = theirs[[0, -1]]
    if min(np.linalg.norm(ends[1] - ends[0]), np.linalg.norm(other[1] - other[0])) < 2.0 * reach:
        return None
    if np.linalg.norm(ends - other, axis=1).sum() > np.linalg.norm(ends - other[::-1], axis=1).sum():
        other = other[::-1]
    meet = np.linalg.norm(ends - other, axis=1) <= reach
    if not meet.any():
        return None
    along = tangents[meet] / np.maximum(np.linalg.norm(tangents[meet], axis=1, keepdims=True), 1e-300)
    return ends[meet], other[meet], along[:, None, :]


def _solve(bodies: dict, size: int, triplets: list, rhs: list, limits: np.ndarray, mm_per_unit: float) -> dict:
    from scipy.sparse import coo_matrix

    # variables: the bodies' own as differences of non-negative parts, then per edge its step
    # by tier (TIERS): up to 0.45 of the limit, and beyond
    edges = len(limits)
    r_, c_, v_ = [], [], []
    for line, column, value in triplets:
        slack = column < 0
        body_lines, body_columns, body_values = line[~slack], column[~slack], value[~slack]
        r_ += [body_lines, body_lines]
        c_ += [body_columns, size + body_columns]
        v_ += [body_values, -body_values]
        for tier in range(len(TIERS)):
            r_.append(line[slack])
            c_.append(2 * size + tier * edges + (-column[slack] - 1))
            v_.append(value[slack])
    bound = list(rhs)
    line = sum(len(r) for r in rhs)
    for body in bodies.values():  # each within the tolerance
        k = len(body.limits)
        lines = line + np.repeat(np.arange(k), body.size)
        columns = np.tile(body.column + np.arange(body.size), k)
        r_ += [lines, lines]
        c_ += [columns, size + columns]
        v_ += [body.rows.reshape(-1), -body.rows.reshape(-1)]
        bound.append(body.limits)
        line += k
    matrix = coo_matrix((np.concatenate(v_), (np.concatenate(r_), np.concatenate(c_))),
                        shape=(line, 2 * size + len(TIERS) * edges)).tocsr()
    cost = np.r_[np.full(2 * size, MOVE_WEIGHT), *(np.full(edges, weight * mm_per_unit) for _, weight in TIERS)]
    upper = np.r_[np.full(2 * size, np.inf), *(share * limits for share, _ in TIERS)]
    x = _primal(cost, matrix, np.concatenate(bound), upper)
    x = x[:size] - x[size:2 * size]
    out = {}
    for name, body in bodies.items():
        mine = x[body.column:body.column + body.size]
        if body.kind == "plane":
            move = _plane_move(body, mine)
        else:
            move = _rigid_move(body, mine)
        if move["largest_move_mm"] > 1e-6 * body.tolerance:  # model units here
            move["largest_move_mm"] *= mm_per_unit
            out[name] = move
    return out


def _primal(cost: np.ndarray, matrix, bound: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """x >= 0 (N,) minimising cost . x subject to matrix x <= bound and x <= upper
    (ArithmeticError when HiGHS does not solve it).

    Solved as its dual (max -bound . y subject to matrix^T y >= -cost, y >= 0), whose basis is
    as large as the primal's columns (a few thousand) instead of its rows (a hundred thousand
    points of edges and plates: HiGHS takes three to five times as long on the primal); the
    primal solution is the dual's constraints' marginals."""
    from scipy.optimize import linprog
    from scipy.sparse import csr_matrix, vstack

    capped = np.flatnonzero(np.isfinite(upper))
    caps = csr_matrix((np.ones(len(capped)), (np.arange(len(capped)), capped)), shape=(len(capped), len(cost)))
    full = vstack([matrix, caps]).tocsr()
    rhs = np.r_[bound, upper[capped]]
    got = linprog(rhs, A_ub=-full.T, b_ub=cost, bounds=(0, None), method="highs")
    if not got.success:
        raise ArithmeticError(f"the joint programme's dual was not solved: {got.message}")
    x = np.maximum(-got.ineqlin.marginals, 0.0)
    violation = float((full @ x - rhs).max())
    if violation > 1e-6 * max(1.0, np.abs(rhs).max()):  # the dual's marginals are the primal
        raise ArithmeticError(f"the joint programme's primal read from its dual breaks a row by {violation:.3g}")
    return x


def _plane_move(body: _Body, x: np.ndarray) -> dict:
    a, b, h = x
    # the largest shift of the region's points: at a vertex of their convex hull (the rows)
    shift = float(np.abs(body.rows[: len(body.rows) // 2] @ x).max())
    normal = body.normal - (a * body.axes[0] + b * body.axes[1]) / body.scale
    normal /= np.linalg.norm(normal)
    return {"kind": "plane", "normal": normal.tolist(), "point": (body.origin + h * body.normal).tolist(),
            "largest_move_mm": shift}


def turned(turn: np.ndarray) -> np.ndarray:
    """The rotation (3, 3) by the turn vector (3,) (axis times angle, radians): Rodrigues."""
    turn = np.asarray(turn, dtype=np.float64)
    angle = float(np.linalg.norm(turn))
    if angle == 0.0:
        return np.eye(3)
    k = turn / angle
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * cross @ cross


def _rigid_move(body: _Body, x: np.ndarray) -> dict:
    translation, turn = x[:3], x[3:] / body.scale
    rotation = turned(turn)
    # the largest move of the points that held it: rows (normal, along, across) x (+, -)
    count = len(body.rows) // 6
    moves = np.stack([body.rows[k * count:(k + 1) * count] @ x for k in (0, 2, 4)], axis=1)
    return {"kind": "rigid", "rotation": rotation.tolist(), "turn": turn.tolist(), "translation": translation.tolist(),
            "centre": body.origin.tolist(), "largest_move_mm": float(np.linalg.norm(moves, axis=1).max())}
