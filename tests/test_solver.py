"""The solver against closed-form answers (DESIGN §1.6) and property tests."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from flatten import InvalidInputError, normalized_residual, nurbs_curve, rulings_on_path, solve
from flatten.equation import COPLANAR, PARALLEL_PLANES
from tests import oracles


def unit(solution, points):
    c, d = solution.field.c, solution.field.d
    lo = np.array([c.domain[0], d.domain[0]])
    return (points - lo) / np.array([np.ptp(c.domain), np.ptp(d.domain)])


def distance_to_branches(solution, points):
    """Unit-square distance of (N, 2) parameter points to the nearest traced branch."""
    from flatten.tracer import _distance_to_polyline
    pts = unit(solution, points)
    return np.min([_distance_to_polyline(pts, unit(solution, b.points)) for b in solution.branches], axis=0)


def assert_identity_path(solution):
    assert solution, solution.message
    path = solution.path
    np.testing.assert_allclose(path.points[:, 1], path.points[:, 0], atol=1e-9)
    assert path.coverage.c_fraction == pytest.approx(1.0, abs=1e-9)
    assert path.coverage.d_fraction == pytest.approx(1.0, abs=1e-9)
    assert solution.max_residual <= 1e-12


def test_cylinder_on_multispan_cubics_gives_identity():
    c, d = oracles.cylinder_pair()
    assert c.n_spans == 5
    solution = solve(c, d)
    assert_identity_path(solution)
    t = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(rulings_on_path(solution, t), t, atol=1e-12)


def test_cone_on_multispan_cubics_gives_identity():
    solution = solve(*oracles.cone_pair())
    assert_identity_path(solution)


@pytest.mark.parametrize("n_spans, angle", [(1, 2 * np.pi / 3), (3, 3 * np.pi / 2)])
def test_rational_arc_frustum_gives_identity(n_spans, angle):
    c, d = oracles.frustum_pair(angle=angle, n_spans=n_spans)
    solution = solve(c, d)
    assert solution.kind == "general" and solution.degree_in_T == 2
    assert_identity_path(solution)
    # every ruling of the frustum meets the axis at the apex height r1 h / (r1 - r2)
    pts = solution.path.points
    rulings = d(pts[:, 1]) - c(pts[:, 0])
    apex_param = -c(pts[:, 0])[:, 0] / rulings[:, 0]
    np.testing.assert_allclose(apex_param * rulings[:, 2], 3.0 * 1.5 / (3.0 - 2.0), rtol=1e-9)


def test_planar_cubics_on_parallel_planes_match_parallel_tangents():
    c, d = oracles.planar_cubics_on_parallel_planes()
    solution = solve(c, d)
    assert solution.kind == PARALLEL_PLANES
    assert solution.degree_in_T == d.degree - 1
    assert any(f.code == "PARALLEL_PLANES" for f in solution.findings)
    assert solution, solution.message
    for branch in solution.branches:
        tc = c.derivatives(branch.points[:, 0], 1)[1]
        td = d.derivatives(branch.points[:, 1], 1)[1]
        cross_z = np.cross(tc, td)[:, 2] / (np.linalg.norm(tc, axis=1) * np.linalg.norm(td, axis=1))
        assert np.abs(cross_z).max() <= 1e-12


def test_c_against_its_mirror_has_no_acceptable_path():
    solution = solve(*oracles.c_and_mirror())
    assert not solution
    assert solution.path is None
    assert "no acceptable strip" in solution.message
    assert len(solution.branches) >= 1
    assert all(not p.acceptable for p in solution.pieces)
    codes = [f.code for f in solution.findings]
    assert "NO_ACCEPTABLE_BRANCH" in codes
    # evidence: Theorem 2 fails along the whole branch, located in parameters and in 3D
    assert solution.mismatches
    m = solution.mismatches[0]
    assert m.t_range[1] - m.t_range[0] > 0.99 and m.points_c.shape == (2, 3)


def test_s_against_c_is_partial_with_regression_at_the_inflection():
    s_curve, c_curve = oracles.s_and_c_curves()
    solution = solve(s_curve, c_curve)
    assert solution
    cov = solution.path.coverage
    assert 0.1 < cov.c_fraction < 0.9 and 0.1 < cov.d_fraction < 0.9
    assert any(f.code == "PARTIAL_COVERAGE" for f in solution.findings)
    assert any(not p.acceptable for p in solution.pieces)
    # the S inflects at t = 1/2 (c'' = 0 there): the turning point sits exactly there
    assert len(solution.turning_points) == 1
    tp = solution.turning_points[0]
    assert tp.t == pytest.approx(0.5, abs=1e-9)
    np.testing.assert_allclose(s_curve.derivatives([tp.t], 2)[2], 0.0, atol=1e-9)
    # and the regression side is the one Theorem 2 flags
    for m in solution.mismatches:
        assert m.t_range[1] <= 0.5 + 1e-6
    assert cov.t_interval[0] == pytest.approx(0.5, abs=1e-9)


def test_skew_lines_give_fans_only():
    solution = solve(*oracles.skew_lines())
    assert not solution
    assert solution.branches == ()
    assert "only fans" in solution.message
    finding = next(f for f in solution.findings if f.code == "NO_SOLUTION_CURVE")
    assert finding.data["f_min"] * finding.data["f_max"] > 0  # f keeps one sign: no zero at all


def test_vertical_fan_is_traced_as_a_branch():
    # c in the plane y = 0 with a z-maximum at t = 1/2; d a line along x in y = 1:
    # the tangent of c at its top is parallel to d, so t = 1/2 is a fan with apex c(1/2)
    c = nurbs_curve([[0, 0, 0], [1, 0, 2], [2, 0, 2], [3, 0, 0]], 3, name="c")
    d = nurbs_curve([[-1, 1, 0.5], [4, 1, 0.5]], 1, name="d")
    solution = solve(c, d)
    fans = [b for b in solution.branches if b.kind == "fan_c"]
    assert len(fans) == 1
    np.testing.assert_allclose(fans[0].points[:, 0], 0.5, atol=1e-12)
    assert np.ptp(fans[0].points[:, 1]) == pytest.approx(1.0)
    assert solution.path.fans and solution.path.fans[0]["apex_on"] == "c"
    assert solution.path.coverage.d_fraction == pytest.approx(1.0)


def test_coplanar_curves_are_a_flat_plate():
    c = nurbs_curve([[0, 0, 0], [1, 0.2, 0], [2, 0, 0], [3, 0.3, 0]], 3, name="c")
    d = nurbs_curve([[0, 2, 0], [1.5, 2.5, 0], [3, 2, 0]], 2, name="d")
    solution = solve(c, d)
    assert solution and solution.kind == COPLANAR
    assert solution.findings[0].code == "FLAT_PLATE"
    assert solution.path.coverage.c_fraction == pytest.approx(1.0)


@pytest.mark.parametrize("reverse", [False, True])
def test_coincident_curves_are_bad_input(reverse):
    c = oracles.multispan_cubic()
    d = c.reversed() if reverse else c
    with pytest.raises(InvalidInputError, match="coincide"):
        solve(c, d)


def test_reversing_d_mirrors_the_solution_set():
    c, d = oracles.cone_pair()
    forward = solve(c, d)
    backward = solve(c, d.reversed())
    lo, hi = d.domain
    assert len(forward.branches) == len(backward.branches)
    mirrored = np.vstack([b.points for b in backward.branches]) * [1, -1] + [0, lo + hi]
    assert distance_to_branches(forward, mirrored).max() <= 1e-3
    assert backward.path.orientation == -forward.path.orientation == -1
    assert backward.path.coverage.c_fraction == pytest.approx(forward.path.coverage.c_fraction, abs=1e-9)
    np.testing.assert_allclose(backward.path.points[:, 1], lo + hi - backward.path.points[:, 0], atol=1e-9)


def test_solution_is_c1_across_knots_of_c2_cubics():
    c, d = oracles.cone_pair()
    d = nurbs_curve(d.control_points + np.array([[0, 0, 0.05 * k * (-1) ** k] for k in range(8)]),
                    3, knots=[0, 0, 0, 0, 0.2, 0.3, 0.55, 0.8, 1, 1, 1, 1], name="d")
    solution = solve(c, d)
    crossings = list(solution.knot_crossings)
    assert len(crossings) >= 4
    assert all(k.expected_class == 1 for k in crossings)
    assert max(k.jump_first for k in crossings) <= 1e-7
    assert max(k.jump_second for k in crossings) > 1e-4  # T'' does jump: C^1, not C^2


def residual_of(solution):
    pts = [b.points for b in solution.branches] + [p.points for p in solution.pieces]
    pts += [np.array([[tp.t, tp.T]]) for tp in solution.turning_points]
    pts = np.vstack(pts)
    c, d = solution.field.c, solution.field.d
    return normalized_residual(c, d, pts[:, 0], pts[:, 1])


def random_pair(seed, rational):
    rng = np.random.default_rng(seed)
    n_c, n_d = rng.integers(4, 8, size=2)
    c = nurbs_curve(rng.uniform(-1, 1, size=(n_c, 3)), 3,
                    weights=rng.uniform(0.5, 2.0, n_c) if rational else None, name="c")
    d = nurbs_curve(rng.uniform(-1, 1, size=(n_d, 3)) + [0, 0, 2.0], 3,
                    weights=rng.uniform(0.5, 2.0, n_d) if rational else None, name="d")
    return c, d


@settings(max_examples=25, derandomize=True, deadline=None)
@given(seed=st.integers(0, 100_000), rational=st.booleans(), lines=st.lists(st.floats(0.001, 0.999), min_size=3, max_size=3))
def test_random_pairs_every_point_polished_and_no_root_missed(seed, rational, lines):
    c, d = random_pair(seed, rational)
    solution = solve(c, d)
    assert not any(f.code in ("UNTRACED_SEEDS", "BRANCH_UNRESOLVED") for f in solution.findings)
    if not solution.branches:
        return
    assert residual_of(solution).max() <= 1e-12
    field = solution.field
    for u in lines:  # lines the tracer never saw
        t = c.domain[0] + u * np.ptp(c.domain)
        _, roots, _ = field.roots_in_T(np.array([t]))
        if len(roots):
            found = distance_to_branches(solution, np.column_stack([np.full(len(roots), t), roots]))
            assert found.max() <= 1e-3, (t, roots, found)
        # and conversely: as many branch crossings of the line as roots on it
        crossings = sum(np.count_nonzero(np.diff(b.points[:, 0] >= t))
                        for b in solution.branches if b.kind != "fan_c")
        assert crossings == len(roots), (t, crossings, roots)
        T = d.domain[0] + u * np.ptp(d.domain)
        _, roots, _ = field.roots_in_t(np.array([T]))
        if len(roots):
            found = distance_to_branches(solution, np.column_stack([roots, np.full(len(roots), T)]))
            assert found.max() <= 1e-3, (T, roots, found)
    # Theorem 2 (curvature signs) agrees with the f-based classification of pieces:
    # a piece is acceptable iff kc kd >= 0 and T' has the path's orientation
    from flatten.judge import curvature_signs
    orientation = solution.path.orientation if solution.path else 1
    for piece in solution.pieces:
        inner = piece.points[1:-1]  # the ends are turning points or junctions
        if len(inner) == 0:
            continue
        kc, kd = curvature_signs(c, d, inner)
        slope = -field(inner[:, 0], inner[:, 1], 1, 0) / field(inner[:, 0], inner[:, 1], 0, 1)
        scale = np.abs(kc).max() * np.abs(kd).max()
        strong = (np.abs(kc * kd) > 1e-6 * scale) & (np.abs(slope) > 1e-6) & (np.abs(slope) < 1e6)
        compatible = (kc * kd > 0) & (orientation * slope > 0)
        if piece.acceptable:
            assert np.all(compatible[strong])
        else:
            assert not np.any(compatible[strong])
