"""End to end: YAML config -> DXF, OBJ, JSON, PNG; checked against closed forms."""

from pathlib import Path

import ezdxf
import numpy as np
import shapely
import pytest
import yaml
from scipy.integrate import quad

from pipeline.cli import main
from pipeline.io.meshio import read_obj
from tests import oracles

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"


def run(config: Path, out: Path) -> int:
    return main(["run", str(config), "--out", str(out), "--quiet"])


def report(out: Path, name: str) -> dict:
    import json
    return json.loads((out / f"{name}.json").read_text())


def curve_yaml(curve) -> dict:
    return {"degree": int(curve.degree), "control_points": curve.control_points.tolist(),
            "weights": curve.weights.tolist(), "knots": curve.knots.tolist()}


def write_config(path: Path, name: str, c, d, **extra) -> Path:
    data = {"name": name, "units": "mm", "curves": {"c": curve_yaml(c), "d": curve_yaml(d)}}
    data.update(extra)
    path.write_text(yaml.safe_dump(data))
    return path


def pairwise(points: np.ndarray) -> np.ndarray:
    return np.linalg.norm(points[:, None, :] - points[None, :, :], axis=-1)


def test_frustum_unrolls_to_the_annular_sector_with_ten_rulings(tmp_path):
    assert run(CONFIGS / "frustum.yaml", tmp_path) == 0
    r1, r2, h, angle = 3000.0, 2000.0, 1500.0, 2 * np.pi / 3
    s = np.hypot(r1 - r2, h)
    rho1, rho2, sector = r1 * s / (r1 - r2), r2 * s / (r1 - r2), angle * (r1 - r2) / s
    v, vt, f = read_obj(tmp_path / "frustum.obj")
    rep = report(tmp_path, "frustum")
    m = rep["resolution"]["samples_per_ruling"]
    assert rep["resolution"]["count"] == 10
    a, b = vt[0::m], vt[m - 1::m]
    apex = a + (b - a) * (rho1 / (rho1 - rho2))
    centre = apex.mean(axis=0)
    assert np.ptp(apex, axis=0).max() <= 1e-9 * rho1
    np.testing.assert_allclose(np.hypot(*(a - centre).T), rho1, rtol=1e-9)
    np.testing.assert_allclose(np.hypot(*(b - centre).T), rho2, rtol=1e-9)
    ends = a[[0, -1]] - centre
    swept = np.arccos(ends[0] @ ends[1] / (np.linalg.norm(ends[0]) * np.linalg.norm(ends[1])))
    assert swept == pytest.approx(sector, rel=1e-9)
    # the 3D vertices are on the frustum: c at radius r1, d at radius r2
    np.testing.assert_allclose(np.hypot(v[0::m, 0], v[0::m, 1]), r1, rtol=1e-12)


def test_cylinder_unrolls_to_the_expected_developed_shape(tmp_path):
    c, d = oracles.cylinder_pair()
    config = write_config(tmp_path / "cyl.yaml", "cyl", c, d, resolution={"rulings": 25})
    assert run(config, tmp_path) == 0
    v, vt, _ = read_obj(tmp_path / "cyl.obj")
    rep = report(tmp_path, "cyl")
    rulings = np.array(rep["rulings"])
    m = rep["resolution"]["samples_per_ruling"]
    axis = d.control_points[0] - c.control_points[0]
    unit = axis / np.linalg.norm(axis)

    def projected_speed(t):
        tangent = c.derivatives([t], 1)[1][0]
        return np.linalg.norm(tangent - (tangent @ unit) * unit)

    sigma = np.array([quad(projected_speed, rulings[0, 0], t, epsabs=1e-13, epsrel=1e-13, limit=200)[0]
                      for t in rulings[:, 0]])
    along = c(rulings[:, 0]) @ unit
    v_samples = np.linspace(0, 1, m)
    expected = np.stack([np.column_stack([sigma, along + s * np.linalg.norm(axis)]) for s in v_samples], axis=1)
    expected = expected.reshape(-1, 2)
    size = np.ptp(expected, axis=0).max()
    assert np.abs(pairwise(vt) - pairwise(expected)).max() <= 1e-9 * size


