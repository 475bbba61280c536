"""The layout's quick paths against the plain ones: line_distance is shapely.distance to the
float, grid_points' clearances are shapely's, and Placer.place_each takes the boxes
Placer.place takes job by job."""

from unittest import mock

import numpy as np
import shapely
from hypothesis import given, seed, settings
from hypothesis import strategies as st

from pipeline.shop.layout import Placer, grid_points, line_distance, plate_layout
from tests.test_layout import _random_plate


def _polylines(rng: np.random.Generator, count: int, size: float) -> list[np.ndarray]:
    """Polylines (K, 2), K from 2 to 6, some with a repeated point (a zero-length segment)
    and some closed."""
    out = []
    for k in range(count):
        line = rng.uniform(-size, size, size=(2 + k % 5, 2))
        if k % 4 == 1:
            line = np.vstack([line[:1], line])
        if k % 4 == 2:
            line = np.vstack([line, line[:1]])
        out.append(line)
    return out


@seed(20261130)
@settings(max_examples=60, deadline=None)
@given(key=st.integers(0, 2**32 - 1), count=st.integers(0, 12), reach=st.sampled_from([1e-3, 1.0, 7.0, 50.0, 1e4]))
def test_line_distance_is_shapely_distance_to_the_float(key, count, reach):
    rng = np.random.default_rng(key)
    lines = _polylines(rng, count, 100.0)
    points = rng.uniform(-130, 130, size=(300, 2))
    # points on the lines' vertices and segments, and on a grid (ties between cells)
    vertices = np.vstack(lines) if lines else np.zeros((0, 2))
    on = [line[0] + f * (line[1] - line[0]) for line, f in zip(lines, rng.uniform(0, 1, len(lines)))]
    grid = np.stack(np.meshgrid(np.linspace(-120, 120, 13), np.linspace(-120, 120, 9)), axis=-1).reshape(-1, 2)
    points = np.vstack([points, vertices, *on, grid]) if on else np.vstack([points, grid])
    got = line_distance(points, lines, reach)
    if not lines:
        assert np.isinf(got).all()
        return
    everything = shapely.multilinestrings([shapely.LineString(p) for p in lines])
    expected = shapely.distance(shapely.points(points), everything)
    assert np.array_equal(got, expected)


def test_line_distance_closed_forms():
    """A unit square's edge: a point inside at (x, y) is min(x, y, 1 - x, 1 - y) from it;
    beyond a corner, the distance to the corner."""
    square = [np.array([(0, 0), (1, 0), (1, 1), (0, 1), (0, 0)], dtype=float)]
    xy = np.random.default_rng(7).uniform(0, 1, size=(500, 2))
    got = line_distance(xy, square, 0.1)
    assert np.allclose(got, np.minimum(xy, 1 - xy).min(axis=1), rtol=0, atol=1e-15)
    assert np.allclose(line_distance([(4.0, 5.0), (-3.0, -4.0)], square, 0.1), [5.0, 5.0], rtol=0, atol=1e-15)


@seed(20261131)
@settings(max_examples=30, deadline=None)
@given(key=st.integers(0, 2**32 - 1), lines=st.integers(0, 5))
def test_grid_points_clearance_is_shapely_distance(key, lines):
    rng = np.random.default_rng(key)
    angles = np.sort(rng.uniform(0, 2 * np.pi, 9))
    radii = 1000.0 * rng.uniform(0.4, 1.0, 9)
    room = shapely.Polygon(np.column_stack([rng.choice([1.0, 8.0]) * radii * np.cos(angles), radii * np.sin(angles)]))
    obstacles = shapely.multilinestrings([shapely.LineString(rng.uniform(-900, 900, size=(2 + k % 3, 2)))
                                          for k in range(lines)]) \
        if lines else None
    pts, depth = grid_points(room, obstacles, n=40)
    assert shapely.contains_xy(room, pts[:, 0], pts[:, 1]).all()
    expected = shapely.distance(shapely.points(pts), room.exterior)
    if obstacles is not None:
        expected = np.minimum(expected, shapely.distance(shapely.points(pts), obstacles))
    assert np.array_equal(depth, expected)
    assert (np.diff(depth) <= 0).all()


@seed(20261132)
@settings(max_examples=40, deadline=None)
@given(key=st.integers(0, 2**32 - 1), lines=st.integers(0, 6), jobs=st.integers(1, 12),
       head=st.sampled_from([1, 4, 16, 1000]), first=st.sampled_from([1, 2, 5]))
