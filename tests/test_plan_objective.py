"""The plan a yard would build (``plan.objective``): the weld budget against the uniform layout,
stealers where the girth shrinks (no plate narrower than the stock), the butt stagger rule,
the plate cache (a plate evaluated once, whatever plan asks) and --jobs 2 writing the bytes
--jobs 1 writes."""

from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.hull.cost import plate_edges, weld_lengths
from pipeline.hull.yardrules import butt_violations, cross_joints, seam_end_violations
from tests.hull_shapes import cylinder_sphere_iges, write_iges_surface

SAME_BYTES = (".json", ".obj", ".csv")


def tapered_iges(path: Path, r_aft=8000.0, r_fore=1200.0, length=20000.0, angle_deg=90.0) -> Path:
    """A bilge whose radius shrinks linearly along x (a cone of axis x): the girth at x is
    r(x) * angle, 12.6 m aft and 1.9 m at the fore end; u along x, v around the arc."""
    h = np.radians(angle_deg) / 2

    def arc(r, x):
        return [[x, -r * np.sin(h), r * (1 - np.cos(h))], [x, 0.0, r - r / np.cos(h)],
                [x, r * np.sin(h), r * (1 - np.cos(h))]]

    w = np.array([1.0, np.cos(h), 1.0])
    poles = np.array([arc(r_aft, 0.0), arc(r_fore, length)])
    return write_iges_surface(path, 1, 2, poles, np.vstack([w, w]), [0, 0, 1, 1], [0, 0, 0, 1, 1, 1])


# sheets that hold every plate these plans make: the tests here are of the plan's own stock
# and objective (the plates' developments against the sheets: tests/test_plan_sheets.py)
ANY_SHEET = [[10000.0, 40000.0]]


def _config(tmp_path: Path, name: str, iges: Path, plan: dict, **strake) -> Path:
    data = {"name": name, "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
            "strake": {"surface": {"iges": str(iges)}, "margin": 0.2, "fit_tolerance": 5.0, "plan": plan, **strake},
            "shop": {"stock": ANY_SHEET}}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


TAPER_STOCK = {"max_length": 6000, "max_width": 3500, "min_length": 1000, "min_width": 1500}


def _grid_area(points: np.ndarray) -> float:
    """Area of a grid of points (R, C, 3) on the hull: each cell's half cross product of its diagonals."""
    d1 = points[1:, 1:] - points[:-1, :-1]
    d2 = points[1:, :-1] - points[:-1, 1:]
    return float(0.5 * np.linalg.norm(np.cross(d1, d2), axis=2).sum())


def _widest(part) -> float:
    """The plate's largest girth width on the hull (what stock width it needs), mm."""
    return float(plate_edges(part.name, part.hull).widths().max())


def test_stealers_keep_every_plate_at_least_the_stock_minimum_wide(tmp_path):
    """Four strakes of 3.1 m at the aft end narrow to 0.5 m at the fore end: the plain
    layout's fore plates are 1.1 m at their widest (below the 1.5 m minimum); with the yard's
    rules the fore end plates merge in pairs (two drop strakes) and every plate is at least
    1.5 m wide somewhere, none wider than the stock."""
    from pipeline.hull.plan import load_run

    iges = tapered_iges(tmp_path / "taper.igs")
    plain = load_run(_config(tmp_path, "plain", iges, {"method": "uniform", "stock": TAPER_STOCK})).parts
    yard = load_run(_config(tmp_path, "yard", iges, {"method": "uniform", "stock": TAPER_STOCK,
                                                    "butt_stagger": 300})).parts
    assert min(_widest(p) for p in plain) < 1500.0  # the control: the plain layout has slivers
    widths = {p.name: _widest(p) for p in yard}
    assert min(widths.values()) >= 1500.0, widths
    assert max(widths.values()) <= 3500.0 + 1.0
    merged = [p for p in yard if "-" in p.name.split("_")[1]]
    assert len(merged) == 2 and all(p.hull.butts[1] is None for p in merged)  # the fore end plates
    # a merged plate spans two strakes: its seams are two apart in the layout
    assert {p.hull.seam_names for p in merged} == {("SEAM 1", "SEAM 3"), ("SEAM 3", "SEAM 5")}



def test_drop_strakes_go_on_past_the_end_plates_while_the_girth_shrinks(tmp_path):
    """A bilge tapering from 8 m to 0.4 m radius over 20 m, in plates of at most 4 m: the
    plain layout's four strakes (3.1 m aft) are 0.75 m wide at the fore column's widest and
    1.35 m at the next column's, both below the 1.5 m minimum. The yard merges all four in
    the end plate (2.8 m), then two pairs in the next column (2.4 and 2.5 m): the seam
    between the pairs stops at the end plate's butt, the seams inside the pairs at the pairs'
    butts; every plate at least the minimum wide, none wider or longer than the stock, the
    butts still staggered. Merging only the end plates (before) left the next column's four
    plates 1.11 to 1.15 m wide at their widest."""
    from pipeline.hull.plan import load_run

    iges = tapered_iges(tmp_path / "taper.igs", r_fore=400.0)
    stock = dict(TAPER_STOCK, max_length=4000)
    plain = load_run(_config(tmp_path, "plain", iges, {"method": "uniform", "stock": stock})).parts
    yard = load_run(_config(tmp_path, "yard", iges, {"method": "uniform", "stock": stock, "butt_stagger": 300})).parts
    plain_widths = {p.name: _widest(p) for p in plain}
    # the control: the plain layout's two fore columns are narrower than the stock's minimum
    assert sorted(n for n, w in plain_widths.items() if w < 1500.0) == sorted(
        f"plain_S{i:02d}_B{j:02d}" for i in range(1, 5) for j in (4, 5))
    widths = {p.name: _widest(p) for p in yard}
    assert min(widths.values()) >= 1500.0, widths
    assert max(widths.values()) <= 3500.0 + 1.0
    fore = {p.hull.seam_names: p for p in yard if p.hull.butts[1] is None or p.hull.butts[1].offset > 12000.0}
    end = fore[("SEAM 1", "SEAM 5")]  # all four strakes in one end plate
    assert end.hull.butts[1] is None
    pairs = [fore[("SEAM 1", "SEAM 3")], fore[("SEAM 3", "SEAM 5")]]
    for pair in pairs:  # the next column: two pairs, each ending on the end plate's butt
        assert pair.hull.butts[1].offset == pytest.approx(end.hull.butts[0].offset)
    # the pairs' own butts are staggered from each other across SEAM 3 (which runs on aft of
    # them) and from the single strakes' butts aft of them
    assert abs(pairs[0].hull.butts[0].offset - pairs[1].hull.butts[0].offset) >= 300.0 - 1e-6
    assert butt_violations(yard, 300.0) == []
    for p in yard:
        assert plate_edges(p.name, p.hull).lengths().max() <= 4000.0 + 1.0, p.name
    # the same shell, in 4 x 6 plates less the 3 and 2 that the merges save
    area = sum(_grid_area(plate_edges(p.name, p.hull).points) for p in yard)
    assert area == pytest.approx(sum(_grid_area(plate_edges(p.name, p.hull).points) for p in plain), rel=1e-3)
    assert len(yard) == 4 * 6 - 3 - 2


