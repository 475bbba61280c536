"""The batched geometry of hull plates against closed forms and independent evaluations:
surfaces on cached polynomial patches, crossings narrowed by secant-guided brackets,
arc length of dense samples in chained pieces, a region grid ending on its butt planes."""

import numpy as np
import pytest

from flatten.patch import narrow_crossings, region_grid
from flatten.surface import nurbs_surface
from tests.oracles import circular_arc


def cylinder(radius=2.5, angle=3 * np.pi / 2, n_spans=3, height=4.0):
    """u: an exact rational quadratic arc about z, v: a straight line up z (z = height v)."""
    arc = circular_arc(radius, 0.0, angle, n_spans)
    cp = arc.control_points
    poles = np.stack([np.column_stack([cp[:, :2], np.full(len(cp), z)]) for z in (0.0, height)], axis=1)
    weights = np.repeat(arc.weights[:, None], 2, axis=1)
    return nurbs_surface(2, 1, poles, arc.knots, [0.0, 0.0, 1.0, 1.0], weights, name="cylinder")


def test_rational_patches_lie_on_the_cylinder():
    surface = cylinder()
    rng = np.random.default_rng(5)
    u = np.concatenate([rng.uniform(0.0, 1.0, 2000), [0.0, 1 / 3, 2 / 3, 1.0]])
    v = np.concatenate([rng.uniform(0.0, 1.0, 2000), [0.0, 1.0, 0.5, 1.0]])
    p = surface(u, v)
    np.testing.assert_allclose(np.hypot(p[:, 0], p[:, 1]), 2.5, rtol=1e-14)
    np.testing.assert_allclose(p[:, 2], 4.0 * v, atol=1e-14)
    # the angle along u is the arc's own (an independent evaluation of the same curve)
    arc = circular_arc(2.5, 0.0, 3 * np.pi / 2, 3)
    np.testing.assert_allclose(p[:, :2], arc(u)[:, :2], atol=1e-13)


@pytest.mark.parametrize("degrees", [(1, 1), (2, 3), (3, 3), (3, 2), (4, 3)])
def test_surface_points_match_the_design_matrix_evaluation(degrees):
    """Patches (up to bicubic) and the basis recurrence (above) against scipy's design
    matrices (NurbsSurface.grid), rational, with a double knot, outside the domain clipped."""
    pu, pv = degrees
    rng = np.random.default_rng(sum(degrees))
    nu, nv = pu + 5, pv + 4
    ku = np.concatenate([np.zeros(pu + 1), [0.2, 0.45, 0.45, 0.7, 0.9][:nu - pu - 1], np.ones(pu + 1)]) * 7.0 - 3.0
    kv = np.concatenate([np.zeros(pv + 1), np.linspace(0, 1, nv - pv + 1)[1:-1], np.ones(pv + 1)])
    surface = nurbs_surface(pu, pv, rng.normal(size=(nu, nv, 3)) * 1e4, ku, kv, rng.uniform(0.5, 2.0, (nu, nv)))
    u = np.concatenate([rng.uniform(-3.5, 4.5, 300), np.unique(ku)])
    v = np.concatenate([rng.uniform(-0.1, 1.1, 300), rng.choice(kv, len(np.unique(ku)))])
    reference = np.array([surface.grid(a, b)[0, 0] for a, b in zip(u, v)])
    np.testing.assert_allclose(surface(u, v), reference, rtol=0, atol=1e-10 * 1e4)


def bisection(f, lo, hi, data, steps=48):
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        ok = f(mid, data) >= 0
        hi, lo = np.where(ok, mid, hi), np.where(ok, lo, mid)
    return hi


@pytest.mark.parametrize("kinked", [False, True])
def test_crossings_are_where_bisection_ends(kinked):
    """Smooth crossings take a few evaluations; a kink at the crossing (secant estimates
    all on one side) never takes more than the 48 steps of bisection, and ends where it
    does."""
    rng = np.random.default_rng(11)
    roots = rng.uniform(-5.0, 5.0, 200)
    width = rng.uniform(1e-3, 0.05, 200)  # brackets of a scan, as region_grid makes them
    # brackets either way round (lo outside, hi inside), the root anywhere in them
    side = np.where(rng.random(200) < 0.5, 1.0, -1.0)
    lo = roots - side * width * rng.uniform(0.01, 0.99, 200)
    hi = lo + side * width
    calls = []

    def f(x, k):  # >= 0 past the root on the hi side
        calls.append(len(x))
        y = side[k] * (x - roots[k])
        curved = y * (1.0 + 0.3 * y + 0.1 * np.sin(7.0 * roots[k]) * y * y)
        return np.minimum(curved, 2.0 * y) if kinked else curved

    index = np.arange(200)
    f_lo, f_hi = f(lo, index), f(hi, index)
    calls.clear()
    got = narrow_crossings(f, lo, hi, f_lo, f_hi, index)
    assert len(calls) <= (48 if kinked else 8)  # evaluations, each of all the brackets still open
    assert np.all(f(got, index) >= 0)
    np.testing.assert_allclose(got, roots, rtol=0, atol=4 * np.spacing(5.0))
    np.testing.assert_allclose(got, bisection(f, lo, hi, index), rtol=0, atol=4 * np.spacing(5.0))


