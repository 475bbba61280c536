"""Junctions of plates (pipeline/hull/junction.py): the smallest ball holding a junction's
corners, against closed forms and an independent minimiser, and where formed corners go."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.optimize import minimize

from pipeline.hull.junction import junction_moves, smallest_ball


def test_the_ball_of_two_points_is_centred_between_them():
    centre, radius = smallest_ball(np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 7.0]]))
    assert np.allclose(centre, [1.0, 2.0, 5.0]) and radius == pytest.approx(2.0)


def test_the_ball_of_an_acute_triangle_is_its_circumcircle_and_of_an_obtuse_one_its_longest_side():
    side = 3.0
    equilateral = np.array([[0.0, 0.0, 0.0], [side, 0.0, 0.0], [side / 2, side * np.sqrt(3) / 2, 0.0]])
    centre, radius = smallest_ball(equilateral)
    assert np.allclose(centre, equilateral.mean(axis=0)) and radius == pytest.approx(side / np.sqrt(3))
    obtuse = np.array([[0.0, 0.0, 1.0], [4.0, 0.0, 1.0], [2.0, 0.5, 1.0]])
    centre, radius = smallest_ball(obtuse)
    assert np.allclose(centre, [2.0, 0.0, 1.0]) and radius == pytest.approx(2.0)


def test_one_point_and_repeated_points_are_their_own_ball():
    assert smallest_ball(np.array([[1.0, 1.0, 1.0]]))[1] == 0.0
    centre, radius = smallest_ball(np.array([[1.0, 1.0, 1.0]] * 3 + [[1.0, 1.0, 3.0]]))
    assert np.allclose(centre, [1.0, 1.0, 2.0]) and radius == pytest.approx(1.0)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(arrays(np.float64, (5, 2), elements=st.floats(-10.0, 10.0)),
       arrays(np.float64, 5, elements=st.floats(-0.01, 0.01)))
def test_the_ball_of_a_junctions_corners_is_the_smallest(xy, lift):
    # corners on a hull lie in a thin layer: the ball through two or three of them is the
    # smallest; checked against a minimiser of the largest distance started at the centroid
    points = np.column_stack([xy, lift])
    centre, radius = smallest_ball(points)
    assert np.linalg.norm(points - centre, axis=1).max() == pytest.approx(radius, abs=1e-9)
    worst = minimize(lambda c: np.linalg.norm(points - c, axis=1).max(), points.mean(axis=0),
                     method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-10, "maxiter": 20000})
    assert radius <= worst.fun + 1e-6


def _junction(ends_z, owners, neighbours, corners_z=(0.0,), plates=("F",), reach=10.0):
    corners = np.array([[0.0, 0.0, z] for z in corners_z])
    ends = np.array([[0.0, 0.0, z] for z in ends_z])
    return junction_moves(corners, np.full(len(corners), reach), list(plates), neighbours, ends, list(owners))


def test_a_formed_corner_goes_between_the_ends_of_its_flat_neighbours_not_to_a_diagonal_one():
    # its two flat neighbours' edges end at z = 0 (two edges of one plate: the same corner)
    # and z = 4; the diagonal plate D's corner at z = -3 is no neighbour's, and moves nothing
    found, target = _junction([0.0, 0.0, 4.0, -3.0], ["A", "A", "B", "D"], [{"A", "B"}])
    assert found[0] and np.allclose(target[0], [0.0, 0.0, 2.0])


def test_a_corner_with_only_formed_neighbours_goes_where_they_go_and_a_stranger_does_not():
    # G shares an edge with F, whose corner went to A's end; H shares none with F
    found, target = _junction([3.0], ["A"], [{"A", "G"}, {"F"}, {"X"}], corners_z=(0.0, 1.0, 1.0),
                              plates=("F", "G", "H"))
    assert found.tolist() == [True, True, False]
    assert np.allclose(target[:2], [0.0, 0.0, 3.0]) and np.all(target[2] == 0.0)


def test_ends_out_of_reach_or_spread_wider_than_it_move_nothing():
    assert not _junction([11.0], ["A"], [{"A"}])[0][0]
    # two ends within reach (10 mm, twice the tolerance) of the corner but 18 mm apart: two
    # corners within the tolerance of one hull corner are at most 10 mm apart
    assert not _junction([-9.0, 9.0], ["A", "B"], [{"A", "B"}])[0][0]
    assert not _junction([], [], [{"A"}])[0].any()

