"""Nesting: markers and stock plates checked independently of the engine and of
pipeline.nest.engine's own checks (shapely on the placed outlines, closed-form areas, the DXF
read back), quantities honoured, bad input exit 2, unplaceable parts reported."""

import csv
import json
import os
import math
from collections import Counter
from pathlib import Path

import ezdxf
import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import affinity
from shapely.geometry import Polygon, box

from pipeline.cli import main
from pipeline.config import ConfigError, load_config
from pipeline.nest.engine import NestingError, NestItem, NestResult, Placement, Sheet, check_layout, nest_marker, nest_stock

ROOT = Path(__file__).resolve().parents[1]
LAMPSHADE = ROOT / "configs" / "lampshade.yaml"
PLATE = ROOT / "configs" / "plate.yaml"
SEED = 5


def disc(radius: float, n: int = 64) -> np.ndarray:
    a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    return np.c_[radius * np.cos(a), radius * np.sin(a)] + [300.0, -40.0]  # off the origin on purpose


def rect(w: float, h: float) -> np.ndarray:
    return np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])


def placed(item_outline: np.ndarray, p: Placement) -> Polygon:
    """The placement applied with shapely's own affine maps (not Placement.place)."""
    return affinity.translate(affinity.rotate(Polygon(item_outline), p.rotation, origin=(0, 0)), *p.translation)


def independent_check(result: NestResult, spacing: float, slack: float) -> list[Polygon]:
    polys = []
    for sheet in result.sheets:
        inner = box(result.edge_margin, result.edge_margin, sheet.length - result.edge_margin,
                    sheet.width - result.edge_margin).buffer(slack, join_style="mitre")
        here = [placed(result.items[p.item].outline, p) for p in sheet.placements]
        for poly in here:
            assert inner.contains(poly)
        for i in range(len(here)):
            for j in range(i):
                assert here[i].distance(here[j]) >= spacing - slack
                assert here[i].intersection(here[j]).area <= slack * slack
        polys += here
    return polys


def test_marker_of_discs_and_rectangles_is_valid_and_honours_quantities():
    n = 48
    items = [NestItem("disc", disc(60.0, n), 5, (0.0, 180.0)),
             NestItem("bar", rect(200.0, 40.0), 3, (0.0, 180.0), base_rotation=90.0)]
    result = nest_marker(items, 400.0, 3.0, 5.0, 1, SEED, 1)
    assert result.success, result.message
    polys = independent_check(result, 3.0, 1e-6 * 2000)
    sheet = result.sheets[0]
    assert Counter(p.item for p in sheet.placements) == {"disc": 5, "bar": 3}
    assert sorted(p.copy for p in sheet.placements if p.item == "disc") == list(range(5))
    # areas: the regular 48-gon and the rectangle, in closed form, survive the placement
    disc_area = 0.5 * n * 60.0**2 * math.sin(2 * math.pi / n)
    for p, poly in zip(sheet.placements, polys):
        assert poly.area == pytest.approx(disc_area if p.item == "disc" else 8000.0, rel=1e-12)
    # the bar keeps its reference orientation (base 90 degrees) or turns half a turn
    for p in sheet.placements:
        if p.item == "bar":
            assert (p.rotation - 90.0) % 180.0 == pytest.approx(0.0, abs=1e-9)
    # efficiency is pieces' area over the roll used; the length is at least area / width
    f = result.figures
    assert f["pieces_area"] == pytest.approx(5 * disc_area + 3 * 8000.0)
    assert f["marker_length"] >= f["pieces_area"] / 400.0
    assert f["efficiency"] == pytest.approx(f["pieces_area"] / (400.0 * f["marker_length"]))
    assert f["marker_length"] == pytest.approx(max(poly.bounds[2] for poly in polys) + 5.0)
    assert result.checks["passed"] and result.checks["min_gap"] >= 3.0 - 2e-3


