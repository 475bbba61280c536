"""Junctions of plates (pipeline/hull/junction.py): the smallest ball holding a junction's
corners, against closed forms and an independent minimiser; where formed corners go; which
flat or strip plates part at a formed plate's corner by more than its step limit allows."""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.optimize import minimize

from pipeline.hull.junction import junction_moves, junction_steps, smallest_ball


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


def _plate(klass, edges, tolerance=5.0):
    from pipeline.hull.fitup import Edge

    edges = tuple(Edge(side, side.upper(), np.asarray(points, dtype=float), np.asarray(points, dtype=float)[:, :2])
                  for side, points in edges.items())
    record = SimpleNamespace(klass=klass, edges=edges, edge=lambda s: next((e for e in edges if e.side == s), None))
    return record, SimpleNamespace(hull=SimpleNamespace(fit_tolerance=tolerance))


def _corner_of_three(lift_b, klass_f="formed"):
    # a formed plate F (x, y in 0..1000) with a strip A along its seam 0 (y = 0) and one B
    # along its butt 0 (x = 0); their edges end at F's corner (0, 0), B's lifted by lift_b mm
    records = {"F": _plate(klass_f, {"seam0": [[0, 0, 0], [1000, 0, 0]], "butt0": [[0, 0, 0], [0, 1000, 0]]}),
               "A": _plate("developable", {"seam1": [[0, 0, 0], [1000, 0, 0]]}),
               "B": _plate("flat", {"butt1": [[0, 0, lift_b], [0, 1000, lift_b]]})}
    pairs = [SimpleNamespace(a="A", b="F", side_a="seam1", side_b="seam0", limit=2.1),
             SimpleNamespace(a="B", b="F", side_a="butt1", side_b="butt0", limit=2.1)]
    return records, pairs


def test_two_flat_or_strip_neighbours_parting_at_a_formed_corner_are_a_junction_step():
    # 6 mm apart: the formed corner between them steps 3 mm from each, over the 2.1 mm limit
    records, pairs = _corner_of_three(6.0)
    (step,) = junction_steps(records, pairs, 1.0)
    assert (step.a, step.b, step.side_a, step.side_b, step.formed) == ("A", "B", "seam1", "butt1", "F")
    assert step.step_max == pytest.approx(3.0) and step.limit == 2.1 and step.step_max > step.limit
    # in metres the same
    metres = {n: _plate(r.klass, {e.side: e.points3 / 1000.0 for e in r.edges}, 0.005) for n, (r, _) in records.items()}
    assert junction_steps(metres, pairs, 1000.0)[0].step_max == pytest.approx(3.0)


def test_no_junction_step_within_the_limit_between_neighbours_or_without_a_formed_plate():
    assert junction_steps(*_corner_of_three(4.0), 1.0) == []  # 2 mm from each, within 2.1
    records, pairs = _corner_of_three(6.0)
    pairs.append(SimpleNamespace(a="A", b="B", side_a="butt0", side_b="seam0", limit=2.1, step_max=6.0))
    assert junction_steps(records, pairs, 1.0) == []  # they share an edge that steps: its own step says it
    assert junction_steps(*_corner_of_three(6.0, klass_f="developable"), 1.0) == []
    assert junction_steps(*_corner_of_three(12.0), 1.0) == []  # out of reach (10 mm): no junction


def _tee(short_b, unit=1.0):
    # a formed plate F (x 0..2000, y 0..1000 mm) with two strips along its seam 0, A (x
    # 0..1000) and B (x 1000..2000), sharing their butt at x = 1000 (within the limit: one
    # line), B short of F's seam by short_b mm along it: F's seam is one curve, and the T
    # where A's and B's ends part steps from one of them by half their distance at least
    edge = {"F": {"seam0": [[0, 0, 0], [2000, 0, 0]]},
            "A": {"seam1": [[0, 0, 0], [1000, 0, 0]], "butt1": [[1000, -1000, 0], [1000, 0, 0]]},
            "B": {"seam1": [[1000, -short_b, 0], [2000, -short_b, 0]],
                  "butt0": [[1000, -1000, 0], [1000, -short_b, 0]]}}
    klass = {"F": "formed", "A": "developable", "B": "flat"}
    records = {n: _plate(klass[n], {side: np.array(p, dtype=float) / unit for side, p in sides.items()}, 5.0 / unit)
               for n, sides in edge.items()}
    pairs = [SimpleNamespace(a="A", b="F", side_a="seam1", side_b="seam0", limit=2.1, step_max=0.0),
             SimpleNamespace(a="B", b="F", side_a="seam1", side_b="seam0", limit=2.1, step_max=short_b),
             SimpleNamespace(a="A", b="B", side_a="butt1", side_b="butt0", limit=2.1, step_max=0.0)]
    return records, pairs


@pytest.mark.parametrize("unit", [1.0, 1000.0])
def test_two_neighbours_that_share_an_edge_and_part_along_a_formed_edge_are_a_junction_step(unit):
    # B 6 mm short of A's end where their shared butt meets F's seam: F's seam, one curve
    # through grid points each formed to meet one of them, steps from the other by up to the
    # 6 mm, over the 2.1 mm limit; 2 mm short: within it, none
    (step,) = junction_steps(*_tee(6.0, unit), unit)
    assert (step.a, step.b, step.formed, step.where) == ("A", "B", "F", "edge")
    assert step.step_max == pytest.approx(6.0) and step.limit == 2.1
    assert junction_steps(*_tee(2.0, unit), unit) == []
    records, pairs = _tee(12.0, unit)
    assert junction_steps(records, pairs, unit) == []  # 12 mm: out of reach of each other, not one junction


def test_a_neighbour_whose_edge_runs_past_a_formed_corner_meets_it_along_the_edge():
    # the strip A along F's seam 0 runs 500 mm past F's corner (the butts of the two strakes
    # staggered): its edge, not its end, meets the corner, 6 mm from B's end: a junction step
    records, pairs = _corner_of_three(6.0)
    records["A"] = _plate("developable", {"seam1": [[-500, 0, 0], [1000, 0, 0]]})
    (step,) = junction_steps(records, pairs, 1.0)
    assert (step.a, step.b, step.formed, step.where) == ("A", "B", "F", "corner")
    assert step.step_max == pytest.approx(3.0)
    records["A"] = _plate("developable", {"seam1": [[-500, 12, 0], [1000, 12, 0]]})
    assert junction_steps(records, pairs, 1.0) == []  # 12 mm off the corner: out of reach