def test_drop_strakes_without_a_stagger_merge_side_by_side_at_one_butt():
    """butt_stagger 0 (butts may align anywhere): six strakes whose fore end plates are 0.7 m
    wide merge in two threes (2.1 m), side by side, both ending on the strakes' last butt; with
    a 300 mm stagger the first three's butt lies one stagger aft of it and the second's two
    (one point of their common seam otherwise: a cross joint)."""
    from types import SimpleNamespace

    from pipeline.hull.yardrules import strake_butts, yard_layout

    stock = SimpleNamespace(max_length=4000.0, max_width=3500.0, min_width=1500.0)

    def width_of(lo, hi, a, b):
        return (hi - lo) * (700.0 if b is None else 2000.0)  # only the fore end plates are narrow

    for stagger in (0.0, 300.0):
        last = strake_butts(0.0, 20000.0, 4000.0, stagger, [], 0.0)[-1]  # 16000 (0), 16667 (300)
        plates = yard_layout(6, 0.0, 20000.0, (None, None), stock, stagger, [], width_of)
        merged = {(lo, hi): xs for lo, hi, xs, _ in plates if hi - lo > 1}
        assert merged == {(0, 3): [last - stagger, None], (3, 6): [last - 2 * stagger, None]}, merged


def _layout_faults(plates: list, n: int, x0: float, x1: float, stagger: float) -> list:
    """What is wrong with a yard layout's plates [(lo, hi, [x or None, x or None], B)]: a strake
    not covered once from x0 to x1, or two butts meeting a seam from either side less than the
    stagger apart off the seam's ends (a cross joint when they coincide)."""
    faults = []
    for i in range(n):
        spans = sorted(((x0 if a is None else a), (x1 if b is None else b)) for lo, hi, (a, b), _ in plates
                       if lo <= i < hi)
        if spans[0][0] != x0 or spans[-1][1] != x1 or any(s[1] != t[0] for s, t in pairwise(spans)):
            faults.append(f"strake {i} covered by {spans}")
    for seam in range(1, n):
        below = [p for p in plates if p[1] == seam]
        above = [p for p in plates if p[0] == seam]
        ends = (max(min(x0 if p[2][0] is None else p[2][0] for p in side) for side in (below, above)),
                min(max(x1 if p[2][1] is None else p[2][1] for p in side) for side in (below, above)))
        butts = [{x for p in side for x in p[2] if x is not None and ends[0] < x < ends[1]} for side in (below, above)]
        faults += [f"seam {seam}: butts {a} and {b}" for a in butts[0] for b in butts[1] if abs(a - b) < stagger]
    return faults


@pytest.mark.parametrize("narrow", ["middle", "crossed"])
def test_drop_strakes_from_both_ends_meet_at_the_middle_butt_once(narrow):
    """Four plates a strake (three butts), strakes narrow from both ends up to the middle butt:
    each end merges its columns, and the middle butt is the aft end's to move (when both
    moved it, each its own way, strake 3 was left uncovered from 8700 to 9600 mm, or two
    merged plates met seam 2 at one point: a cross joint)."""
    from types import SimpleNamespace

    from pipeline.hull.yardrules import yard_layout

    x0, x1 = 0.0, 18000.0
    stock = SimpleNamespace(max_length=6000.0, max_width=1300.0, min_width=1000.0)

    def strake_width(i, x):
        if narrow == "middle":  # strakes 1 and 2 narrow everywhere, 0 and 3 aft of x = 9300
            return 600.0 if i in (1, 2) or x <= 9300.0 else 1200.0
        # strakes 0 and 1 narrow aft of x = 9300, 2 and 3 fore of x = 8500
        return 600.0 if (i < 2 and x <= 9300.0) or (i >= 2 and x >= 8500.0) else 1200.0

    def width_of(lo, hi, a, b):
        xs = np.linspace(x0 if a is None else a, x1 if b is None else b, 201)
        return max(sum(strake_width(i, x) for i in range(lo, hi)) for x in xs)

    plates = yard_layout(4, x0, x1, (None, None), stock, 300.0, [], width_of)
    assert _layout_faults(plates, 4, x0, x1, 300.0) == []
    assert any(hi - lo > 1 for lo, hi, _, _ in plates)

