"""Textile pieces: AAMA round trip, sew line, allowance, notches, grain, printout, real files."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
import shapely
from shapely.geometry import LinearRing, LineString, Point, Polygon

from pipeline.textile.aama import read_aama
from pipeline.cli import main
from pipeline.io.meshio import read_obj

from .astm_parser import astm, astm_or_none  # noqa: F401 (fixtures)

ROOT = Path(__file__).resolve().parents[1]
LAMPSHADE = ROOT / "configs" / "lampshade.yaml"
REALDATA = ROOT / "tests" / "data" / "textile"  # origin: tests/data/SOURCES.md


@pytest.fixture(scope="module")
def lampshade(tmp_path_factory):
    out = tmp_path_factory.mktemp("lamp")
    assert main(["run", str(LAMPSHADE), "--out", str(out), "--quiet"]) == 0
    reports = {p.stem: json.loads(p.read_text()) for p in out.glob("lampshade_*.json")}
    return out, read_aama(out / "lampshade.dxf"), reports


def test_multi_piece_file_has_one_block_per_piece_with_the_layers(lampshade):
    out, read, reports = lampshade
    assert read.units == "METRIC"
    assert [p.block for p in read.pieces] == ["lampshade_1_M", "lampshade_2_M", "lampshade_3_M"]
    for piece in read.pieces:
        assert piece.texts["piece name"] == piece.block[:-2]
        assert piece.texts["size"] == "M" and piece.texts["quantity"] == "2"
        assert piece.boundary is not None and piece.sew is not None
        assert len(piece.grain) == 1
        assert len(piece.internal) == reports[piece.name]["resolution"]["count"]  # rulings on layer 8
    assert [len(p.notches) for p in read.pieces] == [2, 4, 2]
    import ezdxf
    doc = ezdxf.readfile(out / "lampshade.dxf")
    assert doc.dxfversion == "AC1009"
    inserts = doc.modelspace().query("INSERT")
    assert len(inserts) == 3 and all(tuple(i.dxf.insert) == (0, 0, 0) for i in inserts)
    assert read.insert_layers == ("1", "1", "1") and {p.flags for p in read.pieces} == {64}
    assert read.header["style name"] == "lampshade" and re.fullmatch(r"\d{1,2}:\d\d", read.header["creation time"])
    # as the real AAMA files write it: the hour padded with a space ("Creation Time:  9:34")
    texts = [t.dxf.text for t in doc.modelspace().query("TEXT") if t.dxf.text.startswith("Creation Time:")]
    assert len(texts) == 1 and re.fullmatch(r"Creation Time: [ \d]\d:\d\d", texts[0])
    # the layers are declared in a LAYER table (FreeCAD's importer needs one)
    text = (out / "lampshade.dxf").read_text()
    table = re.search(r"\n  2\nLAYER\n(.*?)\n  0\nENDTAB", text, re.S).group(1)
    declared = set(re.findall(r"\n  0\nLAYER\n  2\n(\w+)\n", "\n" + table))
    used = set(re.findall(r"\n  8\n(\w+)\n", text))
    assert used <= declared and {"1", "2", "3", "4", "7", "8"} <= declared


def test_the_creation_time_pads_a_morning_hour_with_a_space_as_real_files_do(monkeypatch):
    """Whatever the hour the suite runs at (it read "0:06" back once past midnight)."""
    import datetime

    from pipeline.textile.aama import build_document

    morning = datetime.datetime(2026, 11, 24, 7, 5, tzinfo=datetime.timezone.utc)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", str(int(morning.timestamp())))
    texts = [t.dxf.text for t in build_document([], "style", 1.0).modelspace().query("TEXT")]
    assert "Creation Time:  7:05" in texts and "Creation Date: 24-11-2026" in texts


def test_aama_uses_the_entities_and_layers_of_the_real_files(lampshade):
    """Every (entity, layer) pair we write in a piece block occurs in the AccuMark or CLO
    files, and so do our texts' keys: the same structure, not a dialect of our own."""
    import ezdxf

    def structure(path):
        doc = ezdxf.readfile(path)
        pairs, keys = set(), set()
        for block in doc.blocks:
            if block.name.startswith("*"):
                continue
            for e in block:
                pairs.add((e.dxftype(), e.dxf.layer))
                if e.dxftype() == "TEXT" and e.dxf.layer == "1":
                    keys.add(e.dxf.text.partition(":")[0].strip().lower())
        return pairs, keys
    real_pairs, real_keys = set(), set()
    for path in REALDATA.iterdir():
        pairs, keys = structure(path)
        real_pairs |= pairs
        real_keys |= keys
    ours, our_keys = structure(lampshade[0] / "lampshade.dxf")
    assert ours <= real_pairs, ours - real_pairs
    assert our_keys == {"piece name", "size", "quantity", "fabric"} and our_keys <= real_keys


