"""strake.fit_up: follow (pipeline/hull/follow.py): a formed plate is formed to meet its flat
and strip neighbours' edges, so that they do not step, and no plate changes class.

Real data: the four flat plates of the 160 m hull's bow shoulder (seams v = 3.25, 3.43, 3.62,
butts x = 32.4, 36.1, 39.8 m; see test_fitup_repair) are each within the 5 mm fit tolerance
of their planes but 3.5-4.5 mm off the hull at their edges. One of them developed on the hull
(a formed plate) steps from its two flat neighbours by their distance from the hull; formed
to meet them, it does not, and it stays within the tolerance of the hull."""

import dataclasses
import pickle
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from flatten.closest import SurfaceDistance
from pipeline.hull.fitup import shell_fitup
from pipeline.hull.follow import _solve, follow_fitup
from pipeline.hull.plan import load_run
from pipeline.hull.plates import evaluate_plate, run_part
from pipeline.hull.plateshop import develop
from pipeline.shop.templates import hull_mesh
from tests.test_fitup_repair import shoulder


def _grids(shapes):
    """Plain region grids (only their shapes are read by the solve), their start indices."""
    grids, start, total = {}, {}, 0
    for k, (rows, cols) in enumerate(shapes):
        name = f"P{k}"
        grids[name] = SimpleNamespace(points=np.zeros((rows, cols, 3)), flat=np.zeros((rows * cols, 3)))
        start[name] = total
        total += rows * cols
    return grids, sorted(grids), start, total


def _ring(rows, cols):
    known = np.zeros((rows, cols), dtype=bool)
    known[0], known[-1], known[:, 0], known[:, -1] = True, True, True, True
    return known.ravel()


def test_the_blend_reproduces_a_linear_field_across_two_joined_plates():
    # two 7 x 6 grids side by side, sharing the column x = 5 (each has its own copy of it):
    # a linear field is discrete-harmonic, so given on the outer ring it is found everywhere,
    # on the shared column too, when the two are joined (each edge point's neighbour across
    # is the other plate's first column inside)
    rows = 7
    grids, names, start, total = _grids([(rows, 6), (rows, 6)])
    i, j = np.meshgrid(np.arange(rows), np.arange(6), indexing="ij")
    x = np.concatenate([j.ravel(), (j + 5).ravel()]).astype(float)
    y = np.concatenate([i.ravel(), i.ravel()]).astype(float)
    field = np.column_stack([2.0 * x - 0.5 * y + 1.0, 0.25 * y, -x + 3.0])
    left, right = _ring(rows, 6), _ring(rows, 6)
    left[np.arange(rows) * 6 + 5] = False  # the shared column is not given
    right[np.arange(rows) * 6] = False
    left[[5, (rows - 1) * 6 + 5]] = right[[0, (rows - 1) * 6]] = True  # its ends are (corners)
    fixed = np.r_[left, right]
    across = {}
    for r in range(1, rows - 1):
        across[start["P0"] + r * 6 + 5] = ((start["P1"] + r * 6 + 1, 1.0),)
        across[start["P1"] + r * 6] = ((start["P0"] + r * 6 + 4, 1.0),)
    value = np.where(fixed[:, None], field, 1e3)  # the unknown values are not read
    out = _solve(grids, names, start, total, fixed, value, across)
    assert np.allclose(out["P0"].reshape(-1, 3), field[:rows * 6], atol=1e-12)
    assert np.allclose(out["P1"].reshape(-1, 3), field[rows * 6:], atol=1e-12)
    # without the join each plate keeps its own copy of the edge: they no longer agree
    alone = _solve(grids, names, start, total, fixed, value, {})
    assert not np.allclose(alone["P0"][:, 5], alone["P1"][:, 0], atol=1e-3)


def test_the_join_interpolates_across_an_edge_whose_points_do_not_coincide():
    # the left plate (7 rows, y = 0..6) meets the right one (5 rows, y = 0, 1.5, .., 6) on
    # x = 5: each edge point's neighbour across is interpolated along the other plate's first
    # column inside, and a linear field is still found exactly, on both copies of the edge
    from pipeline.hull.follow import _join

    def plate(xs, ys):
        x, y = np.meshgrid(xs, ys)
        points = np.stack([x, y, np.zeros_like(x)], axis=-1)
        rows, cols = points.shape[:2]
        idx = np.arange(rows * cols).reshape(rows, cols)
        butt = "butt1" if xs[-1] == 5.0 else "butt0"
        column = cols - 1 if butt == "butt1" else 0
        return SimpleNamespace(points=points, flat=points.reshape(-1, 3), lines={butt: idx[:, column]},
                               hull=SimpleNamespace(fit_tolerance=1e-6),
                               inward_of=lambda side, index: index + (-1 if side == "butt1" else 1))

    left, right = plate(np.arange(6.0), np.arange(7.0)), plate(np.arange(5.0, 11.0), np.linspace(0.0, 6.0, 5))
    grids = {"P0": left, "P1": right}
    start = {"P0": 0, "P1": 42}
    across = {}
    _join(left, "butt1", right, "butt0", 0, 42, across)
    _join(right, "butt0", left, "butt1", 42, 0, across)
    assert len(across) == 7 + 5
    xy = np.vstack([left.flat, right.flat])
    field = np.column_stack([2.0 * xy[:, 0] - 0.5 * xy[:, 1] + 1.0, 0.25 * xy[:, 1], -xy[:, 0] + 3.0])
    fixed = np.zeros(42 + 30, dtype=bool)
    for g, s0 in ((left, 0), (right, 42)):
        r, c = g.points.shape[:2]
        ring = np.zeros((r, c), dtype=bool)
        ring[0], ring[-1], ring[:, 0], ring[:, -1] = True, True, True, True
        fixed[s0:s0 + r * c] = ring.ravel()
    fixed[list(across)] = False
    fixed[[5, 41, 42, 42 + 24]] = True  # the edge's ends (corners) are given
    out = _solve(grids, ["P0", "P1"], start, 72, fixed, np.where(fixed[:, None], field, 1e3), across)
    assert np.allclose(np.vstack([out["P0"].reshape(-1, 3), out["P1"].reshape(-1, 3)]), field, atol=1e-12)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(arrays(np.float64, (6, 9), elements=st.floats(-5.0, 5.0)))
