"""Where and which way to split a hull plate that does not fit (the adaptive plan).

A developable strip fits a hull patch when the patch bends little along its rulings, and a
strip's rulings follow the hull's direction of least normal curvature. Through a point of
the region, a ruling in that direction crosses the plate over about
l = min(L / |cos a|, W / |sin a|) (L, W the plate's length and girth there, a the angle of the
direction to the length), and the hull bends away from it by the sagitta of that chord,
kappa l^2 / 8; the best-fit strip (pipeline/hull/bestfit.py) centres its rulings in that bow and
meets it within half of it:

    misfit(p) = |kappa_min(p)| l(p)^2 / 16        (model units)

The plate's estimate is the largest misfit over a coarse grid of its region, or 0 when the
region lies within the tolerance of some plane (its minimax plane: flat). It ranks candidate splits,
it is not the verdict (the strip solve and hull check are): a split at x = X (a butt plane)
or at a girth fraction w (a new seam) is scored by the area of the halves it expects to fit
(estimate <= tolerance), then by the larger of the halves' estimates, then by how near the
middle it lies; halves stay within the stock's minimum sizes. A plate of a cylinder joined
to a spherical cap is thus split at the junction: one half fits, the other does not.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flatten.patch import grid_frame, principal_curvatures, region_grid
from flatten.minimax import fits_a_plane



@dataclass(frozen=True)
class RegionSample:
    """A plate's region on a coarse grid: points (R, C, 3), misfit terms per point, and the
    cumulative arc lengths along rows (R, C) and columns (R, C) (model units)."""

    points: np.ndarray
    rows: np.ndarray  # girth fractions of the grid rows (R,)
    kappa: np.ndarray  # |least principal curvature| (R, C), 1 / model units
    cos: np.ndarray  # |cos| of the least-curvature direction to the row (R, C)
    sin: np.ndarray
    along: np.ndarray  # arc length from the row's start (R, C)
    across: np.ndarray  # arc length from the column's start (R, C)
    area: np.ndarray  # area per grid point (R, C), model units^2


def sample_region(surface, axis: int, girths, planes, rows: int = 17, cols: int = 33) -> RegionSample | None:
    grid = region_grid(surface, axis, girths[0], girths[1], [None if p is None else p.as_tuple() for p in planes],
                       rows, cols, probe=160, spacing="parameter")
    if grid is None:
        return None
    p = grid.points
    r, c = p.shape[:2]
    k, d1 = principal_curvatures(surface, grid.params[..., 0].ravel(), grid.params[..., 1].ravel())
    t_s, t_g = grid_frame(p)
    d1 = d1.reshape(r, c, 3)
    cos = np.abs(np.sum(d1 * t_s, axis=2))
    sin = np.abs(np.sum(d1 * t_g, axis=2))
    seg_s = np.linalg.norm(np.diff(p, axis=1), axis=2)
    seg_g = np.linalg.norm(np.diff(p, axis=0), axis=2)
    along = np.concatenate([np.zeros((r, 1)), np.cumsum(seg_s, axis=1)], axis=1)
    across = np.concatenate([np.zeros((1, c)), np.cumsum(seg_g, axis=0)], axis=0)
    ds = np.gradient(along, axis=1)
    dg = np.gradient(across, axis=0)
    kappa = np.abs(k[:, 0]).reshape(r, c)
    kappa = np.where(np.isfinite(kappa), kappa, 0.0)
    return RegionSample(p, grid.rows, kappa, cos, sin, along, across, ds * dg)


def _misfit(s: RegionSample, mask: np.ndarray, length: np.ndarray, width: np.ndarray) -> float:
    """Largest |kappa_min| l^2 / 16 over the masked points, or 0 when they are planar."""
    if not mask.any():
        return 0.0
    chord = np.minimum(length / np.maximum(s.cos, 1e-9), width / np.maximum(s.sin, 1e-9))
    return float(np.max((s.kappa * chord**2 / 16.0)[mask]))


def _flat(s: RegionSample, mask: np.ndarray, tol: float) -> bool:
    pts = s.points[mask]
    return len(pts) >= 3 and fits_a_plane(pts, tol)


def estimate(s: RegionSample, tol: float) -> float:
    """The plate's misfit estimate (model units); 0 when the region is flat within tol."""
    full = np.ones(s.points.shape[:2], dtype=bool)
    if _flat(s, full, tol):
        return 0.0
    length = np.broadcast_to(s.along[:, -1:], s.kappa.shape)
    width = np.broadcast_to(s.across[-1:, :], s.kappa.shape)
    return _misfit(s, full, length, width)