def test_turn_points_at_the_corners_and_curve_points_along_the_curves(lampshade):
    _, read, reports = lampshade
    for piece in read.pieces:
        edges = reports[piece.name]["textile"]["edges"]
        # the sew line's corners are the ends of the developed c and d edges (the report);
        # the cut line's are where it turns by more than 20 degrees (mitred corners)
        sew_corners = np.array([edges[k][i] for k in ("c", "d") for i in (0, -1)])
        ring = piece.boundary
        u = np.roll(ring, -1, axis=0) - ring
        v = ring - np.roll(ring, 1, axis=0)
        cross = v[:, 0] * u[:, 1] - v[:, 1] * u[:, 0]
        turn = np.degrees(np.abs(np.arctan2(cross, np.einsum("ij,ij->i", v, u))))
        cut_corners = ring[turn > 20.0]
        assert len(cut_corners) == 4
        expected = np.vstack([cut_corners, sew_corners])
        got = piece.turn_points
        assert len(got) == 8
        assert np.abs(np.sort(got, axis=0) - np.sort(expected, axis=0)).max() <= 1e-9
        # every other vertex of both rings is a curve point, and only those
        assert len(piece.curve_points) == len(piece.boundary) + len(piece.sew) - 8
        rings = np.vstack([piece.boundary, piece.sew])
        gap = np.min(np.linalg.norm(piece.curve_points[:, None] - rings[None], axis=-1), axis=1)
        assert gap.max() <= 1e-9


def test_sew_line_is_the_developed_outline(lampshade):
    out, read, reports = lampshade
    for piece in read.pieces:
        rep = reports[piece.name]
        _, vt, _ = read_obj(out / f"{piece.name}.obj")
        m = rep["resolution"]["samples_per_ruling"]
        outline = np.vstack([vt[0::m], vt[m - 1::m][::-1]]) + rep["textile"]["offset_in_sheet"]
        # same ring, possibly traversed the other way: compare point sets both ways
        sew = piece.sew
        d1 = np.min(np.linalg.norm(outline[:, None] - sew[None], axis=-1), axis=1)
        d2 = np.min(np.linalg.norm(sew[:, None] - outline[None], axis=-1), axis=1)
        assert max(d1.max(), d2.max()) <= 1e-9 * np.ptp(sew, axis=0).max()
        assert len(sew) == len(outline)


def test_cut_line_lies_at_the_allowance_from_the_sew_line(lampshade):
    _, read, reports = lampshade
    for piece in read.pieces:
        widths = set(reports[piece.name]["textile"]["allowances"].values())
        assert widths == {10.0, 15.0}
        sew_ring = LinearRing(piece.sew)
        assert Polygon(piece.boundary).contains(Polygon(piece.sew))
        cut = np.vstack([piece.boundary, piece.boundary[:1]])
        mids = 0.5 * (cut[1:] + cut[:-1])
        dist = np.array([sew_ring.distance(Point(p)) for p in mids])
        # every straight stretch of the cut line is one allowance away (10 on the seams,
        # 15 on the end rulings); only the four mitred corners reach further
        on_allowance = np.isclose(dist, 10.0, atol=1e-9) | np.isclose(dist, 15.0, atol=1e-9)
        assert np.count_nonzero(~on_allowance) <= 8
        assert dist.min() >= 10.0 - 1e-9
        # mitred corners of angles >= 60 degrees reach at most 15 / sin(30 deg)
        assert LinearRing(piece.boundary).hausdorff_distance(sew_ring) <= 30.0