def test_the_blend_stays_between_its_given_values(values):
    grids, names, start, total = _grids([(6, 9)])
    fixed = _ring(6, 9)
    given_values = np.repeat(values.reshape(-1, 1), 3, axis=1)
    out = _solve(grids, names, start, total, fixed, given_values, {})["P0"][..., 0].ravel()
    ring = values.ravel()[fixed]
    assert np.array_equal(out[fixed], ring)  # the given values are kept
    assert out[~fixed].max() <= ring.max() + 1e-12 and out[~fixed].min() >= ring.min() - 1e-12  # maximum principle


def test_hull_mesh_carries_the_moves_onto_its_fine_mesh():
    from flatten.surface import nurbs_surface

    poles = np.array([[[x, y, 0.1 * x * y] for y in (0.0, 1.0, 2.0)] for x in (0.0, 1.0, 2.0, 3.0)])
    surface = nurbs_surface(2, 2, poles, [0, 0, 0, 0.5, 1, 1, 1], [0, 0, 0, 1, 1, 1])
    u, v = np.meshgrid(np.linspace(0, 1, 4), np.linspace(0, 1, 3), indexing="ij")
    params = np.stack([u, v], axis=-1)
    flat = params * 3.0
    move = np.array([0.0, 0.01, -0.02])
    plain = hull_mesh(surface, params, flat, 1000.0, target_mm=200.0)
    moved = hull_mesh(surface, params, flat, 1000.0, target_mm=200.0, offsets=np.broadcast_to(move, (4, 3, 3)))
    assert len(plain[0]) > params.shape[0] * params.shape[1]  # refined
    assert np.allclose(moved[0] - plain[0], move * 1000.0, atol=1e-9)
    assert np.array_equal(moved[1], plain[1]) and np.array_equal(moved[2], plain[2])


@pytest.fixture(scope="module")
def one_formed(tmp_path_factory):
    """The shoulder with its first plate developed on the hull, before and after the fit-up
    by forming (config, results, fit-up, results, fit-up, report)."""
    return _formed_to_meet(tmp_path_factory.mktemp("follow"), (0,))


def _developed(part, config):
    """The plate evaluated as a plan does (lean), its development done: what a fit-up reads
    (``load_run`` develops the plan's plates before the fit-up)."""
    return develop(evaluate_plate(part, config), config)


def _formed_to_meet(tmp, held_plates: tuple):
    """The shoulder with the given plates developed on the hull, before and after the fit-up
    by forming."""
    config = load_run(shoulder(tmp), evaluate_plate)
    parts = config.parts
    for k in held_plates:
        parts[k].hull.held = {"reason": "test: developed on the hull"}
    for part in parts:
        part.hull.result = _developed(part, config)
    before = [run_part(part, config) for part in parts]
    fit_before = shell_fitup(before, config)
    flat = [k for k in range(len(parts)) if k not in held_plates]
    kept = [parts[k].hull.result for k in flat]
    # the forming alone: the flat plates keep their own (minimax) planes (joint moves: test_fitup_joint.py)
    report = follow_fitup(parts, lambda batch: [_developed(p, config) for p in batch], config.mm_per_unit, 14.0,
                          joint=False)
    assert all(parts[k].hull.result is was for k, was in zip(flat, kept))  # the flat plates are not touched
    after = [run_part(part, config) for part in parts]
    return config, before, fit_before, after, shell_fitup(after, config), report


def _steps(fit, name):
    return {tuple(sorted((p.a, p.b))): p for p in fit.pairs if name in (p.a, p.b)}


def test_a_formed_plate_formed_to_meet_its_flat_neighbours_does_not_step(one_formed):
    _, before, fit_before, after, fit_after, report = one_formed
    name = before[0].name
    assert [r.figures["plate_class"]["class"] for r in before] == ["formed", "flat", "flat", "flat"]
    assert [r.figures["plate_class"]["class"] for r in after] == ["formed", "flat", "flat", "flat"]
    stepped = _steps(fit_before, name)
    assert len(stepped) == 2 and all(p.step_max > p.limit for p in stepped.values())  # the flat plates' edges
    assert list(report.moved) == [name] and report.moved[name]["neighbours"] == sorted(
        n for key in stepped for n in key if n != name)
    now = _steps(fit_after, name)
    assert now.keys() == stepped.keys()
    for key, pair in now.items():
        assert pair.step_max < 0.5 * pair.limit, (key, pair.step_max)
        assert pair.step_max < 0.25 * stepped[key].step_max
    others = [p for p in fit_after.pairs if name not in (p.a, p.b)]
    assert others and all(p.step_max == pytest.approx(q.step_max, abs=1e-9) for p, q in zip(
        others, [p for p in fit_before.pairs if name not in (p.a, p.b)]))


def test_the_formed_plate_stays_within_the_tolerance_and_says_how_far_it_moved(one_formed):
    config, before, _, after, _, report = one_formed
    plate = after[0]
    tol = plate.part.hull.fit_tolerance
    largest = report.moved[plate.name]["largest_move_mm"]
    assert 1.0 < largest <= tol + 1e-9  # the flat plates' edges are 3.5-4.5 mm off the hull
    assert plate.figures["follow"]["neighbours"] == report.moved[plate.name]["neighbours"]
    # its mesh is the hull's grid moved: no point further from the hull than the largest move
    distance = plate.part.hull.distance or SurfaceDistance(plate.part.hull.surface)
    v3 = np.asarray(plate.mesh[0])
    # (the moves are mostly along the hull's normal: the farthest point is about the largest move off it)
    assert 0.8 * largest / config.mm_per_unit <= distance(v3).max() <= largest / config.mm_per_unit * (1 + 1e-6) + 1e-9
    assert np.allclose(np.asarray(before[0].mesh[0]), v3) is False
    # the same region: its developed area changes by the strain of a few millimetres only
    assert plate.figures["area_m2"] == pytest.approx(before[0].figures["area_m2"], rel=1e-3)
    assert plate.figures["area_m2"] != before[0].figures["area_m2"]


