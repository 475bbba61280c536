"""The steel plate text layout (pipeline.shop.layout), checked independently with shapely:
random plates, mark lines and texts; every placed box inside the room, clear of the lines
and of the other boxes; the fast tests of the placer decide as the exact ones do."""

from unittest import mock

import numpy as np
import pytest
import shapely
from hypothesis import given, seed, settings
from hypothesis import strategies as st

from pipeline.shop.layout import Placer, free_reach, inscribed_radius, plate_layout


def _star(rng: np.random.Generator, n: int, size: float, aspect: float) -> np.ndarray:
    """A simple polygon (n, 2), closed: radii at sorted angles, stretched by aspect."""
    angles = np.sort(rng.uniform(0, 2 * np.pi, n))
    radii = size * rng.uniform(0.4, 1.0, n)
    ring = np.column_stack([aspect * radii * np.cos(angles), radii * np.sin(angles)])
    return np.vstack([ring, ring[:1]])


def _lines(rng: np.random.Generator, plate: shapely.Polygon, count: int) -> list[np.ndarray]:
    """Segments (2, 2) and polylines (K, 2) across the plate's bounding box."""
    x0, y0, x1, y1 = plate.bounds
    out = []
    for k in range(count):
        points = rng.uniform([x0, y0], [x1, y1], size=(2 + k % 3, 2))
        out.append(points)
    return out


def _box(text, at, height, angle) -> shapely.Polygon:
    """The text's box from its fields alone (one character = one height wide, 1.3 high)."""
    a = np.radians(angle)
    u, v = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
    w, h = height * max(len(text), 1), 1.3 * height
    c = np.asarray(at)
    return shapely.Polygon([c + sx * w / 2 * u + sy * h / 2 * v for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))])


def _random_plate(key, corners, aspect, bends, frames, data_lines):
    """A plate outline (N, 2), its edges, bend marks, frame lines and part data lines."""
    rng = np.random.default_rng(key)
    net = _star(rng, corners, rng.uniform(200, 2000), aspect)
    plate = shapely.Polygon(net)
    x0, y0, x1, y1 = plate.bounds
    bend_marks = [(f"B{k + 1} R{rng.integers(500, 90000)}", *rng.uniform([x0, y0], [x1, y1], size=(2, 2)))
                  for k in range(bends)]
    frame_lines = [(f"FR {k}", line) for k, line in enumerate(_lines(rng, plate, frames))]
    ring = net[:-1]
    edges = {f"EDGE {k}": np.vstack([ring[k], ring[(k + 1) % len(ring)]]) for k in range(min(4, len(ring)))}
    part_data = [f"LINE {k} " + "X" * int(rng.integers(3, 30)) for k in range(data_lines)]
    return net, edges, bend_marks, frame_lines, part_data


@seed(20261123)
@settings(max_examples=30, deadline=None)
@given(key=st.integers(0, 2**32 - 1), corners=st.integers(3, 12), aspect=st.sampled_from([1.0, 3.0, 12.0]),
       bends=st.integers(0, 8), frames=st.integers(0, 3), data_lines=st.integers(1, 6))
def test_every_placed_text_inside_the_room_clear_of_lines_and_texts(key, corners, aspect, bends, frames, data_lines):
    net, edges, bend_marks, frame_lines, part_data = _random_plate(key, corners, aspect, bends, frames, data_lines)
    text_height = (5.0, 40.0)
    layout = plate_layout(net, net, edges, bend_marks, frame_lines, part_data, text_height)

    # the clearance the layout promises, from its own definition with an independent radius
    outline = shapely.make_valid(shapely.Polygon(net))
    outline = max(getattr(outline, "geoms", [outline]), key=lambda g: g.area)
    radius = shapely.maximum_inscribed_circle(outline, 1e-4 * np.sqrt(outline.area)).length
    clearance = min(0.2 * text_height[0], 0.05 * radius)
    tol = 1e-6 * clearance + 1e-3 * np.sqrt(outline.area) * 0.05  # the radius is found to 1e-3 sqrt(area)

    boxes = [_box(t.text, t.at, t.height, t.angle) for t in layout.texts]
    lines = [shapely.LineString(p) for _, p in layout.lines if len(p) >= 2]
    for t, b in zip(layout.texts, boxes):
        assert text_height[0] * (1 - 1e-9) <= t.height <= text_height[1], t  # shop.text_height, every text
        assert outline.contains(b), t
        # grown by the clearance inside the outline shrunk by it (its round corners are chords)
        assert b.distance(outline.exterior) >= 2 * clearance * (1 - 2e-3) - 2 * tol, t
        for line in lines:
            assert b.distance(line) >= clearance - tol, t
    for i in range(len(boxes)):
        for j in range(i):
            assert boxes[i].distance(boxes[j]) >= clearance - tol, (layout.texts[i], layout.texts[j])
    # every text is placed or named
    placed = {t.text for t in layout.texts}
    found = " ".join(layout.findings)
    on_plate = [text for text, a, b in bend_marks if shapely.LineString([a, b]).intersection(outline).length > 0]
    for text in list(edges) + on_plate:
        assert text in placed or repr(text) in found, text
    if "part data block" not in found:
        assert all(any(line in t for t in placed) for line in part_data)