def test_butts_of_neighbouring_strakes_are_staggered_or_on_a_block_joint(tmp_path):
    """The rule on a plan: butts meeting a seam from either side are 300 mm apart or more, or
    meet on a block joint. The plain layout breaks it (every strake butts at the same x: a
    cross joint at each); the yard layout keeps it, and a block joint at x = 10000 is a butt of
    every strake (aligned there, allowed)."""
    from pipeline.hull.plan import load_run

    iges = tapered_iges(tmp_path / "taper.igs")
    plain = load_run(_config(tmp_path, "plain", iges, {"method": "uniform", "stock": TAPER_STOCK})).parts
    assert butt_violations(plain, 300.0)  # the control: the check finds cross joints
    yard = load_run(_config(tmp_path, "yard", iges, {"method": "uniform", "stock": TAPER_STOCK,
                                                    "block_joints": [10000.0], "butt_stagger": 300})).parts
    assert butt_violations(yard, 300.0, [10000.0]) == []
    assert butt_violations(yard, 300.0) != []  # the block joint is where they align
    strakes = {(f"SEAM {i}", f"SEAM {i + 1}") for i in range(1, 5)}  # the merged end plates lie fore of it
    at_joint = {p.hull.seam_names for p in yard if any(b is not None and abs(b.offset - 10000.0) < 1e-6
                                                      for b in p.hull.butts)}
    assert at_joint == strakes
    # every plate within the stock length: the stagger and the stealers lengthen none beyond it
    for p in yard:
        lengths = plate_edges(p.name, p.hull).lengths()
        assert lengths.max() <= 6000.0 + 1.0, (p.name, lengths.max())


def test_an_adaptive_plan_without_an_objective_keeps_the_butt_stagger(tmp_path, monkeypatch):
    """``butt_stagger`` without an objective: the plan splits every plate that does not fit,
    a depth at a time. The control is the plan as it was, without the yard's rules on its
    splits: both strakes of the cylinder-sphere split their end plates along the length at
    the same depth, each without the other's butt, and the two meet the seam between them
    3 mm apart (3411 and 3408 mm); and plates on either side of a butt split along the girth
    at one girth, so that their new seams join across the butt with the butts in line on
    both sides (seven cross joints: four plates at a point). Now a butt split keeps the
    stagger from the butts across its seams and a girth split's seam ends keep it from the
    seam ends across its butts, those taken at the same depth too; the shell is still
    covered once."""
    from pipeline.hull import planner
    from pipeline.hull.plan import load_run
    from pipeline.runner import plate_evaluator

    iges = tmp_path / "cs.igs"
    cylinder_sphere_iges(iges, 10000.0, 60.0, 1500.0, 3000.0, 0.3)
    plan = {"method": "adaptive", "max_splits": 2, "butt_stagger": 300,
            "stock": {"max_length": 4000, "max_width": 2500, "min_length": 1000, "min_width": 1000}}
    with plate_evaluator(1) as evaluator:
        yard = load_run(_config(tmp_path, "yard", iges, plan), evaluator).parts
    with monkeypatch.context() as off, plate_evaluator(1) as evaluator:
        off.setattr(planner, "_yard_rules", lambda cells, *args: [None] * len(cells))  # as before
        control = load_run(_config(tmp_path, "control", iges, plan), evaluator).parts
    crossing = butt_violations(control, 300.0)
    assert crossing and all(min(abs(xa), abs(xb)) > 3000.0 for *_, xa, xb in crossing)  # the end plates' splits
    assert butt_violations(yard, 300.0) == []
    # girth splits of two plates across a butt at one girth: their seams join there, a cross joint
    assert cross_joints(control)
    assert cross_joints(yard) == []
    assert seam_end_violations(yard, 300.0) == []  # no seam end within the stagger of another across a butt
    uniform = {-1666.667, 1666.667, -1366.667, 1966.667}  # the two strakes' staggered butts, rounded
    splits = {round(b.offset, 3) for p in yard for b in p.hull.butts if b is not None} - uniform
    assert len(splits) >= 4  # the plan still splits along the length, staggered
    area = sum(_grid_area(plate_edges(p.name, p.hull).points) for p in yard)
    assert area == pytest.approx(sum(_grid_area(plate_edges(p.name, p.hull).points) for p in control), rel=1e-3)


def _cs_plan(tmp_path: Path, name: str, plan: dict, monkeypatch=None, **patches) -> list:
    """The cylinder-sphere planned with ``plan`` on one worker, with planner functions replaced
    by ``patches`` for the plan (a control)."""
    from pipeline.hull import planner
    from pipeline.hull.plan import load_run
    from pipeline.runner import plate_evaluator

    iges = tmp_path / "cs.igs"
    if not iges.exists():
        cylinder_sphere_iges(iges, 10000.0, 60.0, 1500.0, 3000.0, 0.3)
    with monkeypatch.context() as patched, plate_evaluator(1) as evaluator:
        for name_, value in patches.items():
            patched.setattr(planner, name_, value)
        return load_run(_config(tmp_path, name, iges, plan), evaluator).parts


def test_a_butt_split_waits_for_a_butt_taken_across_its_seam_at_the_same_depth(tmp_path, monkeypatch):
    """Strakes too narrow to split along the girth (1.2 m minimum): both strakes' end plates
    split along the length at one depth, each under its rule from the plan before that depth.
    Without the same-depth check (the control) the two new butts meet the seam between them
    191 mm and 101 mm apart; with it the second waits a depth and is chosen against the
    first: none within 300 mm."""
    plan = {"method": "adaptive", "max_splits": 2, "butt_stagger": 300,
            "stock": {"max_length": 4000, "max_width": 2500, "min_length": 1000, "min_width": 1200}}
    control = _cs_plan(tmp_path, "control", plan, monkeypatch, _clash=lambda *args: False)
    assert {round(abs(xa - xb)) for *_, xa, xb in butt_violations(control, 300.0)} == {101, 191}
    yard = _cs_plan(tmp_path, "yard", plan, monkeypatch)
    assert butt_violations(yard, 300.0) == [] and cross_joints(yard) == []
    assert len(yard) > 6  # it still splits