def test_the_run_forms_the_formed_plates_to_meet_and_reports_it(tmp_path, capsys, monkeypatch):
    # at a 4 mm fit tolerance the shoulder's plates of the first butt stay flat and those of
    # the second are formed: formed to meet the flat ones, their butt no longer steps, and the
    # two flat plates' own seam is left as it was. Where that seam meets the butt the two flat
    # plates step by 7.2 mm: each formed plate meets its own flat neighbour there, so their
    # shared seam takes that step at its end (and only there: its median stays 0). The forming
    # and planes alone: the least-curvature strips (which fit some of the shoulder's flat
    # plates: test_fitup_joint) not tried
    import json

    from pipeline.cli import main
    from pipeline.hull import leaststrip

    monkeypatch.setattr(leaststrip, "GATE", -1.0)

    (tmp_path / "plain").mkdir()
    plain = shoulder(tmp_path / "plain", fit_tolerance=4.0)
    assert main(["run", str(plain), "--out", str(tmp_path / "plain_out")]) == 0
    path = shoulder(tmp_path, fit_tolerance=4.0, fit_up="follow")
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    before = json.loads((tmp_path / "plain_out" / "fit_summary.json").read_text())["shell"]
    summary = json.loads((tmp_path / "out" / "fit_summary.json").read_text())
    follow = summary["shell"]["follow"]
    assert sorted(follow["moved"]) == ["fit_S1_B2", "fit_S2_B2"]
    assert "2 formed plate(s) formed to meet their flat and strip neighbours" in out
    steps = {tuple(p["plates"]): p for p in summary["shell"]["pairs"]}
    was = {tuple(p["plates"]): p for p in before["pairs"]}
    assert steps.keys() == was.keys() and len(steps) == 4
    for key, pair in steps.items():
        if key == ("fit_S1_B1", "fit_S2_B1"):  # two flat plates: nothing to form; their planes, chosen
            # together, bring their step down as far as the tolerance lets them (not below the limit here)
            assert pair["misfit"] and pair["step_max_mm"] < was[key]["step_max_mm"] - 0.1
            assert sorted(follow["planes"]) == list(key) and follow["flat_planes_moved"] == 2
            assert [list(key)] == [u["plates"] for u in follow["untaken"]]
        elif key == ("fit_S1_B2", "fit_S2_B2"):  # the formed plates' seam, from the flat plates' junction
            assert pair["step_median_mm"] < 0.05 and pair["step_max_mm"] <= steps[("fit_S1_B1", "fit_S2_B1")][
                "step_max_mm"]
        else:
            assert not pair["misfit"] and pair["step_max_mm"] < 0.5 * pair["step_limit_mm"], (key, pair)
    stepped = [k for k in was if "fit_S2_B2" in k and "fit_S2_B1" in k]
    assert stepped and was[stepped[0]]["misfit"]  # the flat/formed butt stepped before
    for name in follow["moved"]:
        plate = json.loads((tmp_path / "out" / f"{name}.json").read_text())
        assert plate["plate_class"]["class"] == "formed"
        assert 1.0 < plate["follow"]["largest_move_mm"] <= 4.0 + 1e-9
        assert plate["hull_fit"]["passed"] and plate["edge_fit"] is None if "edge_fit" in plate else True


def test_two_formed_plates_across_a_butt_move_together(tmp_path):
    # the shoulder's two plates of its first seam developed on the hull, across their butt:
    # formed to meet the flat plates beyond their seam, they are joined at the butt (the
    # region grids' butt columns found from the plan's butt planes): the butt moves with
    # them (not pinned to the hull as a free edge would be). At its seam end each meets its
    # own flat neighbour, and the flat plates step there by 7.8 mm: the two plates' butts
    # part by that much at the corner, by about 0.27 of it a point further (2 - sqrt 3, the
    # joined equation's damping), and so on to the free edge, where both stay on the hull
    _, _, fit_before, after, fit_after, report = _formed_to_meet(tmp_path, (0, 1))
    a, b = after[0], after[1]
    assert sorted(report.moved) == [a.name, b.name]
    offsets = [r.part.hull.follow["offsets"] for r in (a, b)]
    largest = max(float(np.linalg.norm(o, axis=2).max()) for o in offsets)
    butt_x = a.part.hull.butts[1].offset
    columns = [int(np.argmin(np.abs(r.mesh[0].reshape(o.shape)[0, [0, -1], 0] - butt_x))) * (o.shape[1] - 1)
               for r, o in zip((a, b), offsets)]
    assert sorted(columns) == [0, offsets[0].shape[1] - 1]  # an end column of each (the grids run either way)
    along = [o[:, c] for o, c in zip(offsets, columns)]  # the butt's points, seam 0 (free) to seam 1
    assert along[0].shape == along[1].shape and len(along[0]) == 5
    assert np.linalg.norm(along[0][1:-1], axis=1).max() > 0.2 * largest  # moved with the plates
    apart = np.linalg.norm(along[0] - along[1], axis=1)
    assert apart[0] == 0.0 and apart[-1] > largest  # on the hull at the free edge; the flat plates' step
    assert np.all(apart[1:-1] <= 0.3 * apart[2:]) and np.all(apart[1:-1] >= 0.2 * apart[2:])
    butt = [p for p in fit_after.pairs if {p.a, p.b} == {a.name, b.name}]
    flat_butt = [p for p in fit_after.pairs if p.kind == "butt" and a.name not in (p.a, p.b) and b.name not in (
        p.a, p.b)]
    # their butt steps only where the flat plates' butt does, at its seam end (7-9 mm there)
    assert len(butt) == 1 and len(flat_butt) == 1 and butt[0].step_max <= flat_butt[0].step_max + 0.1
    for name in (a.name, b.name):  # and their seam with the flat plates no longer steps
        seam = [p for p in fit_after.pairs if name in (p.a, p.b) and p.kind == "seam"]
        was = [p for p in fit_before.pairs if name in (p.a, p.b) and p.kind == "seam"]
        assert len(seam) == 1 and was[0].misfit and seam[0].step_median < 0.5 * seam[0].limit, seam[0]


