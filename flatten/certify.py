"""Certified enclosure of the zero set Z = {f = 0} and the critical points of f.

On every cell (span of c x span of d) f is a bivariate polynomial; its Bernstein
coefficients on a box bound it there (convex hull property). Subdividing the cells
(de Casteljau halving, batched over all boxes) until every box either has
coefficients of one sign (no zero in it: excluded, proved) or is small gives

- a proof that Z is empty (every box excluded), or the boxes that may hold Z, among
  them the boxes where f provably changes sign (corner values of both signs);
- the critical points of f (f_t = f_T = 0) by the same subdivision of the partial
  derivatives followed by Newton on the gradient. Every closed loop of Z inside a cell
  bounds a disc holding an extremum of f, so a seed line through every extremum meets
  every such loop (loops that cross a knot line are met by the seed line on the knot).

Everything here works in the local coordinates (s, σ) in [0, 1]^2 of a cell and
reports boxes and points in the curves' own parameters (t, T).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from math import comb

import numpy as np

from .equation import DevelopabilityField

# Rounding of a Bernstein coefficient computed from the cell polynomial: a few ulps
# per term, relative to the cell's natural scale of f (DevelopabilityField.scale).
_ROUNDING = 64.0 * np.finfo(float).eps


@dataclass(frozen=True)
class Enclosure:
    """Result of the exclusion stage on one block of cells.

    boxes : (M, 4) [t0, t1, T0, T1] boxes not excluded (Z, if any, lies in their union)
    sign_change : (M,) bool, f takes both signs at the corners of the box (a zero in it,
        proved)
    proved_empty : every box of the rectangle was excluded: f has no zero (up to the
        rounding margin ``margin``, relative to the cell scale)
    complete : the subdivision stopped because it reached the box size it aimed at,
        not because it ran out of budget
    n_excluded : number of boxes proved free of zeros; depth : deepest level reached
    f_min, f_max : the Bernstein bounds of f over the rectangle (its range lies inside)
    """

    boxes: np.ndarray
    sign_change: np.ndarray
    proved_empty: bool
    complete: bool
    n_excluded: int
    depth: int
    margin: float
    f_min: float
    f_max: float


@dataclass(frozen=True)
class CriticalPoints:
    """Critical points of f (f_t = f_T = 0) inside the cells, in parameters.

    points : (K, 2) [t, T]; value : (K,) f; hessian : (K, 2, 2) in unit-square
    coordinates of the block; kind : (K,) 'min', 'max', 'saddle' or 'degenerate';
    scale : (K,) natural scale of f at the point (for relative zero tests);
    complete : the subdivision ran to its end (no box left unresolved for lack of budget)
    """

    points: np.ndarray
    value: np.ndarray
    hessian: np.ndarray
    kind: np.ndarray
    scale: np.ndarray
    complete: bool


def bernstein_cells(field: DevelopabilityField) -> np.ndarray:
    """Bernstein coefficients of f on every cell in local (s, σ), shape (nc, nd, A, B)."""
    return field.bernstein


@lru_cache(maxsize=None)
def _halving_matrix(n: int) -> np.ndarray:
    """(2n, n): Bernstein coefficients (n of them) of the halves [0, 1/2] (rows :n) and
    [1/2, 1] (rows n:) from those of the whole interval, read-only. De Casteljau at 1/2
    as one linear map: lo_r = sum_k C(r, k) c_k / 2^r, hi_r = sum_k C(n-1-r, k-r) c_k / 2^(n-1-r);
    every entry is a dyadic fraction (exact), every row sums to 1."""
    out = np.zeros((2 * n, n))
    for r in range(n):
        for k in range(r + 1):
            out[r, k] = comb(r, k) / 2.0**r
        for k in range(r, n):
            out[n + r, k] = comb(n - 1 - r, k - r) / 2.0 ** (n - 1 - r)
    out.setflags(write=False)
    return out


def _split4(arrays: list[np.ndarray], boxes: np.ndarray):
    """Quarter every box (K, 4) [s0, s1, σ0, σ1] and its coefficient arrays (K, A, B):
    two matrix products per array (the halving along s, then along σ, for all boxes)."""
    out_arrays = []
    for coefs in arrays:
        k, a, b = coefs.shape
        x = _halving_matrix(a) @ coefs.transpose(1, 0, 2).reshape(a, k * b)  # (2a, k b): [s half, a] x [k, b]
        y = x.reshape(2 * a * k, b) @ _halving_matrix(b).T  # (2 a k, 2 b): [s half, a, k] x [σ half, b]
        # (s lo, σ lo), (s lo, σ hi), (s hi, σ lo), (s hi, σ hi), each K boxes
        out_arrays.append(y.reshape(2, a, k, 2, b).transpose(0, 3, 2, 1, 4).reshape(4 * k, a, b))
    s0, s1, g0, g1 = boxes.T
    sm, gm = 0.5 * (s0 + s1), 0.5 * (g0 + g1)
    quarters = [np.column_stack(q) for q in ((s0, sm, g0, gm), (s0, sm, gm, g1),
                                              (sm, s1, g0, gm), (sm, s1, gm, g1))]
    return out_arrays, np.concatenate(quarters)


def _one_sign(coefs: np.ndarray, margin: np.ndarray) -> np.ndarray:
    """(K,) True where every coefficient of a box is beyond ± margin (K,)."""
    flat = coefs.reshape(len(coefs), int(np.prod(coefs.shape[1:])))
    return np.all(flat > margin[:, None], axis=1) | np.all(flat < -margin[:, None], axis=1)


def _to_params(field: DevelopabilityField, cell: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    bc, bd = field.c.breakpoints, field.d.breakpoints
    i, j = cell[:, 0], cell[:, 1]
    wc, wd = bc[i + 1] - bc[i], bd[j + 1] - bd[j]
    return np.column_stack([bc[i] + boxes[:, 0] * wc, bc[i] + boxes[:, 1] * wc,
                            bd[j] + boxes[:, 2] * wd, bd[j] + boxes[:, 3] * wd])


def _initial(field: DevelopabilityField):
    nc, nd = field.cells.shape[:2]
    ii, jj = np.meshgrid(np.arange(nc), np.arange(nd), indexing="ij")
    cell = np.column_stack([ii.ravel(), jj.ravel()])
    boxes = np.tile([0.0, 1.0, 0.0, 1.0], (len(cell), 1))
    return cell, boxes


def _unit_size(field: DevelopabilityField, cell: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Larger side of each box in the block's unit square, (K,): the local side times the
    cell's share of the domain."""
    share_c = np.diff(field.c.breakpoints) / np.ptp(field.c.domain)
    share_d = np.diff(field.d.breakpoints) / np.ptp(field.d.domain)
    return np.maximum((boxes[:, 1] - boxes[:, 0]) * share_c[cell[:, 0]],
                      (boxes[:, 3] - boxes[:, 2]) * share_d[cell[:, 1]])