def _brute_place(placer: Placer, centres, width, height, angles):
    """The first centre whose grown box lies in the room, meets no line and no placed box
    (shapely, one box at a time)."""
    c = placer.clearance
    for i, (p, a) in enumerate(zip(centres, angles)):
        grown = shapely.affinity.rotate(shapely.box(p[0] - width / 2 - c, p[1] - height / 2 - c,
                                                    p[0] + width / 2 + c, p[1] + height / 2 + c), a, origin=tuple(p))
        if not placer.room.contains(grown):
            continue
        if placer.obstacles is not None and placer.obstacles.intersects(grown):
            continue
        if any(grown.intersects(b) for b in placer.boxes):
            continue
        return i
    return None


@seed(20261124)
@settings(max_examples=40, deadline=None)
@given(key=st.integers(0, 2**32 - 1), lines=st.integers(0, 6), boxes=st.integers(0, 6))
def test_placer_takes_the_first_centre_the_exact_tests_accept(key, lines, boxes):
    """The placer's cheap tests (corner points, circumcircles, separating axes) only rule out
    boxes the exact shapely tests rule out: it takes the same centre as a one-by-one search,
    also on centres on a grid (touching boxes and lines included)."""
    rng = np.random.default_rng(key)
    room = shapely.Polygon(_star(rng, 7, 1000.0, rng.choice([1.0, 4.0])))
    if not room.is_valid:
        room = max(getattr(room.buffer(0), "geoms", [room.buffer(0)]), key=lambda g: g.area)
    marks = _lines(rng, room, lines)
    placer = Placer(room, marks, clearance=float(rng.choice([0.0, 1.0, 5.0])))
    twin = Placer(room, marks, placer.clearance)
    x0, y0, x1, y1 = room.bounds
    for k in range(boxes + 1):
        n = 60
        if k % 2:  # on a grid, boxes as wide as whole cells: they touch the placed ones (nearly)
            cell = np.array([(x1 - x0) / 20, (y1 - y0) / 40])
            centres = rng.integers(0, 20, size=(n, 2)) * cell + [x0, y0]
            angles = np.zeros(n)
            gap = rng.choice([0.0, 1e-4, -1e-4])  # touching, just apart, just overlapping
            w, h = (rng.integers(1, 4, size=2) * cell - placer.clearance - gap)
            w, h = max(w, 1.0), max(h, 1.0)
        else:
            centres = rng.uniform([x0, y0], [x1, y1], size=(n, 2))
            angles = rng.uniform(-90, 90, n)
            w, h = rng.uniform(10, 300), rng.uniform(5, 60)
        expected = _brute_place(twin, centres, w, h, angles)
        got = placer.place(centres.astype(float), w, h, angles)
        assert got == expected
        if expected is not None:
            twin.boxes.append(placer.boxes[-1])


@seed(20261125)
@settings(max_examples=60, deadline=None)
@given(key=st.integers(0, 2**32 - 1), count=st.integers(1, 30), angle=st.floats(-180, 180))
def test_free_reach_is_where_the_middle_line_first_meets_a_segment(key, count, angle):
    """A segment along the direction shorter than twice the reach meets none of the
    segments; one a little longer meets one (shapely)."""
    rng = np.random.default_rng(key)
    segments = rng.uniform(-100, 100, size=(count, 2, 2))
    centres = rng.uniform(-120, 120, size=(50, 2))
    a = np.radians(angle)
    d = np.array([np.cos(a), np.sin(a)])
    reach = free_reach(centres, d, segments)
    lines = shapely.multilinestrings(list(segments))
    for c, r in zip(centres, reach):
        if np.isfinite(r):
            assert not lines.intersects(shapely.LineString([c - 0.999999 * r * d, c + 0.999999 * r * d]))
            assert lines.intersects(shapely.LineString([c - 1.000001 * r * d, c + 1.000001 * r * d]))
        else:
            assert not lines.intersects(shapely.LineString([c - 1e3 * d, c + 1e3 * d]))