@settings(max_examples=30, deadline=None, derandomize=True)
@given(arrays(np.float64, (2, 5, 4), elements=st.floats(-5.0, 5.0)))
def test_the_joined_blend_stays_between_its_given_values(values):
    # two 5 x 4 grids joined along their shared column, random values on their outer rings
    grids, names, start, total = _grids([(5, 4), (5, 4)])
    fixed = np.r_[_ring(5, 4), _ring(5, 4)]
    across = {}
    for r in range(1, 4):
        fixed[r * 4 + 3] = fixed[20 + r * 4] = False
        across[r * 4 + 3] = ((20 + r * 4 + 1, 0.7), (20 + min(r + 1, 3) * 4 + 1, 0.3))
        across[20 + r * 4] = ((r * 4 + 2, 1.0),)
    given_values = np.repeat(values.reshape(-1, 1), 3, axis=1)
    out = _solve(grids, names, start, total, fixed, given_values, across)
    solved = np.r_[out["P0"][..., 0].ravel(), out["P1"][..., 0].ravel()]
    ring = values.ravel()[fixed]
    assert np.array_equal(solved[fixed], ring)
    assert solved[~fixed].max() <= ring.max() + 1e-12 and solved[~fixed].min() >= ring.min() - 1e-12


def _rectangle_ring(points, hull, tolerance):
    """A rectangular grid's ring and side codes: the seams its rows, the butts its end columns."""
    r, c = points.shape[:2]
    idx = np.arange(r * c).reshape(r, c)
    pieces = [(idx[0, :], 0), (idx[1:-1, -1], 3), (idx[-1, ::-1], 1), (idx[-2:0:-1, 0], 2)]
    return np.concatenate([i for i, _ in pieces]), np.concatenate([np.full(len(i), k) for i, k in pieces])


def _two_formed_plates(monkeypatch, gap: float, unit: float = 1.0, flat_lift=None, butt_lift=None):
    """Two formed plates' region grids side by side in the plane z = 0 (5 x 6 points, 500 mm
    apart; model units of ``unit`` mm), sharing the edge x = 2500 mm (butt 1 of the left,
    butt 0 of the right), the right one lifted by ``gap`` mm (two faces of a hull model that
    disagree where a plan cut them). ``flat_lift``: a flat
    neighbour along the left plate's seam 0, its edge that far (mm) above it; ``butt_lift``:
    one along its butt 0 (the shell's end otherwise). (grids, pairs, records)."""
    from pipeline.hull import follow
    from pipeline.hull.fitup import Edge

    monkeypatch.setattr(follow, "_grid_ring", _rectangle_ring)
    def plane_at(z_mm):  # each plate's hull is its own plane (the faces that disagree)
        return lambda points: np.abs(np.asarray(points).reshape(-1, 3)[:, 2] - z_mm / unit)

    hulls = {name: SimpleNamespace(fit_tolerance=5.0 / unit, distance=plane_at(gap if name == "R" else 0.0))
             for name in ("L", "R", "F", "B")}
    y, x = np.meshgrid(np.arange(5) * 500.0, np.arange(6) * 500.0, indexing="ij")
    left = np.stack([x, y, np.zeros_like(x)], axis=-1) / unit
    right = np.stack([x + 2500.0, y, np.full_like(x, gap)], axis=-1) / unit
    grids = {"L": follow._PlateGrid("L", left, hulls["L"]), "R": follow._PlateGrid("R", right, hulls["R"])}

    def record(klass, side, points, name):
        edge = Edge(side, side.upper(), points, points[:, :2])
        return SimpleNamespace(klass=klass, edge=lambda s: edge if s == side else None), SimpleNamespace(
            hull=hulls[name])

    records = {"L": record("formed", "butt1", left[:, -1], "L"), "R": record("formed", "butt0", right[:, 0], "R")}
    pairs = [SimpleNamespace(a="L", b="R", side_a="butt1", side_b="butt0", step_max=gap, limit=2.1)]
    if flat_lift is not None:
        records["F"] = record("flat", "seam1", left[0] + np.array([0.0, 0.0, flat_lift / unit]), "F")
        pairs.append(SimpleNamespace(a="F", b="L", side_a="seam1", side_b="seam0", step_max=flat_lift, limit=2.1))
    if butt_lift is not None:
        records["B"] = record("flat", "butt1", left[:, 0] + np.array([0.0, 0.0, butt_lift / unit]), "B")
        pairs.append(SimpleNamespace(a="B", b="L", side_a="butt1", side_b="butt0", step_max=butt_lift, limit=2.1))
    return grids, pairs, records


