"""NURBS curves: validation, evaluation, derivatives, spans, arc length, curvature.

A curve of degree p has control points P_i (n+1, 3), weights w_i > 0 and knots U
(n+p+2,). It is evaluated in homogeneous form Pw_i = (w_i P_i, w_i), a polynomial
B-spline in R^4 evaluated by :class:`scipy.interpolate.BSpline` (no hand-written de
Boor). Parameters live on the curve's own knot domain [U_p, U_{n+1}].
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache
from math import comb, factorial

import numpy as np
from scipy.interpolate import BSpline, PPoly, insert

from .errors import InvalidCurveError

# Gauss-Legendre rule used for arc length on every sub-interval of a span.
_GAUSS_ORDER = 12
_ARC_SUBDIVISIONS = 8


@lru_cache(maxsize=8)
def _gauss_rule(order: int) -> tuple[np.ndarray, np.ndarray]:
    nodes, weights = np.polynomial.legendre.leggauss(order)
    nodes.setflags(write=False)
    weights.setflags(write=False)
    return nodes, weights


# computed once (read-only): every arc-length call used to recompute them
_GAUSS_NODES, _GAUSS_WEIGHTS = _gauss_rule(_GAUSS_ORDER)

# Input limits (not tolerances): the solver's polynomial in T has degree 2p - 2, and it is
# certified up to p = 9 in tests/test_hostile_inputs.py; coordinates beyond 1e9 model units
# (1000 km in mm) overflow the products of four coordinates in the developability
# determinant long before they mean a real part.
MAX_DEGREE = 9
MAX_COORDINATE = 1e9
MAX_CONTROL_POINTS = 100_000
MAX_WEIGHT_RATIO = 1e10  # beyond it the homogeneous coordinates lose every digit of the light points
# knot values: derivatives scale with 1 / domain width, and products of four of them must
# stay far from overflow
MAX_KNOT = 1e12
MIN_DOMAIN = 1e-12


def ppoly_from_spline(spline: BSpline) -> PPoly:
    """The piecewise polynomial of a scalar B-spline, one piece per non-empty knot span.

    Same result as ``PPoly.from_spline``, which crashes the interpreter for degree >= 8
    (fitpack's fixed work arrays, scipy issue 4343): the Taylor coefficients are taken
    from ``BSpline`` derivatives at each span's left end (right limits) instead.
    """
    k = spline.k
    t = np.asarray(spline.t)
    x = np.unique(t[k: len(t) - k])
    coef = np.array([spline(x[:-1], nu=k - m) / factorial(k - m) for m in range(k + 1)])
    return PPoly(coef.reshape(k + 1, len(x) - 1), x, extrapolate=spline.extrapolate)


def spline_piece(spline: BSpline, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """(coefficients, knots) of the exact piece of a B-spline over [a, b] inside its domain:
    knots inserted to full multiplicity (the degree) at the cuts, the coefficients between
    them kept, the knot vector clamped at a and b. The coefficients keep any trailing axes
    (homogeneous points, a surface's rows)."""
    p, t = spline.k, np.asarray(spline.t)
    lo, hi = t[p], t[-p - 1]
    for x in (a, b):
        have = int(np.count_nonzero(spline.t == x))
        if lo < x < hi and have < p:
            spline = insert(x, spline, m=p - have)
    t = spline.t
    first = int(np.flatnonzero(t == a)[-1]) - p
    last = int(np.flatnonzero(t == b)[0]) - 1
    knots = np.concatenate([np.full(p + 1, a), t[(t > a) & (t < b)], np.full(p + 1, b)])
    return spline.c[first:last + 1], knots


def _readonly(array: np.ndarray) -> np.ndarray:
    array = np.array(array, dtype=np.float64, copy=True, order="C")  # one layout, pickled or not
    array.setflags(write=False)
    return array


def clamped_uniform_knots(n_points: int, degree: int) -> np.ndarray:
    """Clamped uniform knot vector on [0, 1] for ``n_points`` control points, shape (n_points + degree + 1,)."""
    interior = np.linspace(0.0, 1.0, n_points - degree + 1)[1:-1]
    return np.concatenate([np.zeros(degree + 1), interior, np.ones(degree + 1)])


@dataclass(frozen=True, eq=False)
class NurbsCurve:
    """A validated NURBS curve. Build it with :func:`nurbs_curve`.

    Attributes
    ----------
    degree : int
    control_points : (n+1, 3) float array, read-only, model units
    weights : (n+1,) float array, read-only, all > 0
    knots : (n+degree+2,) float array, read-only, non-decreasing
    name : str, used in messages
    """

    degree: int
    control_points: np.ndarray
    weights: np.ndarray
    knots: np.ndarray
    name: str = "curve"

    # ------------------------------------------------------------------ basics
    @cached_property
    def homogeneous(self) -> BSpline:
        """The homogeneous B-spline C(t) = sum N_i(t) (w_i P_i, w_i), values in R^4."""
        pw = np.hstack([self.control_points * self.weights[:, None], self.weights[:, None]])
        return BSpline(self.knots, pw, self.degree, extrapolate=True)

    @property
    def domain(self) -> tuple[float, float]:
        """Parameter interval (U_p, U_{n+1})."""
        return float(self.knots[self.degree]), float(self.knots[-self.degree - 1])

    @cached_property
    def is_rational(self) -> bool:
        """False when all weights are equal (the curve is a polynomial B-spline)."""
        return bool(np.ptp(self.weights) > 1e-14 * np.max(self.weights))

    @cached_property
    def _constant_weight(self) -> bool:
        """Every weight the same float (not merely within :attr:`is_rational`'s 1e-14: a
        weight's derivative of 1e-14 times a coordinate of 1e6 is no round-off)."""
        return bool(np.all(self.weights == self.weights[0]))

    @cached_property
    def breakpoints(self) -> np.ndarray:
        """Distinct knots inside the domain, ends included, shape (n_spans + 1,)."""
        lo, hi = self.domain
        inner = self.knots[(self.knots >= lo) & (self.knots <= hi)]
        return _readonly(np.unique(inner))

    @property
    def n_spans(self) -> int:
        return len(self.breakpoints) - 1

    def knot_continuity(self) -> np.ndarray:
        """Continuity order C^k at each interior breakpoint, shape (n_spans - 1,): k = degree - multiplicity."""
        inner = self.breakpoints[1:-1]
        mult = np.array([np.count_nonzero(self.knots == k) for k in inner], dtype=int)
        return self.degree - mult

    def reversed(self) -> "NurbsCurve":
        """The same point set traversed backwards, on the mirrored knot domain."""
        lo, hi = self.domain
        knots = (lo + hi) - self.knots[::-1]
        return NurbsCurve(self.degree, _readonly(self.control_points[::-1]),
                          _readonly(self.weights[::-1]), _readonly(knots), self.name)

    def segment(self, a: float, b: float) -> "NurbsCurve":
        """The exact piece of the curve over [a, b] (knot insertion to full multiplicity)."""
        lo, hi = self.domain
        if not lo <= a < b <= hi:
            raise InvalidCurveError(f"{self.name}: segment [{a}, {b}] is not inside the domain [{lo}, {hi}]")
        p = self.degree
        pw, knots = spline_piece(self.homogeneous, a, b)
        return NurbsCurve(p, _readonly(pw[:, :3] / pw[:, 3:]), _readonly(pw[:, 3]), _readonly(knots), self.name)

    # -------------------------------------------------------------- evaluation
    def homogeneous_derivatives(self, t: np.ndarray, order: int) -> np.ndarray:
        """Derivatives 0..order of C(t) in R^4, shape (order+1, N, 4)."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        spline = self.homogeneous
        return np.stack([spline(t, nu=k) for k in range(order + 1)])

    def derivatives(self, t: np.ndarray, order: int = 2) -> np.ndarray:
        """Point and derivatives 1..order of the rational curve c(t), shape (order+1, N, 3).

        Leibniz rule on A = w c: c^(k) = (A^(k) - sum_{i=1..k} C(k,i) w^(i) c^(k-i)) / w.
        """
        hom = self.homogeneous_derivatives(t, order)
        a, w = hom[..., :3], hom[..., 3]
        if self._constant_weight:  # its derivatives vanish, and the sum with them
            return a / w[0][None, :, None]
        out = np.empty_like(a)
        for k in range(order + 1):
            acc = a[k].copy()
            for i in range(1, k + 1):
                acc -= comb(k, i) * w[i][:, None] * out[k - i]
            out[k] = acc / w[0][:, None]
        return out

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Points c(t), shape (N, 3)."""
        return self.derivatives(t, 0)[0]

    # ------------------------------------------------------------------- spans
    @cached_property
    def power_coefficients(self) -> np.ndarray:
        """Homogeneous span polynomials, shape (n_spans, degree+1, 4).

        Entry [i, k] is the coefficient of s^k with s = (t - b_i) / (b_{i+1} - b_i)
        in [0, 1] on span i (b = :attr:`breakpoints`).
        """
        # the Taylor coefficients of ppoly_from_spline, all four coordinates in one
        # evaluation of the homogeneous B-spline per derivative order (the same values)
        k, t = self.degree, self.knots
        x = np.unique(t[k: len(t) - k])
        desc = np.array([self.homogeneous(x[:-1], nu=k - m) / factorial(k - m) for m in range(k + 1)])
        starts = self.breakpoints[:-1]
        widths = np.diff(self.breakpoints)
        idx = np.searchsorted(x, starts, side="right") - 1
        asc = desc[::-1][:, idx].transpose(1, 0, 2)  # (n_spans, degree+1, 4) ascending powers
        return _readonly(asc * (widths[:, None] ** np.arange(k + 1))[:, :, None])

    @cached_property
    def bezier_control_points(self) -> np.ndarray:
        """Homogeneous Bezier control points of every span, shape (n_spans, degree+1, 4)."""
        p = self.degree
        # power -> Bernstein: b_j = sum_{k<=j} C(j,k)/C(p,k) a_k
        conv = np.array([[comb(j, k) / comb(p, k) if k <= j else 0.0 for k in range(p + 1)]
                         for j in range(p + 1)])
        return _readonly(np.einsum("jk,skd->sjd", conv, self.power_coefficients))

    def span_index(self, t: np.ndarray) -> np.ndarray:
        """Span containing each parameter (the last span includes the domain end), shape (N,)."""
        t = np.asarray(t, dtype=np.float64)
        idx = np.searchsorted(self.breakpoints, t, side="right") - 1
        return np.clip(idx, 0, self.n_spans - 1)

    # -------------------------------------------------------------- arc length
    @cached_property
    def _arc_table(self) -> tuple[np.ndarray, np.ndarray]:
        """Sub-interval edges (M+1,) and cumulative arc length at them (M+1,)."""
        edges = np.concatenate([np.linspace(a, b, _ARC_SUBDIVISIONS + 1)[:-1]
                                for a, b in zip(self.breakpoints[:-1], self.breakpoints[1:])]
                               + [self.breakpoints[-1:]])
        pieces = self._gauss_length(edges[:-1], edges[1:])
        return edges, np.concatenate([[0.0], np.cumsum(pieces)])

    def _gauss_length(self, a: np.ndarray, b: np.ndarray, order: int | None = None) -> np.ndarray:
        x, w = (_GAUSS_NODES, _GAUSS_WEIGHTS) if order is None else _gauss_rule(order)
        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        half = 0.5 * (b - a)
        nodes = (0.5 * (a + b))[:, None] + half[:, None] * x[None, :]
        speed = np.linalg.norm(self.derivatives(nodes.ravel(), 1)[1], axis=1).reshape(nodes.shape)
        return half * (speed @ w)

    def arc_length_at(self, t: np.ndarray) -> np.ndarray:
        """Arc length from the domain start to each t, shape (N,), model units."""
        t = np.clip(np.atleast_1d(np.asarray(t, dtype=np.float64)), *self.domain)
        edges, cumulative = self._arc_table
        idx = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(edges) - 2)
        return cumulative[idx] + self._gauss_length(edges[idx], t)

    def arc_length_along(self, t: np.ndarray) -> np.ndarray:
        """:meth:`arc_length_at` of many parameters at once (N,), model units: in order of t,
        each is integrated from the previous one or from the arc table's edge before it,
        whichever is nearer, and the pieces are summed from the edge. A piece shorter than
        1/16 of its table interval (1/64) takes 6 (4) Gauss nodes instead of 12: on the
        interval the 12-node rule is exact to round-off, and the error of an n-node rule falls
        as the piece length to the power 2n, so the short pieces are too; a dense sample costs
        a third of the evaluations."""
        t = np.clip(np.atleast_1d(np.asarray(t, dtype=np.float64)), *self.domain)
        edges, cumulative = self._arc_table
        order = np.argsort(t, kind="stable")
        ts = t[order]
        i = np.clip(np.searchsorted(edges, ts, side="right") - 1, 0, len(edges) - 2)
        first = np.ones(len(ts), dtype=bool)  # first of its table interval
        first[1:] = i[1:] != i[:-1]
        start = np.where(first, edges[i], np.concatenate([ts[:1], ts[:-1]]))
        h = (ts - start) / (edges[i + 1] - edges[i])
        piece = np.zeros(len(ts))
        for n_nodes, group in ((4, h <= 1.0 / 64.0), (6, (h > 1.0 / 64.0) & (h <= 1.0 / 16.0)), (None, h > 1.0 / 16.0)):
            sel = np.flatnonzero(group & (h > 0))
            if len(sel):
                piece[sel] = self._gauss_length(start[sel], ts[sel], n_nodes)
        # summed along each run of points in one table interval, from its edge
        total = np.cumsum(piece)
        run = np.cumsum(first) - 1
        out = np.empty(len(ts))
        out[order] = cumulative[i] + total - (total - piece)[first][run]
        return out

    @property
    def length(self) -> float:
        """Total arc length, model units."""
        return float(self._arc_table[1][-1])

    def parameter_at_length(self, s: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`arc_length_at` by Newton iterations, shape (N,)."""
        s = np.clip(np.atleast_1d(np.asarray(s, dtype=np.float64)), 0.0, self.length)
        edges, cumulative = self._arc_table
        idx = np.clip(np.searchsorted(cumulative, s, side="right") - 1, 0, len(edges) - 2)
        frac = (s - cumulative[idx]) / np.maximum(cumulative[idx + 1] - cumulative[idx], 1e-300)
        t = edges[idx] + frac * (edges[idx + 1] - edges[idx])
        for _ in range(30):
            speed = np.linalg.norm(self.derivatives(t, 1)[1], axis=1)
            step = (self.arc_length_at(t) - s) / np.maximum(speed, 1e-300)
            t = np.clip(t - step, edges[idx], edges[idx + 1])
            if np.max(np.abs(step), initial=0.0) < 1e-15 * (1.0 + np.ptp(self.domain)):
                break
        return t

    # --------------------------------------------------------------- curvature
    def curvature(self, t: np.ndarray) -> np.ndarray:
        """Curvature |c' x c''| / |c'|^3, shape (N,), 1/model units."""
        return self.speed_and_curvature(t)[1]

    def speed_and_curvature(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Speed |c'| (N,), model units per parameter, and :meth:`curvature` (N,), from one
        evaluation of the derivatives."""
        _, d1, d2 = self.derivatives(t, 2)
        speed = np.linalg.norm(d1, axis=1)
        return speed, np.linalg.norm(np.cross(d1, d2), axis=1) / speed**3

    def normal_curvature(self, t: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """Normal curvature c'' . n / |c'|^2 against unit surface normals n (N, 3), shape (N,)."""
        _, d1, d2 = self.derivatives(t, 2)
        return np.einsum("ij,ij->i", d2, normals) / np.einsum("ij,ij->i", d1, d1)


def knots_text(knots: np.ndarray, limit: int = 40) -> str:
    """A knot vector for a message: every value when there are at most ``limit``, else the
    first and last ``limit // 2``."""
    values = [f"{float(k):.10g}" for k in knots]
    if len(values) > limit:
        values = values[: limit // 2] + [f"... ({len(values) - limit} more)"] + values[-(limit // 2):]
    return "[" + ", ".join(values) + "]"


def check_knot_structure(u: np.ndarray, degree: int, field: str) -> None:
    """Refuse a finite, non-decreasing knot vector (n+degree+2,) with a non-empty domain
    that would break the curve or leave a control point without influence; the message
    names ``field`` ("curves.c.knots"), the knot and the whole vector.

    - a knot value inside the domain may appear at most ``degree`` times (the curve would
      be discontinuous there);
    - any knot value but the first and the last may appear at most ``degree`` times: with
      degree + 1 copies the domain ends there and the knots beyond it give control points
      that act nowhere (the curve evaluates to 0/0 at that end);
    - a value may appear at most degree + 1 times anywhere;
    - the first and the last control points act on the domain: knots[degree] <
      knots[degree + 1] and knots[n] < knots[n + 1].
    """
    n = len(u) - degree - 2  # index of the last control point
    lo, hi = u[degree], u[n + 1]
    inner = u[(u > lo) & (u < hi)]
    values, counts = np.unique(inner, return_counts=True)
    if np.any(counts > degree):
        k = values[np.argmax(counts)]
        raise InvalidCurveError(
            f"{field}: interior knot {k:.10g} has multiplicity {counts.max()} > degree {degree}, "
            f"the curve would be discontinuous (knots: {knots_text(u)})")
    values, counts = np.unique(u, return_counts=True)
    if np.any(counts > degree + 1):
        k = values[np.argmax(counts)]
        raise InvalidCurveError(
            f"{field}: knot {k:.10g} has multiplicity {counts.max()} > degree + 1 = {degree + 1}, "
            f"a control point would have no influence on the curve (knots: {knots_text(u)})")
    middle = (values > u[0]) & (values < u[-1]) & (counts > degree)
    if np.any(middle):
        k, m = values[middle][0], counts[middle][0]
        raise InvalidCurveError(
            f"{field}: interior knot {k:.10g} has multiplicity {m} > degree {degree} ({degree + 1} copies only "
            f"at the two ends of the knot vector): the domain would end there and the control points beyond "
            f"it act nowhere; a curve with a break is two curves (knots: {knots_text(u)})")
    for i, a, b in ((0, degree, degree + 1), (n, n, n + 1)):
        if not u[a] < u[b]:
            raise InvalidCurveError(
                f"{field}: knots[{a}] = knots[{b}] = {u[a]:.10g}: control point {i} would act nowhere on the "
                f"domain [{lo:.10g}, {hi:.10g}] (knots: {knots_text(u)})")


def nurbs_curve(control_points, degree: int = 3, weights=None, knots=None,
                name: str = "curve") -> NurbsCurve:
    """Validate the definition of a NURBS curve and build it.

    Parameters
    ----------
    control_points : (n+1, 3) array_like, model units
    degree : int >= 1
    weights : (n+1,) array_like of positive floats, default all 1
    knots : (n+degree+2,) array_like, non-decreasing, default clamped uniform on [0, 1]
    name : str, names the curve in error messages ("c", "curves.d", ...)

    Raises
    ------
    InvalidCurveError
        Naming the field and the offending value.
    """
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)):
        raise InvalidCurveError(f"{name}.degree must be an integer, got {degree!r}")
    if degree < 1:
        raise InvalidCurveError(f"{name}.degree must be >= 1, got {degree}")
    if degree > MAX_DEGREE:
        raise InvalidCurveError(f"{name}.degree {degree} is above the supported maximum {MAX_DEGREE}")
    try:
        points = np.asarray(control_points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidCurveError(f"{name}.control_points are not numbers: {exc}") from None
    if points.ndim != 2 or points.shape[1] != 3:
        raise InvalidCurveError(f"{name}.control_points must have shape (n, 3), got {points.shape}")
    bad = np.argwhere(~np.isfinite(points))
    if len(bad):
        i, j = bad[0]
        raise InvalidCurveError(f"{name}.control_points[{i}][{j}] is not finite: {points[i, j]}")
    big = np.argwhere(np.abs(points) > MAX_COORDINATE)
    if len(big):
        i, j = big[0]
        raise InvalidCurveError(f"{name}.control_points[{i}][{j}] = {points[i, j]:g} is beyond the supported "
                                f"range +-{MAX_COORDINATE:g} model units")
    n_points = len(points)
    if n_points > MAX_CONTROL_POINTS:
        raise InvalidCurveError(f"{name}.control_points has {n_points} points, more than the {MAX_CONTROL_POINTS} "
                                "supported")
    if n_points < degree + 1:
        raise InvalidCurveError(
            f"{name}.control_points has {n_points} points; degree {degree} needs at least {degree + 1}")

    if weights is None:
        w = np.ones(n_points)
    else:
        try:
            w = np.asarray(weights, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InvalidCurveError(f"{name}.weights are not numbers: {exc}") from None
        if w.shape != (n_points,):
            raise InvalidCurveError(
                f"{name}.weights has {w.size} values for {n_points} control points")
        for i, value in enumerate(w):
            if not np.isfinite(value) or value <= 0:
                raise InvalidCurveError(f"{name}.weights[{i}] must be finite and > 0, got {value}")
        if w.max() > MAX_WEIGHT_RATIO * w.min():
            i = int(np.argmin(w))
            raise InvalidCurveError(f"{name}.weights[{i}] = {w[i]:g} is more than {MAX_WEIGHT_RATIO:g} times "
                                    f"smaller than the largest weight {w.max():g}")

    if knots is None:
        u = clamped_uniform_knots(n_points, degree)
    else:
        try:
            u = np.asarray(knots, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InvalidCurveError(f"{name}.knots are not numbers: {exc}") from None
        expected = n_points + degree + 1
        if u.ndim != 1 or u.size != expected:
            raise InvalidCurveError(
                f"{name}.knots has {u.size} values; {n_points} control points of degree {degree} "
                f"need {expected}")
        for i, value in enumerate(u):
            if not np.isfinite(value):
                raise InvalidCurveError(f"{name}.knots[{i}] is not finite: {value}")
        drops = np.flatnonzero(np.diff(u) < 0)
        if len(drops):
            i = drops[0] + 1
            raise InvalidCurveError(
                f"{name}.knots must be non-decreasing: knots[{i}] = {u[i]} < knots[{i - 1}] = {u[i - 1]}")
        lo, hi = u[degree], u[-degree - 1]
        if not hi > lo:
            raise InvalidCurveError(f"{name}.knots give an empty domain [{lo}, {hi}]")
        check_knot_structure(u, degree, f"{name}.knots")
        if np.abs(u).max() > MAX_KNOT or hi - lo < MIN_DOMAIN:
            raise InvalidCurveError(f"{name}.knots: the domain [{lo:g}, {hi:g}] is outside the supported "
                                    f"range (|knot| <= {MAX_KNOT:g}, width >= {MIN_DOMAIN:g})")

    # the control points whose basis functions reach into the domain make the curve; when
    # they coincide the curve is a point, whatever the other control points
    i = np.arange(n_points)
    active = (u[i] < u[-degree - 1]) & (u[i + degree + 1] > u[degree])
    size = float(np.max(np.ptp(points[active], axis=0)))
    if size == 0.0:
        raise InvalidCurveError(f"{name} has zero length: the control points acting on its knot domain all "
                                f"equal {points[active][0].tolist()}")
    return NurbsCurve(int(degree), _readonly(points), _readonly(w), _readonly(u), name)
