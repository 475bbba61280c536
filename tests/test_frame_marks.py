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
