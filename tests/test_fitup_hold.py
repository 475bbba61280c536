"""strake.hold_steps with fit_up: follow (pipeline/hull/follow.py): the pairs of flat or strip
plates that still step over the limit after the joint programme have a plate held on the
hull, the fewest square metres that cover them, and the forming shapes it to meet its
neighbours.

Real data: the 160 m hull's bow shoulder (see test_fitup_repair), four flat plates twisted
against each other. Under follow two become strips along the least curvature and three
pairs still step over the 2.1 mm limit (2.9, 7.4 and 3.7 mm): no plane or strip within the
tolerance meets them. Held, the two plates that cover those pairs are developed on the hull
and formed to meet their strip neighbours; their steps fall under the limit, and what is
left is the formed plates' own shared seam, which takes the strips' step at its corner."""

from types import SimpleNamespace

import pytest

from pipeline.hull import follow
from tests.test_fitup_joint import run
from tests.test_fitup_repair import shoulder


@pytest.fixture(scope="module")
def shoulders(tmp_path_factory):
    out = []
    for hold in (False, True):
        tmp = tmp_path_factory.mktemp("hold" if hold else "follow")
        out.append(run(shoulder(tmp, fit_up="follow", hold_steps=hold)))
    return out


def _excess(fit) -> float:
    return sum(max(0.0, p.step_max - p.limit) for p in fit.pairs)


def _developable(results, name) -> bool:
    return next(r for r in results if r.name == name).figures["plate_class"]["class"] in ("flat", "developable")


def test_pairs_of_flat_or_strip_plates_left_stepping_are_held_and_formed(shoulders):
    (_, plain_results, plain), (config, results, held) = shoulders
    report = config.fitup_follow
    stepping = [(p.a, p.b) for p in plain.pairs
                if p.step_max > p.limit and _developable(plain_results, p.a) and _developable(plain_results, p.b)]
    assert len(stepping) == 3  # the control: follow alone leaves them
    assert not report.untaken and report.held
    by_name = {r.name: r for r in results}
    for name, record in report.held.items():
        result = by_name[name]
        assert record["class_before"] in ("flat", "developable") and record["class_after"] == "formed"
        assert result.figures["plate_class"]["class"] == "formed"
        assert result.figures["edge_fit"]["rule"] == "strake.hold_steps (fit_up: follow)"
        assert name in config.fitup_follow.moved  # formed to meet its neighbours
        assert result.figures["hull_fit"]["max_distance"] <= result.part.hull.fit_tolerance * (1 + 1e-6)
    # every pair that stepped has a plate held, and no flat or strip pair steps any more
    assert all(a in report.held or b in report.held for a, b in stepping)
    assert not [p for p in held.pairs if p.step_max > p.limit
                and _developable(results, p.a) and _developable(results, p.b)]
    for a, b in stepping:
        pair = next(p for p in held.pairs if {p.a, p.b} == {a, b})
        assert pair.step_max <= pair.limit
    assert _excess(held) < 0.5 * _excess(plain)
    assert "held for their steps" in report.one_line()
    assert report.as_dict()["held"] == report.held


def test_the_held_plates_are_the_fewest_square_metres_that_cover_the_steps(monkeypatch):
    # a plate between two stepping neighbours covers both pairs: held alone when it is
    # smaller than its two neighbours together, else the two neighbours are
    from pipeline.hull import repair

    def sides(pair, records, mm):
        return [(1.0, name, "E", other, "flat") for name, other in ((pair.a, pair.b), (pair.b, pair.a))]

    monkeypatch.setattr(repair, "holdable_sides", sides)

    def cover(middle_m2):
        areas = {"left": 2.0, "middle": middle_m2, "right": 2.1}
        records = {name: (None, SimpleNamespace(hull=SimpleNamespace(result=SimpleNamespace(
            figures={"region": {"area_m2": area}})))) for name, area in areas.items()}
        pairs = [SimpleNamespace(a="left", b="middle", step_max=3.0), SimpleNamespace(a="middle", b="right", step_max=4.0)]
        chosen = follow._cover(pairs, records, 1.0)
        return sorted(chosen), {name: pair.step_max for name, (pair, _) in chosen.items()}

    assert cover(3.0) == (["middle"], {"middle": 4.0})  # its worst pair is its record
    assert cover(5.0) == (["left", "right"], {"left": 3.0, "right": 4.0})
    # a tie of pairs per square metre (left 1 / 2.0, middle 2 / 4.0) goes to the name
    assert cover(4.0) == (["middle"], {"middle": 4.0})


def test_without_hold_steps_nothing_is_held(shoulders):
    (config, results, _), _ = shoulders
    assert not config.fitup_follow.held and "held" not in config.fitup_follow.as_dict()
    assert all("edge_fit" not in r.figures for r in results)


