"""Shop marks on steel plates: labels checked against the 3D geometry."""

import itertools
import json
import re
import shutil
import subprocess
from collections import Counter
from pathlib import Path

import ezdxf
import numpy as np
import pytest
import shapely
import yaml
from scipy.spatial import cKDTree

from pipeline.cli import main
from pipeline.io.meshio import read_obj

ROOT = Path(__file__).resolve().parents[1]
SHIP = ROOT / "tests" / "data" / "ship"


def _strake_config(tmp_path, name, surface, seams, butts, fit=5.0, **extra):
    data = {"name": name, "units": "mm", "resolution": {"chord_tolerance": 1.0},
            "strake": {"surface": surface, "seams": seams, "butts": butts, "margin": 0.2, "fit_tolerance": fit,
                       **extra}}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def strakes(tmp_path_factory):
    """Two real strakes whose seams run opposite ways: hullmod's iso-curves run towards -x,
    DTMB 5415's towards +x."""
    tmp = tmp_path_factory.mktemp("shop")
    runs = {}
    aft = _strake_config(tmp, "aft", {"iges": str(SHIP / "test_1_hull_exported.igs")},
                         [{"iso": {"v": 4.0}}, {"iso": {"v": 4.3}}], [72000, 88000, 104000],
                         frames={"spacing": 2500})
    fore = _strake_config(tmp, "fore", {"iges": str(SHIP / "ship_5415.igs"), "directory": 5},
                          [{"iso": {"v": 3.0}}, {"iso": {"v": 3.2}}], [1000, 2000, 3000], fit=1.0,
                          frames={"spacing": 250})
    for key, config in (("aft", aft), ("fore", fore)):
        out = tmp / key
        assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
        runs[key] = (out, yaml.safe_load(config.read_text())["strake"])
    return runs


@pytest.mark.parametrize("key", ["aft", "fore"])
def test_butt_labels_sit_on_the_butt_they_name_in_3d(strakes, key):
    out, spec = strakes[key]
    butts = spec["butts"]
    directions = set()
    for j in range(len(butts) - 1):
        name = f"{key}_S1_B{j + 1}"
        v, vt, _ = read_obj(out / f"{name}.obj")
        directions.add(np.sign(v[-1, 0] - v[0, 0]))
        tree = cKDTree(vt)
        msp = ezdxf.readfile(out / f"{name}.dxf").modelspace()
        seen = []
        for text in msp.query("TEXT"):
            if not text.dxf.text.startswith("BUTT "):
                continue
            k = int(text.dxf.text.split()[1])
            _, nearest = tree.query(np.array(text.dxf.insert)[:2])
            x = v[nearest, 0]
            # the label's place on the flat plate maps to the butt it names, not the other one
            other = butts[j + 1] if k == j + 1 else butts[j]
            assert abs(x - butts[k - 1]) < abs(x - other), (name, k, x)
            seen.append(k)
        assert sorted(seen) == [j + 1, j + 2]
        rep = json.loads((out / f"{name}.json").read_text())
        assert rep["plate_class"]["class"] == "developable"
        assert rep["outline"]["max_deviation"] <= 0.05
        assert set(rep["outline"]["edges"]) == {"c", "d", "start", "end"}
        # the trimmed mesh's boundary vertices (exact developed points) lie on the cut outline
        m = rep["resolution"]["samples_per_ruling"]
        ring = shapely.LinearRing(_lwpolyline(out / f"{name}.dxf", "CUT_OUTER"))
        boundary = np.vstack([vt[0::m], vt[m - 1::m]])
        assert shapely.distance(shapely.points(boundary), ring).max() <= 0.05
    # the two strakes do run in opposite directions along their seams
    assert directions == ({-1.0} if key == "aft" else {1.0})


def _lwpolyline(path, layer):
    msp = ezdxf.readfile(path).modelspace()
    polylines = msp.query(f"LWPOLYLINE[layer=='{layer}']")
    assert len(polylines) == 1 and polylines[0].closed
    return np.array([p[:2] for p in polylines[0].get_points("xy")])


