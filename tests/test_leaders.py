"""Labels written away from what they name, with a leader (pipeline.shop.leaders), and the
shop drawing's heating-group names and B-numbers that find no room beside their lines.

A leader starts at a dot on the label's own line, runs straight toward the label's centre
and stops GAP short of the side of its box that it meets; the label's box is clear of every
drawn line, label and leader; the leader crosses no label, no other leader and no barrier
(dimension lines), runs across lines rather than along them or along an area's hatching,
passes other dots and points still to be led by DOT_CLEAR, and its end is nearer its own
label than any other by END_CLEAR; dots stay DOT_APART. On a drawing whose heating lines lie
closer than a label's height, every group's name is drawn with its dot on its own group's
line (read back from the PDF: no overlap, no text on a line); a name with no room even for
a leader is listed in the title block's room left, else on the sheet; B-numbers hemmed in at
both ends are led from their own lines.
"""

import itertools

import numpy as np
import pytest
import shapely

from pipeline.shop.drawing import (
    NEARER_BY,
    UNNAMED_NOTE,
    _nearer,
    _own_parts,
    plan_pages,
    write_shop_drawing,
)
from pipeline.shop.layout import Layout, Text
from pipeline.shop.leaders import (
    DOT_APART,
    DOT_CLEAR,
    DOT_OFF_EDGES,
    HATCH_CLEAR,
    LEADER_REACH,
    WORD_GAP,
    Leaders,
    slid_along,
)
from pipeline.shop.paper import END_CLEAR, GAP, H_LABEL, PaperPlacer
from tests.test_drawing_read import check_readable


def _hatch(centre, half: float, pitch: float) -> list[np.ndarray]:
    """Vertical lines every ``pitch`` mm over a square of half-side ``half`` about centre."""
    cx, cy = centre
    return [np.array([[x, cy - half], [x, cy + half]]) for x in np.arange(cx - half, cx + half + 1e-9, pitch)]


def _box(label) -> shapely.Polygon:
    return shapely.box(*label.box())


def _short_of(leader, label) -> float:
    """How far the leader's end stops short of the label's box, across the side it meets."""
    x0, y0, x1, y1 = label.box()
    x, y = leader[1]
    return max(x0 - x, x - x1, y0 - y, y - y1)


def _check_leader(label, leader, point, lines):
    box = label.box()
    centre = np.array([0.5 * (box[0] + box[2]), 0.5 * (box[1] + box[3])])
    np.testing.assert_allclose(leader[0], point, atol=1e-12)
    d = centre - point  # straight toward the label's centre
    cross = d[0] * (leader[1] - point)[1] - d[1] * (leader[1] - point)[0]
    assert abs(cross) <= 1e-9 * float(d @ d)
    assert _short_of(leader, label) == pytest.approx(GAP, abs=1e-9)
    assert not shapely.LineString(leader).intersects(_box(label))
    assert np.linalg.norm(d) <= max(LEADER_REACH) + 1e-9
    grown = _box(label).buffer(GAP * (1 - 1e-9), join_style="mitre")  # the label clear of every line
    assert not any(grown.intersects(shapely.LineString(line)) for line in lines)


def test_a_label_with_no_room_near_its_point_is_led_to_the_nearest_free_place():
    point = np.array([100.0, 101.0])
    lines = _hatch((100.0, 100.0), 20.0, 2.0)  # 2 mm apart: no 2.5 mm label fits within 20 mm
    placer = PaperPlacer((0.0, 0.0, 300.0, 200.0), lines)
    near = point + np.array([[dx, dy] for dx in np.linspace(-13, 13, 9) for dy in np.linspace(-13, 13, 9)])
    assert placer.place("G7", near, 0) is None
    leaders = Leaders(placer)
    label, leader = leaders.place("G7", [point], 0, own=lines[10])
    assert label.text == "G7" and label.h == H_LABEL
    _check_leader(label, leader, point, lines)
    # the nearest reach that leaves the hatching: the box beyond the 20 mm square, within 25 mm
    assert np.linalg.norm(np.array(label.box()).reshape(2, 2).mean(axis=0) - point) <= 25.0 + 1e-9
    assert len(placer.boxes) == 1 and len(placer.leaders) == 1


