"""Textile pieces: AAMA round trip, sew line, allowance, notches, grain, printout, real files."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from shapely.geometry import LinearRing, LineString, Point, Polygon

from pipeline.aama import read_aama
from pipeline.cli import main
from pipeline.meshio import read_obj

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
        # the notch lines in the DXF start on the cut line and point inwards
        for line in piece.notches:
            assert LinearRing(piece.boundary).distance(Point(line[0])) <= 1e-9
            assert Polygon(piece.boundary).contains(Point(line[1]))
    for s in (100.0, 267.0353755551324, 150.0, 300.0):
        hits = placed[s]
        assert len(hits) == 2 and {h[1] for h in hits} == {"c", "d"}
        assert hits[0][0] != hits[1][0]
        # equal flat arc length on both pieces, equal to the 3D arc length (isometry)
        assert hits[0][2] == pytest.approx(hits[1][2], abs=0.02)
        assert hits[0][2] == pytest.approx(s, abs=0.02)


def test_printout_is_one_to_one_with_a_check_square(lampshade):
    out, read, _ = lampshade
    svg = (out / "lampshade_print.svg").read_text()
    width_pt, height_pt = (float(v) for v in re.search(r'width="([\d.]+)pt" height="([\d.]+)pt"', svg).groups())
    cut = np.vstack([p.boundary for p in read.pieces])
    extent = np.ptp(cut, axis=0)
    # sheet = pieces + 2 x 20 mm margins, plus the 100 mm check square and its margin below
    assert width_pt * 25.4 / 72 == pytest.approx(extent[0] + 40.0, abs=0.01)
    assert height_pt * 25.4 / 72 == pytest.approx(extent[1] + 40.0 + 120.0, abs=0.01)
    assert "10 cm check square" in svg
    pdf = (out / "lampshade_print.pdf").read_bytes()
    box = re.search(rb"/MediaBox \[\s*0 0 ([\d.]+) ([\d.]+)\s*\]", pdf)
    assert float(box.group(1)) == pytest.approx(width_pt, abs=0.01)


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