def enclose(field: DevelopabilityField, target: float = 4e-3, max_boxes: int = 6000,
            max_depth: int = 30) -> Enclosure:
    """Exclude boxes of the rectangle where f provably keeps one sign.

    Parameters
    ----------
    target : box size (unit square of the block) at which live boxes stop splitting
    max_boxes : budget of live boxes per level; beyond it the subdivision stops (the
        enclosure is then coarser than ``target``, ``complete`` False)

    While Z may be empty (few live boxes), boxes keep splitting below ``target`` so
    that a near miss is still proved empty.
    """
    bern = bernstein_cells(field)
    cell, boxes = _initial(field)
    coefs = bern.reshape(-1, *bern.shape[2:])
    scale = field.scale.ravel()
    f_min, f_max = float(coefs.min(initial=0.0)), float(coefs.max(initial=0.0))
    n_excluded, depth, complete = 0, 0, True
    while True:
        margin = _ROUNDING * coefs.shape[1] * coefs.shape[2] * scale[cell[:, 0] * field.cells.shape[1] + cell[:, 1]]
        out = _one_sign(coefs, margin)
        n_excluded += int(out.sum())
        cell, boxes, coefs = cell[~out], boxes[~out], coefs[~out]
        if len(cell) == 0:
            break
        corners = coefs[:, [0, 0, -1, -1], [0, -1, 0, -1]]
        changes = (corners.max(axis=1) > 0) & (corners.min(axis=1) < 0)
        size = _unit_size(field, cell, boxes)
        # keep splitting boxes that are large, and every box while no sign change has
        # been seen (f may have no zero at all: prove it); stop at the budget
        split = size > target
        if not changes.any():
            split = size > 1e-9
        if not split.any() or depth >= max_depth:
            break
        if 4 * int(split.sum()) + int((~split).sum()) > max_boxes:
            complete = False
            break
        (new_coefs,), new_boxes = _split4([coefs[split]], boxes[split])
        cell = np.vstack([cell[~split], np.tile(cell[split], (4, 1))])
        boxes = np.vstack([boxes[~split], new_boxes])
        coefs = np.concatenate([coefs[~split], new_coefs])
        depth += 1
    if len(cell):
        corners = coefs[:, [0, 0, -1, -1], [0, -1, 0, -1]]
        changes = (corners.max(axis=1) > 0) & (corners.min(axis=1) < 0)
        params = _to_params(field, cell, boxes)
    else:
        changes, params = np.zeros(0, dtype=bool), np.zeros((0, 4))
    return Enclosure(params, changes, len(cell) == 0, complete, n_excluded, depth,
                     _ROUNDING * bern.shape[2] * bern.shape[3], f_min, f_max)


