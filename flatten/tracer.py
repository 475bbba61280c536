"""Trace the whole zero set Z = {f = 0} of the developability field.

Seeds are every real root of f on a grid of lines t = const and T = const (knots
included), found by the batched polynomial solver. From each seed not yet passed by
a trace, a predictor-corrector continuation follows Z in both directions until it
leaves the parameter rectangle or closes into a loop; every grid line the trace
crosses must hold a seed there, which the trace marks as passed and inserts into its
polyline. Transversal self-crossings of Z (singular points, e.g. a fan crossing a
graph branch) are passed straight through. Work is done in the unit square
x = (u, U), u = (t - t0) / (t1 - t0), U = (T - T0) / (T1 - T0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .equation import DevelopabilityField
from .tolerances import Tolerances

END_LOOP = "loop"
END_UNRESOLVED = "unresolved"
END_STEP_LIMIT = "step_limit"
SIDE_NAMES = ("t_start", "t_end", "T_start", "T_end")


@dataclass(frozen=True)
class GridSeeds:
    """Roots of f on the grid lines, in the unit square.

    u_lines, U_lines : (Nu,), (NU,) positions of the vertical and horizontal lines
    points : (S, 2) seed positions; line_axis : (S,) 0 for a vertical line (u fixed),
    1 for a horizontal one; line_index : (S,) index into u_lines or U_lines
    vanishing_u : (Nu, n_d_spans) bool, f identically zero on that line and span
    vanishing_U : (NU, n_c_spans) bool
    """

    u_lines: np.ndarray
    U_lines: np.ndarray
    points: np.ndarray
    line_axis: np.ndarray
    line_index: np.ndarray
    vanishing_u: np.ndarray
    vanishing_U: np.ndarray


@dataclass(frozen=True)
class Trace:
    """One traced branch in the unit square: points (N, 2), closed loop or not, end kinds."""

    points: np.ndarray
    closed: bool
    ends: tuple[str, str]


def grid_lines(breakpoints: np.ndarray, per_span: int, minimum: int) -> np.ndarray:
    """Unit-square positions of seed lines: every breakpoint plus an even split of each span."""
    lo, hi = breakpoints[0], breakpoints[-1]
    n_spans = len(breakpoints) - 1
    per_span = max(per_span, int(np.ceil(minimum / n_spans)))
    lines = [np.linspace(a, b, per_span + 1)[:-1] for a, b in zip(breakpoints[:-1], breakpoints[1:])]
    lines.append(breakpoints[-1:])
    return (np.concatenate(lines) - lo) / (hi - lo)


def _merge_lines(lines: np.ndarray, extra) -> np.ndarray:
    """Sorted union of line positions; extra lines closer than 1e-9 to one kept are dropped."""
    extra = np.clip(np.asarray(extra, dtype=np.float64).ravel(), 0.0, 1.0)
    if extra.size == 0:
        return lines
    merged = np.sort(np.concatenate([lines, extra]))
    keep = np.ones(len(merged), dtype=bool)
    keep[1:] = np.diff(merged) > 1e-9
    keep[-1] = True
    merged = merged[keep]
    merged[0], merged[-1] = 0.0, 1.0
    return np.unique(merged)


@dataclass(frozen=True)
class StepCaps:
    """Where the zero set comes close to itself: the trace step must stay below the gap.

    points : (K, 2) critical points of f (unit square); gap : (K,) distance across Z
    there (two arms of a near-tangent saddle, or the small axis of a small loop);
    slope : (K,) how fast the arms separate with the distance from the point. The cap
    at x is min_k (gap_k + slope_k |x - p_k|) / 4.
    """

    points: np.ndarray
    gap: np.ndarray
    slope: np.ndarray

    def cap(self, x: np.ndarray) -> float:
        if len(self.gap) == 0:
            return np.inf
        dist = np.hypot(*(self.points - x).T)
        return float(np.min(0.25 * (self.gap + self.slope * dist)))


NO_CAPS = StepCaps(np.zeros((0, 2)), np.zeros(0), np.zeros(0))


class _UnitField:
    """f and its gradient in unit-square coordinates for one point at a time."""

    def __init__(self, field: DevelopabilityField):
        self.field = field
        self.t0, self.t1 = field.c.domain
        self.T0, self.T1 = field.d.domain
        self.dt = self.t1 - self.t0
        self.dT = self.T1 - self.T0
        self.bc, self.bd = field.c.breakpoints, field.d.breakpoints
        self.pow_c = np.arange(field.cells.shape[2], dtype=np.float64)
        self.pow_d = np.arange(field.cells.shape[3], dtype=np.float64)
        self.dcoef_c, self.dcoef_d = self.pow_c, self.pow_d

    def params(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.asarray(x, dtype=np.float64).reshape(-1, 2)
        return self.t0 + x[:, 0] * self.dt, self.T0 + x[:, 1] * self.dT

    def value_gradient(self, x: np.ndarray):
        """f and (f_u, f_U) at one unit point, as ((1,), (1, 2)) arrays.

        Written for a single point: the tracer calls it thousands of times.
        """
        u, U = float(x.reshape(-1)[0]), float(x.reshape(-1)[1])
        i, s, hc = self._locate(self.bc, self.t0 + u * self.dt)
        j, sig, hd = self._locate(self.bd, self.T0 + U * self.dT)
        m = self.field.cells[i, j]
        ps = s ** self.pow_c
        pt = sig ** self.pow_d
        dps = self.dcoef_c * np.concatenate(([0.0], ps[:-1]))
        dpt = self.dcoef_d * np.concatenate(([0.0], pt[:-1]))
        mp = m @ pt
        f = ps @ mp
        fu = dps @ mp / hc * self.dt
        fU = ps @ (m @ dpt) / hd * self.dT
        return np.array([f]), np.array([[fu, fU]])

    @staticmethod
    def _locate(breaks: np.ndarray, x: float):
        i = min(max(int(np.searchsorted(breaks, x, side="right")) - 1, 0), len(breaks) - 2)
        width = breaks[i + 1] - breaks[i]
        return i, (x - breaks[i]) / width, width

    def project(self, y: np.ndarray, iterations: int = 8, accept: float = 1e-12):
        """Newton projection onto f = 0 along the gradient; returns point, converged flag
        (the last Newton step below ``accept``)."""
        y = y.copy()
        size = np.inf
        for _ in range(iterations):
            f, g = self.value_gradient(y)
            f, g = f[0], g[0]
            gg = g @ g
            if gg == 0.0:
                return y, False
            step = f * g / gg
            y -= step
            size = np.sqrt(step @ step)
            # Newton converges quadratically: after a step below ``accept`` the point
            # is within ~ curvature * accept^2 of Z
            if size <= max(1e-14, accept):
                return y, True
        # where |grad f| is small (near a small loop or a saddle) round-off in f keeps
        # the last Newton steps near 1e-14 instead of 0: the point is on Z all the same
        return y, bool(size <= accept)

    def tangent(self, x: np.ndarray) -> np.ndarray:
        _, g = self.value_gradient(x)
        g = g[0]
        n = np.hypot(g[0], g[1])
        return np.array([-g[1], g[0]]) / n if n > 0 else np.zeros(2)


def find_seeds(field: DevelopabilityField, tol: Tolerances, extra_u=(), extra_U=()) -> GridSeeds:
    """All roots of f on the grid lines, batched (one matrix product per direction).

    ``extra_u``, ``extra_U`` : further line positions in the unit square (lines through
    the extrema of f, so that every small loop is crossed by a seed line).
    """
    unit = _UnitField(field)
    u_lines = _merge_lines(grid_lines(field.c.breakpoints, tol.grid_lines_per_span, tol.min_grid_lines), extra_u)
    U_lines = _merge_lines(grid_lines(field.d.breakpoints, tol.grid_lines_per_span, tol.min_grid_lines), extra_U)
    line_v, T, van_u = field.roots_in_T(unit.t0 + u_lines * unit.dt, tol.zero_relative)
    line_h, t, van_U = field.roots_in_t(unit.T0 + U_lines * unit.dT, tol.zero_relative)
    pts_v = np.column_stack([u_lines[line_v], (T - unit.T0) / unit.dT])
    pts_h = np.column_stack([(t - unit.t0) / unit.dt, U_lines[line_h]])
    return GridSeeds(
        u_lines, U_lines,
        np.vstack([pts_v, pts_h]),
        np.concatenate([np.zeros(len(pts_v), int), np.ones(len(pts_h), int)]),
        np.concatenate([line_v, line_h]),
        van_u, van_U)


class _Tracer:
    def __init__(self, field: DevelopabilityField, seeds: GridSeeds, tol: Tolerances,
                 caps: StepCaps = NO_CAPS):
        self.unit = _UnitField(field)
        self.seeds = seeds
        self.tol = tol
        self.caps = caps
        self.visited = np.zeros(len(seeds.points), dtype=bool)
        self.tree = cKDTree(seeds.points.reshape(-1, 2))
        # seeds per line, for matching crossings
        self.by_line = {}
        for k, (axis, idx) in enumerate(zip(seeds.line_axis, seeds.line_index)):
            self.by_line.setdefault((int(axis), int(idx)), []).append(k)
        self.lines = (seeds.u_lines, seeds.U_lines)
        kinks = []
        for curve in (field.c, field.d):
            inner = curve.breakpoints[1:-1]
            kinks.append((inner[curve.knot_continuity() <= 1] - curve.domain[0]) / np.ptp(curve.domain))
        self.kinks = tuple(kinks)

    def _mark(self, k: int) -> None:
        """Mark seed k and every seed at the same point (a root at a grid node is found
        on both of its lines)."""
        self.visited[self.tree.query_ball_point(self.seeds.points[k], self.tol.junction)] = True

    # -- grid-line crossings -------------------------------------------------
    def _crossings(self, x: np.ndarray, y: np.ndarray) -> list[tuple[float, int]]:
        """Seeds on grid lines crossed by the chord x -> y, as (chord fraction, seed)."""
        found = []
        chord = y - x
        length = np.hypot(*chord)
        for axis in (0, 1):
            lines = self.lines[axis]
            lo, hi = sorted((x[axis], y[axis]))
            span = np.flatnonzero((lines >= lo - 1e-15) & (lines <= hi + 1e-15))
            for idx in span:
                if chord[axis] != 0.0:
                    frac = (lines[idx] - x[axis]) / chord[axis]
                else:
                    frac = 0.0
                if frac <= 1e-12:
                    continue  # the start point itself
                estimate = x + frac * chord
                best, best_d = None, 0.25 * length + 1e-9
                for k in self.by_line.get((axis, int(idx)), ()):
                    dist = np.hypot(*(self.seeds.points[k] - estimate))
                    if dist < best_d:
                        best, best_d = k, dist
                if best is not None:
                    found.append((float(frac), best))
        found.sort()
        return found

    def _boundary_exit(self, x: np.ndarray, y: np.ndarray):
        """Where the chord x -> y leaves the unit square, snapped to a boundary seed."""
        chord = y - x
        best_frac, side = 2.0, None
        for axis in (0, 1):
            for bound, name in ((0.0, SIDE_NAMES[2 * axis]), (1.0, SIDE_NAMES[2 * axis + 1])):
                if chord[axis] != 0.0:
                    frac = (bound - x[axis]) / chord[axis]
                    if 0.0 <= frac < best_frac:
                        best_frac, side = frac, name
        point = np.clip(x + min(best_frac, 1.0) * chord, 0.0, 1.0)
        axis = 0 if side.startswith("t_") else 1
        idx = 0 if side.endswith("start") else len(self.lines[axis]) - 1
        best, best_d = None, max(0.5 * np.hypot(*chord), 1e-7)
        for k in self.by_line.get((axis, idx), ()):
            dist = np.hypot(*(self.seeds.points[k] - point))
            if dist < best_d:
                best, best_d = k, dist
        if best is not None:
            self._mark(best)
            point = self.seeds.points[best].copy()
        else:
            proj, ok = self.unit.project(point)
            if ok:
                proj[axis] = float(idx > 0)
                point = proj
        return point, side

    # -- kinks: knot lines where f is only C0 ---------------------------------
    def _kink_crossing(self, x: np.ndarray, tangent: np.ndarray, h: float):
        """(seed, tangent beyond) when the next step would cross a knot line where f is
        only continuous (a C1 knot of a curve: f holds C', so Z has a corner there).

        The corrector cannot follow Z round such a corner (its tangent jumps), so the
        trace goes to the root on the knot line (a seed, found by the line solver) and
        leaves it with the tangent of the cell beyond.
        """
        for axis in (0, 1):
            lines = self.kinks[axis]
            if len(lines) == 0 or tangent[axis] == 0.0:
                continue
            reach = x[axis] + 1.5 * h * tangent[axis]
            lo, hi = sorted((x[axis], reach))
            ahead = lines[(lines > lo + 1e-13) & (lines < hi)] if tangent[axis] > 0 else \
                lines[(lines > lo) & (lines < hi - 1e-13)]
            if len(ahead) == 0:
                continue
            line = ahead[np.argmin(np.abs(ahead - x[axis]))]
            idx = int(np.argmin(np.abs(self.lines[axis] - line)))
            estimate = x + (line - x[axis]) / tangent[axis] * tangent
            best, best_d = None, 0.5 * h + 1e-9
            for k in self.by_line.get((axis, idx), ()):
                dist = np.hypot(*(self.seeds.points[k] - estimate))
                if dist < best_d:
                    best, best_d = k, dist
            if best is None:
                return None
            far = self._side_tangent(self.seeds.points[best], axis, np.sign(tangent[axis]))
            return None if far is None else (best, far)
        return None

    def _side_tangent(self, x: np.ndarray, axis: int, side: float):
        """Tangent of Z at x (on a kink line across ``axis``) in the cell on ``side``
        (+1 / -1 along the axis), pointing into that cell; None if Z does not enter it."""
        beyond = x.copy()
        beyond[axis] += side * 1e-9
        far = self.unit.tangent(beyond)
        if far[axis] * side < 0:
            far = -far
        if not far.any() or far[axis] == 0.0:
            return None
        return far

    def _start_tangent(self, x: np.ndarray, direction: float) -> np.ndarray:
        """The tangent to leave a seed with; on a kink line, that of the cell it enters."""
        tangent = self.unit.tangent(x) * direction
        for axis in (0, 1):
            if tangent[axis] != 0.0 and np.any(np.abs(self.kinks[axis] - x[axis]) <= 1e-12):
                side = self._side_tangent(x, axis, np.sign(tangent[axis]))
                if side is not None:
                    return side
        return tangent

    # -- continuation --------------------------------------------------------
    def _step(self, x, tangent, h):
        # polyline points need not be exact (they are polished afterwards and checked):
        # a Newton step of 1e-4 h is converged even where round-off keeps it from 0
        y, ok = self.unit.project(x + h * tangent, accept=max(1e-12, 1e-6 * h))
        if not ok:
            return None
        new_tangent = self.unit.tangent(y)
        if new_tangent @ tangent < 0:
            new_tangent = -new_tangent
        moved = np.hypot(*(y - x))
        # a corrector that pulls the point back (moved ~ 0) would let the trace stall
        # forever; one that moves it far has jumped to another arm
        if new_tangent @ tangent < 0.9 or moved > 2.0 * h or moved < 0.25 * h:
            return None
        return y, new_tangent

    def trace_one_way(self, start: np.ndarray, direction: float):
        tol = self.tol
        x = start.copy()
        tangent = self._start_tangent(x, direction)
        if not tangent.any():
            return [x], END_UNRESOLVED
        points = [x]
        h = min(tol.trace_step, self.caps.cap(x))
        travelled = 0.0
        for _ in range(tol.trace_max_steps):
            attempt = None
            cap = self.caps.cap(x)
            h = min(h, cap)
            kink = self._kink_crossing(x, tangent, h)
            if kink is not None:  # step onto the knot line, turn to the far side's tangent
                k, far_tangent = kink
                y = self.seeds.points[k].copy()
                for _, m in self._crossings(x, y):
                    if m != k:
                        self._mark(m)
                        points.append(self.seeds.points[m].copy())
                self._mark(k)
                travelled += np.hypot(*(y - x))
                points.append(y)
                x, tangent = y, far_tangent
                continue
            trial = h
            min_step = min(tol.trace_min_step, 0.125 * cap)
            while trial >= min_step and attempt is None:
                attempt = self._step(x, tangent, trial)
                if attempt is None:
                    trial *= 0.5
            if attempt is None and cap == np.inf:  # jump over a singular point along the tangent
                for trial in h * np.array([2.0, 4.0, 8.0, 16.0]):
                    attempt = self._step(x, tangent, trial)
                    if attempt is not None:
                        break
            if attempt is None:
                return points, END_UNRESOLVED
            y, new_tangent = attempt
            if np.any(y < -1e-12) or np.any(y > 1.0 + 1e-12):
                exit_point, side = self._boundary_exit(x, y)
                # the grid lines crossed on the way out: along the chord to the exit point
                # (the clipped step can point elsewhere and miss their seeds)
                for _, k in self._crossings(x, exit_point):
                    if not self.visited[k] and np.all(self.seeds.points[k] > 0) and np.all(self.seeds.points[k] < 1):
                        self._mark(k)
                        points.append(self.seeds.points[k].copy())
                points.append(exit_point)
                return points, side
            step_len = np.hypot(*(y - x))
            travelled += step_len
            closing = travelled > 2.5 * step_len and np.hypot(*(y - start)) <= max(step_len * 1.01, 1e-12)
            # the closing chord ends at the start: the grid lines it crosses are those
            # between x and the start, not between x and y
            for _, k in self._crossings(x, start if closing else y):
                self._mark(k)
                points.append(self.seeds.points[k].copy())
            if closing:
                points.append(start.copy())
                return points, END_LOOP
            points.append(y)
            x, tangent = y, new_tangent
            h = min(trial * 1.5, tol.trace_step)
        return points, END_STEP_LIMIT

    def trace_from(self, seed_index: int) -> Trace:
        start = self.seeds.points[seed_index].copy()
        self._mark(seed_index)
        forward, end_f = self.trace_one_way(start, 1.0)
        if end_f == END_LOOP:
            return Trace(_dedupe(np.array(forward)), True, (END_LOOP, END_LOOP))
        backward, end_b = self.trace_one_way(start, -1.0)
        pts = np.array(backward[::-1] + forward[1:])
        return Trace(_dedupe(pts), False, (end_b, end_f))


def _distance_to_polyline(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance of each of (S, 2) points to a polyline (N, 2), shape (S,)."""
    if len(poly) == 1:
        return np.hypot(*(points - poly[0]).T)
    a, r = poly[:-1], np.diff(poly, axis=0)
    rr = np.maximum(np.einsum("ij,ij->i", r, r), 1e-300)
    rel = points[:, None, :] - a[None, :, :]
    frac = np.clip(np.einsum("snj,nj->sn", rel, r) / rr, 0.0, 1.0)
    gap = rel - frac[..., None] * r[None]
    return np.sqrt(np.einsum("snj,snj->sn", gap, gap).min(axis=1))


def near_polyline(points: np.ndarray, poly: np.ndarray, tol: float, tree: cKDTree | None = None) -> np.ndarray:
    """(S,) True where a point of (S, 2) lies within ``tol`` of the polyline (N, 2).

    Memory and time O(S + N) (a k-d tree of the points, queried around each segment),
    not the O(S N) of all point-segment distances: a long trace against many seeds
    must not ask for gigabytes.
    """
    out = np.zeros(len(points), dtype=bool)
    if len(points) == 0 or len(poly) == 0:
        return out
    if len(poly) == 1:
        return np.hypot(*(points - poly[0]).T) <= tol
    tree = cKDTree(points) if tree is None else tree
    a, r = poly[:-1], np.diff(poly, axis=0)
    length = np.hypot(*r.T)
    hits = tree.query_ball_point(a + 0.5 * r, 0.5 * length + tol, return_sorted=False)
    counts = np.fromiter((len(h) for h in hits), dtype=int, count=len(hits))
    if counts.sum() == 0:
        return out
    seg = np.repeat(np.arange(len(a)), counts)
    idx = np.concatenate([np.asarray(h, dtype=int) for h in hits if len(h)])
    rel = points[idx] - a[seg]
    rr = np.maximum(length[seg] ** 2, 1e-300)
    frac = np.clip(np.einsum("ij,ij->i", rel, r[seg]) / rr, 0.0, 1.0)
    gap = np.hypot(*(rel - frac[:, None] * r[seg]).T)
    out[idx[gap <= tol]] = True
    return out


def _dedupe(points: np.ndarray) -> np.ndarray:
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.hypot(*(np.diff(points, axis=0).T)) > 1e-13
    return points[keep]


def _grid_line_fans(seeds: GridSeeds, field: DevelopabilityField) -> list[Trace]:
    """Fans lying exactly on grid lines (f identically zero there): no seed finds them."""
    traces = []
    span_edges = ((field.d.breakpoints - field.d.breakpoints[0]) / np.ptp(field.d.domain),
                  (field.c.breakpoints - field.c.breakpoints[0]) / np.ptp(field.c.domain))
    for axis, (vanishing, lines) in enumerate(((seeds.vanishing_u, seeds.u_lines),
                                               (seeds.vanishing_U, seeds.U_lines))):
        edges = span_edges[axis]
        for idx in np.flatnonzero(vanishing.any(axis=1)):
            run_start = None
            flags = list(vanishing[idx]) + [False]
            for span, flag in enumerate(flags):
                if flag and run_start is None:
                    run_start = span
                elif not flag and run_start is not None:
                    along = np.linspace(edges[run_start], edges[span], 33)
                    fixed = np.full_like(along, lines[idx])
                    pts = np.column_stack([fixed, along] if axis == 0 else [along, fixed])
                    traces.append(Trace(pts, False, _fan_ends(pts)))
                    run_start = None
    return traces


def _fan_ends(points: np.ndarray) -> tuple[str, str]:
    def side(p):
        for axis in (1, 0):
            if p[axis] <= 0.0:
                return SIDE_NAMES[2 * axis]
            if p[axis] >= 1.0:
                return SIDE_NAMES[2 * axis + 1]
        return END_UNRESOLVED
    return side(points[0]), side(points[-1])


def trace_zero_set(field: DevelopabilityField, tol: Tolerances, extra_u=(), extra_U=(),
                   caps: StepCaps = NO_CAPS, explained: np.ndarray | None = None
                   ) -> tuple[list[Trace], GridSeeds, np.ndarray]:
    """Every branch of Z in the unit square.

    ``extra_u``, ``extra_U`` add seed lines; ``caps`` bound the step near critical
    points; seeds within ``tol.junction`` of the (K, 2) ``explained`` points (isolated
    points of Z, reported on their own) are not traced.

    Returns the traces, the grid seeds and a (S,) bool array telling which seeds
    some trace passed (all of them, unless a branch could not be followed).
    """
    seeds = find_seeds(field, tol, extra_u, extra_U)
    tracer = _Tracer(field, seeds, tol, caps)
    traces = _grid_line_fans(seeds, field)
    tree = tracer.tree
    for trace in traces:  # seeds on those fans are already explained
        tracer.visited |= near_polyline(seeds.points, trace.points, tol.junction, tree)
    if explained is not None and len(explained) and len(seeds.points):
        near = np.hypot(*(seeds.points[:, None, :] - explained[None, :, :]).transpose(2, 0, 1)).min(axis=1)
        tracer.visited |= near <= 1e-5
    # interior seeds first, so that branches are traced through rather than from an end
    order = np.argsort(-np.min(np.minimum(seeds.points, 1.0 - seeds.points), axis=1), kind="stable")
    for k in order:
        if not tracer.visited[k]:
            trace = tracer.trace_from(int(k))
            traces.append(trace)
            # a grid line tangent to the branch holds a (double) root the trace touches
            # without crossing the line
            tracer.visited |= near_polyline(seeds.points, trace.points, 1e-6, tree)
    return traces, seeds, tracer.visited.copy()
