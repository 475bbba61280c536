"""A plate grid's edges where the hull's seam turns sharply (flatten.patch.turn_refined_grid).

DTMB 5415's seam 2 turns from the keel up the stem within about 300 mm; the plates either
side of it sample it at their own columns, about 150 mm apart, and their chords parted by
up to 20.6 mm there. Here a surface extruded from a profile that runs along x, turns up
through a quarter circle of radius R and runs up z: its seams (v constant) are that
profile, whose distance from any point is known in closed form."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flatten.patch import (
    _near_cuts,
    chord_sagittas,
    region_grid,
    subdivided,
    turn_refined,
    turn_refined_grid,
)
from flatten.surface import nurbs_surface

R = 0.05
SQ = np.sqrt(0.5)
NORMAL = np.array([SQ, 0.0, SQ])  # x + z grows along the whole profile: butt planes cut it once


def bent_sheet(straight_far=False):
    """u along the profile: (0, 0) to (1, 0), the exact quarter circle to (1 + R, R), up to
    (1 + R, 1) (degree 2, double knots at the joins); v: y from 0 to 1, linear, to the same
    profile at y = 1, or (``straight_far``) to a straight line there (the edge y = 0 is the
    profile exactly)."""
    profile = [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0), (1.0 + R, 0.0), (1.0 + R, R), (1.0 + R, 0.5 + R / 2),
               (1.0 + R, 1.0)]
    far = [(1.6 * t, 0.6 * t) for t in (0.0, 0.2, 0.4, 0.5, 0.6, 0.8, 1.0)] if straight_far else profile
    weights = [1.0, 1.0, 1.0, SQ, 1.0, 1.0, 1.0]
    poles = np.array([[(x, 0.0, z), (x_far, 1.0, z_far)] for (x, z), (x_far, z_far) in zip(profile, far)])
    return nurbs_surface(2, 1, poles, [0, 0, 0, 0.45, 0.45, 0.55, 0.55, 1, 1, 1], [0, 0, 1, 1],
                         weights=np.repeat(np.array(weights)[:, None], 2, axis=1), name="bent")


def profile_distance(points, at_y=0.5):
    """Distance (N,) of points (N, 3) from the profile at y = ``at_y`` (closed form)."""
    x, y, z = points.T
    on_line = np.hypot(np.clip(x, 0.0, 1.0) - x, z)
    up = np.hypot(x - (1.0 + R), np.clip(z, R, 1.0) - z)
    angle = np.arctan2(z - R, x - 1.0)  # the arc's points lie at angles -90..0 degrees from (1, R)
    inside = (angle >= -np.pi / 2) & (angle <= 0.0)
    arc = np.where(inside, np.abs(np.hypot(x - 1.0, z - R) - R), np.inf)
    return np.sqrt(np.minimum(np.minimum(on_line, up), arc) ** 2 + (y - at_y) ** 2)


def chord_standoff(polyline, samples=41, at_y=0.5):
    """The largest distance from the profile at y = ``at_y`` of the polyline's chords (sampled)."""
    t = np.linspace(0.0, 1.0, samples)[None, :, None]
    pts = polyline[:-1, None, :] + t * np.diff(polyline, axis=0)[:, None, :]
    return float(profile_distance(pts.reshape(-1, 3), at_y).max())


def planes(lo, hi):
    return [(NORMAL, lo * SQ), (NORMAL, hi * SQ)]  # x + z between lo and hi


def const(value):
    return lambda s: np.full(np.shape(s), float(value))


def test_a_chords_sagitta_on_a_circle_is_the_closed_form():
    # chords of angle d on a circle of radius r stand off it by r (1 - cos(d / 2))
    for r, n in ((100.0, 5), (3.0, 40), (0.05, 3)):
        theta = np.linspace(0.0, np.pi / 2, n)
        circle = np.c_[r * np.cos(theta), r * np.sin(theta), np.zeros(n)]
        expected = r * (1.0 - np.cos(theta[1] / 2))
        assert chord_sagittas(circle) == pytest.approx(np.full(n - 1, expected), rel=2e-2)
    straight = np.c_[np.linspace(0, 1, 9), np.zeros(9), np.zeros(9)]
    assert np.all(chord_sagittas(straight) == 0.0)