def test_obj_ruling_edges_keep_their_length_and_other_edges_match_the_chord_discrepancy(tmp_path):
    assert run(CONFIGS / "plate.yaml", tmp_path) == 0
    v, vt, faces = read_obj(tmp_path / "bilge_plate.obj")
    rep = report(tmp_path, "bilge_plate")
    m = rep["resolution"]["samples_per_ruling"]
    assert len(v) == len(vt) == rep["resolution"]["count"] * m
    k = np.arange(rep["resolution"]["count"])
    a, b = k * m, k * m + m - 1
    l3 = np.linalg.norm(v[b] - v[a], axis=1)
    l2 = np.linalg.norm(vt[b] - vt[a], axis=1)
    assert np.abs(l2 - l3).max() <= 1e-12 * l3.max()
    edges = np.unique(np.sort(np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1), axis=0)
    e3 = np.linalg.norm(v[edges[:, 1]] - v[edges[:, 0]], axis=1)
    e2 = np.linalg.norm(vt[edges[:, 1]] - vt[edges[:, 0]], axis=1)
    discrepancy = rep["unroll"]["chord_discrepancy_max_relative"]
    assert np.max(np.abs(e2 - e3) / e3) <= discrepancy * (1 + 1e-9)
    assert rep["unroll"]["ruling_edge_max_relative_error"] <= 1e-12
    # the strip is one disc (trimesh, vertex order kept) bounded by its two seams and end rulings
    mesh, k = rep["mesh"], rep["resolution"]["count"]
    assert mesh["vertices"] == len(v) and mesh["euler_number"] == 1
    assert mesh["boundary_edges"] == 2 * (k - 1) + 2 * (m - 1)
    assert mesh["area_3d"] == pytest.approx(rep["unroll"]["area_3d"], rel=1e-12)


def test_dxf_reads_back_with_layers_units_and_the_flat_outline(tmp_path):
    assert run(CONFIGS / "plate.yaml", tmp_path) == 0
    doc = ezdxf.readfile(tmp_path / "bilge_plate.dxf")
    assert doc.dxfversion == "AC1015"
    assert doc.header["$INSUNITS"] == 4
    assert {"CUT_OUTER", "MARK_BEND", "MARK_TEXT"} <= {layer.dxf.name for layer in doc.layers}
    assert len(doc.audit().errors) == 0
    msp = doc.modelspace()
    outlines = msp.query("LWPOLYLINE[layer=='CUT_OUTER']")
    assert len(outlines) == 1 and outlines[0].closed
    assert len(msp.query("SPLINE HATCH MTEXT")) == 0
    rep = report(tmp_path, "bilge_plate")
    # bending lines for the shop (not the solver's rulings), numbered
    assert len(msp.query("LINE[layer=='MARK_BEND']")) == rep["bending"]["count"] >= 2
    assert rep["bending"]["count"] != rep["resolution"]["count"]
    texts = " ".join(t.dxf.text for t in msp.query("TEXT[layer=='MARK_TEXT']"))
    assert "bilge_plate" in texts and "THK 12 MM" in texts and "S355" in texts
    pts = np.array([p[:2] for p in outlines[0].get_points("xy")])
    # the outline follows the exact developed boundary: the mesh's boundary vertices (exact
    # developed points on c and d, mm) lie on it within the outline tolerance
    _, vt, _ = read_obj(tmp_path / "bilge_plate.obj")
    m = rep["resolution"]["samples_per_ruling"]
    boundary = np.vstack([vt[0::m], vt[m - 1::m][::-1]])
    ring = shapely.LinearRing(pts)
    gaps = shapely.distance(shapely.points(boundary), ring)
    assert gaps.max() <= rep["outline"]["tolerance"] == 0.05
    assert rep["outline"]["max_deviation"] <= 0.05
    area = 0.5 * abs(np.dot(pts[:, 0], np.roll(pts[:, 1], -1)) - np.dot(pts[:, 1], np.roll(pts[:, 0], -1)))
    assert area / 1e6 == pytest.approx(rep["steel"]["area_m2"], rel=1e-9)


def test_naive_ruled_surface_fails_the_curvature_check_while_the_strip_passes(tmp_path):
    assert run(CONFIGS / "plate.yaml", tmp_path) == 0
    dev = report(tmp_path, "bilge_plate")["developability"]
    assert dev["passed"]
    assert dev["max_abs_K_times_size_squared"] <= dev["curvature_limit"]
    assert dev["naive_max_abs_K_times_size_squared"] > 100 * dev["curvature_limit"]
    assert dev["mesh"]["integrated_abs_angle_defect"] < 1e-3 * dev["naive_T_equals_t"]["integrated_abs_angle_defect"]
    assert dev["max_residual"] <= 1e-12


def test_failing_part_writes_its_report_and_no_dxf(tmp_path):
    assert run(CONFIGS / "c_against_mirror.yaml", tmp_path) == 1
    rep = report(tmp_path, "c_against_mirror")
    assert rep["status"] == "failed"
    assert "no acceptable strip" in rep["reason"]
    assert rep["solver"]["curvature_mismatches"]
    assert not (tmp_path / "c_against_mirror.dxf").exists()
    assert not (tmp_path / "c_against_mirror.obj").exists()


