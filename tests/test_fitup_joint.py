"""The flat plates' planes chosen together (pipeline/hull/joint.py, strake.fit_up: follow).

Two flat plates of unequal length on a circular cylinder step from each other at their butt
by a closed form (each on its minimax plane, half its sagitta off the hull); on planes chosen
together they meet, each still within the fit tolerance of the cylinder itself (measured on
the exact cylinder, not on the plan's grid). Plates that meet already keep their planes; the
shoulder's twisted plates, which no planes within the tolerance bring within the limit, end
no worse than they began."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.hull.fitup import shell_fitup
from pipeline.hull.plan import load_run
from pipeline.hull.plates import evaluate_plate, run_part
from tests.hull_shapes import cylinder_iges
from tests.test_fitup_repair import shoulder

RADIUS, WIDTH, TOLERANCE, THICKNESS = 20000.0, 2000.0, 5.0, 14.0  # step limit min(0.15 t, 3) = 2.1 mm


def cylinder_strake(tmp_path: Path, butts, fit_up: str) -> Path:
    cylinder_iges(tmp_path / "cyl.igs", radius=RADIUS, angle_deg=10.0, width=WIDTH)
    path = tmp_path / f"cyl_{fit_up}.yaml"
    path.write_text(yaml.safe_dump({
        "name": "cyl", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False, "dxf": False},
        "steel": {"thickness": THICKNESS},
        "strake": {"surface": {"iges": "cyl.igs"}, "seams": [{"iso": {"v": 0.0}}, {"iso": {"v": 1.0}}],
                   "butts": list(butts), "margin": 0.2, "fit_tolerance": TOLERANCE, "fit_up": fit_up}}))
    return path


def run(path: Path):
    config = load_run(path, evaluate_plate)
    results = [run_part(part, config) for part in config.parts]
    assert all(r.ok for r in results)
    return config, results, shell_fitup(results, config)


def half_angle(x0: float, x1: float) -> float:
    """Half the arc angle of the cylinder between the planes x = x0 and x = x1 (x = R sin theta)."""
    return 0.5 * abs(np.arcsin(x1 / RADIUS) - np.arcsin(x0 / RADIUS))


def off_cylinder(plane_point, normal, x0: float, x1: float) -> float:
    """Largest distance of the cylinder between x0 and x1 from a plane: the exact surface,
    densely sampled (theta, y)."""
    theta = np.linspace(np.arcsin(x0 / RADIUS), np.arcsin(x1 / RADIUS), 2001)
    y = np.linspace(0.0, WIDTH, 21)
    t, yy = np.meshgrid(theta, y)
    points = np.stack([RADIUS * np.sin(t), yy, RADIUS * (1.0 - np.cos(t))], axis=-1).reshape(-1, 3)
    normal = np.asarray(normal) / np.linalg.norm(normal)
    return float(np.abs((points - np.asarray(plane_point)) @ normal).max())


@pytest.fixture(scope="module")
def unequal(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("joint")
    butts = (-1200.0, 0.0, 400.0)
    return butts, run(cylinder_strake(tmp, butts, "report")), run(cylinder_strake(tmp, butts, "follow"))


def test_two_flat_plates_of_unequal_length_step_by_their_half_sagittas(unequal):
    butts, (_, results, fit), _ = unequal
    assert [r.figures["plate_class"]["class"] for r in results] == ["flat", "flat"]
    a, b = half_angle(butts[0], butts[1]), half_angle(butts[1], butts[2])
    e_a, e_b = RADIUS * (1 - np.cos(a)) / 2, RADIUS * (1 - np.cos(b)) / 2  # each edge off the hull, outward
    step = np.sqrt(e_a ** 2 + e_b ** 2 - 2 * e_a * e_b * np.cos(a + b))  # along the two planes' normals
    assert len(fit.pairs) == 1
    pair = fit.pairs[0]
    assert pair.step_max == pytest.approx(step, abs=0.02) and pair.step_max > pair.limit  # 4.0 mm > 2.1 mm


def test_planes_chosen_together_meet_within_the_tolerance_of_the_cylinder(unequal):
    butts, (_, plain, _), (config, results, fit) = unequal
    report = config.fitup_follow
    assert report.misfits == 1 and not report.untaken and not report.moved
    assert len(fit.pairs) == 1 and fit.pairs[0].step_max < 0.5 * fit.pairs[0].limit  # was 4.0 mm
    assert set(report.planes) <= {r.name for r in results} and report.planes
    for result, was, x0, x1 in zip(results, plain, butts[:-1], butts[1:]):
        klass = result.figures["plate_class"]
        assert klass["class"] == "flat"
        off = off_cylinder(klass["plane_point"], klass["normal"], x0, x1)
        assert off <= TOLERANCE * (1 + 1e-6)
        if result.name in report.planes:  # it says how far the plane moved its region's points
            assert klass["joint_plane"] and klass["normal"] != was.figures["plate_class"]["normal"] or \
                klass["plane_point"] != was.figures["plate_class"]["plane_point"]
            assert 0.0 < report.planes[result.name] <= 2 * TOLERANCE
        # the plate is its region projected on its plane: the same region, a nearby plane
        assert result.figures["area_m2"] == pytest.approx(was.figures["area_m2"], rel=1e-5)


def test_plates_that_meet_keep_their_planes(tmp_path):
    config, results, _ = run(cylinder_strake(tmp_path, (-800.0, 0.0, 800.0), "follow"))
    report = config.fitup_follow
    assert [r.figures["plate_class"]["class"] for r in results] == ["flat", "flat"]
    assert report.misfits == 0 and report.planes == {}  # equal plates: their step is along the hull, 0.2 mm
    assert all("joint_plane" not in r.figures["plate_class"] for r in results)


def test_twisted_flat_plates_end_no_worse_than_they_began(tmp_path):
    # the shoulder's four flat plates are twisted against each other: on planes within the
    # tolerance their steps stay over the limit, but the planes chosen together bring the
    # steps' excess down, never up
    (tmp_path / "plain").mkdir()
    _, _, before = run(shoulder(tmp_path / "plain"))
    _, results, after = run(shoulder(tmp_path, fit_up="follow"))
    assert [r.figures["plate_class"]["class"] for r in results] == ["flat"] * 4

    def excess(fit):
        return sum(max(0.0, p.step_max - p.limit) for p in fit.pairs)

    assert len(after.pairs) == len(before.pairs) == 4
    assert excess(after) < excess(before) - 0.5
    for result in results:  # each within the tolerance of its region on its plane
        v3 = np.asarray(result.mesh[0])
        klass = result.figures["plate_class"]
        normal = np.asarray(klass["normal"])
        off = np.abs((v3 - np.asarray(klass["plane_point"])) @ normal).max()
        assert off <= result.part.hull.fit_tolerance * (1 + 1e-6)