def test_fractions_of_gently_turning_edges_are_kept_as_they_are():
    theta = np.linspace(0.0, 0.1, 11)
    arc = np.c_[10.0 * np.cos(theta), 10.0 * np.sin(theta), np.zeros(11)]  # sagitta 1.25e-4
    fractions = np.linspace(0.0, 1.0, 11)
    assert turn_refined(fractions, (arc,), 1e-3, 1e-4) is fractions
    refined = turn_refined(fractions, (arc,), 1e-4, 1e-5)
    assert len(refined) > 11 and np.all(np.diff(refined) > 0) and set(fractions) <= set(refined)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.integers(3, 30), st.floats(0.01, 100.0), st.floats(0.05, 3.0), st.floats(1e-4, 0.8))
def test_refined_fractions_keep_the_old_ones_and_bring_a_circle_within_the_target(n, radius, sweep, target):
    # any arc of a circle sampled evenly: the cut fractions still increase from 0 to 1, hold
    # the old ones, and the chords of the arc sampled at them stand off it by at most the
    # target where they were cut (and by the old sagitta, under the trigger, elsewhere)
    fractions = np.linspace(0.0, 1.0, n)

    def arc(f):
        return np.c_[radius * np.cos(sweep * f), radius * np.sin(sweep * f), np.zeros(len(f))]

    sagitta = radius * (1.0 - np.cos(sweep / (n - 1) / 2))
    refined = turn_refined(fractions, (arc(fractions),), 0.5 * sagitta, target * sagitta, max_pieces=8)
    assert refined[0] == 0.0 and refined[-1] == 1.0 and np.all(np.diff(refined) > 0)
    assert set(fractions) <= set(refined)
    pieces = (len(refined) - 1) // (n - 1)  # every chord of a circle alike
    assert len(refined) == (n - 1) * pieces + 1 and 2 <= pieces <= 8
    exact = radius * (1.0 - np.cos(sweep * np.diff(refined) / 2))
    assert exact.max() <= max(target, 1.0 / 64) * sagitta * 1.02
    assert pieces == 8 or (pieces - 1) ** 2 < 1.02 / target  # no more pieces than it takes: one fewer would not do


@pytest.mark.parametrize("spacing", ["length", "parameter"])
def test_two_plates_across_a_sharply_turning_seam_meet_once_their_columns_are_cut(spacing):
    # plate A (seams v 0..0.5) and B (v 0.5..1) share seam v = 0.5 over x + z 0.4..1.7, the
    # turn inside; their butts are staggered, so each samples the turn at its own columns
    surface = bent_sheet()
    trigger, target = 5e-3, 5e-4
    standoff, refined, plain_grids = {}, {}, {}
    for name, (lo_seam, hi_seam, lo, hi, row) in {"A": (0.0, 0.5, 0.3, 1.7, -1), "B": (0.5, 1.0, 0.4, 1.8, 0)}.items():
        args = (surface, 0, const(lo_seam), const(hi_seam), planes(lo, hi))
        plain = region_grid(*args, 5, 11, probe=200, spacing=spacing)
        grid = turn_refined_grid(*args, 5, 11, trigger, target, probe=200, spacing=spacing)
        standoff[name] = chord_standoff(plain.points[row]), chord_standoff(grid.points[row])
        refined[name], plain_grids[name] = grid, plain
        # the butts lie on their planes and the seams on the surface, as before
        ends = grid.points[:, [0, -1]] @ NORMAL / SQ
        np.testing.assert_allclose(ends, np.broadcast_to([lo, hi], ends.shape), atol=1e-9)
        assert grid.shape[0] == plain.shape[0] and grid.shape[1] > plain.shape[1]
    for name in "AB":
        before, after = standoff[name]
        assert before > trigger  # the plain grid's edge chords cut the turn
        assert after <= 1.5 * target  # the estimate from the turn: within half as much again
    # the step between the two plates' edges (each one's seam points from the other's
    # chords, over their common part): the turn's chord before, the target now
    for grids, bound in (({n: plain_grids[n] for n in "AB"}, None), (refined, 2.0 * target)):
        a, b = grids["A"].points[-1], grids["B"].points[0]
        step = max(polyline_distance(a[along_profile(a, 0.4, 1.7)], b), polyline_distance(b[along_profile(b, 0.4, 1.7)], a))
        if bound is None:
            assert step > trigger
        else:
            assert step <= bound


