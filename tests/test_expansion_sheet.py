"""The shell expansion's sheet: the parts, sheet and scale chosen for closed-form lengths,
their boxes on the paper (a property over random hulls), and a long cylinder's drawing
measured back out of its PDF (every plate's path at its length over the scale, in the part
it is drawn in) and out of its DXF's paper space (a viewport per part at the scale, the
match line at the frame, linetypes scaled for the plot)."""

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.cli import main
from pipeline.hull.expansion_sheet import (
    BETWEEN,
    CAPTION,
    FOOT,
    HEAD,
    MARGIN,
    SHEETS,
    _clear_level_places,
    _overlaps,
    _text_box,
    part_captions,
    plan_sheet,
    scale_bar_length,
)
from pipeline.hull.levels import Level
from tests.hull_shapes import cylinder_along_iges

PT = 72.0 / 25.4  # PDF points per paper mm


def test_the_160m_hull_is_drawn_in_two_parts_at_1_100_cut_at_its_midship_frame():
    """160 m by 30 m of girth, frames every 2.5 m: in one strip A0 and A1 draw it at 1:200
    at most (160 m / 1:200 = 800 mm); cut at frame 32 (x = 80 m) each half is 800 mm long at
    1:100, and both halves, 300 mm of girth each, fit A0's height."""
    frames = [(k, 2500.0 * k) for k in range(65)]
    plan = plan_sheet((0.0, 160000.0), 30000.0, 1.0, frames)
    assert (plan.sheet, plan.scale) == ("A0", 100)
    assert plan.cuts == ((32, 80000.0),)
    assert plan.parts == ((0.0, 80000.0), (80000.0, 160000.0))
    for left, bottom, width, height in plan.boxes:
        assert (left, width, height) == pytest.approx((MARGIN, 800.0, 300.0))
    # the second part under the first, its caption between them
    assert plan.boxes[0][1] - (plan.boxes[1][1] + 300.0) == pytest.approx(BETWEEN + CAPTION)


def test_a_drawing_that_fits_at_1_100_is_not_cut():
    """60 m by 3 m of girth fits one A1 strip at 1:100 (600 mm): not cut, though two parts
    of 30 m would fit A0 at 1:50; a 10 m strake takes A0 at 1:10 (1000 mm) over A1 at 1:20."""
    plan = plan_sheet((0.0, 60000.0), 3000.0, 1.0, [(k, 2500.0 * k) for k in range(25)])
    assert (plan.sheet, plan.scale, len(plan.parts), plan.cuts) == ("A1", 100, 1, ())
    plan = plan_sheet((5000.0, 15000.0), 4712.4, 1.0, [(k, 2500.0 * k) for k in range(2, 7)])
    assert (plan.sheet, plan.scale, len(plan.parts), plan.cuts) == ("A0", 10, 1, ())


def test_fore_and_aft_bodies_are_named_from_the_bow():
    frames = [(k, 2500.0 * k) for k in range(65)]
    plan = plan_sheet((0.0, 160000.0), 30000.0, 1.0, frames)
    high = part_captions(plan, 1.0, "high")
    low = part_captions(plan, 1.0, "low")
    assert high[0].startswith("AFTBODY PART 1 OF 2") and high[1].startswith("FOREBODY PART 2 OF 2")
    assert low[0].startswith("FOREBODY") and low[1].startswith("AFTBODY")
    assert "PART 1 OF 2: FROM THE AFT END TO THE MATCH LINE AT FR 32, X 0.00 TO 80.00 M" in high[0]
    assert "PART 2 OF 2: FROM THE MATCH LINE AT FR 32 TO THE FORE END, X 80.00 TO 160.00 M" in high[1]
    assert "FROM THE FORE END" in low[0] and "FROM THE END TO" in part_captions(plan, 1.0, None)[0]
    assert not part_captions(plan, 1.0, None)[0].startswith(("AFT", "FORE"))


@settings(max_examples=200, deadline=None, derandomize=True)
@given(length=st.floats(1000.0, 400000.0), girth=st.floats(100.0, 80000.0), spacing=st.floats(300.0, 5000.0),
       start=st.floats(-3000.0, 3000.0))
