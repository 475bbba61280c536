"""Closest points on a surface with a collapsed side (a pole row): the search from the nearest
seed stops on it, the search along the sides does not (flatten.closest.closest_with_sides)."""

from __future__ import annotations

import numpy as np

from flatten.closest import CONVERGED, SurfaceDistance, closest_with_sides
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


def _rectangle(corner, along_u, along_v, name):
    """The bilinear patch corner + u along_u + v along_v, (u, v) in [0, 1]^2 (mm)."""
    corner, along_u, along_v = (np.asarray(x, dtype=float) for x in (corner, along_u, along_v))
    poles = np.array([[corner, corner + along_v], [corner + along_u, corner + along_u + along_v]])
    return nurbs_surface(1, 1, poles, [0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 1.0, 1.0], name=name)


def _seed_search_of_every_surface(distance: SurfaceDistance, points: np.ndarray) -> np.ndarray:
    """SurfaceDistance's distance with every surface's seed samples looked up for every
    point (before the lookups were bounded by the surfaces' boxes), written out here."""
    seed = np.stack([tree.query(points)[0] for _, _, tree in distance._seeds])
    first = np.argmin(seed, axis=0)
    best = np.full(len(points), np.inf)
    for k in range(len(distance.surfaces)):
        mine = np.flatnonzero(first == k)
        best[mine] = distance.closest(points[mine], k, converged=CONVERGED)[1]
    for k in range(len(distance.surfaces)):
        need = np.flatnonzero((first != k) & (seed[k] - distance._reach[k] <= best))
        best[need] = np.minimum(best[need], distance.closest(points[need], k, converged=CONVERGED)[1])
    return best


def _bilge(length, breadth, radius):
    """The quarter cylinder (radius mm, along x over length) turning from the bottom z = 0
    to the side y = breadth: its centre line at y = breadth - radius, z = radius."""
    cy, cz = breadth - radius, radius
    arc = np.array([[cy, 0.0], [breadth, 0.0], [breadth, cz]])  # rational quadratic quarter circle
    poles = np.array([[[x, y, z] for y, z in arc] for x in (0.0, length)])
    weights = np.array([[1.0, np.sqrt(0.5), 1.0]] * 2)
    return nurbs_surface(1, 2, poles, [0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 0.0, 1.0, 1.0, 1.0], weights, name="bilge")


def _distance_to_bilge(points, length, breadth, radius):
    """Closed form: along x as to a segment, across as to the quarter circle (to its
    nearer end where the point's direction from the centre line lies outside the quarter)."""
    cy, cz = breadth - radius, radius
    y, z = points[:, 1] - cy, points[:, 2] - cz
    angle = np.arctan2(z, y)  # the quarter runs from -pi/2 (bottom) to 0 (side)
    inside = (angle >= -np.pi / 2) & (angle <= 0.0)
    ends = np.array([[0.0, -radius], [radius, 0.0]])
    to_ends = np.min([np.hypot(y - a, z - b) for a, b in ends], axis=0)
    across = np.where(inside, np.abs(np.hypot(y, z) - radius), to_ends)
    return np.hypot(points[:, 0] - np.clip(points[:, 0], 0.0, length), across)


def test_the_distance_to_a_hull_of_a_bottom_a_bilge_a_side_and_a_transom_is_the_nearest_face_s():
    """A 100 m bottom and side joined by a 3 m bilge, and an 8 m high transom across their
    end (flat: from the hull's length a KD-tree search visits most of its samples, so it is
    searched only where it may be the nearest): every point within 500 mm of the hull lies at
    its distance to the nearest face in closed form, and every point's distance is bit for bit
    what searching every face's seeds gives."""
    length, breadth, depth, radius = 100_000.0, 10_000.0, 8_000.0, 3_000.0
    bottom = _rectangle((0, 0, 0), (length, 0, 0), (0, breadth - radius, 0), "bottom")
    side = _rectangle((0, breadth, radius), (length, 0, 0), (0, 0, depth - radius), "side")
    transom = _rectangle((0, 0, 0), (0, breadth, 0), (0, 0, depth), "transom")
    faces = [bottom, _bilge(length, breadth, radius), side, transom]
    rng = np.random.default_rng(7)
    points = rng.uniform((-5_000.0, -2_000.0, -2_000.0), (length + 5_000.0, breadth + 2_000.0, depth + 2_000.0),
                         (20_000, 3))
    boxes = [((0.0, 0.0, 0.0), (length, breadth - radius, 0.0)), ((0.0, breadth, radius), (length, breadth, depth)),
             ((0.0, 0.0, 0.0), (0.0, breadth, depth))]
    exact = np.min([np.linalg.norm(points - np.clip(points, a, b), axis=1) for a, b in boxes]
                   + [_distance_to_bilge(points, length, breadth, radius)], axis=0)
    found = SurfaceDistance(faces)(points)
    near = exact < 500.0  # (Gauss-Newton's 12 steps settle metres away from the bilge only to ~0.01 %)
    assert near.sum() > 1000
    assert np.abs(found - exact)[near].max() < 1e-6
    assert np.array_equal(found, _seed_search_of_every_surface(SurfaceDistance(faces), points))
