"""Issue 11 (solver parts): the tracer finishes on repeated knots, and the solution does
not depend on where the part is."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from flatten import normalized_residual, nurbs_curve, rulings_on_path, solve
from tests import oracles


def curve_with_repeated_knot(rng, name, shift, multiplicity):
    n = int(rng.integers(4 + multiplicity, 9))
    inner = np.sort(rng.uniform(0.1, 0.9, n - 4))
    k = int(rng.integers(0, len(inner) - multiplicity + 1))
    inner[k:k + multiplicity] = inner[k]  # a knot of the given multiplicity
    knots = np.concatenate([[0] * 4, np.sort(inner), [1] * 4])
    return nurbs_curve(rng.uniform(-1, 1, size=(n, 3)) + shift, 3, knots=knots, name=name)


@settings(max_examples=6, derandomize=True, deadline=None)
@given(seed=st.integers(0, 100_000), multiplicity=st.sampled_from([2, 3]))
def test_random_cubics_with_repeated_knots_finish_and_every_branch_is_followed(seed, multiplicity):
    # a double knot makes f only C0 across the knot line (Z has corners there); the
    # corrector used to stall on them until a 200000-step cap (minutes per pair)
    rng = np.random.default_rng(seed)
    c = curve_with_repeated_knot(rng, "c", 0.0, multiplicity)
    d = curve_with_repeated_knot(rng, "d", [0.0, 0.0, 2.0], 2)
    solution = solve(c, d)
    codes = {f.code for f in solution.findings}
    assert not {"BRANCH_UNRESOLVED", "UNTRACED_SEEDS", "RESIDUAL_EXCEEDED"} & codes
    points = np.vstack([b.points for b in solution.branches])
    assert normalized_residual(solution.field.c, solution.field.d, *points.T).max() <= 1e-12
    # the bound that makes it finish: no trace stalls (a stalled corrector used to take
    # 200000 steps of zero length); every branch is a few hundred steps per unit length
    assert sum(len(b.points) for b in solution.branches) < 20 * 1000


def moved(curve, shift, scale=1000.0):
    return nurbs_curve(curve.control_points * scale + [shift, 0.0, 0.0], curve.degree,
                       weights=curve.weights, knots=curve.knots, name=curve.name)


@pytest.mark.parametrize("pair", ["frustum", "s_and_c", "cylinder"])
@pytest.mark.parametrize("shift", [1e7, 1e8])
def test_a_plate_far_from_the_origin_solves_like_at_the_origin(pair, shift):
    c, d = {"frustum": oracles.frustum_pair, "s_and_c": oracles.s_and_c_curves,
            "cylinder": oracles.cylinder_pair}[pair]()
    near = solve(moved(c, 0.0), moved(d, 0.0))
    far = solve(moved(c, shift), moved(d, shift))
    assert far.kind == near.kind and bool(far) == bool(near)
    assert far.path.coverage.c_fraction == pytest.approx(near.path.coverage.c_fraction, abs=1e-9)
    assert far.path.coverage.c_length == pytest.approx(near.path.coverage.c_length, rel=1e-9)
    t = np.linspace(*near.path.points[[0, -1], 0], 101)
    np.testing.assert_allclose(rulings_on_path(far, t), rulings_on_path(near, t), atol=1e-9)
    # 3D outputs are in the model's frame
    for tp_far, tp_near in zip(far.turning_points, near.turning_points):
        np.testing.assert_allclose(tp_far.point_c - [shift, 0, 0], tp_near.point_c, atol=1e-6)
    assert far.max_residual <= 1e-12


def test_pointed_plate_gives_no_nan():
    # c and d share their first point: the ruling there has zero length
    x = np.linspace(0.0, 1.0, 5)
    c = nurbs_curve(np.column_stack([3 * x, 0.3 * np.sin(3 * x), 0 * x]), 3, name="c")
    d = nurbs_curve(np.column_stack([3 * x, 0.3 * np.sin(3 * x) + x, 0.5 * x]), 3, name="d")
    solution = solve(c, d)
    assert solution, solution.message
    assert "nan" not in solution.message.lower()
    assert np.isfinite(solution.max_residual)
    for f in solution.findings:
        assert "nan" not in f.message.lower()
    assert solution.path.coverage.c_fraction == pytest.approx(1.0)
    assert not [f for f in solution.findings if f.code == "ISOLATED_POINT"]


# ------------------------------------------------------------ issue 13 (solver parts)
def test_nearly_coplanar_curves_give_no_spurious_fans():
    # d's plane turned 1e-9 rad against c's: f is 1e-9 of its natural scale, and a
    # line test relative to that scale took whole grid lines for fans
    c, d = oracles.planar_cubics_on_parallel_planes()
    poles = d.control_points.copy()
    poles[:, 2] = 1e-9 * poles[:, 1]
    d = nurbs_curve(poles, 3, knots=d.knots, name="d")
    solution = solve(c, d)
    assert solution and solution.kind == "general"
    assert [b.kind for b in solution.branches] == ["graph"]
    assert not {"BRANCH_UNRESOLVED", "RESIDUAL_EXCEEDED"} & {f.code for f in solution.findings}
    assert solution.max_residual <= 1e-12


def test_planes_parallel_only_to_the_planarity_tolerance_are_solved_in_full():
    c, d = oracles.planar_cubics_on_parallel_planes()
    poles = d.control_points.copy()
    poles[:, 2] += 1e-10 * poles[:, 0]  # parallel to 1e-10: the reduced equation misses 1e-12
    solution = solve(c, nurbs_curve(poles, 3, knots=d.knots, name="d"))
    assert solution.kind == "general" and solution.max_residual <= 1e-12
    assert "RESIDUAL_EXCEEDED" not in {f.code for f in solution.findings}


def test_zero_speed_ends_keep_the_cone():
    # a doubled first pole on both curves (zero speed at t = 0): still a cone, T = t
    import warnings
    c, d = oracles.cone_pair()
    knots = np.concatenate([[0, 0, 0, 0], np.linspace(0, 1, 7)[1:-1], [1, 1, 1, 1]])
    c2, d2 = (nurbs_curve(np.vstack([k.control_points[:1], k.control_points]), 3, knots=knots, name=k.name)
              for k in (c, d))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        solution = solve(c2, d2)
    assert solution, solution.message
    np.testing.assert_allclose(solution.path.points[:, 1], solution.path.points[:, 0], atol=1e-9)
    assert solution.path.coverage.c_fraction == pytest.approx(1.0)
    assert solution.max_residual <= 1e-12
    assert "RESIDUAL_EXCEEDED" not in {f.code for f in solution.findings}


def test_a_trace_stops_at_its_step_limit_with_a_finding():
    from flatten import Tolerances
    solution = solve(*oracles.cone_pair(), Tolerances(trace_max_steps=30))
    limited = [f for f in solution.findings if f.code == "BRANCH_UNRESOLVED" and "step limit" in f.message]
    assert limited
    # steps (each filled in to at most MAX_STEP_FACTOR points a trace step apart) + grid crossings
    from flatten.tracer import MAX_STEP_FACTOR
    assert all(len(b.points) <= 2 * 30 * MAX_STEP_FACTOR + 200 for b in solution.branches)


def test_seed_matching_is_linear_in_memory_and_agrees_with_all_pairs():
    from flatten.tracer import _distance_to_polyline, near_polyline
    rng = np.random.default_rng(0)
    points = rng.uniform(0, 1, (3000, 2))
    for n in (1, 2, 500):
        poly = np.cumsum(rng.normal(0, 0.01, (n, 2)), axis=0) + 0.5
        for tol in (1e-6, 1e-3, 0.02):
            np.testing.assert_array_equal(near_polyline(points, poly, tol),
                                          _distance_to_polyline(points, poly) <= tol)


# ------------------------------------------------- issue 15: the judge's memory bound
def full_overlap_table(a, b, slack=1e-12):
    """Every (k, l) whose segment boxes overlap, from the K x L table (the reference)."""
    lo_a, hi_a = np.minimum(a[:-1], a[1:]), np.maximum(a[:-1], a[1:])
    lo_b, hi_b = np.minimum(b[:-1], b[1:]), np.maximum(b[:-1], b[1:])
    near = ((lo_a[:, None, 0] <= hi_b[None, :, 0] + slack) & (lo_b[None, :, 0] <= hi_a[:, None, 0] + slack)
            & (lo_a[:, None, 1] <= hi_b[None, :, 1] + slack) & (lo_b[None, :, 1] <= hi_a[:, None, 1] + slack))
    return np.nonzero(near)


@settings(max_examples=30, derandomize=True, deadline=None)
@given(seed=st.integers(0, 10_000), n_a=st.integers(2, 400), n_b=st.integers(2, 400),
       jumps=st.integers(0, 5), same=st.booleans())
def test_crossing_candidates_are_those_of_the_full_table(seed, n_a, n_b, jumps, same):
    from flatten.judge import _overlapping_boxes
    rng = np.random.default_rng(seed)
    walks = []
    for n in (n_a, n_b):
        steps = rng.normal(0.0, 0.01, (n, 2))
        steps[rng.integers(0, n, jumps)] *= 30.0  # a few long segments (the large boxes)
        walks.append(0.5 + np.cumsum(steps, axis=0))
    a, b = (walks[0], walks[0]) if same else walks
    got = _overlapping_boxes(np.minimum(a[:-1], a[1:]), np.maximum(a[:-1], a[1:]),
                             np.minimum(b[:-1], b[1:]), np.maximum(b[:-1], b[1:]), 1e-12)
    want = full_overlap_table(a, b)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])


def piled_circle(n_points=40001, turns=30, centre=(0.5, 0.5), radius=0.05):
    """A polyline going round one circle ``turns`` times: a trace that missed its own
    start and circled until its step limit (2 x 20000 steps)."""
    angle = np.linspace(0.0, 2.0 * np.pi * turns, n_points)
    return np.column_stack([centre[0] + radius * np.cos(angle), centre[1] + radius * np.sin(angle)])


def test_crossings_of_a_piled_up_trace_stay_within_a_memory_budget():
    # the K x K table of a 40001-point trace is 1.6e9 cells (a MemoryError before)
    import tracemalloc
    from flatten.judge import CrossingOverflow, _segment_intersections
    points = piled_circle()
    tracemalloc.start()
    try:
        with pytest.raises(CrossingOverflow) as raised:
            _segment_intersections(points, points, True)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert raised.value.pairs > raised.value.budget
    assert peak < 50 * 2**20


def test_a_branch_circling_until_its_step_limit_is_a_finding(monkeypatch):
    # the tracer's loop closing missed (a random rational pair, degree 2, did it): the
    # solve must end with the branch flagged, not with a MemoryError in the judge
    import flatten.solver as solver
    from flatten.tracer import END_STEP_LIMIT, Trace
    from tests import families

    real = solver.trace_zero_set

    def circling(field, tol, *args, **kwargs):
        traces, seeds, visited = real(field, tol, *args, **kwargs)
        out = []
        for trace in traces:
            if trace.closed:  # go round the traced loop 30 times, 40001 points
                p = trace.points
                arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
                where = np.linspace(0.0, 30.0, 40001) % 1.0 * arc[-1]
                trace = Trace(np.column_stack([np.interp(where, arc, p[:, 0]), np.interp(where, arc, p[:, 1])]),
                              False, (END_STEP_LIMIT, END_STEP_LIMIT))
            out.append(trace)
        return out, seeds, visited

    monkeypatch.setattr(solver, "trace_zero_set", circling)
    solution = solve(*families.loop_pair(1e-2, tilt=0.02))
    found = {f.code: f for f in solution.findings}
    assert "BRANCH_UNRESOLVED" in found and "CROSSINGS_UNCHECKED" in found
    unchecked = found["CROSSINGS_UNCHECKED"]
    assert unchecked.data["branches"] == [0] and unchecked.data["candidate_pairs"] > unchecked.data["budget"]
    assert "40001 points" in unchecked.message and "not searched" in unchecked.message
    assert [len(b.points) for b in solution.branches] == [40001]


def doubled_end_poles(curve, ends):
    """The curve with its first and/or last pole doubled (zero speed there), uniform knots."""
    poles = curve.control_points
    poles = np.vstack([poles[:1]] * ("start" in ends) + [poles] + [poles[-1:]] * ("end" in ends))
    inner = np.linspace(0.0, 1.0, len(poles) - 2)[1:-1]
    return nurbs_curve(poles, 3, knots=np.concatenate([[0.0] * 4, inner, [1.0] * 4]), name=curve.name)


@pytest.mark.parametrize("ends", [("start",), ("end",), ("start", "end")])
def test_seams_standing_still_at_their_ends_give_no_fan(ends):
    # a doubled end pole: c' = 0 there, so f = det[C, C', D, D'] vanished on the whole
    # side line, which came out as fans from the end point over all of the other curve;
    # the path chooser took two of them (a crease, 100 % coverage) for the real strip.
    # The cone d = apex + 0.45 (c - apex) with the same poles doubled is still T = t.
    c, d = (doubled_end_poles(k, ends) for k in oracles.cone_pair())
    solution = solve(c, d)
    assert solution, solution.message
    assert not [b.kind for b in solution.branches if b.kind.startswith("fan")]
    assert solution.path.fans == ()
    np.testing.assert_allclose(solution.path.points[:, 1], solution.path.points[:, 0], atol=1e-9)
    assert solution.path.coverage.c_fraction == pytest.approx(1.0)
    assert solution.path.coverage.d_fraction == pytest.approx(1.0)
    assert "RESIDUAL_EXCEEDED" not in {f.code for f in solution.findings}


@pytest.mark.parametrize("which", ["c", "d", "cd"])
@pytest.mark.parametrize("ends", [("start",), ("end",)])
def test_a_plate_seam_with_a_doubled_end_pole_keeps_its_strip(which, ends):
    # the bench's plate (one graph branch): a doubled end pole on a seam only slows the
    # seam down at its end; the strip stays one graph branch, with no fan and no finding
    x = np.linspace(0.0, 12.0, 8)
    c = nurbs_curve(np.column_stack([x, 0.4 * np.sin(x / 4), 0.05 * x]), 3, name="c")
    d = nurbs_curve(np.column_stack([x * 1.02, 2.2 + 0.6 * np.sin(x / 4 + 0.2), 1.5 + 0.08 * x]), 3, name="d")
    c = doubled_end_poles(c, ends) if "c" in which else c
    d = doubled_end_poles(d, ends) if "d" in which else d
    solution = solve(c, d)
    assert solution, solution.message
    assert [b.kind for b in solution.branches] == ["graph"]
    assert solution.path.fans == ()
    assert {f.code for f in solution.findings} <= {"PARTIAL_COVERAGE", "CERTIFICATE"}
    assert solution.max_residual <= 1e-12


def random_rational_quadratics(seed):
    """Degree-2 rational pairs, 8 poles each, drawn like tests/test_solver.py's random pairs."""
    rng = np.random.default_rng(seed)
    c = nurbs_curve(rng.uniform(-1, 1, size=(8, 3)), 2, weights=rng.uniform(0.5, 2.0, 8), name="c")
    d = nurbs_curve(rng.uniform(-1, 1, size=(8, 3)) + [0, 0, 2.0], 2, weights=rng.uniform(0.5, 2.0, 8), name="d")
    return c, d