def test_arc_length_of_dense_samples_is_the_exact_arc():
    radius, angle = 2.5, 3 * np.pi / 2
    arc = circular_arc(radius, 0.7, angle, n_spans=3)
    rng = np.random.default_rng(2)
    for t in (np.linspace(0.0, 1.0, 2049), rng.uniform(0.0, 1.0, 3000), np.sort(rng.uniform(0.0, 1.0, 7))):
        p = arc(t)
        exact = radius * np.mod(np.arctan2(p[:, 1], p[:, 0]), 2 * np.pi)
        exact[t == 0.0] = 0.0
        np.testing.assert_allclose(arc.arc_length_along(t), exact, rtol=0, atol=1e-13 * radius * angle)
        np.testing.assert_allclose(arc.arc_length_along(t), arc.arc_length_at(t), rtol=0,
                                   atol=1e-14 * radius * angle)


def test_region_grid_ends_on_slanted_butt_planes():
    """Rows between two girth lines of the cylinder end exactly on two slanted planes."""
    surface = cylinder()
    normal = np.array([0.0, 0.3, 1.0]) / np.hypot(0.3, 1.0)
    planes = [(normal, 1.0), (normal, 2.5)]  # region: 1.0 <= n . p <= 2.5
    grid = region_grid(surface, 1, lambda s: np.full(np.shape(s), 0.2), lambda s: np.full(np.shape(s), 0.4), planes,
                       rows=7, cols=11, probe=200, spacing="parameter")
    assert grid is not None and grid.shape == (7, 11) and grid.ends.all()
    np.testing.assert_allclose(grid.points[:, 0] @ normal, 1.0, atol=1e-12)
    np.testing.assert_allclose(grid.points[:, -1] @ normal, 2.5, atol=1e-12)
    np.testing.assert_allclose(np.hypot(grid.points[..., 0], grid.points[..., 1]), 2.5, rtol=1e-14)
    # every grid point inside the region; the rows follow the girth fractions
    inside = grid.points @ normal
    assert inside.min() >= 1.0 - 1e-12 and inside.max() <= 2.5 + 1e-12
    np.testing.assert_allclose(grid.params[..., 0], (0.2 + 0.2 * grid.rows)[:, None] * np.ones(11), atol=1e-15)


def test_outline_and_bending_lines_from_the_stages_development_are_the_tracers_own():
    """The PlateTracer developing from the strip's development (PartResult.developed) and
    developing the strip again give the same outline and bending lines; both are the
    frustum's annular sector (ends on two circles about one apex)."""
    from types import SimpleNamespace

    from flatten import solve
    from flatten.develop import DevelopedStrip
    from flatten.strip import build_strip, choose_rulings
    from pipeline.shop.bending import bending_lines
    from pipeline.shop.outline import PlateTracer, exact_outline
    from tests.oracles import frustum_pair

    r1, r2, h = 3.0, 2.0, 1.5
    c, d = frustum_pair(r1, r2, h, 2 * np.pi / 3, n_spans=3)
    solution = solve(c, d)
    rulings = choose_rulings(solution, c, d, n_rulings=40)
    strip = build_strip(c, d, rulings, 5)
    developed = DevelopedStrip(c, d, rulings, solution.field)
    pattern = SimpleNamespace(vertices=developed.development.vertices(strip.samples))
    part = SimpleNamespace(c=c, d=d)
    shared = PlateTracer(part, solution, strip, pattern, (), developed)
    own = PlateTracer(part, solution, strip, pattern)
    assert shared._strip is developed and own._strip is not developed
    a, b = exact_outline(shared, 1e-4), exact_outline(own, 1e-4)
    assert a.edges == b.edges
    np.testing.assert_allclose(a.points, b.points, rtol=0, atol=1e-11)
    lines_a, length_a = bending_lines(shared, 0.4)
    lines_b, length_b = bending_lines(own, 0.4)
    assert len(lines_a) == len(lines_b) >= 3 and length_a == pytest.approx(length_b, abs=1e-11)
    for la, lb in zip(lines_a, lines_b):
        np.testing.assert_allclose([la.a, la.b], [lb.a, lb.b], rtol=0, atol=1e-11)
    s = np.hypot(r1 - r2, h)
    rho1, rho2 = r1 * s / (r1 - r2), r2 * s / (r1 - r2)
    ends_a = np.array([line.a for line in lines_a])
    ends_b = np.array([line.b for line in lines_a])
    apex = (ends_a + (ends_b - ends_a) * (rho1 / (rho1 - rho2))).mean(axis=0)
    np.testing.assert_allclose(np.hypot(*(ends_a - apex).T), rho1, rtol=1e-10)
    np.testing.assert_allclose(np.hypot(*(ends_b - apex).T), rho2, rtol=1e-10)


