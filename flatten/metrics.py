"""Distortion figures of a flat pattern against its 3D strip (DESIGN §1.4)."""

from __future__ import annotations

import numpy as np

from .nurbs import NurbsCurve


def edge_lengths(vertices: np.ndarray, edges: np.ndarray) -> np.ndarray:
    return np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1)


def unique_edges(faces: np.ndarray) -> np.ndarray:
    """Undirected edges of a triangle mesh, each once, sorted, shape (E, 2)."""
    e = np.sort(np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1).astype(np.int64)
    n = int(e.max()) + 1 if len(e) else 1
    keys = np.unique(e[:, 0] * n + e[:, 1])
    return np.column_stack([keys // n, keys % n])


def triangle_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    if vertices.shape[1] == 2:
        u, v = b - a, c - a
        return 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def polyline_length(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def distortion(vertices3d: np.ndarray, flat: np.ndarray, faces: np.ndarray, ruling_edges: np.ndarray,
               boundary_c: np.ndarray, boundary_d: np.ndarray, c: NurbsCurve, d: NurbsCurve,
               rulings: np.ndarray) -> dict:
    """Figures of the flat mesh against the 3D one.

    boundary_c, boundary_d : vertex indices along c and d in ruling order.
    Returns relative ruling-edge error (must be round-off), the chord discrepancy of the
    other edges (O(h^2), not an error), the area ratio, and the flat boundary length
    against the 3D arc length of c and d over the covered parameters, in mm per metre.
    """
    rule3 = edge_lengths(vertices3d, ruling_edges)
    rule2 = edge_lengths(flat, ruling_edges)
    all_edges = unique_edges(faces)
    n = int(max(all_edges.max(), ruling_edges.max())) + 1
    sorted_rulings = np.sort(ruling_edges, axis=1).astype(np.int64)
    is_ruling = np.isin(all_edges[:, 0] * n + all_edges[:, 1], sorted_rulings[:, 0] * n + sorted_rulings[:, 1])
    other = all_edges[~is_ruling]
    l3, l2 = edge_lengths(vertices3d, other), edge_lengths(flat, other)
    positive = rule3 > 0
    area3 = triangle_areas(vertices3d, faces).sum()
    area2 = triangle_areas(flat, faces).sum()
    arc_c = float(np.diff(c.arc_length_at(np.array([rulings[0, 0], rulings[-1, 0]])))[0])
    T_lo, T_hi = sorted((rulings[0, 1], rulings[-1, 1]))
    arc_d = float(np.diff(d.arc_length_at(np.array([T_lo, T_hi])))[0])
    flat_c, flat_d = polyline_length(flat[boundary_c]), polyline_length(flat[boundary_d])

    def per_metre(flat_len, arc):
        return 1000.0 * (flat_len - arc) / arc if arc > 0 else 0.0

    return {
        "ruling_edge_max_relative_error": float(np.max(np.abs(rule2[positive] - rule3[positive]) / rule3[positive],
                                                       initial=0.0)),
        "chord_discrepancy_max_relative": float(np.max(np.abs(l2 - l3) / np.maximum(l3, 1e-300), initial=0.0)),
        "chord_discrepancy_rms_relative": float(np.sqrt(np.mean(((l2 - l3) / np.maximum(l3, 1e-300)) ** 2))
                                                if len(l3) else 0.0),
        "area_3d": float(area3),
        "area_flat": float(area2),
        "area_ratio": float(area2 / area3) if area3 > 0 else 1.0,
        "arc_length_c": arc_c,
        "arc_length_d": arc_d,
        "flat_length_c": flat_c,
        "flat_length_d": flat_d,
        "boundary_error_c_mm_per_m": per_metre(flat_c, arc_c),
        "boundary_error_d_mm_per_m": per_metre(flat_d, arc_d),
    }
