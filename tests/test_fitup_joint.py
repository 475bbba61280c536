"""The flat plates' planes chosen together (pipeline/hull/joint.py, strake.fit_up: follow).

Two flat plates of unequal length on a circular cylinder step from each other at their butt
by a closed form (each on its minimax plane, half its sagitta off the hull); on planes chosen
together they meet, each still within the fit tolerance of the cylinder itself (measured on
the exact cylinder, not on the plan's grid). Plates that meet already keep their planes; the
shoulder's twisted plates, which no planes within the tolerance bring within the limit, end
no worse than they began. Asked for as strips (strake.flats_as_strips), the cylinder's two
plates become the strips through their seams, the cylinder itself, and meet to round-off;
the shoulder's, which no strip fits, stay flat and say why."""

import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.hull.fitup import shell_fitup
from pipeline.hull.plan import load_run
from pipeline.hull.plates import evaluate_plate, run_part
from tests.hull_shapes import cylinder_iges
from tests.test_fitup_repair import shoulder

RADIUS, WIDTH, TOLERANCE, THICKNESS = 20000.0, 2000.0, 5.0, 14.0  # step limit min(0.15 t, 3) = 2.1 mm


def cylinder_strake(tmp_path: Path, butts, fit_up: str, as_strips: bool = False) -> Path:
    # as_strips off: these plates would become the strips through their seams (the cylinder
    # itself), and the planes chosen together would have nothing to do
    cylinder_iges(tmp_path / "cyl.igs", radius=RADIUS, angle_deg=10.0, width=WIDTH)
    path = tmp_path / f"cyl_{fit_up}{'_as_strips' if as_strips else ''}.yaml"
    path.write_text(yaml.safe_dump({
        "name": "cyl", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False, "dxf": False},
        "steel": {"thickness": THICKNESS},
        "strake": {"surface": {"iges": "cyl.igs"}, "seams": [{"iso": {"v": 0.0}}, {"iso": {"v": 1.0}}],
                   "butts": list(butts), "margin": 0.2, "fit_tolerance": TOLERANCE, "fit_up": fit_up,
                   "flats_as_strips": as_strips}}))
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
            assert klass["joint_plane"] and (klass["normal"] != was.figures["plate_class"]["normal"]
                                             or klass["plane_point"] != was.figures["plate_class"]["plane_point"])
            assert 0.0 < report.planes[result.name] <= 2 * TOLERANCE
        # the plate is its region projected on its plane: the same region, a nearby plane
        assert result.figures["area_m2"] == pytest.approx(was.figures["area_m2"], rel=1e-5)


def test_flat_plates_that_step_are_delivered_as_the_strips_through_their_seams(tmp_path):
    # the same two plates asked for as strips: the strip between a plate's seams (two
    # circles of the cylinder) is the cylinder itself, so each lies on the hull, develops to
    # its arc length times its width, and the two meet to round-off (from 4.0 mm); the flat
    # + strip share is the same, the plates are rolled instead of cut flat
    butts = (-1200.0, 0.0, 400.0)
    config, results, fit = run(cylinder_strake(tmp_path, butts, "follow", as_strips=True))
    report = config.fitup_follow
    assert set(report.as_strips) == {r.name for r in results} and not report.kept_flat
    assert "2 flat plate(s) delivered as strips" in report.one_line()
    # one first, measured against its neighbour still flat (that plane's edge stands off the
    # hull by half its own sagitta: the short plate's, 0.50 mm), then the other against it
    after = sorted(entry["step_after_mm"] for entry in report.as_strips.values())
    b = half_angle(butts[1], butts[2])
    assert after[0] < 1e-6 and after[1] == pytest.approx(RADIUS * (1 - np.cos(b)) / 2, abs=0.02)
    for result, x0, x1 in zip(results, butts[:-1], butts[1:]):
        klass = result.figures["plate_class"]
        assert klass["class"] == "developable" and klass["family"] == "rulings seam to seam"
        assert klass["flat_declined"]["step_mm"] == pytest.approx(4.005, abs=0.02)
        assert klass["max_deviation"] < 1e-6 and result.figures["hull_fit"]["passed"]
        arc = 2 * RADIUS * half_angle(x0, x1)
        assert result.figures["outline"]["area_m2"] == pytest.approx(arc * WIDTH / 1e6, rel=1e-4)
    assert len(fit.pairs) == 1 and fit.pairs[0].step_max < 1e-6 and not fit.pairs[0].misfit
    assert not report.planes and not report.untaken