def test_hold_steps_without_follow_is_refused_naming_both_fields(tmp_path, capsys):
    from pipeline.cli import main

    path = shoulder(tmp_path, fit_up="report", hold_steps=True)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{path.name}:" in err and "hold_steps: true" in err and "got fit_up: report" in err
    assert not (tmp_path / "out").exists()


def test_held_plates_leave_the_joint_programmes_lists(shoulders):
    # a held plate's plane chosen with its neighbours is gone with its flat development
    _, (config, _, _) = shoulders
    report = config.fitup_follow
    assert report.held
    for name, record in report.held.items():
        assert name not in report.planes and name not in report.strips and name not in report.as_strips
        assert record["undone"] == ["joint_plane"]


def test_a_held_plate_that_cannot_be_developed_stays_as_it_was(tmp_path):
    from pipeline.hull.plan import load_run
    from pipeline.hull.plates import evaluate_plate

    failed = []

    def evaluate(part, config):
        result = evaluate_plate(part, config)
        if part.hull.held and part.name == "fit_S2_B2":
            result.status, result.reason = "failed", "no development (test)"
            failed.append(part.name)
        return result

    config = load_run(shoulder(tmp_path, fit_up="follow", hold_steps=True), evaluate)
    report = config.fitup_follow
    assert report.hold_failed == {"fit_S2_B2": "no development (test)"} and "fit_S2_B2" not in report.held
    part = next(p for p in config.parts if p.name == "fit_S2_B2")
    assert part.hull.held is None and part.hull.result.ok
    assert part.hull.result.figures["plate_class"]["class"] == "flat"
    # the next round holds its neighbour across the pair instead (a strip moved and delivered
    # for a flat plate before: both undone)
    assert report.held["fit_S2_B1"]["round"] == 2 and report.held["fit_S2_B1"]["neighbour"] == "fit_S2_B2"
    assert report.held["fit_S2_B1"]["undone"] == ["strip_moved", "flat_as_strip"]
    assert not report.untaken
    assert failed == ["fit_S2_B2"]  # not held again in round two, though it would cover two steps there
    # round two also finds the strip fit_S1_B1 and the flat fit_S2_B2 parting at the corner of
    # fit_S1_B2 (held and formed in round one) by 6.6 mm: the formed corner between them would
    # step 3.3 mm from each (limit 2.1); they share no edge, and the strip is held for it
    junction = report.held["fit_S1_B1"]
    assert junction["round"] == 2 and junction["junction"] == "fit_S1_B2" and junction["neighbour"] == "fit_S2_B2"
    assert 2.1 < junction["step_mm"] < 5.0
    strip = next(p for p in config.parts if p.name == "fit_S1_B1")
    assert "from fit_S2_B2's at formed plate fit_S1_B2's corner" in strip.hull.held["reason"]


def test_a_held_plate_moved_by_the_forming_is_not_tried_flat_or_as_a_strip_again(tmp_path, monkeypatch):
    # its plane and strip failed on the same region when it was held: moved, it is developed
    # from its moved patch at once (the 160 m hull's 44 held plates each solved its strip twice)
    import flatten.edgeplane
    from pipeline.hull import plates

    tried = []
    strip, plane = plates._edge_held_strip, flatten.edgeplane.edge_held_plane

    def spy_strip(result, *args, **kwargs):
        tried.append(("strip", result.part.name, bool(result.part.hull.follow)))
        return strip(result, *args, **kwargs)

    def spy_plane(*args, **kwargs):
        tried.append(("plane",))
        return plane(*args, **kwargs)

    monkeypatch.setattr(plates, "_edge_held_strip", spy_strip)
    monkeypatch.setattr(flatten.edgeplane, "edge_held_plane", spy_plane)
    config, _, _ = run(shoulder(tmp_path, fit_up="follow", hold_steps=True))
    held = set(config.fitup_follow.held)
    assert held and held <= set(config.fitup_follow.moved)
    assert sorted(name for kind, *rest in tried if kind == "strip" for name, _ in [rest]) == sorted(held)
    assert not any(moved for kind, *rest in tried if kind == "strip" for _, moved in [rest])


def test_what_the_hold_reports_is_what_a_plan_made_again_counts_as_lost(shoulders):
    # plan.replan_held reads the hold's report: every plate held from flat or strip to formed
    from pipeline.hull.replan import lost_plates, region_key

    (config, _, _), (held_config, _, _) = shoulders
    report = held_config.fitup_follow
    by_name = {p.name: p for p in held_config.parts}
    assert lost_plates(report.held, held_config.parts) == frozenset(
        (name, region_key(by_name[name].hull)) for name in report.held)
    assert lost_plates(config.fitup_follow.held, config.parts) == frozenset()  # the control: nothing held