def test_flat_plate_config_runs(tmp_path):
    assert run(CONFIGS / "flat_plate.yaml", tmp_path) == 0
    rep = report(tmp_path, "flat_bottom_plate")
    assert rep["solver"]["kind"] == "coplanar"
    assert rep["unroll"]["ruling_edge_max_relative_error"] <= 1e-12
    assert rep["unroll"]["area_ratio"] == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("config", sorted(CONFIGS.glob("*.yaml")), ids=lambda p: p.name)
def test_every_example_config_runs(config, tmp_path):
    expected = 1 if "mirror" in config.name else 0
    assert main(["check", str(config)]) == 0
    if config.name.endswith("_shell.yaml"):
        return  # whole hulls (hundreds of plates) run in bench/bench_hull.py; check plans them here
    assert run(config, tmp_path) == expected
    assert list(tmp_path.glob("*.json"))
    assert not list(tmp_path.glob(".*.tmp"))


def test_multi_part_run_with_progress_and_summary(tmp_path, capsys):
    c1, d1 = oracles.frustum_pair()
    c2, d2 = oracles.cylinder_pair()
    data = {"units": "m", "resolution": {"rulings": 12}, "parts": [
        {"name": "p1", "curves": {"c": curve_yaml(c1), "d": curve_yaml(d1)}},
        {"name": "p2", "curves": {"c": curve_yaml(c2), "d": curve_yaml(d2)}, "steel": {"thickness": 20}}]}
    config = tmp_path / "two.yaml"
    config.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "p1" in captured.out and "p2" in captured.out and "status" in captured.out
    assert "2/2" in captured.err  # progress bar
    doc = ezdxf.readfile(out / "p2.dxf")
    assert "THK 20 MM" in " ".join(t.dxf.text for t in doc.modelspace().query("TEXT"))
    # units m: the DXF is in mm
    rep = report(out, "p1")
    pts = np.array(doc.modelspace().query("LWPOLYLINE")[0].get_points("xy"))
    assert np.ptp(pts[:, 0]) > 100  # metres scaled to millimetres
    assert rep["units"] == "m"


def test_the_last_line_says_where_the_files_went(tmp_path, capsys):
    c, d = oracles.frustum_pair()
    config = write_config(tmp_path / "cone.yaml", "cone", c, d, resolution={"rulings": 12})
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out)]) == 0
    written = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    assert "cone_summary.json" in written and "cone.dxf" in written
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last == f"wrote {len(written)} files to {out}/ (summary: {out}/cone_summary.json)"
    # quiet: nothing on stdout
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    assert capsys.readouterr().out == ""


def test_reversing_d_or_changing_units_gives_the_same_plate(tmp_path):
    base = yaml.safe_load((CONFIGS / "plate.yaml").read_text())
    variants = {"same": base}
    rev = yaml.safe_load(yaml.safe_dump(base))
    rev["curves"]["d"]["control_points"] = rev["curves"]["d"]["control_points"][::-1]
    variants["reversed"] = rev
    metres = yaml.safe_load(yaml.safe_dump(base))
    metres["units"] = "m"
    metres["resolution"]["chord_tolerance"] = base["resolution"]["chord_tolerance"] / 1000
    for key in ("c", "d"):
        metres["curves"][key]["control_points"] = [[x / 1000 for x in p] for p in base["curves"][key]["control_points"]]
    variants["metres"] = metres
    reports = {}
    for label, data in variants.items():
        data["name"] = label
        config = tmp_path / f"{label}.yaml"
        config.write_text(yaml.safe_dump(data))
        assert run(config, tmp_path) == 0
        reports[label] = report(tmp_path, label)
    assert reports["reversed"]["solver"]["path"]["orientation"] == -1
    for label in ("reversed", "metres"):
        assert reports[label]["steel"]["area_m2"] == pytest.approx(reports["same"]["steel"]["area_m2"], rel=1e-9)
        assert reports[label]["steel"]["weight_kg"] == pytest.approx(reports["same"]["steel"]["weight_kg"], rel=1e-9)
    outlines = {}
    for label in variants:
        pts = np.array(ezdxf.readfile(tmp_path / f"{label}.dxf").modelspace().query("LWPOLYLINE")[0].get_points("xy"))
        outlines[label] = np.sort(np.linalg.norm(pts - pts.mean(axis=0), axis=1))  # rigid-motion invariant
    np.testing.assert_allclose(outlines["metres"], outlines["same"], rtol=1e-9)
