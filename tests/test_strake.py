"""Hull strakes: plates between seams and butts, trimmed, fitted to the hull, marked."""

import csv
import json
from pathlib import Path

import ezdxf
import numpy as np
import pytest
import yaml

from pipeline.cli import main
from pipeline.io.meshio import read_obj

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "hullmod_strake.yaml"


@pytest.fixture(scope="module")
def strake(tmp_path_factory):
    out = tmp_path_factory.mktemp("strake")
    assert main(["run", str(CONFIG), "--out", str(out), "--quiet"]) == 0
    spec = yaml.safe_load(CONFIG.read_text())["strake"]
    return out, spec


def plate_names(spec):
    return [f"hullmod_S{i + 1}_B{j + 1}" for i in range(len(spec["seams"]) - 1)
            for j in range(len(spec["butts"]) - 1)]


def test_every_plate_fits_the_hull_and_stays_between_its_butts(strake):
    out, spec = strake
    names = plate_names(spec)
    assert len(names) == 10
    for name in names:
        rep = json.loads((out / f"{name}.json").read_text())
        assert rep["status"] == "ok"
        fit = rep["hull_fit"]
        assert fit["passed"] and fit["max_distance"] <= spec["fit_tolerance"]
        assert rep["plate_coverage"]["c"] == pytest.approx(1.0) and rep["plate_coverage"]["d"] == pytest.approx(1.0)
        # complete: the cut plate holds the four corners of its region on the hull (exact
        # corner rulings, kept by the trim) and every point of the region
        assert rep["plate_class"]["class"] == "developable" and rep["completeness"]["passed"]
        assert max(rep["completeness"]["corner_gaps"]) <= 1e-6
        assert rep["completeness"]["max_region_gap"] <= spec["fit_tolerance"]
        planes = rep["trim"]["butt_planes"]
        assert [p["normal"] for p in planes] == [[1.0, 0.0, 0.0]] * 2
        x_lo, x_hi = (p["offset"] for p in planes)
        v, vt, _ = read_obj(out / f"{name}.obj")
        assert v[:, 0].min() >= x_lo - 1e-6 and v[:, 0].max() <= x_hi + 1e-6
        # trimmed rulings keep their length in the flat pattern
        m = rep["resolution"]["samples_per_ruling"]
        l3 = np.linalg.norm(v[m - 1::m] - v[0::m], axis=1)
        l2 = np.linalg.norm(vt[m - 1::m] - vt[0::m], axis=1)
        assert np.abs(l3 - l2).max() <= 1e-9 * l3.max()
        # and the report says so (round-off of coordinates of ~1e5 mm): corner rulings cut
        # to a point are no relative error (they read 0.1-1.4)
        assert rep["unroll"]["ruling_edge_max_relative_error"] <= 1e-10
        assert rep["unroll"]["ruling_edge_max_abs_error"] <= 1e-9 * l3.max()


def test_neighbouring_plates_meet_at_their_butt(strake):
    out, spec = strake
    for i in range(len(spec["seams"]) - 1):
        for j in range(len(spec["butts"]) - 2):
            left, _, _ = read_obj(out / f"hullmod_S{i + 1}_B{j + 1}.obj")
            right, _, _ = read_obj(out / f"hullmod_S{i + 1}_B{j + 2}.obj")
            x = spec["butts"][j + 1]
            # the corners on both seams at the butt plane are shared (exact corner rulings)
            for corner in (left[np.abs(left[:, 0] - x) < 1e-6],):
                assert len(corner) >= 2
                gaps = np.min(np.linalg.norm(corner[:, None] - right[None], axis=2), axis=1)
                assert np.sort(gaps)[:2].max() <= 1e-6


def test_frame_lines_butt_and_seam_names_are_marked(strake):
    out, spec = strake
    rep = json.loads((out / "hullmod_S1_B2.json").read_text())
    frames = rep["trim"]["frames"]
    assert frames == [x for x in np.arange(0, 200000, spec["frames"]["spacing"]) if 72000 < x < 88000]
    doc = ezdxf.readfile(out / "hullmod_S1_B2.dxf")
    msp = doc.modelspace()
    assert len(msp.query("LWPOLYLINE[layer=='MARK_FRAME']")) == len(frames)
    texts = " ".join(t.dxf.text for t in msp.query("TEXT"))
    for word in ("SEAM 1", "SEAM 2", "BUTT 2", "BUTT 3", "PART hullmod_S1_B2", "THK 14 MM", "AH36", "WEIGHT"):
        assert word in texts
    assert len(doc.audit().errors) == 0