@pytest.mark.parametrize("gap, unit", [(6.0, 1.0), (14.0, 1.0), (6.0, 1000.0)])
def test_two_formed_plates_that_step_are_formed_to_meet_halfway(monkeypatch, gap, unit):
    # formed plates whose faces disagree by `gap` where they meet: each is formed half the
    # way to the other (at most the fit tolerance, 5 mm), so a 6 mm step closes and a 14 mm
    # one is left at 14 - 2 x 5 = 4 mm (model units of mm or of metres alike); the moves fall
    # off harmonically to their free edges
    from pipeline.hull.follow import shell_moves

    grids, pairs, records = _two_formed_plates(monkeypatch, gap, unit)
    moves = shell_moves(grids, pairs, records, unit)
    half = min(gap / 2, 5.0) / unit
    left, right = grids["L"].points + moves["L"], grids["R"].points + moves["R"]
    assert np.allclose(moves["L"][:, -1], [0.0, 0.0, half], atol=1e-9)
    assert np.allclose(moves["R"][:, 0], [0.0, 0.0, -half], atol=1e-9)
    assert np.allclose(right[:, 0, 2] - left[:, -1, 2], gap / unit - 2 * half, atol=1e-9)
    assert np.allclose(right[:, 0, :2], left[:, -1, :2], atol=1e-9)  # only across the plates
    for name, shared in (("L", -1), ("R", 0)):
        size = np.abs(moves[name][..., 2])
        assert size.max() <= half + 1e-12 and np.all(size[1:-1, 1:-1] < half)  # between 0 and the edge's move
        free = np.ones(size.shape, dtype=bool)
        free[1:-1, 1:-1] = False
        free[:, shared] = False
        assert np.all(size[free] == 0.0)  # the shell's free edges stay on the hull


def test_a_flat_neighbour_holds_its_corner_against_the_halfway_move(monkeypatch):
    # the left plate's seam 0 meets a flat plate 1 mm above it: its points there, the shared
    # edge's corner among them, meet the flat plate; the right plate's corner there, with no
    # flat neighbour of its own, goes where the left one's went (6 - 1 = 5 mm down, the
    # tolerance: the junction's corners meet) and the rest of the shared edge meets halfway
    from pipeline.hull.follow import shell_moves

    grids, pairs, records = _two_formed_plates(monkeypatch, 6.0, flat_lift=1.0)
    moves = shell_moves(grids, pairs, records, 1.0)
    assert np.allclose(moves["L"][0], [0.0, 0.0, 1.0], atol=1e-9)  # the whole seam, corner included
    assert np.allclose(moves["L"][1:, -1], [0.0, 0.0, 3.0], atol=1e-9)
    assert np.allclose(moves["R"][1:, 0], [0.0, 0.0, -3.0], atol=1e-9)
    assert np.allclose(moves["R"][0, 0], [0.0, 0.0, -5.0], atol=1e-9)
    assert np.allclose(grids["R"].points[0, 0] + moves["R"][0, 0], grids["L"].points[0, -1] + moves["L"][0, -1])


@pytest.mark.parametrize("unit", [1.0, 1000.0])
@pytest.mark.parametrize("along, lift, left_mm", [(3.0, 4.75, 0.0), (0.0, 7.0, 2.0), (12.0, 1.0, np.hypot(12.0, 1.0) - 10.0)])
def test_a_formed_plate_meets_a_neighbour_off_the_hull_within_the_tolerance_of_it(monkeypatch, unit, along, lift,
                                                                                   left_mm):
    # a flat neighbour's edge 4.75 mm above the hull (the plane z = 0) and 3 mm along it,
    # outwards: 5.6 mm from the formed plate's seam, but within the 5 mm tolerance of the
    # hull, so the seam goes all the way onto it (shortened to 5 mm, as the moves were before,
    # it stepped 0.6 mm); 7 mm above, the seam goes up to the tolerance and steps 2 mm; 12 mm
    # along (1 mm above) it slides at most twice the tolerance, 10 mm of the 12.04
    from pipeline.hull.follow import _within_tolerance, shell_moves

    grids, pairs, records = _two_formed_plates(monkeypatch, 0.0, unit, flat_lift=0.0)
    edge = records["F"][0].edge("seam1")
    shifted = edge.points3 + np.array([0.0, -along, lift]) / unit
    records["F"] = (SimpleNamespace(klass="flat", edge=lambda s: dataclasses.replace(edge, points3=shifted)
                                    if s == "seam1" else None), records["F"][1])
    moves = shell_moves(grids, pairs, records, unit)
    seam = grids["L"].points[0, 1:-1] + moves["L"][0, 1:-1]
    gap = np.linalg.norm(seam - shifted[1:-1], axis=1) * unit
    assert np.allclose(gap, left_mm, atol=1e-9)
    assert np.abs(seam[:, 2]).max() * unit <= 5.0 + 1e-9  # within the tolerance of the hull
    _, off = _within_tolerance(grids["L"].points, moves["L"], grids["L"].hull)
    slid = lift * min(1.0, 10.0 / np.hypot(along, lift))  # the move shortened to twice the tolerance
    assert off * unit <= 5.0 + 1e-9 and off * unit == pytest.approx(min(slid, 5.0))


@pytest.mark.parametrize("unit", [1.0, 1000.0])
def test_a_formed_corner_between_two_flat_neighbours_that_part_goes_between_them(monkeypatch, unit):
    # the left plate's seam 0 meets a flat plate lying on it and its butt 0 one 4 mm above it:
    # their edges end at the plate's corner 4 mm apart. Sent to either end the corner would
    # step 4 mm from the other neighbour (what one edge's end claims: the nearer, 0); at the
    # centre of the two ends it steps 2 mm from each. The seam's and the butt's other points
    # meet their own neighbour, and the right plate, joined, meets the left at the corner
    from pipeline.hull.follow import shell_moves

    grids, pairs, records = _two_formed_plates(monkeypatch, 0.0, unit, flat_lift=0.0, butt_lift=4.0)
    moves = shell_moves(grids, pairs, records, unit)
    assert np.allclose(moves["L"][0, 0], [0.0, 0.0, 2.0 / unit], atol=1e-12)
    assert np.allclose(moves["L"][0, 1:], 0.0, atol=1e-12)
    assert np.allclose(moves["L"][1:, 0], [0.0, 0.0, 4.0 / unit], atol=1e-12)
    corner = grids["L"].points[0, 0] + moves["L"][0, 0]
    for name, side in (("F", "seam1"), ("B", "butt1")):
        assert np.linalg.norm(records[name][0].edge(side).points3[0] - corner) * unit == pytest.approx(2.0)


