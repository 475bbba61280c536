"""Isometric development of a developable strip into the plane (DESIGN §1.4).

The exact development integrates along c: the developed curve has the speed |c'| and
turns at the geodesic curvature of c on the strip, κ_g = c'' . (n x c') / |c'|^3 with
n ∥ c' x (d - c); each ruling leaves it at its 3D angle to c' and keeps its length.
The integrals are spectral (Chebyshev-Lobatto nodes, exact indefinite integration of
the interpolant) on pieces split at every knot of c and every knot of d crossed by T(t),
so the result is exact to round-off whatever the ruling density.

The classic shipyard triangle-by-triangle unfolding is kept as the cross-check.
"""

from __future__ import annotations

import math

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.polynomial import chebyshev

from .equation import DevelopabilityField
from .nurbs import NurbsCurve
from .strip import batches

_NODES = 24  # Chebyshev-Lobatto nodes on a piece; fewer on the short pieces of dense strips
_NODES_SHORT = 10
_SHORT_PIECE = 1.0 / 1000.0
_MAX_PIECE = 1.0 / 64.0
_CHUNK_PIECES = 2048  # pieces per batch: N nodes each, so ~2e4 to 5e4 curve evaluations


@lru_cache(maxsize=4)
def _lobatto_integration(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Chebyshev-Lobatto nodes on [-1, 1] (ascending) and the matrix Q with
    (Q f)_i = ∫_{-1}^{x_i} p(x) dx for the interpolant p of f at the nodes."""
    x = -np.cos(np.pi * np.arange(n) / (n - 1))
    vander = chebyshev.chebvander(x, n - 1)
    inv = np.linalg.inv(vander)
    integ = np.zeros((n, n))
    for k in range(n):
        coef = np.zeros(n)
        coef[k] = 1.0
        integ[:, k] = chebyshev.chebval(x, chebyshev.chebint(coef, lbnd=-1.0))
    q = integ @ inv
    x.setflags(write=False)
    q.setflags(write=False)
    return x, q


@lru_cache(maxsize=4)
def _lobatto_antiderivative(n: int) -> np.ndarray:
    """Matrix A (n + 1, n): for the interpolant p of f at the n Chebyshev-Lobatto nodes,
    the Chebyshev coefficients of x -> ∫_{-1}^x p are A f (so that chebvander(x, n) A f is
    that integral at any x in [-1, 1]; at the nodes it is :func:`_lobatto_integration`'s Q f)."""
    x = -np.cos(np.pi * np.arange(n) / (n - 1))
    inv = np.linalg.inv(chebyshev.chebvander(x, n - 1))
    integ = np.zeros((n + 1, n))
    for k in range(n):
        coef = np.zeros(n)
        coef[k] = 1.0
        integ[:, k] = chebyshev.chebint(coef, lbnd=-1.0)
    a = integ @ inv
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Development:
    """Flat positions of the ruling ends: along_c (K, 2), along_d (K, 2), model units,
    seen from the strip normal c' x (d - c)."""

    along_c: np.ndarray
    along_d: np.ndarray

    def vertices(self, samples: np.ndarray) -> np.ndarray:
        """Flat positions of the strip vertices (K * m, 2) for ruling samples v (m,)."""
        v = np.asarray(samples)
        pts = np.empty((len(self.along_c), len(v), 2))
        for lo, hi in batches(len(pts)):  # no temporaries of the full size
            pts[lo:hi] = (self.along_c[lo:hi, None, :] * (1 - v)[None, :, None]
                          + self.along_d[lo:hi, None, :] * v[None, :, None])
        return pts.reshape(-1, 2)


def _interval_breaks(c: NurbsCurve, d: NurbsCurve, field: DevelopabilityField | None,
                     rulings: np.ndarray) -> np.ndarray:
    """Sorted t values splitting the rulings' t range at knots of c and where T(t)
    crosses a knot of d; rulings' own t values included."""
    t, T = rulings[:, 0], rulings[:, 1]
    breaks = [t]
    lo, hi = t.min(), t.max()
    inner_c = c.breakpoints[(c.breakpoints > lo) & (c.breakpoints < hi)]
    breaks.append(inner_c)
    if field is not None:
        for knot in d.breakpoints[1:-1]:
            crossing = np.flatnonzero((T[:-1] - knot) * (T[1:] - knot) < 0)
            if crossing.size == 0:
                continue
            line, roots, _ = field.roots_in_t(np.array([knot]))
            for k in crossing:
                inside = roots[(roots > t[k]) & (roots < t[k + 1])]
                breaks.append(inside[:1])
    out = np.unique(np.concatenate(breaks))
    # cap the piece length so the spectral rule never works on a long interval: n equal
    # parts of each interval (the values np.linspace(a, b, n + 1)[1:] gives, vectorised)
    width = max(np.ptp(c.domain), 1e-300)
    a, b = out[:-1], out[1:]
    n = np.maximum(np.ceil((b - a) / (width * _MAX_PIECE)), 1).astype(np.int64)
    if np.all(n == 1):
        return out
    owner = np.repeat(np.arange(len(a)), n)
    j = np.arange(len(owner)) - np.repeat(np.cumsum(n) - n, n) + 1
    step = (b - a) / n
    split = j * step[owner] + a[owner]
    last = j == n[owner]
    split[last] = b[owner[last]]
    return np.concatenate([out[:1], split])


def _T_of_t(field: DevelopabilityField | None, rulings: np.ndarray, t: np.ndarray) -> np.ndarray:
    guess = np.interp(t, rulings[:, 0], rulings[:, 1])
    # the turn rates read T through the ruling's direction: first order in its error, which the
    # power form holds to ~1e-9 of the parameter: no finishing on the curves
    return guess if field is None else field.refine_T(t, guess, iterations=6, on_curves=False)


def develop(c: NurbsCurve, d: NurbsCurve, rulings: np.ndarray,
            field: DevelopabilityField | None, chunk: int = _CHUNK_PIECES) -> Development:
    """Exact development of the strip with the given rulings (K, 2) [t, T] (t
    non-decreasing; repeated t is a fan with its apex on c). ``field`` is None for a
    flat plate, whose T(t) is then interpolated between rulings. The integration pieces
    are processed ``chunk`` at a time (memory; the result does not depend on it beyond
    round-off)."""
    return DevelopedStrip(c, d, rulings, field, chunk, interpolant=False).development


class DevelopedStrip:
    """One exact development of a strip (:func:`develop`), integrated once along c; the
    developed ends of further rulings in its t range are then integrated from the last
    break before each on that piece's spectral interpolant (its integrands are kept at its
    nodes), in the same frame, instead of re-integrating the whole strip with them.

    rulings : (K, 2) [t, T], t non-decreasing (as for :func:`develop`)
    development : the development of those rulings
    interpolant : keep the pieces' integrands for :meth:`ends` (3 N floats a piece, N = 10
        nodes: 240 bytes a ruling of a dense strip, which :func:`develop` does not keep)
    """

    def __init__(self, c: NurbsCurve, d: NurbsCurve, rulings: np.ndarray,
                 field: DevelopabilityField | None, chunk: int = _CHUNK_PIECES, interpolant: bool = True):
        rulings = np.asarray(rulings, dtype=np.float64)
        self.c, self.d, self.field, self.rulings, self.chunk = c, d, field, rulings, chunk
        breaks = _interval_breaks(c, d, field, rulings)
        # spectral error on a piece of relative length h falls like h^N: 10 nodes give round-off
        # once every piece is shorter than 1/1000 of the domain
        longest = float(np.max(np.diff(breaks), initial=0.0)) / max(np.ptp(c.domain), 1e-300)
        x, q = _lobatto_integration(_NODES_SHORT if longest <= _SHORT_PIECE else _NODES)
        n_pieces = len(breaks) - 1
        # state at every break: the start node of each piece, plus the end of the last one
        break_theta = np.zeros(n_pieces + 1)
        break_xy = np.zeros((n_pieces + 1, 2))
        # each piece's integrands at its nodes (turn rate, and the moves in x and y along the
        # developed c), times its half width: any t in the piece is integrated from them
        self._integrands = np.zeros((n_pieces, 3, len(x))) if interpolant else None
        carry = np.zeros(3)  # theta, x, y at the end of the pieces done so far
        # pieces in batches: the N nodes per piece are the largest temporaries (N curve
        # evaluations per ruling); the running sums carried across batches are summed in the
        # same order as one cumsum over all pieces
        for lo, hi in batches(n_pieces, chunk):
            a, b = breaks[lo:hi], breaks[lo + 1:hi + 1]
            theta_local, xs, ys, _, rates = self._pieces(a, b, x, q, carry[0])
            if interpolant:
                self._integrands[lo:hi] = rates
            theta_start = np.cumsum(np.concatenate([carry[:1], theta_local[:, -1]]))
            x_start = np.cumsum(np.concatenate([carry[1:2], xs[:, -1]]))
            y_start = np.cumsum(np.concatenate([carry[2:], ys[:, -1]]))
            theta = theta_local + theta_start[:-1, None]
            break_theta[lo:hi] = theta[:, 0]
            break_xy[lo:hi, 0] = x_start[:-1] + xs[:, 0]
            break_xy[lo:hi, 1] = y_start[:-1] + ys[:, 0]
            carry = np.array([theta_start[-1], x_start[-1], y_start[-1]])
            break_theta[hi] = theta[-1, -1]
            break_xy[hi] = x_start[-2] + xs[-1, -1], y_start[-2] + ys[-1, -1]
        self.breaks, self.break_theta, self.break_xy = breaks, break_theta, break_xy
        self._antiderivative = _lobatto_antiderivative(len(x))
        idx = np.clip(np.searchsorted(breaks, rulings[:, 0]), 0, len(breaks) - 1)
        along_c = break_xy[idx]
        self.development = Development(along_c, self._along_d(rulings, along_c, break_theta[idx]))

    def _pieces(self, a: np.ndarray, b: np.ndarray, x: np.ndarray, q: np.ndarray, theta0):
        """Integrals over pieces [a, b] (P,) at their N nodes: the turn of the developed c
        from a, and (with the turn started at theta0 (P,) or a scalar carried through the
        pieces in order) its x and y moves from a, (P, N) each; the nodes' T; the three
        integrands at the nodes times the pieces' half widths, (P, 3, N)."""
        half = 0.5 * (b - a)
        nodes = (0.5 * (a + b))[:, None] + half[:, None] * x[None, :]  # (P, N)
        t = nodes.ravel()
        T = _T_of_t(self.field, self.rulings, t)
        pc, dc, ddc = self.c.derivatives(t, 2)
        ruling = self.d(T) - pc
        normal = np.cross(dc, ruling)
        normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
        speed2 = np.einsum("ij,ij->i", dc, dc)
        turn_rate = np.einsum("ij,ij->i", ddc, np.cross(normal, dc)) / speed2  # dθ/dt
        shape = nodes.shape
        # products by einsum, not BLAS: these (P, N) x (N, N) products are large enough for
        # a threaded BLAS to hand them to threads, which on busy cores wait for one another
        theta_local = np.einsum("pn,mn->pm", turn_rate.reshape(shape), q) * half[:, None]
        if np.ndim(theta0) == 0:  # consecutive pieces: each starts where the previous ends
            theta_start = np.cumsum(np.concatenate([[theta0], theta_local[:, -1]]))[:-1]
        else:
            theta_start = theta0
        theta = theta_local + theta_start[:, None]
        speed = np.sqrt(speed2).reshape(shape)
        along_x, along_y = speed * np.cos(theta), speed * np.sin(theta)
        xs = np.einsum("pn,mn->pm", along_x, q) * half[:, None]
        ys = np.einsum("pn,mn->pm", along_y, q) * half[:, None]
        rates = np.stack([turn_rate.reshape(shape), along_x, along_y], axis=1) * half[:, None, None]
        return theta_local, xs, ys, T, rates

    def _along_d(self, rulings: np.ndarray, along_c: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """Developed d ends of rulings (K, 2) from their developed c ends and the turn of the
        developed c there: each ruling leaves it at its 3D angle to c'."""
        along_d = np.empty_like(along_c)
        for lo, hi in batches(len(rulings), self.chunk * _NODES):
            pc_k, dc_k = self.c.derivatives(rulings[lo:hi, 0], 1)
            r_k = self.d(rulings[lo:hi, 1]) - pc_k
            cos_phi = np.einsum("ij,ij->i", dc_k, r_k)
            sin_phi = np.linalg.norm(np.cross(dc_k, r_k), axis=1)
            angle = theta[lo:hi] + np.arctan2(sin_phi, cos_phi)
            length = np.linalg.norm(r_k, axis=1)
            along_d[lo:hi, 0] = along_c[lo:hi, 0] + length * np.cos(angle)
            along_d[lo:hi, 1] = along_c[lo:hi, 1] + length * np.sin(angle)
        return along_d

    def ends(self, rulings: np.ndarray) -> Development:
        """Developed ends of further rulings (N, 2) [t, T], any order, each t within the
        strip's t range (ValueError otherwise). The developed c at t is integrated from the
        last break before it on the spectral interpolant of that piece's integrands (the
        turn rate, and the moves in x and y, at its nodes): round-off, as the integrals
        over the pieces are, and no curve evaluation beyond each ruling's own ends."""
        if self._integrands is None:
            raise ValueError("this development kept no interpolant (DevelopedStrip(interpolant=False))")
        rulings = np.asarray(rulings, dtype=np.float64).reshape(-1, 2)
        t = rulings[:, 0]
        breaks = self.breaks
        if not len(t):
            return Development(np.zeros((0, 2)), np.zeros((0, 2)))
        if t.min() < breaks[0] or t.max() > breaks[-1]:
            raise ValueError(f"rulings at t in [{t.min():.17g}, {t.max():.17g}] reach beyond the developed "
                             f"strip's [{breaks[0]:.17g}, {breaks[-1]:.17g}]")
        along_c, theta = np.empty((len(t), 2)), np.empty(len(t))
        for lo, hi in batches(len(t), self.chunk * _NODES):
            tt = t[lo:hi]
            i = np.clip(np.searchsorted(breaks, tt, side="right") - 1, 0, max(len(breaks) - 2, 0))
            a, b = breaks[i], breaks[i + 1]
            x = np.clip((2.0 * tt - (a + b)) / (b - a), -1.0, 1.0)
            # (M, N): the weights of the piece's node values in the integral from its start to x
            vander = chebyshev.chebvander(x, self._antiderivative.shape[0] - 1)
            weights = np.einsum("mj,jn->mn", vander, self._antiderivative)  # not BLAS: as in _pieces
            moved = np.einsum("mn,mkn->mk", weights, self._integrands[i])  # (M, 3): turn, x, y
            at_break = tt == a  # the break's own state, exactly
            moved[at_break] = 0.0
            theta[lo:hi] = self.break_theta[i] + moved[:, 0]
            along_c[lo:hi] = self.break_xy[i] + moved[:, 1:]
        return Development(along_c, self._along_d(rulings, along_c, theta))


def unfold_triangles(vertices_c: np.ndarray, vertices_d: np.ndarray, first: Development) -> Development:
    """Classic triangle-by-triangle unfolding of the strip's outer triangles
    (A_k, B_k, A_k+1), (A_k+1, B_k, B_k+1) from their 3D edge lengths, starting from
    the first ruling of ``first``. Keeps every edge length; drifts by O(h^2).

    Each triangle is placed from the one before, so the plane positions are a chain: the
    3D lengths are taken for all triangles at once and the chain runs on Python floats
    (a numpy call per scalar would cost ten times the arithmetic)."""
    a3, b3 = np.asarray(vertices_c, dtype=float), np.asarray(vertices_d, dtype=float)
    step_a = np.linalg.norm(np.diff(a3, axis=0), axis=1).tolist()  # |A_k+1 - A_k|
    step_b = np.linalg.norm(np.diff(b3, axis=0), axis=1).tolist()  # |B_k+1 - B_k|
    to_b = np.linalg.norm(a3[1:] - b3[:-1], axis=1).tolist()  # |A_k+1 - B_k|
    to_next_a = np.linalg.norm(b3[1:] - a3[1:], axis=1).tolist()  # |B_k+1 - A_k+1|

    def place(p, q, r1, r2):
        """The point at distances r1 from p and r2 from q, to the right of p -> q."""
        bx, by = q[0] - p[0], q[1] - p[1]
        length = math.hypot(bx, by)
        if length == 0.0:
            return p
        along = (r1**2 - r2**2 + length**2) / (2 * length)
        h = math.sqrt(max(r1**2 - along**2, 0.0))
        ex, ey = bx / length, by / length
        return (p[0] + along * ex + h * ey, p[1] + along * ey - h * ex)

    a = tuple(map(float, first.along_c[0]))
    b = tuple(map(float, first.along_d[0]))
    a2, b2 = [a], [b]
    for k in range(len(a3) - 1):
        # A_k+1 lies on the c side of ruling k: to the right of A -> B when seen from n
        if step_a[k] != 0.0:
            a = place(a, b, step_a[k], to_b[k])
        if step_b[k] != 0.0:
            b = place(a, b, to_next_a[k], step_b[k])
        a2.append(a)
        b2.append(b)
    return Development(np.array(a2, dtype=float).reshape(-1, 2), np.array(b2, dtype=float).reshape(-1, 2))
