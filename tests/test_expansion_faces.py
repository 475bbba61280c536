"""A shell of several faces in one expansion: girth continued from face to face, plates cut
at their face's trim, end faces and overlapping faces in bands of their own. Closed forms on
planes (a flat bottom, a side above it, a raked bow, a transom), and the real hulls: every
point of KCS's and KVLCC2's flat of bottom drawn at its distance from the centre plane, and
points of two faces that meet drawn where they meet."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from flatten.metrics import polygon_area
from flatten.surface import nurbs_surface
from pipeline.hull.cost import PlateEdges
from pipeline.hull.expansion import expand, shell_edges, write_expansion_dxf
from pipeline.hull.expansion_sheet import plan_sheet
from pipeline.hull.trims import Trim
from tests.shipped_configs import plain_uniform, with_files_from

ROOT = Path(__file__).resolve().parents[1]
BEAM, DEPTH, LENGTH = 3000.0, 5000.0, 20000.0


def plane(corners) -> object:
    """The bilinear surface through corners ((S(0,0), S(0,1)), (S(1,0), S(1,1))): u runs along x."""
    return nurbs_surface(1, 1, np.asarray(corners, dtype=float), [0, 0, 1, 1], [0, 0, 1, 1])


FLAT = plane([[(0, BEAM, 0), (0, 0, 0)], [(LENGTH, BEAM, 0), (LENGTH, 0, 0)]])  # girth parameter from the bilge in
SIDE = plane([[(0, BEAM, 0), (0, BEAM, DEPTH)], [(LENGTH, BEAM, 0), (LENGTH, BEAM, DEPTH)]])
BOW = plane([[(LENGTH, 0, 0), (LENGTH, 2000, 4000)], [(LENGTH + 6000, 0, 0), (LENGTH + 6000, 2000, 4000)]])
TRANSOM = plane([[(-300, 0, 0), (-300, 2000, 0)], [(0, 0, 3000), (0, 2000, 3000)]])  # u runs up its rake
TWIN = plane([[(0, 0, 0), (0, BEAM, 0)], [(LENGTH, 0, 0), (LENGTH, BEAM, 0)]])  # the flat again, another face


def plate(name: str, surface, u: tuple, v: tuple, trim=None, rows: int = 9, cols: int = 17):
    """A result and its edges for the region u x v of a face (long axis 0)."""
    uu, vv = np.meshgrid(np.linspace(*u, cols), np.linspace(*v, rows))
    points = surface(uu.ravel(), vv.ravel()).reshape(rows, cols, 3)
    hull = SimpleNamespace(surface=surface, long_axis=0, trim=trim)
    result = SimpleNamespace(name=name, ok=True, figures={"plate_class": {"class": "flat"}},
                             part=SimpleNamespace(hull=hull, steel=SimpleNamespace(thickness=12.0)))
    return result, PlateEdges(name, points, np.stack([uu, vv], axis=-1))


def drawn(pairs, frames=()):
    results = [r for r, _ in pairs]
    return expand(results, {e.name: e for _, e in pairs}, list(frames), gap=1000.0)


def by_name(drawing) -> dict:
    return {p.name: p for p in drawing.plates}


def test_a_side_above_a_flat_bottom_continues_its_girth_and_faces_apart_in_x_share_the_band():
    pairs = [plate("flat", FLAT, (0.1, 0.5), (0.2, 0.9)),  # y 2400 .. 300
             plate("side", SIDE, (0.1, 0.5), (0.2, 0.8)),  # z 1000 .. 4000
             plate("bow", BOW, (0.0, 1.0), (0.0, 1.0)),
             plate("transom", TRANSOM, (0.0, 1.0), (0.0, 1.0)),
             plate("twin", TWIN, (0.3, 0.9), (0.0, 1.0))]
    drawing = drawn(pairs, frames=[(4, 8000.0), (9, 23000.0)])
    plates = by_name(drawing)
    # the flat counts from the centre plane (its girth parameter runs the other way)
    assert plates["flat"].outline[:, 1].min() == pytest.approx(300.0, abs=1e-6)
    assert plates["flat"].outline[:, 1].max() == pytest.approx(2400.0, abs=1e-6)
    # the side starts where the flat ends, at the beam
    assert plates["side"].outline[:, 1].min() == pytest.approx(BEAM + 1000.0, abs=1e-6)
    assert plates["side"].outline[:, 1].max() == pytest.approx(BEAM + 4000.0, abs=1e-6)
    # the bow, beyond the flat's length, counts from the keel in the same band
    assert plates["bow"].band == plates["flat"].band == plates["side"].band == 0
    assert plates["bow"].outline[:, 1].max() == pytest.approx(np.hypot(2000.0, 4000.0), abs=1e-6)
    # the transom stands across the hull, the twin flat counts from the keel where the flat
    # does: each in a band of its own, above the first
    assert {plates["transom"].band, plates["twin"].band} == {1, 2}
    first = drawing.bands[0]
    assert first == pytest.approx((0.0, BEAM + DEPTH))
    assert drawing.bands[1][0] == pytest.approx(BEAM + DEPTH + 1000.0)
    twin = plates["twin"].outline[:, 1] - drawing.bands[plates["twin"].band][0]
    assert twin.min() == pytest.approx(0.0, abs=1e-6) and twin.max() == pytest.approx(BEAM, abs=1e-6)
    # a frame runs from the keel over both faces; one over the bow over the bow alone
    frames = {(x, band): (lo, hi) for x, lo, hi, band, _ in drawing.frames}
    assert frames[(8000.0, 0)] == pytest.approx((0.0, BEAM + DEPTH))
    assert frames[(23000.0, 0)] == pytest.approx((0.0, np.hypot(2000.0, 4000.0)))
    assert "continues its girth" in drawing.girth_from


@settings(max_examples=15, deadline=None, derandomize=True)
@given(beam=st.floats(500.0, 8000.0), depth=st.floats(500.0, 8000.0), gap=st.floats(0.0, 19.0),
       inward=st.booleans(), z0=st.floats(0.0, 0.4), z1=st.floats(0.6, 1.0))
def test_a_side_continues_a_flat_bottom_across_a_gap_whichever_way_the_flat_runs(beam, depth, gap, inward, z0, z1):
    """A side standing ``gap`` outboard of a flat bottom's edge (within the join, 0.2 % of the
    drawing's 10 m: 20 mm) continues its girth: a side point at height z is drawn at beam +
    gap + z, whichever way the flat's girth parameter runs (from the centre or to it)."""
    ends = [(0, beam, 0), (0, 0, 0)] if inward else [(0, 0, 0), (0, beam, 0)]
    flat = plane([ends, [(LENGTH, y, z) for _, y, z in ends]])
    side = plane([[(0, beam + gap, 0), (0, beam + gap, depth)], [(LENGTH, beam + gap, 0), (LENGTH, beam + gap, depth)]])
    drawing = drawn([plate("flat", flat, (0.1, 0.6), (0.0, 1.0)), plate("side", side, (0.1, 0.6), (z0, z1))])
    plates = by_name(drawing)
    assert plates["flat"].outline[:, 1].min() == pytest.approx(0.0, abs=1e-6)
    assert plates["flat"].outline[:, 1].max() == pytest.approx(beam, rel=1e-9)
    girth = plates["side"].outline[:, 1]
    assert girth.min() == pytest.approx(beam + gap + z0 * depth, rel=1e-9)
    assert girth.max() == pytest.approx(beam + gap + z1 * depth, rel=1e-9)
    assert len(drawing.bands) == 1