def test_the_layout_check_finds_overlaps_gaps_and_parts_outside():
    items = {"sq": NestItem("sq", rect(10.0, 10.0), 3)}
    good = Sheet("s", 20.0, 40.0, (Placement("sq", 0, 0.0, np.array([0.0, 0.0])),
                                   Placement("sq", 1, 0.0, np.array([12.0, 0.0])),
                                   Placement("sq", 2, 90.0, np.array([34.0, 5.0]))))
    ok = check_layout(NestResult("marker", [good], items, 2.0, 0.0))
    assert ok["passed"] and ok["min_gap"] == pytest.approx(2.0)
    bad = Sheet("s", 20.0, 40.0, (Placement("sq", 0, 0.0, np.array([0.0, 0.0])),
                                  Placement("sq", 1, 0.0, np.array([11.0, 0.0])),  # 1 apart, spacing 2
                                  Placement("sq", 2, 0.0, np.array([35.0, 15.0]))))  # 5 past the edge
    found = check_layout(NestResult("marker", [bad], items, 2.0, 0.0))
    assert not found["passed"]
    sheet = found["sheets"][0]
    assert not sheet["inside"] and sheet["max_outside"] == pytest.approx(5.0)
    assert sheet["spacing_violations"][0]["gap"] == pytest.approx(1.0)
    overlap = Sheet("s", 20.0, 40.0, (Placement("sq", 0, 0.0, np.array([0.0, 0.0])),
                                      Placement("sq", 1, 0.0, np.array([9.0, 0.0]))))
    found = check_layout(NestResult("marker", [overlap], items, 0.0, 0.0))
    # overlap 1 x 10: depth 2 * 10 / 22
    assert found["sheets"][0]["spacing_violations"][0]["gap"] == pytest.approx(-20.0 / 22.0)
    assert not found["quantities_accounted"] and found["quantity_errors"]["sq"]["placed"] == 2


def test_stock_plates_report_a_part_longer_than_every_plate():
    items = [NestItem("square", rect(490.0, 490.0), 8, (0.0, 90.0, 180.0, 270.0)),
             NestItem("bar", rect(4000.0, 100.0), 2, (0.0, 90.0, 180.0, 270.0))]
    result = nest_stock(items, [("S", 1000.0, 1500.0)], 5.0, 0.0, 2, SEED, 1)
    assert not result.success  # the bar is not placed ...
    assert result.unplaced == [{"item": "bar", "copies": 2, "reason": result.unplaced[0]["reason"]}]
    assert "longer than every stock length" in result.unplaced[0]["reason"]
    # ... and the squares are: a plate holds 2 x 3 of them with 5 mm gaps (985 x 1480), so
    # 8 squares need 2 plates (also the area bound: 8 x 0.2401 m2 > 1.5 m2)
    assert result.checks["passed"] and result.checks["quantities_accounted"]
    assert sum(len(s.placements) for s in result.sheets) == 8
    assert len(result.sheets) == 2
    independent_check(result, 5.0, 1e-6 * 1500)
    assert result.figures["utilisation"] == pytest.approx(8 * 490.0**2 / (2 * 1.5e6))


def test_a_part_wider_than_the_roll_or_every_plate_is_bad_input():
    items = [NestItem("wide", rect(300.0, 250.0), 1, (0.0, 180.0))]
    with pytest.raises(NestingError, match=r"nesting.fabric_width = 200.*wide is 250"):
        nest_marker(items, 200.0, 0.0, 0.0, 1, SEED, 1)
    # turning by 90 degrees would fit it, but the grain forbids it; free rotation may not help either
    with pytest.raises(NestingError, match="wider than every stock plate"):
        nest_stock([NestItem("wide", rect(3000.0, 2500.0), 1, (0.0, 90.0))], [("S", 2000.0, 2400.0)], 0.0, 0.0, 1,
                   SEED, 1)
    with pytest.raises(NestingError, match="no parts"):
        nest_marker([], 200.0, 0.0, 0.0, 1, SEED, 1)


