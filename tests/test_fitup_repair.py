"""strake.fit_up: repair (pipeline/hull/repair.py): neighbours that step further than a weld may
be misaligned are brought onto the hull, the worse plate first.

Real data: four flat plates of the 160 m hull's bow shoulder (seams v = 3.25, 3.43, 3.62,
butts x = 32.4, 36.1, 39.8 m) are each within the 5 mm fit tolerance of their minimax planes
but 3.5-4.5 mm off the hull at their edges, in opposite senses on the two sides of a shared
edge: their steps are 7-9 mm, over IACS Rec. 47's min(0.15 t, 3 mm) = 2.1 mm for 14 mm plate.
The repair develops them on the hull, so that their shared edges coincide, and each says why."""

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from pipeline.cli import main
from pipeline.hull.fitup import Edge, PlateEdges, SharedEdge, shell_fitup
from pipeline.hull.plan import load_run
from pipeline.hull.plates import evaluate_plate, run_part
from pipeline.hull.repair import _to_hold

ROOT = Path(__file__).resolve().parents[1]


def shoulder(tmp_path: Path, **strake) -> Path:
    data = {"name": "fit", "units": "mm",
            "strake": dict({"surface": {"iges": str(ROOT / "tests" / "data" / "ship" / "test_1_hull_exported.igs"),
                                        "entity": 0},
                            "seams": [{"iso": {"v": 3.25}}, {"iso": {"v": 3.43}}, {"iso": {"v": 3.62}}],
                            "butts": [32400, 36100, 39800], "margin": 0.2, "fit_tolerance": 5.0}, **strake),
            "resolution": {"chord_tolerance": 1.0}, "steel": {"thickness": 14},
            "output": {"png": False, "dxf": False}}
    path = tmp_path / "fit.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def plain_and_repaired(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("shoulder")
    out = []
    for mode in ("report", "repair"):
        config = load_run(shoulder(tmp / mode if (tmp / mode).mkdir() is None else tmp, fit_up=mode), evaluate_plate)
        results = [run_part(part, config) for part in config.parts]
        out.append((config, results, shell_fitup(results, config)))
    return out


def test_the_shoulder_plates_step_over_the_limit_as_planned(plain_and_repaired):
    config, results, fit = plain_and_repaired[0]
    assert [r.figures["plate_class"]["class"] for r in results] == ["flat"] * 4
    assert len(fit.pairs) == 4 and all(p.limit == pytest.approx(2.1) for p in fit.pairs)
    assert all(6.0 < p.step_max < 10.0 for p in fit.pairs)  # two plates ~4 mm off, opposite senses
    assert config.fitup_repair is None


def test_repair_brings_misfit_neighbours_onto_the_hull(plain_and_repaired):
    (_, plain, _), (config, results, fit) = plain_and_repaired
    assert all(p.step_max < 0.1 for p in fit.pairs) and not any(p.misfit for p in fit.pairs)
    report = config.fitup_repair
    assert report.rounds[0]["misfits"] == 4 and sorted(report.held) == sorted(r.name for r in results)
    assert not report.unrepaired
    for before, after in zip(plain, results):
        record = after.figures["edge_fit"]
        klass = after.figures["plate_class"]
        assert klass["class"] == "formed" and klass["rolling_only"]  # 4 mm over 3.7 m: rolling forms it
        assert "fit-up repair" in klass["strip_not_delivered_because"]
        assert record["class_before"] == "flat" and record["step_mm"] > record["step_limit_mm"]
        # the plate's edge was as far off as the plain run delivered it
        assert record["edge_deviation_before_mm"] == pytest.approx(before.figures["plate_class"]["max_deviation"],
                                                                   rel=0.1)
        assert after.figures["region"]["area_m2"] == pytest.approx(before.figures["region"]["area_m2"], rel=1e-9)