def test_run_summary_csv_json_and_pictures(strake):
    out, spec = strake
    rows = list(csv.DictReader((out / "hullmod_summary.csv").open()))
    assert [r["id"] for r in rows] == plate_names(spec)
    assert all(r["status"] == "ok" and float(r["max_hull_deviation"]) <= 5.0 for r in rows)
    summary = json.loads((out / "hullmod_summary.json").read_text())
    assert summary["schema_version"] == "1.0" and summary["failed"] == []
    assert (out / "hullmod_hull.png").stat().st_size > 0 and (out / "hullmod_sheet.png").stat().st_size > 0


def test_plate_previews_are_opt_in_for_a_strake(strake, tmp_path, capsys):
    """By default a strake's plates get no PNG previews (the run's sheet and hull pictures and
    each plate's shop drawing stay); ``output.part_previews: true`` draws them."""
    out, spec = strake
    names = plate_names(spec)
    assert not list(out.glob("*_flat.png")) and not list(out.glob("*_solutions.png"))
    assert all((out / f"{name}_drawing.pdf").exists() for name in names)
    assert not [f for name in names for f in json.loads((out / f"{name}.json").read_text())["files"]
                if f.endswith(".png")]
    data = yaml.safe_load(CONFIG.read_text())
    data["strake"]["surface"]["iges"] = str(ROOT / "tests" / "data" / "ship" / "test_1_hull_exported.igs")
    data["strake"]["butts"] = data["strake"]["butts"][:2]  # two plates
    data["output"] = {"part_previews": True}
    config = tmp_path / "previews.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    for name in ("hullmod_S1_B1", "hullmod_S2_B1"):
        report = json.loads((tmp_path / "o" / f"{name}.json").read_text())
        for image in (f"{name}_flat.png", f"{name}_solutions.png"):
            assert image in report["files"] and (tmp_path / "o" / image).read_bytes()[:4] == b"\x89PNG"
    data["output"] = {"part_previews": True, "png": False}
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "p"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "output" in err and "part_previews: true needs png: true" in err and str(config) in err
    assert not (tmp_path / "p").exists()


def test_parallel_run_gives_the_same_plates(strake, tmp_path):
    out, spec = strake
    assert main(["run", str(CONFIG), "--out", str(tmp_path), "--quiet", "--jobs", "2"]) == 0
    for name in plate_names(spec):  # bit-identical: workers compute exactly what one process does
        assert (out / f"{name}.json").read_bytes() == (tmp_path / f"{name}.json").read_bytes()
    assert (out / "hullmod_summary.json").read_bytes() == (tmp_path / "hullmod_summary.json").read_bytes()


def test_plates_off_the_hull_are_delivered_from_their_hull_patch(tmp_path):
    data = yaml.safe_load(CONFIG.read_text())
    data["strake"]["surface"]["iges"] = str(ROOT / "tests" / "data" / "ship" / "test_1_hull_exported.igs")
    data["strake"]["fit_tolerance"] = 0.1  # only the flatter plates' strips fit
    config = tmp_path / "tight.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    summary = json.loads((tmp_path / "o" / "hullmod_summary.json").read_text())
    assert summary["failed"] == []
    methods = set()
    for row in summary["parts"]:
        assert (tmp_path / "o" / f"{row['id']}.dxf").exists()
        rep = json.loads((tmp_path / "o" / f"{row['id']}.json").read_text())
        klass = rep["plate_class"]
        if klass["method"].startswith("devflat strip"):
            methods.add("strip")
            assert klass["class"] == "developable" and rep["hull_fit"]["max_distance"] <= 0.1
            continue
        # the strip between the same seams misses the hull by more than the tolerance
        assert "deviates from the hull" in klass["strip_not_delivered_because"]
        assert klass["strip_max_deviation"] > 0.1
        assert klass["misfit"] == pytest.approx(rep["strain"]["max_abs_strain"] * max(rep["region"]["length"],
                                                                                      rep["region"]["width"]))
        methods.add(klass["class"])
        # developable means devflat's strip fits: a patch is formed, rolled only when its strain allows
        assert klass["class"] == "formed" and klass["rolling_only"] == (klass["misfit"] <= 0.1)
        # roll lines were traced; the roll set-up keeps those below the no-roll radius (these
        # side plates' radii are tens of metres, above 8927 mm for 14 mm AH36: none is rolled)
        rolling = rep["forming"]["rolling"]
        assert rep["forming"]["roll_lines"] + rolling["lines_not_rolled"] >= 2
        assert all(r < rolling["no_roll_radius"] for r in rep["forming"]["roll_line_radii"])
        assert rep["forming"]["roll_lines"] > 0 or rolling["smallest_radius"] >= rolling["no_roll_radius"]
    assert methods == {"strip", "formed"}