def test_uniform_allowance_equals_the_shapely_mitre_buffer(tmp_path):
    data = yaml.safe_load(LAMPSHADE.read_text())
    data["name"] = "uniform"
    data["textile"]["seam_allowance"] = 12.0
    data["textile"]["printout"] = False
    config = tmp_path / "uniform.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    for piece in read_aama(tmp_path / "o" / "uniform.dxf").pieces:
        expected = Polygon(piece.sew).buffer(12.0, join_style="mitre", mitre_limit=10.0)
        got = Polygon(piece.boundary)
        assert got.symmetric_difference(expected).area <= 1e-6 * got.area
        assert LinearRing(piece.boundary).hausdorff_distance(expected.exterior) <= 1e-6


def test_matching_notches_are_at_equal_arc_length(lampshade):
    _, read, reports = lampshade
    placed = {}
    for piece in read.pieces:
        rep = reports[piece.name]
        sew = LinearRing(piece.sew)
        for notch in rep["textile"]["notches"]:
            point = Point(notch["sew_point"])
            assert sew.distance(point) <= 0.2  # the exact point, within the chord tolerance
            edge = LineString(rep["textile"]["edges"][notch["edge"]])
            # the lampshade strips cover their arcs fully: the flat edge starts at the curve start
            placed.setdefault(notch["arc_length"], []).append((piece.name, notch["edge"], edge.project(point)))
        # the notch points in the DXF lie on the cut line; each is a 5 mm slit pointing inwards
        for notch in piece.notches:
            assert LinearRing(piece.boundary).distance(Point(notch.point)) <= 1e-9
            assert notch.depth == pytest.approx(5.0) and notch.width == 0.0
            inwards = np.array([np.cos(np.radians(notch.angle)), np.sin(np.radians(notch.angle))])
            tip = notch.point + notch.depth * inwards
            assert Polygon(piece.boundary).contains(Point(tip))
            # at right angles to the cut line: the tip is one notch depth inside it
            assert LinearRing(piece.boundary).distance(Point(tip)) == pytest.approx(5.0, abs=0.05)
    for s in (100.0, 267.0353755551324, 150.0, 300.0):
        hits = placed[s]
        assert len(hits) == 2 and {h[1] for h in hits} == {"c", "d"}
        assert hits[0][0] != hits[1][0]
        # equal flat arc length on both pieces, equal to the 3D arc length (isometry)
        assert hits[0][2] == pytest.approx(hits[1][2], abs=0.02)
        assert hits[0][2] == pytest.approx(s, abs=0.02)


def test_svg_sheet_is_one_to_one_with_a_check_square(lampshade):
    out, read, _ = lampshade
    svg = (out / "lampshade_print.svg").read_text()
    width_pt, height_pt = (float(v) for v in re.search(r'width="([\d.]+)pt" height="([\d.]+)pt"', svg).groups())
    cut = np.vstack([p.boundary for p in read.pieces])
    extent = np.ptp(cut, axis=0)
    # sheet = pieces + 2 x 20 mm margins, plus the 100 mm check square and its margin below
    assert width_pt * 25.4 / 72 == pytest.approx(extent[0] + 40.0, abs=0.01)
    assert height_pt * 25.4 / 72 == pytest.approx(extent[1] + 40.0 + 120.0, abs=0.01)
    assert "10 cm check square" in svg


@pytest.mark.parametrize("name", ["GLX4802S19_AAMA.DXF", "GLX4802S19_ASTM.DXF", "MEN_CLASSIC_TEE.DXF",
                                  "WM_SLIM_TANK.DXF", "simple.DXF", "clo-box.dxf", "clo-pattern.dxf"])
def test_real_aama_files_parse_with_the_same_reader(name):
    read = read_aama(REALDATA / name)
    assert read.units.upper() in ("METRIC", "ENGLISH")
    assert read.pieces
    for piece in read.pieces:
        assert piece.name
        assert len(piece.boundary) >= 3
        assert Polygon(piece.boundary).area > 0
    assert any(piece.grain for piece in read.pieces)


REAL_FILES = sorted(REALDATA.iterdir())
OUR_LAYERS = {"1", "2", "3", "4", "7", "8"}