def test_the_run_reports_the_repair_in_its_summary_and_console(tmp_path, capsys):
    path = shoulder(tmp_path, fit_up="repair")
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 0
    summary = json.loads((tmp_path / "out" / "fit_summary.json").read_text())
    repair = summary["shell"]["repair"]
    assert repair["plates_held"] == 4 and repair["rounds"][0]["misfits"] == 4
    assert repair["held_kept_flat_or_strip"] == []  # neither plane nor strip keeps these edges near the hull
    assert summary["shell"]["misfits"] == 0
    part = json.loads((tmp_path / "out" / "fit_S1_B1.json").read_text())
    assert part["edge_fit"]["rule"] == "strake.fit_up: repair"
    assert "fit-up repair: 4 misfit pair(s) found, 4 plate(s) held in 1 round(s) (0 kept flat or as a strip" in \
        capsys.readouterr().out


def _record(name, klass, off_mm, held=None):
    """A plate whose edge SEAM lies ``off_mm`` from its (stand-in) hull."""
    edge = Edge("seam1" if name == "a" else "seam0", "SEAM", np.zeros((3, 3)), np.zeros((3, 2)))
    hull = SimpleNamespace(distance=lambda pts, off=off_mm: np.full(len(pts), off), surface=None, held=held)
    return name, (PlateEdges(name, klass, klass in ("flat", "developable"), (edge,), np.zeros((3, 3))),
                  SimpleNamespace(name=name, hull=hull))


def _pair(step, mismatch=0.0):
    return SharedEdge("a", "b", "seam", "SEAM", step, step, (0.0, 0.0, 0.0), (1000.0, 1000.0),
                      (1000.0, 1000.0 + mismatch), True, 2.1, "seam1", "seam0")


@pytest.mark.parametrize("off_a, off_b, klass_b, held", [
    (4.0, 1.0, "developable", ["a"]),  # the other within the limit once the worse is on the hull
    (1.0, 4.0, "developable", ["b"]),
    (4.0, 3.0, "developable", ["a", "b"]),  # both further off than the limit: both
    (4.0, 0.0, "formed", ["a"]),  # a patch is on the hull already
])
def test_the_worse_plate_is_held_and_the_other_only_when_still_too_far(off_a, off_b, klass_b, held):
    records = dict([_record("a", "developable", off_a), _record("b", klass_b, off_b)])
    picked = _to_hold(_pair(off_a + off_b), records, 1.0, 1)
    assert [name for name, _ in picked] == held
    assert all("step" in record["reason"] and record["step_limit_mm"] == 2.1 for _, record in picked)


def test_a_flat_plate_first_tries_a_plane_holding_its_edges_then_a_patch():
    records = dict([_record("a", "flat", 4.0), _record("b", "formed", 0.0)])
    (_, first), = _to_hold(_pair(4.0), records, 1.0, 1)
    assert first["edge_limit"] == pytest.approx(1.05)  # half the pair's limit, model units (mm)
    records = dict([_record("a", "flat", 3.0, held=first), _record("b", "formed", 0.0)])
    (_, second), = _to_hold(_pair(3.0), records, 1.0, 2)
    assert "edge_limit" not in second and second["round"] == 2
    records = dict([_record("a", "formed", 0.0, held=second), _record("b", "formed", 0.0)])
    assert _to_hold(_pair(3.0), records, 1.0, 3) == []  # nothing left to hold: reported as unrepaired


def test_a_length_mismatch_holds_the_plate_further_off_only():
    records = dict([_record("a", "developable", 1.0), _record("b", "developable", 1.5)])
    picked = _to_hold(_pair(1.0, mismatch=2.0), records, 1.0, 1)
    assert [name for name, _ in picked] == ["b"] and "developed lengths differ" in picked[0][1]["reason"]


def test_fit_up_mode_is_checked(tmp_path, capsys):
    path = shoulder(tmp_path, fit_up="fix")
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "fit_up" in err and "fix" in err and str(path) in err
    assert not (tmp_path / "out").exists()


