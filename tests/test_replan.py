"""plan.replan_held (pipeline/hull/replan.py): a plan made again after the fit-up, splitting
the plates strake.hold_steps held and delivered formed.

A bilge of the parallel midbody (a cylinder along x) is planned as two 10 m strips. The plan
counts a plate it is told was lost at a fit-up as not fitting and splits it as it splits any
plate that does not fit, within max_splits; the run keeps the plan whose fit-up left the
fewest pairs stepping, then the highest delivered flat + strip share. The fit-up here is a
stand-in that holds named plates (the real hold is tested in test_fitup_hold, and what it
reports is what lost_plates reads there): what is tested is the loop around it, with the
run's own evaluator and its cache."""

import json
from pathlib import Path
from types import SimpleNamespace

import pytest
import yaml

from pipeline.hull import plan as plan_module
from pipeline.hull.follow import FollowReport
from pipeline.hull.replan import lost_plates, region_key
from tests.hull_shapes import cylinder_along_iges

STOCK = {"max_length": 10500, "max_width": 5000, "min_length": 3000, "min_width": 1000}


def _config(tmp_path: Path, name: str, replan_held: int = 1, max_splits: int = 2, **strake) -> Path:
    tmp_path.mkdir(parents=True, exist_ok=True)
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


def test_the_plates_lost_are_those_held_from_flat_or_strip_to_neither_known_by_their_regions():
    def plate(name, g):
        girths = (SimpleNamespace(s=(0.0, 1.0), g=(g, g)), SimpleNamespace(s=(0.0, 1.0), g=(g + 0.1, g + 0.1)))
        return SimpleNamespace(name=name, hull=SimpleNamespace(girths=girths, butts=(None, None)))

    parts = [plate(name, 0.1 * k) for k, name in enumerate("abcdef")]
    lost = lost_plates({"a": _held("SEAM 3"), "b": _held("BUTT X13333", before="flat"),
                        "c": _held("SEAM 1", after="developable"), "d": _held("SEAM 1", before="flat", after="flat"),
                        "e": _held("SEAM 1", before="formed"), "f": _held("BUTT X1", after="patch"),
                        "gone": _held("SEAM 1")}, parts)
    assert lost == frozenset((p.name, region_key(p.hull)) for p in parts if p.name in "abf")


def _stand_in_fit_up(holds: list, calls: list, untaken: tuple = (), fail_at: int | None = None):
    """A fit-up that holds, on its n-th call, the plates of ``holds[n]`` present in the plan
    and delivers them formed (their class record says so, and the part is marked held as the
    real hold marks it), leaving ``untaken[n]`` pairs of flat or strip plates stepping; its
    ``fail_at``-th call raises. Each call's parts are recorded in ``calls``."""

    def fit_up(parts, spec, config, evaluate, seconds):
        if len(calls) == fail_at:
            raise RuntimeError("the stand-in fit-up fails")
        names = {p.name for p in parts}
        held = {name: _held("SEAM 1") for name in holds[len(calls)] if name in names}
        left = untaken[len(calls)] if len(calls) < len(untaken) else 0
        calls.append(list(parts))
        for part in parts:
            if part.name in held:
                result = part.hull.result
                result.figures["plate_class"] = dict(result.figures["plate_class"], **{"class": "formed"})
                part.hull.held = {"edge": "SEAM 1"}
        report = FollowReport(held=held, untaken=[("a", "b", "SEAM 1", 3.5)] * left)
        return None, report, (seconds[0] + 1.0, seconds[1] + 1.0)

    return fit_up


def _load(path: Path):
    from pipeline.runner import plate_evaluator

    return plan_module.load_run(path, plate_evaluator(1))  # its cache: a plan made again asks for plates again


def _names(parts) -> list:
    return sorted(p.name for p in parts)