def test_place_each_takes_what_place_takes_in_turn(key, lines, jobs, head, first):
    """The same indices and the same boxes as place() job by job, also with boxes placed
    between two jobs, on random and on grid centres (touching boxes)."""
    rng = np.random.default_rng(key)
    angles = np.sort(rng.uniform(0, 2 * np.pi, 7))
    radii = 1000.0 * rng.uniform(0.4, 1.0, 7)
    room = shapely.Polygon(np.column_stack([rng.choice([1.0, 4.0]) * radii * np.cos(angles), radii * np.sin(angles)]))
    marks = [rng.uniform(-900, 900, size=(2 + k % 3, 2)) for k in range(lines)]
    clearance = float(rng.choice([0.0, 1.0, 5.0]))
    fast, plain = Placer(room, marks, clearance), Placer(room, marks, clearance)
    x0, y0, x1, y1 = room.bounds
    work = []
    for k in range(jobs):
        n = int(rng.integers(0, 80))
        if k % 2:
            cell = np.array([(x1 - x0) / 20, (y1 - y0) / 40])
            centres = rng.integers(0, 20, size=(n, 2)) * cell + [x0, y0]
            w, h = np.maximum(rng.integers(1, 4, size=2) * cell - clearance - rng.choice([0.0, 1e-4, -1e-4]), 1.0)
            ang = np.zeros(n)
        else:
            centres = rng.uniform([x0, y0], [x1, y1], size=(n, 2))
            w, h = rng.uniform(10, 300), rng.uniform(5, 60)
            ang = rng.uniform(-90, 90, n)
        work.append((centres.astype(float), float(w), float(h), ang))
    between = (rng.uniform([x0, y0], [x1, y1], size=(30, 2)), 80.0, 20.0, 0.0)
    for k, got in enumerate(fast.place_each(work, head=head, first=first)):
        assert got == plain.place(*work[k])
        if k % 3 == 1:  # a box placed between two jobs counts for the next ones
            assert fast.place(*between) == plain.place(*between)
    assert np.array_equal(fast.placed, plain.placed)


@seed(20261133)
@settings(max_examples=20, deadline=None)
@given(key=st.integers(0, 2**32 - 1), corners=st.integers(3, 12), aspect=st.sampled_from([1.0, 3.0, 12.0]),
       bends=st.integers(0, 8), frames=st.integers(0, 3))
def test_layout_with_place_each_is_the_layout_with_place(key, corners, aspect, bends, frames):
    """The whole plate's layout is the same when every label is placed by place() alone."""
    args = _random_plate(key, corners, aspect, bends, frames, 3)
    fast = plate_layout(args[0], args[0], *args[1:], (5.0, 40.0))

    def one_by_one(self, jobs, head=16, first=2):
        for job in jobs:
            yield self.place(*job)

    with mock.patch.object(Placer, "place_each", one_by_one):
        plain = plate_layout(args[0], args[0], *args[1:], (5.0, 40.0))
    assert fast.texts == plain.texts and fast.findings == plain.findings


@seed(20261201)
@settings(max_examples=60, deadline=None)
@given(key=st.integers(0, 2**32 - 1), count=st.integers(1, 40))
def test_text_corners_are_shapelys_turned_boxes_to_the_float(key, count):
    """The layout's extents take every text's corners at once: the same floats as a shapely
    box turned by shapely.affinity.rotate about its centre, text by text (right angles,
    whose cosines shapely rounds to 0, among the angles)."""
    from shapely.affinity import rotate

    from pipeline.shop.layout import CHAR_WIDTH, Text, text_corners

    rng = np.random.default_rng(key)
    angles = np.where(rng.uniform(size=count) < 0.3, rng.choice([-90.0, 0.0, 90.0, 180.0], size=count),
                      rng.uniform(-180, 180, size=count))
    texts = [Text("text", "X" * int(rng.integers(0, 12)), tuple(rng.uniform(-5e3, 5e3, 2)),
                  float(rng.uniform(1, 60)), float(a)) for a in angles]
    corners = text_corners(texts)
    assert corners.shape == (count, 4, 2)
    for text, mine in zip(texts, corners):
        w, h = CHAR_WIDTH * text.height * max(len(text.text), 1), 1.3 * text.height
        x, y = text.at
        box = shapely.box(x - w / 2, y - h / 2, x + w / 2, y + h / 2)
        theirs = np.asarray(rotate(box, text.angle, origin=(x, y)).exterior.coords)[:4]
        assert np.array_equal(mine, theirs)
        assert np.array_equal(np.asarray(text.box().exterior.coords)[:4], theirs)
