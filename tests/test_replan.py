"""plan.replan_held (pipeline/hull/replan.py): a plan made again after the fit-up, splitting
the plates strake.hold_steps held and delivered formed across the edge that held them.

A bilge of the parallel midbody (a cylinder along x) is planned as two 10 m strips. The plan
counts a plate it is told was lost at a fit-up as not fitting and splits it as it splits any
plate that does not fit, within max_splits; the run keeps the plan whose delivered flat +
strip share is the highest. The fit-up here is a stand-in that
holds a named plate (the real hold is tested in test_fitup_hold): what is tested is the loop
around it."""

from pathlib import Path

import pytest
import yaml

from pipeline.hull import plan as plan_module
from pipeline.hull.follow import FollowReport
from pipeline.hull.replan import delivered_share, lost_plates
from tests.hull_shapes import cylinder_along_iges

STOCK = {"max_length": 10500, "max_width": 5000, "min_length": 3000, "min_width": 1000}


def _config(tmp_path: Path, name: str, replan_held: int = 1, max_splits: int = 2, **strake) -> Path:
    iges = tmp_path / "bilge.igs"
    if not iges.exists():
        cylinder_along_iges(iges)
    plan = {"method": "adaptive", "max_splits": max_splits, "stock": STOCK}
    if replan_held:
        plan["replan_held"] = replan_held
    data = {"name": name, "units": "mm", "resolution": {"chord_tolerance": 1.0}, "steel": {"thickness": 14},
            "output": {"png": False, "dxf": False}, "shop": {"stock": [[6000, 12000]]},
            "strake": {"surface": {"iges": str(iges)}, "margin": 0.2, "fit_tolerance": 5.0, "plan": plan,
                       "fit_up": "follow", "hold_steps": True, **strake}}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _held(edge: str, before: str = "developable", after: str = "formed") -> dict:
    return {"round": 1, "class_before": before, "class_after": after, "edge": edge, "neighbour": "n",
            "step_mm": 3.0, "edge_deviation_before_mm": 2.0, "undone": []}


def test_the_plates_lost_are_those_held_from_flat_or_strip_to_neither():
    lost = lost_plates({"a": _held("SEAM 3"), "b": _held("BUTT X13333", before="flat"),
                        "c": _held("SEAM 1", after="developable"), "d": _held("SEAM 1", before="flat", after="flat"),
                        "e": _held("SEAM 1", before="formed"), "f": _held("BUTT X1", after="patch")})
    assert lost == frozenset({"a", "b", "f"})


def _stand_in_fit_up(holds: list, calls: list):
    """A fit-up that holds, on its n-th call, the plates of ``holds[n]`` present in the plan
    and delivers them formed (their class record says so); the plan's parts are recorded."""

    def fit_up(parts, spec, config, evaluate, seconds):
        names = {p.name for p in parts}
        held = {name: _held("SEAM 1") for name in holds[len(calls)] if name in names}
        calls.append(sorted(names))
        for part in parts:
            if part.name in held:
                result = part.hull.result
                result.figures["plate_class"] = dict(result.figures["plate_class"], **{"class": "formed"})
        return None, FollowReport(held=held), (seconds[0] + 1.0, seconds[1] + 1.0)

    return fit_up


def _load(path: Path):
    from pipeline.hull.plates import evaluate_plate

    return plan_module.load_run(path, evaluate_plate)