# ------------------------------------------------------------------ through the CLI
def lampshade_config(tmp_path: Path, **nesting) -> Path:
    data = yaml.safe_load(LAMPSHADE.read_text())
    data["nesting"] = {"fabric_width": 900, "spacing": 2, "time": 1, "seed": SEED, **nesting}
    path = tmp_path / "lampshade.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def plate_config(tmp_path: Path, **nesting) -> Path:
    data = yaml.safe_load(PLATE.read_text())
    data["nesting"] = {"stock": {"width": 3000, "length": 6000}, "spacing": 10, "edge_margin": 10, "time": 1,
                       "seed": SEED, **nesting}
    path = tmp_path / "plate.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_lampshade_marker_dxf_holds_every_copy_on_the_roll(tmp_path):
    out = tmp_path / "out"
    assert main(["nest", str(lampshade_config(tmp_path)), "--out", str(out), "--quiet"]) == 0
    report = json.loads((out / "lampshade_nesting.json").read_text())
    group = report["groups"]["fabric"]
    assert group["checks"]["passed"] and report["success"]
    length, width = group["figures"]["marker_length"], group["figures"]["fabric_width"]
    # read back: each INSERT's boundary (layer 1), transformed by ezdxf, lies on the roll
    doc = ezdxf.readfile(out / "lampshade_marker.dxf")
    rings = {}
    for insert in doc.modelspace().query("INSERT"):
        for e in insert.virtual_entities():
            if e.dxftype() == "POLYLINE" and e.dxf.layer == "1":
                rings.setdefault(insert.dxf.name, []).append(
                    Polygon([tuple(v.dxf.location)[:2] for v in e.vertices]))
    assert {k: len(v) for k, v in rings.items()} == {f"lampshade_{k}_M": 2 for k in (1, 2, 3)}  # quantity 2
    polys = [p for v in rings.values() for p in v]
    roll = box(0, 0, length, width).buffer(1e-3)
    assert all(roll.contains(p) for p in polys)
    assert max(p.bounds[2] for p in polys) == pytest.approx(length, abs=1e-3)
    for i in range(len(polys)):
        for j in range(i):
            assert polys[i].distance(polys[j]) >= 2.0 - 1e-3
    for name, items in rings.items():
        area = group["items"][name[:-2]]["area"]
        assert all(p.area == pytest.approx(area, rel=1e-9) for p in items)
    header = {e.dxf.text.partition(":")[0]: e.dxf.text.partition(":")[2].strip()
              for e in doc.modelspace().query("TEXT")}
    assert float(header["Marker Length"]) == pytest.approx(length, abs=0.05)
    assert (out / "lampshade_marker.png").stat().st_size > 0


def test_steel_pairs_fill_stock_plates_and_the_cutting_list_adds_up(tmp_path):
    out = tmp_path / "out"
    config = plate_config(tmp_path, pairs=True, quantities={"bilge_plate": 2})
    assert main(["nest", str(config), "--out", str(out), "--quiet"]) == 0
    rows = list(csv.DictReader((out / "bilge_plate_cutting_list.csv").open()))
    parts = Counter(p.split("#")[0] for r in rows for p in r["parts"].split())
    assert parts == {"bilge_plate_SB": 2, "bilge_plate_PS": 2}
    # two 2.9 m x 2.7 m plates per 6 m stock plate, at most
    assert len(rows) == 2
    for r in rows:
        plate_area = float(r["width_mm"]) * float(r["length_mm"]) / 1e6
        assert float(r["plate_area_m2"]) == pytest.approx(plate_area, abs=1e-4)
        assert float(r["scrap_area_m2"]) == pytest.approx(plate_area - float(r["parts_area_m2"]), abs=2e-4)
        assert float(r["scrap_weight_kg"]) == pytest.approx(float(r["scrap_area_m2"]) * 0.012 * 7850, abs=0.2)
        assert float(r["utilisation"]) == pytest.approx(float(r["parts_area_m2"]) / plate_area, abs=1e-4)
        doc = ezdxf.readfile(out / f"bilge_plate_{r['plate']}.dxf")
        assert doc.header["$INSUNITS"] == 4 and not doc.audit().errors
        cuts = [Polygon(list(e.vertices_in_wcs())) for e in doc.modelspace().query("LWPOLYLINE[layer=='CUT_OUTER']")]
        assert len(cuts) == int(r["parts_count"])
        stock = box(10, 10, float(r["length_mm"]) - 10, float(r["width_mm"]) - 10).buffer(1e-2)
        assert all(stock.contains(c) for c in cuts)
        assert sum(c.area for c in cuts) / 1e6 == pytest.approx(float(r["parts_area_m2"]), abs=1e-4)
        texts = " ".join(e.dxf.text for e in doc.modelspace().query("TEXT"))
        assert f"STOCK {r['plate']}" in texts and "UTILISATION" in texts
    report = json.loads((out / "bilge_plate_nesting.json").read_text())
    group = next(iter(report["groups"].values()))
    # the port part is the starboard part's mirror image: same area, reflected outline
    assert group["items"]["bilge_plate_PS"]["area"] == pytest.approx(group["items"]["bilge_plate_SB"]["area"])


def test_a_plate_longer_than_the_stock_is_reported_not_dropped(tmp_path):
    out = tmp_path / "out"
    config = plate_config(tmp_path, stock={"width": 3000, "length": 2500})
    assert main(["nest", str(config), "--out", str(out), "--quiet"]) == 1
    rows = list(csv.DictReader((out / "bilge_plate_cutting_list.csv").open()))
    assert [(r["plate"], r["parts"], r["parts_count"]) for r in rows] == [("UNPLACED", "bilge_plate", "1")]
    assert "longer than every stock length" in rows[0]["note"]
    report = json.loads((out / "bilge_plate_nesting.json").read_text())
    assert not report["success"]