def test_an_objective_plan_takes_no_two_seams_that_would_meet_across_a_butt_in_one_round(tmp_path, monkeypatch):
    """{maximise: flat_strip, weld_factor: 3}: a round takes several girth splits at once, each
    chosen under its rule from the plan before the round. The control lets two of them end
    on one butt together (cross joints); the plan takes the second only in a later round,
    against the first."""
    plan = {"method": "adaptive", "max_splits": 3, "objective": {"maximise": "flat_strip", "weld_factor": 3.0},
            "stock": {"max_length": 4000, "max_width": 2500, "min_length": 1000, "min_width": 1000}}
    control = _cs_plan(tmp_path, "control", plan, monkeypatch, SeamRule=lambda ends, stagger: (lambda points: True))
    assert cross_joints(control)
    yard = _cs_plan(tmp_path, "yard", plan, monkeypatch)
    assert cross_joints(yard) == [] and seam_end_violations(yard, 300.0) == []
    assert butt_violations(yard, 300.0) == []


def test_plates_larger_than_the_stock_are_split_before_they_are_evaluated_into_the_same_plan(tmp_path, monkeypatch):
    """The cylinder-sphere (x over 10 m) in three butts of 3.33 m under a 3.4 m stock: the end
    plates run 3.56 m along the hull (an arc of 20.4 deg at 10 m radius), longer than any
    sheet, one strake on the cylinder and the sphere, the other on the sphere alone. Split as
    soon as they are laid (across their excess where the estimate expects a fit, else where
    the misfit is), the plan is the one the control makes by evaluating them first, with
    fewer evaluations, and no plate is longer than the stock."""
    from pipeline.hull import planner
    from pipeline.hull.plan import load_run
    from pipeline.runner import plate_evaluator

    iges = tmp_path / "cs.igs"
    cylinder_sphere_iges(iges, 10000.0, 60.0, 1500.0, 3000.0, 0.3)
    plan = {"method": "adaptive", "max_splits": 2,
            "stock": {"max_length": 3400, "max_width": 2500, "min_length": 1000, "min_width": 1000}}

    def planned(name, **patches):
        with monkeypatch.context() as patched, plate_evaluator(1) as evaluator:
            for key, value in patches.items():
                patched.setattr(planner, key, value)
            run = load_run(_config(tmp_path, name, iges, plan), evaluator)
        plates = {p.name.split("_", 1)[1]: (tuple(float(g(0.5)) for g in p.hull.girths),
                                            tuple(None if b is None else round(b.offset, 6) for b in p.hull.butts))
                  for p in run.parts}
        longest = max(p.hull.result.figures["region"]["length"] for p in run.parts)
        return plates, run.plan_record.evaluations, longest

    early, early_evaluations, early_longest = planned("early")
    late, late_evaluations, late_longest = planned("late", _coarse_oversize=lambda cell, stock: ())
    assert early == late
    assert early_evaluations < late_evaluations
    assert max(early_longest, late_longest) <= 3400.0


def _cs(tmp_path: Path, name: str, method: str, objective=None, max_splits: int = 1) -> Path:
    iges = tmp_path / "cs.igs"
    if not iges.exists():
        cylinder_sphere_iges(iges, 10000.0, 60.0, 1500.0, 3000.0, 0.3)
    plan = {"method": method, "max_splits": max_splits,
            "stock": {"max_length": 4000, "max_width": 5000, "min_length": 1000, "min_width": 1000}}
    if objective is not None:
        plan["objective"] = objective
    return _config(tmp_path, name, iges, plan)


def _weld_m(parts) -> float:
    w = weld_lengths([e for e in (plate_edges(p.name, p.hull) for p in parts) if e is not None])
    return (w.seams + w.butts) / 1000.0


@pytest.fixture(scope="module")
def counted(tmp_path_factory):
    """One evaluator for every plan of the cylinder-sphere strake, counting the plate runs."""
    from pipeline.hull.plates import evaluate_plate
    from pipeline.runner import PlateEvaluator

    calls = []

    def evaluate(part, config):
        calls.append(part.name)
        return evaluate_plate(part, config)

    return tmp_path_factory.mktemp("cs"), PlateEvaluator(evaluate, 1), calls


def test_the_weld_budget_holds_and_each_plate_is_evaluated_once(counted):
    """Uniform: three plates, two butts of 4.5 m (9 m of weld). The adaptive plan without an
    objective splits all three (about 19 m); with {maximise: flat_strip, weld_factor: 1.5} it
    takes the one split that pays best within 13.5 m (the seam at the cylinder-sphere
    junction, which delivers the cylinder part as a strip) and stays within 1.5 x the uniform
    weld, measured on the hull. The second plan asks for plates the first evaluated: the cache
    answers, and a third identical plan computes nothing."""
    from pipeline.hull.planner import honest_class
    from pipeline.hull.plan import load_run

    tmp, evaluator, calls = counted
    uniform = load_run(_cs(tmp, "u", "uniform")).parts
    free = load_run(_cs(tmp, "free", "adaptive"), evaluator)
    n_free = len(calls)
    assert n_free == len(set(calls)) == 9  # three plates, then their six halves
    budget = load_run(_cs(tmp, "b", "adaptive", {"maximise": "flat_strip", "weld_factor": 1.5}), evaluator)
    w_uniform, w_free, w_budget = _weld_m(uniform), _weld_m(free.parts), _weld_m(budget.parts)
    assert w_uniform == pytest.approx(9.0, rel=0.01)
    assert w_free > 1.5 * w_uniform  # the control: splitting everything breaks the budget
    assert w_budget <= 1.5 * w_uniform
    assert budget.plan_record.weld_budget_m == pytest.approx(1.5 * budget.plan_record.uniform_weld_m)
    fits = [p for p in budget.parts if honest_class(p.hull.result) in ("flat", "developable")]
    assert len(budget.parts) == 4 and len(fits) == 1
    assert len(calls) == n_free  # every plate the budget plan asked for was evaluated already
    assert evaluator.requested > evaluator.computed == len(set(calls))
    again = load_run(_cs(tmp, "b2", "adaptive", {"maximise": "flat_strip", "weld_factor": 1.5}), evaluator)
    assert len(calls) == n_free and [p.name for p in again.parts] == [p.name.replace("b_", "b2_", 1)
                                                                        for p in budget.parts]
    # the Pareto front of what the plan tried: more share costs more weld
    front = budget.plan_record.pareto()
    assert [p.weld_m for p in front] == sorted(p.weld_m for p in front)
    assert [p.flat_strip for p in front] == sorted(p.flat_strip for p in front)


