"""Distortion figures of a flat pattern against its 3D strip (DESIGN §1.4)."""

from __future__ import annotations

import numpy as np

from .nurbs import NurbsCurve
from .strip import CHUNK_RULINGS, grid_faces

# Ruling edges shorter than this share of the coordinates' magnitude are left out of the
# relative ruling error: a hull plate's corner ruling, trimmed to a point by a butt plane,
# keeps edges of ~1e-12 mm whose lengths are round-off of coordinates of ~1e5 mm, so their
# relative error reads 0.1-1.4 and says nothing of the development. Such edges are still in
# the absolute figure.
RULING_EDGE_FLOOR = 1e-9


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


def closest_on_polyline(point: np.ndarray, polyline: np.ndarray) -> tuple[np.ndarray, float]:
    """The closest point (3,) of a polyline (N, 3) to a point (3,), and its distance."""
    if len(polyline) < 2:
        return polyline[0].copy(), float(np.linalg.norm(polyline[0] - point))
    a, ab = polyline[:-1], np.diff(polyline, axis=0)
    t = np.clip(np.einsum("ij,ij->i", point - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
    feet = a + t[:, None] * ab
    gaps = np.linalg.norm(feet - point, axis=1)
    k = int(np.argmin(gaps))
    return feet[k], float(gaps[k])


def distortion(vertices3d: np.ndarray, flat: np.ndarray, m: int, c: NurbsCurve, d: NurbsCurve,
               rulings: np.ndarray, chunk: int = CHUNK_RULINGS) -> dict:
    """Figures of the flat strip against the 3D one.

    vertices3d (K m, 3) and flat (K m, 2): the strip's grid, vertex k m + j at sample j
    of ruling k, triangulated as :func:`flatten.strip.grid_faces` (quad k, j split along
    (k + 1, j) - (k, j + 1)). Returns the relative ruling-edge error (must be round-off),
    the chord discrepancy of the other edges (along the strip and the quad diagonals,
    each edge once: O(h^2), not an error), the area ratio, and the flat boundary length
    against the 3D arc length of c and d over the covered parameters, in mm per metre.
    The relative ruling error leaves out edges shorter than ``RULING_EDGE_FLOOR`` times
    the largest coordinate (corner slivers of a trimmed plate: their relative error is
    round-off over round-off; NaN when no edge is that long); the absolute one (model
    units) takes every ruling edge.
    Computed in windows of ``chunk`` rulings (bounded temporaries); the edges are those
    of the grid, so no edge list of the whole mesh is built.
    """
    grid3 = vertices3d.reshape(-1, m, 3)
    grid2 = flat.reshape(-1, m, 2)
    n = len(grid3)
    faces = grid_faces(min(n, chunk + 1), m)
    size = max(float(grid3.max(initial=0.0)), -float(grid3.min(initial=0.0)))  # no temporary of the grid
    rule_err = rule_abs = other_max = other_sq = area3 = area2 = 0.0
    n_other = n_measurable = 0
    for lo in range(0, n, chunk):
        hi = min(lo + chunk, n)
        # rulings lo .. hi - 1, and the quads between them and ruling hi (if any)
        a3, a2 = grid3[lo:hi + 1], grid2[lo:hi + 1]
        r3 = np.linalg.norm(np.diff(a3[:hi - lo], axis=1), axis=2).ravel()
        r2 = np.linalg.norm(np.diff(a2[:hi - lo], axis=1), axis=2).ravel()
        gap = np.abs(r2 - r3)
        rule_abs = max(rule_abs, float(np.max(gap, initial=0.0)))
        measurable = r3 > RULING_EDGE_FLOOR * size
        n_measurable += int(np.count_nonzero(measurable))
        rule_err = max(rule_err, float(np.max(gap[measurable] / r3[measurable], initial=0.0)))
        if len(a3) < 2:
            continue
        l3 = np.concatenate([np.linalg.norm(a3[1:] - a3[:-1], axis=2).ravel(),  # along the strip
                             np.linalg.norm(a3[1:, :-1] - a3[:-1, 1:], axis=2).ravel()])  # diagonals
        l2 = np.concatenate([np.linalg.norm(a2[1:] - a2[:-1], axis=2).ravel(),
                             np.linalg.norm(a2[1:, :-1] - a2[:-1, 1:], axis=2).ravel()])
        # an edge that collapses in 3D (seams meeting at a point) has no relative error: its
        # round-off length in the plane over a zero length would read as 1e+288
        real = l3 > 1e-12 * max(float(np.max(l3, initial=0.0)), 1e-300)
        rel = np.abs(l2[real] - l3[real]) / l3[real]
        other_max = max(other_max, float(np.max(rel, initial=0.0)))
        other_sq += float(np.sum(rel**2))
        n_other += len(rel)
        f = faces if len(a3) == chunk + 1 else grid_faces(len(a3), m)
        area3 += float(triangle_areas(a3.reshape(-1, 3), f).sum())
        area2 += float(triangle_areas(a2.reshape(-1, 2), f).sum())
    arc_c = float(np.diff(c.arc_length_at(np.array([rulings[0, 0], rulings[-1, 0]])))[0])
    T_lo, T_hi = sorted((rulings[0, 1], rulings[-1, 1]))
    arc_d = float(np.diff(d.arc_length_at(np.array([T_lo, T_hi])))[0])
    flat_c, flat_d = polyline_length(grid2[:, 0]), polyline_length(grid2[:, -1])

    def per_metre(flat_len, arc):
        return 1000.0 * (flat_len - arc) / arc if arc > 0 else 0.0

    return {
        # none long enough to measure one (a strip 1e-9 of its distance from the origin):
        # not measured, NaN (null in a report), rather than a 0 that would claim exactness
        "ruling_edge_max_relative_error": rule_err if n_measurable or not n else float("nan"),
        "ruling_edge_max_abs_error": rule_abs,
        "chord_discrepancy_max_relative": other_max,
        "chord_discrepancy_rms_relative": float(np.sqrt(other_sq / n_other)) if n_other else 0.0,
        "area_3d": area3,
        "area_flat": area2,
        "area_ratio": area2 / area3 if area3 > 0 else 1.0,
        "arc_length_c": arc_c,
        "arc_length_d": arc_d,
        "flat_length_c": flat_c,
        "flat_length_d": flat_d,
        "boundary_error_c_mm_per_m": per_metre(flat_c, arc_c),
        "boundary_error_d_mm_per_m": per_metre(flat_d, arc_d),
    }


def polygon_area(points: np.ndarray) -> float:
    """Area of a closed polygon (N, 2), not repeated (shoelace)."""
    x, y = points[:, 0], points[:, 1]
    return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)))