def along_profile(points, lo, hi):
    return (points @ NORMAL / SQ >= lo) & (points @ NORMAL / SQ <= hi)


def polyline_distance(points, polyline):
    """Largest distance (scalar) of points (N, 3) from a polyline (M, 3)."""
    a, ab = polyline[:-1], np.diff(polyline, axis=0)
    f = np.clip(np.einsum("pij,ij->pi", points[:, None] - a[None], ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return float(np.linalg.norm(a[None] + f[..., None] * ab[None] - points[:, None], axis=2).min(axis=1).max())


@pytest.mark.parametrize("spacing", ["length", "parameter"])
def test_two_plates_across_a_sharply_turning_butt_meet_once_their_rows_are_cut(spacing):
    # the same sheet with u across the girth (long_axis 1: the plates run along y and their
    # butts, planes y = const, are the profile): plate A (y 0..0.5) spans the girth u
    # 0.1..0.9 and B (y 0.5..1) 0.2..0.95, so each samples the turn of their common butt at
    # its own rows; cut, A's butt points lie on B's butt chords within twice the target
    surface = bent_sheet()
    trigger, target = 5e-3, 5e-4
    y_planes = {"A": [None, (np.array([0.0, 1.0, 0.0]), 0.5)], "B": [(np.array([0.0, 1.0, 0.0]), 0.5), None]}
    girths = {"A": (0.1, 0.9), "B": (0.2, 0.95)}
    butt = {}
    for name, column in (("A", -1), ("B", 0)):
        args = (surface, 1, const(girths[name][0]), const(girths[name][1]), y_planes[name])
        plain = region_grid(*args, 9, 5, probe=200, spacing=spacing)
        grid = turn_refined_grid(*args, 9, 5, trigger, target, probe=200, spacing=spacing)
        assert grid.shape[1] == plain.shape[1] and grid.shape[0] > plain.shape[0]
        np.testing.assert_allclose(grid.points[:, column, 1], 0.5, atol=1e-12)
        butt[name] = plain.points[:, column], grid.points[:, column]
    for k, bound in ((0, None), (1, 2.0 * target)):
        a, b = butt["A"][k], butt["B"][k]
        inside = along_profile(a, float(b[0] @ NORMAL / SQ), float(b[-1] @ NORMAL / SQ))
        step = max(polyline_distance(a[inside], b), polyline_distance(b[along_profile(b, float(a[0] @ NORMAL / SQ),
                                                                                       float(a[-1] @ NORMAL / SQ))], a))
        assert step > trigger if bound is None else step <= bound


def test_the_seam_that_turns_is_cut_whichever_edge_of_the_grid_it_is():
    # the sheet bends at y = 0 and is straight at y = 1: a plate between the seams v 0..1 has
    # its turning seam as its first row and a straight one as its last; the columns are cut
    # for the first, within the target
    surface = bent_sheet(straight_far=True)
    trigger, target = 5e-3, 5e-4
    args = (surface, 0, const(0.0), const(1.0), planes(0.3, 1.7))
    plain = region_grid(*args, 5, 11, probe=200, spacing="length")
    grid = turn_refined_grid(*args, 5, 11, trigger, target, probe=200, spacing="length")
    assert chord_sagittas(plain.points[-1]).max() < trigger < chord_standoff(plain.points[0], at_y=0.0)
    assert chord_standoff(grid.points[0], at_y=0.0) <= 1.5 * target


def test_a_grid_whose_edges_turn_gently_is_the_plain_grid_to_the_bit():
    surface = bent_sheet()
    args = (surface, 0, const(0.1), const(0.6), planes(0.2, 0.9))  # the flat part: no turn
    for spacing in ("length", "parameter"):
        plain = region_grid(*args, 6, 13, probe=200, spacing=spacing)
        grid = turn_refined_grid(*args, 6, 13, 5e-3, 5e-4, probe=200, spacing=spacing)
        assert grid.points.tobytes() == plain.points.tobytes() and grid.params.tobytes() == plain.params.tobytes()


def test_pieces_of_cut_intervals_and_their_neighbours_are_marked():
    old = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    new = np.array([0.0, 0.25, 0.375, 0.5, 0.75, 1.0])  # the second interval cut in two
    assert _near_cuts(old, new).tolist() == [True, True, True, True, False]
    assert _near_cuts(old, old).tolist() == [False] * 4
    dropped = np.array([0.0, 0.25, 0.75, 1.0])  # a row dropped: the interval across it is no old one
    assert _near_cuts(old, dropped).tolist() == [True, True, True]


def test_points_that_coincide_make_no_turn():
    # a seam collapsing to a point at a strake's end repeats its point: its direction is
    # round-off, not a turn of the straight line it lies on
    for gap in (0.0, 1e-13):
        line = np.array([[0.0, 0.0, 0.0], [gap, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
        assert np.all(chord_sagittas(line) == 0.0)
        assert len(turn_refined(np.linspace(0, 1, 4), (line,), 1e-6, 1e-7)) == 4


def test_fractions_that_do_not_increase_are_refused_naming_them():
    surface = bent_sheet()
    with pytest.raises(ValueError, match="cols fractions"):
        region_grid(surface, 0, const(0.0), const(0.5), planes(0.3, 1.7), 5, [0.0, 0.6, 0.5, 1.0])
    with pytest.raises(ValueError, match="cols fractions"):
        region_grid(surface, 0, const(0.0), const(0.5), planes(0.3, 1.7), 5, [0.1, 0.5, 1.0])
    with pytest.raises(ValueError, match="rows fractions"):
        region_grid(surface, 0, const(0.0), const(0.5), planes(0.3, 1.7), [0.0, 1.2], 9)
    same = region_grid(surface, 0, const(0.0), const(0.5), planes(0.3, 1.7), 5, 9)
    given = region_grid(surface, 0, const(0.0), const(0.5), planes(0.3, 1.7), np.linspace(0, 1, 5), np.linspace(0, 1, 9))
    assert np.array_equal(same.points, given.points)


def test_intervals_cut_into_even_parts_as_linspace_places_them():
    assert subdivided(np.array([0.0, 1.0, 3.0]), [2, 1]).tolist() == [0.0, 0.5, 1.0, 3.0]
    points = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 8.0]])  # a polyline: every segment in 4
    expected = np.r_[np.c_[np.arange(4.0), np.zeros(4)], np.c_[np.full(4, 4.0), 2.0 * np.arange(4.0)], [[4.0, 8.0]]]
    assert np.array_equal(subdivided(points, 4), expected)
    f = np.array([0.0, 0.1, 0.7, 1.0])
    assert np.array_equal(subdivided(f, [3, 1, 5])[:-1], np.concatenate([np.linspace(0.0, 0.1, 4)[:-1], [0.1],
                                                                       np.linspace(0.7, 1.0, 6)[:-1]]))
