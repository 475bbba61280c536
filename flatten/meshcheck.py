"""Numerical developability check of a strip mesh with libigl (DESIGN §1.5).

The one module that talks to libigl.
"""

from __future__ import annotations

from dataclasses import dataclass

import igl
import numpy as np

from .equation import normalized_residual
from .nurbs import NurbsCurve
from .strip import CHUNK_RULINGS, Strip, build_strip, grid_faces


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


def strip_angle_defects(strip: Strip, chunk: int = CHUNK_RULINGS) -> CurvatureFigures:
    """:func:`angle_defects` of a strip's grid mesh (vertex k m + j on ruling k, faces as
    :func:`grid_faces`), in windows of ``chunk`` rulings so that libigl's temporaries stay
    bounded. A vertex's defect and Voronoi area depend only on the faces around it, which
    lie between its neighbouring rulings: each window carries one ruling more on either
    side, whose vertices are border vertices there and so not counted twice. The sums are
    then taken window by window (the same figures up to the order of summation)."""
    m = len(strip.samples)
    grid = strip.vertices.reshape(-1, m, 3)
    n = len(grid)
    if n <= chunk + 2:
        return angle_defects(strip.vertices, strip.faces)
    max_defect = total = max_k = 0.0
    count = 0
    for lo in range(1, n - 1, chunk):  # the interior rulings 1 .. n - 2 in windows
        hi = min(lo + chunk, n - 1)
        window = grid[lo - 1:hi + 1]
        part = angle_defects(window.reshape(-1, 3), grid_faces(len(window), m))
        max_defect = max(max_defect, part.max_defect)
        total += part.integrated_abs_defect
        max_k = max(max_k, part.max_abs_K)
        count += part.interior_vertices
    return CurvatureFigures(max_defect, total, max_k, count)


def naive_rulings(c: NurbsCurve, d: NurbsCurve, n_rulings: int) -> np.ndarray:
    """Rulings of the naive ruled surface T = t (both domains mapped linearly), (K, 2)."""
    s = np.linspace(0.0, 1.0, n_rulings)
    return np.column_stack([c.domain[0] + s * np.ptp(c.domain), d.domain[0] + s * np.ptp(d.domain)])


def naive_reference(c: NurbsCurve, d: NurbsCurve, n_rulings: int, samples_per_ruling: int) -> CurvatureFigures:
    strip = build_strip(c, d, naive_rulings(c, d, n_rulings), samples_per_ruling)
    return strip_angle_defects(strip)


def ruling_residuals(c: NurbsCurve, d: NurbsCurve, rulings: np.ndarray) -> np.ndarray:
    """|g| / (|c'| |d'| |d - c|) at each ruling, (K,)."""
    return normalized_residual(c, d, rulings[:, 0], rulings[:, 1])
