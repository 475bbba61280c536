"""Curve sources: IGES (126, iso-curves of 128, units), DXF splines and polylines, point fits."""

import json
from pathlib import Path

import ezdxf
import numpy as np
import pytest
import yaml

from flatten import nurbs_curve
from pipeline.cli import main
from pipeline.io.iges import read_iges
from pipeline.io.meshio import read_obj
from pipeline.io.sources import fit_points

ROOT = Path(__file__).resolve().parents[1]
SHIP = ROOT / "tests" / "data" / "ship"


def run_config(tmp_path, data, name="part"):
    config = tmp_path / f"{name}.yaml"
    config.write_text(yaml.safe_dump(data))
    return main(["run", str(config), "--out", str(tmp_path / "out"), "--quiet"]), config


def test_napa_bilge_plate_develops_into_the_25_8_by_2_199205_m_rectangle(tmp_path):
    out = tmp_path / "out"
    assert main(["run", str(ROOT / "configs" / "napa_bilge.yaml"), "--out", str(out), "--quiet"]) == 0
    rep = json.loads((out / "napa_bilge.json").read_text())
    _, vt, _ = read_obj(out / "napa_bilge.obj")
    m = rep["resolution"]["samples_per_ruling"]
    a, b = vt[0::m], vt[m - 1::m]  # developed seams (the quarter circles)
    rulings = b - a
    # every ruling (a generator) is 25.8 m long and parallel to the others
    np.testing.assert_allclose(np.linalg.norm(rulings, axis=1), 25800.0, atol=0.02)  # file rounding: 6 mm / 129 m
    direction = rulings / np.linalg.norm(rulings, axis=1)[:, None]
    assert np.abs(direction @ direction[0] - 1).max() <= 1e-12
    # the developed seam is a straight line across them, 2.199205 m long (arc of the cubic Bezier quarter circle)
    across = np.array([-direction[0, 1], direction[0, 0]])
    along = (a - a[0]) @ direction[0]
    assert np.abs(along).max() <= 1e-3  # 0.3 um: the file gives its poles to 1e-6 m
    # the poles are given to 1 um: the exact strip of these slightly imperfect arcs starts
    # 1.6e-6 into c (3.7 um of its length), so the rectangle holds to a few micrometres
    assert np.ptp(a @ across) == pytest.approx(2199.205, abs=5e-3)
    assert np.ptp(a @ across) == pytest.approx(rep["coverage"]["c_length"], rel=1e-12)
    assert rep["coverage"]["c_fraction"] == pytest.approx(1.0, abs=1e-5)
    assert rep["steel"]["area_m2"] == pytest.approx(25.79999 * 2.199205, rel=1e-5)  # chord mesh, 0.5 mm


def test_iges_units_and_entity_126(tmp_path):
    iges = read_iges(SHIP / "test_1_deck.igs")
    assert iges.unit_mm == 1000.0 and iges.unit_name.upper() == "M"
    hull = read_iges(SHIP / "test_1_hull_exported.igs")
    assert [e.type for e in hull.of_type(128)] == [128]
    # the deck line (metres in the file) read into a config in mm, against a hull iso-curve
    data = {"name": "deck_strake", "units": "mm", "check": {"min_coverage": 0.0},
            "curves": {"c": {"iges": str(SHIP / "test_1_deck.igs"), "entity": 0},
                       "d": {"iges": str(SHIP / "test_1_hull_exported.igs"), "iso": {"v": 3.0}}}}
    config = tmp_path / "deck.yaml"
    config.write_text(yaml.safe_dump(data))
    from pipeline.config import load_config
    part = load_config(config).parts[0]
    deck = part.c(np.linspace(*part.c.domain, 7))
    np.testing.assert_allclose(deck[:, 2], 10000.0, atol=1e-6)  # z = 10 m
    assert 150_000 < part.c.length < 170_000  # a 160 m ship's sheer line, in mm
    assert np.ptp(part.d.control_points[:, 0]) > 100_000


def test_dxf_spline_is_taken_exactly_and_a_polyline_is_fitted(tmp_path):
    curve = nurbs_curve([[0, 0, 0], [300, 200, 0], [700, -100, 50], [1000, 100, 0], [1400, 0, 0]], 3,
                        weights=[1, 0.8, 1.3, 1, 1])
    doc = ezdxf.new("R2000")
    msp = doc.modelspace()
    spline = msp.add_rational_spline(curve.control_points.tolist(), curve.weights.tolist(), degree=3,
                                     dxfattribs={"layer": "SEAM_C"})
    spline.knots = curve.knots.tolist()
    t = np.linspace(0, 1, 60)
    msp.add_lwpolyline([tuple(p[:2]) for p in curve(t)], dxfattribs={"layer": "SEAM_D", "elevation": 0.0})
    path = tmp_path / "seams.dxf"
    doc.saveas(path)
    from pipeline.config import load_config
    data = {"name": "p", "curves": {"c": {"dxf": "seams.dxf", "layer": "SEAM_C"},
                                    "d": {"dxf": "seams.dxf", "layer": "SEAM_D", "tolerance": 0.05}}}
    config = tmp_path / "p.yaml"
    config.write_text(yaml.safe_dump(data))
    part = load_config(config).parts[0]
    np.testing.assert_allclose(part.c(t), curve(t), atol=1e-9)
    fit = part.fits["curves.d"]
    assert fit.max_error <= 0.05 and fit.points == 60