def test_a_weighted_cost_splits_only_where_the_area_pays_for_the_weld(counted):
    """{weights}: a split costs weld_m per metre and plate per plate, and earns formed_m2 per
    m^2 it delivers flat or strip. The junction split adds a seam of about 3.5 m and one plate
    and delivers a few m^2 as a strip: at formed_m2 = 1 the plate's 10 alone outweighs that
    area, at formed_m2 = 100 it pays."""
    from pipeline.hull.plan import load_run

    tmp, evaluator, calls = counted
    cheap = load_run(_cs(tmp, "w1", "adaptive", {"weights": {"weld_m": 1.0, "plate": 10.0, "formed_m2": 1.0}}),
                     evaluator)
    dear = load_run(_cs(tmp, "w2", "adaptive", {"weights": {"weld_m": 1.0, "plate": 10.0, "formed_m2": 100.0}}),
                    evaluator)
    assert len(cheap.parts) == 3 and cheap.plan_record.splits_taken == 0
    assert len(dear.parts) > 3 and dear.plan_record.splits_taken >= 1


def test_a_split_the_estimate_says_gains_nothing_is_tried_with_the_budget_left(tmp_path, monkeypatch):
    """The split estimate is coarse (a strip's verdict is the solve's): with every split's
    expected gain forced to nothing, {maximise: flat_strip} still spends the weld budget left
    on them, one at a time within it, and keeps the one whose halves pay (the seam at the
    cylinder-sphere junction: the cylinder part as a strip), the others rejected and their weld
    refunded: a plan as good as the one it reaches with the estimate intact. The weighted cost does not
    explore (a split that earns nothing costs its weld and its plate)."""
    from dataclasses import replace

    from pipeline.hull import planner
    from pipeline.hull.plan import load_run

    objective = {"maximise": "flat_strip", "weld_factor": 1.5}
    estimated = load_run(_cs(tmp_path, "est", "adaptive", objective), _plain_evaluator())
    real = planner.choose_split

    def blind(*args, **kwargs):
        split = real(*args, **kwargs)
        return None if split is None else replace(split, estimates=(np.inf, np.inf), fitting_share=0.0)

    monkeypatch.setattr(planner, "choose_split", blind)
    blinded = load_run(_cs(tmp_path, "blind", "adaptive", objective), _plain_evaluator())
    fits = [p for p in blinded.parts if planner.honest_class(p.hull.result) in ("flat", "developable")]
    assert len(blinded.parts) == 4 and len(fits) == 1
    # the strake is symmetric end to end: the plan order meets the other end's junction first
    assert np.allclose(sorted(_class_areas(blinded.parts)), sorted(_class_areas(estimated.parts)), rtol=1e-6)
    assert blinded.plan_record.splits_taken == estimated.plan_record.splits_taken == 1
    assert _weld_m(blinded.parts) <= 1.5 * blinded.plan_record.uniform_weld_m
    weighted = load_run(_cs(tmp_path, "wblind", "adaptive", {"weights": {"weld_m": 1.0, "plate": 1.0,
                                                                          "formed_m2": 100.0}}), _plain_evaluator())
    assert weighted.plan_record.splits_taken == 0 and len(weighted.parts) == 3


def test_a_plate_whose_split_did_not_pay_is_offered_the_other_kind(tmp_path, monkeypatch):
    """With the estimate steered to butt splits first, the cylinder-sphere strake's plates are
    cut across at mid length, and no half fits (each keeps part of the cap's double curvature).
    {maximise: flat_strip} gives the weld back and offers each plate a new seam instead: the
    seam at the junction delivers the cylinder part as a strip, the plan the estimate reaches
    unsteered. A plan that gives up after the first kind (the control) delivers nothing flat
    or strip."""
    from pipeline.hull import planner
    from pipeline.hull.plan import load_run

    objective = {"maximise": "flat_strip", "weld_factor": 1.5}
    estimated = load_run(_cs(tmp_path, "est", "adaptive", objective), _plain_evaluator())
    real = planner.choose_split

    def butts_first(sample, tol, min_length, min_width, allow=None, strict_width=False, kinds=planner.SPLIT_KINDS,
                    allow_seam=None, tapering=False):
        kinds = ("length",) if "length" in kinds else kinds
        return real(sample, tol, min_length, min_width, allow, strict_width, kinds, allow_seam, tapering=tapering)

    monkeypatch.setattr(planner, "choose_split", butts_first)
    steered = load_run(_cs(tmp_path, "steer", "adaptive", objective), _plain_evaluator())
    fits = [p for p in steered.parts if planner.honest_class(p.hull.result) in ("flat", "developable")]
    assert len(fits) == 1 and "+" in fits[0].hull.seam_names[1]  # the fitting half is below a new seam
    assert np.allclose(sorted(_class_areas(steered.parts)), sorted(_class_areas(estimated.parts)), rtol=1e-6)
    assert steered.plan_record.splits_rejected >= 1
    monkeypatch.setattr(planner, "_retry", lambda cell, kind, objective: False)
    once = load_run(_cs(tmp_path, "once", "adaptive", objective), _plain_evaluator())
    assert not [p for p in once.parts if planner.honest_class(p.hull.result) in ("flat", "developable")]


def _class_areas(parts) -> list:
    """(1 for flat or strip else 0, shell area m^2) per plate."""
    from pipeline.hull.hullplots import shell_area
    from pipeline.hull.planner import honest_class

    return [(float(honest_class(p.hull.result) in ("flat", "developable")), shell_area(p.hull.result)) for p in parts]


def _plain_evaluator():
    from pipeline.hull.plates import evaluate_plate
    from pipeline.runner import PlateEvaluator

    return PlateEvaluator(evaluate_plate, 1)


def test_a_bad_objective_is_named(tmp_path):
    from pipeline.config import ConfigError, load_config

    path = _cs(tmp_path, "bad", "adaptive", {"maximise": "flat_strip"})
    with pytest.raises(ConfigError, match="weld_factor"):
        load_config(path)


