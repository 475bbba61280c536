"""The exact development against the closed-form frustum sector at any ruling density, and
the triangle-unfolding cross-check's O(h^2) drift."""

import numpy as np
import pytest

from flatten import solve
from flatten.develop import develop, unfold_triangles
from flatten.strip import build_strip, choose_rulings
from tests import oracles

R1, R2, H, ANGLE = 3.0, 2.0, 1.5, 2 * np.pi / 3


def sector_errors(c, d, n):
    solution = solve(c, d)
    rulings = choose_rulings(solution, c, d, n_rulings=n)
    dev = develop(c, d, rulings, solution.field)
    s = np.hypot(R1 - R2, H)
    rho1, rho2 = R1 * s / (R1 - R2), R2 * s / (R1 - R2)
    a, b = dev.along_c, dev.along_d
    apex = (a + (b - a) * (rho1 / (rho1 - rho2))).mean(axis=0)
    radius_error = max(np.abs(np.hypot(*(a - apex).T) - rho1).max() / rho1,
                       np.abs(np.hypot(*(b - apex).T) - rho2).max() / rho2)
    # developed polar angle = 3D polar angle x |r1 - r2| / s
    polar3d = np.arctan2(*c(rulings[:, 0])[:, [1, 0]].T)
    polar2d = np.unwrap(np.arctan2(*(a - apex)[:, [1, 0]].T))
    angle_error = np.abs((polar2d - polar2d[0]) - polar3d * (R1 - R2) / s).max()
    return radius_error, angle_error, rulings, dev


@pytest.mark.parametrize("n", [2, 10, 200, 3000])
def test_frustum_development_is_exact_whatever_the_ruling_density(n):
    c, d = oracles.frustum_pair(R1, R2, H, ANGLE)
    radius_error, angle_error, _, _ = sector_errors(c, d, n)
    assert radius_error <= 1e-12
    assert angle_error <= 1e-12


def test_multispan_frustum_development_is_exact():
    c, d = oracles.frustum_pair(R1, R2, H, 3 * np.pi / 2, n_spans=3)
    s = np.hypot(R1 - R2, H)
    radius_error, _, rulings, dev = sector_errors(c, d, 25)
    assert radius_error <= 1e-12
    a = dev.along_c
    apex = (a + (dev.along_d - a) * (R1 / (R1 - R2))).mean(axis=0)
    ends = a[[0, -1]] - apex
    cross = ends[0, 0] * ends[1, 1] - ends[0, 1] * ends[1, 0]
    swept = np.arctan2(cross, ends[0] @ ends[1]) % (2 * np.pi)
    assert swept == pytest.approx(3 * np.pi / 2 * (R1 - R2) / s, rel=1e-12)


def test_triangle_unfolding_drifts_quadratically():
    c, d = oracles.frustum_pair(R1, R2, H, ANGLE)
    drifts = []
    for n in (50, 100, 200):
        solution = solve(c, d)
        rulings = choose_rulings(solution, c, d, n_rulings=n)
        strip = build_strip(c, d, rulings, 3)
        dev = develop(c, d, rulings, solution.field)
        unf = unfold_triangles(strip.vertices[0::3], strip.vertices[2::3], dev)
        drifts.append(np.abs(unf.along_c - dev.along_c).max())
    assert drifts[0] / drifts[1] == pytest.approx(4.0, rel=0.15)
    assert drifts[1] / drifts[2] == pytest.approx(4.0, rel=0.15)


def test_triangle_unfolding_keeps_every_edge_length_and_the_side_of_each_triangle():
    """Each outer triangle (A_k, B_k, A_k+1), (A_k+1, B_k, B_k+1) is laid flat with its 3D
    edge lengths, A_k+1 and B_k+1 to the right of the ruling they are placed from, and a
    zero step (two rulings through one end) stays put."""
    from flatten.develop import Development

    rng = np.random.default_rng(15)
    n = 40
    t = np.cumsum(rng.random(n))
    a3 = np.column_stack([t, np.sin(t), 0.1 * t**2]) * 1000.0 + 5e4
    b3 = a3 + np.column_stack([rng.normal(size=n), np.full(n, 300.0), rng.normal(size=n) + 50.0])
    a3[7:9] = a3[7]  # a fan at A_7
    first = Development(np.array([[3.0, -2.0]]), np.array([[3.0 + 301.0, -2.0]]))
    unf = unfold_triangles(a3, b3, first)
    a2, b2 = unf.along_c, unf.along_d
    for x2, y2, x3, y3 in ((a2[1:], a2[:-1], a3[1:], a3[:-1]), (b2[1:], b2[:-1], b3[1:], b3[:-1]),
                           (a2[1:], b2[:-1], a3[1:], b3[:-1]), (a2[1:], b2[1:], a3[1:], b3[1:])):
        np.testing.assert_allclose(np.linalg.norm(x2 - y2, axis=1), np.linalg.norm(x3 - y3, axis=1),
                                   rtol=1e-12, atol=1e-9)
    assert np.array_equal(a2[8], a2[7])

    def right_of(p, q, x):  # x to the right of p -> q (or on it)
        return (q[:, 0] - p[:, 0]) * (x[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (x[:, 0] - p[:, 0]) <= 1e-6

    assert right_of(a2[:-1], b2[:-1], a2[1:]).all()
    assert right_of(a2[1:], b2[:-1], b2[1:]).all()


@pytest.mark.parametrize("n_new", [1, 7, 2001])
def test_further_rulings_developed_from_the_strip_match_one_development_of_them_all(n_new):
    """DevelopedStrip.ends (further rulings integrated from the nearest break or ruling)
    against develop() of the base and the further rulings together, and against the
    closed-form frustum sector (rulings in any order, a repeat and the path's ends)."""
    from flatten.develop import DevelopedStrip
    from flatten.strip import sample_path

    c, d = oracles.frustum_pair(R1, R2, H, ANGLE, n_spans=3)
    solution = solve(c, d)
    ends_of_path = sample_path(solution, np.array([0.0, 1.0]))
    base = np.vstack([ends_of_path[:1], choose_rulings(solution, c, d, n_rulings=30), ends_of_path[1:]])
    lam = np.random.default_rng(5).random(n_new)
    new = sample_path(solution, np.concatenate([lam, lam[:1], [0.0, 1.0]]))
    strip = DevelopedStrip(c, d, base, solution.field)
    got = strip.ends(new)
    # one development of them all, anchored at the same first ruling (the path's start)
    merged = np.vstack([base, new])
    order = np.lexsort((merged[:, 1] * solution.path.orientation, merged[:, 0]))
    dev = develop(c, d, merged[order], solution.field)
    position = np.empty(len(merged), dtype=int)
    position[order] = np.arange(len(merged))
    mine = position[len(base):]
    assert np.abs(got.along_c - dev.along_c[mine]).max() <= 1e-12
    assert np.abs(got.along_d - dev.along_d[mine]).max() <= 1e-12
    # the closed form: ends on circles about one apex with the sector's radii
    s = np.hypot(R1 - R2, H)
    rho1, rho2 = R1 * s / (R1 - R2), R2 * s / (R1 - R2)
    a, b = got.along_c, got.along_d
    apex = (a + (b - a) * (rho1 / (rho1 - rho2))).mean(axis=0)
    assert np.abs(np.hypot(*(a - apex).T) - rho1).max() <= 1e-12 * rho1
    assert np.abs(np.hypot(*(b - apex).T) - rho2).max() <= 1e-12 * rho2
    with pytest.raises(ValueError, match="beyond the developed strip"):
        DevelopedStrip(c, d, base[2:-2], solution.field).ends(new)  # the path's ends lie outside