def test_a_formed_corner_with_only_formed_neighbours_at_a_junction_goes_where_theirs_go(monkeypatch):
    # the flat plate along the left plate's seam 0 lies 3 mm above it: the left plate's
    # corner at the shared butt goes to its end; the right plate's corner there, whose only
    # neighbour there is the left plate, goes to the same point (kept on the hull as a corner
    # of the shell's free seam, the two formed plates stepped 3 mm at the junction)
    from pipeline.hull.follow import shell_moves

    grids, pairs, records = _two_formed_plates(monkeypatch, 0.0, flat_lift=3.0)
    moves = shell_moves(grids, pairs, records, 1.0)
    left = grids["L"].points + moves["L"]
    right = grids["R"].points + moves["R"]
    assert np.allclose(moves["L"][0], [0.0, 0.0, 3.0], atol=1e-9)
    assert np.allclose(right[0, 0], left[0, -1], atol=1e-9)
    assert np.all(moves["R"][0, 1:] == 0.0)  # the rest of its free seam stays on the hull


def _t_junction(monkeypatch, left: tuple, right: tuple, upper_step: float, left_from: float = 0.0):
    """Three plates of the plane z = 0 (mm) meeting at a T: below, the left (x ``left_from``-2500, y
    0-2000) and the right (x 2500-5000), each (class, lift: its edges that far above the
    plane); above them the formed plate U (y 2000-4000) with points every ``upper_step``
    along x. (grids, pairs, records, the three grids' points by name)."""
    from pipeline.hull import follow
    from pipeline.hull.fitup import Edge

    monkeypatch.setattr(follow, "_grid_ring", _rectangle_ring)
    hull = SimpleNamespace(fit_tolerance=5.0, distance=lambda points: np.abs(np.asarray(points).reshape(-1, 3)[:, 2]))

    def grid(x0, x1, step, y0, z=0.0):
        cols = round((x1 - x0) / step) + 1
        y, x = np.meshgrid(np.linspace(y0, y0 + 2000.0, 5), np.linspace(x0, x1, cols), indexing="ij")
        return np.stack([x, y, np.full_like(x, z)], axis=-1)

    points = {"L": grid(left_from, 2500.0, 500.0, 0.0, left[1]), "R": grid(2500.0, 5000.0, 500.0, 0.0, right[1]),
              "U": grid(0.0, 5000.0 - 5000.0 % upper_step, upper_step, 2000.0)}
    # a formed plate's region grid lies on the hull
    grids = {name: follow._PlateGrid(name, points[name] * np.array([1.0, 1.0, 0.0]), hull)
             for name, kind in (("L", left[0]), ("R", right[0]), ("U", "formed")) if kind == "formed"}

    def record(klass, sides):
        edges = {side: Edge(side, side.upper(), q, q[:, :2]) for side, q in sides.items()}
        return SimpleNamespace(klass=klass, edge=edges.get), SimpleNamespace(hull=hull)

    records = {"L": record(left[0], {"seam1": points["L"][-1], "butt1": points["L"][:, -1]}),
               "R": record(right[0], {"seam1": points["R"][-1], "butt0": points["R"][:, 0]}),
               "U": record("formed", {"seam0": points["U"][0]})}
    step = abs(left[1] - right[1])
    pairs = [SimpleNamespace(a="L", b="R", side_a="butt1", side_b="butt0", step_max=step, limit=2.1),
             SimpleNamespace(a="L", b="U", side_a="seam1", side_b="seam0", step_max=abs(left[1]), limit=2.1),
             SimpleNamespace(a="R", b="U", side_a="seam1", side_b="seam0", step_max=abs(right[1]), limit=2.1)]
    return grids, pairs, records, points


@pytest.mark.parametrize("lift", [4.0, -3.0])
def test_a_formed_plate_runs_through_a_junction_on_its_edge(monkeypatch, lift):
    # KCS: below a formed plate's seam, a formed plate and a strip end together at their
    # butt (a T). The lower formed plate's corner goes to the strip's corner, 4 mm off the
    # hull; the upper plate's seam meets the strip beyond the junction, but its grid has no
    # point at the junction: its nearest point, short of it on the formed plate's side, was
    # a mean of its neighbours, and the seam's chord passed beside the two corners (KCS: 4.39
    # mm, its point 12.7 mm short; here 0.89 and 0.67 mm, its point 100 mm short). Here the
    # lower formed plate L, the flat plate R lifted by `lift`, U's points 600 mm apart
    from pipeline.hull.follow import shell_moves

    grids, pairs, records, points = _t_junction(monkeypatch, ("formed", 0.0), ("flat", lift), 600.0)
    moves = shell_moves(grids, pairs, records, 1.0)
    junction = np.array([2500.0, 2000.0, lift])  # the flat plate's corner
    assert np.allclose(points["L"][-1, -1] + moves["L"][-1, -1], junction, atol=1e-9)  # the junction rule's
    seam = points["U"][0] + moves["U"][0]
    # beyond the junction the seam lies on the flat plate's edge ...
    assert np.allclose(seam[5:, 2], lift, atol=1e-9)
    # ... and its chord from 2400 to 3000 mm passes through the junction
    at = seam[4] + (2500.0 - 2400.0) / 600.0 * (seam[5] - seam[4])
    assert np.linalg.norm(at - junction) <= 1e-9
    assert np.abs(seam[:, 2]).max() <= 5.0 + 1e-9


