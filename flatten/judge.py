"""Judge the branches of Z: acceptable and regression pieces, turning points,
Theorem 2's curvature signs, continuity at knots, and the best acceptable path.

All functions take traces in the unit square (u, U) and the developability field.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from scipy.spatial import cKDTree

from .equation import (EDGE_REACH, EDGE_ROUNDOFF, GENERAL, DevelopabilityField, corner_knots, normalized_residual,
                       root_along, ruling_determinant)
from .nurbs import NurbsCurve
from .solution import (Branch, Coverage, CurvatureMismatch, KnotCrossing, Path, Piece,
                       TurningPoint)
from .tracer import Trace


# A polyline crossing is a true crossing of two branches only where f vanishes to this
# normalised residual (the saddle's f0 of a near-tangent pair does not).
CROSSING_RESIDUAL = 1e-12
# A polished point inside the square whose normalised residual is at most this is not
# finished on the curves' own g (see UnitMap._on_curves): it lies on Z to round-off.
RESIDUAL_FLOOR = 1e-14


class UnitMap:
    """Conversions between the unit square and the curves' parameters."""

    def __init__(self, field: DevelopabilityField):
        self.field = field
        self.lo = np.array([field.c.domain[0], field.d.domain[0]])
        self.width = np.array([np.ptp(field.c.domain), np.ptp(field.d.domain)])

    def to_params(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x)
        # the sides map onto the domain ends exactly (branch ends, corner fans)
        return np.where(x >= 1.0, self.lo + self.width, self.lo + x * self.width)

    @cached_property
    def corner_lines(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit positions of the C0 knots of c and of d (corners: the solution jumps)."""
        return tuple((corner_knots(curve) - lo) / width for curve, lo, width in (
            (self.field.c, self.lo[0], self.width[0]), (self.field.d, self.lo[1], self.width[1])))

    def to_unit(self, p: np.ndarray) -> np.ndarray:
        return (np.asarray(p) - self.lo) / self.width

    def gradient(self, x: np.ndarray) -> np.ndarray:
        """(F_u, F_U) at (N, 2) unit points, shape (N, 2)."""
        p = self.to_params(x)
        g = self.field.gradient(p[:, 0], p[:, 1])
        return g * self.width

    def hessian_terms(self, x: np.ndarray):
        p = self.to_params(x)
        f = self.field
        w = self.width
        return (f(p[:, 0], p[:, 1], 2, 0) * w[0] ** 2, f(p[:, 0], p[:, 1], 1, 1) * w[0] * w[1],
                f(p[:, 0], p[:, 1], 0, 2) * w[1] ** 2)

    def newton_terms_at(self, x: np.ndarray) -> tuple[float, np.ndarray, tuple]:
        """f, the unit gradient (2,) and the unit Hessian terms (f_uu, f_uU, f_UU) at one
        unit point x (2,), with one cell lookup: bitwise the values of the field's call,
        :meth:`gradient` and :meth:`hessian_terms` at that point (the same products)."""
        p = self.to_params(x[None])
        f, ft, fT, ftt, ftT, fTT = self.field.derivatives_at_point(
            float(p[0, 0]), float(p[0, 1]), ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)))
        w = self.width
        return np.float64(f), np.array([ft, fT]) * w, (ftt * w[0] ** 2, ftT * w[0] * w[1], fTT * w[1] ** 2)

    def project_along(self, x: np.ndarray, direction: np.ndarray, iterations: int = 8) -> np.ndarray:
        """Move points (N, 2) along one unit direction (2,) onto f = 0 (Newton on the
        line): a chord's points land on the arc beside them, never on another branch."""
        return self.project_groups(np.asarray(x)[None], np.asarray(direction)[None], iterations)[0]

    def project_groups(self, x: np.ndarray, directions: np.ndarray, iterations: int = 8) -> np.ndarray:
        """:meth:`project_along` of groups of points (G, P, 2), each group along its own
        unit direction (G, 2), in one batch: each group takes the steps, and stops where,
        it would alone (the field is evaluated point by point and each group's slopes are
        its own product), so the batch gives each group's own result bit for bit when
        P >= 2 (a one-point group alone takes the field's scalar path, in a batch its array
        path: the same point to round-off, not bit for bit)."""
        x = np.array(x, dtype=np.float64, copy=True)
        directions = np.asarray(directions, dtype=np.float64)
        moving = np.arange(len(x))
        for _ in range(iterations):
            p = self.to_params(x[moving].reshape(-1, 2))
            f, g = self.field.value_gradient(p[:, 0], p[:, 1])
            f, g = f.reshape(len(moving), -1), (g * self.width).reshape(len(moving), -1, 2)
            slope = np.matmul(g, directions[moving][:, :, None])[:, :, 0]  # a product per group, as alone
            step = np.divide(f, slope, out=np.zeros_like(f), where=np.abs(slope) > 0)
            x[moving] -= step[:, :, None] * directions[moving][:, None, :]
            # the rest converged (quadratically); a NaN step goes on, as it always did
            moving = moving[~(np.max(np.abs(step), axis=1, initial=0.0) <= 1e-15)]
            if not len(moving):
                break
        return x

    @cached_property
    def kink_lines(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit positions of the knots where f is only C0 (C1 knots of c or of d)."""
        return tuple((curve.breakpoints[1:-1][curve.knot_continuity() <= 1] - lo) / width
                     for curve, lo, width in ((self.field.c, self.lo[0], self.width[0]),
                                              (self.field.d, self.lo[1], self.width[1])))

    def polish_each(self, arrays: list[np.ndarray]) -> list[np.ndarray]:
        """:meth:`polish` of several point arrays (each (N_k, 2), N_k >= 2) in one batch:
        polishing is point by point, so the batch gives each array's own result at the
        set-up cost of one call."""
        if not arrays:
            return []
        ends = np.cumsum([len(a) for a in arrays])[:-1]
        return np.split(self.polish(np.concatenate(arrays)), ends)

    def polish(self, x: np.ndarray, iterations: int = 4, settled: float = 1e-15) -> np.ndarray:
        """Newton along the gradient onto f = 0, batched, staying in the unit square.

        A point on a side stays on it (ends of branches, fans on the boundary) and so
        does a point on a knot line where f is only C0 (its gradient is one-sided
        there): it moves along the line only, by Newton on f restricted to the line. A
        point on a corner line does not move: any ruling through a corner is a fan ruling.

        A point whose step is at most ``settled`` (unit square) stops after it. The default
        waits for a step of round-off; a larger one (1e-9, say) stops one step earlier,
        after the step whose square is round-off (Newton's error after a step of h is
        about K h^2, K the curvature of the zero set against the gradient's length).
        """
        x = np.array(x, dtype=np.float64, copy=True)
        # a point within round-off of a side is on it (where a curve has zero speed at
        # its end the residual is 0/0 just off the side)
        x[np.abs(x) <= 1e-14] = 0.0
        x[np.abs(x - 1.0) <= 1e-14] = 1.0
        fixed = np.zeros(x.shape, dtype=bool)
        for axis, lines in enumerate(self.kink_lines):
            if len(lines):
                # a point within 1e-9 of the line (a turning point at a kink found by
                # Newton on one-sided derivatives) is put on it
                gap = np.abs(x[:, axis:axis + 1] - lines[None, :])
                near = gap.min(axis=1) <= 1e-9
                x[near, axis] = lines[np.argmin(gap[near], axis=1)]
                fixed[:, axis] |= near
        for axis, lines in enumerate(self.corner_lines):
            if len(lines):
                fixed[np.any(x[:, axis:axis + 1] == lines[None, :], axis=1)] = True
        one = fixed.sum(axis=1) == 1
        any_fixed = bool(fixed.any())
        # only the points still moving are iterated: a point the step no longer moves
        # (or moves by round-off) stays (each point's iterations depend on it alone)
        active = np.arange(len(x))
        company = -1  # a settled point computed along with a last moving one
        for _ in range(iterations):
            if len(active) == 0:
                break
            xa = x[active]
            p = self.to_params(xa)
            f, g = self.field.value_gradient(p[:, 0], p[:, 1])
            g = g * self.width
            gg = np.einsum("ij,ij->i", g, g)
            ok = gg > 0
            # (the masks below are applied only where they select something: the same
            # values, without the array work for the common case of free points)
            if ok.all():
                step = (f / gg)[:, None] * g
            else:
                step = np.zeros_like(xa)
                step[ok] = (f[ok] / gg[ok])[:, None] * g[ok]
            # a point fixed on a line or lying on a side of the square (none, mostly: two
            # reductions tell) moves along its free axis only, or not at all
            on_side = None
            if any_fixed or not (xa.min() > 0.0 and xa.max() < 1.0):
                on_side = fixed[active] | (xa <= 0.0) | (xa >= 1.0)
                sided = on_side.any(axis=1)
                # on a line: Newton along the free axis
                line = (sided & (on_side.sum(axis=1) == 1)) | one[active]
                if line.any():
                    free = np.argmin(on_side, axis=1)
                    g_free = g[np.arange(len(xa)), free]
                    # (not where f is constant along the line: a fan lying on it)
                    along = line & (np.abs(g_free) > 1e-6 * np.sqrt(gg))
                    step[along] = 0.0
                    step[along, free[along]] = f[along] / g_free[along]
            # near a singular point (branch crossing) the gradient vanishes with f:
            # a long step would throw the point onto another branch
            long = np.hypot(step[:, 0], step[:, 1]) > 1e-4
            if long.any():
                step[long] = 0.0
            if on_side is not None and sided.any():
                step[on_side] = 0.0
            moved = np.minimum(np.maximum(xa - step, 0.0), 1.0)  # (np.clip's values, less overhead)
            # a step below a few ulps of the unit square leaves the point where the
            # next steps would (round-off): it is settled
            going = np.any(moved != xa, axis=1) & (np.abs(step).max(axis=1) > settled)
            if company >= 0:  # the company stays where it is: every point's result is its own
                mine = active != company
                x[active[mine]] = moved[mine]
                going &= mine
            else:
                x[active] = moved
            active = active[going]
            company = -1
            if len(active) == 1 < len(x):
                # one point alone would take the field's one-point path (other round-off):
                # a settled point keeps it company (computed along, not moved)
                company = 1 if active[0] == 0 else 0
                active = np.append(active, company)
        x[np.abs(x) <= 1e-14] = 0.0
        x[np.abs(x - 1.0) <= 1e-14] = 1.0
        return self.locate_on_sides(self._on_curves(x, fixed), fixed)

    def _on_curves(self, x: np.ndarray, fixed: np.ndarray) -> np.ndarray:
        """Points (N, 2) inside the square finished by Newton along the gradient of g
        evaluated from the curves (:func:`ruling_determinant`), (N, 2): near a far side of
        a high-degree cell the power form of f has lost digits and its root lies off Z by
        up to ~1e-9 there. A point whose residual is at most :data:`RESIDUAL_FLOOR` or
        whose first step is round-off (``EDGE_ROUNDOFF``) stays as it is; a correction is
        taken when it settles within ``EDGE_REACH`` with the normalised residual not
        larger (not across a crossing, where the gradient vanishes)."""
        if self.field.kind != GENERAL:  # (see DevelopabilityField._on_curves)
            return x
        inside = np.flatnonzero(np.all((x > 0.0) & (x < 1.0), axis=1) & ~fixed.any(axis=1))
        if len(inside) == 0:
            return x
        # (first the residual alone, from first derivatives: most points meet it already)
        p = self.to_params(x[inside])
        inside = inside[~(normalized_residual(self.field.c, self.field.d, p[:, 0], p[:, 1]) <= RESIDUAL_FLOOR)]
        if len(inside) == 0:
            return x
        y = x[inside].copy()
        g0 = at_root = None
        for _ in range(8):
            p = self.to_params(y)
            g, grad, scale = ruling_determinant(self.field.c, self.field.d, p[:, 0], p[:, 1])
            grad = grad * self.width
            gg = np.einsum("ij,ij->i", grad, grad)
            step = np.divide(g, gg, out=np.zeros_like(g), where=gg > 0)[:, None] * grad
            size = np.hypot(step[:, 0], step[:, 1])
            with np.errstate(divide="ignore", invalid="ignore"):
                g_now = np.abs(g) / scale  # the normalised residual (NaN where a curve stands still)
            if g0 is None:
                g0, at_root = g_now, size <= EDGE_ROUNDOFF
                if at_root.all():
                    return x
            done = at_root | (size <= 1e-16)
            if done.all():
                break
            y[~done] = np.minimum(np.maximum(y[~done] - step[~done], 0.0), 1.0)
        taken = (~at_root & (g_now <= g0) & (np.hypot(*(y - x[inside]).T) <= EDGE_REACH)
                 & np.all((y > 0.0) & (y < 1.0), axis=1))
        x = x.copy()
        x[inside[taken]] = y[taken]
        return x

    def locate_on_sides(self, x: np.ndarray, fixed: np.ndarray | None = None) -> np.ndarray:
        """Points (N, 2) lying on a side of the unit square moved to the root of f
        restricted to that side, (N, 2): Newton along the side on g evaluated from the
        curves (:func:`ruling_determinant`), not on the power form of f, whose round-off
        on a high-degree cell can put an end ~1e-9 off its root (degree-7 rational
        curves). A point at a corner of the square where f does not vanish (a branch
        passing within ~1e-8 of the corner, ended there by the tracer) goes to the nearer
        root on the two sides through it. Points fixed on a knot line (``fixed`` (N, 2)
        bool) and points whose side carries no root within ``EDGE_REACH`` (:func:`root_along`) stay."""
        on_side = (x == 0.0) | (x == 1.0)
        if self.field.kind != GENERAL:  # (see DevelopabilityField._on_curves)
            return x
        if fixed is not None:
            on_side &= ~fixed.any(axis=1)[:, None]
        sides = on_side.sum(axis=1)
        if not sides.any():
            return x
        x = x.copy()
        # one batch: each point on one side along that side, each corner point along both
        single = np.flatnonzero(sides == 1)
        corner = np.flatnonzero(sides == 2)
        which = np.concatenate([single, corner, corner])
        free = np.concatenate([np.argmin(on_side[single], axis=1), np.zeros(len(corner), dtype=np.intp),
                               np.ones(len(corner), dtype=np.intp)])
        moved, ok, root = self._newton_along(x[which], free)
        n = len(single)
        x[single[ok[:n]]] = moved[:n][ok[:n]]
        if len(corner):
            # the nearer root of the two sides; none where f vanishes at the corner itself
            along = [slice(n, n + len(corner)), slice(n + len(corner), None)]
            dist = np.stack([np.where(ok[k], np.abs(moved[k, axis] - x[corner, axis]), np.inf)
                             for axis, k in enumerate(along)])
            best = np.argmin(dist, axis=0)
            take = np.isfinite(dist.min(axis=0)) & ~(root[along[0]] | root[along[1]])
            for axis, k in enumerate(along):
                pick = take & (best == axis)
                x[corner[pick]] = moved[k][pick]
        return x

    def _newton_along(self, x: np.ndarray, free: np.ndarray):
        """:func:`root_along` of unit points (N, 2) along their free axes (N,): (moved unit
        points (N, 2), taken (N,), at_root (N,))."""
        p = self.to_params(x)
        t, T, taken, at_root = root_along(self.field.c, self.field.d, p[:, 0], p[:, 1], free)
        y = x.copy()
        rows = np.arange(len(x))
        y[rows, free] = self.to_unit(np.column_stack([t, T]))[rows, free]
        # the sides map onto the domain ends exactly (see :meth:`to_params`)
        y[np.abs(y) <= 1e-14] = 0.0
        y[np.abs(y - 1.0) <= 1e-14] = 1.0
        return y, taken, at_root


# ------------------------------------------------------------------ classes
def acceptable_points(unit: UnitMap, x: np.ndarray, orientation: int = 1) -> np.ndarray:
    """True where neighbouring rulings do not cross inside the strip, with T moving
    against t in the given orientation (+1: T' >= 0, -1: T' <= 0), fans included, (N,).

    Rulings cross inside the strip (regression) exactly when c(t) and d(T(t)) move to
    opposite sides of the ruling: with a, b the components of c' and dd/dt normal to
    the ruling in the tangent plane, the crossing lies at v* = a / (a - T' b), which is
    outside [0, 1] iff T' a b >= 0, i.e. f_t f_T a b <= 0.
    """
    return _acceptability(unit, x, unit.gradient(x))[:, 0 if orientation > 0 else 1]


def _acceptability(unit: UnitMap, x: np.ndarray, g: np.ndarray, derivs=None) -> np.ndarray:
    """(N, 2) :func:`acceptable_points` for orientation +1 and -1 at once, given the
    unit gradient ``g`` (N, 2) at ``x`` (the curve derivatives serve both columns);
    ``derivs`` : (c.derivatives, d.derivatives) to order 2 at the points, if known."""
    gg = np.einsum("ij,ij->i", g, g)
    p = unit.to_params(x)
    if derivs is None:
        (pc, dc), (pd, dd) = unit.field.c.derivatives(p[:, 0], 1), unit.field.d.derivatives(p[:, 1], 1)
        seconds = (None, None)
    else:
        (pc, dc, ddc), (pd, dd, ddd) = derivs
        seconds = (ddc, ddd)
    dc = _limit_tangent(unit.field.c, p[:, 0], dc, seconds[0])
    dd = _limit_tangent(unit.field.d, p[:, 1], dd, seconds[1])
    ruling = pd - pc
    rr = np.maximum(np.einsum("ij,ij->i", ruling, ruling), 1e-300)
    perp_c = dc - (np.einsum("ij,ij->i", dc, ruling) / rr)[:, None] * ruling
    perp_d = dd - (np.einsum("ij,ij->i", dd, ruling) / rr)[:, None] * ruling
    ab = np.einsum("ij,ij->i", perp_c, perp_d)
    ab_scale = np.linalg.norm(perp_c, axis=1) * np.linalg.norm(perp_d, axis=1)
    product = g[:, 0] * g[:, 1]
    same_side = product * ab <= 1e-9 * gg * ab_scale
    return np.column_stack([same_side & (product <= 1e-9 * gg), same_side & (-product <= 1e-9 * gg)])


def _limit_tangent(curve: NurbsCurve, t: np.ndarray, tangent: np.ndarray, second=None) -> np.ndarray:
    """c'(t) (N, 3), with the limit direction ±c'' where the curve stands still (a doubled
    end pole: zero speed at the end, yet a tangent direction, that of c'' pointing into
    the curve's domain); only the direction matters to the classification."""
    still = ~np.any(tangent, axis=1)
    if not still.any():
        return tangent
    out = tangent.copy()
    second = curve.derivatives(t[still], 2)[2] if second is None else second[still]
    inward = np.where(t[still] <= 0.5 * (curve.domain[0] + curve.domain[1]), 1.0, -1.0)
    out[still] = inward[:, None] * second
    return out


def _turning_point(unit: UnitMap, a: np.ndarray, b: np.ndarray, which: int):
    """Solve f = 0 and f_t = 0 (``which`` 0) or f_T = 0 (1) between two unit points by
    Newton; returns (point, kind) or None when Newton does not converge inside the
    segment's box."""
    x = 0.5 * (a + b)
    lo, hi = np.minimum(a, b) - 1e-9, np.maximum(a, b) + 1e-9
    converged = False
    for _ in range(30):
        f, g, (fuu, fuU, fUU) = unit.newton_terms_at(x)
        second = np.array([fuu, fuU]) if which == 0 else np.array([fuU, fUU])
        try:
            step = np.linalg.solve(np.array([g, second]), np.array([f, g[which]]))
        except np.linalg.LinAlgError:
            break
        x = x - step
        if not np.all(np.isfinite(x)):
            break
        if np.hypot(*step) < 1e-13:  # round-off keeps the last steps near 1e-16, not 0
            converged = True
            break
    if not converged or not (np.all(x >= lo) and np.all(x <= hi)):
        return None
    return np.clip(x, 0.0, 1.0), "dT/dt=0" if which == 0 else "dt/dT=0"


# ---------------------------------------------------------------- junctions
def _singular_points(unit: UnitMap, x: np.ndarray, tol: float) -> list:
    """Two branches can only cross where f and its gradient vanish. Newton on the
    gradient (Hessian system) from each polyline intersection x (M, 2), all at once (a
    point leaves the batch when it settles or fails); per point the crossing point, or
    None when the polylines cross only because they are chords of two branches that pass
    close to each other without meeting (or the Hessian is singular on the way)."""
    x = np.asarray(x, dtype=np.float64).reshape(-1, 2)
    y = x.copy()
    converged = np.zeros(len(x), dtype=bool)
    active = np.arange(len(x))
    for _ in range(30):
        if not len(active):
            break
        ya = y[active]
        g = unit.gradient(ya)
        fuu, fuU, fUU = unit.hessian_terms(ya)
        hessian = np.stack([np.stack([fuu, fuU], axis=-1), np.stack([fuU, fUU], axis=-1)], axis=-2)
        regular = np.ones(len(active), dtype=bool)
        step = np.full((len(active), 2), np.nan)
        try:
            step[:] = np.linalg.solve(hessian, g[..., None])[..., 0]
        except np.linalg.LinAlgError:  # a singular Hessian stops its point: the others one by one
            for k in range(len(active)):
                try:
                    step[k] = np.linalg.solve(hessian[k], g[k])
                except np.linalg.LinAlgError:
                    regular[k] = False
        moved = ya - step
        far = ~np.all(np.isfinite(moved), axis=1) | (np.hypot(*(moved - x[active]).T) > 1e-2)
        ok = regular & ~far
        y[active[ok]] = moved[ok]
        settled = ok & (np.hypot(*step.T) < 1e-15)
        converged[active[settled]] = True
        active = active[ok & ~settled]
    out: list = [None] * len(x)
    done = np.flatnonzero(converged)
    if len(done):
        z = np.clip(y[done], 0.0, 1.0)
        p = unit.to_params(z)
        # two arms of a near-tangent saddle (f0 != 0) pass each other without meeting:
        # joining them there would put a ruling off Z on the path
        residual = normalized_residual(unit.field.c, unit.field.d, p[:, 0], p[:, 1])
        for k, point, r in zip(done.tolist(), z, residual.tolist()):
            if r <= 10.0 * CROSSING_RESIDUAL:
                out[k] = point
    return out


def _segment_intersections(a: np.ndarray, b: np.ndarray, same: bool):
    """(k, fa, l, fb, point) for every crossing of polyline a's segment k with b's segment l,
    in the order of (k, l)."""
    p, r = a[:-1], np.diff(a, axis=0)
    q, s = b[:-1], np.diff(b, axis=0)
    if len(r) == 0 or len(s) == 0:
        return []
    if same and (np.all(r[:, 0] > 0) or np.all(r[:, 0] < 0) or np.all(r[:, 1] > 0) or np.all(r[:, 1] < 0)):
        return []  # strictly monotone in u or U: segments apart do not even share a u (U) range
    if not same and (np.any(a.min(axis=0) > b.max(axis=0) + 1e-12) or np.any(b.min(axis=0) > a.max(axis=0) + 1e-12)):
        return []  # bounding boxes apart
    ks, ls = _overlapping_boxes(np.minimum(a[:-1], a[1:]), np.maximum(a[:-1], a[1:]),
                                np.minimum(b[:-1], b[1:]), np.maximum(b[:-1], b[1:]), 1e-12)
    if same:
        keep = np.abs(ks - ls) > 1
        ks, ls = ks[keep], ls[keep]
    rk, sl = r[ks], s[ls]
    denom = rk[:, 0] * sl[:, 1] - rk[:, 1] * sl[:, 0]
    live = denom != 0.0
    ks, ls, rk, sl, denom = ks[live], ls[live], rk[live], sl[live], denom[live]
    qp = q[ls] - p[ks]
    fa = (qp[:, 0] * sl[:, 1] - qp[:, 1] * sl[:, 0]) / denom
    fb = (qp[:, 0] * rk[:, 1] - qp[:, 1] * rk[:, 0]) / denom
    # within one trace, segments meeting at a shared vertex (a grid crossing inserts
    # very short segments) are no crossing: only interior intersections count
    lo_f, hi_f = (1e-9, 1 - 1e-9) if same else (-1e-12, 1 + 1e-12)
    hit = (lo_f <= fa) & (fa <= hi_f) & (lo_f <= fb) & (fb <= hi_f)
    points = p[ks[hit]] + fa[hit, None] * rk[hit]
    return list(zip(ks[hit].tolist(), fa[hit].tolist(), ls[hit].tolist(), fb[hit].tolist(), points))


class CrossingOverflow(Exception):
    """The crossing candidates of two polylines exceed the judge's memory budget (a
    trace that piles up on itself: a branch that circles until its step limit)."""

    def __init__(self, pairs: int, budget: int):
        super().__init__(f"{pairs} crossing candidates (budget {budget})")
        self.pairs, self.budget = pairs, budget


def _pair_budget(k: int, l: int) -> int:
    """Candidate pairs allowed for polylines of k and l segments: a smooth polyline
    meets a few neighbours per segment; 2^20 pairs are ~25 MB of index arrays."""
    return 16 * (k + l) + 2**20


def _overlapping_boxes(lo_a, hi_a, lo_b, hi_b, slack: float):
    """(k, l) index pairs, sorted, of boxes (K, 2) and (L, 2) that overlap within ``slack``.

    Small boxes are paired through k-d trees of their centres (max norm), the few large
    ones against all: time and memory O(K + L) for polylines of short segments, not the
    O(K L) of the full table. Raises :class:`CrossingOverflow` when the candidates
    exceed :func:`_pair_budget` (segments piled up in one place): memory stays bounded.
    """
    ca, ha = 0.5 * (lo_a + hi_a), 0.5 * (hi_a - lo_a).max(axis=1)
    cb, hb = 0.5 * (lo_b + hi_b), 0.5 * (hi_b - lo_b).max(axis=1)
    cut = 2.0 * float(np.percentile(np.concatenate([ha, hb]), 90))
    small_a, small_b = ha <= cut, hb <= cut
    ia, ib = np.flatnonzero(small_a), np.flatnonzero(small_b)
    budget = _pair_budget(len(lo_a), len(lo_b))
    large = int((~small_a).sum()) * len(lo_b) + int((~small_b).sum()) * len(ia)
    if large > budget:
        raise CrossingOverflow(large, budget)
    ks, ls = [], []
    if len(ia) and len(ib):
        tree_a, tree_b, radius = cKDTree(ca[ia]), cKDTree(cb[ib]), 2.0 * cut + 2.0 * slack
        # count first (no pair list) unless even all pairs fit the budget
        if len(ia) * len(ib) > budget:
            count = int(tree_a.count_neighbors(tree_b, radius, p=np.inf))
            if count + large > budget:
                raise CrossingOverflow(count + large, budget)
        pairs = tree_a.sparse_distance_matrix(tree_b, radius, p=np.inf, output_type="ndarray")
        ks.append(ia[pairs["i"]])
        ls.append(ib[pairs["j"]])
    for k in np.flatnonzero(~small_a):  # a large box of a against every box of b
        ks.append(np.full(len(lo_b), k))
        ls.append(np.arange(len(lo_b)))
    for l in np.flatnonzero(~small_b):  # a large box of b against the small boxes of a
        ks.append(ia)
        ls.append(np.full(len(ia), l))
    if not ks:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    k, l = np.concatenate(ks).astype(np.intp), np.concatenate(ls).astype(np.intp)
    near = ((lo_a[k, 0] <= hi_b[l, 0] + slack) & (lo_b[l, 0] <= hi_a[k, 0] + slack)
            & (lo_a[k, 1] <= hi_b[l, 1] + slack) & (lo_b[l, 1] <= hi_a[k, 1] + slack))
    k, l = k[near], l[near]
    order = np.lexsort((l, k))
    return k[order], l[order]


def _point_on_polyline(point: np.ndarray, poly: np.ndarray, tol: float):
    """(segment, fraction) of the nearest point of poly if within tol, else None."""
    if len(poly) < 2:
        return None
    p, r = poly[:-1], np.diff(poly, axis=0)
    rr = np.einsum("ij,ij->i", r, r)
    frac = np.clip(np.einsum("ij,ij->i", point - p, r) / np.where(rr > 0, rr, 1.0), 0.0, 1.0)
    dist = np.hypot(*(p + frac[:, None] * r - point).T)
    k = int(np.argmin(dist))
    return (k, float(frac[k])) if dist[k] <= tol else None


# ------------------------------------------------------------------- pieces
def _classes(unit: UnitMap, x: np.ndarray, derivs=None) -> np.ndarray:
    """(N, 2) acceptability of points for orientation +1 and -1; points at singular
    points (vanishing gradient) take the class of the point before them."""
    g = unit.gradient(x)
    acc = _acceptability(unit, x, g, derivs)
    gnorm = np.hypot(*g.T)
    weak = gnorm < 1e-8 * max(np.median(gnorm), 1e-300)
    weak[:1] = False  # the first point keeps its own class
    # each weak point takes the class of the last strong point before it
    source = np.maximum.accumulate(np.where(weak, 0, np.arange(len(acc))))
    return acc[source]


def _class_boundaries(unit: UnitMap, a: np.ndarray, b: np.ndarray, columns: np.ndarray) -> list[tuple[np.ndarray, str]]:
    """Where a branch changes class between two of its points a[m], b[m] (M, 2) in the
    column ``columns[m]`` of :func:`_acceptability`, (point, kind) for each m: a turning
    point (f_t = 0 or f_T = 0, by Newton) or else by bisection along the branch (also
    where c' or d' runs along the ruling). The bisections run as one batch."""
    if not len(a):
        return []
    g = unit.gradient(np.vstack([a, b]))
    ga, gb = g[:len(a)], g[len(a):]
    found: list = [None] * len(a)
    kinds = []
    for m in range(len(a)):
        turns_t, turns_T = np.sign(ga[m, 0]) != np.sign(gb[m, 0]), np.sign(ga[m, 1]) != np.sign(gb[m, 1])
        if turns_t or turns_T:
            found[m] = _turning_point(unit, a[m], b[m], 0 if turns_t else 1)
        kinds.append("dT/dt=0" if turns_t else "dt/dT=0" if turns_T else "ruling tangent to a curve")
    left = [m for m in range(len(a)) if found[m] is None]
    if left:
        for m, point in zip(left, _bisected_class_changes(unit, a[left], b[left], columns[left])):
            found[m] = (point, kinds[m])
    return found


def _bisected_class_changes(unit: UnitMap, a: np.ndarray, b: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """The point where each branch piece a[m] -> b[m] (M, 2) changes class in column
    ``columns[m]``, by bisection along the branch (its chord's points projected onto it
    across the chord), (M, 2); batched bisection: 64 points a round, 64^4 = 1.7e7
    subdivisions, the M pieces in one batch."""
    rows = np.arange(len(a))
    start = np.array([acceptable_points(unit, a[m][None], 1 if columns[m] == 0 else -1)[0] for m in rows])
    chord = (b - a) / np.maximum(np.hypot(*(b - a).T), 1e-300)[:, None]
    normal = np.column_stack([-chord[:, 1], chord[:, 0]])
    frac = np.linspace(0.0, 1.0, 65)[:, None]
    lo, hi = np.array(a, dtype=np.float64), np.array(b, dtype=np.float64)
    for _ in range(4):
        pts = unit.project_groups(lo[:, None, :] + frac[None] * (hi - lo)[:, None, :], normal)
        flat = pts.reshape(-1, 2)
        acc = _acceptability(unit, flat, unit.gradient(flat)).reshape(len(a), len(frac), 2)
        same = acc[rows, :, columns] == start[:, None]
        k = np.where(same.all(axis=1), len(frac) - 1, np.argmin(same, axis=1))
        lo, hi = pts[rows, np.maximum(k - 1, 0)], pts[rows, k]
    return np.array([unit.project_along(0.5 * (lo[m] + hi[m])[None], normal[m])[0] for m in rows])


def split_pieces(unit: UnitMap, traces: list[Trace], tol: float, derivs=None):
    """Cut every trace where its class changes (for either orientation of d against c)
    and at junctions.

    Returns pieces as (unit points, (acceptable for +1, acceptable for -1), trace index),
    class boundaries as (unit point, kind, trace index, orientation) and the trace pairs
    (i, j, candidates, budget) whose crossings were not searched because their segment
    pairs exceed the memory budget (:class:`CrossingOverflow`).
    """
    cuts: list[list[tuple[int, float, np.ndarray]]] = [[] for _ in traces]
    turning = []
    changes = []  # (trace, segment, column) of every class change, all found in one batch
    for n, trace in enumerate(traces):
        acc = _classes(unit, trace.points, None if derivs is None else derivs[n])
        changes += [(n, int(k), column) for column in (0, 1)
                    for k in np.flatnonzero(acc[1:, column] != acc[:-1, column])]
    ends = np.array([traces[n].points[k:k + 2] for n, k, _ in changes]).reshape(-1, 2, 2)
    found = _class_boundaries(unit, ends[:, 0], ends[:, 1], np.array([c for _, _, c in changes], dtype=int))
    for (n, k, column), (point, kind) in zip(changes, found):
        x = traces[n].points
        seg = x[k + 1] - x[k]
        frac = float(np.clip((point - x[k]) @ seg / max(seg @ seg, 1e-300), 0.0, 1.0))
        cuts[n].append((k, frac, point))
        turning.append((point, kind, n, 1 if column == 0 else -1))
    unchecked = []
    for i in range(len(traces)):
        for j in range(i, len(traces)):
            try:
                crossings = _segment_intersections(traces[i].points, traces[j].points, i == j)
            except CrossingOverflow as overflow:
                unchecked.append((i, j, overflow.pairs, overflow.budget))
                continue
            found = _singular_points(unit, np.array([c[4] for c in crossings]), tol) if crossings else []
            for (k, fa, l, fb, _), point in zip(crossings, found):
                if point is None:
                    continue
                cuts[i].append((k, fa, point))
                cuts[j].append((l, fb, point))
        for j in range(len(traces)):  # an end of trace i lying on trace j
            if i == j or traces[i].closed:
                continue
            for end in (traces[i].points[0], traces[i].points[-1]):
                hit = _point_on_polyline(end, traces[j].points, tol)
                if hit is not None:
                    cuts[j].append((hit[0], hit[1], end.copy()))
    pieces, middles = [], []
    for n, trace in enumerate(traces):
        for part in _cut_polyline(trace.points, trace.closed, cuts[n], tol):
            if len(part) < 2:
                continue
            if len(part) > 2:  # judged at its middle point, below, all pieces at once
                acc = None
                middles.append(part[len(part) // 2])
            else:  # a two-point piece: judge by its direction
                slope = np.prod(part[-1] - part[0])
                acc = (bool(slope >= -1e-18), bool(slope <= 1e-18))
            pieces.append((part, acc, n))
    if middles:
        middle = np.array(middles)
        grad = unit.gradient(middle)
        judged = iter(_acceptability(unit, middle, grad).tolist())
        pieces = [(part, tuple(next(judged)) if acc is None else acc, n) for part, acc, n in pieces]
    return pieces, turning, unchecked


def _cut_polyline(points: np.ndarray, closed: bool, cuts, tol: float) -> list[np.ndarray]:
    """Split a polyline at (segment, fraction, point) cuts; a closed one is rotated first."""
    if not cuts:
        return [points]
    cuts = sorted(cuts, key=lambda c: (c[0], c[1]))
    parts, current = [], [points[0]]
    cursor = 0
    for k, frac, point in cuts:
        while cursor < k:
            cursor += 1
            current.append(points[cursor])
        current.append(point)
        parts.append(np.array(current))
        current = [point]
    for m in range(cursor + 1, len(points)):
        current.append(points[m])
    parts.append(np.array(current))
    if closed and len(parts) > 1:
        parts[0] = np.vstack([parts[-1], parts[0][1:]])
        parts.pop()
    cleaned = []
    for part in parts:
        keep = np.ones(len(part), dtype=bool)
        keep[1:] = np.hypot(*np.diff(part, axis=0).T) > 1e-15
        part = part[keep]
        # a part all within round-off of one point is no piece: two cuts at the same
        # point (a turning point found from both segments beside a seed at it)
        if len(part) >= 2 and np.abs(part - part[0]).max() > 0.1 * tol:
            cleaned.append(part)
    return cleaned


# ------------------------------------------------------------ branch kinds
def branch_kind(x: np.ndarray, closed: bool) -> str:
    if closed:
        return "loop"
    if np.ptp(x[:, 0]) <= 1e-9:
        return "fan_c"
    if np.ptp(x[:, 1]) <= 1e-9:
        return "fan_d"
    du = np.diff(x[:, 0])
    return "graph" if np.all(du >= -1e-12) or np.all(du <= 1e-12) else "curve"


# ----------------------------------------------------------- Theorem 2
def curvature_signs(c: NurbsCurve, d: NurbsCurve, params: np.ndarray, derivs=None):
    """Normal curvature signs of c and d against the strip normal along each ruling.

    Returns (kc, kd) (N,), the normal curvatures c''.ν / |c'|^2 and d''.ν / |d'|^2.
    ``derivs`` : (c.derivatives, d.derivatives) to order 2 at the points, if known.
    """
    t, T = params[:, 0], params[:, 1]
    (pc, dc, ddc), (pd, dd, ddd) = (c.derivatives(t, 2), d.derivatives(T, 2)) if derivs is None else derivs
    ruling = pd - pc
    normal = np.cross(dc, ruling)
    weak = np.linalg.norm(normal, axis=1) <= 1e-12 * np.linalg.norm(dc, axis=1) * np.linalg.norm(ruling, axis=1)
    normal[weak] = np.cross(dd[weak], ruling[weak])
    normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
    # at a zero-speed end (a doubled end pole) the curvature is undefined: report 0
    speed_c = np.einsum("ij,ij->i", dc, dc)
    speed_d = np.einsum("ij,ij->i", dd, dd)
    kc = np.einsum("ij,ij->i", ddc, normal) / np.where(speed_c > 0, speed_c, np.inf)
    kd = np.einsum("ij,ij->i", ddd, normal) / np.where(speed_d > 0, speed_d, np.inf)
    return kc, kd


def curvature_mismatches(c: NurbsCurve, d: NurbsCurve, branch: int, params: np.ndarray,
                         relative: float = 1e-9, derivs=None) -> list[CurvatureMismatch]:
    """Runs of branch points where kc and kd have strictly opposite signs."""
    kc, kd = curvature_signs(c, d, params, derivs)
    scale = max(np.abs(kc).max(initial=0.0), np.abs(kd).max(initial=0.0), 1e-300)
    bad = kc * kd < -(relative * scale) ** 2
    out = []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], bad.astype(int), [0]])))
    for a, b in zip(edges[::2], edges[1::2]):
        run = params[a:b]
        worst = a + int(np.argmin((kc * kd)[a:b]))
        ends = run[[0, -1]]
        out.append(CurvatureMismatch(
            branch, (float(run[:, 0].min()), float(run[:, 0].max())),
            (float(run[:, 1].min()), float(run[:, 1].max())),
            c(ends[:, 0]), d(ends[:, 1]), (float(params[worst, 0]), float(params[worst, 1]))))
    return out


# ------------------------------------------------------------------- knots
def knot_crossings(field: DevelopabilityField, branch: int, params: np.ndarray) -> list[KnotCrossing]:
    """One-sided T' and T'' at every interior knot of c or d the branch crosses (all
    crossings of the branch and both sides of each in one batched evaluation)."""
    hits = []  # (axis, knot index, point index), knot by knot, points in branch order
    for axis, curve in ((0, field.c), (1, field.d)):
        inner = curve.breakpoints[1:-1]
        if len(inner) == 0 or len(params) == 0:
            continue
        near = np.abs(params[None, :, axis] - inner[:, None]) <= 1e-12 * (1 + np.abs(inner[:, None]))
        n, h = np.nonzero(near)
        hits.append((np.full(len(n), axis), n, h))
    if not hits or not sum(len(h[1]) for h in hits):
        return []
    axis, n, h = (np.concatenate(x) for x in zip(*hits))
    t, T = params[h, 0], params[h, 1]
    # the cells of the point (the last span holds the domain end); on the knot's own
    # axis the two sides are the spans n and n + 1 beside it (the point may lie a few
    # ulps off the knot, on either side)
    ic, jd = field.c.span_index(t), field.d.span_index(T)
    on_c = axis == 0
    ic_lo, ic_hi = np.where(on_c, n, ic), np.where(on_c, n + 1, ic)
    jd_lo, jd_hi = np.where(on_c, jd, n), np.where(on_c, jd, n + 1)
    orders = ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
    ft, fT, ftt, ftT, fTT = field.derivatives_in_cells(np.concatenate([t, t]), np.concatenate([T, T]),
                                                       np.concatenate([ic_lo, ic_hi]),
                                                       np.concatenate([jd_lo, jd_hi]), orders)
    ok = fT != 0.0
    safe = np.where(ok, fT, 1.0)
    slope = -ft / safe
    bend = -(ftt + 2 * ftT * slope + fTT * slope**2) / safe
    k = len(t)
    s1, s2, c1, c2 = slope[:k], slope[k:], bend[:k], bend[k:]
    curves = ((field.c, "c", field.c.knot_continuity().tolist(), field.c.breakpoints.tolist()),
              (field.d, "d", field.d.knot_continuity().tolist(), field.d.breakpoints.tolist()))
    jump_first = (np.abs(s1 - s2) / (1 + np.abs(s1))).tolist()
    jump_second = (np.abs(c1 - c2) / (1 + np.abs(c1))).tolist()
    out = []
    for m in np.flatnonzero(ok[:k] & ok[k:]).tolist():
        _, name, classes, breaks = curves[axis[m]]
        out.append(KnotCrossing(branch, name, breaks[n[m] + 1], float(t[m]), float(T[m]), classes[n[m]] - 1,
                                jump_first[m], jump_second[m]))
    return out


# -------------------------------------------------------------------- path
def coverage(c: NurbsCurve, d: NurbsCurve, t_interval, T_interval) -> Coverage:
    lc = c.arc_length_at(np.asarray(t_interval))
    ld = d.arc_length_at(np.asarray(T_interval))
    return Coverage((float(t_interval[0]), float(t_interval[1])),
                    (float(T_interval[0]), float(T_interval[1])),
                    float(lc[1] - lc[0]), float(ld[1] - ld[0]),
                    float((lc[1] - lc[0]) / c.length), float((ld[1] - ld[0]) / d.length))


def strip_area(c: NurbsCurve, d: NurbsCurve, params: np.ndarray) -> float:
    """Area of the ruled strip along (N, 2) rulings [t, T], two triangles per ruling pair
    (model units squared; exact for planar quads, a lower bound otherwise)."""
    if len(params) < 2:
        return 0.0
    pc, pd = c(params[:, 0]), d(params[:, 1])
    a = np.cross(pd[:-1] - pc[:-1], pc[1:] - pc[:-1])
    b = np.cross(pd[1:] - pc[1:], pd[:-1] - pd[1:])
    return float(0.5 * (np.linalg.norm(a, axis=1) + np.linalg.norm(b, axis=1)).sum())


def path_rank(cov: Coverage) -> tuple[float, float]:
    """The path chooser's measure: the smaller covered fraction of the two curves first
    (a strip must cover both; a near-cone over ~0 of one curve ranks last), then the
    strip area. Fractions closer than 1e-6 count as equal."""
    return (round(min(cov.c_fraction, cov.d_fraction) * 1e6), cov.area)


def choose_path(c: NurbsCurve, d: NurbsCurve, pieces: list[Piece], tol: float,
                min_gain: float, orientation: int = 1) -> Path | None:
    """Best monotone chain of acceptable pieces, by :func:`path_rank`: the smaller of
    the covered arc-length fractions of c and d first, then the strip area (pieces
    meet at turning points, junctions and corner fans).

    A chain's fractions and area are the sums over its pieces (they cover consecutive
    parameter intervals), so the chains ending at each node are kept as a Pareto set
    of (c fraction, d fraction, area).

    ``orientation = -1`` looks for T decreasing while t increases (d runs the other
    way); pieces must have been classified for that orientation.
    """
    mirror = np.array([1.0, float(orientation)])
    candidates = []
    for p in pieces:
        if not p.acceptable:
            continue
        pts = p.points * mirror
        if pts[-1].sum() < pts[0].sum():
            pts = pts[::-1]
        candidates.append((p.index, pts * mirror))
    if not candidates:
        return None
    gains, covs = [], []
    for _, pts in candidates:
        cov = coverage(c, d, sorted(pts[[0, -1], 0]), sorted(pts[[0, -1], 1]))
        covs.append(cov)
        gains.append((cov.c_fraction, cov.d_fraction, strip_area(c, d, pts)))
    scale = np.array([np.ptp(c.domain), np.ptp(d.domain)])
    flat = np.vstack([pts[[0, -1]] for _, pts in candidates]) / scale
    node = -np.ones(len(flat), dtype=int)
    n_nodes = 0
    for k in range(len(flat)):
        if node[k] >= 0:
            continue
        close = np.hypot(*(flat - flat[k]).T) <= tol
        node[close & (node < 0)] = n_nodes
        n_nodes += 1
    start_node, end_node = node[0::2], node[1::2]
    order = np.argsort([(flat[2 * i] * mirror).sum() for i in range(len(candidates))], kind="stable")
    # labels: (c fraction, d fraction, area, piece, previous label or None)
    labels: list[list[tuple]] = [[] for _ in range(n_nodes)]
    for i in order:
        cf, df, area = gains[i]
        if cf + df < min_gain:
            continue
        new = [(cf, df, area, int(i), None)]
        new += [(lab[0] + cf, lab[1] + df, lab[2] + area, int(i), lab) for lab in labels[start_node[i]]]
        labels[end_node[i]] = _pareto(labels[end_node[i]] + new)
    finals = [lab for node_labels in labels for lab in node_labels]
    if not finals:
        return None
    last = max(finals, key=lambda lab: (round(min(lab[0], lab[1]) * 1e6), lab[2]))
    chain = []
    while last is not None:
        chain.append(last[3])
        last = last[4]
    chain.reverse()
    points = np.vstack([candidates[i][1] if k == 0 else candidates[i][1][1:]
                        for k, i in enumerate(chain)])
    points[:, 0] = np.maximum.accumulate(points[:, 0])
    points[:, 1] = np.maximum.accumulate(points[:, 1] * orientation) * orientation
    fans = []
    corner = {p.index for p in pieces if p.corner}
    for i in chain:
        pts = candidates[i][1]
        extra = {"corner": True} if candidates[i][0] in corner else {}
        if np.ptp(pts[:, 0]) <= 1e-9 * scale[0]:
            fans.append({"apex_on": "c", "t": float(pts[0, 0]),
                         "T_interval": sorted([float(pts[0, 1]), float(pts[-1, 1])]), **extra})
        elif np.ptp(pts[:, 1]) <= 1e-9 * scale[1]:
            fans.append({"apex_on": "d", "T": float(pts[0, 1]),
                         "t_interval": [float(pts[0, 0]), float(pts[-1, 0])], **extra})
    # a path of one piece is that piece (the usual plate): its coverage and area are known
    one = len(chain) == 1 and np.array_equal(points, candidates[chain[0]][1])
    cov = covs[chain[0]] if one else coverage(c, d, (points[0, 0], points[-1, 0]),
                                               sorted((points[0, 1], points[-1, 1])))
    cov = Coverage(cov.t_interval, cov.T_interval, cov.c_length, cov.d_length, cov.c_fraction,
                   cov.d_fraction, gains[chain[0]][2] if one else strip_area(c, d, points))
    return Path(points, tuple(candidates[i][0] for i in chain), cov, tuple(fans), orientation)


def _pareto(labels: list[tuple], keep: int = 16) -> list[tuple]:
    """Labels not dominated in (c fraction, d fraction, area), best ``keep`` of them."""
    labels = sorted(labels, key=lambda lab: (-min(lab[0], lab[1]), -lab[2]))
    out: list[tuple] = []
    for lab in labels:
        if not any(o[0] >= lab[0] - 1e-12 and o[1] >= lab[1] - 1e-12 and o[2] >= lab[2] for o in out):
            out.append(lab)
        if len(out) >= keep:
            break
    return out


def make_branch(index: int, params: np.ndarray, trace: Trace, unit_points: np.ndarray) -> Branch:
    return Branch(index, params, trace.closed, trace.ends, branch_kind(unit_points, trace.closed))


def make_turning_point(c: NurbsCurve, d: NurbsCurve, params: np.ndarray, kind: str, branch: int) -> TurningPoint:
    return TurningPoint(branch, float(params[0]), float(params[1]), kind,
                        c(params[:1])[0], d(params[1:])[0])
