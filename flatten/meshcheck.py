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
    """Angle defects at interior vertices (radians) and pointwise K (1/units^2).

    max_abs_K counts only the part of each defect above its round-off floor (what the mesh
    can measure: see :func:`defect_noise`); max_abs_K_raw is the plain defect / area."""

    max_defect: float
    integrated_abs_defect: float
    max_abs_K: float
    interior_vertices: int
    max_abs_K_raw: float = 0.0

    def as_dict(self) -> dict:
        return {"max_angle_defect": self.max_defect, "integrated_abs_angle_defect": self.integrated_abs_defect,
                "max_abs_gaussian_curvature": self.max_abs_K, "max_abs_gaussian_curvature_raw": self.max_abs_K_raw,
                "interior_vertices": self.interior_vertices}


def defect_noise(vertices: np.ndarray, faces: np.ndarray, scale: float | None = None) -> np.ndarray:
    """Per vertex (V,), a bound on the round-off of its angle defect: vertex positions are known
    to a few ulps of the largest coordinate (round-off of the curves and of the rulings'
    polish, ~1e-15 relative), and an angle between edges of
    lengths l1, l2 moves by up to that error times (1/l1 + 1/l2) per moved end. Far from the
    origin (a hull plate 100 m aft of midship) with short edges (corner rulings a few mm
    apart) this floor, divided by a small Voronoi area, is a spurious |K| far above a
    strip's true curvature: only the defect above it is curvature the mesh shows. ``scale``:
    the largest coordinate of the whole mesh (default: of these vertices)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    scale = float(np.abs(v).max(initial=0.0)) if scale is None else float(scale)
    position = 8.0 * np.finfo(np.float64).eps * scale
    # edge k of a face runs from its corner k to corner k + 1; corner k lies between
    # edges k and k - 1
    edges = np.stack([np.linalg.norm(v[f[:, (k + 1) % 3]] - v[f[:, k]], axis=1) for k in range(3)])  # (3, F)
    with np.errstate(divide="ignore"):
        corner = 2.0 * position * (1.0 / edges + 1.0 / np.roll(edges, 1, axis=0))  # (3, F)
    corner = np.where(np.isfinite(corner), corner, 0.0)
    return np.bincount(f.T.ravel(), weights=corner.ravel(), minlength=len(v))


def angle_defects(vertices: np.ndarray, faces: np.ndarray, scale: float | None = None) -> CurvatureFigures:
    """libigl's integrated Gaussian curvature 2π - Σθ at interior vertices, and
    pointwise K = defect / Voronoi area. Collapsed triangles (two rulings through one point,
    a ruling of zero length) have no angles: they are left out, and the vertices they border
    count as border vertices (no defect is measured there, none is made up as NaN)."""
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    twice_area = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    f = np.ascontiguousarray(f[twice_area > 1e-12 * twice_area.max(initial=0.0)])
    if not len(f):
        return CurvatureFigures(0.0, 0.0, 0.0, 0)
    defect = np.full(len(v), np.nan)
    got = igl.gaussian_curvature(v, f)
    defect[: len(got)] = got
    border = np.ones(len(v), dtype=bool)
    flags = np.asarray(igl.is_border_vertex(f), dtype=bool)
    border[: len(flags)] = flags
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    area = np.zeros(len(v))
    diag = igl.massmatrix(v, f, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    area[: len(diag)] = diag
    interior = ~border & used & np.isfinite(defect) & np.isfinite(area) & (area > 0)
    if not interior.any():
        return CurvatureFigures(0.0, 0.0, 0.0, 0)
    k = defect[interior] / np.maximum(area[interior], 1e-300)
    measurable = np.maximum(np.abs(defect[interior]) - defect_noise(v, f, scale)[interior], 0.0)
    k_sig = measurable / np.maximum(area[interior], 1e-300)
    return CurvatureFigures(float(np.abs(defect[interior]).max()), float(np.abs(defect[interior]).sum()),
                            float(k_sig.max()), int(interior.sum()), float(np.abs(k).max()))


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
    scale = float(np.abs(strip.vertices).max(initial=0.0))  # one round-off floor for every window
    if n <= chunk + 2:
        return angle_defects(strip.vertices, strip.faces, scale)
    max_defect = total = max_k = max_raw = 0.0
    count = 0
    for lo in range(1, n - 1, chunk):  # the interior rulings 1 .. n - 2 in windows
        hi = min(lo + chunk, n - 1)
        window = grid[lo - 1:hi + 1]
        part = angle_defects(window.reshape(-1, 3), grid_faces(len(window), m), scale)
        max_defect = max(max_defect, part.max_defect)
        total += part.integrated_abs_defect
        max_k = max(max_k, part.max_abs_K)
        max_raw = max(max_raw, part.max_abs_K_raw)
        count += part.interior_vertices
    return CurvatureFigures(max_defect, total, max_k, count, max_raw)


def naive_rulings(c: NurbsCurve, d: NurbsCurve, n_rulings: int) -> np.ndarray:
    """Rulings of the naive ruled surface T = t (both domains mapped linearly), (K, 2)."""
    s = np.linspace(0.0, 1.0, n_rulings)
    return np.column_stack([c.domain[0] + s * np.ptp(c.domain), d.domain[0] + s * np.ptp(d.domain)])


def naive_reference(c: NurbsCurve, d: NurbsCurve, n_rulings: int, samples_per_ruling: int) -> CurvatureFigures:
    strip = build_strip(c, d, naive_rulings(c, d, n_rulings), samples_per_ruling, chords=False)
    return strip_angle_defects(strip)


def ruling_residuals(c: NurbsCurve, d: NurbsCurve, rulings: np.ndarray) -> np.ndarray:
    """|g| / (|c'| |d'| |d - c|) at each ruling, (K,)."""
    return normalized_residual(c, d, rulings[:, 0], rulings[:, 1])