def test_plates_that_meet_keep_their_planes(tmp_path):
    config, results, _ = run(cylinder_strake(tmp_path, (-800.0, 0.0, 800.0), "follow"))
    report = config.fitup_follow
    assert [r.figures["plate_class"]["class"] for r in results] == ["flat", "flat"]
    assert report.misfits == 0 and report.planes == {}  # equal plates: their step is along the hull, 0.2 mm
    assert all("joint_plane" not in r.figures["plate_class"] for r in results)


def test_twisted_flat_plates_end_no_worse_than_they_began(tmp_path, monkeypatch):
    # the shoulder's four flat plates are twisted against each other: on planes within the
    # tolerance their steps stay over the limit, but the planes chosen together bring the
    # steps' excess down, never up. The planes alone: the least-curvature strips, which fit
    # two of them (test_twisted_flat_plates_become_strips_along_the_least_curvature), not tried
    from pipeline.hull import leaststrip

    monkeypatch.setattr(leaststrip, "GATE", -1.0)
    (tmp_path / "plain").mkdir()
    _, _, before = run(shoulder(tmp_path / "plain"))
    config, results, after = run(shoulder(tmp_path, fit_up="follow"))
    assert [r.figures["plate_class"]["class"] for r in results] == ["flat"] * 4
    # asked for as strips first, none fits (the strips between nearly flat seams lean far
    # off the hull): each stays flat and the report says why
    report = config.fitup_follow
    assert not report.as_strips and set(report.kept_flat) == {r.name for r in results}
    assert all("rulings seam to seam" in why and "rulings butt to butt" in why for why in report.kept_flat.values())
    assert all("flat_declined" not in r.figures["plate_class"] for r in results)
    assert all(part.hull.as_strip is None and part.hull.result.figures["plate_class"]["class"] == "flat"
               for part in config.parts)  # restored as developed, its cache key with it

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


def test_twisted_flat_plates_become_strips_along_the_least_curvature(tmp_path):
    # with every strip family: two of the shoulder's twisted flat plates are strips along the
    # hull's least curvature (neither their seams nor their butt sections carry one), each
    # kept because its worst step to its flat or strip neighbours falls; the other two stay
    # flat, saying why each family failed; the steps' excess falls below half of what it was
    (tmp_path / "plain").mkdir()
    _, _, before = run(shoulder(tmp_path / "plain"))
    config, results, after = run(shoulder(tmp_path, fit_up="follow"))
    report = config.fitup_follow
    strips = {r.name for r in results if r.figures["plate_class"]["class"] == "developable"}
    assert len(strips) == 2 and strips == set(report.as_strips)
    assert all(r.figures["plate_class"]["family"] == "rulings along the least curvature" for r in results
               if r.name in strips)
    assert all(v["step_after_mm"] < v["step_mm"] for v in report.as_strips.values())
    assert set(report.kept_flat) == {r.name for r in results} - strips
    assert all("rulings along the least curvature: " in why for why in report.kept_flat.values())

    def excess(fit):
        return sum(max(0.0, p.step_max - p.limit) for p in fit.pairs)

    assert excess(after) < 0.5 * excess(before)


# two strakes of strips on a torus (a bilge of 20 m radius whose centre line bows at 138 m):
# the wide one (1200 mm of girth) misses the hull by its sagitta between its seams, 9.0 mm, so
# its strip is moved off the hull by half of it for its best fit, seams and all; the narrow
# one (600 mm) is the plain strip between its seams, which lie on the hull. They step at their
# shared seam by that half sagitta; moved rigidly, within the tolerance, they meet.
BOW, TUBE, HALF_SPAN = 138000.0, 20000.0, np.radians(5.0)


def girth_v(s: float) -> float:
    """The iso-v of the torus patch at girth s (mm) from its middle (rational quadratic arc)."""
    return float((np.tan(s / TUBE / 2) / np.tan(HALF_SPAN / 2) + 1) / 2)


def off_torus(points: np.ndarray) -> np.ndarray:
    """Distances of points (N, 3) from the torus of bowed_bilge_iges: the tube's centre circle
    has radius BOW about the axis parallel to y through (0, 0, BOW)."""
    q = np.asarray(points) - np.array([0.0, 0.0, BOW])
    rho = np.hypot(q[:, 0], q[:, 2])
    return np.abs(np.hypot(rho - BOW, q[:, 1]) - TUBE)