@dataclass(frozen=True)
class Split:
    """``kind`` "length" (a butt plane x = ``at``) or "girth" (a seam at girth fraction ``at``);
    the halves' estimates and the area expected to fit (share of the plate)."""

    kind: str
    at: float
    estimates: tuple[float, float]
    fitting_share: float
    weld: float = 0.0  # length of the new butt (its girth width) or seam (its length), model units
    ends: tuple = ()  # a girth split's new seam's two ends (on the plate's butts or the hull's ends), model units


class _Flatness:
    """Whether the points of a mask lie within ``tol`` of some plane (:func:`_flat`), each
    answer reused for the masks it settles: a plane that fits a set of points fits every
    subset of it, and none fits a set holding one that no plane fits."""

    def __init__(self, s: RegionSample, tol: float):
        self.s, self.tol, self.flat, self.bent = s, tol, [], []

    def __call__(self, mask: np.ndarray) -> bool:
        if any(not (mask & ~m).any() for m in self.flat):
            return True
        if any(not (m & ~mask).any() for m in self.bent):
            return False
        answer = _flat(self.s, mask, self.tol)
        if answer:
            self.flat.append(mask)
        elif np.count_nonzero(mask) >= 3:  # (fewer points are not flat by definition; a superset may be)
            self.bent.append(mask)
        return answer

    def bisect(self, growing: list) -> None:
        """Ask for the masks of a growing family (each holding the one before) in the order of
        a bisection: its flat ones are a prefix, so about log2(n) plane fits settle all n."""
        lo, hi = 0, len(growing)
        while lo < hi:
            mid = (lo + hi) // 2
            if self(growing[mid]):
                lo = mid + 1
            else:
                hi = mid


def _half_scores(s: RegionSample, masks, lengths, widths, tol: float, flat: _Flatness):
    est, good = [], 0.0
    total = sum(float(s.area[m].sum()) for m in masks) or 1.0  # a shared row or column counts twice
    for mask, length, width in zip(masks, lengths, widths):
        e = 0.0 if flat(mask) else _misfit(s, mask, length, width)
        est.append(e)
        good += float(s.area[mask].sum()) if e <= tol else 0.0
    return tuple(est), good / total