def test_a_face_that_would_draw_over_the_face_it_continues_counts_its_own_girth_in_a_band_of_its_own():
    """Two sides standing on the same flat's edge over the same length both continue it; the
    second would cover the first, so it goes to a new band from its own lower edge."""
    other_side = plane([[(0, BEAM, 0), (0, BEAM, DEPTH)], [(LENGTH, BEAM, 0), (LENGTH, BEAM, DEPTH)]])
    drawing = drawn([plate("flat", FLAT, (0.1, 0.5), (0.2, 0.9)), plate("side", SIDE, (0.1, 0.5), (0.2, 0.8)),
                     plate("again", other_side, (0.1, 0.5), (0.2, 0.8))])
    plates = by_name(drawing)
    assert plates["side"].band == 0 and plates["again"].band == 1
    assert plates["side"].outline[:, 1].min() == pytest.approx(BEAM + 1000.0, abs=1e-6)
    base = drawing.bands[1][0]
    assert plates["again"].outline[:, 1].min() - base == pytest.approx(1000.0, abs=1e-6)
    assert drawing.bands[1][1] == pytest.approx(DEPTH)


def test_faces_of_one_surface_kind_alone_keep_their_own_band_and_girth():
    """Without a face to continue, a side counts from its own lower edge, as before."""
    drawing = drawn([plate("side", SIDE, (0.1, 0.5), (0.2, 0.8))])
    side = by_name(drawing)["side"]
    assert side.outline[:, 1].min() == pytest.approx(1000.0, abs=1e-6)
    assert drawing.bands == ((0.0, DEPTH),)
    assert "continues" not in drawing.girth_from