def test_a_held_plate_whose_seam_strip_keeps_its_edges_on_the_hull_stays_developable(tmp_path):
    """A flat plate of the 160 m hull's bottom (seams v = 0.634 and 1.006, butts x = 101.25 and
    106.67 m): flat within the tolerance on its minimax plane, whose edges leave the hull further
    than half a 14 mm plate's step limit. Held for its fit-up it is not made a patch: the strip
    between its seams fits the hull and its edges lie within the limit (its seams are on the
    hull), so it is delivered as that strip, and says so."""
    from pipeline.hull.plates import edge_deviation

    path = shoulder(tmp_path, seams=[{"iso": {"v": 0.6337212004946159}}, {"iso": {"v": 1.006477178601899}}],
                    butts=[101250.0, 106666.667])
    config = load_run(path)
    part, = config.parts
    plain = evaluate_plate(part, config)
    limit = 1.05
    assert plain.figures["plate_class"]["class"] == "flat" and edge_deviation(plain) > 4 * limit
    part.hull.held = {"reason": "fit-up repair: test", "edge_limit": limit}
    held = evaluate_plate(part, config)
    klass = held.figures["plate_class"]
    assert klass["class"] == "developable" and klass["family"] == "rulings seam to seam"
    assert "held for its fit-up" in klass["method"]
    off = edge_deviation(held)
    assert off is not None and off <= limit
    assert held.figures["region"]["area_m2"] == pytest.approx(plain.figures["region"]["area_m2"], rel=1e-12)


def test_a_held_bottom_plate_is_kept_as_its_seam_strip_and_its_neighbour_then_fits(tmp_path):
    """Two plates of the 160 m hull's bottom (seams v = 0.634, 1.006, 1.2; butts x = 101.25 and
    106.67 m): the flat one steps from its strip neighbour by more than 2.1 mm at their seam.
    The repair holds it and keeps it developable (its seam strip), and the pair fits; the
    report names it as kept."""
    seams = [{"iso": {"v": v}} for v in (0.6337212004946159, 1.006477178601899, 1.2)]
    for folder in ("report", "repair"):
        (tmp_path / folder).mkdir()
    plain = load_run(shoulder(tmp_path / "report", seams=seams, butts=[101250.0, 106666.667]), evaluate_plate)
    results = [run_part(part, plain) for part in plain.parts]
    before = shell_fitup(results, plain)
    assert [r.figures["plate_class"]["class"] for r in results] == ["flat", "developable"]
    assert [q.misfit for q in before.pairs] == [True]
    config = load_run(shoulder(tmp_path / "repair", seams=seams, butts=[101250.0, 106666.667], fit_up="repair"),
                      evaluate_plate)
    report = config.fitup_repair
    assert report.held == ["fit_S1_B1"] and report.kept == ["fit_S1_B1"] and not report.unrepaired
    assert "1 kept flat or as a strip" in report.one_line()
    results = [run_part(part, config) for part in config.parts]
    after = shell_fitup(results, config)
    assert [q.misfit for q in after.pairs] == [False] and after.pairs[0].step_max < 2.1
    klass = results[0].figures["plate_class"]
    assert klass["class"] == "developable" and "held for its fit-up" in klass["method"]


@pytest.mark.parametrize("klass, step, mismatch, limited", [
    ("developable", 4.0, 0.0, True),  # a step: its seam strip may keep its edges on the hull
    ("developable", 1.0, 2.0, False),  # its developed length alone: the same strip would come back
    ("flat", 1.0, 2.0, True),  # a flat plate tries the edge-held plane (and its seam strip)
])
def test_a_plate_held_the_first_time_gets_an_edge_limit_where_it_may_keep_its_class(klass, step, mismatch, limited):
    records = dict([_record("a", "developable", 0.5), _record("b", klass, step)])
    picked = dict(_to_hold(_pair(step, mismatch=mismatch), records, 1.0, 1))
    assert list(picked) == ["b"]
    assert ("edge_limit" in picked["b"]) == limited