def test_a_plate_lost_at_the_fit_up_is_split_and_the_better_plan_kept(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(plan_module, "_fit_up", _stand_in_fit_up([["bilge_S01_B01"], []], calls))
    config = _load(_config(tmp_path, "bilge", replan_held=2))
    first, second = calls
    assert first == ["bilge_S01_B01", "bilge_S01_B02"]  # the control: both plates strips as planned
    assert second == ["bilge_S01_B01-1", "bilge_S01_B01-2", "bilge_S01_B02"]
    assert sorted(p.name for p in config.parts) == second
    halves = [p for p in config.parts if p.name.startswith("bilge_S01_B01-")]
    whole = next(p for p in config.parts if p.name == "bilge_S01_B02")
    # two strips that share a butt plane or a seam and cover the plate (its mirror's area)
    assert halves[0].hull.butts[1] == halves[1].hull.butts[0] or halves[0].hull.girths[1] is halves[1].hull.girths[0]
    area = sum(h.hull.result.figures["region"]["area_m2"] for h in halves)
    assert area == pytest.approx(whole.hull.result.figures["region"]["area_m2"], rel=1e-3)
    for half in halves:
        assert half.hull.result.figures["plate_class"]["class"] == "developable"
        assert half.hull.plan["depth"] == 1 and "held_at_fit_up_before" not in half.hull.plan
    report = config.replan
    assert report.kept == 1 and len(report.plans) == 2
    assert report.plans[0]["held_lost"] == ["bilge_S01_B01"]
    assert report.plans[1]["asked_split"] == ["bilge_S01_B01"] and report.plans[1]["asked_not_split"] == []
    assert report.plans[0]["delivered_flat_strip"] == pytest.approx(0.5, abs=0.01)  # one of two equal plates
    assert report.plans[1]["delivered_flat_strip"] == pytest.approx(1.0)
    assert report.plans[1]["delivered_flat_strip"] == pytest.approx(delivered_share(config.parts))
    assert report.stopped == "the last fit-up held no plate that lost its flat or strip class"
    assert config.fitup_seconds == (2.0, 2.0)  # both fit-ups counted
    assert "plan 2 kept" in report.one_line()


def test_a_plan_made_again_that_delivers_less_is_not_kept(tmp_path, monkeypatch):
    calls = []
    holds = [["bilge_S01_B01"], ["bilge_S01_B01-1", "bilge_S01_B01-2", "bilge_S01_B02"]]
    monkeypatch.setattr(plan_module, "_fit_up", _stand_in_fit_up(holds, calls))
    config = _load(_config(tmp_path, "bilge", replan_held=1))
    assert len(calls) == 2
    assert [p.name for p in config.parts] == ["bilge_S01_B01", "bilge_S01_B02"]
    report = config.replan
    assert report.kept == 0 and report.plans[1]["delivered_flat_strip"] == pytest.approx(0.0)
    assert config.fitup_follow.held.keys() == {"bilge_S01_B01"}  # the kept plan's own fit-up
    assert report.stopped == "plan.replan_held = 1 plans made again"
    assert report.as_dict()["plans"][1]["held_lost"] == holds[1]


def test_a_lost_plate_at_max_splits_stays_whole_and_says_so(tmp_path):
    from pipeline.config import load_config
    from pipeline.hull.plan import _Judge
    from pipeline.hull.planner import plan_hull
    from pipeline.hull.plates import evaluate_plate

    path = _config(tmp_path, "bilge", replan_held=0, max_splits=0)
    config = load_config(path)
    parts = plan_hull(config.spec, path, config.mm_per_unit, config.lines, _Judge(evaluate_plate, config),
                      lost=frozenset({"bilge_S01_B02"}))
    assert [p.name for p in parts] == ["bilge_S01_B01", "bilge_S01_B02"]
    assert parts[1].hull.plan == {"depth": 0, "class_for_plan": "developable", "method": "adaptive",
                                  "stopped": "max_splits = 0", "held_at_fit_up_before": True}
    assert parts[0].hull.plan["stopped"] == "fits" and "held_at_fit_up_before" not in parts[0].hull.plan


def test_replan_held_without_hold_steps_is_refused_naming_both_fields(tmp_path, capsys):
    from pipeline.cli import main

    path = _config(tmp_path, "bilge", hold_steps=False)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{path.name}:" in err and "plan.replan_held: 1" in err and "hold_steps: False" in err
    assert not (tmp_path / "out").exists()
