"""The minimax (Chebyshev) plane against closed forms and brute force: points on two parallel
planes, a cylinder cap (the slab from its chord plane to its apex), and small plate-like
point sets whose thinnest slab is found by enumerating every candidate direction (normals of
point triples and of edge pairs: the minimum width of a set is attained at one of them)."""

import itertools

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from flatten.minimax import fits_a_plane, flattest_plane, minimax_plane
from flatten.patchflat import fit_plane


def rotation(seed: int) -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q


def brute_half_width(points: np.ndarray) -> float:
    """Half the least width over the normals of all triples and of all pairs of segments."""
    dirs = []
    for i, j, k in itertools.combinations(range(len(points)), 3):
        dirs.append(np.cross(points[j] - points[i], points[k] - points[i]))
    segments = [points[j] - points[i] for i, j in itertools.combinations(range(len(points)), 2)]
    for a, b in itertools.combinations(segments, 2):
        dirs.append(np.cross(a, b))
    d = np.array(dirs)
    n = np.linalg.norm(d, axis=1)
    d = d[n > 1e-9 * n.max()] / n[n > 1e-9 * n.max(), None]
    return float(np.ptp(points @ d.T, axis=0).min()) / 2


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_points_on_two_parallel_planes_give_their_mid_plane(seed):
    rng = np.random.default_rng(seed)
    h = 7.0
    local = np.column_stack([rng.uniform(-5000, 5000, 300), rng.uniform(-1500, 1500, 300),
                             np.where(np.arange(300) % 3 == 0, h, 0.0)])
    rot = rotation(seed)
    pts = local @ rot.T + np.array([1e5, -3e3, 2e3])
    fit = minimax_plane(pts)
    assert fit.max_distance == pytest.approx(h / 2, rel=1e-9)
    assert abs(fit.normal @ rot[:, 2]) == pytest.approx(1.0, abs=1e-12)
    assert fit.proven and fit.lower_bound == pytest.approx(h / 2, rel=1e-9)
    # the plane's point lies midway: every point is at +-h/2
    np.testing.assert_allclose(np.abs((pts - fit.centroid) @ fit.normal), h / 2, rtol=1e-9)


@pytest.mark.parametrize("phi", [0.02, 0.1, 0.3])
def test_a_cylinder_cap_is_held_by_the_slab_from_its_chord_plane_to_its_apex(phi):
    """Points on a cylinder of radius R over angles [-phi, phi] (axis x): the thinnest slab
    is bounded by the chord plane z = R cos(phi) and the tangent plane z = R at the apex, so
    the minimax plane misses by R (1 - cos phi) / 2; the least-squares plane, at the mean
    height R sin(phi)/phi, misses by R (sin(phi)/phi - cos phi) (about R phi^2 / 3)."""
    R = 8000.0
    theta = np.linspace(-phi, phi, 61)
    s = np.linspace(0.0, 12000.0, 25)
    T, S = np.meshgrid(theta, s)
    pts = np.column_stack([S.ravel(), R * np.sin(T.ravel()), R * np.cos(T.ravel())]) @ rotation(7).T
    fit = minimax_plane(pts)
    assert fit.max_distance == pytest.approx(R * (1 - np.cos(phi)) / 2, rel=1e-9)
    assert abs(fit.normal @ rotation(7)[:, 2]) == pytest.approx(1.0, abs=1e-12)
    assert fit.proven
    mean = np.mean(np.cos(theta))  # the discrete mean height / R of the samples
    assert fit.least_squares_max == pytest.approx(R * max(1 - mean, mean - np.cos(phi)), rel=1e-6)
    assert fit.least_squares_max > 1.2 * fit.max_distance


@pytest.mark.parametrize("seed", range(8))
def test_small_plate_like_sets_match_brute_force(seed):
    """Ten points spread over 2 m x 1 m, heights of some centimetres: the fit equals the
    enumeration of every candidate normal (not only near the least-squares one), and the
    certified lower bound never exceeds it."""
    rng = np.random.default_rng(100 + seed)
    local = np.column_stack([rng.uniform(-1000, 1000, 10), rng.uniform(-500, 500, 10), rng.normal(0, 20, 10)])
    pts = local @ rotation(seed).T
    fit = minimax_plane(pts)
    best = brute_half_width(pts)
    assert fit.max_distance == pytest.approx(best, rel=1e-9)
    assert fit.lower_bound <= best * (1 + 1e-9)
    assert fit.max_distance <= fit.least_squares_max + 1e-12
    # the reported distances are the points' distances to the reported plane
    np.testing.assert_allclose(fit.distances, (pts - fit.centroid) @ fit.normal, atol=1e-9)