@pytest.mark.parametrize("case", ["band", "sliver", "sheared", "whole"])
def test_a_long_probe_sampled_sparsely_gives_the_whole_probes_grid(case, monkeypatch):
    """A probe of 400 columns along the cylinder's height is first sampled at every tenth column
    and then only around what those find: the grid is the whole probe's, bit for bit, for a
    band of the height, a sliver between two sampled columns (found by the whole probe
    only), rows whose runs shift along the height by more than their length (planes slanted
    across the girth: some rows lie wholly between the sampled ones' runs), and no planes."""
    from flatten import patch

    surface = cylinder(height=100.0)
    band = {"band": (10.0, 30.0), "sliver": (51.3, 51.5), "sheared": (40.0, 41.0), "whole": None}[case]
    if band is None:
        planes = [None, None]
    elif case == "sheared":
        normal = np.array([0.0, 0.999, 0.045])  # mostly across the girth: each row meets it at its own height
        normal /= np.linalg.norm(normal)
        planes = [(normal, band[0] * normal[2]), (normal, band[1] * normal[2])]
    else:
        planes = [(np.array([0.0, 0.0, 1.0]), band[0]), (np.array([0.0, 0.0, 1.0]), band[1])]
    counted = _Counting(surface)
    args = (counted, 1, lambda s: np.full(np.shape(s), 0.1), lambda s: np.full(np.shape(s), 0.9), planes, 9, 17)
    sparse = region_grid(*args, probe=400, spacing="parameter")
    sparse_points, counted.points = counted.points, 0
    monkeypatch.setattr(patch, "COARSE_PROBE", 10**6)  # every column evaluated
    whole = region_grid(*args, probe=400, spacing="parameter")
    if case == "sheared":
        assert whole is not None and np.ptp(whole.params[:, 0, 1]) > 1.0 / 100.0  # rows' runs at their own heights
    if case == "band":
        assert sparse_points < 0.5 * counted.points  # the probe's columns away from the band are skipped
    for field in ("params", "points", "rows", "ends"):
        assert np.array_equal(getattr(sparse, field), getattr(whole, field)), field


class _Counting:
    """A surface that counts the points it is evaluated at."""

    def __init__(self, surface):
        self.surface, self.points = surface, 0

    def __call__(self, u, v):
        self.points += len(np.atleast_1d(u))
        return self.surface(u, v)

    def __getattr__(self, name):
        return getattr(self.surface, name)


def test_a_row_whose_longest_run_lies_between_sparse_columns_is_probed_whole(monkeypatch):
    """A row that lies inside twice, briefly beside the other row's run and longer between two
    sampled columns far from it (a review's case): the grid keeps each row's longest run, so
    the sparse probe, which sees only the short one, gives way to the whole probe."""
    from flatten import patch

    plane = nurbs_surface(1, 1, [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]], [0, 0, 1, 1], [0, 0, 1, 1])

    def g_hi(s):  # the upper row dips inside near the lower row's run, and for longer near u = 0.764
        s = np.asarray(s, dtype=float)
        return 0.9 - 0.45 * np.exp(-((s - 0.3775) / 0.002) ** 2) - 0.8 * np.exp(-((s - 0.7644) / 0.006) ** 2)

    planes = [(np.array([1.0, 0.0, 0.0]), 0.25), (np.array([1.0, 1.0, 0.0]), 1.0)]  # x >= 0.25, x + y <= 1
    args = (plane, 0, lambda s: np.full(np.shape(s), 0.5), g_hi, planes, 2, 5)
    sparse = region_grid(*args)
    monkeypatch.setattr(patch, "COARSE_PROBE", 10**6)
    whole = region_grid(*args)
    assert 0.76 < whole.params[1, 0, 0] < whole.params[1, -1, 0] < 0.77  # the upper row's longer run
    for field in ("params", "points", "rows", "ends"):
        assert np.array_equal(getattr(sparse, field), getattr(whole, field)), field