def test_the_parts_cover_the_hull_once_and_their_boxes_fit_the_sheet_apart(length, girth, spacing, start):
    x_range = (start, start + length)
    frames = [(k, k * spacing) for k in range(int(np.floor(start / spacing)) - 1, int(np.ceil((start + length)
                                                                                             / spacing)) + 2)]
    plan = plan_sheet(x_range, girth, 1.0, frames)
    w, h = SHEETS[plan.sheet]
    assert plan.size == (w, h)
    # the parts run end to end over the whole length, cut where a frame is
    assert plan.parts[0][0] == x_range[0] and plan.parts[-1][1] == x_range[1]
    assert all(a[1] == b[0] for a, b in zip(plan.parts[:-1], plan.parts[1:]))
    assert all(a < b for a, b in plan.parts)
    frame_xs = {x for _, x in frames}
    assert all(x in frame_xs and (n, x) in frames for n, x in plan.cuts)
    for (a, b), (left, bottom, width, height) in zip(plan.parts, plan.boxes):
        # true to the scale
        assert width == pytest.approx((b - a) / plan.scale, rel=1e-12)
        assert height == pytest.approx(girth / plan.scale, rel=1e-12)
        # inside the margins, clear of the title at the top and of the foot
        assert left >= MARGIN and left + width <= w - MARGIN + 1e-9
        assert bottom >= MARGIN + FOOT - 1e-9 and bottom + height + CAPTION <= h - MARGIN - HEAD + 1e-9
    for upper, lower in zip(plan.boxes[:-1], plan.boxes[1:]):
        assert lower[1] + lower[3] + CAPTION <= upper[1] + 1e-9
    # no larger standard scale fits the same parts
    assert plan.scale >= max(b - a for a, b in plan.parts) / (w - 2 * MARGIN) - 1e-9


@pytest.mark.parametrize("scale, length", [(100, 10.0), (200, 20.0), (250, 20.0), (20, 2.0), (500, 50.0)])
def test_the_scale_bar_is_the_longest_round_length_within_120_mm(scale, length):
    assert scale_bar_length(scale) == length


def test_a_level_name_moves_along_its_line_off_the_names_already_there():
    """A level along y = 1000 over x 0..80 m at 1:100 (paper = model / 100): frame numbers every
    2.5 m just over the line and a plate name at the quarter: each of its two names lands on
    the line at the quarter or three quarters moved by at most an eighth, clear of all of them."""
    def to_paper(point):
        return np.asarray(point, dtype=float) / 100.0

    line = np.column_stack([np.linspace(0.0, 80000.0, 81), np.full(81, 1000.0)])
    level = Level("WL 1000", "waterline", (line,), 0)
    taken = [_text_box(to_paper((x, 1000.0)) + (0.0, 0.8), 5, 4.0, 1, 0.0, 0.0) for x in np.arange(0, 80001, 2500)]
    taken.append(_text_box(to_paper((20000.0, 1000.0)), 14, 8.0, 2, 0.0, 0.5))
    others = list(taken)
    places = _clear_level_places(level, (0.0, 80000.0), taken, to_paper, 5.0)
    assert len(places) == 2 and len(taken) == len(others) + 2
    for (point, angle), target in zip(places, (20000.0, 60000.0)):
        assert point[1] == pytest.approx(1000.0) and angle == pytest.approx(0.0)
        assert abs(point[0] - target) <= 0.125 * 80000.0 + 1e-6
        assert not _overlaps(_text_box(to_paper(point), 7, 5.0, 1, 0.0, 0.0), others)


