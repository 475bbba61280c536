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



def plane_crossings(curve: NurbsCurve, plane: Plane) -> np.ndarray:
    """Parameters where the curve meets the plane (exact roots of the homogeneous
    polynomial n . A - offset w on every span), sorted. The span polynomials are the
    curve's (computed once per curve, whatever the number of planes)."""
    spans = curve.power_coefficients  # (n_spans, degree + 1, 4) in s = (t - b_i) / w_i
    coef = spans[:, :, :3] @ np.asarray(plane.normal, dtype=float) - plane.offset * spans[:, :, 3]
    breaks = curve.breakpoints
    widths = np.diff(breaks)
    # PPoly wants powers of (t - b_i), highest first: (degree + 1, n_spans)
    taylor = (coef / widths[:, None] ** np.arange(curve.degree + 1)).T[::-1]
    roots = PPoly(taylor, breaks, extrapolate=False).roots(extrapolate=False)
    lo, hi = curve.domain
    return np.unique(roots[(roots >= lo) & (roots <= hi)])
