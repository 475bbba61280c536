"""Every frame that crosses a hull plate is marked, end plates included (a frame on a butt
is the butt): a 12 m bilge cylinder (axis x, tests/hull_shapes.py) planned uniformly, frames
every 1000 mm from x = 250; which frames cross each plate is read independently off the
plate's own 3D mesh (its OBJ: the x range its vertices span)."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.cli import main
from tests.hull_shapes import cylinder_along_iges

SPACING, START = 1000.0, 250.0


def _x_range(obj: Path) -> tuple[float, float]:
    xs = [float(line.split()[1]) for line in obj.read_text().splitlines() if line.startswith("v ")]
    return min(xs), max(xs)


@pytest.fixture(scope="module")
def shell(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("frames")
    iges = cylinder_along_iges(tmp / "c.igs", radius=3000.0, angle_deg=60.0, length=12000.0)
    config = tmp / "cyl.yaml"
    config.write_text(yaml.safe_dump({
        "name": "cyl", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
        "strake": {"surface": {"iges": str(iges)}, "fit_tolerance": 5.0, "margin": 0.2,
                   "frames": {"spacing": SPACING, "start": START},
                   "plan": {"method": "uniform", "stock": {"max_length": 5000, "max_width": 3500,
                                                           "min_length": 2000, "min_width": 1000}}}}))
    out = tmp / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    return out


def test_every_frame_crossing_a_plate_is_marked_end_plates_included(shell):
    reports = {p.stem: json.loads(p.read_text()) for p in shell.glob("cyl_S*.json")}
    assert len(reports) >= 3
    ends = 0
    for name, rep in reports.items():
        lo, hi = _x_range(shell / f"{name}.obj")
        crossing = [START + k * SPACING for k in range(int(np.ceil((lo - START) / SPACING)),
                                                       int(np.floor((hi - START) / SPACING)) + 1)
                    if lo + 1.0 < START + k * SPACING < hi - 1.0]
        assert crossing, name
        marked = sorted(float(t.split()[1]) for t in rep["layout"]["frames_marked"])
        assert marked == crossing, (name, lo, hi)
        assert not [f for f in rep["layout"]["findings"] if "from a butt" in f], name
        ends += "HULL END" in json.dumps(rep)
    assert ends >= 2  # the plates at both ends of the hull are among them


def test_an_end_plate_reaches_as_far_as_its_surface_end_does_between_the_girth_lines():
    """A hull end whose edge bulges aft between two of the nine girth lines the end plate's
    x range is sampled on (a raised pole of the end row, at 1/16 of the girth): the range
    reaches the edge's true farthest x (a 20001-point search) within 0.01 mm; the nine lines
    alone stop short of it by more than 1 mm."""
    from flatten.plane import Plane
    from flatten.surface import nurbs_surface
    from pipeline.hull.region import Girth, plate_x_range

    nv = 17
    v = np.linspace(0.0, 1.0, nv)
    poles = np.zeros((2, nv, 3))
    poles[0, :, 0], poles[1, :, 0] = 0.0, 10000.0
    poles[:, :, 1] = 3000.0 * v
    poles[1, 1, 0] += 300.0  # the end edge bulges aft near v = 1/16
    knots_v = np.concatenate([[0.0] * 3, np.linspace(0.0, 1.0, nv - 2), [1.0] * 3])
    surface = nurbs_surface(1, 3, poles, [0, 0, 1, 1], knots_v, name="bulged end")
    girths = (Girth.iso(0.0), Girth.iso(1.0))
    lo, hi = plate_x_range((Plane((1.0, 0.0, 0.0), 5000.0), None), surface, 0, girths)
    truth = float(surface(np.ones(20001), np.linspace(0.0, 1.0, 20001))[:, 0].max())
    nine = float(surface(np.ones(9), np.linspace(0.0, 1.0, 9))[:, 0].max())
    assert lo == 5000.0 and abs(hi - truth) <= 0.01
    assert truth - nine > 1.0