@pytest.fixture(scope="module")
def long_cylinder(tmp_path_factory):
    """A 200 m bilge (R 3 m, 90 degrees) in two strakes, butts at x = 0, 120 and 200 m, frames
    every 2.5 m, the bow at the high x: one strip would be 1:250 on A1 (200 m / 801 mm), two
    parts cut at frame 40 (x = 100 m) are 1:100 on A0."""
    tmp = tmp_path_factory.mktemp("longcyl")
    iges = cylinder_along_iges(tmp / "c.igs", radius=3000.0, angle_deg=90.0, length=200000.0)
    config = tmp / "lc.yaml"
    config.write_text(yaml.safe_dump({
        "name": "lc", "units": "mm", "resolution": {"chord_tolerance": 5.0}, "output": {"png": True, "obj": False},
        "strake": {"surface": {"iges": str(iges)}, "seams": [{"iso": {"v": v}} for v in (0.0, 0.5, 1.0)],
                   "butts": [0.0, 120000.0, 200000.0], "frames": {"spacing": 2500.0}, "bow": "high",
                   "margin": 0.1, "fit_tolerance": 5.0}}))
    out = tmp / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    return out


def test_the_long_cylinder_pdf_draws_each_plate_to_scale_in_both_parts(long_cylinder):
    import pdfplumber

    girth = 3000.0 * np.pi / 2  # mm
    with pdfplumber.open(long_cylinder / "lc_expansion.pdf") as pdf:
        assert len(pdf.pages) == 1
        page = pdf.pages[0]
        assert sorted((page.width / PT, page.height / PT)) == pytest.approx([841.0, 1189.0], abs=0.5)
        text = "".join(c["text"] for c in page.chars)
        words = [w["text"] for w in page.extract_words(use_text_flow=True)]
        green = [c for c in page.curves if c.get("fill") and isinstance(c["non_stroking_color"], tuple)
                 and len(c["non_stroking_color"]) == 3 and c["non_stroking_color"][1] > 0.6]
    assert "1:100" in text and "scale 1:100 on A0" in text
    assert "AFTBODY PART 1 OF 2" in text and "FOREBODY PART 2 OF 2" in text and "MATCH LINE FR 40" in text
    # each plate named once, in the part that holds most of it
    for name in (f"lc_S{i}_B{j}" for i in (1, 2) for j in (1, 2)):
        assert words.count(name) == 1, name
    # 4 plates drawn in each of the 2 parts (clipped to it): each path as long as its plate
    # at 1:100, starting where its x puts it in that part's box
    assert len(green) == 8
    tops = sorted({round(c["top"], 1) for c in green})
    parts = [[c for c in green if c["top"] < np.mean(tops)], [c for c in green if c["top"] > np.mean(tops)]]
    for k, (a, drawn) in enumerate(zip((0.0, 100000.0), parts)):
        assert len(drawn) == 4, k
        spans = np.array(sorted((c["x0"] / PT - MARGIN + a / 100.0, (c["x1"] - c["x0"]) / PT) for c in drawn))
        # the plate's x on paper (part's left + (x - a) / 100) and its length / 100, to 0.01 mm
        assert np.abs(spans - [(0.0, 1200.0), (0.0, 1200.0), (1200.0, 800.0), (1200.0, 800.0)]).max() < 0.01
        high = max(c["bottom"] for c in drawn) - min(c["top"] for c in drawn)
        assert high / PT == pytest.approx(girth / 100.0, abs=0.05)