def test_a_dot_is_kept_off_other_lines_and_other_dots_and_slides_along_its_own_line():
    lines = _hatch((100.0, 100.0), 20.0, 2.0)
    own = lines[10]  # x = 100
    placer = PaperPlacer((0.0, 0.0, 300.0, 200.0), lines + [np.array([[90.0, 110.0], [110.0, 110.0]])])
    leaders = Leaders(placer)
    # the named point lies where a cross line meets its line: the dot slides along its line
    anchors = slid_along(own, np.array([100.0, 110.0]))
    np.testing.assert_allclose(anchors[0], [100.0, 110.0])
    _, leader = leaders.place("G1", anchors, 0, own=own)
    assert leader[0][0] == pytest.approx(100.0) and abs(leader[0][1] - 110.0) >= 1.0 - 1e-9
    assert shapely.LineString(own).distance(shapely.Point(leader[0])) < 1e-9
    # a second label named at the first's dot gets its own dot DOT_APART away on the line
    _, leader2 = leaders.place("G2", slid_along(own, leader[0]), 0, own=own)
    assert np.linalg.norm(leader2[0] - leader[0]) >= DOT_APART - 1e-9
    assert shapely.LineString(leader2).distance(shapely.Point(leader[0])) >= DOT_CLEAR - 1e-9
    assert shapely.LineString(leader).distance(shapely.Point(leader2[0])) >= DOT_CLEAR - 1e-9


def test_leaders_cross_no_label_leader_or_barrier_and_later_labels_avoid_them():
    point = np.array([150.0, 100.0])
    lines = _hatch(point, 20.0, 2.0)
    barrier = np.array([[176.0, 60.0], [176.0, 140.0]])  # a dimension line on the right, drawn
    placer = PaperPlacer((0.0, 0.0, 300.0, 200.0), lines + [barrier])
    # a wall of labels just outside the hatching above and below
    for x in np.arange(127.0, 174.0, 6.0):
        for y in (126.0, 74.0):
            assert placer.place("X", np.array([[x, y]]), 0) is not None
    walls = [shapely.box(*b) for b in placer.boxes]
    leaders = Leaders(placer, barriers=[barrier])
    placed = []
    for k, text in enumerate(("G1", "G2", "G3")):
        dot = point + np.array([0.0, 6.0 * k - 6.0])
        label, leader = leaders.place(text, [dot], 0, own=lines[10])
        _check_leader(label, leader, dot, lines)
        path = shapely.LineString(leader)
        assert not any(path.intersects(w) for w in walls)
        assert not path.intersects(shapely.LineString(barrier))
        for other, other_leader in placed:
            assert not path.intersects(_box(other)) and not path.intersects(shapely.LineString(other_leader))
            # the end nearer its own label than any other
            assert shapely.Point(leader[1]).distance(_box(other)) >= END_CLEAR - 1e-9
            assert shapely.Point(other_leader[1]).distance(_box(label)) >= END_CLEAR - 1e-9
        placed.append((label, leader))
    assert all(lb.box()[2] < 176.0 for lb, _ in placed)  # none beyond the dimension line
    # a label asked for across a leader, or at its end, is not placed there
    _, first = placed[0]
    assert placer.place("Y", (0.5 * (first[0] + first[1]))[None, :], 0) is None
    assert placer.place("Y", (first[1] + (first[1] - first[0]) / np.linalg.norm(first[1] - first[0]) * 2.0)[None, :],
                        0) is None


def test_a_leader_keeps_clear_of_points_still_to_be_led():
    lines = _hatch((100.0, 100.0), 20.0, 2.0)
    placer = PaperPlacer((0.0, 0.0, 300.0, 200.0), lines)
    leaders = Leaders(placer)
    first, second = np.array([100.0, 100.0]), np.array([110.0, 100.0])
    # unreserved, the first label's nearest leader (to the right, 0 degrees) would pass the second point
    free = Leaders(PaperPlacer((0.0, 0.0, 300.0, 200.0), lines))
    _, open_leader = free.place("G1", [first], 0, own=lines[10])
    leaders.reserved = np.array([first, second])
    _, leader = leaders.place("G1", [first], 0, own=lines[10])
    assert shapely.LineString(leader).distance(shapely.Point(second)) >= DOT_CLEAR - 1e-9
    assert shapely.LineString(open_leader).distance(shapely.Point(second)) < DOT_CLEAR


