"""Closest points on a surface with a collapsed side (a pole row): the search from the nearest
seed stops on it, the search along the sides does not (flatten.closest.closest_with_sides)."""

from __future__ import annotations

import numpy as np

from flatten.closest import SurfaceDistance, closest_with_sides
from flatten.surface import nurbs_surface


def test_a_foot_beside_a_collapsed_side_is_found_on_the_side_it_lies_on():
    """The triangle P(u, v) = (u v W, v L, 0), its side v = 0 collapsed to the apex: points
    30 mm beyond its side u = 1 near the apex and 5 mm above lie sqrt(d^2 + 25) from it, d their
    distance from the line x = W y / L in closed form."""
    width, length = 1000.0, 5000.0
    poles = np.array([[[0.0, 0.0, 0.0], [0.0, length, 0.0]], [[0.0, 0.0, 0.0], [width, length, 0.0]]])
    triangle = nurbs_surface(1, 1, poles, [0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 1.0, 1.0], name="triangle")
    y = np.linspace(20.0, 300.0, 8)
    points = np.column_stack([width * y / length + 30.0, y, np.full_like(y, 5.0)])
    normal = np.array([length, -width]) / np.hypot(length, width)
    exact = np.hypot(points[:, :2] @ normal, 5.0)
    distance = SurfaceDistance(triangle, grid=60)
    assert distance.closest(points)[1][0] > exact[0] + 5.0  # stopped on the apex
    params, found = closest_with_sides(distance, points)
    assert np.abs(found - exact).max() < 1e-6 * length
    assert np.allclose(params[:, 0], 1.0)  # on the side u = 1
    assert np.allclose(np.linalg.norm(triangle(params[:, 0], params[:, 1]) - points, axis=1), found)