def _derivative_coefs(coefs: np.ndarray, axis: int) -> np.ndarray:
    """Bernstein coefficients of the partial derivative along axis (1: s, 2: σ), up to
    the positive factor (degree / box width): only the signs matter here."""
    return np.diff(coefs, axis=axis)


def _newton_critical(cells: np.ndarray, cell: np.ndarray, x: np.ndarray, iterations: int = 30):
    """Newton on grad f = 0 in local cell coordinates; returns points (K, 2), converged (K,)."""
    a, b = cells.shape[2:]
    pa, pb = np.arange(a), np.arange(b)
    m = cells[cell[:, 0], cell[:, 1]]  # (K, A, B)
    x = x.copy()
    ok = np.zeros(len(x), dtype=bool)
    for _ in range(iterations):
        s, g = x[:, 0:1], x[:, 1:2]
        ps = [_pow_rows(s, pa, k) for k in range(3)]
        pg = [_pow_rows(g, pb, k) for k in range(3)]
        fs = np.einsum("ka,kab,kb->k", ps[1], m, pg[0])
        fg = np.einsum("ka,kab,kb->k", ps[0], m, pg[1])
        fss = np.einsum("ka,kab,kb->k", ps[2], m, pg[0])
        fsg = np.einsum("ka,kab,kb->k", ps[1], m, pg[1])
        fgg = np.einsum("ka,kab,kb->k", ps[0], m, pg[2])
        det = fss * fgg - fsg**2
        safe = np.where(det != 0, det, 1.0)
        ds = np.where(det != 0, (fgg * fs - fsg * fg) / safe, 0.0)
        dg = np.where(det != 0, (fss * fg - fsg * fs) / safe, 0.0)
        step = np.column_stack([ds, dg])
        step = np.clip(step, -0.25, 0.25)  # stay near the box Newton started from
        x = x - step
        ok = np.hypot(ds, dg) <= 1e-14
        if ok.all():
            break
    return x, ok & np.all(np.isfinite(x), axis=1)


def _pow_rows(x: np.ndarray, powers: np.ndarray, order: int) -> np.ndarray:
    """d^order/dx^order of x**powers for column x (K, 1), shape (K, n)."""
    coef = np.ones(len(powers))
    for k in range(order):
        coef = coef * (powers - k)
    exponent = np.maximum(powers - order, 0)
    return coef[None, :] * x ** exponent[None, :]