def test_frustum_outline_is_the_true_annular_sector_whatever_the_ruling_count(tmp_path):
    """configs/frustum.yaml solves with 10 rulings; the cut outline must still follow the
    true sector (DESIGN §1.6) within 0.05 mm, its area to 1e-5."""
    out = tmp_path / "o"
    assert main(["run", str(ROOT / "configs" / "frustum.yaml"), "--out", str(out), "--quiet"]) == 0
    rep = json.loads((out / "frustum.json").read_text())
    assert rep["resolution"]["count"] == 10
    pts = _lwpolyline(out / "frustum.dxf", "CUT_OUTER")
    r1, r2, h, theta = 3000.0, 2000.0, 1500.0, 2 * np.pi / 3
    s = np.hypot(r1 - r2, h)
    rho1, rho2, angle = r1 * s / (r1 - r2), r2 * s / (r1 - r2), theta * (r1 - r2) / s
    # the two end rulings are the longest segments; their lines meet at the apex
    seg = np.roll(pts, -1, axis=0) - pts
    ends = np.argsort(np.linalg.norm(seg, axis=1))[-2:]
    (p, u), (q, w) = [(pts[i], seg[i]) for i in ends]
    apex = p + u * np.linalg.solve(np.column_stack([u, -w]), q - p)[0]
    assert np.linalg.norm(seg[ends], axis=1) == pytest.approx(rho1 - rho2, rel=1e-9)
    r = np.linalg.norm(pts - apex, axis=1)
    # every vertex on one of the two arcs, to round-off
    assert np.minimum(np.abs(r - rho1), np.abs(r - rho2)).max() <= 1e-6
    # every point of every segment within 0.05 mm of the true sector's boundary
    f = np.linspace(0.0, 1.0, 21)
    dense = (pts[:, None] + f[None, :, None] * seg[:, None]).reshape(-1, 2)
    rd = np.linalg.norm(dense - apex, axis=1)
    on_ruling = np.zeros(len(pts), dtype=bool)
    on_ruling[ends] = True
    arc_pts = ~np.repeat(on_ruling, len(f))
    gap = np.minimum(np.abs(rd - rho1), np.abs(rd - rho2))[arc_pts]
    assert gap.max() <= 0.05
    assert rep["outline"]["max_deviation"] <= 0.05 and rep["outline"]["units"] == "mm"
    area = 0.5 * abs(np.dot(pts[:, 0], np.roll(pts[:, 1], -1)) - np.dot(pts[:, 1], np.roll(pts[:, 0], -1)))
    exact = 0.5 * angle * (rho1**2 - rho2**2)
    assert area == pytest.approx(exact, rel=1e-5)
    assert rep["area_m2"] == pytest.approx(exact / 1e6, rel=1e-5)
    # the opening angle of the sector
    a1, a2 = (np.arctan2(*(pts[i] - apex)[::-1]) for i in ends)
    assert abs(np.angle(np.exp(1j * (a1 - a2)))) == pytest.approx(angle, rel=1e-9)


def test_default_tolerances_are_physical_whatever_the_units(tmp_path):
    """No resolution given: the chord tolerance is 0.5 mm in a metre config too (it was
    taken as 0.5 m), and the cut outline keeps its 0.05 mm."""
    base = yaml.safe_load((ROOT / "configs" / "plate.yaml").read_text())
    del base["resolution"]
    metres = yaml.safe_load(yaml.safe_dump(base))
    metres["units"] = "m"
    for key in ("c", "d"):
        metres["curves"][key]["control_points"] = [[v / 1000 for v in p] for p in base["curves"][key]["control_points"]]
    reports = {}
    for label, data in (("mm", base), ("m", metres)):
        config = tmp_path / f"{label}.yaml"
        config.write_text(yaml.safe_dump(data))
        assert main(["run", str(config), "--out", str(tmp_path / label), "--quiet"]) == 0
        reports[label] = json.loads((tmp_path / label / "bilge_plate.json").read_text())
    mm, m = reports["mm"], reports["m"]
    assert m["resolution"]["count"] == mm["resolution"]["count"] > 10
    assert m["resolution"]["chord_tolerance"] == pytest.approx(0.5e-3)
    assert max(m["resolution"]["max_chord_error_c"], m["resolution"]["max_chord_error_d"]) <= 0.5e-3
    assert m["outline"]["tolerance"] == mm["outline"]["tolerance"] == 0.05
    assert m["outline"]["vertices"] == mm["outline"]["vertices"]
    assert m["area_m2"] == pytest.approx(mm["area_m2"], rel=1e-9)