def torus_strakes(tmp_path: Path, fit_up: str) -> Path:
    from tests.hull_shapes import bowed_bilge_iges

    bowed_bilge_iges(tmp_path / "torus.igs", bow=BOW, bilge=TUBE, length=20000.0, angle_deg=10.0)
    path = tmp_path / f"torus_{fit_up}.yaml"
    path.write_text(yaml.safe_dump({
        "name": "tor", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False, "dxf": False},
        "steel": {"thickness": THICKNESS},
        "strake": {"surface": {"iges": "torus.igs"}, "seams": [{"iso": {"v": girth_v(s)}} for s in (-1200, 0, 600)],
                   "butts": [-3000.0, 3000.0], "margin": 0.2, "fit_tolerance": TOLERANCE, "fit_up": fit_up}}))
    return path


@pytest.fixture(scope="module")
def strips(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("torus")
    return run(torus_strakes(tmp, "report")), run(torus_strakes(tmp, "follow"))


def test_two_strips_step_by_the_half_sagitta_of_the_wider(strips):
    (_, results, fit), _ = strips
    assert [r.figures["plate_class"]["class"] for r in results] == ["developable", "developable"]
    sagitta = TUBE * (1 - np.cos(1200.0 / TUBE / 2))  # 9.0 mm
    assert results[0].figures["hull_fit"]["max_distance"] == pytest.approx(sagitta / 2, abs=0.05)
    assert results[1].figures["hull_fit"]["max_distance"] == pytest.approx(TUBE * (1 - np.cos(600.0 / TUBE / 2)),
                                                                           abs=0.05)
    assert len(fit.pairs) == 1 and fit.pairs[0].step_max == pytest.approx(sagitta / 2, abs=0.05)
    assert fit.pairs[0].misfit


def test_strips_moved_rigidly_meet_within_the_tolerance_of_the_torus(strips):
    (_, plain, _), (config, results, fit) = strips
    report = config.fitup_follow
    assert report.strips and set(report.strips) <= {r.name for r in results}
    assert not report.refused and not report.planes
    assert len(fit.pairs) == 1 and fit.pairs[0].step_max < 0.5 * fit.pairs[0].limit  # was 4.5 mm
    for result, was in zip(results, plain):
        assert result.figures["plate_class"]["class"] == "developable"
        # the same plate: its development untouched, its 3D shape the old one moved rigidly
        assert np.array_equal(result.pattern.vertices, was.pattern.vertices)
        v3 = result.strip.vertices if result.strip is not None and result.strip.trim is not None else result.mesh[0]
        v0 = was.strip.vertices if was.strip is not None and was.strip.trim is not None else was.mesh[0]
        assert np.allclose(np.linalg.norm(v3[1:] - v3[:-1], axis=1), np.linalg.norm(v0[1:] - v0[:-1], axis=1),
                           atol=1e-9)
        if result.name not in report.strips:
            assert "rigid_move" not in result.figures and np.array_equal(v3, v0)
            continue
        move = result.figures["rigid_move"]
        assert 0.0 < move["largest_move_mm"] < 2 * TOLERANCE
        # within the tolerance of the exact torus (not only of the NURBS the plan read)
        assert off_torus(v3).max() <= TOLERANCE * (1 + 1e-6)
        assert result.figures["hull_fit"]["max_distance"] == pytest.approx(off_torus(v3).max(), abs=1e-3)
        assert result.figures["hull_fit"]["before_move_max_distance"] == was.figures["hull_fit"]["max_distance"]


@settings(max_examples=25, deadline=None, derandomize=True)
@given(st.integers(2, 6), st.integers(3, 25), st.integers(0, 10_000))
def test_the_primal_from_the_dual_is_the_primal_optimum(columns, rows, seed):
    # the programme is solved as its dual (a basis of its few columns): the marginals read back
    # are feasible and as good as HiGHS's own primal solution
    from scipy.optimize import linprog
    from scipy.sparse import csr_matrix

    from pipeline.hull.joint import _primal

    rng = np.random.default_rng(seed)
    matrix = rng.normal(size=(rows, columns))
    bound = matrix @ rng.uniform(0.0, 0.5, columns) + rng.uniform(0.0, 1.0, rows)  # feasible at that x
    upper = np.where(rng.uniform(size=columns) < 0.3, rng.uniform(0.5, 2.0, columns), np.inf)
    cost = rng.uniform(0.1, 2.0, columns) * np.where(rng.uniform(size=columns) < 0.5, -1.0, 1.0)
    matrix = np.vstack([matrix, np.eye(columns)])  # every column bounded: the programme has an optimum
    bound = np.r_[bound, np.full(columns, 5.0)]
    x = _primal(cost, csr_matrix(matrix), bound, upper)
    direct = linprog(cost, A_ub=matrix, b_ub=bound, bounds=[(0, None if np.isinf(u) else u) for u in upper],
                     method="highs")
    assert direct.success and x is not None
    assert (matrix @ x - bound).max() <= 1e-7 and x.min() >= 0.0 and np.all(x <= upper + 1e-9)
    assert cost @ x == pytest.approx(direct.fun, abs=1e-7 * max(1.0, abs(direct.fun)))


def test_a_strip_moves_by_a_rigid_motion():
    from pipeline.hull.joint import _Body

    rng = np.random.default_rng(5)
    centre, scale = rng.normal(size=3) * 1000, 3000.0
    body = _Body("s", "rigid", 0, centre, np.zeros((2, 3)), np.zeros(3), scale, np.zeros((0, 6)), np.zeros(0), 5.0)
    points = centre + rng.normal(size=(7, 3)) * 2000
    v, w = rng.normal(size=3), rng.normal(size=3) * 1e-3
    moves = body.basis(points) @ np.r_[v, w * scale]
    assert np.allclose(moves, v + np.cross(w, points - centre), atol=1e-12)


def test_a_strip_on_a_later_face_of_a_shell_is_held_on_its_own_face(strips):
    # a shell's distance holds every face: a strip of its second face is measured on that
    # face, not on the first (which once gave parameters outside its own face's domain)
    import copy
    import dataclasses

    from flatten.closest import SurfaceDistance
    from flatten.surface import nurbs_surface
    from pipeline.hull.joint import _rigid_body

    (_, results, _), _ = strips
    plain = results[0].part
    decoy = nurbs_surface(1, 1, [[[0, 0, -9e4], [0, 1e3, -9e4]], [[1e3, 0, -9e4], [1e3, 1e3, -9e4]]],
                          [0, 0, 1, 1], [0, 0, 1, 1], name="decoy")
    bodies = []
    for distance in (SurfaceDistance(plain.hull.surface), SurfaceDistance([decoy, plain.hull.surface])):
        part = copy.copy(plain)
        part.hull = dataclasses.replace(plain.hull, distance=distance, result=results[0])
        bodies.append(_rigid_body(part.name, part, 0))
    assert np.all(np.isfinite(bodies[1].limits)) and np.all(np.isfinite(bodies[1].rows))
    assert np.allclose(bodies[0].limits, bodies[1].limits, atol=1e-9)
    assert np.allclose(bodies[0].rows, bodies[1].rows, atol=1e-9)


def test_a_failed_programme_leaves_the_plates_as_developed_and_says_why(tmp_path, monkeypatch):
    from pipeline.hull import follow

    def broken(*args, **kwargs):
        raise ValueError("Invalid input for linprog: c must not contain values inf")

    monkeypatch.setattr(follow, "joint_moves", broken)
    config, results, fit = run(cylinder_strake(tmp_path, (-1200.0, 0.0, 400.0), "follow"))
    report = config.fitup_follow
    assert report.joint_error.startswith("ValueError: Invalid input") and not report.planes and not report.strips
    assert "the joint programme failed: ValueError" in report.one_line()
    assert fit.pairs[0].misfit and [r.figures["plate_class"]["class"] for r in results] == ["flat", "flat"]


def test_a_moved_strip_is_cut_and_bent_as_developed_and_sits_where_it_was_moved(tmp_path):
    # a move along the hull (across the butt planes) and a turn: the plate the shop cuts is
    # the strip as developed (re-cut at the butt planes, a moved strip would be another piece
    # of it); only where it sits changes, its 3D geometry moved once its shop data are done
    from pipeline.hull.joint import turned
    from pipeline.hull.rigid import moved_rigidly

    config = load_run(torus_strakes(tmp_path, "report"), evaluate_plate)
    part = config.parts[1]
    part.hull.result = evaluate_plate(part, config)
    plain = run_part(part, config)
    lean = evaluate_plate(part, config)
    centre = np.asarray(lean.strip.vertices).mean(axis=0)
    turn = np.array([0.0, 0.0, 1e-3])
    move = {"rotation": turned(turn).tolist(), "turn": turn.tolist(), "translation": [2.0, 0.0, 1.0],
            "centre": centre.tolist(), "largest_move_mm": 5.0}
    part.hull.result = moved_rigidly(lean, move)
    moved = run_part(part, config)
    assert moved.ok and plain.ok
    assert np.allclose(moved.shop.outline.points, plain.shop.outline.points, atol=1e-9)
    assert [(b.a, b.b) for b in moved.shop.bending] == pytest.approx([(b.a, b.b) for b in plain.shop.bending], abs=1e-9)
    assert moved.figures["outline"]["area_m2"] == pytest.approx(plain.figures["outline"]["area_m2"], rel=1e-12)
    expected = centre + (np.asarray(plain.strip.vertices) - centre) @ turned(turn).T + np.array([2.0, 0.0, 1.0])
    assert np.allclose(moved.strip.vertices, expected, atol=1e-9)  # the OBJ's plate, moved
    assert moved.figures["rigid_move"]["placed"] and not lean.figures.get("rigid_move")
    edges = moved.figures["fitup_edges"]  # the fit-up measures the moved edges
    assert np.allclose(edges.ring3, centre + (plain.figures["fitup_edges"].ring3 - centre) @ turned(turn).T
                       + np.array([2.0, 0.0, 1.0]), atol=1e-9)


def test_a_strips_points_held_in_the_programme_spread_along_it(strips):
    # a strip cut to its butts has a fan of rulings at each: its points are taken along the
    # plate, not by ruling index (most rulings would lie on the butts)
    from pipeline.hull.joint import STRIP_GRID, _strip_points

    (_, results, _), _ = strips
    for result in results:
        points = _strip_points(result)
        xs = np.unique(points[:, 0].round(1))
        assert len(points) == STRIP_GRID[0] * STRIP_GRID[1] and len(xs) >= STRIP_GRID[1] - 1
        assert xs.min() < -2900.0 and xs.max() > 2900.0  # from butt to butt (x = -3000, 3000)
        assert np.diff(np.sort(xs)).max() < 1500.0  # none of the plate's length left out


def test_the_fit_up_is_a_stage_of_its_own_on_the_console(tmp_path, capsys, monkeypatch):
    """`time:` gives the fit-up its own seconds, apart from the plan's: a fit-up made to take
    two seconds longer shows them there and not in the plan; a run in `report` has none."""
    import time

    from pipeline.cli import main
    from pipeline.hull import follow

    slow = follow.follow_fitup

    def slower(*args, **kwargs):
        time.sleep(2.0)
        return slow(*args, **kwargs)

    monkeypatch.setattr(follow, "follow_fitup", slower)
    stages = {}
    for fit_up in ("report", "follow"):
        path = cylinder_strake(tmp_path, (-1200.0, 0.0, 400.0), fit_up)
        assert main(["run", str(path), "--out", str(tmp_path / fit_up)]) == 0
        line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("time:"))
        stages[fit_up] = {name.strip(): (float(wall), float(cpu)) for name, wall, cpu in
                          re.findall(r"([a-z +-]+?)(?: \d+ plates \(\d+ cached\))? ([\d.]+) s \(([\d.]+) CPU s\)",
                                     line[len("time:"):])}
    assert "fit-up" not in stages["report"]
    assert list(stages["follow"])[:2] == ["plan", "fit-up"]
    assert stages["follow"]["fit-up"][0] >= 2.0 > stages["follow"]["plan"][0]
    assert stages["follow"]["fit-up"][1] < 2.0  # asleep: the CPU seconds are its own work's