def choose_split(s: RegionSample, tol: float, min_length: float, min_width: float, allow=None,
                 strict_width: bool = False, kinds: tuple = ("length", "girth"), allow_seam=None,
                 tapering: bool = False) -> Split | None:
    """The best split of the plate within the minimum sizes, or None when none is allowed.
    Candidates: a butt plane through each interior grid column (x = its mean x), a seam
    along each interior grid row; the halves share that column or row. ``allow(x)``: whether
    a butt at x keeps the yard's stagger rule (:mod:`.yardrules`); ``strict_width``: each half
    of a butt split keeps a girth width of at least ``min_width`` somewhere (a plate tapering
    to the stem is not cut into a sliver); ``kinds``: the kinds of split considered;
    ``allow_seam(ends)``: whether a new seam ending at those points (2, 3) keeps the yard's
    rule against the seams across the plate's butts (no cross joints); ``tapering``: a girth
    split's halves keep ``min_width`` where the plate is wide enough for two cut at a grid
    row (twice the width and the rows' spacing there), somewhere at least; where it tapers
    narrower (to a point at a stern or stem) each half keeps a third of the plate's width
    there, so at least half as wide as the other: no sliver."""
    laid = []  # (kind, at, masks, lengths, widths, weld, ends) of each split allowed
    x = s.points[..., 0]
    row_len = s.along[:, -1]
    n_rows, n_cols = x.shape
    for j in range(2, n_cols - 2) if "length" in kinds else ():
        X = float(np.mean(x[:, j]))
        cut = np.array([np.interp(X, *(_monotone(x[i], s.along[i]))) for i in range(n_rows)])
        if cut.min() < min_length or (row_len - cut).min() < min_length:
            continue
        if allow is not None and not allow(X):
            continue
        # a half's width from the columns wholly inside it: the column at the cut is not the
        # plane's section (a width read there passed a half 1 % narrower than the stock)
        if strict_width and (s.across[-1, :j].max() < min_width or s.across[-1, j + 1:].max() < min_width):
            continue
        lengths = (np.broadcast_to(cut[:, None], x.shape), np.broadcast_to((row_len - cut)[:, None], x.shape))
        widths = (np.broadcast_to(s.across[-1:, :], x.shape),) * 2
        sign = 1.0 if x[:, -1].mean() >= x[:, 0].mean() else -1.0
        lower = sign * (x - X) <= 1e-9 * np.ptp(x)
        upper = sign * (x - X) >= -1e-9 * np.ptp(x)
        laid.append(("length", X, (lower, upper), lengths, widths, float(s.across[-1, j]), ()))
    col_w = s.across[-1, :]
    need, slack = np.full(n_cols, min_width), 0.0
    if tapering:
        # wide enough for two halves cut at a grid row: twice the width and the rows' spacing;
        # narrower, a row is not the middle where the rows bunch: each half keeps a third
        wide = col_w >= 2.0 * min_width + np.diff(s.across, axis=0).max(axis=0)
        need = np.where(wide, min_width, np.minimum(min_width, col_w / 3.0)) if wide.any() else None
        slack = 1e-9 * float(col_w.max())  # the point a plate tapers to: both halves nil there
    for i in range(1, n_rows - 1) if "girth" in kinds and need is not None else ():
        cut = s.across[i, :]
        if np.any(np.minimum(cut, col_w - cut) < need - slack):
            continue
        ends = s.points[i, [0, -1]]
        if allow_seam is not None and not allow_seam(ends):
            continue
        widths = (np.broadcast_to(cut[None, :], x.shape), np.broadcast_to((col_w - cut)[None, :], x.shape))
        lengths = (np.broadcast_to(s.along[:, -1:], x.shape),) * 2
        below = np.broadcast_to((np.arange(n_rows) <= i)[:, None], x.shape)
        above = np.broadcast_to((np.arange(n_rows) >= i)[:, None], x.shape)
        laid.append(("girth", float(s.rows[i]), (below, above), lengths, widths, float(s.along[i, -1]),
                     tuple(tuple(float(v) for v in p) for p in ends)))
    # each kind's first halves grow with the split's place and its second halves shrink
    flat = _Flatness(s, tol)
    for kind in ("length", "girth"):
        halves = [masks for k, _, masks, *_ in laid if k == kind]
        flat.bisect([first for first, _ in halves])
        flat.bisect([second for _, second in halves][::-1])
    candidates = []
    for kind, at, masks, lengths, widths, weld, ends in laid:
        est, share = _half_scores(s, masks, lengths, widths, tol, flat)
        candidates.append(Split(kind, at, est, share, weld, ends))
    if not candidates:
        return None
    x_mid = 0.5 * (float(np.mean(x[:, 0])) + float(np.mean(x[:, -1])))
    x_span = max(abs(float(np.mean(x[:, -1]) - np.mean(x[:, 0]))), 1e-300)
    w_mid = 0.5 * (s.rows[0] + s.rows[-1])

    def rank(c: Split):
        # fraction from the middle, so that among equals the plate is halved
        mid = abs(c.at - x_mid) / x_span if c.kind == "length" else abs(c.at - w_mid)
        return (-round(c.fitting_share, 2), round(max(c.estimates) / max(tol, 1e-300), 1), mid)

    return min(candidates, key=rank)


def _monotone(xs: np.ndarray, lengths: np.ndarray):
    """(xs, lengths) sorted by x, for interpolating where a row crosses x = X."""
    order = np.argsort(xs, kind="stable")
    return xs[order], lengths[order]