@pytest.mark.parametrize("hatch", [45.0, 135.0])
def test_a_leader_does_not_run_along_an_areas_hatching(hatch):
    # no lines near the point: the free first choice would be along the hatching's direction
    area = np.array([[60.0, 60.0], [140.0, 60.0], [140.0, 140.0], [60.0, 140.0]])
    placer = PaperPlacer((0.0, 0.0, 300.0, 200.0), [])
    point = np.array([100.0, 100.0])
    blocked = [np.array([100.0, 100.0]) + r * np.array([np.cos(a), np.sin(a)]) for r in LEADER_REACH
               for a in np.radians(np.arange(0.0, 360.0, 22.5)) if abs((np.degrees(a) - hatch + 90) % 180 - 90) > 1.0]
    for c in blocked:  # every other direction taken by labels
        placer.place("X", c[None, :], 0)
    leaders = Leaders(placer, hatched=[(hatch, area)])
    led = leaders.place("G1", [point], 0)
    assert led is None or abs((np.degrees(np.arctan2(*(led[1][1] - led[1][0])[::-1])) - hatch + 90) % 180 - 90) \
        >= HATCH_CLEAR


def test_no_room_anywhere_leaves_the_placer_unchanged():
    placer = PaperPlacer((0.0, 0.0, 40.0, 40.0), _hatch((20.0, 20.0), 20.0, 2.0))
    assert Leaders(placer).place("G1", [np.array([20.0, 20.0])], 0) is None
    assert len(placer.boxes) == 0 and placer.leaders == []


def _crowded_plate(groups: int = 12, names: bool = True) -> Layout:
    """A 6 m x 2 m plate whose groups of four heating lines, 60 mm apart (2.4 mm at 1:20),
    fill its middle; each group's name beside its second line as the DXF has it (plate mm),
    naming the point of that line beside it."""
    cut = np.array([[0.0, 0.0], [6000.0, 0.0], [6000.0, 2000.0], [0.0, 2000.0]])
    layout = Layout(cut, None, text_height=40.0)
    for g in range(groups):
        x0 = 1500.0 + 250.0 * g
        for k in range(4):
            layout.lines.append(("heat", np.array([[x0 + 60.0 * k, 300.0], [x0 + 60.0 * k, 1700.0]])))
        y = 1000.0 + 40.0 * (g % 3)
        layout.texts.append(Text("heat", f"G{g + 1}", (x0 + 96.0, y), 40.0, 90.0,
                                 (x0 + 60.0, y) if names else None))
    return layout


def test_crowded_heating_groups_are_named_with_leaders_from_their_own_lines(tmp_path):
    layout = _crowded_plate()
    names = [t.text for t in layout.texts]
    pages, info = plan_pages(layout, "crowded", ["PART P1"], [], None, [], None)
    assert info["not_placed"] == []
    page = pages[0]
    heat = [line for style, lines in page.lines.items() if style.startswith("other:") for line in lines]
    assert len(heat) == 48
    labels = {lb.text: lb for lb in page.labels if lb.text in names}
    assert sorted(labels) == sorted(names)
    leaders = page.lines["leader"]
    dots = [(x, y) for x, y, r in page.circles if r < 0.5]
    assert len(leaders) == len(dots) >= len(names) - 1  # the last group's name has room past its lines
    for name, lb in labels.items():
        led = [p for p in leaders if _short_of(p, lb) == pytest.approx(GAP, abs=1e-9)]
        if not led:  # written beside its own line, nearer it than any other
            box = _box(lb)
            own = shapely.LineString(heat[4 * (int(name[1:]) - 1) + 1])
            assert box.distance(own) < min(box.distance(shapely.LineString(h)) for h in heat if h is not own.coords)
            continue
        [leader] = led
        # its dot on its own group's second line (the one its DXF text names), or slid along it
        own = heat[4 * (int(name[1:]) - 1) + 1]
        assert shapely.LineString(own).distance(shapely.Point(leader[0])) < 1e-9
        path = shapely.LineString(leader)
        assert not any(path.intersects(_box(other)) for other in page.labels)
        for other in leaders:
            if other is not leader:
                assert not path.intersects(shapely.LineString(other))
                assert path.distance(shapely.Point(other[0])) >= DOT_CLEAR - 1e-9
                assert np.linalg.norm(other[0] - leader[0]) >= DOT_APART - 1e-9
    # and the PDF reads as a plater reads it: every name there, no overlap, no text on a line
    pdf = tmp_path / "crowded.pdf"
    write_shop_drawing(pdf, layout, "crowded", ["PART P1"], [], None)
    words = set().union(*check_readable(pdf))
    assert set(names) <= words and "NAMED" not in words