def test_a_plate_past_its_face_trim_is_drawn_as_cut_with_its_trim_line(tmp_path):
    """The flat trimmed along the diagonal v = u of its parameters: a plate over u 0.1-0.5,
    v 0.2-0.9 keeps the part with v >= u, drawn (x = 20000 u, girth = 3000 v from the centre
    side) as that polygon mapped affinely; the side still starts at the beam."""
    loop = np.array([(0.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)])
    trim = Trim(1, loop, (), 144)
    pairs = [plate("flat", FLAT, (0.1, 0.5), (0.2, 0.9), trim=trim), plate("side", SIDE, (0.1, 0.5), (0.2, 0.8))]
    drawing = drawn(pairs)
    flat = by_name(drawing)["flat"]
    # the kept part in (u, v): the rectangle less the triangle below v = u
    from shapely.geometry import Polygon, box

    kept = box(0.1, 0.2, 0.5, 0.9).intersection(Polygon(loop)).area
    assert polygon_area(flat.outline) == pytest.approx(kept * LENGTH * BEAM, rel=1e-9)
    assert len(flat.trim_lines) == 1
    line = flat.trim_lines[0]
    u, girth_from_bilge = line[:, 0] / LENGTH, BEAM - line[:, 1]  # the flat's v runs from the bilge in
    assert np.allclose(girth_from_bilge / BEAM, u, atol=1e-12)  # on v = u
    assert sorted(np.round(u[[0, -1]], 12)) == [0.2, 0.5]  # from the region's side v = 0.2 to u = 0.5
    # its seams and butts clipped to the cut: nothing drawn beyond it
    for piece in flat.seams + flat.butts:
        assert np.all((BEAM - piece[:, 1]) / BEAM >= piece[:, 0] / LENGTH - 1e-9)
    assert by_name(drawing)["side"].outline[:, 1].min() == pytest.approx(BEAM + 1000.0, abs=1e-6)
    # the DXF draws the cut outline, and the trim line with the seams
    import ezdxf

    sheet = plan_sheet(drawing.x_range, drawing.height, 1.0, [])
    target = tmp_path / "cut_expansion.dxf"
    write_expansion_dxf(target, drawing, 1.0, "cut", sheet, {"drawing": "CUT", "hull": "cut", "plates": 2,
                                                              "side": "Y > 0", "bow": None, "notes": []})
    msp = ezdxf.readfile(target).modelspace()
    outlines = [np.array(e.get_points("xy")) for e in msp.query("LWPOLYLINE[layer=='EXP_FLAT']")]
    assert sorted(polygon_area(o) for o in outlines) == pytest.approx(
        sorted(polygon_area(p.outline) for p in drawing.plates), rel=1e-9)
    seams = [np.array(e.get_points("xy")) for e in msp.query("LWPOLYLINE[layer=='EXP_SEAMS']")]
    assert any(len(s) == 2 and (np.allclose(s, line[[0, -1]]) or np.allclose(s, line[[-1, 0]])) for s in seams)


def uniform_shell(name: str, tmp_path: Path):
    """The shipped shell config's uniform plan: its plates (unevaluated, as the drawing
    reads them) and their edges on the hull."""
    from pipeline.hull.plan import load_run

    source = ROOT / "configs" / f"{name}_shell.yaml"
    data = with_files_from(plain_uniform(yaml.safe_load(source.read_text())), source.parent)
    config_path = tmp_path / f"{name}.yaml"
    config_path.write_text(yaml.safe_dump(data))
    config = load_run(config_path)
    results = [SimpleNamespace(name=p.name, part=p, ok=True, figures={"plate_class": {"class": "flat"}})
               for p in config.parts if getattr(p, "hull", None) is not None]
    return results, shell_edges(results)


