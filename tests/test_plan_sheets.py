"""A plan's plates fit the stock sheets by their developments, not only by their regions
(pipeline/hull/sheets.py, ``planner._onto_sheets``): a strake that runs round a cone
develops into an annular sector whose rectangle is wider than its girth."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.hull.cost import off_sheets
from pipeline.hull.sheets import Sheets, development_need
from tests.hull_shapes import write_iges_surface

HALF_ARC = np.radians(15.0)  # the strake runs from -15 to +15 deg round the cone's axis (z)
R_LOW, R_HIGH, RISE = 18500.0, 21500.0, 1500.0  # mm: the frustum's radii at z = 0 and z = RISE


def frustum_iges(path: Path, r_high: float = R_HIGH, rise: float = RISE) -> Path:
    """A strake of a cone of axis z: u round the axis (a rational arc of 30 deg, symmetric
    about the y axis, so the plane x = 0 is a generator), v up the generators from radius
    18.5 m to ``r_high`` (21.5 m) over a ``rise`` (1.5 m)."""
    c, s = np.cos(HALF_ARC), np.sin(HALF_ARC)

    def arc(r, z):
        return [[-r * s, r * c, z], [0.0, r / c, z], [r * s, r * c, z]]

    poles = np.array([arc(R_LOW, 0.0), arc(r_high, rise)]).transpose(1, 0, 2)
    weights = np.array([[1.0, 1.0], [c, c], [1.0, 1.0]])
    return write_iges_surface(path, 2, 1, poles, weights, [0, 0, 0, 1, 1, 1], [0, 0, 1, 1])


def sector_need(clearance: float, pieces: int = 1) -> np.ndarray:
    """(short, long) mm of the development of the cone strake (or of one of ``pieces`` equal
    pieces cut along generators), an annular sector of the developed cone (slant radii
    r / sin a, angle 2 HALF_ARC sin a / pieces), in its symmetric rectangle, plus the
    clearance on every side."""
    sin_a = (R_HIGH - R_LOW) / np.hypot(R_HIGH - R_LOW, RISE)
    inner, outer, half = R_LOW / sin_a, R_HIGH / sin_a, HALF_ARC * sin_a / pieces
    return np.sort([outer - inner * np.cos(half), 2.0 * outer * np.sin(half)]) + 2.0 * clearance


def _config(tmp_path: Path, name: str, sheets: list, objective: dict | None = None, iges: Path | None = None,
            max_length: float = 12000.0) -> Path:
    iges = iges or frustum_iges(tmp_path / "frustum.igs")
    data = {"name": name, "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
            "strake": {"surface": {"iges": str(iges)}, "margin": 0.2,
                       "fit_tolerance": 5.0,
                       "plan": {"method": "adaptive", "max_splits": 0,
                                "stock": {"max_length": max_length, "max_width": 3500, "min_length": 1000,
                                          "min_width": 1000}}},
            "shop": {"stock": sheets, "stock_margin": 10.0}}
    if objective is not None:  # the yard's plan: its rules (the butt stagger) on the split too
        data["strake"]["plan"]["objective"] = objective
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_the_smallest_rectangle_of_a_turned_rectangle_is_its_own_sides_plus_the_clearance():
    angle = np.radians(30.0)
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    corners = np.array([[0.0, 0.0], [3000.0, 0.0], [3000.0, 1000.0], [0.0, 1000.0]]) @ turn.T + [500.0, -200.0]
    sheets = Sheets(((1020.0, 3020.0), (2000.0, 4000.0)), 10.0)
    assert sheets.need(corners) == pytest.approx([1020.0, 3020.0], abs=1e-6)
    assert sheets.holding(sheets.need(corners)) == (1020.0, 3020.0)  # the smaller of the two that hold it
    assert Sheets(((1019.0, 3020.0),), 10.0).holding(sheets.need(corners)) is None
    points_on_a_line = np.array([[0.0, 0.0], [1000.0, 1000.0], [2000.0, 2000.0]])
    assert Sheets((), 5.0).need(points_on_a_line) == pytest.approx([10.0, 2000.0 * np.sqrt(2) + 10.0])


def test_the_clearance_is_the_stock_margin_and_the_largest_allowance():
    from pipeline.config import Shop

    shop = Shop(stock=[(16000.0, 3500.0)], stock_margin=12.0, excess={"c": 0, "d": 0, "start": 30, "end": 50},
                shrinkage=5.0)
    sheets = Sheets.of_shop(shop)
    assert sheets.sizes == ((3500.0, 16000.0),)
    assert sheets.clearance == 12.0 + 55.0


@pytest.mark.parametrize("objective", [None, {"maximise": "flat_strip", "weld_factor": 1.5}])
def test_a_plate_whose_development_no_sheet_holds_is_split_until_its_halves_are_held(tmp_path, monkeypatch,
                                                                                    objective):
    """The cone strake (30 deg round at 18.5-21.5 m, 3.35 m up the generators) is one plate
    within the plan's stock (12 m x 3.5 m), formed (an end plate both ways, rolled only;
    ``max_splits: 0`` keeps it whole for its fit), but its development, an annular sector,
    needs 3.94 x 11.18 m with 10 mm margins: no 3.6 m sheet holds it (measured against the
    sector's closed form). The plan splits it at the butt x = 0, a generator: the two halves
    are strips a sheet holds (3.52 x 5.64 m), where a girth split's would be formed."""
    from pipeline.hull import planner
    from pipeline.hull.plan import load_run
    from pipeline.runner import plate_evaluator

    path = _config(tmp_path, "cone", [[3600, 12000]], objective)
    sheets = Sheets(((3600.0, 12000.0),), 10.0)
    with monkeypatch.context() as patched, plate_evaluator(1) as evaluator:
        patched.setattr(planner, "_onto_sheets", lambda kept, build, ctx: kept)
        unchecked = load_run(path, evaluator)
        evaluator.develop([p.hull.result for p in unchecked.parts], unchecked)
    assert len(unchecked.parts) == 1
    whole = development_need(unchecked.parts[0].hull.result, sheets, 1.0)
    assert whole == pytest.approx(sector_need(10.0), abs=5.0)
    assert sheets.holding(whole) is None
    # the plan's cost judges a plate without the shop's check by its development
    assert off_sheets([p.hull.result for p in unchecked.parts], 1.0, sheets) == [
        {"plate": unchecked.parts[0].name, "needed_mm": list(whole)}]

    with plate_evaluator(1) as evaluator:
        run = load_run(path, evaluator)
    assert len(run.parts) == 2
    assert {p.hull.butt_names for p in run.parts} == {("HULL END", "BUTT X0"), ("BUTT X0", "HULL END")}
    for part in run.parts:
        need = development_need(part.hull.result, sheets, 1.0)
        assert sheets.holding(need) == (3600.0, 12000.0), need
        assert part.hull.plan["stopped"] == "fits"
    assert run.plan_record.splits_taken == 1
    assert off_sheets([p.hull.result for p in run.parts], 1.0, sheets) == []
    assert run.plan_record.points[-1].plates == 2 and run.plan_record.points[-1].kept


def test_the_plan_splits_for_the_sheets_with_tapering_halves_allowed(tmp_path, monkeypatch):
    """The splits for the sheets are chosen with the tapering rule (a plate that no sheet
    holds is not left whole for a taper it has anyway): every split chosen for the cone
    (``max_splits: 0``: the plan itself splits nothing) is chosen with it."""
    from pipeline.hull import planner
    from pipeline.hull.plan import load_run
    from pipeline.runner import plate_evaluator

    asked = []

    def choose(*args, tapering=False, **kwargs):
        asked.append(tapering)
        return choose_split(*args, tapering=tapering, **kwargs)

    choose_split = planner.choose_split
    monkeypatch.setattr(planner, "choose_split", choose)
    with plate_evaluator(1) as evaluator:
        run = load_run(_config(tmp_path, "cone", [[3600, 12000]]), evaluator)
    assert len(run.parts) == 2 and asked and all(asked)


def test_the_plan_record_reads_the_class_again_once_the_kept_plate_is_developed(tmp_path, monkeypatch):
    """The cone plate is kept formed (a sheet holds anything here); its development, done
    once it is kept, fails it: its plan record says failed, not the class it was kept with."""
    from pipeline.hull import plateshop
    from pipeline.hull.plan import load_run
    from pipeline.runner import plate_evaluator

    def failing(result, config):
        result.status, result.reason = "failed", "the development raised (made up)"
        return result

    monkeypatch.setattr(plateshop, "develop", failing)
    with plate_evaluator(1) as evaluator:
        run = load_run(_config(tmp_path, "cone", [[10000, 40000]]), evaluator)
    [part] = run.parts
    assert part.hull.plan["class_for_plan"] == "failed" and part.hull.plan["depth"] == 0


def test_the_shop_finds_a_sheet_for_every_plate_of_the_run(tmp_path, monkeypatch, capsys):
    """The whole run, judged by the shop's own stock check on each plate's cut outline: every
    plate is placed on a sheet, needing what half the sector does, and none warns that no
    stock plate fits. The control, the plan's check left out: the one plate needs the whole
    sector, the shop warns, and the plan's cost and its console line name it."""
    import json

    from pipeline.cli import main
    from pipeline.hull import planner

    def plates_of(out: Path) -> list:
        return [json.loads(p.read_text()) for p in out.glob("cone_*.json") if "summary" not in p.name]

    path = _config(tmp_path, "cone", [[3600, 12000]])
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 0
    plates = plates_of(tmp_path / "out")
    assert len(plates) == 2
    for plate in plates:
        assert plate["stock"]["fits_on"] == [3600.0, 12000.0]
        assert plate["stock"]["needed"] == pytest.approx(sector_need(10.0, pieces=2), abs=5.0)
        assert not [w for w in plate["warnings"] if "no stock plate fits" in w]
        # the plate's JSON says how the plan came to it: one split deep, kept for its fit
        assert plate["plan"]["depth"] == 1 and plate["plan"]["stopped"] == "fits"
        assert plate["plan"]["class_for_plan"] == plate["plate_class"]["class"]
    summary = json.loads((tmp_path / "out" / "cone_summary.json").read_text())
    assert summary["plan_cost"]["off_sheets"] == []
    assert "on no stock sheet" not in capsys.readouterr().out

    monkeypatch.setattr(planner, "_onto_sheets", lambda kept, build, ctx: kept)
    assert main(["run", str(path), "--out", str(tmp_path / "control")]) == 0
    [plate] = plates_of(tmp_path / "control")
    assert plate["stock"]["fits_on"] is None and plate["stock"]["needed"] == pytest.approx(sector_need(10.0), abs=5.0)
    assert [w for w in plate["warnings"] if "no stock plate fits" in w]
    assert plate["plan"] == {"depth": 0, "class_for_plan": plate["plate_class"]["class"], "method": "adaptive",
                             "stopped": "max_splits = 0"}  # the plan's check left out
    summary = json.loads((tmp_path / "control" / "cone_summary.json").read_text())
    assert summary["plan_cost"]["off_sheets"] == [{"plate": plate["name"], "needed_mm": plate["stock"]["needed"]}]
    assert "1 on no stock sheet" in capsys.readouterr().out


def test_neighbours_split_for_the_sheets_keep_their_butts_staggered(tmp_path):
    """Twice the cone's girth (18.5 to 24.5 m over a 3 m rise): two strakes of one plate each,
    neither held by a 3.6 m sheet. Under the yard's rules both are split for the sheets, and
    the butts across their common seam keep the 300 mm stagger: the second plate's best butt
    (x = 0, in line with the first's) waits a round and is chosen again against it."""
    from pipeline.hull.plan import load_run
    from pipeline.hull.yardrules import butt_violations
    from pipeline.runner import plate_evaluator

    iges = frustum_iges(tmp_path / "wide.igs", r_high=24500.0, rise=3000.0)
    path = _config(tmp_path, "wide", [[3600, 16000]], {"maximise": "flat_strip", "weld_factor": 1.5}, iges, 16000.0)
    sheets = Sheets(((3600.0, 16000.0),), 10.0)
    with plate_evaluator(1) as evaluator:
        run = load_run(path, evaluator)
    assert len({p.hull.seam_names for p in run.parts}) == 2  # two strakes
    assert all(sheets.holding(development_need(p.hull.result, sheets, 1.0)) for p in run.parts)
    assert len(run.parts) >= 4 and run.plan_record.splits_taken >= 2
    assert butt_violations(run.parts, 300.0) == []
    butts = sorted(round(b.offset) for p in run.parts for b in p.hull.butts if b is not None)
    assert len(set(butts)) >= 2  # not one butt line across both strakes


def test_a_split_is_ranked_by_how_near_its_worse_half_comes_to_a_sheet():
    """The ranking of splits for the sheets: halves a sheet holds first, then the split whose
    worse half comes nearer one; a failed half (no development) ranks last: failing a plate
    is no remedy. Among held halves, the larger share fitting the hull, then less weld."""
    from types import SimpleNamespace

    from pipeline.hull.planner import _sheet_rank

    ctx = SimpleNamespace(sheets=Sheets(((3000.0, 12000.0),), 0.0), mm_per_unit=1.0)
    needs = {}

    def kid(width, length, fits=True):
        pattern = None if width is None else SimpleNamespace(
            outline=np.array([[0.0, 0.0], [length, 0.0], [length, width], [0.0, width]]))
        figures = {"region": {"area_m2": 1.0},
                   "plate_class": {"class": "flat" if fits else "formed"}}
        cell = SimpleNamespace(result=SimpleNamespace(pattern=pattern, figures=figures, ok=True, part=None), lost=False,
                               area_of=(None, 0.0))  # as a planner.Cell starts
        needs[id(cell)] = development_need(cell.result, ctx.sheets, 1.0)
        return cell

    def option(kind, weld, *kids):
        return SimpleNamespace(kind=kind, at=0.0, weld=weld), list(kids)

    def excess(cell):
        return ctx.sheets.excess(needs[id(cell)])

    assert excess(kid(3200.0, 5000.0)) == pytest.approx(200.0)
    assert excess(kid(2900.0, 13000.0)) == pytest.approx(1000.0)
    assert excess(kid(None, None)) == 0.0  # nothing to judge: left alone
    held = option("girth", 9000.0, kid(1500.0, 9000.0), kid(1500.0, 9000.0))
    nearer = option("length", 3000.0, kid(3100.0, 4500.0), kid(3050.0, 4500.0))
    failed = option("length", 2000.0, kid(2000.0, 4500.0), kid(None, None))
    formed = option("length", 3000.0, kid(2000.0, 4500.0), kid(2000.0, 4500.0, fits=False))
    ranked = sorted([failed, nearer, held, formed], key=lambda o: _sheet_rank(o, needs, ctx))
    assert ranked == [held, formed, nearer, failed]