def test_the_certificate_closes_on_a_plate_grid_and_the_rms_shortcut_is_safe():
    """A saddle-shaped 16 m x 3 m grid: the fit is proven optimal; flattest_plane returns the
    least-squares plane only when its RMS already exceeds the tolerance (no plane fits then:
    every plane's largest distance is at least the least-squares RMS)."""
    x, y = np.meshgrid(np.linspace(0, 16000, 81), np.linspace(0, 3000, 16))
    z = 4e-8 * (x - 8000) * (y - 1500) + 1e-7 * (x - 3000) ** 2
    pts = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    fit = minimax_plane(pts)
    assert fit.proven and fit.max_distance < fit.least_squares_max
    rms = float(np.sqrt(np.mean(fit_plane(pts).distances ** 2)))
    assert rms <= fit.max_distance
    assert flattest_plane(pts, 0.99 * rms).max_distance == pytest.approx(fit.least_squares_max)
    assert flattest_plane(pts, fit.max_distance).max_distance == pytest.approx(fit.max_distance, rel=1e-12)
    # fits_a_plane agrees with the minimax fit on either side of it, whichever bound decides
    for tol in (0.99 * rms, 0.999 * fit.max_distance, fit.max_distance * 1.001, fit.least_squares_max):
        assert fits_a_plane(pts, tol) == (fit.max_distance <= tol)


def bent_plate(kx: float, ky: float, kxy: float, noise: float, seed: int) -> np.ndarray:
    """A 12 m x 3 m plate grid (mm) bent about a point off its middle (so that its
    least-squares plane is not its minimax plane), with noise, turned and moved anywhere."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(-6000, 6000, 25), np.linspace(-1500, 1500, 7))
    cx, cy = rng.uniform(-6000, 6000), rng.uniform(-1500, 1500)
    z = kx * (x - cx) ** 2 + ky * (y - cy) ** 2 + kxy * (x - cx) * (y - cy) + noise * rng.normal(size=x.shape)
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()]) @ rotation(seed).T + rng.normal(size=3) * 1e4


@settings(max_examples=60, derandomize=True, deadline=None)
@given(st.floats(-3e-7, 3e-7), st.floats(-3e-7, 3e-7), st.floats(-2e-7, 2e-7), st.floats(0.0, 0.5),
       st.integers(0, 10 ** 6), st.sampled_from([0.5, 0.9, 0.999, 1.001, 1.1, 2.0]))
def test_fits_a_plane_stops_early_with_the_full_fits_answer(kx, ky, kxy, noise, seed, ratio):
    """Bent, twisted and noisy plate grids at tolerances on either side of their minimax
    distance: the decision that stops at the first round whose plane fits or whose
    certificate rules every plane out is the full fit's answer (sets thicker than
    round-off: a flat one's distances are its last digits, whichever way computed)."""
    pts = bent_plate(kx, ky, kxy, noise, seed)
    fit = minimax_plane(pts)
    assume(fit.max_distance > 1e-9 * 12000)
    tol = ratio * fit.max_distance
    assert fits_a_plane(pts, tol) == (fit.max_distance <= tol)


def test_a_decision_solves_one_programme_where_the_fit_solves_two(monkeypatch):
    """The first round of a bent plate finds its minimax normal; the full fit solves a
    second round to see the normal stand still, the decision stops after the first on
    either side of the tolerance."""
    from flatten import minimax

    solved = []
    real = minimax._chart_lp
    monkeypatch.setattr(minimax, "_chart_lp", lambda xy, z: solved.append(1) or real(xy, z))
    pts = bent_plate(1e-7, -5e-8, 4e-8, 0.0, 3)
    fit = minimax_plane(pts)
    assert fit.rounds == 2 and len(solved) == 2 and fit.proven
    for ratio, answer in ((0.99, False), (1.01, True)):
        solved.clear()
        assert fits_a_plane(pts, ratio * fit.max_distance) is answer
        assert len(solved) == 1
