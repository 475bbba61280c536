"""The region of a hull surface between two seams and two butt planes, as a fine grid mesh.

A plate's region in the surface's parameters: along the longitudinal parameter s, between
two girth curves g_lo(s) and g_hi(s) (seams), and between two planes (butts) or the
surface's own end (the hull's stem or stern). Each grid row follows the girth fraction
w in [0, 1] between the seams; its ends are where the row meets the butt planes, found by
bisection on the exact surface, so the grid's boundary lies on the seams and the butts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .surface import NurbsSurface


@dataclass(frozen=True)
class PatchGrid:
    """params (R, C, 2) surface parameters (u, v); points (R, C, 3); rows: girth fractions
    (R,) kept (rows that miss the region are dropped); ends: per kept row whether its two
    ends lie on a butt plane (True) or on the surface's end (False), (R, 2)."""

    params: np.ndarray
    points: np.ndarray
    rows: np.ndarray
    ends: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return self.points.shape[:2]

    def faces(self) -> np.ndarray:
        """Triangles (2 (R-1) (C-1), 3) of the grid, vertices numbered row-major."""
        r, c = self.shape
        idx = np.arange(r * c).reshape(r, c)
        a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
        d, e = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
        return np.concatenate([np.column_stack([a, b, e]), np.column_stack([a, e, d])]).astype(np.int64)

    def corners(self) -> np.ndarray:
        """The four corners (4, 3): seam lo at butt lo, seam lo at butt hi, seam hi at butt hi,
        seam hi at butt lo."""
        p = self.points
        return np.array([p[0, 0], p[0, -1], p[-1, -1], p[-1, 0]])

    def boundary(self) -> np.ndarray:
        """Closed boundary polyline (N, 3) around the grid (not repeated)."""
        return grid_ring(self.points)


def grid_ring(values: np.ndarray) -> np.ndarray:
    """The boundary of a grid (R, C, k) as one closed ring (2 (R + C) - 4, k), not repeated:
    first row, last column, last row back, first column back."""
    return np.vstack([values[0, :], values[1:, -1], values[-1, -2::-1], values[-2:0:-1, 0]])