def test_the_open_astm_parser_reads_every_notch_grain_and_boundary_of_ours(lampshade, astm):
    out, read, reports = lampshade
    [res] = astm([out / "lampshade.dxf"])
    assert res["ok"], res
    assert res["diagnostics"] == []  # nothing it could not read
    assert res["asset"]["unit"] == 1 and res["asset"]["creationTime"] and res["sizes"] == ["M"]
    assert res["style"]["name"] == "lampshade"
    by_name = {p["name"]: p for p in res["pieces"]}
    assert sorted(by_name) == sorted(p.name for p in read.pieces)
    for piece in read.pieces:
        got = {k: np.array(v["M"]["points"]).reshape(-1, 2) for k, v in by_name[piece.name].items() if k != "name"}
        assert by_name[piece.name]["boundary"]["M"]["lengths"] == [len(piece.boundary)]
        assert np.abs(got["boundary"] - piece.boundary).max() <= 1e-9
        configured = [n for n in reports[piece.name]["textile"]["notches"]]
        assert len(got["notches"]) == len(configured) == len(piece.notches) > 0
        # each notch it reads is on the cut line, at the configured notch's place
        for point, notch in zip(got["notches"], configured):
            assert LinearRing(piece.boundary).distance(Point(point)) <= 1e-6
            assert np.hypot(*(point - notch["sew_point"])) == pytest.approx(10.0, abs=0.05)  # the allowance
        assert np.abs(got["grain"] - piece.grain[0]).max() <= 1e-9
        assert len(got["turn"]) == 8 and len(got["curve"]) == len(piece.curve_points)


def test_the_open_astm_parser_reads_the_real_files_with_the_same_structure(astm):
    results = astm(REAL_FILES)
    for path, res in zip(REAL_FILES, results):
        assert res["ok"], res
        # the real files' diagnostics concern layers we do not write (84/85 ASTM
        # validation curves, CLO's unknown group code 250): none about ours
        about_ours = [d for d in res["diagnostics"] if d["layer"] in OUR_LAYERS]
        assert about_ours == [], (path.name, about_ours[:3])
        pieces = res["pieces"]
        assert pieces
        for pc in pieces:
            for size, shape in pc["boundary"].items():
                assert shape["lengths"], (path.name, pc["name"], size)
        counts = {k: sum(len(s["lengths"]) for pc in pieces for s in pc[k].values())
                  for k in ("turn", "notches", "grain")}
        assert counts["turn"] > 0 and counts["grain"] > 0, (path.name, counts)
        if path.name != "clo-box.dxf":  # the one real file without notches
            assert counts["notches"] > 0, (path.name, counts)


def textile_config(tmp_path, **textile):
    data = yaml.safe_load(LAMPSHADE.read_text())
    data["textile"].update(textile)
    config = tmp_path / "bad.yaml"
    config.write_text(yaml.safe_dump(data))
    return config


BAD_TEXTILE = [
    ({"seam_allowance": -3.0}, ["textile.seam_allowance", "-3"]),
    ({"seam_allowance": {"c": 10, "d": -1, "start": 5, "end": 5}}, ["textile.seam_allowance.d", "-1"]),
    ({"seam_allowance": 500.0}, ["seam_allowance", "500", "larger than the piece"]),
    ({"notches": [{"curve": 1, "at": [2000]}]}, ["textile.notches[0].at[0] = 2000", "outside the edge"]),
    ({"notches": [{"curve": 7, "at": [10]}]}, ["textile.notches[0].curve", "7"]),
    ({"notches": [{"ruling": 999}]}, ["textile.notches[0].ruling = 999", "outside piece"]),
    ({"grain": {"bias": 45}}, ["textile.grain.bias", "unknown field"]),
    ({"grain": {"angle": 30, "ruling": 2}}, ["textile.grain", "exactly one of"]),
    ({"grain": {"direction": [1, 0, 0.0001]}}, []),  # valid: tangent to the pieces at the middle ruling
]