def critical_points(field: DevelopabilityField, target: float = 1.0 / 64,
                    max_boxes: int = 4000, max_depth: int = 12) -> CriticalPoints:
    """Every critical point of f in the interior of the cells, by subdivision + Newton.

    Boxes where f_s or f_σ keeps one sign hold no critical point; the rest are split
    down to ``target`` (relative to the cell) and Newton runs from their centres.
    Cells on which f itself keeps one sign are skipped: no loop of Z lies in them.
    """
    empty = CriticalPoints(np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2, 2)), np.zeros(0, dtype="<U10"),
                           np.zeros(0), True)
    if min(field.cells.shape[2:]) < 2:
        return empty  # f is constant along t or T on each cell: its zero set is lines, no loops
    bern = bernstein_cells(field)
    cell, boxes = _initial(field)
    coefs = bern.reshape(-1, *bern.shape[2:])
    scale = field.scale.ravel()[cell[:, 0] * field.cells.shape[1] + cell[:, 1]]
    margin0 = _ROUNDING * coefs.shape[1] * coefs.shape[2] * scale
    live = ~_one_sign(coefs, margin0)
    cell, boxes, coefs, scale = cell[live], boxes[live], coefs[live], scale[live]
    ds, dg = _derivative_coefs(coefs, 1), _derivative_coefs(coefs, 2)
    complete = True
    for depth in range(max_depth + 1):
        margin = _ROUNDING * coefs.shape[1] * coefs.shape[2] * scale
        keep = ~(_one_sign(ds, margin) | _one_sign(dg, margin))
        cell, boxes, scale, ds, dg = cell[keep], boxes[keep], scale[keep], ds[keep], dg[keep]
        if len(cell) == 0 or np.all(boxes[:, 1] - boxes[:, 0] <= target) or depth == max_depth:
            break
        if 4 * len(cell) > max_boxes:
            complete = False
            break
        (ds, dg), boxes = _split4([ds, dg], boxes)
        cell, scale = np.tile(cell, (4, 1)), np.tile(scale, 4)
    empty = CriticalPoints(empty.points, empty.value, empty.hessian, empty.kind, empty.scale, complete)
    if len(cell) == 0:
        return empty
    start = np.column_stack([0.5 * (boxes[:, 0] + boxes[:, 1]), 0.5 * (boxes[:, 2] + boxes[:, 3])])
    x, ok = _newton_critical(field.cells, cell, start)
    inside = ok & np.all((x >= -1e-9) & (x <= 1.0 + 1e-9), axis=1)
    x, cell, scale = np.clip(x[inside], 0.0, 1.0), cell[inside], scale[inside]
    if len(x) == 0:
        return empty
    bc, bd = field.c.breakpoints, field.d.breakpoints
    t = bc[cell[:, 0]] + x[:, 0] * (bc[cell[:, 0] + 1] - bc[cell[:, 0]])
    T = bd[cell[:, 1]] + x[:, 1] * (bd[cell[:, 1] + 1] - bd[cell[:, 1]])
    points = np.column_stack([t, T])
    # the same point reached from several boxes (or from both cells of a knot line)
    unit = (points - [bc[0], bd[0]]) / [bc[-1] - bc[0], bd[-1] - bd[0]]
    order = np.lexsort((unit[:, 1], unit[:, 0]))
    keep = []
    for k in order:
        if all(np.hypot(*(unit[k] - unit[m])) > 1e-9 for m in keep[-8:]):
            keep.append(k)
    keep = np.array(keep)
    points, scale, cell = points[keep], scale[keep], cell[keep]
    spans = [(int(i), int(j)) for i, j in cell]
    value = np.array([field(p[0], p[1], spans=s)[0] for p, s in zip(points, spans)])
    wu, wU = bc[-1] - bc[0], bd[-1] - bd[0]
    hess = np.array([[[field(p[0], p[1], 2, 0, s)[0] * wu * wu, field(p[0], p[1], 1, 1, s)[0] * wu * wU],
                      [field(p[0], p[1], 1, 1, s)[0] * wu * wU, field(p[0], p[1], 0, 2, s)[0] * wU * wU]]
                     for p, s in zip(points, spans)]).reshape(-1, 2, 2)
    det = hess[:, 0, 0] * hess[:, 1, 1] - hess[:, 0, 1] ** 2
    size = np.abs(hess).reshape(len(hess), -1).max(axis=1)
    kind = np.where(det > 1e-12 * size**2, np.where(hess[:, 0, 0] > 0, "min", "max"),
                    np.where(det < -1e-12 * size**2, "saddle", "degenerate"))
    return CriticalPoints(points, value, hess, kind, scale, complete)


def near_gap(value: np.ndarray, hessian: np.ndarray) -> np.ndarray:
    """Distance across the zero set at a critical point, unit square, (K,).

    At a saddle f ≈ f0 + ½ λ1 x² + ½ λ2 y² the two arms pass 2 sqrt(2 |f0| / |λ|)
    apart, λ the eigenvalue of sign opposite to f0; at an extremum the same number is
    the small axis of the loop around it (or inf when f0 has the extremum's sign: no loop).
    """
    lam = np.linalg.eigvalsh(hessian)  # ascending, (K, 2)
    opposite = np.where(value[:, None] > 0, lam < 0, lam > 0)
    mag = np.where(opposite, np.abs(lam), 0.0).max(axis=1)
    with np.errstate(divide="ignore"):
        return np.where(mag > 0, 2.0 * np.sqrt(2.0 * np.abs(value) / np.where(mag > 0, mag, 1.0)), np.inf)
