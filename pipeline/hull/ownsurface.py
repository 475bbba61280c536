"""A plate's own surface: distances from it and closest points on it.

A plan of several faces shares one :class:`flatten.closest.SurfaceDistance` over all of
them, which measures against the nearest face. Where two faces disagree (DTMB 5415's bow and
main hull at the plan's cut) a plate moved toward the other face would pass for on the hull,
so a plate that is moved (formed to meet, pulled at erection) is measured against its own.
"""

from __future__ import annotations

import numpy as np


def own_surface(hull):
    """(finder, k): a SurfaceDistance and the index of the plate's own surface in it (the
    plan's shared one where it holds that surface, else one of its own)."""
    from flatten.closest import SurfaceDistance

    shared = hull.distance
    k = next((i for i, s in enumerate(getattr(shared, "surfaces", None) or ()) if s is hull.surface), None)
    return (shared, k) if k is not None else (SurfaceDistance(hull.surface), 0)


def hull_distance(hull):
    """Distances (N,) of points (N, 3) from the plate's own surface (a plate given a
    distance function of its own hull, not a SurfaceDistance, is measured with that)."""
    from flatten.closest import CONVERGED

    shared = hull.distance
    if shared is not None and getattr(shared, "surfaces", None) is None:
        return shared
    finder, k = own_surface(hull)
    return lambda points: finder.closest(points, k, converged=CONVERGED)[1]


def hull_points(hull, points: np.ndarray) -> np.ndarray:
    """(N, 3) the closest points of the plate's own surface to points (N, 3)."""
    from flatten.closest import CONVERGED

    finder, k = own_surface(hull)
    uv, _ = finder.closest(points, k, converged=CONVERGED)
    return np.asarray(hull.surface(uv[:, 0], uv[:, 1]), dtype=np.float64)