def ring_points(points: np.ndarray) -> np.ndarray:
    """A plate grid's boundary (R, C, 3) in the order the drawing's outline runs."""
    return np.vstack([points[0], points[1:, -1], points[-1, ::-1][1:], points[::-1, 0][1:-1]])


@pytest.mark.parametrize("name, girth_error_mm, meet_mm, cut", [("kcs", 5.0, 4.0, 20), ("kvlcc2", 12.0, 10.0, 3)])
def test_a_real_shell_of_several_faces_is_one_band_girth_from_the_keel(tmp_path, name, girth_error_mm, meet_mm, cut):
    """KCS (the main hull lofted from two faces, the flat of bottom trimmed, stern and bow
    faces) and KVLCC2 (the loft of main hull and flat, the faces beyond its end planes): one
    band; every plate point on the flat of bottom (z = 0) drawn at its distance |y| from the
    centre plane, whichever face it is on (the side shell's lowest seams continue the flat's
    girth); two plates' points of different faces within 20 mm of each other drawn as far
    apart in girth as they are in space, within ``meet_mm``; the plates past the flat's trim
    drawn cut, no two plates over each other by more than 0.02 m^2 (a sliver 1 mm wide
    along a 20 m joint of trim and side shell)."""
    from scipy.spatial import cKDTree
    from shapely.geometry import Polygon
    from shapely.strtree import STRtree

    results, edges = uniform_shell(name, tmp_path)
    drawing = expand(results, edges, [], gap=1000.0)
    assert len(drawing.bands) == 1
    face = {r.name: id(r.part.hull.surface) for r in results}
    assert len(set(face.values())) == 4
    assert sum(bool(p.trim_lines) for p in drawing.plates) == cut
    outlines = [Polygon(p.outline) for p in drawing.plates]
    assert all(o.is_valid for o in outlines)
    tree = STRtree(outlines)
    assert max((outlines[i].intersection(outlines[j]).area for i in range(len(outlines))
                for j in tree.query(outlines[i]) if j > i), default=0.0) <= 2e4
    points, girth, faces = [], [], []
    on_flat = 0
    for p in drawing.plates:
        if p.trim_lines:  # the cut ones' outlines are the trim's, not the grid's
            continue
        ring = ring_points(edges[p.name].points)
        flat = np.abs(ring[:, 2]) < 1.0
        assert np.abs(p.outline[flat, 1] - np.abs(ring[flat, 1])).max(initial=0.0) <= girth_error_mm, p.name
        on_flat += int(flat.any())
        points.append(ring), girth.append(p.outline[:, 1]), faces.append(np.full(len(ring), face[p.name]))
    assert on_flat >= 25
    points, girth, faces = np.vstack(points), np.concatenate(girth), np.concatenate(faces)
    pairs = cKDTree(points).query_pairs(20.0, output_type="ndarray")
    pairs = pairs[faces[pairs[:, 0]] != faces[pairs[:, 1]]]
    assert len(pairs) >= 100
    apart = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1)
    assert (np.abs(girth[pairs[:, 0]] - girth[pairs[:, 1]]) - apart).max() <= meet_mm


def test_a_plate_past_its_face_trim_is_as_wide_as_the_part_the_shop_cuts():
    """The flat trimmed to v >= 0.95 - 0.5 u: over u 0.1-0.5 a plate on v 0.2-0.9 keeps, at
    column u, the girth BEAM (0.9 - max(0.2, 0.95 - 0.5 u)), widest (0.45 BEAM) at u = 0.5;
    the plan's cost counts that, not the region's 0.7 BEAM."""
    from pipeline.hull.cost import TRIM_SAMPLES

    loop = np.array([(0.0, 0.95), (1.0, 0.45), (1.0, 1.0), (0.0, 1.0), (0.0, 0.95)])
    _, edges = plate("flat", FLAT, (0.1, 0.5), (0.2, 0.9), trim=Trim(1, loop, (), 144), rows=33, cols=9)
    u = edges.params[0, :, 0]
    expected = BEAM * (0.9 - np.maximum(0.2, 0.95 - 0.5 * u))
    # each column's step that the trim crosses is measured to 1 / TRIM_SAMPLES of it
    step = BEAM * 0.7 / 32
    assert np.abs(edges.widths(Trim(1, loop, (), 144)) - expected).max() <= step / TRIM_SAMPLES + 1e-9
    assert edges.widths() == pytest.approx(np.full(9, 0.7 * BEAM))


