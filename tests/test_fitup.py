"""The run's fit-up report (pipeline/hull/fitup.py, coverage.py) against closed forms: a bilge
cylinder strake whose shared edges are straight generators and circular arcs of known length,
the same strake with one plate moved (caught as a misfit, and only that plate), and the 160 m
hull's strake whose shared seams are iso-curves of the hull of known arc length."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from flatten.plane import plane_crossings
from pipeline.cli import main
from pipeline.hull.fitup import LENGTH_LIMIT_MM, plate_edges, shell_fitup
from pipeline.hull.plan import load_run
from pipeline.hull.plates import evaluate_plate, run_part
from tests.hull_shapes import cylinder_along_iges

ROOT = Path(__file__).resolve().parents[1]
RADIUS, HALF_ANGLE, LENGTH = 3000.0, np.pi / 4, 20000.0
SEAMS = (0.1, 0.5, 0.9)
BUTTS = (2000.0, 8000.0, 14000.0)
THICKNESS = 14.0  # step limit min(0.15 t, 3 mm) = 2.1 mm


def theta(v: float) -> float:
    """Angle round the bilge of the iso-curve v of the exact rational quadratic arc (weight
    cos(h) on the middle pole): tan(theta / 2) = tan(h / 2) (2 v - 1)."""
    return 2.0 * np.arctan(np.tan(HALF_ANGLE / 2) * (2.0 * v - 1.0))


def write_config(tmp_path: Path) -> Path:
    cylinder_along_iges(tmp_path / "bilge.igs", radius=RADIUS, angle_deg=90.0, length=LENGTH)
    config = tmp_path / "bilge.yaml"
    config.write_text(yaml.safe_dump({
        "name": "bilge", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
        "steel": {"thickness": THICKNESS},
        "strake": {"surface": {"iges": "bilge.igs"}, "seams": [{"iso": {"v": v}} for v in SEAMS],
                   "butts": list(BUTTS), "margin": 0.2, "fit_tolerance": 5.0}}))
    return config


@pytest.fixture(scope="module")
def bilge(tmp_path_factory):
    """The bilge strake's plates run in this process (with their geometry)."""
    config = load_run(write_config(tmp_path_factory.mktemp("bilge")), evaluate_plate)
    results = [run_part(part, config) for part in config.parts]
    assert all(r.ok for r in results)
    return config, results


def by_plates(fit) -> dict:
    return {(p.a, p.b): p for p in fit.pairs}


def test_bilge_shared_edges_against_closed_form(bilge):
    config, results = bilge
    fit = shell_fitup(results, config)
    pairs = by_plates(fit)
    # 2 x 2 plates: two seams (SEAM 2 between the strakes) and two butts (BUTT 2 along each)
    assert sorted((p.kind, p.label) for p in fit.pairs) == [("butt", "BUTT 2")] * 2 + [("seam", "SEAM 2")] * 2
    for j in (1, 2):  # SEAM 2: a generator between consecutive butts, 6 m straight
        seam = pairs[(f"bilge_S1_B{j}", f"bilge_S2_B{j}")]
        np.testing.assert_allclose(seam.length3 + seam.length2, [BUTTS[j] - BUTTS[j - 1]] * 4, rtol=1e-9)
        assert seam.step_max < 1e-3
    for i in (1, 2):  # BUTT 2: the circular arc between the strake's seams, R (theta1 - theta0)
        butt = pairs[(f"bilge_S{i}_B1", f"bilge_S{i}_B2")]
        arc = RADIUS * (theta(SEAMS[i]) - theta(SEAMS[i - 1]))
        np.testing.assert_allclose(butt.length3 + butt.length2, [arc] * 4, rtol=1e-6)
        assert butt.step_max < 1e-3 and butt.isometric and not butt.misfit
    # every measured edge lies on the cylinder (axis along x through y = 0, z = R)
    for r in results:
        for edge in plate_edges(r).edges:
            p = edge.points3
            assert np.abs(np.hypot(p[:, 1], p[:, 2] - RADIUS) - RADIUS).max() < 1e-6 * RADIUS
    report = fit.as_dict()
    assert report["misfits"] == 0 and report["warnings"] == [] and report["steps_over_3mm"] == 0
    cov = report["coverage"]
    shell = (BUTTS[-1] - BUTTS[0]) * RADIUS * (theta(SEAMS[-1]) - theta(SEAMS[0])) / 1e6
    assert cov["shell_m2"] == pytest.approx(shell, rel=1e-6)
    assert cov["covered"] == pytest.approx(1.0, abs=1e-6) and cov["overlap"] < 1e-9