@pytest.mark.parametrize("textile, expected", BAD_TEXTILE, ids=[str(k) for k, _ in BAD_TEXTILE])
def test_bad_textile_input_exits_2_naming_the_field(tmp_path, capsys, textile, expected):
    config = textile_config(tmp_path, **textile)
    out = tmp_path / "out"
    code = main(["run", str(config), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    if not expected:
        assert code == 0, err
        return
    assert code == 2, err
    for piece in expected:
        assert piece in err, (piece, err)
    assert not out.exists()


def test_sew_line_on_layer_14_and_v_notches(tmp_path):
    config = textile_config(tmp_path, sew_line_layer=14, notch_type="v", notch_width=4.0, printout=False)
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    import ezdxf
    doc = ezdxf.readfile(out / "lampshade.dxf")
    for piece in read_aama(out / "lampshade.dxf").pieces:
        sew = [e for e in doc.blocks[piece.block] if e.dxf.layer == "14"]
        assert len(sew) == 1 and sew[0].is_closed and piece.sew is not None
        assert not any(e.dxftype() == "POLYLINE" for e in doc.blocks[piece.block] if e.dxf.layer == "8")
        assert all(n.depth == pytest.approx(5.0) and n.width == 4.0 for n in piece.notches)


@pytest.mark.parametrize("grain", [{"ruling": 5}, {"angle": 30.0}, {"direction": [0, 0, 1]}],
                         ids=["ruling", "angle", "direction"])
def test_grain_line_options(tmp_path, grain):
    config = textile_config(tmp_path, grain=grain, printout=False)
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    for piece in read_aama(out / "lampshade.dxf").pieces:
        rep = json.loads((out / f"{piece.name}.json").read_text())
        g = piece.grain[0][1] - piece.grain[0][0]
        g /= np.linalg.norm(g)
        c_edge, d_edge = (np.array(rep["textile"]["edges"][k]) for k in ("c", "d"))
        if "angle" in grain:
            assert abs(abs(g @ [np.cos(np.pi / 6), np.sin(np.pi / 6)]) - 1) <= 1e-12
            continue
        k = 5 if "ruling" in grain else len(c_edge) // 2
        ruling = d_edge[k] - c_edge[k]
        ruling /= np.linalg.norm(ruling)
        # on a cone with a vertical axis the vertical direction lies along the generators,
        # so the projected grain runs along the middle ruling
        assert abs(abs(g @ ruling) - 1) <= 1e-9
        assert Polygon(piece.sew).buffer(1e-9).contains(Point(piece.grain[0][0]))


# ------------------------------------------------------------------ seams that match
SAIL = ROOT / "configs" / "sail.yaml"
SAIL_C1 = np.array([[100, 0, 1000], [1400, 280, 1000], [2900, 0, 1000]], dtype=float)


def bezier_length(points: np.ndarray, a: float, b: float) -> float:
    """Arc length of a quadratic Bezier over [a, b] by adaptive quadrature of its speed
    (independent of devflat's NURBS code)."""
    from scipy.integrate import quad

    def speed(t):
        return np.linalg.norm(2 * (1 - t) * (points[1] - points[0]) + 2 * t * (points[2] - points[1]))
    return quad(speed, a, b, epsabs=1e-10, epsrel=1e-12)[0]


# sail_1 (curves 0 and 1 on the planes z = 0 and 1000) starts where the plan tangent of
# curve 0 at its start, (1500, 300), is parallel to curve 1's, 2(1-T)(1300, 280) + 2T(1500, -280):
# 1500 * 280 (1 - 2T) = 300 (1300 + 200T), so T = 1/30; sail_2 covers curve 1 whole
T_SAIL_1 = 1.0 / 30.0
UNSEWABLE = bezier_length(SAIL_C1, 0.0, T_SAIL_1)


def sail_run(tmp_path, mode):
    data = yaml.safe_load(SAIL.read_text())
    data["textile"].update(seams=mode, printout=False)
    data["textile"].pop("match_marks")  # these tests follow the configured notches (tests/test_textile_cutting.py the marks)
    data["output"] = {"png": False, "obj": False}
    config = tmp_path / "sail.yaml"
    config.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    code = main(["run", str(config), "--out", str(out), "--quiet"])
    reports = {p.stem: json.loads(p.read_text()) for p in out.glob("sail_?.json")}
    return code, out, reports


def polyline_length(points) -> float:
    return float(np.linalg.norm(np.diff(np.asarray(points), axis=0), axis=1).sum())


def test_sail_seam_report_says_how_much_is_unsewable_and_why(tmp_path):
    code, out, reports = sail_run(tmp_path, "report")
    assert code == 0
    assert reports["sail_1"]["coverage"]["T_interval"][0] == pytest.approx(T_SAIL_1, abs=1e-9)
    for name in ("sail_1", "sail_2"):
        [seam] = reports[name]["textile"]["seams"]
        assert seam["curve"] == "1" and seam["curve_length"] == pytest.approx(bezier_length(SAIL_C1, 0, 1), rel=1e-9)
        [item] = seam["unsewable"]  # one stretch, on sail_2: sail_1 does not reach it
        assert item["piece"] == "sail_2" and item["edge"] == "c" and item["from"] == pytest.approx(0.0, abs=1e-9)
        assert item["length"] == pytest.approx(UNSEWABLE, rel=1e-7)
        assert "sail_1 stops" in item["because"] and "start of curve 0" in item["because"]
    assert any(f"{UNSEWABLE:.1f} mm of edge c unsewable" in w for w in reports["sail_2"]["warnings"])
    # unmatched, the flat seam edges differ by that stretch
    d1 = polyline_length(reports["sail_1"]["textile"]["edges"]["d"])
    c2 = polyline_length(reports["sail_2"]["textile"]["edges"]["c"])
    assert c2 - d1 == pytest.approx(UNSEWABLE, abs=0.5)


def test_sail_seams_match_to_half_a_millimetre_and_notches_stay_matched(tmp_path):
    code, out, reports = sail_run(tmp_path, "match")
    assert code == 0
    d1 = reports["sail_1"]["textile"]["edges"]["d"]
    c2 = reports["sail_2"]["textile"]["edges"]["c"]
    sewable = bezier_length(SAIL_C1, T_SAIL_1, 1.0)
    assert polyline_length(d1) == pytest.approx(polyline_length(c2), abs=0.5)
    assert polyline_length(c2) == pytest.approx(sewable, abs=0.5)
    [seam] = reports["sail_2"]["textile"]["seams"]
    assert seam["unsewable"] == [] and seam["sewable_length"] == pytest.approx(sewable, rel=1e-7)
    assert any("trimmed by" in w for w in reports["sail_2"]["warnings"])
    # the notches at 700, 1400, 2100 mm along curve 1 sit at equal flat distances from the
    # seam's start on both pieces, i.e. at s - (the trimmed stretch)
    placed = {}
    for name, edge in (("sail_1", d1), ("sail_2", c2)):
        line = LineString(edge)
        for notch in reports[name]["textile"]["notches"]:
            placed.setdefault(notch["arc_length"], []).append(line.project(Point(notch["sew_point"])))
    assert sorted(placed) == [700.0, 1400.0, 2100.0]
    for s, (a, b) in placed.items():
        assert a == pytest.approx(b, abs=0.5)
        assert a == pytest.approx(s - UNSEWABLE, abs=0.5)
    read = read_aama(out / "sail.dxf")
    assert [len(p.notches) for p in read.pieces] == [3, 3]


def test_separate_parts_share_no_seam(tmp_path):
    """The c and d of parts given one by one are each part's own curves, not a seam."""
    data = yaml.safe_load(SAIL.read_text())
    curves = data.pop("sequence")
    data.pop("name")
    data["parts"] = [{"name": f"panel_{k}", "curves": {"c": curves[k], "d": curves[k + 1]}} for k in (0, 1)]
    data["textile"].update(seams="require_full", printout=False, notches=[])
    data["output"] = {"png": False, "obj": False}
    config = tmp_path / "parts.yaml"
    config.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    for k in (0, 1):
        rep = json.loads((out / f"panel_{k}.json").read_text())
        assert rep["status"] == "ok" and rep["textile"]["seams"] == []


def test_sail_require_full_fails_the_pieces_and_writes_no_pattern(tmp_path):
    code, out, reports = sail_run(tmp_path, "require_full")
    assert code == 1
    for name in ("sail_1", "sail_2"):
        assert reports[name]["status"] == "failed"
        assert "require_full" in reports[name]["reason"] and "curve 1" in reports[name]["reason"]
    assert f"{UNSEWABLE:.1f} mm of edge c unsewable" in reports["sail_2"]["reason"]
    assert not (out / "sail.dxf").exists()


# ------------------------------------------------------------------ tiled printout
PT = 72.0 / 25.4


def pdf_pages(path):
    pdfplumber = pytest.importorskip("pdfplumber", reason="pdfplumber (test extra) reads the printout PDF back")
    return pdfplumber.open(path).pages


def page_lines(page, width_pt):
    """Polylines (K, 2) in page millimetres (y up) of the strokes of this width."""
    out = []
    for obj in page.curves + page.lines:
        if abs(obj["linewidth"] - width_pt) <= 1e-3:
            pts = np.array(obj["pts"], dtype=float) / PT
            pts[:, 1] = page.height / PT - pts[:, 1]
            out.append(pts)
    return out


def check_squares(page, size=50.0):
    return [r for r in page.rects if abs(r["width"] - size * PT) <= 0.01 and abs(r["height"] - size * PT) <= 0.01]


@pytest.mark.parametrize("paper, orientation, overlap", [("A4", "portrait", 10.0), ("Letter", "landscape", 15.0)])
def test_tiled_printout_covers_every_outline_with_the_configured_overlap(tmp_path, paper, orientation, overlap):
    config = textile_config(tmp_path, printout={"paper": paper, "orientation": orientation, "overlap": overlap})
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    read = read_aama(out / "lampshade.dxf")
    border = 8.0
    size = {"A4": (210.0, 297.0), "Letter": (215.9, 279.4)}[paper]
    size = size[::-1] if orientation == "landscape" else size
    w, h = size[0] - 2 * border, size[1] - 2 * border
    cut = np.vstack([p.boundary for p in read.pieces])
    lo, hi = cut.min(axis=0) - 5.0, cut.max(axis=0) + 5.0  # the documented 5 mm margin
    pages = pdf_pages(out / "lampshade_print.pdf")
    # the bottom join lines lie at border + band + overlap: the band below the window that
    # holds the check square when some page has no free place for it is 0 or 58 mm
    bands = {round(line[0, 1] - border - overlap, 6) for page in pages[1:] for line in page_lines(page, 0.45)
             if np.ptp(line[:, 1]) < 1e-6}
    # one row of pages has no bottom join line: the left trim lines start at border + band
    bands = bands or {round(line[:, 1].min() - border, 6) for page in pages[1:] for line in page_lines(page, 0.35)
                      if np.ptp(line[:, 0]) < 1e-6}
    assert len(bands) == 1 and bands <= {0.0, 58.0}
    band = bands.pop()
    h -= band
    drawn, labels = [], set()
    for k, page in enumerate(pages):
        assert (page.width / PT, page.height / PT) == pytest.approx(size, abs=0.01)
        assert len(check_squares(page)) == 1  # the 5 cm square, on every page
        if k == 0:
            continue  # the assembly map
        label = "".join(c["text"] for c in page.chars if c["size"] > 15)  # the page label, 18 pt
        row, col = ord(label[0]) - ord("A"), int(label[1:]) - 1
        labels.add(label)
        # the page's window on the sheet: from the top-left corner of the pieces' box
        x0, y0 = lo[0] + col * (w - overlap), hi[1] - h - row * (h - overlap)
        for line in page_lines(page, 0.85):  # cut lines and notches
            sheet = line - [border, border + band] + [x0, y0]
            assert np.all(sheet.min(axis=0) >= [x0 - 1e-3, y0 - 1e-3])
            assert np.all(sheet.max(axis=0) <= [x0 + w + 1e-3, y0 + h + 1e-3])
            drawn.append(LineString(sheet))
        # the join lines lie `overlap` inside the right window edge (and the bottom one, above)
        for line in page_lines(page, 0.45):
            if np.ptp(line[:, 0]) < 1e-6:
                assert border + w - line[0, 0] == pytest.approx(overlap, abs=0.01)
        # no text on the page touches a cut line, the grain line or the sew line
        strokes = [LineString(p) for lw in (0.85, 0.6, 0.5) for p in page_lines(page, lw) if len(p) > 1]
        for c in page.chars:
            rect = shapely.box(c["x0"] / PT, (page.height - c["bottom"]) / PT, c["x1"] / PT, (page.height - c["top"]) / PT)
            assert not any(rect.intersects(s) for s in strokes), c["text"]
    assert len(labels) == len(pages) - 1
    union = shapely.unary_union(drawn)
    for piece in read.pieces:
        ring = LinearRing(piece.boundary)
        samples = [ring.interpolate(s) for s in np.arange(0, ring.length, 2.0)]
        gaps = [union.distance(p) for p in samples]
        assert max(gaps) <= 0.01  # every piece's whole outline is printed


def test_a_printout_of_too_many_pages_is_bad_input(tmp_path, capsys):
    data = yaml.safe_load(LAMPSHADE.read_text())
    data["units"] = "m"  # the lampshade 1000 times larger: a 1.8 km sheet
    data["resolution"]["chord_tolerance"] = 0.05
    data["textile"].update(seam_allowance=0.01, notches=[], notch_length=0.005)
    config = tmp_path / "huge.yaml"
    config.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "textile.printout" in err and "pages of A4 portrait" in err
    assert not out.exists()


def test_tiles_cover_the_box_and_overlap_by_the_configured_amount():
    from pipeline.textile.printout import tile_sheet

    for window, overlap in (((194.0, 281.0), 10.0), ((404.0, 281.0), 25.0), ((199.9, 263.4), 0.0)):
        lo, hi = np.array([-3.0, 7.0]), np.array([1785.0, 346.0])
        tiles = tile_sheet(lo, hi, window, overlap)
        covered = shapely.unary_union([t.window for t in tiles])
        assert covered.contains(shapely.box(*lo, *hi))
        by = {(t.row, t.col): t for t in tiles}
        for (r, c), t in by.items():
            if (r, c + 1) in by:
                assert t.x0 + t.w - by[r, c + 1].x0 == pytest.approx(overlap)
            if (r + 1, c) in by:
                assert by[r + 1, c].y0 + by[r + 1, c].h - t.y0 == pytest.approx(overlap)
        # no more tiles than needed: dropping the last column or row leaves part uncovered
        cols = 1 + max(t.col for t in tiles)
        fewer = shapely.unary_union([t.window for t in tiles if t.col < cols - 1])
        assert cols == 1 or not fewer.contains(shapely.box(*lo, *hi))


# ------------------------------------------------------------------ preview
def test_textile_preview_speaks_the_sewing_rooms_language():
    from pipeline.config import load_config
    from pipeline.export import textile_pieces
    from pipeline.stages import run_part
    from pipeline.textile.preview import LEGEND, textile_preview_figure

    config = load_config(LAMPSHADE)
    results = [run_part(part, config) for part in config.parts[:2]]
    piece = textile_pieces(results, config)[1]  # lampshade_2: notches on both seams
    fig = textile_preview_figure(piece, "mm")
    fig.canvas.draw()
    [ax] = [a for a in fig.axes if a.get_legend() is not None]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert set(LEGEND) <= set(legend) and "internal lines (rulings)" in legend
    texts = [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))]
    assert not any("bend" in t or t == "cut" for t in texts)  # no steel words, no mislabelled sew line
    assert ax.get_aspect() == 1.0  # true aspect
    lines = {line.get_label(): line.get_xydata() for line in ax.get_lines()}
    assert np.array_equal(lines["cut line"][:-1], piece.cut) and np.array_equal(lines["sew line"][:-1], piece.sew)
    # the piece's name, size and fabric inside the sew line, touching neither it, the
    # grain line nor a notch
    [label] = [t for t in ax.texts if t.get_text().startswith(piece.name)]
    assert "size M, cut 2" in label.get_text() and "linen" in label.get_text()
    corners = ax.transData.inverted().transform(label.get_window_extent().get_points())
    rect = shapely.box(*corners[0], *corners[1])
    assert Polygon(piece.sew).contains(rect)
    assert not rect.intersects(LineString(piece.grain))
    assert not any(rect.intersects(LineString(n.line)) for n in piece.notches)
