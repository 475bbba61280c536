"""Developments of a surface patch given as a triangle mesh: planar projection for flat
plates, minimal-strain flattening (LSCM seed, then ARAP) for doubly curved (formed)
plates, and the in-plane strain of any development.

Strain convention: for each triangle the map from the 3D triangle to its flat image has
singular values s_max >= s_min (flat length / hull length along the principal directions);
the principal strains are s - 1. A positive strain means the flat plate is longer there
than the hull: forming must shrink it (line heating); a negative strain means it must be
stretched.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PlaneFit:
    """Least-squares plane: centroid (3,), orthonormal in-plane axes (2, 3), unit normal (3,),
    signed distances of the fitted points (N,)."""

    centroid: np.ndarray
    axes: np.ndarray
    normal: np.ndarray
    distances: np.ndarray

    @property
    def max_distance(self) -> float:
        return float(np.abs(self.distances).max())

    def project(self, points: np.ndarray) -> np.ndarray:
        """In-plane coordinates (N, 2) of points (N, 3)."""
        return (np.asarray(points) - self.centroid) @ self.axes.T


def plane_through(points: np.ndarray, normal, point) -> PlaneFit:
    """The plane of the given normal (3,) through the point (3,) as a fit of the points (N, 3):
    its in-plane axes (:func:`flatten.plane.perpendicular_pair`) and their signed distances."""
    from .plane import perpendicular_pair

    normal = np.asarray(normal, dtype=np.float64)
    normal = normal / np.linalg.norm(normal)
    point = np.asarray(point, dtype=np.float64)
    return PlaneFit(point, np.array(perpendicular_pair(normal)), normal,
                    (np.asarray(points, dtype=np.float64) - point) @ normal)


def fit_plane(points: np.ndarray) -> PlaneFit:
    """Total least-squares plane through points (N, 3) (smallest singular vector)."""
    points = np.asarray(points, dtype=np.float64)
    centroid = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centroid, full_matrices=False)
    normal = vt[2]
    return PlaneFit(centroid, vt[:2].copy(), normal, (points - centroid) @ normal)


def triangle_stretches(v3: np.ndarray, v2: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Principal stretches (F, 2) [s_max, s_min] of the map taking each 3D triangle of
    (V, 3) to its image in (V, 2). Degenerate triangles give NaN rows."""
    p0, p1, p2 = (v3[faces[:, k]] for k in range(3))
    q0, q1, q2 = (v2[faces[:, k]] for k in range(3))
    a, b = p1 - p0, p2 - p0
    la = np.linalg.norm(a, axis=1)
    e1 = a / np.where(la > 0, la, 1)[:, None]
    n = np.cross(a, b)
    ln = np.linalg.norm(n, axis=1)
    e2 = np.cross(n / np.where(ln > 0, ln, 1)[:, None], e1)
    P = np.stack([np.stack([la, np.einsum("ij,ij->i", b, e1)], axis=1),
                  np.stack([np.zeros_like(la), np.einsum("ij,ij->i", b, e2)], axis=1)], axis=1)  # (F, 2, 2)
    Q = np.stack([q1 - q0, q2 - q0], axis=2)  # columns are the flat edge vectors
    out = np.full((len(faces), 2), np.nan)
    good = (ln > 1e-14 * np.maximum(la, 1.0) ** 2)
    J = Q[good] @ np.linalg.inv(P[good])
    out[good] = np.linalg.svd(J, compute_uv=False)
    return out