@pytest.mark.parametrize("bends", [0, 3])
def test_a_name_with_no_room_even_for_a_leader_is_said_on_the_sheet(tmp_path, bends):
    """Sixty short lines 20 mm apart (2 mm at 1:10), each its own group: more names than
    room. The names left are listed in the title block where its room allows (with bending
    lines, the room kept for the table's note is free when the table sits beside the plate),
    else in the drawing area."""
    layout = _short_lines(60, 20.0)
    marks = []
    for k in range(bends):
        x = 300.0 + 150.0 * k
        layout.lines.append(("bend", np.array([[x, 100.0], [x, 900.0]])))
        marks.append((k + 1, f"B{k + 1} R1000 CVX", np.array([x, 100.0]), np.array([x, 900.0]), x))
    pages, info = plan_pages(layout, "dense", ["PART P1"], marks, 150.0 if bends else None, [], None)
    unnamed = [f.split("'")[1] for f in info["not_placed"]]
    assert 0 < len(unnamed) < 60
    drawn = {lb.text for lb in pages[0].labels}
    assert not set(unnamed) & drawn
    assert set(unnamed) | (drawn & {f"G{g + 1}" for g in range(60)}) == {f"G{g + 1}" for g in range(60)}
    labels = pages[0].labels
    [k] = [i for i, lb in enumerate(labels) if lb.text.startswith(UNNAMED_NOTE)]
    note = [labels[k]] + list(itertools.takewhile(lambda lb: lb.text.startswith("  "), labels[k + 1:]))
    assert " ".join(lb.text for lb in note)[len(UNNAMED_NOTE):].replace(",", " ").split() == unnamed
    # the title block's top rule: the full-width rule in the lower half of the sheet
    top = max(r[0][1] for r in pages[0].lines["rule"]
              if abs(r[0][1] - r[-1][1]) < 1e-9 and r[0][1] < 0.5 * pages[0].height and len(r) == 2)
    assert (note[0].y < top) == (bends > 0)
    pdf = tmp_path / "dense.pdf"
    write_shop_drawing(pdf, layout, "dense", ["PART P1"], marks, 150.0 if bends else None)
    check_readable(pdf)


def test_bending_numbers_hemmed_in_are_led_from_their_own_lines_ends():
    # five bending lines whose both ends meet bands of other marks (1.5 mm off at 1:20): no
    # row beyond either end has room for a B-number
    layout = Layout(np.array([[0.0, 0.0], [6000.0, 0.0], [6000.0, 2000.0], [0.0, 2000.0]]), None, text_height=40.0)
    bends = []
    for k in range(5):
        x = 2000.0 + 500.0 * k
        layout.lines.append(("bend", np.array([[x, 700.0], [x, 1300.0]])))
        bends.append((k + 1, f"B{k + 1} R1000 CVX", np.array([x, 700.0]), np.array([x, 1300.0]), x))
    for y in list(np.arange(150.0, 690.0, 40.0)) + list(np.arange(1330.0, 1860.0, 40.0)):
        layout.lines.append(("heat", np.array([[1500.0, y], [4600.0, y]])))
    pages, info = plan_pages(layout, "hemmed", ["PART P1"], bends, 500.0, [], None)
    assert info["not_placed"] == []
    page = pages[0]
    drawn = page.lines["bend"]
    for k in range(5):
        [label] = [lb for lb in page.labels if lb.text == f"B{k + 1}"]
        [leader] = [p for p in page.lines["leader"] if _short_of(p, label) == pytest.approx(GAP, abs=1e-9)]
        own = drawn[k]
        assert min(np.linalg.norm(leader[0] - own[0]), np.linalg.norm(leader[0] - own[-1])) < 1e-9
        path = shapely.LineString(leader)
        assert not any(path.intersects(_box(other)) for other in page.labels)


