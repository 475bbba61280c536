"""Batched real roots of many small polynomials on [0, 1].

Companion-matrix eigenvalues for a whole batch at once (one LAPACK call per
effective degree), then Newton polishing on the real polynomial.
"""

from __future__ import annotations

from functools import lru_cache
from math import comb

import numpy as np


@lru_cache(maxsize=None)
def bernstein_matrix(degree: int) -> np.ndarray:
    """(m+1, m+1) matrix taking ascending power coefficients to Bernstein coefficients on
    [0, 1], read-only (built once per degree)."""
    out = np.array([[comb(j, k) / comb(degree, k) if k <= j else 0.0
                     for k in range(degree + 1)] for j in range(degree + 1)])
    out.setflags(write=False)
    return out


def horner(coefficients: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Values and first derivatives of polynomials, ascending coefficients (K, m+1), x (K,) -> (K,), (K,)."""
    value = np.zeros_like(x)
    slope = np.zeros_like(x)
    for k in range(coefficients.shape[1] - 1, -1, -1):
        slope = slope * x + value
        value = value * x + coefficients[:, k]
    return value, slope


def real_roots_unit_interval(coefficients: np.ndarray, zero_relative: float = 1e-11,
                             slack: float = 1e-9, newton_steps: int = 3):
    """Real roots in [0, 1] of each polynomial of a batch.

    Parameters
    ----------
    coefficients : (K, m+1) ascending power coefficients
    zero_relative : coefficients below this fraction of the row's largest count as
        zero when trimming the leading terms (degree drops)
    slack : roots in [-slack, 1 + slack] are kept and clipped onto [0, 1]

    Returns
    -------
    row : (R,) int, index of the polynomial each root belongs to
    root : (R,) float, the root, polished
    vanishing : (K,) bool, rows that are identically zero (every x is a root)
    """
    coefficients = np.asarray(coefficients, dtype=np.float64)
    n_rows, width = coefficients.shape
    scale = np.max(np.abs(coefficients), axis=1)
    vanishing = scale == 0.0
    safe = np.where(vanishing, 1.0, scale)
    normed = coefficients / safe[:, None]
    significant = np.abs(normed) > zero_relative
    # effective degree: index of the highest significant coefficient
    degree = np.where(significant.any(axis=1),
                      width - 1 - np.argmax(significant[:, ::-1], axis=1), 0)
    # Bernstein coefficients of one sign bound the polynomial away from zero on [0, 1]
    # (convex hull property): most (line, span) pairs are discarded here.
    bern = normed @ bernstein_matrix(width - 1).T
    margin = 1e-9
    no_root = np.all(bern > margin, axis=1) | np.all(bern < -margin, axis=1)
    degree = np.where(no_root, 0, degree)
    rows_out, roots_out = [], []
    # Bernstein coefficients all beyond the margin with one sign change: exactly one root
    # in (0, 1), a simple one (variation diminishing), found by safeguarded Newton without
    # the companion matrix (the usual case: a branch crossing a seed line once per cell)
    clear = np.all(np.abs(bern) > margin, axis=1)
    single = clear & ~vanishing & (degree > 0) & (np.sum(bern[:, 1:] * bern[:, :-1] < 0, axis=1) == 1)
    if single.any():
        rows = np.flatnonzero(single)
        rows_out.append(rows)
        roots_out.append(_bracketed_root(normed[rows], bern[rows, 0], bern[rows, -1]))
        degree = np.where(single, 0, degree)
    for m in range(1, width):
        rows = np.flatnonzero((degree == m) & ~vanishing)
        if rows.size == 0:
            continue
        poly = normed[rows, : m + 1]
        if m == 1:
            cand = (-poly[:, 0] / poly[:, 1])[:, None]
            imag_ok = np.ones_like(cand, dtype=bool)
        else:
            companion = np.zeros((rows.size, m, m))
            companion[:, 1:, :-1] = np.eye(m - 1)
            companion[:, :, -1] = -poly[:, :m] / poly[:, m : m + 1]
            eig = np.linalg.eigvals(companion)
            # double roots (tangencies) split into pairs with imaginary parts ~ sqrt(eps)
            imag_ok = np.abs(eig.imag) <= 1e-6 * (1.0 + np.abs(eig.real))
            cand = eig.real
        r_idx, k_idx = np.nonzero(imag_ok & (cand > -1e-3) & (cand < 1.0 + 1e-3))
        x = cand[r_idx, k_idx]
        p = poly[r_idx]
        value, slope = horner(p, x)
        for _ in range(newton_steps):
            step = np.where(slope != 0.0, value / np.where(slope != 0.0, slope, 1.0), 0.0)
            # never let Newton leave the neighbourhood of the eigenvalue, and keep a step
            # only if it lowers |p| (at a double root the slope vanishes too)
            trial = x - np.clip(step, -1e-3, 1e-3)
            t_value, t_slope = horner(p, trial)
            better = np.abs(t_value) < np.abs(value)
            x = np.where(better, trial, x)
            value = np.where(better, t_value, value)
            slope = np.where(better, t_slope, slope)
        keep = (x >= -slack) & (x <= 1.0 + slack)
        rows_out.append(rows[r_idx[keep]])
        roots_out.append(np.clip(x[keep], 0.0, 1.0))
    if rows_out:
        row = np.concatenate(rows_out)
        root = np.concatenate(roots_out)
        order = np.lexsort((root, row))
        row, root = row[order], root[order]
        # merge the two halves of a double root
        dup = np.zeros(row.size, dtype=bool)
        dup[1:] = (row[1:] == row[:-1]) & (np.abs(root[1:] - root[:-1]) < 1e-7)
        row, root = row[~dup], root[~dup]
    else:
        row, root = np.zeros(0, dtype=int), np.zeros(0)
    return row, root, vanishing


def _bracketed_root(poly: np.ndarray, at_0: np.ndarray, at_1: np.ndarray, iterations: int = 40) -> np.ndarray:
    """The one root in (0, 1) of each polynomial (K, m+1) (ascending coefficients) whose
    values at 0 and 1 (K,) have opposite signs: Newton kept inside the shrinking bracket,
    bisection where Newton would leave it; the points still moving are iterated."""
    lo, hi = np.zeros(len(poly)), np.ones(len(poly))
    x = at_0 / (at_0 - at_1)  # regula falsi on the end values
    sign_0 = np.sign(at_0)
    active = np.arange(len(poly))
    for _ in range(iterations):
        if len(active) == 0:
            break
        xa, la, ha = x[active], lo[active], hi[active]
        value, slope = horner(poly[active], xa)
        below = np.sign(value) == sign_0[active]  # the root lies above xa
        la, ha = np.where(below, xa, la), np.where(below, ha, xa)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = xa - value / slope
        inside = np.isfinite(step) & (step >= la) & (step <= ha)
        new = np.where(value == 0.0, xa, np.where(inside, step, 0.5 * (la + ha)))
        x[active], lo[active], hi[active] = new, la, ha
        settled = (value == 0.0) | (np.abs(new - xa) <= 4e-16 * np.maximum(np.abs(xa), 1e-300)) | (ha - la <= 4e-16)
        active = active[~settled]
    return x
