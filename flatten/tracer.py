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

import math
from bisect import bisect_left, bisect_right
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .equation import DevelopabilityField, span_at
from .tolerances import Tolerances

END_LOOP = "loop"
END_UNRESOLVED = "unresolved"
END_STEP_LIMIT = "step_limit"
SIDE_NAMES = ("t_start", "t_end", "T_start", "T_end")

# Step control of the continuation (unit square). Where Z is nearly straight the
# predictor lands close to it and the step grows to MAX_STEP_FACTOR trace steps; it is
# held so that the corrector moves the predicted point about STEP_DEFLECTION (the
# predictor's error, ~ curvature h^2 / 2) and the tangent turns about STEP_TURN radians
# per step. A corrector that moves the point more than 4 STEP_DEFLECTION is refused (the
# step is halved): the trace cannot reach an arm of Z farther away than that.
MAX_STEP_FACTOR = 16.0
STEP_DEFLECTION = 1.5e-4
STEP_TURN = 0.1
# Where Z runs within ~ 11 degrees of a grid direction (or turns through it: a turning
# point) it may cross a grid line twice within a long step whose chord crosses it
# never; the step there stays at most a trace step, as the tracer always took.
AXIS_SLOPE = 0.2


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
    """f and its gradient in unit-square coordinates, one point at a time, in floats.

    The tracer steps one point at a time, so numpy's overhead per call (about a
    microsecond per operation on a 2-vector) would dominate: the coefficients of a
    cell are taken once as nested lists (highest powers first) and evaluated by
    Horner's rule in plain Python floats (about 25x fewer interpreter-level calls).
    """

    def __init__(self, field: DevelopabilityField):
        self.field = field
        self.t0, self.t1 = field.c.domain
        self.T0, self.T1 = field.d.domain
        self.dt = self.t1 - self.t0
        self.dT = self.T1 - self.T0
        self.bc, self.bd = field.c.breakpoints.tolist(), field.d.breakpoints.tolist()
        self.spans_d = len(self.bd) - 1  # the stride of a cell's key
        self._rows: dict[int, list[list[float]]] = {}  # cell -> Horner rows, filled as cells are visited

    def params(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.asarray(x, dtype=np.float64).reshape(-1, 2)
        return self.t0 + x[:, 0] * self.dt, self.T0 + x[:, 1] * self.dT

    def _cell_rows(self, i: int, j: int) -> list[list[float]]:
        key = i * self.spans_d + j
        rows = self._rows.get(key)
        if rows is None:
            rows = [row[::-1] for row in self.field.cells[i, j].tolist()[::-1]]
            self._rows[key] = rows
        return rows

    def value_gradient(self, u: float, U: float) -> tuple[float, float, float]:
        """(f, f_u, f_U) at the unit point (u, U)."""
        # (the tracer's unit of work, ~850 calls a plate: branches, not min/max calls)
        bc, bd = self.bc, self.bd
        t = self.t0 + u * self.dt
        i = span_at(bc, t)
        b0 = bc[i]
        hc = bc[i + 1] - b0
        s = (t - b0) / hc
        T = self.T0 + U * self.dT
        j = span_at(bd, T)
        b1 = bd[j]
        hd = bd[j + 1] - b1
        sig = (T - b1) / hd
        rows = self._rows.get(i * self.spans_d + j)
        if rows is None:
            rows = self._cell_rows(i, j)
        f = fs = fg = 0.0
        for row in rows:  # powers of s, highest first
            q = dq = 0.0
            for coef in row:  # powers of σ, highest first
                dq = dq * sig + q
                q = q * sig + coef
            fs = fs * s + f
            f = f * s + q
            fg = fg * s + dq
        return f, fs / hc * self.dt, fg / hd * self.dT

    def project(self, u: float, U: float, iterations: int = 8, accept: float = 1e-12):
        """Newton projection onto f = 0 along the gradient; returns (u, U, converged)
        (converged: the last Newton step below ``accept``)."""
        size = math.inf
        for _ in range(iterations):
            f, gu, gU = self.value_gradient(u, U)
            gg = gu * gu + gU * gU
            if gg == 0.0:
                return u, U, False
            k = f / gg
            su, sU = k * gu, k * gU
            u, U = u - su, U - sU
            size = math.sqrt(su * su + sU * sU)
            # Newton converges quadratically: after a step below ``accept`` the point
            # is within ~ curvature * accept^2 of Z
            if size <= max(1e-14, accept):
                return u, U, True
        # where |grad f| is small (near a small loop or a saddle) round-off in f keeps
        # the last Newton steps near 1e-14 instead of 0: the point is on Z all the same
        return u, U, size <= accept

    def value_gradient_many(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(f (N,), (f_u, f_U) (N, 2)) at unit points (N, 2), batched."""
        t, T = self.params(x)
        f, g = self.field.value_gradient(t, T)
        return f, g * [self.dt, self.dT]

    def project_on_lines(self, x: np.ndarray, direction: np.ndarray, iterations: int = 8) -> np.ndarray:
        """Points (N, 2) moved along their own unit directions (N, 2) onto f = 0 (Newton
        on each line, batched); NaN where Newton does not settle to 1e-12."""
        x = np.array(x, dtype=np.float64, copy=True)
        active = np.arange(len(x))
        for _ in range(iterations):
            if len(active) == 0:
                break
            f, g = self.value_gradient_many(x[active])
            slope = np.einsum("ij,ij->i", g, direction[active])
            with np.errstate(divide="ignore", invalid="ignore"):
                step = f / slope
            x[active] -= step[:, None] * direction[active]
            active = active[~(np.abs(step) <= 1e-12)]
        x[active] = np.nan
        return x

    def tangent(self, u: float, U: float) -> tuple[float, float]:
        _, gu, gU = self.value_gradient(u, U)
        n = math.hypot(gu, gU)
        return (-gU / n, gu / n) if n > 0 else (0.0, 0.0)

def find_seeds(field: DevelopabilityField, tol: Tolerances, extra_u=(), extra_U=()) -> GridSeeds:
    """All roots of f on the grid lines, batched (one matrix product per direction).

    ``extra_u``, ``extra_U`` : further line positions in the unit square (lines through
    the extrema of f, so that every small loop is crossed by a seed line).
    """
    unit = _UnitField(field)
    u_lines = _merge_lines(grid_lines(field.c.breakpoints, tol.grid_lines_per_span, tol.min_grid_lines), extra_u)
    U_lines = _merge_lines(grid_lines(field.d.breakpoints, tol.grid_lines_per_span, tol.min_grid_lines), extra_U)
    (line_v, T, van_u), (line_h, t, van_U) = field.roots_on_lines(
        unit.t0 + u_lines * unit.dt, unit.T0 + U_lines * unit.dT, tol.zero_relative)
    pts_v = np.column_stack([u_lines[line_v], (T - unit.T0) / unit.dT])
    pts_h = np.column_stack([(t - unit.t0) / unit.dt, U_lines[line_h]])
    return GridSeeds(
        u_lines, U_lines,
        np.vstack([pts_v, pts_h]),
        np.concatenate([np.zeros(len(pts_v), int), np.ones(len(pts_h), int)]),
        np.concatenate([line_v, line_h]),
        van_u, van_U)


class _Tracer:
    """Predictor-corrector continuation of Z from the grid seeds.

    Points are (u, U) tuples of floats and every per-step test is plain Python (bisect
    on the sorted line positions, the seeds of a line by index): a step costs a few
    field evaluations and O(log lines) besides, so a trace is linear in its length
    whatever the number of grid lines and seeds.
    """

    def __init__(self, field: DevelopabilityField, seeds: GridSeeds, tol: Tolerances,
                 caps: StepCaps = NO_CAPS):
        self.unit = _UnitField(field)
        self.seeds = seeds
        self.pts = [tuple(p) for p in seeds.points.reshape(-1, 2).tolist()]
        self.tol = tol
        self.caps = [tuple(row) for row in np.column_stack(
            [caps.points.reshape(-1, 2), caps.gap, caps.slope]).tolist()]
        self.visited = np.zeros(len(seeds.points), dtype=bool)
        self.tree = cKDTree(seeds.points.reshape(-1, 2))
        # a root at a grid node is found on both of its lines: marking one marks both
        # (the few pairs closer than a junction, from the tree; every other seed is alone)
        self.partners: dict[int, list[int]] = {}
        for i, j in (self.tree.query_pairs(tol.junction) if len(seeds.points) else ()):
            self.partners.setdefault(i, []).append(j)
            self.partners.setdefault(j, []).append(i)
        # seeds per line, for matching crossings
        self.by_line: dict[tuple[int, int], list[int]] = {}
        for k, key in enumerate(zip(seeds.line_axis.tolist(), seeds.line_index.tolist())):
            line = self.by_line.get(key)
            if line is None:
                self.by_line[key] = [k]
            else:
                line.append(k)
        self.lines = (seeds.u_lines.tolist(), seeds.U_lines.tolist())
        kinks = []
        for curve in (field.c, field.d):
            inner = curve.breakpoints[1:-1]
            kinks.append(((inner[curve.knot_continuity() <= 1] - curve.domain[0]) / np.ptp(curve.domain)).tolist())
        self.kinks = tuple(kinks)

    def same(self, k: int) -> list[int]:
        """Seed k and every seed at the same point (within a junction)."""
        return [k, *self.partners.get(k, ())]

    def _mark(self, k: int) -> None:
        """Mark seed k and every seed at the same point."""
        self.visited[k] = True
        for m in self.partners.get(k, ()):
            self.visited[m] = True

    def _cap(self, x) -> float:
        """Largest step at x near critical points (see :class:`StepCaps`)."""
        if not self.caps:
            return math.inf
        u, U = x
        return min(0.25 * (gap + slope * math.hypot(pu - u, pU - U)) for pu, pU, gap, slope in self.caps)

    def _nearest_on_line(self, axis: int, idx: int, eu: float, eU: float, within: float):
        """The seed of grid line (axis, idx) nearest (eu, eU), if closer than ``within``."""
        best, best_d = None, within
        for k in self.by_line.get((axis, idx), ()):
            p = self.pts[k]
            dist = math.hypot(p[0] - eu, p[1] - eU)
            if dist < best_d:
                best, best_d = k, dist
        return best

    # -- grid-line crossings -------------------------------------------------
    def _crossings(self, x, y) -> list[tuple[float, int]]:
        """Seeds on grid lines crossed by the chord x -> y, as (place along the chord as a
        fraction of it, seed), in that order."""
        found = []
        chord = None
        for axis in (0, 1):
            lines = self.lines[axis]
            lo, hi = (x[axis], y[axis]) if x[axis] <= y[axis] else (y[axis], x[axis])
            first, last = bisect_left(lines, lo - 1e-15), bisect_right(lines, hi + 1e-15)
            if first < last and chord is None:  # most steps cross no grid line
                chord = (y[0] - x[0], y[1] - x[1])
                length = math.hypot(*chord)
            for idx in range(first, last):
                frac = (lines[idx] - x[axis]) / chord[axis] if chord[axis] != 0.0 else 0.0
                if frac <= 1e-12:
                    continue  # the start point itself
                best = self._nearest_on_line(axis, idx, x[0] + frac * chord[0], x[1] + frac * chord[1],
                                             0.25 * length + 1e-9)
                if best is not None:
                    # ordered by where the seed itself lies along the chord: where Z crosses
                    # two lines at a shallow angle, the chord's crossings can come in the
                    # other order
                    p = self.pts[best]
                    found.append((((p[0] - x[0]) * chord[0] + (p[1] - x[1]) * chord[1]) / (length * length),
                                  best))
        found.sort()
        return found

    def _boundary_exit(self, x, y):
        """Where the chord x -> y leaves the unit square, snapped to a boundary seed."""
        chord = (y[0] - x[0], y[1] - x[1])
        best_frac, side = 2.0, None
        for axis in (0, 1):
            for bound, name in ((0.0, SIDE_NAMES[2 * axis]), (1.0, SIDE_NAMES[2 * axis + 1])):
                if chord[axis] != 0.0:
                    frac = (bound - x[axis]) / chord[axis]
                    if 0.0 <= frac < best_frac:
                        best_frac, side = frac, name
        frac = min(best_frac, 1.0)
        point = (min(max(x[0] + frac * chord[0], 0.0), 1.0), min(max(x[1] + frac * chord[1], 0.0), 1.0))
        axis = 0 if side.startswith("t_") else 1
        idx = 0 if side.endswith("start") else len(self.lines[axis]) - 1
        best = self._nearest_on_line(axis, idx, point[0], point[1], max(0.5 * math.hypot(*chord), 1e-7))
        if best is not None:
            self._mark(best)
            point = self.pts[best]
        else:
            pu, pU, ok = self.unit.project(*point)
            if ok:
                point = (float(idx > 0), pU) if axis == 0 else (pu, float(idx > 0))
        return point, side

    # -- kinks: knot lines where f is only C0 ---------------------------------
    def _kink_crossing(self, x, tangent, h: float):
        """(seed, tangent beyond) when the next step would cross a knot line where f is
        only continuous (a C1 knot of a curve: f holds C', so Z has a corner there).

        The corrector cannot follow Z round such a corner (its tangent jumps), so the
        trace goes to the root on the knot line (a seed, found by the line solver) and
        leaves it with the tangent of the cell beyond.
        """
        for axis in (0, 1):
            lines = self.kinks[axis]
            if not lines or tangent[axis] == 0.0:
                continue
            reach = x[axis] + 1.5 * h * tangent[axis]
            if tangent[axis] > 0:  # the nearest kink line strictly ahead, within reach
                k = bisect_right(lines, x[axis] + 1e-13)
                if k == len(lines) or not lines[k] < reach:
                    continue
                line = lines[k]
            else:
                k = bisect_left(lines, x[axis] - 1e-13) - 1
                if k < 0 or not lines[k] > reach:
                    continue
                line = lines[k]
            grid = self.lines[axis]
            at = bisect_left(grid, line)
            idx = min((m for m in (at - 1, at) if 0 <= m < len(grid)), key=lambda m: abs(grid[m] - line))
            along = (line - x[axis]) / tangent[axis]
            best = self._nearest_on_line(axis, idx, x[0] + along * tangent[0], x[1] + along * tangent[1],
                                         0.5 * h + 1e-9)
            if best is None:
                return None
            far = self._side_tangent(self.pts[best], axis, 1.0 if tangent[axis] > 0 else -1.0)
            return None if far is None else (best, far)
        return None

    def _side_tangent(self, x, axis: int, side: float):
        """Tangent of Z at x (on a kink line across ``axis``) in the cell on ``side``
        (+1 / -1 along the axis), pointing into that cell; None if Z does not enter it."""
        beyond = (x[0] + side * 1e-9, x[1]) if axis == 0 else (x[0], x[1] + side * 1e-9)
        far = self.unit.tangent(*beyond)
        if far[axis] * side < 0:
            far = (-far[0], -far[1])
        if far[axis] == 0.0:
            return None
        return far

    def _start_tangent(self, x, direction: float):
        """The tangent to leave a seed with; on a kink line, that of the cell it enters."""
        tu, tU = self.unit.tangent(*x)
        tangent = (tu * direction, tU * direction)
        for axis in (0, 1):
            if tangent[axis] != 0.0 and any(abs(k - x[axis]) <= 1e-12 for k in self.kinks[axis]):
                side = self._side_tangent(x, axis, 1.0 if tangent[axis] > 0 else -1.0)
                if side is not None:
                    return side
        return tangent

    # -- continuation --------------------------------------------------------
    def _step(self, x, tangent, h: float, curvature: float = 0.0):
        """One predictor-corrector step of length h from x along the unit tangent:
        ((u, U), tangent there, corrector deflection, sine of the tangent's turn (signed,
        to the left)) or None. :meth:`_UnitField.project` and
        :meth:`_UnitField.tangent` written out (the same float operations): a step is
        the tracer's inner loop, and calls cost as much as its arithmetic."""
        value_gradient = self.unit.value_gradient
        x0, x1 = x
        t0, t1 = tangent
        # predictor: the osculating parabola of the last step's curvature (signed, to
        # the left of the tangent); the corrector then moves the point ~ h^3, not h^2
        bend = 0.5 * h * h * curvature
        pu, pU = x0 + h * t0 - bend * t1, x1 + h * t1 + bend * t0
        u, U = pu, pU
        # polyline points need not be exact (they are polished afterwards and checked):
        # a Newton step of 1e-4 h is converged even where round-off keeps it from 0
        accept = max(1e-12, 1e-6 * h)
        stop = max(1e-14, accept)
        size = math.inf
        for _ in range(8):  # Newton onto f = 0 along the gradient
            f, gu, gU = value_gradient(u, U)
            gg = gu * gu + gU * gU
            if gg == 0.0:
                return None
            k = f / gg
            su, sU = k * gu, k * gU
            u, U = u - su, U - sU
            size = math.sqrt(su * su + sU * sU)
            if size <= stop:
                break
        else:
            if not size <= accept:
                return None
        _, gu, gU = value_gradient(u, U)
        n = math.hypot(gu, gU)
        nu, nU = (-gU / n, gu / n) if n > 0 else (0.0, 0.0)
        dot = nu * t0 + nU * t1
        if dot < 0:
            nu, nU, dot = -nu, -nU, -dot
        moved = math.hypot(u - x0, U - x1)
        # a corrector that pulls the point back (moved ~ 0) would let the trace stall
        # forever; one that moves it far has jumped to another arm
        if dot < 0.9 or moved > 2.0 * h or moved < 0.25 * h:
            return None
        deflection = math.hypot(u - pu, U - pU)
        if deflection > 4.0 * STEP_DEFLECTION:
            return None
        return (u, U), (nu, nU), deflection, t0 * nU - t1 * nu

    def trace_one_way(self, start, direction: float, start_seed: int | None = None):
        """(points, end kind, arcs) of the walk from ``start`` along ``direction``: arcs
        (i, j, tangent at i, tangent at j) index the walk's points where points[i] ->
        points[j] is one regular continuation step (with the grid-line seeds it crossed
        between them), along which Z is smooth and :meth:`_fill` may put further points
        (the unit tangents point along the walk; at an exit point or the closing start,
        that of the step's corrected point beside it)."""
        tol = self.tol
        at_start = set(self.same(start_seed)) if start_seed is not None else set()
        knot_roots: set[int] = set()  # knot-line roots this trace stepped onto
        x = start
        tangent = self._start_tangent(x, direction)
        if tangent == (0.0, 0.0):
            return [x], END_UNRESOLVED, []
        points = [x]
        arcs: list[tuple] = []
        h = min(tol.trace_step, self._cap(x))
        curvature = 0.0  # of Z at x, signed, estimated from the last step's turn
        travelled = 0.0
        # per-step work is a few field evaluations: skip the calls that cannot matter
        capped, kinked = bool(self.caps), bool(self.kinks[0] or self.kinks[1])
        trace_step, trace_min_step = tol.trace_step, tol.trace_min_step
        max_step = MAX_STEP_FACTOR * trace_step
        for _ in range(tol.trace_max_steps):
            attempt = None
            cap = self._cap(x) if capped else math.inf
            h = min(h, cap)
            kink = self._kink_crossing(x, tangent, min(h, trace_step)) if kinked else None
            if kink is not None:  # step onto the knot line, turn to the far side's tangent
                k, far_tangent = kink
                y = self.pts[k]
                # a loop smaller than a step around a crossing of knot lines is followed
                # from root to root on those lines: back at the start it is closed; at
                # another root met before the trace is going round without its start
                if k in at_start or k in knot_roots:
                    for _, m in self._crossings(x, y):
                        if m != k:
                            self._mark(m)
                            points.append(self.pts[m])
                    points.append(start if k in at_start else y)
                    return points, END_LOOP if k in at_start else END_UNRESOLVED, arcs
                knot_roots.add(k)
                for _, m in self._crossings(x, y):
                    if m != k:
                        self._mark(m)
                        points.append(self.pts[m])
                self._mark(k)
                travelled += math.hypot(y[0] - x[0], y[1] - x[1])
                points.append(y)
                x, tangent, curvature = y, far_tangent, 0.0
                continue
            if kinked and h > trace_step:
                # a long step stops a trace step short of a kink line, which the next
                # step then reaches root to root (the corrector cannot turn its corner)
                ahead = self._kink_distance(x, tangent, 1.5 * h)
                h = max(min(h, ahead - trace_step), trace_step)
            if h > trace_step and min(abs(tangent[0]), abs(tangent[1])) < AXIS_SLOPE:
                h = trace_step
            trial = h
            min_step = min(trace_min_step, 0.125 * cap)
            while trial >= min_step and attempt is None:
                attempt = self._step(x, tangent, trial, curvature)
                if attempt is not None and trial > trace_step:
                    far = attempt[1]
                    if (min(abs(far[0]), abs(far[1])) < AXIS_SLOPE or far[0] * tangent[0] < 0
                            or far[1] * tangent[1] < 0):
                        attempt, trial = None, 2.0 * trace_step  # halved below
                if attempt is None:
                    trial *= 0.5
            jumped = attempt is None
            if attempt is None and cap == math.inf:  # jump over a singular point along the tangent
                base = min(h, trace_step)
                for trial in (2.0 * base, 4.0 * base, 8.0 * base, 16.0 * base):
                    attempt = self._step(x, tangent, trial)
                    if attempt is not None:
                        break
            if attempt is None:
                return points, END_UNRESOLVED, arcs
            y, new_tangent, deflection, turn = attempt
            first = len(points) - 1
            if min(y) < -1e-12 or max(y) > 1.0 + 1e-12:
                exit_point, side = self._boundary_exit(x, y)
                # the grid lines crossed on the way out: along the chord to the exit point
                # (the clipped step can point elsewhere and miss their seeds)
                for _, k in self._crossings(x, exit_point):
                    p = self.pts[k]
                    if not self.visited[k] and 0 < p[0] < 1 and 0 < p[1] < 1:
                        self._mark(k)
                        points.append(p)
                points.append(exit_point)
                if not jumped:
                    arcs.append((first, len(points) - 1, tangent, new_tangent))
                return points, side, arcs
            step_len = math.hypot(y[0] - x[0], y[1] - x[1])
            travelled += step_len
            closing = travelled > 2.5 * step_len and math.hypot(y[0] - start[0], y[1] - start[1]) <= max(
                step_len * 1.01, 1e-12)
            # the closing chord ends at the start: the grid lines it crosses are those
            # between x and the start, not between x and y
            for _, k in self._crossings(x, start if closing else y):
                self._mark(k)
                points.append(self.pts[k])
            if closing:
                points.append(start)
                if not jumped:
                    arcs.append((first, len(points) - 1, tangent, new_tangent))
                return points, END_LOOP, arcs
            points.append(y)
            if not jumped:
                arcs.append((first, len(points) - 1, tangent, new_tangent))
            x, tangent = y, new_tangent
            angle = math.asin(max(-1.0, min(turn, 1.0)))
            curvature = 0.0 if jumped else angle / step_len
            # the next step: the deflection grows as h^3 (h^2 where the curvature
            # changes fast: the step then shrinks) and the turn as h
            grow = 2.0
            if deflection > 0.0:
                grow = min(grow, (STEP_DEFLECTION / deflection) ** (1.0 / 3.0))
            if angle != 0.0:
                grow = min(grow, STEP_TURN / abs(angle))
            h = min(trial * max(grow, 0.5), max_step)
        return points, END_STEP_LIMIT, arcs

    def _kink_distance(self, x, tangent, reach: float) -> float:
        """Distance along the tangent to the nearest kink line ahead, ``reach`` if none
        is nearer."""
        best = reach
        for axis in (0, 1):
            lines = self.kinks[axis]
            if not lines or tangent[axis] == 0.0:
                continue
            if tangent[axis] > 0:
                k = bisect_right(lines, x[axis] + 1e-13)
                if k < len(lines):
                    best = min(best, (lines[k] - x[axis]) / tangent[axis])
            else:
                k = bisect_left(lines, x[axis] - 1e-13) - 1
                if k >= 0:
                    best = min(best, (lines[k] - x[axis]) / tangent[axis])
        return best

    def _fill(self, walks):
        """The walks' points (each (N_w, 2)) with Z's points put between those of each arc
        longer than a trace step, so that no two points are more than ~1.25 trace steps
        apart there.

        ``walks`` : list of (points, arcs) (see :meth:`trace_one_way`). The new points
        start on the cubic Hermite curve of the arc (its end points and Z's tangents
        there) and move onto Z along the chord's normal (Newton on the line, all at
        once): each stays beside its place on the chord, in the chord's order, and the
        grid seeds of the arc are merged in by their position along the chord.
        """
        step = self.tol.trace_step
        owner, ends = [], []
        for w, (points, arcs) in enumerate(walks):
            for i, j, tx, ty in arcs:
                x, y = points[i], points[j]
                if math.hypot(y[0] - x[0], y[1] - x[1]) > 1.25 * step:
                    owner.append((w, i, j))
                    ends.append((x, y, tx, ty))
        if not owner:
            return [np.array(points, dtype=np.float64).reshape(-1, 2) for points, _ in walks]
        ends = np.array(ends)  # (K, [start, end, tangent at start, tangent at end], 2)
        a, b = ends[:, 0], ends[:, 1]
        chord = b - a
        length = np.hypot(*chord.T)
        along = chord / length[:, None]
        normal = np.column_stack([-along[:, 1], along[:, 0]])
        m0, m1 = ends[:, 2] * length[:, None], ends[:, 3] * length[:, None]
        # sub-chords per arc (a step of one trace step, whose chord is a little longer
        # or shorter, is left as it is)
        n = np.maximum(np.ceil(length / step - 0.25), 1).astype(int)
        row = np.repeat(np.arange(len(a)), n - 1)
        s = (np.arange(len(row)) - np.repeat(np.cumsum(n - 1) - (n - 1), n - 1) + 1) / n[row]
        s2, s3 = s * s, s * s * s
        guess = ((2 * s3 - 3 * s2 + 1)[:, None] * a[row] + (s3 - 2 * s2 + s)[:, None] * m0[row]
                 + (3 * s2 - 2 * s3)[:, None] * b[row] + (s3 - s2)[:, None] * m1[row])
        moved = self.unit.project_on_lines(guess, normal[row])
        ok = np.isfinite(moved).all(axis=1) & (np.hypot(*(moved - guess).T) <= 0.25 * (length / n)[row])
        # every point is ordered by its place along the walk: the original points by the
        # walk's length up to them; a filled arc's new points and seeds by their place along
        # the chord from the arc's start (unclipped: a seed where Z crosses the grid line a
        # little beyond the step's end, which the chord crossed before it, goes after it)
        walk = np.array([w for w, _, _ in owner])
        first = np.array([i for _, i, _ in owner])
        last = np.array([j for _, _, j in owner])
        arrays = [np.array(points, dtype=np.float64).reshape(-1, 2) for points, _ in walks]
        keys = [np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(x, axis=0).T))]) for x in arrays]
        start_key = np.array([keys[w][i] for w, i, _ in owner])
        scale = (np.array([keys[w][j] for w, _, j in owner]) - start_key) / length
        inner = last - first - 1  # seeds met between the ends
        if inner.any():
            arc = np.repeat(np.arange(len(a)), inner)
            idx = np.arange(len(arc)) - np.repeat(np.cumsum(inner) - inner, inner) + first[arc] + 1
            for w in range(len(walks)):
                mine = walk[arc] == w
                rel = arrays[w][idx[mine]] - a[arc[mine]]
                place = np.einsum("ij,ij->i", rel, along[arc[mine]])
                keys[w][idx[mine]] = start_key[arc[mine]] + scale[arc[mine]] * place
        fill_key = start_key[row] + scale[row] * np.einsum("ij,ij->i", moved - a[row], along[row])
        out = []
        for w in range(len(walks)):
            mine = ok & (walk[row] == w)
            x = np.vstack([arrays[w], moved[mine]])
            out.append(x[np.argsort(np.concatenate([keys[w], fill_key[mine]]), kind="stable")])
        return out

    def trace_from(self, seed_index: int) -> Trace:
        start = self.pts[seed_index]
        self._mark(seed_index)
        forward, end_f, arcs_f = self.trace_one_way(start, 1.0, seed_index)
        if end_f == END_LOOP:
            (forward,) = self._fill([(forward, arcs_f)])
            return Trace(_dedupe(forward), True, (END_LOOP, END_LOOP))
        backward, end_b, arcs_b = self.trace_one_way(start, -1.0, seed_index)
        forward, backward = self._fill([(forward, arcs_f), (backward, arcs_b)])
        pts = np.vstack([backward[::-1], forward[1:]])
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
    if len(poly) == 1 or len(points) * len(poly) <= 1 << 15:  # a small table: all distances
        return _distance_to_polyline(points, poly) <= tol
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
            # without crossing the line (only the seeds no trace passed can change)
            left = np.flatnonzero(~tracer.visited)
            tracer.visited[left[near_polyline(seeds.points[left], trace.points, 1e-6)]] = True
    return traces, seeds, tracer.visited.copy()