def test_dtmb5415_plates(tmp_path):
    assert main(["run", str(ROOT / "configs" / "dtmb5415_strake.yaml"), "--out", str(tmp_path), "--quiet"]) == 0
    summary = json.loads((tmp_path / "dtmb5415_summary.json").read_text())
    assert len(summary["parts"]) == 3
    assert all(r["max_hull_deviation"] <= 1.0 for r in summary["parts"])


def test_slanted_butt_planes(tmp_path):
    data = yaml.safe_load(CONFIG.read_text())
    data["strake"]["surface"]["iges"] = str(ROOT / "tests" / "data" / "ship" / "test_1_hull_exported.igs")
    data["strake"]["seams"] = data["strake"]["seams"][:2]
    normal = [1.0, 0.0, 0.3]
    data["strake"]["butts"] = [{"point": [x, 0.0, 0.0], "normal": normal} for x in (72000.0, 88000.0, 104000.0)]
    config = tmp_path / "slanted.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    n = np.array(normal) / np.linalg.norm(normal)
    plates = []
    for j, (x_lo, x_hi) in enumerate(((72000.0, 88000.0), (88000.0, 104000.0))):
        v, _, _ = read_obj(tmp_path / "o" / f"hullmod_S1_B{j + 1}.obj")
        s = v @ n
        assert s.min() >= n[0] * x_lo - 1e-6 and s.max() <= n[0] * x_hi + 1e-6
        rep = json.loads((tmp_path / "o" / f"hullmod_S1_B{j + 1}.json").read_text())
        assert rep["hull_fit"]["passed"]
        plates.append(v)
    # the shared butt: corner points of both plates on the slanted plane coincide
    on_left = plates[0][np.abs(plates[0] @ n - n[0] * 88000.0) < 1e-6]
    gaps = np.min(np.linalg.norm(on_left[:, None] - plates[1][None], axis=2), axis=1)
    assert len(on_left) >= 2 and np.sort(gaps)[:2].max() <= 1e-6


def test_a_given_curve_as_seam_the_deck_line(tmp_path):
    ship = ROOT / "tests" / "data" / "ship"
    data = {"name": "sheer", "units": "mm", "resolution": {"chord_tolerance": 1.0},
            "strake": {"surface": {"iges": str(ship / "test_1_hull_exported.igs")},
                       "seams": [{"iso": {"v": 5.7}}, {"curve": {"iges": str(ship / "test_1_deck.igs")}}],
                       "butts": [56000, 72000, 88000], "margin": 0.2, "fit_tolerance": 5.0}}
    config = tmp_path / "sheer.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    rows = json.loads((tmp_path / "o" / "sheer_summary.json").read_text())["parts"]
    assert [r["status"] for r in rows] == ["ok", "ok"]
    assert all(r["max_hull_deviation"] <= 5.0 for r in rows)
    # the top edge of the sheer strake is the deck line, z = 10 m. S1_B1 is a strip whose
    # rulings run so obliquely that the butt planes cut most of them below it: nothing of
    # it goes above the deck line
    v, _, _ = read_obj(tmp_path / "o" / "sheer_S1_B1.obj")
    rep = json.loads((tmp_path / "o" / "sheer_S1_B1.json").read_text())
    assert rep["plate_class"]["class"] == "developable"
    m = rep["resolution"]["samples_per_ruling"]
    assert v[m - 1::m, 2].max() <= 10000.0 + 1e-6
    # S1_B2 (once a strip too) lies within 5 mm of its minimax plane though 7.8 mm off its
    # least-squares one: flat, its mesh the region itself, whose top row is the deck line
    rep = json.loads((tmp_path / "o" / "sheer_S1_B2.json").read_text())
    flat = rep["plate_class"]
    assert flat["class"] == "flat" and flat["plane_max_distance"] <= 5.0 < flat["least_squares_max_distance"]
    v, _, _ = read_obj(tmp_path / "o" / "sheer_S1_B2.obj")
    grid = v.reshape(*rep["region"]["grid"], 3)
    assert grid[..., 2].max() <= 10000.0 + 1e-6
    np.testing.assert_allclose(grid[-1, :, 2], 10000.0, atol=1e-6)