def test_kcs_flat_bottom_slivers_are_reported_as_cut():
    """KCS's uniform plan leaves plates of its trimmed flat of bottom that the trim cuts to
    slivers (the outermost strake's end plate: 89 mm of its 3.15 m): their widths inside the
    trim agree with the expansion's cut outlines (a vertical line through each grid column,
    independent of the widths' sampling: the outline is the trim's polygon cut in (u, v)),
    and the plate is narrower than the stock's 1 m."""
    import tempfile

    from shapely.geometry import LineString, Polygon

    with tempfile.TemporaryDirectory() as folder:
        results, edges = uniform_shell("kcs", Path(folder))
    drawing = expand(results, edges, [], gap=1000.0)
    trims = {r.name: r.part.hull.trim for r in results}
    cut = [p for p in drawing.plates if p.trim_lines]
    assert len(cut) == 20
    narrow = []
    for p in cut:
        outline = Polygon(p.outline)
        x0, y0, x1, y1 = outline.bounds
        columns = np.clip(edges[p.name].points[0, :, 0], x0 + 1e-6, x1 - 1e-6)
        drawn = max(outline.intersection(LineString([(x, y0 - 1.0), (x, y1 + 1.0)])).length for x in columns)
        width = edges[p.name].widths(trims[p.name]).max()
        assert width == pytest.approx(drawn, abs=2.0), p.name
        narrow += [p.name] if width < 1000.0 else []
    assert sorted(narrow) == ["kcs_P4_S01_B09", "kcs_P4_S02_B10", "kcs_P4_S03_B11", "kcs_P4_S04_B13", "kcs_P4_S04_B14"]


def test_where_a_face_does_not_meet_the_face_it_continues_the_sheet_says_so():
    """The flat trimmed to v >= 0.1 max(0, 2u - 1) (u along x, v from the bilge in): from
    x = 10 m aft its plate stops short of the beam by BEAM (0.2 u - 0.1), 300 mm at the end,
    while the side still stands on the beam and continues the flat's untrimmed girth there.
    The drawing leaves that girth open at every station, exactly; the sheet's note names the
    faces, the stretch where the opening is at least the least asked (150 mm: from x = 15 m)
    and the widest (300 mm). Without the trim nothing is open and nothing is said."""
    from pipeline.hull.expansion import gap_notes

    loop = np.array([(0.0, 0.0), (0.5, 0.0), (1.0, 0.1), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)])
    pairs = [plate("flat", FLAT, (0.0, 1.0), (0.0, 1.0), trim=Trim(1, loop, (), 144), cols=33),
             plate("side", SIDE, (0.0, 1.0), (0.0, 0.8))]
    drawing = drawn(pairs)
    ((face, other, stations, opened),) = drawing.joins
    assert (face, other) == ("side", "flat")
    expected = BEAM * np.maximum(0.0, 0.2 * stations / LENGTH - 0.1)
    assert np.allclose(opened, expected, atol=1e-6)
    (note,) = gap_notes(drawing, 150.0, 1.0)
    first = stations[expected >= 150.0 - 1e-9].min()
    assert note.startswith(f"SIDE DOES NOT MEET FLAT AT X = {first / 1000:.1f} TO 20.0 M: UP TO 300 MM OF GIRTH OPEN")
    assert gap_notes(drawing, 301.0, 1.0) == []
    whole = drawn([plate("flat", FLAT, (0.0, 1.0), (0.0, 1.0)), plate("side", SIDE, (0.0, 1.0), (0.0, 0.8))])
    assert np.nanmax(whole.joins[0][3]) == pytest.approx(0.0, abs=1e-6) and gap_notes(whole, 1.0, 1.0) == []