def test_a_plate_lost_at_the_fit_up_is_split_and_the_better_plan_kept(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(plan_module, "_fit_up", _stand_in_fit_up([["bilge_S01_B01"], []], calls))
    config = _load(_config(tmp_path, "bilge", replan_held=2))
    first, second = calls
    assert _names(first) == ["bilge_S01_B01", "bilge_S01_B02"]
    assert all(p.hull.result.figures["plate_class"]["class"] == "developable" for p in first
               if p.name != "bilge_S01_B01")  # the control: the other plate a strip as planned
    assert _names(second) == ["bilge_S01_B01-1", "bilge_S01_B01-2", "bilge_S01_B02"]
    assert config.parts == second  # the plan kept, with its own record and fit-up
    assert config.plan_record.points[-1].plates == 3 and config.plan_record.points[-1].kept
    assert config.fitup_follow.held == {}
    halves = [p for p in config.parts if p.name.startswith("bilge_S01_B01-")]
    whole = next(p for p in config.parts if p.name == "bilge_S01_B02")
    # two strips that share a butt plane or a seam and cover the plate (its mirror's area)
    assert halves[0].hull.butts[1] == halves[1].hull.butts[0] or halves[0].hull.girths[1] is halves[1].hull.girths[0]
    area = sum(h.hull.result.figures["region"]["area_m2"] for h in halves)
    assert area == pytest.approx(whole.hull.result.figures["region"]["area_m2"], rel=1e-3)
    for half in halves:
        assert half.hull.result.figures["plate_class"]["class"] == "developable"
        assert half.hull.plan["depth"] == 1 and "held_at_fit_up_before" not in half.hull.plan
    # the plate both plans ask for comes from the cache; its owed work is not done on the
    # first plan's part, which that plan's fit-up changed
    before = next(p for p in first if p.name == "bilge_S01_B02")
    work = whole.hull.result.shop_work
    assert work is not None and work.part is not before and work.part.hull is not before.hull
    report = config.replan
    assert report.kept == 1 and len(report.plans) == 2
    assert report.plans[0]["held_lost"] == ["bilge_S01_B01"]
    assert report.plans[1]["asked_split"] == ["bilge_S01_B01"] and report.plans[1]["asked_not_split"] == []
    assert report.plans[0]["delivered_flat_strip"] == pytest.approx(0.5, abs=0.01)  # one of two equal plates
    assert report.plans[1]["delivered_flat_strip"] == pytest.approx(1.0)
    assert report.stopped == "the last fit-up held no plate that lost its flat or strip class"
    assert config.fitup_seconds == (2.0, 2.0)  # both fit-ups counted
    assert "plan 2 kept" in report.one_line()


def test_a_plan_made_again_that_delivers_less_is_not_kept(tmp_path, monkeypatch):
    calls = []
    holds = [["bilge_S01_B01"], ["bilge_S01_B01-1", "bilge_S01_B01-2", "bilge_S01_B02"]]
    monkeypatch.setattr(plan_module, "_fit_up", _stand_in_fit_up(holds, calls))
    config = _load(_config(tmp_path, "bilge", replan_held=1))
    assert len(calls) == 2
    assert config.parts == calls[0]
    report = config.replan
    assert report.kept == 0 and report.plans[1]["delivered_flat_strip"] == pytest.approx(0.0)
    assert config.fitup_follow.held.keys() == {"bilge_S01_B01"}  # the kept plan's own fit-up
    assert config.plan_record.points[-1].plates == 2
    assert report.stopped == "plan.replan_held = 1 plans made again"
    assert report.as_dict()["plans"][1]["held_lost"] == holds[1]


def test_a_plan_that_leaves_steps_is_not_kept_for_its_share_and_a_tie_keeps_the_first(tmp_path, monkeypatch):
    # the second plan delivers more, but its fit-up left a pair of strips stepping
    calls = []
    monkeypatch.setattr(plan_module, "_fit_up", _stand_in_fit_up([["bilge_S01_B01"], []], calls, untaken=(0, 1)))
    config = _load(_config(tmp_path / "stepping", "bilge", replan_held=1))
    assert len(calls) == 2 and config.parts == calls[0] and config.replan.kept == 0
    assert [p["untaken"] for p in config.replan.plans] == [0, 1]
    # the same share and steps: the first plan stands
    calls = []
    holds = [["bilge_S01_B01"], ["bilge_S01_B01-1", "bilge_S01_B01-2"]]  # the halves are one plate's area
    monkeypatch.setattr(plan_module, "_fit_up", _stand_in_fit_up(holds, calls))
    config = _load(_config(tmp_path / "tie", "bilge", replan_held=1))
    shares = [p["delivered_flat_strip"] for p in config.replan.plans]
    assert shares[1] == pytest.approx(shares[0], abs=1e-3) and config.replan.kept == 0


def test_plates_lost_in_every_plan_before_stay_counted_as_not_fitting(tmp_path, monkeypatch):
    calls = []
    holds = [["bilge_S01_B01"], ["bilge_S01_B01-1"], []]
    monkeypatch.setattr(plan_module, "_fit_up", _stand_in_fit_up(holds, calls))
    config = _load(_config(tmp_path, "bilge", replan_held=2))
    assert len(calls) == 3
    assert config.replan.plans[2]["asked_split"] == ["bilge_S01_B01", "bilge_S01_B01-1"]
    third = _names(calls[2])
    assert "bilge_S01_B01" not in third and "bilge_S01_B01-1" not in third
    assert {"bilge_S01_B01-1-1", "bilge_S01_B01-1-2", "bilge_S01_B01-2", "bilge_S01_B02"} == set(third)
    assert config.replan.kept == 2


def test_a_plan_made_again_unchanged_is_not_fitted_up_and_a_failing_one_leaves_the_first(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(plan_module, "_fit_up", _stand_in_fit_up([["bilge_S01_B02"], []], calls))
    config = _load(_config(tmp_path / "whole", "bilge", replan_held=2, max_splits=0))
    assert len(calls) == 1 and config.parts == calls[0]  # no split allowed: the same plan, not fitted up again
    assert config.replan.stopped == "the plan made again is the plan before: no plate lost could be split"
    calls = []
    monkeypatch.setattr(plan_module, "_fit_up", _stand_in_fit_up([["bilge_S01_B01"], []], calls, fail_at=1))
    config = _load(_config(tmp_path / "failing", "bilge", replan_held=2))
    assert len(calls) == 1 and config.parts == calls[0] and config.replan.kept == 0
    assert config.replan.stopped == "plan 2 failed: RuntimeError: the stand-in fit-up fails"


def test_the_run_reports_the_plans_made_again(tmp_path, monkeypatch, capsys):
    from pipeline.cli import main

    monkeypatch.setattr(plan_module, "_fit_up", _stand_in_fit_up([["bilge_S01_B01"], []], []))
    out = tmp_path / "out"
    assert main(["run", str(_config(tmp_path, "bilge", replan_held=1)), "--out", str(out)]) == 0
    assert "replan: 2 plan(s), flat + strip after fit-up 50.00 %, 100.00 %; plan 2 kept" in capsys.readouterr().out
    summary = json.loads((out / "bilge_summary.json").read_text())
    replan = summary["shell"]["replan"]
    assert replan["kept"] == 1 and [p["plates"] for p in replan["plans"]] == [2, 3]
    assert {p["id"] for p in summary["parts"]} == {"bilge_S01_B01-1", "bilge_S01_B01-2", "bilge_S01_B02"}
    plan = json.loads((out / "bilge_S01_B02.json").read_text())["plan"]
    assert plan["stopped"] == "fits"


def test_a_lost_plate_at_max_splits_stays_whole_and_says_so(tmp_path):
    from pipeline.config import load_config
    from pipeline.hull.plan import _Judge
    from pipeline.hull.planner import plan_hull
    from pipeline.hull.plates import evaluate_plate

    path = _config(tmp_path, "bilge", replan_held=0, max_splits=0)
    config = load_config(path)
    judge = _Judge(evaluate_plate, config)
    first = plan_hull(config.spec, path, config.mm_per_unit, config.lines, judge)
    lost = ("bilge_S01_B02", region_key(first[1].hull))
    # the same name over another region (a neighbour's split moved its butts) is another plate
    elsewhere = ("bilge_S01_B02", region_key(first[0].hull))
    other = plan_hull(config.spec, path, config.mm_per_unit, config.lines, judge, lost=frozenset({elsewhere}))
    assert "held_at_fit_up_before" not in other[1].hull.plan
    parts = plan_hull(config.spec, path, config.mm_per_unit, config.lines, judge, lost=frozenset({lost}))
    assert [p.name for p in parts] == ["bilge_S01_B01", "bilge_S01_B02"]
    assert parts[1].hull.plan == {"depth": 0, "class_for_plan": "developable", "method": "adaptive",
                                  "stopped": "max_splits = 0", "held_at_fit_up_before": True}
    assert parts[0].hull.plan["stopped"] == "fits" and "held_at_fit_up_before" not in parts[0].hull.plan


def test_replan_held_without_hold_steps_is_refused_naming_both_fields(tmp_path, capsys):
    from pipeline.cli import main

    path = _config(tmp_path, "bilge", hold_steps=False)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{path.name}:" in err and "plan.replan_held: 1" in err and "hold_steps: false" in err
    assert not (tmp_path / "out").exists()
    data = yaml.safe_load(path.read_text())
    data["strake"]["hold_steps"] = True
    data["strake"]["plan"]["method"] = "uniform"
    path.write_text(yaml.safe_dump(data))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{path.name}:" in err and "plan.replan_held: 1" in err and "plan.method: uniform" in err
    assert not (tmp_path / "out").exists()


def test_a_plan_made_again_asks_for_no_split_the_plans_before_chose(tmp_path, monkeypatch):
    """A bilge tube bowed on a 30 m radius: its 10 m plates stand 420 mm off their strips and
    are split. A plan made again in the same run (the same judge) asks for the same splits,
    which are answered from the plans before (a split depends on its job alone), and it is
    the same plan; a run of its own (another judge) works them out again."""
    from pipeline.config import load_config
    from pipeline.hull import planner
    from pipeline.hull.plan import _Judge
    from pipeline.runner import plate_evaluator
    from tests.hull_shapes import bowed_bilge_iges

    iges = bowed_bilge_iges(tmp_path / "bowed.igs", bow=30000.0)
    path = _config(tmp_path, "bowed", replan_held=0, max_splits=1)
    data = yaml.safe_load(path.read_text())
    data["strake"]["surface"]["iges"] = str(iges)
    data["strake"]["plan"]["stock"] = {"max_length": 10000, "max_width": 3500, "min_length": 3000, "min_width": 1000}
    path.write_text(yaml.safe_dump(data))
    config = load_config(path)
    worked_out = []
    chooser = planner._region_split

    def counted(job):
        worked_out.append(planner._without_surface(job))
        return chooser(job)

    monkeypatch.setattr(planner, "_region_split", counted)
    judge = _Judge(plate_evaluator(1), config)

    def planned(judge):
        parts = planner.plan_hull(config.spec, path, config.mm_per_unit, config.lines, judge)
        return [(p.name, region_key(p.hull)) for p in parts]

    first = planned(judge)
    chosen = len(worked_out)
    assert chosen >= 2 and len(set(worked_out)) == chosen
    assert len(first) > 2  # the two plates split
    assert planned(judge) == first and len(worked_out) == chosen
    assert planned(_Judge(plate_evaluator(1), config)) == first and len(worked_out) == 2 * chosen