@pytest.mark.parametrize("objective", [{"maximise": "flat_strip", "weld_factor": 3.0}, None])
def test_jobs_2_writes_the_bytes_jobs_1_writes_for_an_adaptive_plan(tmp_path, objective):
    """The candidates evaluated in two worker processes (and, without an objective, the
    splits chosen there too): the same plan and the same files."""
    from pipeline.cli import main

    config = _cs(tmp_path, "cs", "adaptive", objective, max_splits=2)
    for jobs in (1, 2):
        assert main(["run", str(config), "--out", str(tmp_path / f"j{jobs}"), "--jobs", str(jobs), "--quiet"]) == 0
    one = {p.relative_to(tmp_path / "j1"): p for p in sorted((tmp_path / "j1").rglob("*")) if p.is_file()}
    two = {p.relative_to(tmp_path / "j2"): p for p in sorted((tmp_path / "j2").rglob("*")) if p.is_file()}
    assert sorted(one) == sorted(two)
    compared = [name for name in one if name.suffix in SAME_BYTES]
    assert {n.suffix for n in compared} == set(SAME_BYTES) and len(compared) > 10
    for name in compared:
        assert one[name].read_bytes() == two[name].read_bytes(), name


@pytest.mark.parametrize("objective", [None, {"maximise": "flat_strip", "weld_factor": 3.0}])
def test_an_adaptive_plan_chooses_its_splits_on_the_evaluators_workers(tmp_path, objective):
    """The splits of a batch's plates that do not fit are chosen by the evaluator's worker
    processes (idle while the plan chooses), with an objective too (under each plate's butt
    rule): their CPU is counted, and the plan is the one a single process makes."""
    from pipeline.runner import plate_evaluator
    from pipeline.validate import validate

    config = _cs(tmp_path, "cs", "adaptive", objective, max_splits=2)
    with plate_evaluator(2) as two:
        spread = validate(config, two)
    with plate_evaluator(1) as one:
        alone = validate(config, one)
    assert two.mapped_cpu_seconds > 0.0 and one.mapped_cpu_seconds == 0.0
    # each batch is a wave: its plates' (or tasks') CPU in the order handed out
    for evaluator in (one, two):
        plates = [w for w in evaluator.waves if w.kind == "plates"]
        assert len(plates) >= 2 and sum(len(w.cpu) for w in plates) == evaluator.computed
        assert all(c > 0.0 for w in plates for c in w.cpu) and all(w.wall > 0.0 for w in plates)
        assert sum(c for w in plates for c in w.cpu) == pytest.approx(evaluator.cpu_seconds)
    tasks = [w for w in two.waves if w.kind == "tasks"]
    assert tasks and sum(c for w in tasks for c in w.cpu) == pytest.approx(two.mapped_cpu_seconds)
    assert not [w for w in one.waves if w.kind == "tasks"]  # no workers: the splits were chosen here
    assert [p.name for p in spread.parts] == [p.name for p in alone.parts]
    assert len(spread.parts) > 4  # split twice somewhere
    for a, b in zip(spread.parts, alone.parts):
        assert [None if x is None else (tuple(x.normal), x.offset) for x in a.hull.butts] == \
               [None if x is None else (tuple(x.normal), x.offset) for x in b.hull.butts]
        assert [g.g for g in a.hull.girths] == [g.g for g in b.hull.girths]


def test_a_batch_of_one_hulls_plans_evaluates_their_common_plates_once(tmp_path, monkeypatch):
    """``devflat run A.yaml B.yaml --jobs 2``: two plans of the cylinder-sphere strake under
    other names (no objective; flat + strip with 3 x the weld) are planned with one
    evaluator on two workers. B's plan asks for plates A's evaluated (the uniform ones at
    least): they are not run again, and each configuration's files are the bytes its run
    alone writes, its own plate names throughout."""
    from pipeline import runner
    from pipeline.cli import main
    from pipeline.validate import validate

    one = _cs(tmp_path, "csa", "adaptive", None, max_splits=2)
    two = _cs(tmp_path, "csb", "adaptive", {"maximise": "flat_strip", "weld_factor": 3.0}, max_splits=2)
    alone = {}
    for config in (one, two):
        with runner.plate_evaluator(1) as evaluator:
            validate(config, evaluator)
        alone[config.stem] = evaluator.computed
        assert main(["run", str(config), "--out", str(tmp_path / config.stem), "--quiet"]) == 0
    used = []
    make = runner.plate_evaluator
    monkeypatch.setattr(runner, "plate_evaluator", lambda jobs=1: used.append(make(jobs)) or used[-1])
    batch = tmp_path / "batch"
    assert main(["run", str(one), str(two), "--out", str(batch), "--jobs", "2", "--quiet"]) == 0
    (shared,) = used
    assert shared.jobs == 2 and shared.mapped_cpu_seconds > 0.0  # the splits chosen on the workers
    assert shared.requested > shared.computed
    assert max(alone.values()) <= shared.computed < sum(alone.values())
    for config in (one, two):
        files = {p.relative_to(batch / config.stem): p for p in sorted((batch / config.stem).rglob("*")) if p.is_file()}
        single = {p.relative_to(tmp_path / config.stem): p
                  for p in sorted((tmp_path / config.stem).rglob("*")) if p.is_file()}
        assert sorted(files) == sorted(single)
        compared = [name for name in files if name.suffix in SAME_BYTES]
        assert len(compared) > 10 and all(config.stem in name.name for name in compared)
        for name in compared:
            assert files[name].read_bytes() == single[name].read_bytes(), name


