"""Pin-jig tables against a sphere and a real formed hull plate."""

import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.cli import main
from pipeline.shop.pinjig import pin_jig
from pipeline.shop.templates import grid_faces

ROOT = Path(__file__).resolve().parents[1]
SHIP = ROOT / "tests" / "data" / "ship"


def _cap(radius=10000.0, half=1200.0, n=121, tilt=0.3):
    """A square spherical cap (sphere of ``radius`` about the origin, |a|, |b| <= half around
    its top), turned by ``tilt`` radians about x so that no axis is the answer."""
    a, b = np.meshgrid(np.linspace(-half, half, n), np.linspace(-half, half, n), indexing="ij")
    pts = np.column_stack([a.ravel(), b.ravel(), np.sqrt(radius ** 2 - a.ravel() ** 2 - b.ravel() ** 2)])
    c, s = np.cos(tilt), np.sin(tilt)
    rot = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return pts @ rot.T, grid_faces(n, n), rot @ np.array([0.0, 0.0, 1.0])


def test_spherical_cap_pins_reach_the_sphere():
    """The assembly plane of a symmetric cap is square to its axis; every pin's top lies on
    the sphere (0.5 mm), its height is the sphere's height over the floor there (closed
    form), the lowest point of the cap (its corners) stands the shortest pin above the floor
    and every pin is at least that long."""
    radius = 10000.0
    vertices, faces, axis = _cap(radius)
    jig = pin_jig(vertices, faces, axis, [], 600.0, shortest=250.0)
    assert abs(jig.normal @ axis) == pytest.approx(1.0, abs=1e-6)
    assert len(jig.heights) >= 9 and jig.heights.min() >= 250.0
    assert np.abs(np.linalg.norm(jig.tops, axis=1) - radius).max() <= 0.5
    # closed form: floor at the corners' height minus 250 along the axis
    corner = np.sqrt(radius ** 2 - 2 * 1200.0 ** 2)
    feet = jig.origin + jig.pins @ jig.axes
    rho2 = np.sum(feet ** 2, axis=1) - (feet @ axis) ** 2
    expected = np.sqrt(radius ** 2 - rho2) - (corner - 250.0)
    assert np.abs(jig.heights - expected).max() <= 0.5
    assert jig.extent == pytest.approx(radius - corner + 250.0, abs=1e-6)
    # check points: the cap's four corners, its lowest points, the shortest pin above the floor
    assert len(jig.checks) == 4 and np.allclose(jig.check_heights, 250.0, atol=1e-6)
    c, s = np.cos(0.3), np.sin(0.3)
    unturned = jig.checks @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])  # back about x: the cap's own axes
    assert np.allclose(np.abs(unturned[:, :2]), 1200.0)
    assert jig.csv().count("\n") == len(jig.heights) + 4 + 1


def test_formed_hull_plate_pin_jig_table(tmp_path):
    """A formed (doubly curved) DTMB 5415 plate at ship scale: NAME_pinjig.csv lists its
    pins, every one at least 250 mm long, their tops on the hull (each on its frame's plane
    x = X and within 0.5 mm of the hull's own section there)."""
    from tests.test_templates import _distance_to_polyline, _hull_section

    data = {"name": "dt", "units": "mm", "steel": {"thickness": 14, "material": "AH36"},
            "strake": {"surface": {"iges": str(SHIP / "ship_5415.igs"), "directory": 5},
                       "seams": [{"iso": {"v": 2.0}}, {"iso": {"v": 2.4}}], "butts": [40000.0, 54000.0],
                       "scale": 24.824, "frames": {"spacing": 2500}, "margin": 0.2},
            "shop": {"pin_spacing": 400}}
    path = tmp_path / "dt.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "o"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    rep = json.loads((out / "dt_S1_B1.json").read_text())
    assert rep["plate_class"]["class"] == "formed"
    table = list(csv.DictReader(io.StringIO((out / "dt_S1_B1_pinjig.csv").read_text())))
    rows = [r for r in table if r["row"] != "CHECK CORNER"]
    corners = [r for r in table if r["row"] == "CHECK CORNER"]
    assert len(rows) == rep["pinjig"]["pins"] >= 10 and len(corners) == 4
    # the corners lie on the butts (x 40 and 54 m), the lowest one the shortest pin above the floor
    assert sorted(round(float(r["top_x_mm"])) for r in corners) == [40000, 40000, 54000, 54000]
    assert min(float(r["height_mm"]) for r in corners) == pytest.approx(250.0, abs=0.05)
    heights = np.array([float(r["height_mm"]) for r in rows])
    assert heights.min() >= 250.0 - 0.05  # the table's 0.1 mm rounding
    from pipeline.hull.plan import load_run

    surface = load_run(path).parts[0].hull.surface
    for frame in sorted({r["row"] for r in rows}):
        x = float(frame.split()[1])
        tops = np.array([[float(r[k]) for k in ("top_x_mm", "top_y_mm", "top_z_mm")]
                         for r in rows if r["row"] == frame])
        assert np.abs(tops[:, 0] - x).max() <= 0.05
        tops[:, 0] = x
        assert _distance_to_polyline(tops, _hull_section(surface, x, np.linspace(1.95, 2.45, 401))).max() <= 0.5