def _plate_on_plane(name: str, klass: str, x: tuple, y: tuple, surface, distance):
    """The edges record and part of a plate of the plane z = 0 over the rectangle x (x0, x1),
    y (y0, y1) (mm), as the joint programme reads them: a strip (a rigid body) or a flat plate
    (a plane body, moved along its normal only)."""
    from types import SimpleNamespace

    from pipeline.hull.fitup import Edge, PlateEdges

    rows, cols = 5, 9
    xx, yy = np.meshgrid(np.linspace(*x, cols), np.linspace(*y, rows))
    grid = np.stack([xx, yy, np.zeros_like(xx)], axis=-1)  # (rows along y, cols along x, 3)
    figures = {"plate_class": {"class": klass, "normal": [0.0, 0.0, 1.0], "plane_point": grid[0, 0].tolist()},
               "region": {"grid": [rows, cols]}}
    result = SimpleNamespace(mesh=(grid.reshape(-1, 3), np.zeros((0, 3), dtype=np.int64)), figures=figures,
                             strip=None)
    part = SimpleNamespace(hull=SimpleNamespace(result=result, surface=surface, distance=distance,
                                                fit_tolerance=TOLERANCE))
    sides = {"seam0": grid[0], "seam1": grid[-1], "butt0": grid[:, 0], "butt1": grid[:, -1]}
    edges = tuple(Edge(side, side, points, points[:, :2]) for side, points in sides.items())
    return PlateEdges(name, klass, True, edges, grid[0]), part