def moved(result, shift3=None, stretch2=1.0):
    """A copy of a delivered plate with its 3D grid moved by ``shift3(points)`` and/or its
    developed vertices stretched along x by ``stretch2`` (its recorded edges dropped)."""
    v3, faces = result.mesh
    v3 = v3 if shift3 is None else shift3(v3)
    pattern = dataclasses.replace(result.pattern, vertices=result.pattern.vertices * np.array([stretch2, 1.0]))
    figures = {k: v for k, v in result.figures.items() if k != "fitup_edges"}
    return dataclasses.replace(result, mesh=(v3, faces), pattern=pattern, figures=figures)


def radial(delta):
    def shift(p):
        n = np.column_stack([np.zeros(len(p)), p[:, 1], p[:, 2] - RADIUS])
        return p + delta * n / np.linalg.norm(n, axis=1)[:, None]
    return shift


@pytest.mark.parametrize("delta, caught", [(2.5, True), (1.5, False)])
def test_a_plate_moved_off_the_hull_steps_by_the_move(bilge, delta, caught):
    """S1_B1 moved outward by delta: its two shared edges step by delta (limit 2.1 mm for 14 mm
    plate), the others do not move."""
    config, results = bilge
    fit = shell_fitup([moved(results[0], radial(delta))] + results[1:], config)
    for p in fit.pairs:
        if "bilge_S1_B1" in (p.a, p.b):
            assert p.step_max == pytest.approx(delta, abs=1e-3)
            assert p.misfit == caught
        else:
            assert p.step_max < 1e-3 and not p.misfit
    warnings = fit.warnings()
    assert len(warnings) == (2 if caught else 0)
    assert all("bilge_S1_B1" in w and "limit 2.10 mm" in w for w in warnings)


def test_measures_kept_across_a_move_measure_only_the_moved_plate_again(bilge, monkeypatch):
    """One EdgeMeasures carried through a fit-up's measurements (as follow and repair carry
    it): after S1_B1 moves, its two shared edges are measured again and give the fresh
    answer; the two edges of unmoved plates are not measured again."""
    from pipeline.hull import fitup

    config, results = bilge
    records = {r.name: (plate_edges(r), r.part) for r in results}
    measures = fitup.EdgeMeasures(fitup.SAMPLE_MM / config.mm_per_unit)
    before, _ = fitup.shared_edges(records, config.mm_per_unit, THICKNESS, measures)
    calls = []
    real = fitup._measure
    monkeypatch.setattr(fitup, "_measure", lambda da, db: calls.append((da, db)) or real(da, db))
    shifted = moved(results[0], radial(2.5))
    records["bilge_S1_B1"] = (plate_edges(shifted), shifted.part)
    kept, _ = fitup.shared_edges(records, config.mm_per_unit, THICKNESS, measures)
    again = len(calls)
    fresh, _ = fitup.shared_edges(records, config.mm_per_unit, THICKNESS)
    assert kept == fresh
    # measured again: only candidate pairs with an edge of the moved plate, a part of all
    mine = {id(measures.dense(e)) for e in records["bilge_S1_B1"][0].edges}
    assert 2 <= again < len(calls) - again
    assert all(id(da) in mine or id(db) in mine for da, db in calls[:again])
    assert {(p.a, p.b): p.step_max for p in kept if "bilge_S1_B1" in (p.a, p.b)} == pytest.approx(
        {("bilge_S1_B1", "bilge_S2_B1"): 2.5, ("bilge_S1_B1", "bilge_S1_B2"): 2.5}, abs=1e-3)
    assert [p for p in kept if "bilge_S1_B1" not in (p.a, p.b)] == [
        p for p in before if "bilge_S1_B1" not in (p.a, p.b)]
    # a development stretched, its 3D edges unchanged: its length mismatches measured again
    stretched = moved(next(r for r in results if r.name == "bilge_S2_B2"), stretch2=1.001)
    records["bilge_S2_B2"] = (plate_edges(stretched), stretched.part)
    kept, _ = fitup.shared_edges(records, config.mm_per_unit, THICKNESS, measures)
    fresh, _ = fitup.shared_edges(records, config.mm_per_unit, THICKNESS)
    assert kept == fresh and any(p.misfit and "bilge_S2_B2" in (p.a, p.b) for p in kept)
    with pytest.raises(ValueError, match="sampled"):
        fitup.shared_edges(records, 2 * config.mm_per_unit, THICKNESS, measures)