def test_the_long_cylinder_dxf_lays_out_the_same_sheet_in_paper_space(long_cylinder):
    import ezdxf

    doc = ezdxf.readfile(long_cylinder / "lc_expansion.dxf")
    assert doc.header["$LTSCALE"] == 100.0 and doc.header["$PSLTSCALE"] == 0
    assert doc.layers.get("EXP_WATERLINES").dxf.linetype == "DASHDOT"
    assert doc.layers.get("EXP_FRAMES").dxf.linetype == "DASHED"
    assert doc.layers.get("EXP_MATCH").dxf.linetype == "CENTER"
    (match,) = doc.modelspace().query('LINE[layer=="EXP_MATCH"]')
    assert match.dxf.start.x == match.dxf.end.x == pytest.approx(100000.0)
    paper = doc.layouts.get("SHELL EXPANSION")
    assert paper.get_paper_limits()[1].x == pytest.approx(1189.0) or paper.dxf_layout.dxf.paper_width == 1189.0
    ports = sorted((v for v in paper.query("VIEWPORT") if v.dxf.id != 1), key=lambda v: -v.dxf.center.y)
    assert len(ports) == 2
    for port, (a, b) in zip(ports, ((0.0, 100000.0), (100000.0, 200000.0))):
        assert port.dxf.view_height / port.dxf.height == pytest.approx(100.0)  # 1:100
        # the part, and 3 mm of paper beyond its ends (the match line and its frame number whole)
        view_w = port.dxf.view_height * port.dxf.width / port.dxf.height
        centre = port.dxf.view_center_point
        assert (centre.x - view_w / 2, centre.x + view_w / 2) == pytest.approx((a - 300.0, b + 300.0))
        # the girth from 0 up, and the frame numbers over it
        assert centre.y - port.dxf.view_height / 2 == pytest.approx(0.0, abs=1e-6)
        assert centre.y + port.dxf.view_height / 2 > 3000.0 * np.pi / 2 + 200.0
    texts = [t.dxf.text for t in paper.query("TEXT")]
    assert "1:100" in texts and "SCALE 1:100" in texts and "lc" in texts
    assert any(t.startswith("AFTBODY PART 1 OF 2") for t in texts)
    assert texts.count("MATCH LINE FR 40") == 2  # beside both viewports
    # the model space's title clear of what the viewports show
    title = next(t for t in doc.modelspace().query("TEXT") if t.dxf.text.startswith("lc: shell expansion"))
    assert title.dxf.insert.y > max(p.dxf.view_center_point.y + p.dxf.view_height / 2 for p in ports)


def test_a_bow_that_is_neither_end_exits_2_naming_the_field(tmp_path, capsys):
    iges = cylinder_along_iges(tmp_path / "c.igs")
    config = tmp_path / "bad.yaml"
    config.write_text(yaml.safe_dump({"name": "bad", "units": "mm", "strake": {
        "surface": {"iges": str(iges)}, "seams": [{"iso": {"v": 0.0}}, {"iso": {"v": 1.0}}],
        "butts": [5000.0, 15000.0], "bow": "sideways"}}))
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "bad.yaml" in err and "strake.bow" in err and "sideways" in err
    assert not out.exists() or not any(out.iterdir())


def test_the_side_shown_is_the_sign_of_y_whichever_parameter_runs_along_the_hull():
    """The title block's side: y of the plates' points (it read x where the surface's v ran
    along the hull, its long_axis 1 being a parameter's index, not a coordinate's)."""
    from types import SimpleNamespace

    from pipeline.hull.expansion import across, side_shown

    x, y = np.meshgrid(np.linspace(10.0, 50.0, 5), np.linspace(-8.0, -1.0, 4))
    points = np.stack([x, y, np.zeros_like(x)], axis=2)  # x > 0 along the hull, y < 0: the starboard side
    for axis in (0, 1):
        hull = [SimpleNamespace(name="p", part=SimpleNamespace(hull=SimpleNamespace(long_axis=axis)))]
        assert side_shown(across(hull, {"p": SimpleNamespace(points=points)})).startswith("Y < 0")


def test_a_slanted_plate_name_is_sized_to_its_width_at_its_height_not_its_x_extent():
    """A parallelogram 1000 wide at every height, leaning 2000 over its 1000 of girth: its x
    extent is 3000, the room for its name along the line through its centre 1000 (the name
    was sized to the 3000 and ran over its neighbours: DTMB 5415's raked transom plates); a
    part's end cuts it."""
    import shapely

    from pipeline.hull.expansion_sheet import _width_at

    outline = np.array([(0.0, 0.0), (1000.0, 0.0), (3000.0, 1000.0), (2000.0, 1000.0)])
    assert _width_at(outline, np.array([1500.0, 500.0]), -1e9, 1e9, shapely) == pytest.approx(1000.0)
    assert _width_at(outline, np.array([500.0, 100.0]), -1e9, 1e9, shapely) == pytest.approx(1000.0)
    assert _width_at(outline, np.array([1500.0, 500.0]), 1200.0, 1e9, shapely) == pytest.approx(800.0)