@pytest.mark.parametrize("nesting, field", [
    ({"fabric_width": 100}, "nesting.fabric_width = 100"),
    ({"quantities": {"lampshade_1": 0, "lampshade_2": 0, "lampshade_3": 0}}, "nesting.quantities"),
    ({"quantities": {"no_such_piece": 2}}, "nesting.quantities.no_such_piece"),
])
def test_bad_nesting_input_exits_2_naming_the_field_and_writes_nothing(tmp_path, capsys, nesting, field):
    out = tmp_path / "out"
    assert main(["nest", str(lampshade_config(tmp_path, **nesting)), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert field in err and "lampshade.yaml" in err
    assert not out.exists()


@settings(derandomize=True, max_examples=25, deadline=None)
@given(width=st.one_of(st.floats(max_value=0.0, allow_nan=False), st.just(0)),
       which=st.sampled_from(["fabric_width", "stock_width", "stock_length", "time", "spacing"]))
def test_non_positive_sizes_are_rejected_with_the_field(tmp_path_factory, width, which):
    tmp = tmp_path_factory.mktemp("bad")
    if which == "fabric_width":
        data = yaml.safe_load(LAMPSHADE.read_text())
        data["nesting"] = {"fabric_width": width}
    else:
        data = yaml.safe_load(PLATE.read_text())
        nest = {"stock": {"width": 3000, "length": 6000}}
        if which.startswith("stock"):
            nest["stock"][which[6:]] = width
        else:
            nest[which] = -1 if width == 0 else width
        data["nesting"] = nest
    path = tmp / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as info:
        load_config(path)
    name = {"stock_width": "nesting.stock.width", "stock_length": "nesting.stock.length"}.get(which, f"nesting.{which}")
    assert name in str(info.value) and "bad.yaml" in str(info.value)


def test_nesting_section_must_match_the_profile(tmp_path):
    data = yaml.safe_load(LAMPSHADE.read_text())
    data["nesting"] = {"stock": {"width": 3000, "length": 6000}}
    path = tmp_path / "x.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match="nesting.*fabric_width"):
        load_config(path)
    assert main(["nest", str(PLATE), "--out", str(tmp_path / "o")]) == 2  # no nesting section


def _inserts(path: Path) -> list:
    doc = ezdxf.readfile(path)
    return [(e.dxf.name, tuple(e.dxf.insert), e.dxf.rotation) for e in doc.modelspace().query("INSERT")]


def test_replay_reproduces_a_stored_marker_exactly_and_checks_it_again(tmp_path):
    config = lampshade_config(tmp_path)
    first, again, moved = tmp_path / "first", tmp_path / "again", tmp_path / "moved"
    assert main(["nest", str(config), "--out", str(first), "--quiet"]) == 0
    stored = first / "lampshade_nesting.json"
    assert main(["nest", str(config), "--out", str(again), "--quiet", "--replay", str(stored)]) == 0
    a = json.loads(stored.read_text())["groups"]["fabric"]
    b = json.loads((again / "lampshade_nesting.json").read_text())["groups"]["fabric"]
    assert a["sheets"] == b["sheets"] and a["figures"] == b["figures"]
    assert _inserts(first / "lampshade_marker.dxf") == _inserts(again / "lampshade_marker.dxf")
    # a stored layout that no longer holds (one copy moved onto another) fails the checks: exit 1
    data = json.loads(stored.read_text())
    sheet = data["groups"]["fabric"]["sheets"][0]["placements"]
    sheet[1]["translation"], sheet[1]["rotation"] = sheet[0]["translation"], sheet[0]["rotation"]
    tampered = tmp_path / "tampered.json"
    tampered.write_text(json.dumps(data))
    assert main(["nest", str(config), "--out", str(moved), "--quiet", "--replay", str(tampered)]) == 1
    checks = json.loads((moved / "lampshade_nesting.json").read_text())["groups"]["fabric"]["checks"]
    assert not checks["passed"] and checks["sheets"][0]["spacing_violations"]


def test_mainsail_config_nests_its_eight_panels_on_the_roll(tmp_path):
    out = tmp_path / "out"
    assert main(["nest", str(ROOT / "configs" / "mainsail.yaml"), "--out", str(out), "--quiet", "--time", "1"]) == 0
    report = json.loads((out / "mainsail_nesting.json").read_text())
    group = report["groups"]["fabric"]
    assert group["checks"]["passed"] and group["checks"]["placed"] == {f"mainsail_{k}": 1 for k in range(1, 9)}
    f = group["figures"]
    assert f["fabric_width"] == 1370 and f["marker_length"] >= f["pieces_area"] / 1370
    assert report["settings"]["seed"] == 1 and group["engine"]["budget"] == 1  # --time overrides nesting.time


def test_plates_of_different_thickness_never_share_a_stock_plate(tmp_path):
    plate = yaml.safe_load(PLATE.read_text())
    flat = yaml.safe_load((ROOT / "configs" / "flat_plate.yaml").read_text())
    data = {"units": "mm", "name": "two", "resolution": {"rulings": 20},
            "parts": [{"name": "bilge", "curves": plate["curves"], "steel": {"thickness": 12}},
                      {"name": "bottom", "curves": flat["curves"], "steel": {"thickness": 15}}],
            "nesting": {"stock": {"width": 3000, "length": 12000}, "time": 1, "seed": SEED}}
    path = tmp_path / "two.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["nest", str(path), "--out", str(out), "--quiet"]) == 0
    rows = list(csv.DictReader((out / "two_cutting_list.csv").open()))
    # both fit one 3 x 12 m plate by area and size, but 12 mm and 15 mm need a plate each
    assert sorted((r["thickness_mm"], r["parts"]) for r in rows) == [("12", "bilge#1"), ("15", "bottom#1")]
    assert {p.name for p in out.glob("*.dxf")} == {"two_S355-12_P01.dxf", "two_S355-15_P01.dxf"}
    for r in rows:  # 15 mm plate: the scrap weighs 15/12 as much per m2
        kg = float(r["scrap_area_m2"]) * float(r["thickness_mm"]) / 1000 * 7850
        assert float(r["scrap_weight_kg"]) == pytest.approx(kg, abs=0.1)


def test_free_rotation_turns_a_part_that_only_fits_turned():
    # a 120 x 10 bar standing across a 100-wide roll: 0/180 cannot place it, free rotation can
    standing = NestItem("bar", rect(120.0, 10.0), 2, (0.0, 180.0), base_rotation=90.0)
    with pytest.raises(NestingError, match="bar is 120 wide"):
        nest_marker([standing], 100.0, 1.0, 0.0, 1, SEED, 1)
    free = NestItem("bar", rect(120.0, 10.0), 2, None, base_rotation=90.0)
    result = nest_marker([free], 100.0, 1.0, 0.0, 1, SEED, 1)
    assert result.success, result.message
    polys = independent_check(result, 1.0, 1e-6 * 500)
    # turned away from the standing position: its extent across the roll is at most the width
    assert all(p.bounds[3] - p.bounds[1] <= 100.0 + 1e-3 for p in polys)


def test_nest_writes_through_the_output_transaction(tmp_path, capsys):
    """`devflat nest` holds the folder's lock, stages its files and removes the sheets an
    earlier nesting of the same config wrote that this one does not."""
    from pipeline.outdir import STAGING_PREFIX, OutputFolder

    out = tmp_path / "out"
    config = plate_config(tmp_path, quantities={"bilge_plate": 3})
    assert main(["nest", str(config), "--out", str(out), "--quiet"]) == 0
    first = json.loads((out / "bilge_plate_nesting.json").read_text())["files"]
    sheets = sorted(f for f in first if f.endswith(".dxf"))
    assert len(sheets) >= 2  # three 2.9 m x 2.7 m plates do not fit one 3 m x 6 m plate
    config.write_text(config.read_text().replace("bilge_plate: 3", "bilge_plate: 1"))
    assert main(["nest", str(config), "--out", str(out), "--quiet"]) == 0
    second = json.loads((out / "bilge_plate_nesting.json").read_text())["files"]
    assert sorted(p.name for p in out.iterdir()) == sorted(second)  # the stale sheets are gone, no staging left
    assert len([f for f in second if f.endswith(".dxf")]) == 1
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    with OutputFolder(out, None):  # another run holds the folder
        assert main(["nest", str(config), "--out", str(out), "--quiet"]) == 2
        assert f"another devflat run (pid {os.getpid()}) is writing" in capsys.readouterr().err
        assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()
                if not p.name.startswith((".devflat", STAGING_PREFIX))} == before