@seed(20261126)
@settings(max_examples=40, deadline=None)
@given(key=st.integers(0, 2**32 - 1), lines=st.integers(0, 6), angle=st.sampled_from([0.0, 90.0, 33.0, -71.5]))
def test_a_box_longer_than_its_reaches_is_refused_by_the_exact_tests(key, lines, angle):
    """What the part data block's search rules out by the reaches (Placer.reach) the exact
    tests rule out too; and boxes just inside the reaches are not all refused."""
    rng = np.random.default_rng(key)
    room = shapely.Polygon(_star(rng, 9, 1000.0, rng.choice([1.0, 6.0])))
    if not room.is_valid:
        room = max(getattr(room.buffer(0), "geoms", [room.buffer(0)]), key=lambda g: g.area)
    placer = Placer(room, _lines(rng, room, lines), clearance=float(rng.choice([0.0, 2.0])))
    x0, y0, x1, y1 = room.bounds
    centres = rng.uniform([x0, y0], [x1, y1], size=(80, 2))
    centres = centres[shapely.contains_xy(room, centres[:, 0], centres[:, 1])]
    along, across = placer.reach(centres, angle), placer.reach(centres, angle + 90.0)
    c = placer.clearance
    for p, ra, rc in zip(centres, along, across):
        for w, h in ((2 * ra * 1.001 - 2 * c, 0.1), (0.1, 2 * rc * 1.001 - 2 * c)):
            if w > 0 and h > 0:  # a little longer than the reach: refused
                assert _brute_place(placer, [p], w, h, [angle]) is None
    # the middle lines alone (thin boxes) within the reaches fit where nothing else is near
    thin = [(p, 2 * ra * 0.999 - 2 * c) for p, ra in zip(centres, along) if np.isfinite(ra) and ra * 0.999 > c]
    assert all(_brute_place(placer, [p], w, 1e-9, [angle]) == 0 for p, w in thin if c == 0.0)


@seed(20261127)
@settings(max_examples=25, deadline=None)
@given(key=st.integers(0, 2**32 - 1), corners=st.integers(3, 12), aspect=st.sampled_from([1.0, 3.0, 12.0]),
       bends=st.integers(0, 8), data_lines=st.integers(1, 8))
def test_the_reaches_skip_only_what_the_exact_tests_refuse(key, corners, aspect, bends, data_lines):
    """The same layout without the reaches (every centre tried by the placer's own tests)."""
    args = _random_plate(key, corners, aspect, bends, 1, data_lines)
    fast = plate_layout(args[0], args[0], *args[1:], (5.0, 40.0))

    def everywhere(self, centres, angle, count=None):
        return np.full(len(centres) if count is None else count, np.inf)

    with mock.patch.object(Placer, "reach", everywhere):
        slow = plate_layout(args[0], args[0], *args[1:], (5.0, 40.0))
    assert fast.texts == slow.texts and fast.findings == slow.findings


@pytest.mark.parametrize("length, width", [(8000.0, 350.0), (3000.0, 2000.0), (1000.0, 20.0)])
def test_inscribed_radius_of_a_rectangle_and_a_regular_polygon(length, width):
    """Closed forms: a rectangle's largest circle has radius width / 2; a regular n-gon's
    its apothem. The estimate is within 5 % of the mean width 2 area / perimeter."""
    rectangle = shapely.Polygon([(0, 0), (length, 0), (length, width), (0, width)])
    mean_width = 2 * rectangle.area / rectangle.length
    assert abs(inscribed_radius(rectangle) - width / 2) <= 0.05 * mean_width
    n, r = 12, 0.5 * length
    a = 2 * np.pi * np.arange(n) / n
    polygon = shapely.Polygon(np.column_stack([r * np.cos(a), r * np.sin(a)]))
    apothem = r * np.cos(np.pi / n)
    assert abs(inscribed_radius(polygon) - apothem) <= 0.05 * 2 * polygon.area / polygon.length
