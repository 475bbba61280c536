"""flatten.trim.StripMap: closest points on a solved strip and their developed positions.

A strip whose rulings lean far over (a seam strip extended past its butts: 3.5 m rulings
pairing points metres apart along the seams) is where the search's seed matters: Newton in
lam moves a few ruling spacings a step, so a seed must land within reach of the closest
point. Points placed on the strip at known rulings and positions along them, and moved off
it along its normal, must be found there; their developed positions must be the strip's
exact development of those rulings."""

from __future__ import annotations

import numpy as np
import pytest

from flatten import solve
from flatten.develop import develop
from flatten.nurbs import nurbs_curve
from flatten.strip import sample_path
from flatten.trim import StripMap


def leaning_strip():
    """A cylinder: a bent seam c in the plane y = 0 and its copy d moved 3 m across and 5 m
    along x, so that every ruling is that move and leans 59 degrees from the girth."""
    poles = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.6], [8.0, 0.0, 0.6], [12.0, 0.0, 0.0]])
    c = nurbs_curve(poles, name="c")
    d = nurbs_curve(poles + [5.0, 3.0, 0.0], name="d")
    solution = solve(c, d)
    assert solution
    return c, d, solution


@pytest.fixture(scope="module")
def strip_and_points():
    c, d, solution = leaning_strip()
    rng = np.random.default_rng(7)
    lam = rng.uniform(0.02, 0.98, 400)
    v = rng.uniform(0.0, 1.0, 400)
    rulings = sample_path(solution, lam)
    a, b = c(rulings[:, 0]), d(rulings[:, 1])
    on_strip = a + v[:, None] * (b - a)
    # the strip's normal at each point: across its ruling and along the tangent plane
    dc = c.derivatives(rulings[:, 0], 1)[1]
    normal = np.cross(dc, b - a)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    offset = rng.uniform(-0.004, 0.004, 400)  # a few mm off, as a hull is off its plate
    return c, d, solution, lam, v, rulings, on_strip, on_strip + offset[:, None] * normal, np.abs(offset)


def test_the_rulings_lean_far_over(strip_and_points):
    c, d, solution, *_ = strip_and_points
    rulings = sample_path(solution, np.linspace(0.0, 1.0, 11))
    r = d(rulings[:, 1]) - c(rulings[:, 0])
    lean = np.degrees(np.arctan2(np.abs(r[:, 0]), np.hypot(r[:, 1], r[:, 2])))
    np.testing.assert_allclose(lean, np.degrees(np.arctan2(5.0, 3.0)), atol=1e-6)


def test_points_off_a_leaning_strip_are_found_on_their_rulings(strip_and_points):
    c, d, solution, lam, v, _, on_strip, points, offset = strip_and_points
    smap = StripMap(solution, c, d, 801)
    found_lam, found_v, _, found = smap.locate(points)
    np.testing.assert_allclose(found_lam, lam, atol=1e-7)
    np.testing.assert_allclose(found_v, v, atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(points - found, axis=1), offset, atol=1e-7)
    np.testing.assert_allclose(found, on_strip, atol=1e-6)


def test_mapped_points_develop_as_the_whole_strip_does(strip_and_points):
    c, d, solution, lam, v, rulings, _, points, _ = strip_and_points
    smap = StripMap(solution, c, d, 801)
    mapped, own_c, own_d = smap.map(points)
    # the exact development of the map's rulings and these together (one integration of all)
    merged = np.vstack([smap.rulings, rulings])
    order = np.lexsort((merged[:, 1] * solution.path.orientation, merged[:, 0]))
    dev = develop(c, d, merged[order], solution.field)
    position = np.empty(len(merged), dtype=int)
    position[order] = np.arange(len(merged))
    ac, ad = dev.along_c[position], dev.along_d[position]
    k = len(smap.rulings)
    np.testing.assert_allclose(own_c, ac[:k], atol=1e-9)
    np.testing.assert_allclose(own_d, ad[:k], atol=1e-9)
    exact = ac[k:] + v[:, None] * (ad[k:] - ac[k:])
    np.testing.assert_allclose(mapped.flat, exact, atol=1e-6)
    # isometry: developed distances between mapped points equal the 3D ones on the strip
    on = mapped.on_strip
    i, j = np.arange(0, 399), np.arange(1, 400)
    near = np.abs(lam[i] - lam[j]) < 0.05
    np.testing.assert_allclose(np.linalg.norm(mapped.flat[i] - mapped.flat[j], axis=1)[near],
                               np.linalg.norm(on[i] - on[j], axis=1)[near], rtol=1e-3)