def test_point_list_fit_meets_its_tolerance():
    s = np.linspace(0, 1, 40)
    pts = np.column_stack([1000 * s, 200 * np.sin(3 * s), 50 * s**2])
    for tol in (1.0, 0.01):
        curve, report = fit_points(pts, tol, "offsets")
        assert report.max_error <= tol
        # the curve passes within the tolerance of every offset point
        dense = curve(np.linspace(*curve.domain, 4001))
        gaps = np.min(np.linalg.norm(dense[None] - pts[:, None], axis=2), axis=1)
        assert gaps.max() <= tol + 0.5  # dense sampling step of the check itself
    assert fit_points(pts, 0.01, "x")[1].control_points >= fit_points(pts, 1.0, "x")[1].control_points



def test_a_point_fit_is_judged_by_its_own_check_not_fitpacks_warnings():
    """Noisy offsets at a tight tolerance: FITPACK's smoothing iteration runs out (it warns
    "the maximal number of iterations maxit ... reached" and returns its best spline); the
    fit judges every spline by its points' distances, so nothing reaches the console and
    the curve still meets the tolerance."""
    import warnings

    from scipy.interpolate import make_splprep

    rng = np.random.default_rng(0)
    s = np.linspace(0.0, 1.0, 161)
    pts = np.column_stack([1000 * s, 50 * np.sin(3 * s) + rng.normal(0.0, 0.1, len(s)), rng.normal(0.0, 1e-4, len(s))])
    with warnings.catch_warnings(record=True) as raw:  # the fit's smoothing factors, lowered in turn
        warnings.simplefilter("always")
        for k in range(60):
            spline, u = make_splprep(pts.T, k=3, s=len(pts) * 1e-4**2 * 0.25**k)
            if np.linalg.norm(spline(u).T - pts, axis=1).max() <= 1e-4:
                break
    assert any(issubclass(w.category, RuntimeWarning) for w in raw)  # FITPACK does warn on the way
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        curve, report = fit_points(pts, 1e-4, "offsets")
    assert report.max_error <= 1e-4
    assert np.abs(curve(np.linspace(*curve.domain, 5))).max() < 1e4

BAD = [
    ({"iges": "missing.igs"}, ["missing.igs", "cannot read"]),
    ({"iges": str(SHIP / "ship_part4.igs"), "entity": 3}, ["entity-126 curve", "index 3"]),
    ({"iges": str(SHIP / "ship_part4.igs"), "directory": 99, "iso": {"u": 0}}, ["D99", "entity-128"]),
    ({"iges": str(SHIP / "ship_part4.igs"), "directory": 3, "iso": {"u": 7}}, ["iso.u = 7", "outside"]),
    ({"iges": str(ROOT / "README.md")}, ["README.md", "not an IGES"]),
    ({"dxf": "nothing.dxf", "layer": "0"}, ["nothing.dxf", "cannot read"]),
    ({"points": [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], "tolerance": -1}, ["tolerance", "-1"]),
]


@pytest.mark.parametrize("source, expected", BAD, ids=[str(i) for i in range(len(BAD))])
def test_bad_sources_exit_2_naming_file_and_entity(tmp_path, capsys, source, expected):
    data = {"name": "p", "curves": {"c": source, "d": {"iges": str(SHIP / "ship_part4.igs"), "directory": 3,
                                                       "iso": {"v": 1}}}}
    code, _ = run_config(tmp_path, data)
    err = capsys.readouterr().err
    assert code == 2, err
    for piece in expected:
        assert piece in err, (piece, err)
    assert not (tmp_path / "out").exists()


def test_plane_section_of_a_hull_surface_is_fitted_within_tolerance(tmp_path):
    from pipeline.config import load_config
    from pipeline.io.iges import iges_surface
    data = {"name": "p", "units": "mm",
            "curves": {"c": {"iges": str(SHIP / "test_1_hull_exported.igs"), "section":
                             {"point": [0, 0, 2000], "normal": [0, 0, 1]}, "tolerance": 1.0},
                       "d": {"iges": str(SHIP / "test_1_hull_exported.igs"), "section":
                             {"point": [0, 0, 6000], "normal": [0, 0, 1]}, "tolerance": 1.0}}}
    config = tmp_path / "wl.yaml"
    config.write_text(yaml.safe_dump(data))
    part = load_config(config).parts[0]
    # waterlines: every point of the fitted curves at z = 2 m and 6 m, within the tolerance
    for curve, z in ((part.c, 2000.0), (part.d, 6000.0)):
        pts = curve(np.linspace(*curve.domain, 200))
        assert np.abs(pts[:, 2] - z).max() <= 1.0
        assert np.ptp(pts[:, 0]) > 100_000
    assert part.fits["curves.c"].max_error <= 1.0
    # and the section points themselves lie on the surface and in the plane (exact roots)
    iges = read_iges(SHIP / "test_1_hull_exported.igs")
    surface = iges_surface(iges, iges.of_type(128)[0], 1000.0, "hull")
    points = surface.plane_section_points([0, 0, 2000], [0, 0, 1])
    np.testing.assert_allclose(points[:, 2], 2000.0, atol=1e-6)


def test_point_sources_report_their_fit_error(tmp_path):
    s = np.linspace(0, 1, 25)
    c = np.column_stack([3000 * s, 400 * np.sin(2 * s), 0 * s]).tolist()
    d = np.column_stack([3000 * s, 400 * np.sin(2 * s) + 100, 0 * s + 1500]).tolist()
    data = {"name": "offsets", "curves": {"c": {"points": c, "tolerance": 0.2}, "d": {"points": d, "tolerance": 0.2}}}
    code, _ = run_config(tmp_path, data, "offsets")
    assert code == 0
    rep = json.loads((tmp_path / "out" / "offsets.json").read_text())
    for key in ("curves.c", "curves.d"):
        fit = rep["curve_fits"][key]
        assert fit["points"] == 25 and fit["max_error"] <= 0.2 and fit["tolerance"] == 0.2