def test_a_dot_keeps_off_a_hatched_areas_edge_and_off_a_line_alongside_its_own_if_it_can():
    lines = _hatch((100.0, 100.0), 20.0, 4.0)
    own = lines[5]  # x = 100, from y = 80 to 120
    ring = np.array([[90.0, 100.0], [110.0, 100.0], [110.0, 130.0], [90.0, 130.0]])  # its edge crosses own at y = 100
    leaders = Leaders(PaperPlacer((0.0, 0.0, 300.0, 200.0), lines, [ring]), edges=[ring], lines=lines)
    _, leader = leaders.place("G1", slid_along(own, np.array([100.0, 100.0])), 0, own=own)
    assert shapely.LineString(np.vstack([ring, ring[:1]])).distance(shapely.Point(leader[0])) >= DOT_OFF_EDGES - 1e-9
    assert shapely.LineString(own).distance(shapely.Point(leader[0])) < 1e-9
    # a drawn line alongside its own (a bending line on the plate's edge): a dot there only
    # where no dot clear of it leaves room
    own = np.array([[200.0, 40.0], [200.0, 160.0]])
    edge = np.array([[200.3, 40.0], [200.3, 110.0]])
    placer = PaperPlacer((0.0, 0.0, 300.0, 200.0), [own, edge])
    _, leader = Leaders(placer, lines=[own, edge]).place("B1", [np.array([200.0, 90.0]), np.array([200.0, 140.0])],
                                                         0, own=own)
    np.testing.assert_allclose(leader[0], [200.0, 140.0])
    placer = PaperPlacer((0.0, 0.0, 300.0, 200.0), [own, edge])
    _, leader = Leaders(placer, lines=[own, edge]).place("B1", [np.array([200.0, 90.0])], 0, own=own)
    np.testing.assert_allclose(leader[0], [200.0, 90.0])


def _short_lines(groups: int, pitch: float) -> Layout:
    """A 3 m x 1 m plate with ``groups`` short heating lines ``pitch`` mm apart (at 1:10,
    pitch / 10 on the paper), each its own group named beside it."""
    layout = Layout(np.array([[0.0, 0.0], [3000.0, 0.0], [3000.0, 1000.0], [0.0, 1000.0]]), None, text_height=20.0)
    for g in range(groups):
        x = 900.0 + pitch * g
        layout.lines.append(("heat", np.array([[x, 450.0], [x, 550.0]])))
        layout.texts.append(Text("heat", f"G{g + 1}", (x + 5.0, 500.0), 10.0, 90.0, (x, 500.0)))
    return layout


def test_led_labels_keep_a_word_gap_on_their_line_of_text():
    # twenty names led into rows above and below their lines (1.4 mm apart without the rule)
    pages, info = plan_pages(_short_lines(20, 40.0), "rows", ["PART P1"], [], None, [], None)
    assert info["not_placed"] == []
    page = pages[0]
    led = [lb for lb in page.labels if any(_short_of(p, lb) == pytest.approx(GAP, abs=1e-9) for p in page.lines["leader"])]
    assert len(led) >= 10
    for lb in led:
        x0, y0, x1, y1 = lb.box()
        for other in page.labels:
            ox0, oy0, ox1, oy1 = other.box()
            if other is not lb and oy0 < y1 and oy1 > y0:  # on the same line of text
                assert max(ox0 - x1, x0 - ox1) >= WORD_GAP - 1e-9, (lb.text, other.text)


def test_a_bending_lines_own_parts_are_found_when_its_middle_lies_off_the_plate():
    # a line across a U-shaped plate's notch: clipped into two parts, its middle in the notch,
    # where another line passes nearer than either part
    a, b = np.array([0.0, 50.0]), np.array([100.0, 50.0])
    parts = [np.array([[0.0, 50.0], [30.0, 50.0]]), np.array([[70.0, 50.0], [100.0, 50.0]])]
    other = np.array([[50.0, 48.0], [50.0, 90.0]])
    own, others = _own_parts([other] + parts, a, b)
    assert len(own) == 2 and all(any(p is q for q in parts) for p in own)
    assert len(others) == 1 and others[0] is other
    # beyond b's end (nearest its own second part) a place is offered; beside the other line not
    centres = np.array([[105.0, 50.0], [52.0, 70.0]])
    np.testing.assert_allclose(_nearer(centres, np.array([4.0, 3.0]), own, others, NEARER_BY), centres[:1])
    # a segment off the parts finds none of them
    none, every = _own_parts([other] + parts, a + np.array([0.0, 1.0]), b + np.array([0.0, 1.0]))
    assert none == [] and len(every) == 3


def test_a_leader_along_a_finely_sampled_line_is_caught_whole():
    # a heating line drawn as 1 mm pieces: a leader lying on it for 8 mm, and one crossing it
    dense = np.column_stack([np.linspace(0.0, 40.0, 41), np.full(41, 50.0)])
    leaders = Leaders(PaperPlacer((0.0, 0.0, 100.0, 100.0), [dense]), lines=[dense])
    assert leaders._runs_along(shapely.LineString([(10.0, 50.05), (18.0, 50.2)]))
    assert not leaders._runs_along(shapely.LineString([(10.0, 45.0), (13.0, 55.0)]))