@pytest.mark.parametrize("seed", [252, 300])
def test_a_loop_smaller_than_a_step_round_a_crossing_of_knot_lines_closes(seed):
    # every interior knot of a quadratic is C1, so f is only C0 on every knot line and the
    # tracer crosses those lines from root to root; a loop smaller than a trace step round
    # a crossing of two knot lines was followed from root to root for 2 x 20000 steps
    # (4 distinct points, then a MemoryError in the judge's crossing table, or minutes)
    c, d = random_rational_quadratics(seed)
    solution = solve(c, d)
    codes = {f.code for f in solution.findings}
    assert not {"BRANCH_UNRESOLVED", "CROSSINGS_UNCHECKED", "RESIDUAL_EXCEEDED", "UNTRACED_REGION"} & codes
    loops = [b for b in solution.branches if b.closed]
    assert len(loops) == 1 and len(loops[0].points) < 10
    # round a crossing of a knot of c and a knot of d, and on the zero set
    lo, hi = loops[0].points.min(axis=0), loops[0].points.max(axis=0)
    assert any(lo[0] < k < hi[0] for k in c.breakpoints) and any(lo[1] < k < hi[1] for k in d.breakpoints)
    assert normalized_residual(c, d, *loops[0].points.T).max() <= 1e-12
    assert sum(len(b.points) for b in solution.branches) < 5000