def test_a_splits_halves_are_built_while_the_workers_choose_the_next_splits(tmp_path, monkeypatch):
    """Without an objective a depth's split jobs are all handed to the workers at once and
    each split's halves are built as soon as it comes back, before the depth's last split
    is read (the workers no longer wait for the whole depth to be built here); the plan is
    the one a single process makes."""
    from concurrent.futures import ProcessPoolExecutor

    from pipeline.hull import planner
    from pipeline.runner import PlateEvaluator, plate_evaluator
    from pipeline.validate import validate

    events, submitted = [], []
    map_each, children, submit = PlateEvaluator.map_each, planner._children, ProcessPoolExecutor.submit

    def counted_submit(self, *args, **kwargs):
        submitted.append(1)
        return submit(self, *args, **kwargs)

    def counted_map_each(self, func, items):
        before = len(submitted)
        answers = map_each(self, func, items)
        if func is not planner._region_split or self._pool is None or len(items) < 2:
            return answers
        assert len(submitted) - before == len(items)  # every job handed out before any answer is read
        events.append(("handed out", len(items)))

        def read():
            for answer in answers:
                events.append(("answer", None))
                yield answer

        return read()

    def counted_children(cell, split):
        events.append(("halves", None))
        return children(cell, split)

    monkeypatch.setattr(ProcessPoolExecutor, "submit", counted_submit)
    monkeypatch.setattr(PlateEvaluator, "map_each", counted_map_each)
    monkeypatch.setattr(planner, "_children", counted_children)
    config = _cs(tmp_path, "cs", "adaptive", None, max_splits=2)
    with plate_evaluator(2) as two:
        spread = validate(config, two)
    rounds = [k for k, (what, _) in enumerate(events) if what == "handed out"]
    assert len(rounds) >= 2  # two depths of splits on the workers
    for start, end in zip(rounds, rounds[1:] + [len(events)]):
        kinds = [what for what, _ in events[start + 1:end]]
        assert kinds.count("answer") == events[start][1]
        last_answer = len(kinds) - 1 - kinds[::-1].index("answer")
        assert "halves" in kinds[:last_answer]  # halves built before the depth's last split came in
    events.clear()
    with plate_evaluator(1) as one:
        alone = validate(config, one)
    assert not any(what == "handed out" for what, _ in events)
    assert [p.name for p in spread.parts] == [p.name for p in alone.parts]
    assert [[g.g for g in p.hull.girths] for p in spread.parts] == [[g.g for g in p.hull.girths] for p in alone.parts]


def test_the_butt_rule_is_the_stagger_from_the_butts_across_the_seams_or_a_block_joint():
    from pipeline.hull.yardrules import ButtRule

    rule = ButtRule((1000.0, 5000.0), 300.0, (5000.0,))
    assert not rule(1200.0) and not rule(800.0) and not rule(1000.0)  # a cross joint off the block joints
    assert rule(1300.0) and rule(700.0) and rule(3000.0)
    assert rule(5000.0)  # aligned on the block joint
    assert not rule(5100.0) and rule(5300.0)
    assert ButtRule((), 300.0, ())(1000.0)  # no plate across the seams: anything goes


def test_an_objective_plan_chooses_each_plates_split_once_per_butt_rule(tmp_path, monkeypatch):
    """A plate the objective does not split this round (the weld budget) asks for its split
    again the next: it is chosen again only when the plates across its seams moved a butt
    (its rule changed). The control forgets every split between rounds (and the run's
    memory of the jobs answered, kept for plans made again): it computes the same jobs
    again, and plans the same plates."""
    from dataclasses import replace

    from pipeline.hull import planner
    from pipeline.hull.plan import load_run
    from pipeline.runner import plate_evaluator

    jobs = []
    choose, under_rules = planner._region_split, planner._splits_under_rules

    def counted(job):
        surface, axis, girths, pair, *_, allow, strict, kinds = job
        jobs.append((tuple(g.g for g in girths), tuple(None if p is None else p.offset for p in pair), allow, kinds))
        return choose(job)

    def plan(name):
        jobs.clear()
        with plate_evaluator(1) as evaluator:
            parts = load_run(_cs(tmp_path, name, "adaptive", {"maximise": "flat_strip", "weld_factor": 1.5},
                                 max_splits=2), evaluator).parts
        return list(jobs), [(p.name.split("_", 1)[1], [None if b is None else b.offset for b in p.hull.butts],
                             [g.g for g in p.hull.girths]) for p in parts]

    monkeypatch.setattr(planner, "_region_split", counted)
    kept, plates = plan("kept")
    monkeypatch.setattr(planner, "_splits_under_rules", lambda cells, sides, chosen, ctx, *rest: under_rules(
        cells, sides, {}, replace(ctx, remembered=None), *rest))
    forgotten, control = plan("forgot")
    assert len(set(kept)) == len(kept) == len(set(forgotten)) < len(forgotten)
    assert plates == control and len(plates) > 3


def test_the_plans_cost_names_the_plates_narrower_than_the_stock(tmp_path, capsys):
    """The plain layout of the tapering bilge leaves fore plates narrower than the 1.5 m stock
    minimum: the summary's plan cost names exactly those (their largest girth width, m), and
    the console's plan line counts them; the yard's layout merges them (stealers) and names
    none."""
    import json

    from pipeline.cli import main
    from pipeline.hull.plan import load_run

    iges = tapered_iges(tmp_path / "taper.igs")
    for name, extra in (("plain", {}), ("yard", {"butt_stagger": 300})):
        config = _config(tmp_path, name, iges, {"method": "uniform", "stock": TAPER_STOCK, **extra})
        assert main(["run", str(config), "--out", str(tmp_path / name)]) == 0
        line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("plan:"))
        listed = json.loads((tmp_path / name / f"{name}_summary.json").read_text())["plan_cost"]["narrower_than_stock"]
        assert f", {len(listed) or 'none'} narrower than the stock's 1.5 m, " in line
        widths = {p.name: _widest(p) for p in load_run(config).parts}
        assert {p["plate"] for p in listed} == {n for n, w in widths.items() if w < TAPER_STOCK["min_width"]}
        for p in listed:
            assert p["width_m"] == pytest.approx(widths[p["plate"]] / 1000.0, rel=1e-9)
        assert [p["width_m"] for p in listed] == sorted(p["width_m"] for p in listed)
        assert (len(listed) > 0) == (name == "plain")


