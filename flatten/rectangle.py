"""The smallest rectangle (any rotation) holding a set of points in the plane.

Rotating calipers over the convex hull: the minimum-area rectangle has a side along a hull
edge (Freeman & Shapira, 1975), so each hull edge's direction is tried. GEOS (shapely 2.2's
``minimum_rotated_rectangle``) returns a rectangle of zero width for an exact rectangle whose
corners carry rounding noise (a plate developed from a cylinder: its outline's hull has an
edge 1e-13 long, whose unnormalised direction makes any rectangle's area look nil), which
put a 10 x 4.7 m plate on a 2.5 x 12 m sheet. Here a direction comes only from a hull edge
longer than a millionth of the hull's extent, and widths are measured along unit vectors.
"""

from __future__ import annotations

import numpy as np

SHORT_EDGE = 1e-6  # hull edges shorter than this share of the hull's extent give no direction


def minimum_rectangle(points: np.ndarray) -> np.ndarray:
    """Corners (4, 2) of the smallest-area rectangle holding ``points`` (N, 2), in order
    around it, its first side along the hull edge it lies on (units of the points). Points on
    a line give a rectangle of zero width along it; one point, four equal corners."""
    from scipy.spatial import ConvexHull, QhullError

    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if not np.all(np.isfinite(p)):
        raise ValueError(f"minimum_rectangle: points must be finite, got {int((~np.isfinite(p)).sum())} non-finite")
    if len(p) == 0:
        raise ValueError("minimum_rectangle: no points")
    try:
        hull = p[ConvexHull(p).vertices]
    except QhullError:  # collinear (or fewer than three distinct points): a segment
        hull = p
    extent = float(np.ptp(hull, axis=0).max())
    if extent == 0.0:
        return np.repeat(hull[:1], 4, axis=0)
    edges = np.roll(hull, -1, axis=0) - hull
    length = np.linalg.norm(edges, axis=1)
    keep = length > SHORT_EDGE * extent
    if len(hull) < 3 or not keep.any():  # a segment: along its longest extent
        d = p - p.mean(axis=0)
        _, _, vt = np.linalg.svd(d, full_matrices=False)
        along = vt[:1]
    else:
        along = edges[keep] / length[keep, None]  # (m, 2) unit directions
    across = np.column_stack([-along[:, 1], along[:, 0]])
    u, v = hull @ along.T, hull @ across.T  # (h, m) coordinates of the hull in each frame
    area = np.ptp(u, axis=0) * np.ptp(v, axis=0)
    k = int(np.argmin(area))
    u0, u1, v0, v1 = u[:, k].min(), u[:, k].max(), v[:, k].min(), v[:, k].max()
    a, n = along[k], across[k]
    return np.array([u0 * a + v0 * n, u1 * a + v0 * n, u1 * a + v1 * n, u0 * a + v1 * n])


def rectangle_sides(points: np.ndarray) -> np.ndarray:
    """(short, long) sides of :func:`minimum_rectangle` of ``points`` (N, 2)."""
    corners = minimum_rectangle(points)
    return np.sort(np.linalg.norm(np.diff(corners[:3], axis=0), axis=1))