def orient_ccw(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Mirror the flat image if most of its triangles are clockwise (a development is
    defined up to a reflection; keep the moulded side up consistently)."""
    e1 = uv[faces[:, 1]] - uv[faces[:, 0]]
    e2 = uv[faces[:, 2]] - uv[faces[:, 0]]
    signed = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    return uv * np.array([1.0, -1.0]) if np.sum(signed) < 0 else uv


def planar_development(points: np.ndarray, fit: PlaneFit | None = None) -> np.ndarray:
    """Flat image (N, 2) of a nearly planar patch: orthogonal projection on its plane."""
    fit = fit_plane(points) if fit is None else fit
    return fit.project(points)


def arap_development(vertices: np.ndarray, faces: np.ndarray, iterations: int = 50) -> tuple[np.ndarray, int]:
    """Minimal-strain flat image (V, 2) of a disc-like mesh: libigl LSCM with two boundary
    vertices pinned (far apart), rescaled to the 3D area, then libigl ARAP (as-rigid-as-
    possible, local/global) from that seed with one vertex pinned. Returns (uv, iterations)."""
    import igl

    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    loop = igl.boundary_loop(f)
    if len(loop) < 2:
        raise ValueError("the patch mesh has no boundary loop: not a disc")
    far = loop[int(np.argmax(np.linalg.norm(v[loop] - v[loop[0]], axis=1)))]
    b = np.array([loop[0], far], dtype=np.int64)
    bc = np.array([[0.0, 0.0], [float(np.linalg.norm(v[far] - v[loop[0]])), 0.0]])
    uv, _ = igl.lscm(v, f, b, bc)
    area3 = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum()
    e1, e2 = uv[f[:, 1]] - uv[f[:, 0]], uv[f[:, 2]] - uv[f[:, 0]]
    area2 = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    uv = uv * np.sqrt(area3 / area2)
    data = igl.ARAPData()
    data.max_iter = int(iterations)
    pinned = np.array([loop[0]], dtype=np.int32)
    igl.arap_precomputation(v, f, 2, pinned, data)
    uv = igl.arap_solve(uv[pinned.astype(np.int64)], data, np.ascontiguousarray(uv))
    return orient_ccw(uv, f), int(iterations)


def triangle_maps(v3: np.ndarray, v2: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Linear maps (F, 2, 3) taking 3D vectors in each triangle's plane to the flat image."""
    p0, p1, p2 = (v3[faces[:, k]] for k in range(3))
    q0, q1, q2 = (v2[faces[:, k]] for k in range(3))
    A = np.stack([p1 - p0, p2 - p0], axis=2)  # (F, 3, 2)
    Q = np.stack([q1 - q0, q2 - q0], axis=2)  # (F, 2, 2)
    # J A = Q with J restricted to the triangle's plane: J = Q (A^T A)^-1 A^T
    gram = np.einsum("fki,fkj->fij", A, A)
    det = gram[:, 0, 0] * gram[:, 1, 1] - gram[:, 0, 1] ** 2
    good = det > 1e-24 * np.maximum(gram[:, 0, 0] * gram[:, 1, 1], 1e-300)
    inv = np.zeros_like(gram)
    inv[good] = np.linalg.inv(gram[good])
    return np.einsum("fij,fjk,flk->fil", Q, inv, A)


def streamlines(field_points: np.ndarray, field_dirs: np.ndarray, outline: np.ndarray, seeds: np.ndarray,
                step: float, max_steps: int = 2000) -> list[np.ndarray]:
    """Integrate the (sign-free) direction field given at field_points (N, 2) (nearest sample)
    from each seed, both ways, until leaving the closed outline (M, 2); returns polylines."""
    from matplotlib.path import Path as MplPath
    from scipy.spatial import cKDTree

    inside = MplPath(outline).contains_points
    tree = cKDTree(field_points)
    lines = []
    for seed in seeds:
        halves = []
        for sign in (1.0, -1.0):
            p, prev, pts = seed.copy(), None, []
            for _ in range(max_steps):
                d = field_dirs[tree.query(p)[1]]
                if prev is None:
                    d = sign * d
                elif d @ prev < 0:
                    d = -d
                q = p + step * d
                if not inside(q[None])[0]:
                    break
                pts.append(q)
                p, prev = q, d
            halves.append(pts)
        line = np.array(halves[1][::-1] + [seed] + halves[0])
        if len(line) >= 2:
            lines.append(line)
    return lines
