"""Numerical developability check of a strip mesh with libigl (DESIGN §1.5).

The one module that talks to libigl.
"""

from __future__ import annotations

from dataclasses import dataclass

import igl
import numpy as np

from .equation import normalized_residual
from .nurbs import NurbsCurve
from .strip import build_strip


@dataclass(frozen=True)
class CurvatureFigures:
    """Angle defects at interior vertices (radians) and pointwise K (1/units^2)."""

    max_defect: float
    integrated_abs_defect: float
    max_abs_K: float
    interior_vertices: int

    def as_dict(self) -> dict:
        return {"max_angle_defect": self.max_defect, "integrated_abs_angle_defect": self.integrated_abs_defect,
                "max_abs_gaussian_curvature": self.max_abs_K, "interior_vertices": self.interior_vertices}


def angle_defects(vertices: np.ndarray, faces: np.ndarray) -> CurvatureFigures:
    """libigl's integrated Gaussian curvature 2π - Σθ at interior vertices, and
    pointwise K = defect / Voronoi area."""
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    defect = np.full(len(v), np.nan)
    got = igl.gaussian_curvature(v, f)
    defect[: len(got)] = got
    border = np.ones(len(v), dtype=bool)
    flags = np.asarray(igl.is_border_vertex(f), dtype=bool)
    border[: len(flags)] = flags
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    interior = ~border & used & np.isfinite(defect)
    if not interior.any():
        return CurvatureFigures(0.0, 0.0, 0.0, 0)
    area = np.zeros(len(v))
    diag = igl.massmatrix(v, f, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    area[: len(diag)] = diag
    k = defect[interior] / np.maximum(area[interior], 1e-300)
    return CurvatureFigures(float(np.abs(defect[interior]).max()), float(np.abs(defect[interior]).sum()),
                            float(np.abs(k).max()), int(interior.sum()))


def naive_rulings(c: NurbsCurve, d: NurbsCurve, n_rulings: int) -> np.ndarray:
    """Rulings of the naive ruled surface T = t (both domains mapped linearly), (K, 2)."""
    s = np.linspace(0.0, 1.0, n_rulings)
    return np.column_stack([c.domain[0] + s * np.ptp(c.domain), d.domain[0] + s * np.ptp(d.domain)])


def naive_reference(c: NurbsCurve, d: NurbsCurve, n_rulings: int, samples_per_ruling: int) -> CurvatureFigures:
    strip = build_strip(c, d, naive_rulings(c, d, n_rulings), samples_per_ruling)
    return angle_defects(strip.vertices, strip.faces)


def ruling_residuals(c: NurbsCurve, d: NurbsCurve, rulings: np.ndarray) -> np.ndarray:
    """|g| / (|c'| |d'| |d - c|) at each ruling, (K,)."""
    return normalized_residual(c, d, rulings[:, 0], rulings[:, 1])
