"""The two families of rulings of a hull plate: seam to seam (between its seams) or butt to
butt (between its butt sections, trimmed by the seams). Closed-form surfaces where only one
family is right, and a real hull plate."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.cli import main
from tests.hull_shapes import cone_iges, cylinder_along_iges

SHIP = Path(__file__).parent / "data" / "ship"


def run_strake(tmp_path, strake: dict, name="t") -> tuple[int, Path]:
    config = tmp_path / f"{name}.yaml"
    config.write_text(yaml.safe_dump({"name": name, "units": "mm", "strake": strake}))
    out = tmp_path / "out"
    return main(["run", str(config), "--out", str(out)]), out


def report(out: Path, name: str) -> dict:
    return json.loads((out / f"{name}.json").read_text())


def test_a_bilge_cylinder_with_seams_along_its_generators_is_developed_butt_to_butt(tmp_path):
    """A cylinder of axis x (the parallel midbody's bilge), seams along x: the strip between
    the seams is the plane through them (a chord across the bilge, 1 - cos of half the arc
    off), the strip between the butt sections is the cylinder. The development is the
    rectangle (butt distance) x (arc length between the seams)."""
    radius, x1, x2 = 3000.0, 3000.0, 15000.0
    iges = cylinder_along_iges(tmp_path / "bilge.igs", radius=radius, angle_deg=90.0, length=20000.0)
    code, out = run_strake(tmp_path, {"surface": {"iges": str(iges)}, "butts": [x1, x2],
                                      "seams": [{"iso": {"v": 0.2}}, {"iso": {"v": 0.8}}]})
    assert code == 0
    rep = report(out, "t_S1_B1")
    klass = rep["plate_class"]
    assert klass["class"] == "developable" and klass["family"] == "rulings butt to butt"
    assert klass["other_family"]["family"] == "rulings seam to seam"
    assert "deviates from the hull" in klass["other_family"]["rejected_because"]
    assert rep["hull_fit"]["max_distance"] < 1e-9 * radius * 10
    assert rep["completeness"]["passed"] and max(rep["completeness"]["corner_gaps"]) < 1e-8 * radius * 10
    # the seams' angles on the circle, from the corners of the region (closed form: the arc)
    corners = np.array(rep["region"]["corners"])
    theta = np.arctan2(corners[:, 1], radius - corners[:, 2])
    arc = radius * abs(theta[2] - theta[0])
    assert rep["outline"]["area_m2"] == pytest.approx((x2 - x1) * arc / 1e6, rel=1e-8)
    # (to 1e-8: the closest points are as exact as the solver's polished rulings, ~1e-9 relative)
    # the developed plate is that rectangle: its bounding box, placed along its seam
    from pipeline.io.meshio import read_obj

    _, vt, _ = read_obj(out / "t_S1_B1.obj")
    assert np.sort(np.ptp(vt, axis=0)) == pytest.approx(sorted([x2 - x1, arc]), rel=1e-8)
    # bending lines follow the rulings: along the plate (the butt distance long), radius R
    bends = rep["bending"]["lines"]
    assert bends and rep["bending"]["family"] == "rulings butt to butt"
    for line in bends:
        assert line["length"] == pytest.approx(x2 - x1, rel=1e-6)
        assert line["radius"] == pytest.approx(radius, rel=1e-3)


def test_a_cone_frustum_between_two_circles_keeps_its_rulings_seam_to_seam(tmp_path):
    """Seams along the circles of a cone frustum: the cone's generators cross from seam to
    seam, so the seam family fits exactly and is delivered; the butt sections (conics) give
    a worse strip or none."""
    iges = cone_iges(tmp_path / "cone.igs", r1=10000.0, r2=9000.0, height=3000.0)
    code, out = run_strake(tmp_path, {"surface": {"iges": str(iges)}, "butts": [-4000.0, 4000.0],
                                      "seams": [{"iso": {"v": 0.1}}, {"iso": {"v": 0.9}}]})
    assert code == 0
    rep = report(out, "t_S1_B1")
    klass = rep["plate_class"]
    assert klass["class"] == "developable" and klass["family"] == "rulings seam to seam"
    assert klass["other_family"]["family"] == "rulings butt to butt"
    assert rep["hull_fit"]["max_distance"] < 1e-6
    assert rep["completeness"]["passed"]


def test_a_midbody_bilge_plate_of_the_160m_hull_is_developable_butt_to_butt(tmp_path):
    """A 4 m bilge plate of the 160 m hull near midship: the chord across the bilge between
    its seams is far off the hull; the strip between its butt sections fits within 5 mm and
    its outline holds the four corners of the region."""
    strake = {"surface": {"iges": str(SHIP / "test_1_hull_exported.igs")}, "margin": 0.2,
              "seams": [{"iso": {"v": 1.69}}, {"iso": {"v": 2.28}}], "butts": [84000.0, 88000.0]}
    code, out = run_strake(tmp_path, strake, name="bilge")
    assert code == 0
    rep = report(out, "bilge_S1_B1")
    klass = rep["plate_class"]
    assert klass["class"] == "developable" and klass["family"] == "rulings butt to butt"
    seam = klass["other_family"]["rejected_because"]
    assert "deviates from the hull" in seam and float(seam.split("by ")[1].split()[0]) > 50.0
    assert rep["hull_fit"]["max_distance"] <= 5.0 and rep["completeness"]["passed"]
    assert max(rep["completeness"]["corner_gaps"]) <= rep["completeness"]["corner_tolerance"]
    # an independent check of the cut outline: its four corners are the developed region
    # corners, and its area is the hull region's within the strip's fit (5 mm on 3.6 m)
    assert rep["outline"]["area_m2"] == pytest.approx(rep["plate_class"]["area_3d_m2"], rel=5e-3)
    assert set(rep["outline"]["edges"]) == {"c", "d", "start", "end"}
