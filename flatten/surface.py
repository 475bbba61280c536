"""Tensor-product NURBS surfaces: evaluation and iso-parameter curves as NURBS curves."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from math import factorial

import numpy as np
from scipy.interpolate import BSpline

from .errors import InvalidCurveError
from .nurbs import MAX_COORDINATE, MAX_DEGREE, NurbsCurve, nurbs_curve, ppoly_from_spline


def expand_knots(knots, multiplicities) -> np.ndarray:
    """Knot vector from distinct knots and their multiplicities (OpenCASCADE / STEP style)."""
    return np.repeat(np.asarray(knots, dtype=np.float64), np.asarray(multiplicities, dtype=int))


@dataclass(frozen=True, eq=False)
class NurbsSurface:
    """Poles (nu, nv, 3), weights (nu, nv), knots_u (nu + pu + 1,), knots_v (nv + pv + 1,)."""

    degree_u: int
    degree_v: int
    poles: np.ndarray
    weights: np.ndarray
    knots_u: np.ndarray
    knots_v: np.ndarray
    name: str = "surface"

    @cached_property
    def _homogeneous(self) -> np.ndarray:
        # C order whatever the poles' layout (the IGES reader gives a transposed view): einsum
        # sums in memory order, so a pickled copy (C order) would differ at 1e-16 otherwise,
        # and plates computed in worker processes would not be bit-identical
        return np.ascontiguousarray(
            np.concatenate([self.poles * self.weights[..., None], self.weights[..., None]], axis=-1))

    @property
    def domain_u(self) -> tuple[float, float]:
        return float(self.knots_u[self.degree_u]), float(self.knots_u[-self.degree_u - 1])

    @property
    def domain_v(self) -> tuple[float, float]:
        return float(self.knots_v[self.degree_v]), float(self.knots_v[-self.degree_v - 1])

    def iso_u(self, u: float, name: str | None = None) -> NurbsCurve:
        """The curve v -> S(u, v) as an exact NURBS curve of degree pv."""
        nu, nv, _ = self._homogeneous.shape
        spline = BSpline(self.knots_u, self._homogeneous.reshape(nu, nv * 4), self.degree_u)
        row = spline(float(u)).reshape(nv, 4)
        return nurbs_curve(row[:, :3] / row[:, 3:], self.degree_v, row[:, 3], self.knots_v,
                           name=name or f"{self.name}.iso_u({u:g})")

    def iso_v(self, v: float, name: str | None = None) -> NurbsCurve:
        """The curve u -> S(u, v) as an exact NURBS curve of degree pu."""
        nu, nv, _ = self._homogeneous.shape
        spline = BSpline(self.knots_v, self._homogeneous.transpose(1, 0, 2).reshape(nv, nu * 4), self.degree_v)
        col = spline(float(v)).reshape(nu, 4)
        return nurbs_curve(col[:, :3] / col[:, 3:], self.degree_u, col[:, 3], self.knots_u,
                           name=name or f"{self.name}.iso_v({v:g})")

    def plane_section_points(self, point, normal, lines: int = 400) -> np.ndarray:
        """Points of the section by the plane through ``point`` with ``normal``, (N, 3).

        Along iso-curves of the direction whose iso-curves cross the plane once each: on
        each, n . A(s) - h w(s) is a polynomial B-spline whose roots are found exactly.
        Raises ValueError when the plane misses the surface or cuts it more than once per
        iso-curve in both directions.
        """
        n = np.asarray(normal, dtype=np.float64)
        n = n / np.linalg.norm(n)
        h = float(n @ np.asarray(point, dtype=np.float64))
        for along_u in (True, False):
            lo, hi = self.domain_u if along_u else self.domain_v
            found = []
            for value in np.linspace(lo, hi, lines):
                curve = self.iso_u(value) if along_u else self.iso_v(value)
                spline = curve.homogeneous
                coef = spline.c[:, :3] @ n - h * spline.c[:, 3]
                roots = ppoly_from_spline(BSpline(spline.t, coef, spline.k)).roots(extrapolate=False)
                a, b = curve.domain
                roots = np.unique(np.round(roots[(roots >= a) & (roots <= b)], 14))
                if len(roots) > 1:
                    break
                if len(roots) == 1:
                    found.append(curve(roots)[0])
            else:
                if len(found) >= 4:
                    return np.array(found)
        raise ValueError("the plane misses the surface or cuts its iso-curves more than once in both directions")

    def grid(self, u, v) -> np.ndarray:
        """Points S(u_i, v_j) on the tensor grid of u (Nu,) and v (Nv,), shape (Nu, Nv, 3):
        two small basis matrices instead of one per point."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        v = np.atleast_1d(np.asarray(v, dtype=np.float64))
        bu = BSpline.design_matrix(np.clip(u, *self.domain_u), self.knots_u, self.degree_u).toarray()
        bv = BSpline.design_matrix(np.clip(v, *self.domain_v), self.knots_v, self.degree_v).toarray()
        hom = np.einsum("ai,ijk,bj->abk", bu, self._homogeneous, bv, optimize=True)
        return hom[..., :3] / hom[..., 3:]

    @cached_property
    def _patches(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The surface as polynomial patches, one per pair of non-empty knot spans:
        breakpoints in u (Su+1,) and v (Sv+1,), their inverse widths (Su,), (Sv,), and
        homogeneous coefficients (Su, Sv, pv+1, (pu+1) 4) of s^a sigma^b in the local
        (s, sigma) in [0, 1]^2 of the patch: the Taylor coefficients at its lower corner
        (de Boor derivatives of the net, right limits at the knots)."""
        nu, nv, _ = self._homogeneous.shape
        pu, pv = self.degree_u, self.degree_v
        lo_u, hi_u = self.domain_u
        lo_v, hi_v = self.domain_v
        bu = np.unique(self.knots_u[(self.knots_u >= lo_u) & (self.knots_u <= hi_u)])
        bv = np.unique(self.knots_v[(self.knots_v >= lo_v) & (self.knots_v <= hi_v)])
        wu, wv = np.diff(bu), np.diff(bv)
        along_u = BSpline(self.knots_u, self._homogeneous.reshape(nu, nv * 4), pu)
        # (a, Su, nv, 4): d^a/du^a / a! at the u spans' starts, times width^a
        du = np.stack([along_u(bu[:-1], nu=a).reshape(-1, nv, 4) * (wu[:, None, None] ** a / factorial(a))
                       for a in range(pu + 1)])
        su = len(bu) - 1
        net = du.transpose(2, 0, 1, 3).reshape(nv, (pu + 1) * su * 4)
        along_v = BSpline(self.knots_v, net, pv)
        dv = np.stack([along_v(bv[:-1], nu=b).reshape(-1, pu + 1, su, 4) * (wv[:, None, None, None] ** b / factorial(b))
                       for b in range(pv + 1)])  # (b, Sv, a, Su, 4)
        # (Su, Sv, b, a * 4): a point's sigma row times its patch's matrix is one small product
        coef = np.ascontiguousarray(dv.transpose(3, 1, 0, 2, 4)).reshape(su, len(bv) - 1, pv + 1, (pu + 1) * 4)
        for array in (bu, bv, coef):
            array.setflags(write=False)
        return bu, 1.0 / wu, bv, 1.0 / wv, coef

    def partials(self, u, v) -> tuple[np.ndarray, np.ndarray]:
        """S_u and S_v (N, 3) at (u_k, v_k) by differences over 1e-6 of each domain, central
        inside it and one-sided at its edges (one evaluation of the 4 N points)."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        v = np.atleast_1d(np.asarray(v, dtype=np.float64))
        hu, hv = 1e-6 * np.ptp(self.domain_u), 1e-6 * np.ptp(self.domain_v)
        u0, u1 = np.clip(u - hu, *self.domain_u), np.clip(u + hu, *self.domain_u)
        v0, v1 = np.clip(v - hv, *self.domain_v), np.clip(v + hv, *self.domain_v)
        n = len(u)
        at = self(np.concatenate([u0, u1, u, u]), np.concatenate([v, v, v0, v1]))
        return (at[n:2 * n] - at[:n]) / (u1 - u0)[:, None], (at[3 * n:] - at[2 * n:3 * n]) / (v1 - v0)[:, None]

    def __call__(self, u, v) -> np.ndarray:
        """Points S(u_k, v_k) for matching arrays, shape (N, 3).

        Up to degree :data:`PATCH_MAX_DEGREE` on the polynomial patches (:attr:`_patches`):
        a patch lookup and two short power rows per point (the many small evaluations of a
        plate pay per call, not per point). Above it only the (pu + 1) x (pv + 1) poles
        acting at each point take part in the basis recurrence: the dense basis matrices
        (N, nu) and (N, nv) cost N nu nv products per coordinate."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        v = np.atleast_1d(np.asarray(v, dtype=np.float64))
        out = np.empty((len(u), 3))
        if max(self.degree_u, self.degree_v) <= PATCH_MAX_DEGREE:
            bu, iwu, bv, iwv, coef = self._patches
            for k in range(0, len(u), _CHUNK):
                uu = np.clip(u[k:k + _CHUNK], *self.domain_u)
                vv = np.clip(v[k:k + _CHUNK], *self.domain_v)
                i = np.minimum(np.searchsorted(bu, uu, side="right") - 1, len(bu) - 2)
                j = np.minimum(np.searchsorted(bv, vv, side="right") - 1, len(bv) - 2)
                pu = _powers((uu - bu[i]) * iwu[i], self.degree_u)
                pv = _powers((vv - bv[j]) * iwv[j], self.degree_v)
                along = np.matmul(pv[:, None, :], coef[i, j])[:, 0].reshape(len(uu), -1, 4)  # (N, pu+1, 4)
                hom = np.matmul(pu[:, None, :], along)[:, 0]
                out[k:k + _CHUNK] = hom[:, :3] / hom[:, 3:]
            return out
        for k in range(0, len(u), _CHUNK):  # bounded temporaries: (chunk, pu+1, pv+1, 4)
            su, bu = _local_basis(np.clip(u[k:k + _CHUNK], *self.domain_u), self.knots_u, self.degree_u)
            sv, bv = _local_basis(np.clip(v[k:k + _CHUNK], *self.domain_v), self.knots_v, self.degree_v)
            rows = su[:, None, None] + np.arange(self.degree_u + 1)[None, :, None]
            cols = sv[:, None, None] + np.arange(self.degree_v + 1)[None, None, :]
            hom = np.einsum("na,nabk,nb->nk", bu, self._homogeneous[rows, cols], bv)
            out[k:k + _CHUNK] = hom[:, :3] / hom[:, 3:]
        return out


def nurbs_surface(degree_u, degree_v, poles, knots_u, knots_v, weights=None, name="surface") -> NurbsSurface:
    """Validate and build a surface (errors name the field, like :func:`nurbs_curve`)."""
    poles = np.asarray(poles, dtype=np.float64)
    if poles.ndim != 3 or poles.shape[2] != 3:
        raise InvalidCurveError(f"{name}.poles must have shape (nu, nv, 3), got {poles.shape}")
    if not np.all(np.isfinite(poles)):
        raise InvalidCurveError(f"{name}.poles hold a value that is not finite")
    nu, nv, _ = poles.shape
    w = np.ones((nu, nv)) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (nu, nv) or not np.all(w > 0):
        raise InvalidCurveError(f"{name}.weights must be positive with shape {(nu, nv)}")
    ku, kv = np.asarray(knots_u, dtype=np.float64), np.asarray(knots_v, dtype=np.float64)
    if np.abs(poles).max(initial=0.0) > MAX_COORDINATE:
        raise InvalidCurveError(f"{name}.poles reach {np.abs(poles).max():g}, beyond +-{MAX_COORDINATE:g}")
    for label, knots, n, p in (("knots_u", ku, nu, degree_u), ("knots_v", kv, nv, degree_v)):
        if not 1 <= p <= MAX_DEGREE:
            raise InvalidCurveError(f"{name}.degree of {label[-1]} is {p}, supported: 1 to {MAX_DEGREE}")
        if n < p + 1:
            raise InvalidCurveError(f"{name} has {n} poles along {label[-1]}; degree {p} needs at least {p + 1}")
        if knots.size != n + p + 1:
            raise InvalidCurveError(f"{name}.{label} has {knots.size} values; {n} poles of degree {p} need {n + p + 1}")
        if not np.all(np.isfinite(knots)) or np.any(np.diff(knots) < 0):
            raise InvalidCurveError(f"{name}.{label} must be finite and non-decreasing")
        if not knots[-p - 1] > knots[p]:
            raise InvalidCurveError(f"{name}.{label} give an empty domain [{knots[p]}, {knots[-p - 1]}]")
    return NurbsSurface(int(degree_u), int(degree_v), np.ascontiguousarray(poles), np.ascontiguousarray(w), ku, kv,
                        name)


_CHUNK = 16384
# surfaces up to this degree are evaluated on polynomial patches (power form, which loses
# digits as the degree grows), higher ones by the basis recurrence
PATCH_MAX_DEGREE = 3


def _powers(s: np.ndarray, degree: int) -> np.ndarray:
    """Rows (1, s, ..., s^degree), shape (N, degree + 1)."""
    out = np.empty((len(s), degree + 1))
    out[:, 0] = 1.0
    for a in range(1, degree + 1):
        out[:, a] = out[:, a - 1] * s
    return out


def _local_basis(x: np.ndarray, knots: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Index of the first basis function acting at each x (N,) and the p + 1 values of the
    acting ones (N, p + 1): the triangular Cox-de Boor recurrence on all points at once
    (scipy's design matrix builds a sparse matrix per call, ~0.2 ms)."""
    p = degree
    n = len(knots) - p - 1  # basis functions
    span = np.clip(np.searchsorted(knots, x, side="right") - 1, p, n - 1)
    values = np.zeros((len(x), p + 1))
    values[:, 0] = 1.0
    left = np.empty((len(x), p + 1))
    right = np.empty((len(x), p + 1))
    for j in range(1, p + 1):
        left[:, j] = x - knots[span + 1 - j]
        right[:, j] = knots[span + j] - x
        saved = np.zeros(len(x))
        for r in range(j):
            temp = values[:, r] / (right[:, r + 1] + left[:, j - r])
            values[:, r] = saved + right[:, r + 1] * temp
            saved = left[:, j - r] * temp
        values[:, j] = saved
    return span - p, values