@pytest.mark.parametrize("v", [0.0, 1.0])
def test_points_on_the_strips_edges_are_found_on_them(v):
    """A region's corner lies on a seam, where the strip ends: there the distance to the
    strip grows with the error of the ruling found to first order (inside the strip only to
    second), and a corner more than 1 mm off refuses the strip. Points on the edge curves, on
    the map's own rulings (where the k-d tree seeds) and between them, are found on the
    strip to 1e-6 m of a 12 m strip (the search on interpolated rulings alone: 1.2e-4 m)."""
    c, d, solution = leaning_strip()
    lam = np.concatenate([np.linspace(0.0, 1.0, 801)[5:-5:7], np.random.default_rng(3).uniform(0.01, 0.99, 200)])
    rulings = sample_path(solution, lam)
    a = c(rulings[:, 0])
    points = a + v * (d(rulings[:, 1]) - a)
    _, _, _, found = StripMap(solution, c, d, 801).locate(points)
    assert np.linalg.norm(points - found, axis=1).max() < 1e-6


def test_a_small_probe_is_seeded_on_the_rulings_the_tree_would_pick(strip_and_points):
    """A plate's probe (a few dozen points) is seeded ruling by ruling, without the k-d tree
    whose build costs more than the whole probe; the nearest sample found that way is the
    tree's (the same ruling), far off the strip and beyond its ends too, and a map that
    probed first locates the points as a fresh one does, to the bit."""
    from scipy.spatial import cKDTree

    from flatten.trim import SEED_SCAN_PAIRS, _nearest_sample_ruling

    c, d, solution, *_, points, _ = strip_and_points
    smap = StripMap(solution, c, d, 801)
    smap._seed(points[:3])  # builds the seed rulings, no tree
    a, b, v, _ = smap._seeding
    assert smap._tree is None and 3 * len(a) <= SEED_SCAN_PAIRS
    rng = np.random.default_rng(11)
    anywhere = np.vstack([points, points + rng.normal(0.0, 2.0, points.shape), a[[0, -1]] - [6.0, 0.0, 0.0]])
    samples = (a[:, None, :] + v[None, :, None] * (b - a)[:, None, :]).reshape(-1, 3)
    _, index = cKDTree(samples).query(anywhere)
    np.testing.assert_array_equal(_nearest_sample_ruling(anywhere, a, b, v), index // len(v))

    probe = points[::9]  # 45 points: scanned
    assert len(probe) * len(a) <= SEED_SCAN_PAIRS
    probed = StripMap(solution, c, d, 801)
    alone = probed.locate(probe)
    assert probed._tree is None
    whole = probed.locate(points)
    assert probed._tree is not None
    for got, want, fresh in zip(alone, whole, StripMap(solution, c, d, 801).locate(points)):
        np.testing.assert_array_equal(got, want[::9])  # the probe as the whole region locates it
        np.testing.assert_array_equal(want, fresh)
    with pytest.raises(ValueError, match="finite"):
        probed.locate(np.array([[np.nan, 0.0, 0.0]]))


def test_points_near_a_fans_apex_are_seeded_alike_by_the_scan_and_the_tree():
    """A corner fan: a quarter of the seed rulings share their apex on c, so a point whose
    nearest sample is the apex ties between all of them, and the seed (and with it the
    local minimum Newton finds) would depend on which one the search reports. Both
    searches report the first ruling: points located alone (scanned) are located as among
    many (the tree), to the bit."""
    from tests.families import corner_pair

    c, d = corner_pair(tilt=0.1)
    solution = solve(c, d)
    apex = c(np.array([0.5]))[0]
    rng = np.random.default_rng(1)
    near = apex + rng.normal(size=(45, 3)) * 10.0 ** rng.uniform(-4, -1, (45, 1))
    smap = StripMap(solution, c, d, 801)
    alone = smap.locate(near)
    assert smap._tree is None
    among = smap.locate(np.vstack([near, near + 0.01]))
    assert smap._tree is not None
    for got, want in zip(alone, among):
        np.testing.assert_array_equal(got, want[:45])


def test_rulings_within_round_off_of_a_point_are_searched_whole():
    """Where seams meet, a ruling may be a few ulps long: its computed samples are not in
    line and their distances not convex along it, so the window around a point's projection
    can miss the nearest. Such rulings are searched whole: the scan reports the tree's
    ruling (or one holding a sample exactly as near)."""
    from scipy.spatial import cKDTree

    from flatten.trim import _nearest_sample_ruling

    rng = np.random.default_rng(5)
    tip, v = np.array([100.0, 3.0, 5.0]), np.linspace(0.0, 1.0, 129)
    for _ in range(3000):
        length = 10.0 ** rng.uniform(-15, -9)
        a = np.array([tip + length * rng.normal(size=3), tip])  # a ruling ulps long beside one of no length
        b = np.array([tip + length * rng.normal(size=3), tip])
        point = tip + rng.normal(size=(1, 3)) * 10.0 ** rng.uniform(-12, -3)
        samples = (a[:, None, :] + v[None, :, None] * (b - a)[:, None, :]).reshape(-1, 3)
        _, index = cKDTree(samples).query(point)
        gap = point - samples
        nearest = (gap[:, 0] ** 2 + gap[:, 1] ** 2 + gap[:, 2] ** 2).reshape(2, -1).min(axis=1)
        found = _nearest_sample_ruling(point, a, b, v)[0]
        assert found == index[0] // len(v) or nearest[0] == nearest[1]
