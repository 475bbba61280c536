"""Plücker coordinates of the tangent lines of a homogeneous curve.

The tangent line of c at t is spanned by C(t) and C'(t) in projective space; its
Plücker vector L(t) = C(t) ∧ C'(t) holds the six 2x2 minors. Two lines are coplanar
iff their reciprocal product L_1^T Ω L_2 vanishes, and det[A, B, C, D] equals the
reciprocal product of A ∧ B and C ∧ D (generalised Laplace expansion).
"""

from __future__ import annotations

import numpy as np

# Index pairs (i, j) of the minors, in this order.
PAIRS = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))


def reciprocal_matrix() -> np.ndarray:
    """Ω (6, 6) with det[a, b, c, d] = (a ∧ b)^T Ω (c ∧ d) for columns a, b, c, d in R^4.

    Each minor of rows (i, j) pairs with the complementary rows (k, l), with the
    Laplace sign (-1)^(i+j+1) (0-based rows, columns 0 and 1).
    """
    omega = np.zeros((6, 6))
    for row, (i, j) in enumerate(PAIRS):
        k, l = sorted(set(range(4)) - {i, j})
        col = PAIRS.index((k, l))
        omega[row, col] = (-1.0) ** (i + j + 1)
    omega.setflags(write=False)
    return omega


def wedge(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Plücker vectors a ∧ b of pairs of points in R^4, (..., 4) x (..., 4) -> (..., 6)."""
    return np.stack([a[..., i] * b[..., j] - a[..., j] * b[..., i] for i, j in PAIRS], axis=-1)


def tangent_line_polynomials(power: np.ndarray) -> np.ndarray:
    """Span polynomials of L(s) = C(s) ∧ C'(s), shape (n_spans, 2p-1, 6).

    Parameters
    ----------
    power : (n_spans, p+1, 4) ascending power coefficients of C in the local span
        variable s in [0, 1] (derivative taken with respect to s).

    The nominal degree 2p-1 term cancels (a ∧ a = 0), leaving degree 2p-2: Theorem 1.
    """
    n_spans, p1, _ = power.shape
    p = p1 - 1
    deriv = power[:, 1:, :] * np.arange(1, p1)[None, :, None]  # (n_spans, p, 4)
    # every product of a power term a with a derivative term b at once: (n, p+1, p, 4, 4)
    outer = power[:, :, None, :, None] * deriv[:, None, :, None, :]
    rows, cols = np.array(PAIRS).T
    minors = outer[..., rows, cols] - outer[..., cols, rows]  # (n, p+1, p, 6): a ∧ b terms
    out = np.zeros((n_spans, 2 * p, 6))
    for a in range(p1):  # the term s^a s^b lands on s^(a+b)
        out[:, a:a + p, :] += minors[:, a]
    return out[:, : 2 * p - 1, :]