def test_the_seam_rule_keeps_a_new_seams_ends_the_stagger_from_the_seams_across_its_butts():
    """Three plates in a row along one strake (x 0-4000, 4000-8000, 8000-12000; girth y from
    0 to 2000 at z = 0); the one aft of x = 4000 is split along its girth at y = 1000. The
    middle plate's new seam may not end on its butts within 300 mm of that seam's end at
    (4000, 1000, 0), and no other corner on its butts counts: its own corners (where the
    strake's seams run on), the fore plate's, which are its own too, and those of another
    strake's plates aft of x = 4000 (y 5000-7000), out of reach of its butt edge (2 m wide).
    A block joint at x = 4000 lifts the rule there."""
    from types import SimpleNamespace

    from flatten.plane import Plane
    from pipeline.hull.yardrules import plate_corners, seam_rule

    def plate(name, x0, x1, rows):
        corners = [[x, y, 0.0] for x in (x0, x1) for y in rows]
        region = {"corners": corners, "width": rows[-1] - rows[0]}
        hull = SimpleNamespace(butts=(None if x0 == 0 else Plane((1.0, 0.0, 0.0), x0),
                                      None if x1 == 12000 else Plane((1.0, 0.0, 0.0), x1)),
                               result=SimpleNamespace(figures={"region": region}))
        return SimpleNamespace(name=name, hull=hull)

    parts = [plate("aft_low", 0, 4000, (0.0, 1000.0)), plate("aft_high", 0, 4000, (1000.0, 2000.0)),
             plate("mid", 4000, 8000, (0.0, 2000.0)), plate("fore", 8000, 12000, (0.0, 2000.0)),
             plate("far_low", 0, 4000, (5000.0, 6000.0)), plate("far_high", 0, 4000, (6000.0, 7000.0))]
    rule = seam_rule(2, parts, plate_corners(parts), 300.0, ())
    assert rule.ends == ((4000.0, 1000.0, 0.0),)
    assert not rule([[4000.0, 1000.0, 0.0], [8000.0, 1000.0, 0.0]])  # joined across the butt: a cross joint
    assert not rule([[4000.0, 1250.0, 0.0], [8000.0, 1250.0, 0.0]])
    assert rule([[4000.0, 1300.0, 0.0], [8000.0, 1300.0, 0.0]]) and rule([[4000.0, 650.0, 0.0], [8000.0, 650.0, 0.0]])
    assert seam_rule(2, parts, plate_corners(parts), 300.0, (4000.0,)).ends == ()  # a block joint
    assert seam_rule(3, parts, plate_corners(parts), 300.0, ()).ends == ()  # the fore plate: nothing across its butt
    del parts[2].hull.result.figures["region"]["width"]  # the control: without its width every corner there counts
    assert len(seam_rule(2, parts, plate_corners(parts), 300.0, ()).ends) == 4


def _skewed_plane(path: Path, x_end: float = 6000.0) -> Path:
    """A plane z = 0, x in [0, x_end]: its sections x = const run in y from 0 to 6 m at x = 0
    (evenly in v) and to 5 m at x_end, where v crowds towards y = 0 (quadratic in v, control
    points y = 0, 0.2, 5 m): the seam at mid-girth of the widest section (y = 3 m at x = 0)
    runs to y = 0.25 * 0 + 0.5 * 0.2 + 0.25 * 5 = 1.35 m at x_end, and the strake above it
    widens to 5 - 1.35 = 3.65 m there."""
    poles = [[[0.0, 0.0, 0.0], [0.0, 3000.0, 0.0], [0.0, 6000.0, 0.0]],
             [[x_end, 0.0, 0.0], [x_end, 200.0, 0.0], [x_end, 5000.0, 0.0]]]
    return write_iges_surface(path, 1, 2, poles, np.ones((2, 3)), [0, 0, 1, 1], [0, 0, 0, 1, 1, 1])


def test_a_plate_that_fits_but_is_wider_than_the_stock_is_split_across_its_girth(tmp_path, monkeypatch):
    """A flat plane of two strakes laid at its widest section (6 m: 3 m each), the upper
    strake 3.65 m wide at the other end (closed form above) against a 3.5 m stock: no sheet
    holds it. The plan splits it along its girth into plates within the stock, however flat
    it is; switched off, the flat plate is kept 3.65 m wide."""
    from pipeline.hull import planner
    from pipeline.hull.plan import load_run

    iges = _skewed_plane(tmp_path / "skewed.igs")
    stock = {"max_length": 14000, "max_width": 3500, "min_length": 1000, "min_width": 1000}
    config = _config(tmp_path, "sk", iges, {"method": "adaptive", "stock": stock, "max_splits": 2})

    evaluated = []

    def plates():
        from pipeline.hull.plates import evaluate_plate

        def counted(part, config):
            evaluated.append(part.name)
            return evaluate_plate(part, config)

        evaluated.clear()
        run = load_run(config, counted)
        return {p.name: dict(p.hull.result.figures["region"], klass=p.hull.result.figures["plate_class"]["class"])
                for p in run.parts}

    split = plates()
    assert max(r["width"] for r in split.values()) <= 3500.0
    assert sorted(split) == ["sk_S01_B01", "sk_S02_B01-1", "sk_S02_B01-2"]
    # the plate too wide for any sheet is split before it is evaluated (found on its coarse grid)
    assert sorted(evaluated) == sorted(split)
    monkeypatch.setattr(planner, "_coarse_oversize", lambda cell, stock: ())
    assert sorted(plates()) == sorted(split) and "sk_S02_B01" in evaluated  # found once evaluated, as before
    monkeypatch.setattr(planner, "_oversize", lambda cell, stock: ())
    kept = plates()
    assert sorted(kept) == ["sk_S01_B01", "sk_S02_B01"]
    assert kept["sk_S02_B01"]["width"] == pytest.approx(3650.0, rel=1e-3) and kept["sk_S02_B01"]["klass"] == "flat"
    assert {r["klass"] for r in split.values()} == {"flat"}
