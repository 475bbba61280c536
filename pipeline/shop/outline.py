"""The exact cut outline of a plate: its developed boundary curves, sampled to a tolerance.

The plate's boundary is traced along the solved strip by one parameter, the fraction
lam in [0, 1] of the chosen path (``flatten.strip.sample_path``, with its set-up done once: ``PathSampler``): the ruling at lam is
polished onto the solution curve, developed exactly (``flatten.develop``) and, for hull
plates, cut by the butt planes. Its lower end runs along c (or a butt), its upper end
along d (or a butt). Each smooth piece (between plate corners) is sampled adaptively
until every segment stays within the tolerance of the exact development at its check
points, so the outline no longer depends on how many rulings the solver used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flatten.develop import DevelopedStrip
from flatten.strip import PathSampler

CHECKS = np.array([0.25, 0.5, 0.75])  # where each segment is checked against the exact curve
FLOATS = 128  # a corner's bracket this many floats wide is finished by trying each


@dataclass(frozen=True)
class Outline:
    """A closed cut contour in the plate's placed coordinates (model units).

    points : (N, 2) vertices, not repeated at the end
    edges : (N,) name of the edge each segment points[i] -> points[i + 1] lies on
        ('c', 'd', 'start', 'end'; for a hull plate start and end are its first and
        second butt planes, aft and fore)
    max_deviation : largest distance, at the check points, between the exact developed
        boundary and the outline's segments (model units)
    tolerance : the tolerance it was sampled to (model units)
    alignment_error : largest misfit between this development and the pattern's ruling
        ends after the rigid fit (model units; round-off expected)
    """

    points: np.ndarray
    edges: tuple
    max_deviation: float
    tolerance: float
    alignment_error: float

    def area(self) -> float:
        x, y = self.points[:, 0], self.points[:, 1]
        return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)))

    def edge_points(self, name: str) -> np.ndarray:
        """The vertices of one edge in outline order (its segments' starts and the last end)."""
        idx = np.flatnonzero(np.array(self.edges) == name)
        if idx.size == 0:
            return np.zeros((0, 2))
        # the edge's segments are consecutive modulo N: start after a gap
        n = len(self.points)
        gaps = np.flatnonzero(np.diff(idx) > 1)
        if gaps.size:
            idx = np.roll(idx, -(gaps[0] + 1))
        return self.points[np.append(idx, (idx[-1] + 1) % n)]

    def edge_runs(self, name: str) -> list[np.ndarray]:
        """Each stretch of consecutive segments named ``name`` (modulo N) as its own
        polyline of vertices: an edge whose name occurs in two places is two polylines,
        never one line drawn across the plate from one to the other."""
        idx = np.flatnonzero(np.array(self.edges) == name)
        if idx.size == 0:
            return []
        n = len(self.points)
        gaps = np.flatnonzero(np.diff(idx) > 1)
        runs = np.split(idx, gaps + 1)
        if len(runs) > 1 and runs[0][0] == 0 and runs[-1][-1] == n - 1:  # one stretch through the closing point
            runs = [np.concatenate([runs[-1], runs[0]])] + runs[1:-1]
        return [self.points[np.append(r, (r[-1] + 1) % n)] for r in runs]


def lies_on(sa: np.ndarray, sb: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Rulings whose both ends lie on a plane to round-off (signed distances sa, sb against
    the ruling's size, (N,) each)."""
    eps = 1e-9 * size
    return (np.abs(sa) <= eps) & (np.abs(sb) <= eps)


def ruling_interval(ends_c: np.ndarray, ends_d: np.ndarray, planes) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                              np.ndarray]:
    """Per ruling the interval [lo, hi] of v kept between the butt planes and which plane
    sets each end (-1: the curve itself). Degenerate (corner) rulings get lo = hi."""
    n = len(ends_c)
    lo, hi = np.zeros(n), np.ones(n)
    lo_by, hi_by = np.full(n, -1), np.full(n, -1)
    for index, (plane, sign) in enumerate(zip(planes, (1.0, -1.0))):
        sa, sb = sign * plane.signed(ends_c), sign * plane.signed(ends_d)
        ds = sb - sa
        size = np.linalg.norm(ends_d - ends_c, axis=1) + np.abs(sa)
        # a ruling on the plane to round-off (both ends within 1e-9) is not cut by it:
        # its ds is noise, and so would be the cut (the plate's corner ruling, on a cylinder)
        on_plane = lies_on(sa, sb, size)
        with np.errstate(divide="ignore", invalid="ignore"):
            cut = np.where((ds != 0) & ~on_plane, -sa / np.where(ds != 0, ds, 1.0), np.nan)
        raise_lo = (ds > 0) & (cut > lo)
        lo, lo_by = np.where(raise_lo, cut, lo), np.where(raise_lo, index, lo_by)
        lower_hi = (ds < 0) & (cut < hi)
        hi, hi_by = np.where(lower_hi, cut, hi), np.where(lower_hi, index, hi_by)
        # a ruling parallel to the plane lies wholly on one side: outside, it collapses
        # (a corner ruling on the plane itself, to round-off, stays whole)
        outside = (ds == 0) & (sa < -1e-9 * size)
        lo, hi = np.where(outside, 0.0, lo), np.where(outside, 0.0, hi)
    lo, hi = np.clip(lo, 0.0, 1.0), np.clip(hi, 0.0, 1.0)
    crossed = lo > hi
    mid = 0.5 * (lo + hi)
    return np.where(crossed, mid, lo), np.where(crossed, mid, hi), lo_by, hi_by


class PlateTracer:
    """Evaluates the plate at path fractions lam: its rulings, their kept intervals between
    the butt planes, their developed ends in the pattern's placed coordinates.

    The strip is developed once (:class:`flatten.develop.DevelopedStrip`, over the whole
    path) and every ruling asked for later is developed from it; rulings and developed ends
    are kept per lam (the outline, the corners and the bending lines ask for the same ones
    again). Every value is a pointwise function of lam, so batching changes nothing.

    planes : the two butt planes of a hull plate (pipeline.strake.Plane), or () for a
        part bounded by its first and last rulings.
    developed : the development of the (untrimmed) strip's rulings the stages made
        (``PartResult.developed``), used instead of developing the strip again when it
        reaches the path's ends.
    """

    def __init__(self, part, solution, strip, pattern, planes=(), developed: DevelopedStrip | None = None):
        self.part, self.solution, self.strip, self.planes = part, solution, strip, tuple(planes)
        self._corners = None
        # per lam asked for: the ruling (N, 2), its 3D ends (N, 3), (N, 3), its kept interval
        # and what sets its ends (N,) x 4; and its placed developed ends (N, 2), (N, 2)
        self._ruled_rows = _PerLam([np.zeros((0, 2)), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0),
                                    np.zeros(0, dtype=int), np.zeros(0, dtype=int)])
        self._end_rows = _PerLam([np.zeros((0, 2)), np.zeros((0, 2))])
        m = len(strip.samples)
        k = np.arange(strip.n_rulings) * m
        trim = strip.trim if strip.trim is not None else np.column_stack([np.zeros(strip.n_rulings),
                                                                           np.ones(strip.n_rulings)])
        # rigid fit of this development to the pattern's ruling ends (the pattern may be
        # a trimmed strip placed from a development anchored at a ruling it no longer has)
        # anchored at the path's start, which precedes every ruling asked for later (the
        # development's frame is fixed by its first ruling); the path's end is developed
        # too, so that every ruling of the path lies within the development
        self.path_sampler = PathSampler(solution)
        ends = self.path_sampler(np.array([0.0, 1.0]))
        same = developed is not None and developed.c is part.c and developed.d is part.d and \
            developed.field is solution.field
        if same and developed.breaks[0] <= ends[:, 0].min() and ends[:, 0].max() <= developed.breaks[-1] and \
                strip.rulings[:, 0].min() >= developed.breaks[0] and strip.rulings[:, 0].max() <= developed.breaks[-1]:
            # the strip's own development (stage_unroll) reaches the path's ends: every
            # ruling asked for is developed from it, and so are this strip's rulings
            # (a strip trimmed from it keeps some of them: they are its breaks)
            self._strip = developed
            dev = developed.ends(strip.rulings)
            along_c, along_d = dev.along_c, dev.along_d
        else:
            base = np.vstack([ends[:1], strip.rulings, ends[1:]])
            order = np.lexsort((base[:, 1] * solution.path.orientation, base[:, 0]))
            self._strip = DevelopedStrip(part.c, part.d, base[order], solution.field)
            position = np.empty(len(base), dtype=int)
            position[order] = np.arange(len(base))
            mine = position[1:-1]
            dev = self._strip.development
            along_c, along_d = dev.along_c[mine], dev.along_d[mine]
        src = np.vstack([along_c + trim[:, :1] * (along_d - along_c), along_c + trim[:, 1:] * (along_d - along_c)])
        dst = np.vstack([pattern.vertices[k], pattern.vertices[k + m - 1]])
        self.rot, self.shift = _rigid_fit(src, dst)
        self.alignment_error = float(np.abs(src @ self.rot.T + self.shift - dst).max())

    def _ruled(self, lam: np.ndarray) -> tuple[np.ndarray, ...]:
        """At lam (clipped to [0, 1]): rulings (N, 2), their 3D ends on c and d (N, 3) each,
        and :func:`ruling_interval` of them (N,) x 4."""
        return self._ruled_rows.at(lam, self._compute_ruled)

    def developed_at(self, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Placed developed ends (along c, along d) of the rulings at lam, (N, 2) each."""
        return self._end_rows.at(lam, lambda new: self.developed(self._ruled(new)[0]))

    def _compute_ruled(self, lam: np.ndarray):
        r = self.path_sampler(lam)
        pc, pd = self.part.c(r[:, 0]), self.part.d(r[:, 1])
        if not self.planes:
            n = len(pc)
            return r, pc, pd, np.zeros(n), np.ones(n), np.full(n, -1), np.full(n, -1)
        return (r, pc, pd, *ruling_interval(pc, pd, self.planes))

    def rulings(self, lam: np.ndarray) -> np.ndarray:
        return self._ruled(lam)[0]

    def interval(self, lam: np.ndarray):
        """(lo, hi, lo_by, hi_by) of :func:`ruling_interval` and the 3D ends pc, pd of the
        rulings at lam."""
        _, pc, pd, lo, hi, lo_by, hi_by = self._ruled(lam)
        return lo, hi, lo_by, hi_by, pc, pd

    def developed(self, rulings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Placed developed ends (along c, along d) of the given rulings, (N, 2) each."""
        dev = self._strip.ends(rulings)
        return dev.along_c @ self.rot.T + self.shift, dev.along_d @ self.rot.T + self.shift

    def plane_of(self, lam: float) -> int:
        """Index of the butt plane the ruling at lam lies in (to round-off), -1 if none."""
        _, pc, pd, *_ = self._ruled(np.array([lam]))
        size = np.linalg.norm(pd - pc, axis=1)
        for index, plane in enumerate(self.planes):
            sa, sb = plane.signed(pc), plane.signed(pd)
            if lies_on(sa, sb, size + np.abs(sa))[0]:
                return index
        return -1

    def nearest_plane(self, lam: float) -> int:
        """Index of the butt plane the ruling at lam lies in, else of the one nearer to it:
        an end ruling is named by where it is, never by the direction the path runs (a
        seam running towards -x reaches the first butt last)."""
        on = self.plane_of(lam)
        if on >= 0:
            return on
        _, pc, pd, *_ = self._ruled(np.array([lam]))
        far = [np.inf if plane is None else float(max(abs(plane.signed(pc)[0]), abs(plane.signed(pd)[0])))
               for plane in self.planes]
        return int(np.argmin(far))

    def normals(self, lam: np.ndarray) -> np.ndarray:
        """Unit strip normals c' x (d - c) of the rulings at lam, (N, 3): the pattern is
        drawn as seen from this side."""
        r, _, pd, *_ = self._ruled(lam)
        pc, dc = self.part.c.derivatives(r[:, 0], 1)
        n = np.cross(dc, pd - pc)
        return n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]

    def plate_range(self) -> tuple[float, float, list[float]]:
        """(first lam, last lam, corner lams inside) of the plate on the path."""
        if not self.planes:
            return 0.0, 1.0, []
        if self._corners is None:  # the outline and the bending lines both ask
            self._corners = _corners(self)
        corners = self._corners
        lo, hi, *_ = self.interval(np.array([0.0, 1.0]))
        first = 0.0 if hi[0] - lo[0] > 1e-12 or not corners else corners[0]
        last = 1.0 if hi[1] - lo[1] > 1e-12 or not corners else corners[-1]
        return first, last, [c for c in corners if first <= c <= last]

    def sides(self, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Placed points of the lower and upper boundary at lam, (N, 2) each."""
        lo, hi, _, _, _, _ = self.interval(lam)
        ac, ad = self.developed_at(lam)
        return ac + lo[:, None] * (ad - ac), ac + hi[:, None] * (ad - ac)

    def boundary(self, lam: np.ndarray, side: int) -> np.ndarray:
        """Placed points of the lower (side 0) or upper (side 1) boundary at lam, (N, 2)."""
        return self.sides(lam)[side]


class _PerLam:
    """Arrays with one row per path fraction lam computed so far, looked up by lam (kept
    sorted: no Python work per lam); values at lam not seen before are computed first,
    all in one call. Every value is a pointwise function of lam, so which lam share a call
    changes nothing."""

    def __init__(self, empty: list[np.ndarray]):
        self.store = list(empty)
        self.keys = np.zeros(0)  # lam computed, sorted
        self.rows = np.zeros(0, dtype=np.int64)  # their rows in store

    def at(self, lam: np.ndarray, compute) -> tuple[np.ndarray, ...]:
        """The stored arrays at lam (clipped to [0, 1]); ``compute`` of an array of new lam
        gives one array per entry of the store."""
        keys = np.clip(np.asarray(lam, dtype=np.float64).ravel(), 0.0, 1.0)
        pos = np.searchsorted(self.keys, keys)
        hit = pos < len(self.keys)
        hit[hit] = self.keys[pos[hit]] == keys[hit]
        if not hit.all():
            missing = np.unique(keys[~hit])
            start = len(self.store[0])
            for k, value in enumerate(compute(missing)):
                self.store[k] = np.concatenate([self.store[k], value])
            merged = np.concatenate([self.keys, missing])
            order = np.argsort(merged, kind="stable")
            self.keys = merged[order]
            self.rows = np.concatenate([self.rows, np.arange(start, start + len(missing))])[order]
            pos = np.searchsorted(self.keys, keys)
        rows = self.rows[pos]
        return tuple(array[rows] for array in self.store)


def _rigid_fit(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (2, 2) and translation (2,) minimising |src R^T + t - dst| (no reflection)."""
    cs, cd = src.mean(axis=0), dst.mean(axis=0)
    h = (src - cs).T @ (dst - cd)
    u, _, vt = np.linalg.svd(h)
    r = vt.T @ u.T
    if np.linalg.det(r) < 0:
        vt[-1] *= -1
        r = vt.T @ u.T
    return r, cd - cs @ r.T


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of points (N, C, 2) from segments a -> b (N, 2)."""
    seg = b - a
    length2 = np.maximum(np.einsum("ij,ij->i", seg, seg), 1e-300)
    rel = points - a[:, None, :]
    s = np.clip(np.einsum("ncj,nj->nc", rel, seg) / length2[:, None], 0.0, 1.0)
    return np.linalg.norm(rel - s[..., None] * seg[:, None, :], axis=2)


def _sample(tracer: PlateTracer, pieces: list[tuple[int, float, float]], tolerance: float,
            max_points: int = 20000) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Adaptive samples of smooth boundary pieces (side, a, b) (side 0 lower, 1 upper, lam in
    [a, b]): per piece (lam (N,), points (N, 2), max deviation at the check points). A
    segment off by more than the tolerance is split into ceil(sqrt(deviation / tolerance))
    + 1 parts (a chord's deviation falls as h^2). The pieces are refined side by side, each
    round's new points and check points in one evaluation of the tracer."""
    lams = [np.linspace(a, b, 9) for _, a, b in pieces]
    active = list(range(len(pieces)))
    deviations = [np.zeros(0) for _ in pieces]
    for _ in range(40):
        if not active:
            break
        checks = {}
        for k in active:
            la, lb = lams[k][:-1], lams[k][1:]
            checks[k] = (la[:, None] + CHECKS[None, :] * (lb - la)[:, None]).ravel()
        ask = np.concatenate([np.concatenate([lams[k], checks[k]]) for k in active])
        lower, upper = tracer.sides(ask)
        at = 0
        still = []
        for k in active:
            side = pieces[k][0]
            n, n_checks = len(lams[k]), len(checks[k])
            pts = (lower, upper)[side][at:at + n]
            exact = (lower, upper)[side][at + n:at + n + n_checks].reshape(n - 1, len(CHECKS), 2)
            at += n + n_checks
            lam = lams[k]
            la, lb = lam[:-1], lam[1:]
            deviation = _segment_distance(exact, pts[:-1], pts[1:]).max(axis=1)
            deviations[k] = deviation
            bad = np.flatnonzero(deviation > tolerance)
            if bad.size == 0:
                continue
            parts = np.ceil(np.sqrt(deviation[bad] / tolerance)).astype(int) + 1
            if len(lam) + parts.sum() > max_points:
                continue
            new = np.concatenate([la[i] + (lb[i] - la[i]) * np.arange(1, p) / p for i, p in zip(bad, parts)])
            lams[k] = np.sort(np.concatenate([lam, new]), kind="stable")
            still.append(k)
        active = still
    out = []
    for k, (side, _, _) in enumerate(pieces):
        pts = tracer.sides(lams[k])[side]
        out.append((lams[k], pts, float(deviations[k].max(initial=0.0))))
    return out


def _corners(tracer: PlateTracer) -> list[float]:
    """Path fractions where a butt plane crosses c or d (the plate corners): bracketed on
    the path's own vertices (on the solution already: no polish needed), then narrowed,
    all brackets at once, to the last bit of lam. Each step (one evaluation of the path,
    the costly part) tries 31 even points of each bracket (1/32 per step at worst) and,
    around the secant estimate of the crossing, points 1e-2, 1e-3, 1e-4, 1e-6, ..., 1e-14
    of the bracket away (the estimate's error falls as the square of the bracket; the
    points cost little beside the evaluation itself); a bracket of at most FLOATS floats
    tries every one of them: a smooth crossing is pinned in three steps, rarely four. The
    steps' rulings are not asked for again: they are sampled without the tracer's store."""
    grid, r = tracer.path_sampler.vertices()
    ends = (tracer.part.c(r[:, 0]), tracer.part.d(r[:, 1]))
    found = []  # (plane, axis, a, b, sign at a)
    for plane in tracer.planes:
        for axis in (0, 1):
            s = plane.signed(ends[axis])
            idx = np.flatnonzero(np.sign(s[:-1]) * np.sign(s[1:]) <= 0)
            for i in idx[:1]:
                found.append((plane, axis, grid[i], grid[i + 1], s[i], s[i + 1]))
    if not found:
        return []
    a, b, sa, sb = (np.array([f[k] for f in found], dtype=float) for k in (2, 3, 4, 5))
    axes = np.array([f[1] for f in found])
    steps = np.linspace(0.0, 1.0, 33)[1:-1]
    near = np.array([-1e-2, -1e-3, -1e-4, -1e-6, -1e-8, -1e-10, -1e-12, -1e-14, 0.0, 1e-14, 1e-12, 1e-10, 1e-8, 1e-6, 1e-4, 1e-3, 1e-2])
    for _ in range(12):
        width = b - a
        if np.all(width <= 2.0 * np.spacing(np.maximum(np.abs(a), np.abs(b)))):
            break  # a and b are neighbouring floats
        # the secant estimate (where the values are usable), else the middle
        with np.errstate(divide="ignore", invalid="ignore"):
            guess = a - sa * width / (sb - sa)
        guess = np.where(np.isfinite(guess) & (guess > a) & (guess < b), guess, 0.5 * (a + b))
        ulp = np.spacing(np.maximum(np.abs(a), np.abs(b)))
        if np.all(width <= FLOATS * ulp):
            # a few floats left in each bracket: try every one (the last step)
            lam = np.minimum(a[:, None] + ulp[:, None] * np.arange(FLOATS + 1)[None, :], b[:, None])
        else:
            lam = np.hstack([a[:, None] + width[:, None] * steps[None, :],
                             np.clip(guess[:, None] + width[:, None] * near[None, :], a[:, None], b[:, None])])
        lam.sort(axis=1)
        # (the near points clipped to a bracket's ends repeat: each distinct lam once)
        distinct, back = np.unique(lam, return_inverse=True)
        r = tracer.path_sampler(distinct)[back.ravel()].reshape(*lam.shape, 2)
        # each curve evaluated once for the brackets on it
        on_curve = np.empty(lam.shape + (3,))
        for axis, curve in enumerate((tracer.part.c, tracer.part.d)):
            if np.any(axes == axis):
                on_curve[axes == axis] = curve(r[axes == axis, :, axis].ravel()).reshape(-1, lam.shape[1], 3)
        for k, (plane, axis, *_) in enumerate(found):
            s = plane.signed(on_curve[k])
            same = (np.sign(s) == np.sign(sa[k])) & (s != 0)
            j = int(np.argmin(same)) if not same.all() else lam.shape[1]  # the first point past the crossing
            if j > 0:
                a[k], sa[k] = lam[k, j - 1], s[j - 1]
            if j < lam.shape[1]:
                b[k], sb[k] = lam[k, j], s[j]
    return sorted(0.5 * (a + b))


def exact_outline(tracer: "PlateTracer", tolerance: float = 0.05) -> Outline:
    """The plate's cut outline traced on the solved strip to ``tolerance`` (model units)."""
    first, last, corners = tracer.plate_range()
    breaks = sorted({first, last, *corners})
    sides = []
    worst = 0.0
    spans = [(a, b) for a, b in zip(breaks[:-1], breaks[1:]) if b - a > 1e-15]
    sampled = _sample(tracer, [(side, a, b) for side in (0, 1) for a, b in spans], tolerance)
    for side in (0, 1):
        lam_all, pts_all = [], []
        for lam, pts, deviation in sampled[side * len(spans):(side + 1) * len(spans)]:
            worst = max(worst, deviation)
            lam_all.append(lam if not lam_all else lam[1:])
            pts_all.append(pts if not pts_all else pts[1:])
        sides.append((np.concatenate(lam_all), np.vstack(pts_all)))
    (lam_lo, lower), (lam_hi, upper) = sides
    # which edge each segment lies on: the curve or the plane that sets its end
    names = []
    # at the segments' middles as the samples' checks placed them (CHECKS[1] = 0.5): the
    # tracer knows them already, but for pieces that stopped refining at max_points
    middles = [lam[:-1] + CHECKS[1] * (lam[1:] - lam[:-1]) for lam in (lam_lo, lam_hi)]
    tracer.rulings(np.concatenate(middles))  # one path evaluation
    for (lam, side), mid in zip(((lam_lo, 0), (lam_hi, 1)), middles):
        lo, hi, lo_by, hi_by, _, _ = tracer.interval(mid)
        by = lo_by if side == 0 else hi_by
        names.append(np.where(by < 0, "c" if side == 0 else "d", np.where(by == 0, "start", "end")))
    points = np.vstack([lower, upper[::-1]])
    # the closing rulings: a hull plate's end ruling lying in a butt plane is that butt's
    # edge (whichever way the seams run); otherwise the strip's own last and first rulings
    closing = [("start", "end")[tracer.nearest_plane(lam)] if tracer.planes else default
               for lam, default in ((last, "end"), (first, "start"))]
    edges = list(names[0]) + [closing[0]] + list(names[1][::-1]) + [closing[1]]
    # drop repeated points (degenerate corner rulings) with their zero-length segments
    step = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    size = float(np.ptp(points, axis=0).max())
    keep = step > 1e-12 * max(size, 1.0)
    points, edges = points[keep], tuple(str(e) for e, k in zip(edges, keep) if k)
    return Outline(points, edges, worst, tolerance, tracer.alignment_error)