def test_kvlcc2_bow_hole_between_its_faces_is_measured_and_noted(tmp_path):
    """KVLCC2's main-hull face beyond its loft (P3) stands on its flat of bottom's untrimmed
    surface at the bow, while the flat's trim (P4) stops short of it: the drawing leaves that
    girth open, and its sheet (1:200) says so where it shows (0.5 mm on paper: 100 mm).
    Independently, from the faces' own sections (the flat cut at its trim; on the flat
    girth is |y|): at x = 300, 305 and 311 m the opening is the flat's untrimmed girth between
    its trim and the side's foot plus the foot's height, within 2 mm. KCS's faces meet
    everywhere to within 50 mm (its 1:100 sheet's 0.5 mm): no note."""
    from pipeline.hull.expansion import gap_notes
    from pipeline.hull.shell import face_section

    for name, scale, notes in (("kcs", 100, 0), ("kvlcc2", 200, 1)):
        results, edges = uniform_shell(name, tmp_path)
        drawing = expand(results, edges, [], gap=1000.0)
        found = gap_notes(drawing, 0.5 * scale, 1.0)
        assert len(found) == notes, found
    assert found[0].startswith("KVLCC2_P3 DOES NOT MEET KVLCC2_P4 AT X = 299.1 TO 311.9 M")
    ((_, _, stations, opened),) = [j for j in drawing.joins if j[:2] == ("kvlcc2_P3", "kvlcc2_P4")]
    hulls = {r.name.split("_")[1]: r.part.hull for r in results}
    flat, side = hulls["P4"], hulls["P3"]
    for x in (300e3, 305e3, 311e3):
        trimmed = face_section(flat.surface, x, flat.face_trim.face_region(flat.surface))
        edge = max(np.abs(s[:, 1]).max() for s in trimmed)
        foot = min((s[np.argmin(s[:, 2])] for s in face_section(side.surface, x)), key=lambda p: p[2])
        k = int(np.argmin(np.abs(stations - x)))
        assert abs(stations[k] - x) < 100.0
        assert opened[k] == pytest.approx(abs(foot[1]) - edge + foot[2], abs=2.0), x


def test_a_face_across_the_hull_is_drawn_in_true_shape_in_its_own_band():
    """The transom raked 300 mm aft over its 3 m height, 2 m across: in its own band it is
    drawn in its plane, from its aft x (-300) forward by its breadth (y 0 to 2000) and up by
    its length up the rake (hypot(300, 3000)), a plate over v 0.25-0.75, u 0.5-1 exactly at
    its place there; no frame, waterline or deck is drawn over it (they follow sections
    x = const, which run across it), and the sheet says how it is drawn."""
    from pipeline.hull.expansion import shape_notes

    pairs = [plate("flat", FLAT, (0.1, 0.5), (0.2, 0.9)), plate("transom", TRANSOM, (0.0, 1.0), (0.0, 1.0)),
             plate("upper", TRANSOM, (0.5, 1.0), (0.25, 0.75))]
    drawing = drawn(pairs, frames=[(0, 0.0), (4, 8000.0)])
    plates = by_name(drawing)
    band = plates["transom"].band
    assert band == plates["upper"].band != plates["flat"].band
    base = drawing.bands[band][0]
    rake = np.hypot(300.0, 3000.0)
    whole = plates["transom"].outline - [0.0, base]
    assert whole[:, 0].min() == pytest.approx(-300.0) and whole[:, 0].max() == pytest.approx(1700.0)
    assert whole[:, 1].min() == pytest.approx(0.0, abs=1e-9) and whole[:, 1].max() == pytest.approx(rake)
    assert polygon_area(whole) == pytest.approx(2000.0 * rake, rel=1e-9)
    upper = plates["upper"].outline - [0.0, base]
    assert upper[:, 0].min() == pytest.approx(-300.0 + 500.0) and upper[:, 0].max() == pytest.approx(-300.0 + 1500.0)
    assert upper[:, 1].min() == pytest.approx(0.5 * rake) and upper[:, 1].max() == pytest.approx(rake)
    assert drawing.bands[band][1] == pytest.approx(rake)
    assert all(b != band for _, _, _, b, _ in drawing.frames)
    (note,) = shape_notes(drawing, 1.0)
    assert note.startswith("TRANSOM STANDS ACROSS THE HULL: DRAWN IN TRUE SHAPE")
    assert "EDGE AT X = -0.3 M" in note and "(2.00 M) ALONG THE SHEET TOWARD HIGHER X" in note and "(3.01 M) UPWARD" in note