def test_measures_spread_over_worker_processes_are_those_measured_here(bilge, monkeypatch):
    """A batch of pairs not measured before goes to the workers (SPREAD_MIN lowered to the
    bilge's size, two processes): the same shared edges, bit for bit, as measured here."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from pipeline.hull import fitup

    config, results = bilge
    records = {r.name: (plate_edges(r), r.part) for r in results}
    here, _ = fitup.shared_edges(records, config.mm_per_unit, THICKNESS)
    monkeypatch.setattr(fitup, "SPREAD_MIN", 2)
    monkeypatch.setattr(fitup, "SPREAD_BATCH", 3)
    tasks = []
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork")) as pool:
        class Workers:
            running = True

            def map(self, func, items):
                tasks.extend(items)
                return list(pool.map(func, items))

        measures = fitup.EdgeMeasures(fitup.SAMPLE_MM / config.mm_per_unit, Workers())
        there, _ = fitup.shared_edges(records, config.mm_per_unit, THICKNESS, measures)
    assert len(tasks) >= 2 and there == here
    assert not measures._sampled  # nothing was sampled here


def test_a_stretched_development_is_a_length_mismatch(bilge):
    """S1_B1's development 1e-3 longer along the seam: SEAM 2 differs by 6 mm between two
    strip plates, over the 1 mm rule; the 3D edges still meet."""
    config, results = bilge
    fit = shell_fitup([moved(results[0], stretch2=1.001)] + results[1:], config)
    seam = by_plates(fit)[("bilge_S1_B1", "bilge_S2_B1")]
    assert seam.step_max < 1e-3
    assert seam.mismatch == pytest.approx(6.0, rel=1e-6) and seam.mismatch > LENGTH_LIMIT_MM and seam.misfit
    assert fit.as_dict()["mismatch_over_1mm"] == 1


def test_a_plate_moved_along_the_hull_overlaps_its_neighbour(bilge):
    """S1_B1 moved 30 mm along x: it covers 30 mm of S1_B2 (an overlap of 30 mm x the
    strake's girth) and leaves as much uncovered at BUTT 1; BUTT 2 steps by 30 mm."""
    config, results = bilge
    fit = shell_fitup([moved(results[0], lambda p: p + np.array([30.0, 0.0, 0.0]))] + results[1:], config)
    cov = fit.coverage
    girth = RADIUS * (theta(SEAMS[1]) - theta(SEAMS[0]))
    assert cov["overlap_m2"] == pytest.approx(30.0 * girth / 1e6, rel=1e-4)
    # the gap is a difference of areas of the order of the shell's: good to ~1e-6 of the shell
    assert cov["shell_m2"] * (1.0 - cov["covered"]) == pytest.approx(30.0 * girth / 1e6, abs=1e-6 * cov["shell_m2"])
    assert by_plates(fit)[("bilge_S1_B1", "bilge_S1_B2")].step_max == pytest.approx(30.0, rel=1e-6)
    seam = by_plates(fit)[("bilge_S1_B1", "bilge_S2_B1")]  # slid along itself: no step, 5.97 m in common
    assert seam.step_max < 1e-3 and seam.length3 == pytest.approx((5970.0, 5970.0), rel=1e-9)


def test_hullmod_strake_run_reports_its_shell(tmp_path, capsys):
    """Through `devflat run`: the summary's shell section. The strips of a strake share their
    seams with the hull, so each shared seam's developed length on both plates is the arc
    length of the hull's iso-curve between the butt planes."""
    config_path = ROOT / "configs" / "hullmod_strake.yaml"
    out = tmp_path / "out"
    assert main(["run", str(config_path), "--out", str(out)]) == 0
    assert "fit-up: shell covered 100.00 %" in capsys.readouterr().out
    shell = json.loads((out / "hullmod_summary.json").read_text())["shell"]
    assert (shell["shared_edges"], shell["seams"], shell["butts"]) == (13, 5, 8)
    assert shell["misfits"] == 0 and shell["coverage"]["covered"] == pytest.approx(1.0, abs=1e-5)
    spec = yaml.safe_load(config_path.read_text())["strake"]
    config = load_run(config_path)
    seam = config.parts[0].hull.surface.iso_v(spec["seams"][1]["iso"]["v"])
    from pipeline.hull.region import butt_plane

    for pair in (p for p in shell["pairs"] if p["kind"] == "seam"):
        j = int(pair["plates"][0].rsplit("_B", 1)[1])
        ends = [plane_crossings(seam, butt_plane(x))[0] for x in spec["butts"][j - 1:j + 1]]
        arc = float(np.ptp(seam.arc_length_at(np.array(ends))))
        np.testing.assert_allclose(pair["developed_length_mm"] + pair["length_3d_mm"], [arc] * 4, rtol=2e-6)
        assert pair["step_max_mm"] < 0.1


def test_worker_processes_report_the_same_shell(bilge, tmp_path):
    """With --jobs 2 the parent gets each plate's edges back from the workers (the plates'
    geometry stays there): the summary's shell section is the in-process one."""
    config, results = bilge
    out = tmp_path / "out"
    assert main(["run", str(write_config(tmp_path)), "--out", str(out), "--quiet", "--jobs", "2"]) == 0
    shell = json.loads((out / "bilge_summary.json").read_text())["shell"]
    here = shell_fitup(results, config).as_dict()
    assert shell["pairs"] == json.loads(json.dumps(here["pairs"]))
    assert shell["coverage"]["covered"] == pytest.approx(here["coverage"]["covered"], abs=1e-12)


@pytest.mark.parametrize("reverse", [False, True])
def test_a_planned_bilge_shell_with_end_plates(tmp_path, reverse):
    """A planned shell (strake.plan, uniform) of the whole bilge: 2 strakes of 3 plates, the
    end plates closed by the hull's ends. Every butt is found on both of its plates (an end
    plate's butt is its end nearer the butt plane, not its hull end, also where the surface's
    u runs towards -x), each butt is the strake's arc on both plates and the two strakes'
    arcs make the quarter circle; the shell is the whole surface, covered once."""
    cylinder_along_iges(tmp_path / "bilge.igs", radius=RADIUS, angle_deg=90.0, length=LENGTH, reverse=reverse)
    config_path = tmp_path / "shell.yaml"
    config_path.write_text(yaml.safe_dump({
        "name": "shell", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
        "steel": {"thickness": THICKNESS},
        "strake": {"surface": {"iges": "bilge.igs"}, "margin": 0.2, "fit_tolerance": 5.0,
                   "plan": {"method": "uniform", "stock": {"max_length": 8000, "max_width": 2500,
                                                           "min_length": 1000, "min_width": 500}}}}))
    config = load_run(config_path, evaluate_plate)
    results = [run_part(part, config) for part in config.parts]
    assert len(results) == 6 and all(r.ok for r in results)
    fit = shell_fitup(results, config)
    assert sorted(p.kind for p in fit.pairs) == ["butt"] * 4 + ["seam"] * 3
    arcs = {}
    for p in fit.pairs:
        assert p.step_max < 1e-3 and not p.misfit
        assert p.length3[0] == pytest.approx(p.length3[1], rel=1e-9)
        if p.kind == "butt":
            arcs.setdefault(p.label, []).append(p.length2[0])
        else:
            assert p.length2[0] == pytest.approx(LENGTH / 3, rel=1e-6)
    assert sorted(arcs) == ["BUTT X13333", "BUTT X6667"]
    for both in arcs.values():
        assert sum(both) == pytest.approx(RADIUS * 2 * HALF_ANGLE, rel=1e-6)
    cov = fit.coverage
    assert cov["surfaces"][0]["reference"] == "the whole surface"
    assert cov["shell_m2"] == pytest.approx(LENGTH * RADIUS * 2 * HALF_ANGLE / 1e6, rel=1e-6)
    assert cov["covered"] == pytest.approx(1.0, abs=1e-6) and cov["overlap"] < 1e-9


def test_areas_on_the_surface_inside_a_trim(tmp_path):
    """The coverage's reference inside a trim: the bilge's parameter rectangle trimmed to
    u < 0.3 (the first 6 m along x) without a hole of 0.1 x 0.25 in (u, v), whose area on the
    surface is closed form (u is linear in x, v is the rational arc: theta(v))."""
    from pipeline.hull.coverage import _trim_region, surface_area
    from pipeline.hull.trims import Trim
    from pipeline.io.iges import iges_surface, read_iges

    iges = read_iges(cylinder_along_iges(tmp_path / "bilge.igs", radius=RADIUS, angle_deg=90.0, length=LENGTH))
    surface = iges_surface(iges, iges.of_type(128)[0], 1.0, "bilge")
    outer = np.array([[0.0, 0.0], [0.3, 0.0], [0.3, 1.0], [0.0, 1.0], [0.0, 0.0]])
    hole = np.array([[0.1, 0.5], [0.2, 0.5], [0.2, 0.75], [0.1, 0.75], [0.1, 0.5]])
    region = _trim_region(surface, Trim(1, outer, (hole,), 144))
    whole = 0.3 * LENGTH * RADIUS * 2 * HALF_ANGLE
    cut = 0.1 * LENGTH * RADIUS * (theta(0.75) - theta(0.5))
    # cells the hole cuts are integrated by the midpoint rule (2.4e-7 here), whole ones by Gauss
    assert surface_area(surface, region) == pytest.approx(whole - cut, rel=1e-6)


def test_neighbours_whose_edges_lie_apart_are_reported_apart(bilge):
    """S1_B1 moved 60 mm off the hull: more than 10 fit tolerances (50 mm) from its neighbours,
    so its two shared edges are reported apart (with a warning each), not as steps."""
    config, results = bilge
    fit = shell_fitup([moved(results[0], radial(60.0))] + results[1:], config)
    assert sorted((p.a, p.b) for p in fit.apart) == [("bilge_S1_B1", "bilge_S1_B2"), ("bilge_S1_B1", "bilge_S2_B1")]
    assert all(p.step_median == pytest.approx(60.0, abs=1e-3) for p in fit.apart)
    assert len(fit.pairs) == 2 and max(p.step_max for p in fit.pairs) < 1e-3
    assert sum("lie 60 mm apart" in w for w in fit.warnings()) == 2


def test_an_edge_tolerance_develops_plates_whose_edges_leave_the_hull_on_the_hull(tmp_path):
    """strake.edge_tolerance 1 mm on the 160 m hull's strake: its two forward plates' strips
    leave the hull by ~2 mm at their edges (S1_B1, S2_B1; the other eight by 0.2 mm at most),
    so those two are developed on the hull as patches (their edges on it) and say why; every
    flat or strip plate left keeps its edges within 1 mm of the hull, and every shared edge
    steps by at most twice that."""
    from pipeline.hull.plates import edge_deviation

    data = yaml.safe_load((ROOT / "configs" / "hullmod_strake.yaml").read_text())
    data["strake"]["surface"]["iges"] = str(ROOT / "tests" / "data" / "ship" / "test_1_hull_exported.igs")
    data["strake"]["edge_tolerance"] = 1.0
    data["output"] = {"png": False}
    path = tmp_path / "edge.yaml"
    path.write_text(yaml.safe_dump(data))
    config = load_run(path, evaluate_plate)
    results = [run_part(part, config) for part in config.parts]
    assert all(r.ok for r in results)
    moved = {r.name: r.figures["edge_fit"] for r in results if r.figures.get("edge_fit")}
    assert set(moved) == {"hullmod_S1_B1", "hullmod_S2_B1"}
    for name, record in moved.items():
        assert record["class_before"] == "developable" and 1.0 < record["edge_deviation_before"] < 3.0
    for r in results:
        off = edge_deviation(r)
        assert (off is None) == (r.name in moved)  # a patch lies on the hull: nothing to measure
        assert off is None or off <= 1.0
    assert shell_fitup(results, config).as_dict()["step_mm"]["max"] <= 2.0
