"""The smallest rectangle holding a plate's outline (flatten/rectangle.py), which the stock
check, the plan's sheet check and the drawings' orientation read.

Closed forms: a rectangle turned by any angle is its own smallest rectangle; a circle's is
the square of its diameter (within the polygon's chord). Independent check: the area over
every whole degree of rotation, a brute force the calipers must match or beat. Regression:
GEOS's answer for a cylinder plate's developed outline (an exact rectangle with rounding
noise) had zero width."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from flatten.rectangle import minimum_rectangle, rectangle_sides


def _turned_rectangle(a: float, b: float, angle: float, n: int = 50) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n, endpoint=False)
    ring = np.vstack([np.column_stack([a * t, 0 * t]), np.column_stack([a + 0 * t, b * t]),
                      np.column_stack([a * (1 - t), b + 0 * t]), np.column_stack([0 * t, b * (1 - t)])])
    c, s = np.cos(angle), np.sin(angle)
    return ring @ np.array([[c, s], [-s, c]]) + [3.0, -7.0]


def test_a_cylinder_plates_outline_with_rounding_noise_is_its_own_rectangle():
    # the bilge plate's development as the strip gives it: corners 1e-13 and 1e-44 off
    ring = _turned_rectangle(10000.0, 4712.38898038469, 0.0, 295) - [3.0, -7.0]
    ring[0] = [8.766219726684766e-45, 9.9579925010296e-13]
    ring[1] = [-1.1343785978393647e-44, 9.957992501029598e-13]
    ring[295] = [10000.000000000007, 2.4888367287281338e-25]
    assert rectangle_sides(ring) == pytest.approx([4712.38898038469, 10000.0], rel=1e-12)
    from pipeline.shop.plate import part_rectangle

    assert part_rectangle(ring) == pytest.approx([4712.38898038469, 10000.0], rel=1e-12)


@pytest.mark.parametrize("angle", [0.0, 0.3, np.pi / 4, 1.2, np.pi / 2])
def test_a_turned_rectangle_is_its_own_smallest_rectangle(angle):
    ring = _turned_rectangle(7.0, 2.5, angle)
    assert rectangle_sides(ring) == pytest.approx([2.5, 7.0], rel=1e-12)
    corners = minimum_rectangle(ring)
    sides = np.linalg.norm(np.diff(np.vstack([corners, corners[:1]]), axis=0), axis=1)
    assert sides[0] == pytest.approx(sides[2]) and sides[1] == pytest.approx(sides[3])


def test_a_circles_smallest_rectangle_is_the_square_of_its_diameter():
    t = np.linspace(0.0, 2 * np.pi, 720, endpoint=False)
    ring = 5.0 * np.column_stack([np.cos(t), np.sin(t)])
    chord_sagitta = 5.0 * (1 - np.cos(np.pi / 720))
    assert rectangle_sides(ring) == pytest.approx([10.0, 10.0], abs=3 * chord_sagitta)  # an edge-aligned side: 2 sagittas short


def test_points_on_a_line_give_a_rectangle_of_no_width_and_bad_points_are_refused():
    line = np.column_stack([np.linspace(0, 3, 7), np.linspace(0, 4, 7)])
    assert rectangle_sides(line) == pytest.approx([0.0, 5.0], abs=1e-12)
    assert rectangle_sides(np.array([[1.0, 2.0]] * 3)) == pytest.approx([0.0, 0.0])
    with pytest.raises(ValueError, match="non-finite"):
        minimum_rectangle(np.array([[0.0, 0.0], [1.0, np.nan], [2.0, 1.0]]))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.integers(min_value=3, max_value=40).flatmap(
    lambda n: st.lists(st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)), min_size=n, max_size=n)))
@example([(1.0, 0.0), (1.0, 0.0), (3.0, 1.0)])  # two distinct points: a segment of no width
def test_the_rectangle_holds_every_point_and_no_whole_degree_turn_does_better(points):
    p = np.asarray(points, dtype=float)
    corners = minimum_rectangle(p)
    a, b = corners[1] - corners[0], corners[3] - corners[0]
    la, lb = np.linalg.norm(a), np.linalg.norm(b)
    scale = max(float(np.ptp(p, axis=0).max()), 1.0)
    if la > 1e-9 * scale and lb > 1e-9 * scale:
        u, v = (p - corners[0]) @ (a / la), (p - corners[0]) @ (b / lb)
        assert u.min() >= -1e-9 * scale and u.max() <= la + 1e-9 * scale
        assert v.min() >= -1e-9 * scale and v.max() <= lb + 1e-9 * scale
    else:  # points on a line (or one point): the rectangle is the segment between the extremes
        side = a if la >= lb else b
        length = max(la, lb)
        along = (p - corners[0]) @ side / length if length > 0 else np.zeros(len(p))
        off = np.linalg.norm(p - corners[0] - np.outer(along, side / length if length > 0 else [0.0, 0.0]), axis=1)
        assert off.max() <= 1e-9 * scale
        assert along.min() >= -1e-9 * scale and along.max() <= length + 1e-9 * scale
    turns = np.radians(np.arange(180.0))
    brute = min(np.ptp(p @ [np.cos(t), np.sin(t)]) * np.ptp(p @ [-np.sin(t), np.cos(t)]) for t in turns)
    assert la * lb <= brute + 1e-9 * scale ** 2