def _cylinder_config(tmp_path, spacing=None, rulings=7):
    from tests.oracles import circular_arc

    def curve(c):
        return {"degree": c.degree, "control_points": c.control_points.tolist(), "weights": c.weights.tolist(),
                "knots": c.knots.tolist()}

    c = circular_arc(2000.0, 0.0, 2 * np.pi / 3)
    d = circular_arc(2000.0, 1500.0, 2 * np.pi / 3, name="d")
    data = {"name": "cyl", "units": "mm", "curves": {"c": curve(c), "d": curve(d)}, "resolution": {"rulings": rulings}}
    if spacing is not None:
        data["shop"] = {"bend_spacing": spacing}
    path = tmp_path / "cyl.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("spacing", [None, 300.0])
def test_cylinder_bending_lines_at_the_configured_spacing(tmp_path, spacing):
    """A circular cylinder R = 2000 mm, 120 degrees (arc 4188.79 mm), solved with 7 rulings:
    the shop's bending lines are the generators every `spacing` mm (400 by default),
    centred, numbered, each with R 2000."""
    out = tmp_path / "o"
    assert main(["run", str(_cylinder_config(tmp_path, spacing)), "--out", str(out), "--quiet"]) == 0
    rep = json.loads((out / "cyl.json").read_text())
    step = spacing or 400.0
    arc = 2000.0 * 2 * np.pi / 3
    n = int(arc // step)
    bending = rep["bending"]
    assert bending["count"] == n and bending["spacing"] == step and rep["resolution"]["count"] == 7
    assert bending["length_across_rulings"] == pytest.approx(arc, rel=1e-9)
    lines = bending["lines"]
    assert [b["number"] for b in lines] == list(range(1, n + 1))
    assert all(b["radius"] == pytest.approx(2000.0, rel=1e-6) and b["length"] == pytest.approx(1500.0, rel=1e-9)
               for b in lines)
    msp = ezdxf.readfile(out / "cyl.dxf").modelspace()
    dxf_lines = sorted(((np.array(e.dxf.start)[:2], np.array(e.dxf.end)[:2]) for e in msp.query("LINE[layer=='MARK_BEND']")),
                       key=lambda ab: ab[0][0] + ab[1][0])
    assert len(dxf_lines) == n
    # parallel generators at the configured spacing (perpendicular distance), margins equal
    a0, b0 = dxf_lines[0]
    u = (b0 - a0) / np.linalg.norm(b0 - a0)
    normal = np.array([-u[1], u[0]])
    offsets = np.array([(a - a0) @ normal for a, _ in dxf_lines])
    assert np.abs(np.abs(np.diff(offsets)) - step).max() <= 1e-6
    cut = _lwpolyline(out / "cyl.dxf", "CUT_OUTER")
    span = cut @ normal
    lo, hi = span.min() - a0 @ normal, span.max() - a0 @ normal
    assert (offsets.min() - lo) == pytest.approx(hi - offsets.max(), abs=1e-6)
    texts = [t.dxf.text for t in msp.query("TEXT[layer=='MARK_BEND']")]
    assert sorted(texts, key=lambda t: int(t.split()[0][1:])) == [f"B{k} R2000 {lines[k - 1]['mark'].split()[-1]}"
                                                                  for k in range(1, n + 1)]


def _is_steel_part_config(path: Path) -> bool:
    """Steel configs that run in the tests; whole-hull plans (strake.plan) run in
    bench/bench_hull.py (minutes each), the tests only plan them."""
    data = yaml.safe_load(path.read_text())
    return data.get("profile", "steel") == "steel" and "plan" not in (data.get("strake") or {})


STEEL_CONFIGS = [p for p in sorted((ROOT / "configs").glob("*.yaml")) if _is_steel_part_config(p)]


@pytest.mark.parametrize("config", STEEL_CONFIGS, ids=lambda p: p.stem)
def test_every_text_inside_the_plate_clear_of_texts_and_lines(config, tmp_path):
    """Every DXF of every steel config: texts (sized by ezdxf's own font metrics) inside the
    cut outline, not overlapping each other or any mark line; marks clipped to the plate;
    extents set; the report's counts match the file."""
    from ezdxf.tools.text_size import text_size

    out = tmp_path / "o"
    code = main(["run", str(config), "--out", str(out), "--quiet"])
    assert code in (0, 1)
    smallest = ((yaml.safe_load(config.read_text()).get("shop") or {}).get("text_height") or [5.0])[0]
    dxfs = sorted(out.glob("*.dxf"))
    assert dxfs or code == 1
    for path in dxfs:
        if not path.with_suffix(".json").exists():  # not a part's pattern (a run-wide drawing)
            continue
        doc = ezdxf.readfile(path)
        msp = doc.modelspace()
        assert len(doc.audit().errors) == 0
        plate = shapely.Polygon(_lwpolyline(path, "CUT_OUTER"))
        assert plate.is_valid
        boxes = []
        for t in msp.query("TEXT"):
            assert t.dxf.height >= smallest * (1 - 1e-9), (path.name, t.dxf.text)  # shop.text_height's smallest
            size = text_size(t)
            w, h = size.width, size.total_height
            a = np.radians(t.dxf.rotation)
            u, v = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
            c = np.array(t.dxf.align_point)[:2]
            corners = [c + sx * w / 2 * u + sy * h / 2 * v for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            boxes.append((t.dxf.text, shapely.Polygon(corners)))
        assert boxes
        for name, box in boxes:
            assert plate.contains(box), (path.name, name)
        for i in range(len(boxes)):
            for j in range(i + 1, len(boxes)):
                assert not boxes[i][1].intersects(boxes[j][1]), (path.name, boxes[i][0], boxes[j][0])
        marks = [shapely.LineString([(e.dxf.start.x, e.dxf.start.y), (e.dxf.end.x, e.dxf.end.y)]) for e in msp.query("LINE")]
        marks += [shapely.LineString([p[:2] for p in e.get_points("xy")])
                  for e in msp.query("LWPOLYLINE") if not e.closed]
        for line in marks:
            assert plate.buffer(1e-6).contains(line), path.name
            for name, box in boxes:
                assert not box.intersects(line), (path.name, name)
        lo, hi = np.array(doc.header["$EXTMIN"])[:2], np.array(doc.header["$EXTMAX"])[:2]
        x0, y0, x1, y1 = plate.bounds
        assert lo[0] <= x0 and lo[1] <= y0 and hi[0] >= x1 and hi[1] >= y1
        assert np.all(np.abs(np.concatenate([lo, hi])) < 1e9)
        rep = json.loads(path.with_suffix(".json").read_text())
        # a plate developed from its strip gets every mark placed; a label of a flat or
        # formed hull plate that finds no room is reported, never drawn across a line
        findings = rep["layout"]["findings"]
        if rep.get("outline"):
            assert all("not marked" in f for f in findings), findings
        if rep.get("bending"):
            assert len(msp.query("LINE[layer=='MARK_BEND']")) == rep["bending"]["count"]
        if OGRINFO is not None:  # without it, test_gdal_reads_the_shop_dxf_as_ezdxf_wrote_it says so
            assert_gdal_agrees(path)


OGRINFO = shutil.which("ogrinfo")
SUBCLASS_TYPES = {"AcDbPolyline": "LWPOLYLINE", "AcDbLine": "LINE", "AcDbText": "TEXT"}


def _gdal_features(path: Path) -> list[dict]:
    """The DXF's entities as GDAL's DXF driver reads them (ogrinfo): layer, entity type,
    text, point count."""
    text = subprocess.run([OGRINFO, "-ro", "-al", "-q", "-geom=SUMMARY", str(path)], check=True,
                          capture_output=True, text=True, timeout=120).stdout
    features = []
    for block in text.split("OGRFeature(entities):")[1:]:
        fields = dict(re.findall(r"^\s+(\w+) \(String\) = (.*)$", block, flags=re.M))
        kind = fields["SubClasses"].split(":")[1]
        points = re.search(r"^\s+(LINESTRING|POINT|POLYGON)\b.*?(\d+) points", block, flags=re.M)
        features.append({"layer": fields["Layer"], "type": SUBCLASS_TYPES.get(kind, kind),
                         "text": fields.get("Text"), "points": int(points.group(2)) if points else None})
    return features


def assert_gdal_agrees(path: Path) -> None:
    """An independent reader (GDAL) sees the layers, entity counts, texts and polyline
    vertex counts ezdxf wrote."""
    msp = ezdxf.readfile(path).modelspace()
    ours = Counter((e.dxf.layer, e.dxftype()) for e in msp)
    features = _gdal_features(path)
    assert Counter((f["layer"], f["type"]) for f in features) == ours, path.name
    assert sorted(f["text"] for f in features if f["type"] == "TEXT") == sorted(t.dxf.text for t in msp.query("TEXT"))
    # a closed LWPOLYLINE comes back with its first vertex repeated
    ezdxf_points = sorted(len(e) + (1 if e.closed else 0) for e in msp.query("LWPOLYLINE"))
    assert sorted(f["points"] for f in features if f["type"] == "LWPOLYLINE") == ezdxf_points, path.name


@pytest.mark.skipif(OGRINFO is None, reason="GDAL's ogrinfo is not installed (Debian: apt-get install gdal-bin; "
                                            ".ci/run installs it where apt-get is available)")
def test_gdal_reads_the_shop_dxf_as_ezdxf_wrote_it(tmp_path):
    """The frustum and an allowance plate (net line), read by GDAL; every other steel
    config's DXFs are read by GDAL in test_every_text_inside_the_plate_clear_of_texts_and_lines."""
    data = yaml.safe_load((ROOT / "configs" / "frustum.yaml").read_text())
    data["shop"] = {"excess": 25, "bevel": {"c": "X40"}}
    config = tmp_path / "f.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    layers = {f["layer"] for f in _gdal_features(tmp_path / "o" / "frustum.dxf")}
    assert {"CUT_OUTER", "MARK_NET", "MARK_BEND", "MARK_TEXT", "MARK_EDGE"} <= layers
    assert_gdal_agrees(tmp_path / "o" / "frustum.dxf")


def test_mirrored_plate_is_the_reflection_and_napa_plate_warns_no_stock(tmp_path):
    config = ROOT / "configs" / "napa_bilge.yaml"
    data = yaml.safe_load(config.read_text())
    for key in ("c", "d"):
        data["curves"][key]["iges"] = str((config.parent / data["curves"][key]["iges"]).resolve())
    data["shop"] = {"mirror": True, "bevel": {"c": "V30 T2"}}
    path = tmp_path / "napa.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "o"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    rep = json.loads((out / "napa_bilge.json").read_text())
    # the 25.8 m plate fits no stock plate: a warning, the needed size in the report
    assert rep["stock"]["fits_on"] is None and rep["stock"]["needed"][1] > 25800
    assert any("no stock plate fits" in w for w in rep["warnings"])
    model, other = rep["sides"]["modelled"], rep["sides"]["mirrored"]
    assert {model, other} == {"P", "S"} and not (out / "napa_bilge.dxf").exists()
    a = _lwpolyline(out / f"napa_bilge_{model}.dxf", "CUT_OUTER")
    b = _lwpolyline(out / f"napa_bilge_{other}.dxf", "CUT_OUTER")
    # b is a reflected about a vertical line: same vertices with x -> w - x
    w = a[:, 0].min() + a[:, 0].max()
    reflected = np.column_stack([w - a[:, 0], a[:, 1]])
    assert shapely.Polygon(b).symmetric_difference(shapely.Polygon(reflected)).area <= 1e-9 * shapely.Polygon(a).area
    assert shapely.Polygon(a).area == pytest.approx(shapely.Polygon(b).area, rel=1e-12)
    texts = " ".join(t.dxf.text for t in ezdxf.readfile(out / f"napa_bilge_{other}.dxf").modelspace().query("TEXT"))
    assert f"PART napa_bilge_{other} " in texts + " " and f"napa_bilge_{model}" not in texts
    msp = ezdxf.readfile(out / f"napa_bilge_{model}.dxf").modelspace()
    assert [t.dxf.text for t in msp.query("TEXT[layer=='MARK_EDGE']")] == ["EDGE C V30 T2"]


def test_hull_plate_bending_lines_do_not_depend_on_the_sampling_of_the_rulings(tmp_path, monkeypatch):
    """A hull plate cut by two butt planes: the middles of its kept rulings (the bending
    lines are spaced across the rulings between them) turn sharply at the plate's corners,
    where a butt plane starts to cut the rulings. The length across the rulings, the lines'
    stations and their ends must be those of a sampling 30 times denser, to 1e-3 mm (a chord
    sum that stepped over the corners' turns came out 2.2 mm short on such plates, moving the
    lines by up to 1.1 mm)."""
    import pipeline.shop.bending
    from pipeline.hull.plan import load_run
    from pipeline.hull.plates import run_part

    # at 4 mm: within 5 mm its minimax plane (4.89 mm) would make it a flat plate, no strip
    config = _strake_config(tmp_path, "corner", {"iges": str(SHIP / "test_1_hull_exported.igs")},
                            [{"iso": {"v": 4.05}}, {"iso": {"v": 4.1}}], [96000, 104000], fit=4.0)
    # every line kept: this side plate's radii (tens of metres) are far above its no-roll radius
    config.write_text(yaml.safe_dump(dict(yaml.safe_load(config.read_text()), shop={"no_roll_radius": 1e9})))
    plan = load_run(config)

    def bending():
        result = run_part(plan.parts[0], plan)
        assert result.ok and result.figures["plate_class"]["class"] == "developable"
        return result.figures["bending"]

    ours = bending()
    monkeypatch.setattr(pipeline.shop.bending, "DENSE", 30 * pipeline.shop.bending.DENSE)
    dense = bending()
    assert ours["count"] == dense["count"] >= 10
    assert ours["length_across_rulings"] == pytest.approx(dense["length_across_rulings"], abs=1e-3)
    for line, ref in zip(ours["lines"], dense["lines"]):
        assert line["station"] == pytest.approx(ref["station"], abs=1e-3)
        assert np.abs(np.subtract(line["start"], ref["start"])).max() <= 1e-3
        assert np.abs(np.subtract(line["end"], ref["end"])).max() <= 1e-3


@pytest.mark.parametrize("slope", [0.0, 3.0, 20.0])
def test_bending_lines_are_spaced_across_the_rulings_where_a_corner_cuts_them(slope):
    """A flat strip of parallel rulings x = const, its first metre cut obliquely (the kept
    rulings run from y = 0 to y = slope x there, then to 2 + slope): the kept rulings'
    middles slide along the rulings in that corner, which moves no line. The lines must be
    `spacing` apart across the rulings, i.e. at x = m + k spacing with equal margins m, and
    none of them shortened but by the corner (spaced along the middles' path they came
    1 / sqrt(1 + slope^2 / 4) of the spacing apart in the corner)."""
    from pipeline.shop.bending import lines_on_rulings

    length, spacing, corner = 6.0, 0.4, 1.0
    x = np.linspace(0.0, length, 601)
    top = np.where(x < corner, slope * x, slope * corner) + 2.0
    a2, b2 = np.column_stack([x, np.zeros_like(x)]), np.column_stack([x, top])
    a3, b3 = np.column_stack([a2, np.zeros_like(x)]), np.column_stack([b2, np.zeros_like(x)])
    normals = np.tile([0.0, 0.0, 1.0], (len(x), 1))
    lines, across = lines_on_rulings(a2, b2, a3, b3, normals, spacing)
    count = int(np.floor(length / spacing))
    margin = 0.5 * (length - (count - 1) * spacing)
    assert across == pytest.approx(length, abs=1e-12)
    assert len(lines) == count
    xs = np.array([line.a[0] for line in lines])
    np.testing.assert_allclose(xs, margin + spacing * np.arange(count), rtol=0, atol=1e-12)
    np.testing.assert_allclose([line.b[0] for line in lines], xs, rtol=0, atol=1e-12)
    np.testing.assert_allclose([line.station for line in lines], xs, rtol=0, atol=1e-12)
    assert all(np.isinf(line.radius) for line in lines)


def test_hull_plate_bending_lines_are_the_spacing_apart_across_them(tmp_path):
    """The hull plate cut by two butt planes (above): where a butt plane cuts its rulings,
    their kept middles slide along them. Every two neighbouring lines are the spacing apart
    across them, at their middles (to the rulings' fanning: 1 %)."""
    from pipeline.hull.plan import load_run
    from pipeline.hull.plates import run_part

    config = _strake_config(tmp_path, "corner", {"iges": str(SHIP / "test_1_hull_exported.igs")},
                            [{"iso": {"v": 4.05}}, {"iso": {"v": 4.1}}], [96000, 104000], fit=4.0)
    config.write_text(yaml.safe_dump(dict(yaml.safe_load(config.read_text()), shop={"no_roll_radius": 1e9})))
    plan = load_run(config)
    result = run_part(plan.parts[0], plan)
    bending = result.figures["bending"]
    lines = bending["lines"]
    assert len(lines) >= 10
    gaps = []
    for one, two in itertools.pairwise(lines):
        a, b = np.asarray(one["start"]), np.asarray(one["end"])
        u = (b - a) / np.linalg.norm(b - a)
        offset = 0.5 * (np.asarray(two["start"]) + np.asarray(two["end"])) - a
        gaps.append(abs(u[0] * offset[1] - u[1] * offset[0]))
    np.testing.assert_allclose(gaps, bending["spacing"], rtol=0.01)