def test_a_formed_plate_runs_through_two_strips_ends_on_its_edge(monkeypatch):
    # KCS's yard plan: two strips that end together on a formed plate's butt, their corners
    # 2.3 mm apart; the formed plate's point 0.7 mm from them found its closest point at
    # their edges' ends (another neighbour's), so neither claimed it, and left to the
    # Laplace equation it stood 5.6 mm from them (5.43 mm steps). Here two flat plates 1 and
    # 3 mm above the plane end at U's point x = 2500 mm (the left one from x = 1000 mm: U's
    # seam short of it is a free edge, on the hull): it goes to the centre of their ends, 1 mm
    # from each
    from pipeline.hull.follow import shell_moves

    grids, pairs, records, points = _t_junction(monkeypatch, ("flat", 1.0), ("flat", 3.0), 500.0, 1000.0)
    moves = shell_moves(grids, pairs, records, 1.0)
    seam = points["U"][0] + moves["U"][0]
    assert np.allclose(seam[5], [2500.0, 2000.0, 2.0], atol=1e-9)
    assert np.allclose(seam[3:5, 2], 1.0, atol=1e-9) and np.allclose(seam[6:, 2], 3.0, atol=1e-9)


@pytest.mark.parametrize("cut", [False, True])
def test_a_plate_cut_at_its_trim_keeps_the_corner_where_its_trim_ends(monkeypatch, cut):
    # the left plate's butt 0 meets a flat plate 4 mm above it: its corner on the free seam 0
    # goes up with it (a corner of its edge), unless the plate is cut at its trim and its TRIM
    # edge ends at that corner (0.02 mm off it, as a cut outline's vertex may be): moved, the
    # corner would carry the cut off the trim line that the plate across the trim meets, so it
    # stays on the hull, and the rest of the butt moves
    from pipeline.hull.fitup import Edge
    from pipeline.hull.follow import shell_moves

    grids, pairs, records = _two_formed_plates(monkeypatch, 0.0, butt_lift=4.0)
    left = grids["L"].points
    if cut:
        along = left[0, ::-1] + np.array([0.0, 0.02, 0.0])  # along seam 0, ending 0.02 mm off the corner
        edges = {"butt1": records["L"][0].edge("butt1"), "trim": Edge("trim", "TRIM", along, along[:, :2].copy())}
        records["L"] = (SimpleNamespace(klass="formed", edge=edges.get), records["L"][1])
    moves = shell_moves(grids, pairs, records, 1.0)
    assert np.allclose(moves["L"][1:-1, 0], [0.0, 0.0, 4.0], atol=1e-9)
    assert np.allclose(moves["L"][0, 0], [0.0, 0.0, 0.0 if cut else 4.0], atol=1e-9)


def test_two_formed_plates_within_the_limit_are_joined_as_they_lie(monkeypatch):
    # a 1 mm step (the limit is 2.1 mm) is nothing to form away: the plates stay joined at
    # their edge and move together; a flat neighbour 2 mm above the left plate's seam 0 moves
    # it, and the move carries across the joined edge into the right plate
    from pipeline.hull.follow import shell_moves

    grids, pairs, records = _two_formed_plates(monkeypatch, 1.0, flat_lift=2.0)
    moves = shell_moves(grids, pairs, records, 1.0)
    across_left, across_right = moves["L"][1:-1, -1, 2], moves["R"][1:-1, 0, 2]
    assert np.all(across_left > 0.2) and np.all(across_right > 0.2)  # carried across, upwards with it
    assert np.all(moves["R"][..., 2] >= 0.0) and np.abs(moves["R"]).max() <= 2.0 + 1e-9  # not halfway (down)
    # the joined copies part only towards the free seam's corner, where the right plate stays on the hull
    assert abs(across_left[-1] - across_right[-1]) < 0.25 * across_left[-1]


def test_a_formed_plate_moved_to_meet_its_neighbours_keeps_its_verdict_and_is_not_solved_again(tmp_path,
                                                                                              monkeypatch):
    # at a 4 mm fit tolerance the shoulder's two plates of the second butt are formed (no
    # strip fits) and are moved to meet the flat plates: the region and the hull are those
    # they were judged on, so their strips are not solved again; the plate delivered is the
    # one the whole plate run gives for the same moves (its reasons, its roll lines from the
    # same strip, its moved mesh and development), bit for bit
    import copy
    import dataclasses

    from pipeline.hull import plates
    from pipeline.hull.plates import run_plate
    from pipeline.hull.plateshop import complete

    config = load_run(shoulder(tmp_path, fit_tolerance=4.0), evaluate_plate)
    parts = config.parts
    for part in parts:
        part.hull.result = _developed(part, config)
    formed = [p.name for p in parts if p.hull.result.figures["plate_class"]["class"] == "formed"]
    assert formed == ["fit_S1_B2", "fit_S2_B2"]
    solved = []

    def counted(name):
        solve = getattr(plates, name)
        return lambda *args, **kwargs: solved.append(name) or solve(*args, **kwargs)

    for name in ("_seam_strip", "butt_family", "seam_family_far", "flattest_plane"):
        monkeypatch.setattr(plates, name, counted(name))
    report = follow_fitup(parts, lambda batch: [_developed(p, config) for p in batch], config.mm_per_unit, 14.0,
                          joint=False)
    assert sorted(report.moved) == formed and not solved
    monkeypatch.undo()
    for part in (p for p in parts if p.name in formed):
        assert part.hull.follow["verdict"] is not None
        kept = complete(part.hull.result, config)
        whole = dataclasses.replace(part.hull, follow=dict(part.hull.follow, verdict=None), result=None)
        alone = copy.copy(part)
        alone.hull = whole
        again = complete(run_plate(alone, plates.LeanRun(config)), config)
        assert _figures(kept) == _figures(again)
        assert kept.figures["forming"]["roll_line_method"].startswith("rulings of devflat's strip")
        assert kept.figures["follow"]["largest_move_mm"] > 1.0
        assert np.array_equal(kept.mesh[0], again.mesh[0]) and np.array_equal(kept.pattern.vertices,
                                                                             again.pattern.vertices)
        assert np.array_equal(kept.pattern.bend_lines, again.pattern.bend_lines)


def _figures(result) -> str:
    """Every figure of a plate's report, as text (arrays as lists)."""
    import json

    return json.dumps(result.figures, default=lambda o: np.asarray(o).tolist(), sort_keys=True)