def _noisy_line(start, end, noise: float, rng, name: str):
    """A straight line as a cubic B-spline of 13 spans with an uneven speed along it, its inner
    poles off the plane z = 0 by up to ``noise`` (mm): a CAD loft's section across a flat."""
    knots = np.concatenate([[0.0] * 3, np.linspace(0.0, 1.0, 14), [1.0] * 3])
    speed = np.sort(rng.uniform(0.0, 1.0, 14))
    speed = (speed - speed[0]) / (speed[-1] - speed[0])
    greville = np.array([knots[i + 1:i + 4].mean() for i in range(16)])
    poles = np.asarray(start, float) + np.interp(greville, np.linspace(0.0, 1.0, 14), speed)[:, None] \
        * (np.asarray(end, float) - np.asarray(start, float))
    poles[1:-1, 2] += noise * rng.uniform(-1.0, 1.0, 14)
    return nurbs_curve(poles, 3, knots=knots, name=name)


@pytest.mark.parametrize("seed", range(3))
def test_two_lines_flat_to_a_cad_models_precision_are_the_flat_plate_between_them(seed):
    """KVLCC2's loft sections across its flat bottom: two straight lines 15.6 m apart, 1.3 and
    2.0 m long, 13 spans each, off their plane by up to 1.6e-6 mm (1e-10 of their size, over
    the planarity tolerance). They bound the planar region between them: the flat plate's
    rulings from end to end, with the general solve's verdict as the evidence (f is the noise,
    and its branches covered 6 to 20 % of each curve)."""
    rng = np.random.default_rng(seed)
    c = _noisy_line([0.0, 0.0, 0.0], [0.0, 1323.0, 0.0], 1.6e-6, rng, "c")
    d = _noisy_line([15600.0, 2478.0, 0.0], [15600.0, 4465.0, 0.0], 1.6e-6, rng, "d")
    solution = solve(c, d)
    assert solution.kind == "coplanar" and solution, solution.message
    found = {f.code: f for f in solution.findings}
    assert {"FLAT_PLATE", "NEARLY_COPLANAR"} <= set(found)
    assert 1e-10 < found["NEARLY_COPLANAR"].data["relative"] < 1e-9
    assert found["NEARLY_COPLANAR"].data["general_kind"] in ("general", "parallel_planes")
    assert "% of c" in found["NEARLY_COPLANAR"].message
    np.testing.assert_allclose(solution.path.points[[0, -1]], np.transpose([c.domain, d.domain]), atol=1e-12)
    # the same lines 1 mm apart across the plane at one end: a twist, solved in general
    twisted = _noisy_line([15600.0, 2478.0, 0.0], [15600.0, 4465.0, 1.0], 0.0, rng, "d")
    assert solve(c, twisted).kind != "coplanar"
