"""Planes and where NURBS curves cross them: butts, frames and sections of a hull.

A plane is n . p = offset with n a unit normal. Crossings are the exact roots of a curve's
homogeneous span polynomials, so a butt cut by a plane lands on the curve to round-off.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PPoly

from .nurbs import NurbsCurve


def perpendicular_pair(vectors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (N, 3) each, perpendicular to the unit vectors (N, 3) and to each
    other: v x e (e the axis v is least along) normalised, then v x that; (3,) in, (3,) out."""
    v = np.asarray(vectors, dtype=np.float64)
    if v.ndim == 1:  # one vector: its own norm (the rows' norm below rounds differently)
        first = np.cross(v, np.eye(3)[int(np.argmin(np.abs(v)))])
        first /= np.linalg.norm(first)
        return first, np.cross(v, first)
    first = np.cross(v, np.eye(3)[np.argmin(np.abs(v), axis=1)])
    first /= np.linalg.norm(first, axis=1, keepdims=True)
    return first, np.cross(v, first)


@dataclass(frozen=True)
class Plane:
    """The plane n . p = offset, n a unit normal pointing towards the plate's far butt."""

    normal: tuple[float, float, float]
    offset: float

    def signed(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points) @ np.asarray(self.normal) - self.offset

    def shifted(self, distance: float) -> "Plane":
        return Plane(self.normal, self.offset + distance)

    def describe(self) -> str:
        n = self.normal
        if abs(n[0] - 1.0) < 1e-12:
            return f"x = {self.offset:g}"
        return f"{n[0]:.4g} x + {n[1]:.4g} y + {n[2]:.4g} z = {self.offset:g}"

    def as_tuple(self):
        return (np.asarray(self.normal), self.offset)



# curves of this many spans or fewer are solved on every span: sorting their spans out costs
# more than it saves
FEW_SPANS = 12


def plane_crossings(curve: NurbsCurve, plane: Plane) -> np.ndarray:
    """Parameters where the curve meets the plane (exact roots of the homogeneous
    polynomial n . A - offset w on every span), sorted. The span polynomials are the
    curve's (computed once per curve, whatever the number of planes).

    Only the spans that may meet the plane are solved: on the others, |n . A - offset w| >=
    |c_0| - sum |c_k| s^k stays clear of zero (:func:`clear_of_zero`). The roots are bit for
    bit those of solving every span: each span's are its own polynomial's, and a span clear
    of zero leaves no sign change at its ends for the root finder to report (a KVLCC2 seam of
    115 spans crosses a butt plane in one or two)."""
    spans = curve.power_coefficients  # (n_spans, degree + 1, 4) in s = (t - b_i) / w_i
    coef = spans[:, :, :3] @ np.asarray(plane.normal, dtype=float) - plane.offset * spans[:, :, 3]
    breaks = curve.breakpoints
    widths = np.diff(breaks)
    # PPoly wants powers of (t - b_i), highest first: (degree + 1, n_spans)
    taylor = (coef / widths[:, None] ** np.arange(curve.degree + 1)).T[::-1]
    if len(widths) <= FEW_SPANS:
        roots = PPoly(taylor, breaks, extrapolate=False).roots(extrapolate=False)
    else:
        # the size of the terms before they cancel: a span's c_0 and its neighbour's value at
        # their common breakpoint agree to round-off of it, not of what is left of them
        # (bounded over the curve: |n . A_k| <= sum |A_k|, n a unit vector)
        terms = np.abs(spans).sum(axis=1).max(axis=0)
        solved = np.flatnonzero(~clear_of_zero(coef, float(terms[:3].sum() + abs(plane.offset) * terms[3])))
        if not len(solved):
            return np.empty(0)
        runs = np.split(solved, np.flatnonzero(np.diff(solved) > 1) + 1)  # neighbouring spans solved together
        roots = np.concatenate([PPoly(taylor[:, run[0]:run[-1] + 1], breaks[run[0]:run[-1] + 2],
                                      extrapolate=False).roots(extrapolate=False) for run in runs])
    lo, hi = curve.domain
    return np.unique(roots[(roots >= lo) & (roots <= hi)])


def clear_of_zero(coef: np.ndarray, size: float = 0.0) -> np.ndarray:
    """Polynomials sum c_k s^k (rows of ``coef``, (N, degree + 1)) that cannot vanish on
    s in [0, 1], (N,) bool: |c_0| exceeds sum_{k>=1} |c_k| by a millionth of their total and
    by 1e-9 of ``size``, the magnitude of the terms the coefficients were computed from, so
    that the polynomial keeps c_0's sign there and at both ends however the coefficients were
    rounded (a span lying in the plane has coefficients of round-off alone, which say
    nothing of its sign). NaN rows are not clear."""
    first, rest = np.abs(coef[:, 0]), np.abs(coef[:, 1:]).sum(axis=1)
    return first - rest > 1e-6 * (first + rest) + 1e-9 * size