def test_only_a_formed_plate_whose_strips_were_tried_keeps_a_verdict(tmp_path):
    # the shoulder at 4 mm: two flat plates, two formed ones; a verdict is what the strips
    # were found to be, so a flat plate, a plate developed on the hull without trying them
    # (held for its fit-up) and a plate run in full (no owed shop data) have none; a formed
    # plate evaluated in the plan's worker processes carries it across as the one evaluated here
    from pipeline.hull.plates import run_plate
    from pipeline.hull.plateshop import formed_verdict
    from pipeline.runner import PlateEvaluator

    config = load_run(shoulder(tmp_path, fit_tolerance=4.0), evaluate_plate)
    parts = config.parts
    lean = {p.name: evaluate_plate(p, config) for p in parts}
    kinds = {name: r.figures["plate_class"]["class"] for name, r in lean.items()}
    assert sorted(kinds.values()) == ["flat", "flat", "formed", "formed"]
    for name, result in lean.items():
        verdict = formed_verdict(result)
        assert (verdict is not None) == (kinds[name] == "formed")
        if verdict is not None:
            assert [f["family"] for f in verdict["info"]["families"]] == ["rulings seam to seam", "rulings butt to butt",
                                                                         "rulings along the least curvature"]
            # read from the owed development's inputs: the developed plate (a copy) has it too
            assert verdict["info"]["strip_max_deviation"] > 4.0
            developed = develop(pickle.loads(pickle.dumps(result)), config)
            assert not developed.shop_work.develops and result.shop_work.develops
            again = formed_verdict(developed)  # read from its owed shop data now
            assert developed.figures["plate_class"]["strip_max_deviation"] == again["info"]["strip_max_deviation"]
            assert again["info"] == verdict["info"]
    formed = next(p for p in parts if kinds[p.name] == "formed")
    assert formed_verdict(run_plate(formed, config)) is None  # run in full: its shop data are done
    formed.hull.held = {"reason": "test: developed on the hull"}
    held = evaluate_plate(formed, config)
    assert held.figures["plate_class"]["class"] == "formed" and formed_verdict(held) is None
    formed.hull.held = None
    with PlateEvaluator(evaluate_plate, 2) as pool:
        pooled = pool.many(parts, config)
        # the owed developments done by the workers, as here (a fit-up reads them)
        sent = [pickle.loads(pickle.dumps(r)) for r in pooled]
        in_pool = pool.develop(sent, config)
        assert pool._pool is not None  # the workers developed them (two owed: not in turn here)
    owed = [r.name for r in pooled if r.shop_work is not None and r.shop_work.develops]
    assert sorted(owed) == sorted(n for n, k in kinds.items() if k == "formed")
    for given, result in zip(sent, in_pool):
        here = develop(pickle.loads(pickle.dumps(lean[result.name])), config)
        assert result.part is given.part  # handed back with the part it was given
        assert not result.shop_work.develops and result.figures["plate_class"] == here.figures["plate_class"]
        if result.name in owed:
            assert np.array_equal(result.pattern.vertices, here.pattern.vertices)
            assert result.figures["strain"] == here.figures["strain"]
    for result in pooled:
        verdict, here = formed_verdict(result), formed_verdict(lean[result.name])
        assert (verdict is None) == (here is None)
        if verdict is not None:
            assert verdict["info"] == here["info"]
            assert np.array_equal(verdict["roll_strip"].vertices, here["roll_strip"].vertices)


def test_a_fit_up_measured_on_two_workers_is_the_one_measured_here(tmp_path, monkeypatch):
    # the shoulder's shell measured by the evaluator's workers (every batch of new pairs
    # sent to them, as a shell's first measurement is) gives the fit-up of one process
    from pipeline.hull import fitup
    from pipeline.runner import PlateEvaluator, plate_evaluator

    path = shoulder(tmp_path, fit_tolerance=4.0, fit_up="follow")
    alone = load_run(path, evaluate_plate)
    monkeypatch.setattr(fitup, "SPREAD_MIN", 2)
    monkeypatch.setattr(fitup, "SPREAD_BATCH", 1)
    mapped, real = [], PlateEvaluator.map
    monkeypatch.setattr(PlateEvaluator, "map", lambda self, func, items: mapped.append((func, self.running))
                        or real(self, func, items))
    with plate_evaluator(2) as two:
        pooled = load_run(path, two)
    assert (fitup._measured_batch, True) in mapped  # measured by the running workers
    assert pooled.fitup_follow.as_dict() == alone.fitup_follow.as_dict()
    for a, b in zip(pooled.parts, alone.parts):
        ra, rb = run_part(a, pooled), run_part(b, alone)
        for result in (ra, rb):
            result.figures.pop("fitup_edges")  # the fit-up report's (objects, not figures)
        assert _figures(ra) == _figures(rb), a.name


def test_a_fit_up_on_two_workers_develops_the_plates_as_one_process_does(tmp_path):
    # the shoulder at 4 mm under follow: its two formed plates owe their developments after
    # their lean evaluation; the fit-up reads them, so load_run has them developed first, by
    # the evaluator's workers (two of them) or in turn here: the plates the run writes agree
    from pipeline.runner import plate_evaluator

    path = shoulder(tmp_path, fit_tolerance=4.0, fit_up="follow")
    with plate_evaluator(2) as two:
        pooled = load_run(path, two)
    assert two.mapped_cpu_seconds > 0  # the developments were the workers' (no plan maps here)
    alone = load_run(path, evaluate_plate)
    assert pooled.fitup_follow.as_dict() == alone.fitup_follow.as_dict()
    assert sorted(pooled.fitup_follow.moved) == ["fit_S1_B2", "fit_S2_B2"]  # the formed plates, developed
    for a, b in zip(pooled.parts, alone.parts):
        ra, rb = run_part(a, pooled), run_part(b, alone)
        for result in (ra, rb):
            result.figures.pop("fitup_edges")  # the fit-up report's (objects, not figures)
        assert ra.ok and _figures(ra) == _figures(rb), a.name