def _uv(long_axis: int, s: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return (s, g) if long_axis == 0 else (g, s)


def region_grid(surface: NurbsSurface, long_axis: int, g_lo, g_hi, planes, rows: int, cols: int,
                probe: int = 400, s_range=None) -> PatchGrid | None:
    """Grid of the region between girth curves and planes; None when it is empty.

    long_axis : 0 when u runs along the hull (s = u, g = v), 1 when v does
    g_lo, g_hi : callables s (N,) -> girth parameter (N,), the two seams
    planes : (lower, upper), each (normal (3,), offset) or None for the surface's end; the
             region is where normal . p - offset >= 0 for lower and <= 0 for upper
    rows, cols : grid size (rows across the girth, columns along the length)
    s_range : optional (lo, hi) sub-range of the longitudinal parameter to search
    """
    dom = surface.domain_u if long_axis == 0 else surface.domain_v
    s_lo, s_hi = s_range if s_range is not None else dom
    s = np.linspace(s_lo, s_hi, probe)
    w = np.linspace(0.0, 1.0, rows)
    glo, ghi = np.asarray(g_lo(s), dtype=float), np.asarray(g_hi(s), dtype=float)

    def girth(ss, ww):
        a, b = np.asarray(g_lo(ss), dtype=float), np.asarray(g_hi(ss), dtype=float)
        return a + ww * (b - a)

    def margin(pts):
        """How far inside both planes (the smaller signed distance), >= 0 inside."""
        out = np.full(pts.shape[:-1], np.inf)
        for plane, sign in zip(planes, (1.0, -1.0)):
            if plane is not None:
                out = np.minimum(out, sign * (pts @ np.asarray(plane[0], dtype=float) - plane[1]))
        return out

    gg = glo[None, :] + w[:, None] * (ghi - glo)[None, :]
    ss = np.broadcast_to(s, gg.shape)
    u, v = _uv(long_axis, ss.ravel(), gg.ravel())
    probed = margin(surface(u, v).reshape(rows, probe, 3))
    mask = probed >= 0
    # each row's longest run of inside samples (the first of equal ones), all rows at once:
    # run starts and ends in row-major order pair up
    padded = np.zeros((rows, probe + 2), dtype=np.int8)
    padded[:, 1:-1] = mask
    step = np.diff(padded, axis=1)
    start_row, start = np.nonzero(step == 1)
    _, stop = np.nonzero(step == -1)
    order = np.lexsort((start, start - stop, start_row))
    rows_in, first = np.unique(start_row[order], return_index=True)
    run = np.column_stack([start[order][first], stop[order][first] - 1])  # (R, 2) first and last inside
    bounds = s[run]
    flags = np.zeros(bounds.shape, dtype=bool)
    # the run's ends that lie on a plane (a sample outside beyond them) are narrowed down
    # between the last sample inside and the first outside, all rows at once
    beyond = run + np.array([-1, 1])
    task_row, task_end = np.nonzero((beyond >= 0) & (beyond < probe))
    if len(task_row):
        i_in, i_out = run[task_row, task_end], beyond[task_row, task_end]
        ww = w[rows_in[task_row]]

        def margin_at(ss_, ww_):
            uu, vv = _uv(long_axis, ss_, girth(ss_, ww_))
            return margin(surface(uu, vv))

        bounds[task_row, task_end] = narrow_crossings(margin_at, s[i_out], s[i_in], probed[rows_in[task_row], i_out],
                                                      probed[rows_in[task_row], i_in], ww)
        flags[task_row, task_end] = True
    keep = bounds[:, 1] > bounds[:, 0]
    kept = rows_in[keep]
    ends_s = bounds[keep]
    on_plane = flags[keep]
    if len(kept) < 2:
        return None
    t = np.linspace(0.0, 1.0, cols)
    S = ends_s[:, :1] + t[None, :] * (ends_s[:, 1:] - ends_s[:, :1])
    W = np.broadcast_to(w[kept][:, None], S.shape)
    G = girth(S.ravel(), W.ravel()).reshape(S.shape)
    u, v = _uv(long_axis, S, G)
    params = np.stack([u, v], axis=-1)
    points = surface(u.ravel(), v.ravel()).reshape(len(kept), cols, 3)
    return PatchGrid(params, points, w[kept], on_plane)


# where each step tries points around the secant estimate of a crossing, in fractions of
# the bracket (the estimate's error falls as the square of the bracket, so a good one is
# caught by a near point and a poor one by a far one)
_NEAR = np.array([-1e-2, -1e-4, -1e-6, -1e-9, 0.0, 1e-9, 1e-6, 1e-4, 1e-2])


def narrow_crossings(f, lo: np.ndarray, hi: np.ndarray, f_lo: np.ndarray, f_hi: np.ndarray, data: np.ndarray,
                     bits: int = 48) -> np.ndarray:
    """Where f(x, data) (vectorised over brackets) turns >= 0, each bracketed by lo (f < 0)
    and hi (f >= 0), (N,) each: the hi end of every bracket once it is 2^-bits of its first
    width (what as many bisection steps leave) or two neighbouring floats.

    Each step evaluates, per bracket, the secant estimate, points 1e-2 to 1e-9 of the
    bracket and two ulps either side of it, and the middle, and keeps the first crossing
    from the lo end, as bisection would: a smooth crossing takes two to four evaluations of
    f (of 12 points per bracket) where bisection takes ``bits`` (of one point); where f is
    round-off noise or kinked at the crossing the middle keeps it within ``bits`` steps.
    """
    lo, hi = np.array(lo, dtype=np.float64), np.array(hi, dtype=np.float64)
    f_lo, f_hi = np.array(f_lo, dtype=np.float64), np.array(f_hi, dtype=np.float64)
    data = np.asarray(data)
    goal = np.abs(hi - lo) * 2.0 ** -bits
    active = np.arange(len(lo))
    for _ in range(bits):
        width = np.abs(hi[active] - lo[active])
        tiny = 2.0 * np.spacing(np.maximum(np.abs(lo[active]), np.abs(hi[active])))
        active = active[(width > goal[active]) & (width > tiny)]
        if not len(active):
            break
        a, b, fa, fb = lo[active], hi[active], f_lo[active], f_hi[active]
        # in fractions tau of the bracket from its lo end (the bracket may run either way)
        with np.errstate(divide="ignore", invalid="ignore"):
            guess = fa / (fa - fb)
        guess = np.where(np.isfinite(guess) & (guess > 0.0) & (guess < 1.0), guess, 0.5)
        # and two ulps of x either side: once the estimate is good to them the bracket
        # closes, where offsets in fractions of a bracket a few ulps wide fall on the estimate
        ulps = 2.0 * np.spacing(np.maximum(np.abs(a), np.abs(b))) / np.abs(b - a)
        tau = np.hstack([np.clip(guess[:, None] + _NEAR[None, :], 0.0, 1.0),
                         np.clip(guess[:, None] + ulps[:, None] * np.array([-1.0, 1.0]), 0.0, 1.0),
                         np.full((len(active), 1), 0.5)])
        tau.sort(axis=1)
        x = a[:, None] + tau * (b - a)[:, None]
        fx = f(x.ravel(), np.repeat(data[active], tau.shape[1])).reshape(x.shape)
        inside = fx >= 0
        first = np.where(inside.any(axis=1), np.argmax(inside, axis=1), tau.shape[1])  # first point inside
        rows = np.arange(len(active))
        has_in, has_out = first < tau.shape[1], first > 0
        j_in, j_out = np.minimum(first, tau.shape[1] - 1), np.maximum(first - 1, 0)
        hi[active[has_in]], f_hi[active[has_in]] = x[rows, j_in][has_in], fx[rows, j_in][has_in]
        lo[active[has_out]], f_lo[active[has_out]] = x[rows, j_out][has_out], fx[rows, j_out][has_out]
    return hi


def weld(vertices: np.ndarray, faces: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge vertices closer than ``tolerance`` (a collapsed seam end gives a whole row of
    one point) and drop the triangles that become degenerate. Returns (vertices, faces,
    index) with index[old vertex] = new vertex."""
    from scipy.spatial import cKDTree

    pairs = cKDTree(vertices).query_pairs(tolerance, output_type="ndarray")
    parent = np.arange(len(vertices))
    for i, j in pairs[np.argsort(pairs[:, 1])] if len(pairs) else []:
        ri, rj = i, j
        while parent[ri] != ri:
            ri = parent[ri]
        while parent[rj] != rj:
            rj = parent[rj]
        if ri != rj:
            parent[max(ri, rj)] = min(ri, rj)
    for k in range(len(parent)):
        r = k
        while parent[r] != r:
            r = parent[r]
        parent[k] = r
    used, new_index = np.unique(parent, return_inverse=True)
    f = new_index[faces]
    good = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    v = vertices[used]
    f = f[good]
    e1, e2 = v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]
    area = np.linalg.norm(np.cross(e1, e2), axis=1)
    f = f[area > 1e-12 * max(float(np.ptp(v, axis=0).max()), 1.0) ** 2]
    return v, f.astype(np.int64), new_index


def principal_frame(surface: NurbsSurface, u: np.ndarray, v: np.ndarray) -> tuple:
    """Principal curvatures (N, 2) [kappa_1, kappa_2] with |kappa_1| <= |kappa_2|, the
    direction (N, 2) of kappa_1 in (du, dv), and the tangents S_u, S_v (N, 3) at parameters
    u, v (N,), from central differences on the surface."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    hu = 1e-4 * np.ptp(surface.domain_u)
    hv = 1e-4 * np.ptp(surface.domain_v)
    # keep the stencil inside the domain
    u = np.clip(u, surface.domain_u[0] + hu, surface.domain_u[1] - hu)
    v = np.clip(v, surface.domain_v[0] + hv, surface.domain_v[1] - hv)
    s = {(i, j): surface(u + i * hu, v + j * hv) for i in (-1, 0, 1) for j in (-1, 0, 1)}
    su = (s[1, 0] - s[-1, 0]) / (2 * hu)
    sv = (s[0, 1] - s[0, -1]) / (2 * hv)
    suu = (s[1, 0] - 2 * s[0, 0] + s[-1, 0]) / hu**2
    svv = (s[0, 1] - 2 * s[0, 0] + s[0, -1]) / hv**2
    suv = (s[1, 1] - s[1, -1] - s[-1, 1] + s[-1, -1]) / (4 * hu * hv)
    n = np.cross(su, sv)
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    dot = lambda a, b: np.einsum("ij,ij->i", a, b)  # noqa: E731
    first = np.stack([np.stack([dot(su, su), dot(su, sv)], -1), np.stack([dot(su, sv), dot(sv, sv)], -1)], -2)
    second = np.stack([np.stack([dot(suu, n), dot(suv, n)], -1), np.stack([dot(suv, n), dot(svv, n)], -1)], -2)
    shape = np.linalg.solve(first, second)  # Weingarten map in (u, v) coordinates
    kappa, vecs = np.linalg.eig(shape)
    kappa, vecs = kappa.real, vecs.real
    order = np.argsort(np.abs(kappa), axis=1)
    k_sorted = np.take_along_axis(kappa, order, axis=1)
    least = np.take_along_axis(vecs, order[:, None, :1], axis=2)[..., 0]  # (N, 2) in (du, dv)
    return k_sorted, least, su, sv


def principal_curvatures(surface: NurbsSurface, u: np.ndarray, v: np.ndarray) -> tuple:
    """Principal curvatures (N, 2) [kappa_1, kappa_2] with |kappa_1| <= |kappa_2| and the 3D
    unit direction (N, 3) of kappa_1 (the direction of least bending: the rulings of a
    developable surface) at parameters u, v (N,), from central differences on the surface."""
    k_sorted, least, su, sv = principal_frame(surface, u, v)
    d3 = least[:, :1] * su + least[:, 1:] * sv
    d3 /= np.maximum(np.linalg.norm(d3, axis=1), 1e-300)[:, None]
    return k_sorted, d3