def test_two_strips_that_slide_along_their_butt_keep_their_corners_together():
    # KVLCC2's yard plan: two strips of strake 10 whose seam neighbours were formed slid
    # along their shared butt in opposite directions, each within the tolerance, and ended
    # 10 mm apart on seam 11; the formed plate above, formed to meet both, stepped 9.56 mm
    # there. Here strip A's neighbour above, flat plate C, lies 3 mm further up the plane
    # than A's seam (a flat plate moves along its normal only): A slides up to meet it, and
    # strip B, beside A across their butt, with no neighbour of its own to meet, must slide
    # with A, or their corners on the seam part by the slide
    from types import SimpleNamespace

    from flatten.closest import SurfaceDistance
    from flatten.surface import nurbs_surface
    from pipeline.hull.joint import TIERS, joint_moves

    surface = nurbs_surface(1, 1, [[[-3000.0, 0.0, 0.0], [-3000.0, 3000.0, 0.0]],
                                   [[3000.0, 0.0, 0.0], [3000.0, 3000.0, 0.0]]], [0, 0, 1, 1], [0, 0, 1, 1])
    distance = SurfaceDistance(surface)
    shift, limit = 3.0, 2.1
    records = {"A": _plate_on_plane("A", "developable", (-2000.0, 0.0), (1000.0, 2000.0), surface, distance),
               "B": _plate_on_plane("B", "developable", (0.0, 2000.0), (1000.0, 2000.0), surface, distance),
               "C": _plate_on_plane("C", "flat", (-2000.0, 0.0), (2000.0 + shift, 3000.0 + shift), surface, distance)}
    pairs = [SimpleNamespace(a="A", b="B", side_a="butt1", side_b="butt0", limit=limit),
             SimpleNamespace(a="A", b="C", side_a="seam1", side_b="seam0", limit=limit)]
    moves = joint_moves(records, pairs, 1.0)

    def moved(name: str, points: np.ndarray) -> np.ndarray:
        move = moves.get(name)
        if move is None:
            return points
        centre = np.asarray(move["centre"])
        return centre + (points - centre) @ np.asarray(move["rotation"]).T + np.asarray(move["translation"])

    corner = np.array([[0.0, 2000.0, 0.0], [0.0, 1000.0, 0.0]])  # where A's and B's butt edges end
    a_corner, b_corner = moved("A", corner), moved("B", corner)
    # A slid up to C (within the limit of its seam, which it could not meet staying put) ...
    a_seam = moved("A", records["A"][0].edge("seam1").points3)
    assert np.abs(a_seam[:, 1] - (2000.0 + shift)).max() <= TIERS[0][0] * limit + 1e-6
    assert a_corner[0, 1] - corner[0, 1] >= shift - TIERS[0][0] * limit - 1e-6
    # ... and B with it: their corners meet at both ends of the butt, along it too
    assert np.linalg.norm(a_corner - b_corner, axis=1).max() <= TIERS[0][0] * limit + 1e-6
    # every plate stays within the tolerance of the plane
    for name in ("A", "B"):
        assert np.abs(moved(name, records[name][1].hull.result.mesh[0])[:, 2]).max() <= TOLERANCE


def test_two_edges_ends_are_paired_the_way_round_that_meets():
    from pipeline.hull.joint import _junction_ends

    mine = np.column_stack([np.linspace(0.0, 1000.0, 11), np.zeros(11), np.zeros(11)])
    theirs = mine[::-1] + np.array([3.0, 0.5, 0.0])  # the same edge, the other way round
    ends, met, along = _junction_ends(mine, theirs, 10.0)
    assert np.allclose(met - ends, [3.0, 0.5, 0.0]) and np.allclose(along[:, 0], [1.0, 0.0, 0.0])
    # a butt beside a longer seam: only the end they share is a junction
    ends, met, _ = _junction_ends(mine[:6], theirs, 10.0)
    assert np.allclose(ends, [[0.0, 0.0, 0.0]]) and np.allclose(met, [[3.0, 0.5, 0.0]])
    # an edge shorter than twice the reach has one junction at both ends: none is held
    assert _junction_ends(mine[:2] * 0.01, theirs[-2:] * 0.01, 10.0) is None
