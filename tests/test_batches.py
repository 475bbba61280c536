"""Big strips are computed in batches (bounded memory): the batched results equal the
whole-array computations they replace, written out here independently on small strips
with tiny batches, so that every batch boundary case is crossed."""

import numpy as np
import pytest

import flatten.develop as develop_module
from flatten import DEFAULT_TOLERANCES, judge, normalized_residual, nurbs_curve, solve
from flatten.develop import DevelopedStrip, _interval_breaks, develop
from flatten.equation import developability_field
from flatten.meshcheck import angle_defects, strip_angle_defects
from flatten.metrics import distortion, edge_lengths, triangle_areas, unique_edges
from flatten.judge import UnitMap
from flatten.strip import PathSampler, batches, build_strip, choose_rulings, grid_faces, sample_path
from flatten.tracer import trace_zero_set
from tests import oracles


@pytest.fixture(scope="module")
def frustum():
    c, d = oracles.frustum_pair(3.0, 2.0, 1.5, 2 * np.pi / 3, n_spans=3)
    return c, d, solve(c, d)


def test_batches_cover_the_range_once():
    for n in (0, 1, 7, 8, 9, 100):
        for size in (1, 3, 8, 1000):
            spans = list(batches(n, size))
            covered = np.concatenate([np.arange(lo, hi) for lo, hi in spans]) if spans else np.array([])
            assert np.array_equal(covered, np.arange(n))
            assert all(0 < hi - lo <= size for lo, hi in spans)


def test_grid_faces_are_the_two_triangles_of_every_quad():
    for k, m in ((1, 3), (2, 3), (5, 4), (20_000, 3)):  # 20000 rulings cross the batch size
        a = (np.arange(k - 1)[:, None] * m + np.arange(m - 1)[None, :]).ravel()
        expected = np.vstack([np.column_stack([a, a + m, a + 1]), np.column_stack([a + 1, a + m, a + m + 1])])
        got = grid_faces(k, m)
        assert got.shape == (2 * (k - 1) * (m - 1), 3)
        assert np.array_equal(got, expected)


def test_sample_path_is_pointwise(frustum):
    """The polish works point by point, so batching cannot change a ruling: any subset of
    fractions gives the same rows, bit for bit."""
    c, d, solution = frustum
    fractions = np.linspace(0.0, 1.0, 20_001)  # more than one batch
    every = sample_path(solution, fractions)
    pick = np.array([0, 1, 8191, 8192, 8193, 16_384, 20_000])
    assert np.array_equal(sample_path(solution, fractions[pick]), every[pick])


def test_development_in_batches_equals_one_batch(frustum):
    c, d, solution = frustum
    rulings = choose_rulings(solution, c, d, n_rulings=300)
    whole = develop(c, d, rulings, solution.field, chunk=10**9)
    for chunk in (1, 2, 7, 64):
        part = develop(c, d, rulings, solution.field, chunk=chunk)
        # the running sums are carried in the same order; the Newton refinement of T(t)
        # may see other batch shapes (round-off)
        assert np.abs(part.along_c - whole.along_c).max() <= 1e-13
        assert np.abs(part.along_d - whole.along_d).max() <= 1e-13


def test_interval_breaks_split_long_intervals_as_linspace(frustum, monkeypatch):
    c, d, solution = frustum
    rulings = choose_rulings(solution, c, d, n_rulings=3)  # long intervals: many splits
    breaks = _interval_breaks(c, d, solution.field, rulings)
    width = np.ptp(c.domain)
    assert np.all(np.diff(breaks) > 0)
    assert np.diff(breaks).max() <= width / 64 * (1 + 1e-12)
    assert set(rulings[:, 0]) <= set(breaks)
    # the loop it replaced, on the same breaks before splitting
    monkeypatch.setattr(develop_module, "_MAX_PIECE", 2.0)
    coarse = _interval_breaks(c, d, solution.field, rulings)
    assert len(coarse) < len(breaks) / 4
    expected = [coarse[:1]]
    for a, b in zip(coarse[:-1], coarse[1:]):
        expected.append(np.linspace(a, b, int(np.ceil((b - a) / (width / 64))) + 1)[1:])
    assert np.array_equal(breaks, np.concatenate(expected))


def test_angle_defects_in_windows_equal_the_whole_mesh(frustum):
    c, d, solution = frustum
    # a warped correspondence T = s^2 is not the cone: defects are far from zero, so the
    # check has teeth
    s = np.linspace(0.0, 1.0, 40)
    rulings = np.column_stack([c.domain[0] + s * np.ptp(c.domain), d.domain[0] + s**2 * np.ptp(d.domain)])
    strip = build_strip(c, d, rulings, 5)
    whole = angle_defects(strip.vertices, strip.faces)
    assert whole.max_defect > 1e-6 and whole.interior_vertices == 38 * 3
    for chunk in (1, 2, 5, 37):
        part = strip_angle_defects(strip, chunk=chunk)
        assert part.interior_vertices == whole.interior_vertices
        assert part.max_defect == whole.max_defect
        assert part.max_abs_K == whole.max_abs_K
        assert part.integrated_abs_defect == pytest.approx(whole.integrated_abs_defect, rel=1e-13)


def test_distortion_in_windows_equals_the_edge_list_computation(frustum):
    """The grid's edges (along the strip, diagonals, rulings) against the edge list of the
    whole triangle mesh, de-duplicated, on a flat layout that is not isometric."""
    m = 4
    c, d, rulings, strip, flat = _strip_and_flat(frustum, m)
    flat = flat * np.array([1.0, 1.01])  # a stretched pattern: every figure non-trivial
    edges = unique_edges(strip.faces)
    ruling = np.column_stack([np.arange(len(strip.vertices)), np.arange(len(strip.vertices)) + 1])
    ruling = ruling[(ruling[:, 0] % m) != m - 1]
    is_ruling = (edges[:, 1] == edges[:, 0] + 1) & (edges[:, 0] % m != m - 1)
    assert is_ruling.sum() == len(ruling)
    l3, l2 = edge_lengths(strip.vertices, edges[~is_ruling]), edge_lengths(flat, edges[~is_ruling])
    r3, r2 = edge_lengths(strip.vertices, ruling), edge_lengths(flat, ruling)
    rel = np.abs(l2 - l3) / l3
    for chunk in (1, 2, 7, 1000):
        got = distortion(strip.vertices, flat, m, c, d, rulings, chunk=chunk)
        assert got["ruling_edge_max_relative_error"] == pytest.approx((np.abs(r2 - r3) / r3).max(), rel=1e-12)
        assert got["chord_discrepancy_max_relative"] == pytest.approx(rel.max(), rel=1e-12)
        assert got["chord_discrepancy_rms_relative"] == pytest.approx(np.sqrt(np.mean(rel**2)), rel=1e-12)
        assert got["area_3d"] == pytest.approx(triangle_areas(strip.vertices, strip.faces).sum(), rel=1e-13)
        assert got["area_flat"] == pytest.approx(triangle_areas(flat, strip.faces).sum(), rel=1e-13)
        assert got["ruling_edge_max_relative_error"] > 1e-4  # the stretch is seen on the rulings
        assert got["ruling_edge_max_abs_error"] == pytest.approx(np.abs(r2 - r3).max(), rel=1e-12)


def _strip_and_flat(frustum, m: int):
    """The frustum's strip on 30 rulings, m samples a ruling, and its exact development:
    (c, d, rulings, strip, flat vertices (K m, 2))."""
    c, d, solution = frustum
    rulings = choose_rulings(solution, c, d, n_rulings=30)
    strip = build_strip(c, d, rulings, m)
    return c, d, rulings, strip, develop(c, d, rulings, solution.field).vertices(strip.samples)


def test_distortion_of_a_strip_whose_seams_meet_is_finite_and_warns_nothing(frustum):
    """Seams meeting at an end collapse the edges along that ruling to zero length in 3D;
    their round-off length in the plane over zero read as 1e+288 and overflowed the RMS (a
    DTMB 5415 plate). Collapsed edges carry no relative error; the others keep theirs."""
    import warnings

    m = 4
    c, d, rulings, strip, flat = _strip_and_flat(frustum, m)
    vertices, flat = strip.vertices.copy(), flat.copy()
    vertices[m] = vertices[0]  # the first two rulings start at one point in 3D (a seam with zero speed) ...
    flat[m] = flat[0] + 1e-13  # ... and within round-off of one point in the plane
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = distortion(vertices, flat, m, c, d, rulings, chunk=7)
    assert np.isfinite(got["chord_discrepancy_rms_relative"]) and got["chord_discrepancy_max_relative"] < 1.0


def test_a_corner_ruling_trimmed_to_a_point_leaves_the_ruling_error_at_round_off(frustum):
    """A hull plate's corner ruling, cut by a butt plane down to a point, keeps edges of
    ~1e-12 mm whose 3D and flat lengths are round-off of the coordinates: their ratio read
    as a relative ruling error of 0.1-1.4 in the plate reports. The relative figure leaves
    such slivers out (the others stay exact to round-off); the absolute one keeps them."""
    m = 5
    c, d, rulings, strip, flat = _strip_and_flat(frustum, m)
    vertices, flat = strip.vertices.copy(), flat.copy()
    # the last ruling trimmed to its first point: its edges are round-off in 3D and flat
    vertices[-m:] = vertices[-m] + 1e-13 * np.arange(m)[:, None] * np.array([1.0, 0.0, 0.0])
    flat[-m:] = flat[-m] + 3e-13 * np.arange(m)[:, None] * np.array([0.0, 1.0])
    exact = distortion(strip.vertices[:-m], flat[:-m], m, c, d, rulings[:-1])
    for chunk in (1, 7, 1000):
        got = distortion(vertices, flat, m, c, d, rulings, chunk=chunk)
        assert got["ruling_edge_max_relative_error"] == exact["ruling_edge_max_relative_error"] <= 1e-12
        assert got["ruling_edge_max_abs_error"] == pytest.approx(2e-13, rel=1e-2)  # the sliver's 3e-13 - 1e-13


def test_a_strip_far_from_the_origin_reports_no_relative_ruling_error_rather_than_zero(frustum):
    """A strip 1e-9 of its distance from the origin: every ruling edge lies below the floor,
    so the relative figure is not measured (NaN, null in a report), never a 0 that would
    claim an exact development; the absolute figure still shows a 1 % stretch."""
    m = 5
    c, d, rulings, strip, flat = _strip_and_flat(frustum, m)
    flat = flat * 1.01
    near = distortion(strip.vertices, flat, m, c, d, rulings)
    far = distortion(strip.vertices + 8e8, flat, m, c, d, rulings)
    assert near["ruling_edge_max_relative_error"] == pytest.approx(0.01, rel=1e-6)
    assert np.isnan(far["ruling_edge_max_relative_error"])
    assert far["ruling_edge_max_abs_error"] == pytest.approx(near["ruling_edge_max_abs_error"], rel=1e-3)


def test_develop_keeps_no_interpolant_and_bounded_temporaries(frustum):
    """develop() returns the development alone: the pieces' spectral interpolant that
    DevelopedStrip keeps for later rulings (3 x 10 floats a piece, 240 bytes a ruling of a
    dense strip) is not built, so 1e6 rulings stay under issue 15's 600 bytes a ruling
    (bench_growth measured 667 while it was). Traced by tracemalloc at 1e5 rulings: the
    result is 32 bytes a ruling, the batches' temporaries a few MB whatever the count."""
    import tracemalloc

    c, d, solution = frustum
    n = 100_000
    rulings = choose_rulings(solution, c, d, n_rulings=n)
    tracemalloc.start()
    try:
        dev = develop(c, d, rulings, solution.field)
        kept, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert kept <= 40 * n  # along_c and along_d
    assert peak <= 350 * n  # with the interpolant: 466
    again = DevelopedStrip(c, d, rulings, solution.field, interpolant=False)
    assert np.array_equal(again.development.along_c, dev.along_c)
    with pytest.raises(ValueError, match="no interpolant"):
        again.ends(rulings[:3])


def test_polish_of_a_point_does_not_depend_on_its_batch(frustum):
    """Each point's polish is its own: polished alone with a few others, or among many that
    settle earlier or later (a last moving point computed along with a settled one), it
    ends on the same bits. Also the polished points lie on f = 0 to round-off."""
    c, d, solution = frustum
    unit = UnitMap(solution.field)
    x = unit.to_unit(sample_path(solution, np.linspace(0.02, 0.98, 41)))  # inside the square
    rng = np.random.default_rng(7)
    # off the curve by 0 to 1e-5: they settle after different numbers of steps
    starts = x + rng.normal(scale=1e-5, size=x.shape) * rng.uniform(0, 1, (len(x), 1)) ** 4
    every = unit.polish(starts, iterations=6)
    picks = [np.array([i, j]) for i in range(0, 41, 2) for j in range(1, 41, 2)]  # pairs: one settles first
    for pick in picks + [np.arange(5, 12), rng.permutation(41)[:9]]:
        assert np.array_equal(unit.polish(starts[pick], iterations=6), every[pick])
    p = unit.to_params(every)
    assert np.abs(solution.field(p[:, 0], p[:, 1])).max() <= 1e-9 * np.abs(solution.field(*unit.to_params(starts).T)).max()


def test_path_sampler_is_sample_path(frustum):
    """The sampler of one solution, called many times, gives sample_path's rows; its
    vertices are the path's own points at their fractions of its length in the unit square."""
    c, d, solution = frustum
    sample = PathSampler(solution)
    for fractions in (np.array([0.0, 1.0]), np.linspace(0.2, 0.7, 33), np.array([0.5, 0.25, 0.75])):
        assert np.array_equal(sample(fractions), sample_path(solution, fractions))
    lam, points = sample.vertices()
    assert np.allclose(points, solution.path.points, rtol=0, atol=1e-12)
    unit = np.column_stack([(points[:, k] - dom[0]) / (dom[1] - dom[0]) for k, dom in enumerate((c.domain, d.domain))])
    length = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(unit, axis=0), axis=1))])
    assert np.allclose(lam, length / length[-1], rtol=0, atol=1e-14)
    assert lam[0] == 0.0 and lam[-1] == 1.0 and np.all(np.diff(lam) >= 0)
    # a vertex sampled at its own fraction comes back (the polish moves it by round-off only)
    mid = len(lam) // 2
    assert np.allclose(sample(lam[[mid]]), points[[mid]], rtol=0, atol=1e-12)


def test_polish_settled_early_is_the_polish_to_round_off(frustum):
    """Stopping after a Newton step of 1e-10 (the sampler's setting) leaves each point
    where the full polish puts it, to round-off of the unit square, and on f = 0 as
    closely (measured as the distance f / |grad f|); far starts still take their steps."""
    c, d, solution = frustum
    unit = UnitMap(solution.field)
    x = unit.to_unit(sample_path(solution, np.linspace(0.02, 0.98, 201)))
    rng = np.random.default_rng(11)
    starts = x + rng.normal(scale=3e-5, size=x.shape)
    full = unit.polish(starts, iterations=6)
    early = unit.polish(starts, iterations=6, settled=1e-10)
    assert np.abs(early - full).max() <= 1e-14
    assert np.abs(early - starts).max() > 1e-6  # they moved

    def distance(y):
        p = unit.to_params(y)
        return np.abs(solution.field(p[:, 0], p[:, 1])) / np.linalg.norm(unit.gradient(y), axis=1)

    assert distance(early).max() <= max(4 * distance(full).max(), 1e-15)


# ---------------------------------------------------------------- the judge's class changes
def _one_class_boundary(unit, a, b, column):
    """Where a branch changes class between a and b, one boundary at a time: the judge's
    computation before its bisections ran as one batch (Newton for a turning point, else
    4 rounds of 64 chord points projected across the chord), written out independently."""
    ga, gb = unit.gradient(np.vstack([a, b]))
    turns = np.sign(ga) != np.sign(gb)
    if turns.any():
        found = judge._turning_point(unit, a, b, 0 if turns[0] else 1)
        if found is not None:
            return found, "newton"
    kind = "dT/dt=0" if turns[0] else "dt/dT=0" if turns[1] else "ruling tangent to a curve"
    orientation = 1 if column == 0 else -1
    start = judge.acceptable_points(unit, a[None], orientation)[0]
    chord = (b - a) / max(np.hypot(*(b - a)), 1e-300)
    normal = np.array([-chord[1], chord[0]])
    lo, hi = a, b
    for _ in range(4):
        pts = unit.project_along(lo + np.linspace(0.0, 1.0, 65)[:, None] * (hi - lo), normal)
        same = judge.acceptable_points(unit, pts, orientation) == start
        k = int(np.argmin(same)) if not same.all() else len(pts) - 1
        lo, hi = pts[max(k - 1, 0)], pts[k]
    return (unit.project_along(0.5 * (lo + hi)[None], normal)[0], kind), "bisection"


def _wavy_pair(seed: int):
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 10.0, 9)
    c = nurbs_curve(np.column_stack([x, rng.normal(size=9), rng.normal(size=9)]), 3, name="c")
    d = nurbs_curve(np.column_stack([x[::-1] if seed % 2 else x, 2 + rng.normal(size=9),
                                     1 + rng.normal(size=9)]), 3, name="d")
    return c, d


def test_the_class_changes_of_all_branches_found_in_one_batch_equal_each_found_alone():
    """An S curve against a C curve (T turns back) and wavy cubic pairs whose branches turn
    back and forth: every class change (Newton's turning points and the bisected ones
    alike) is bit for bit what it is alone."""
    ways = {"newton": 0, "bisection": 0}
    for c, d in [oracles.s_and_c_curves()] + [_wavy_pair(seed) for seed in range(16)]:
        field = developability_field(c, d)
        unit = judge.UnitMap(field)
        traces = trace_zero_set(field, DEFAULT_TOLERANCES)[0]
        changes = [(tr.points[k], tr.points[k + 1], column) for tr in traces
                   for column, acc in enumerate(judge._classes(unit, tr.points).T)
                   for k in np.flatnonzero(acc[1:] != acc[:-1])]
        a, b, columns = (np.array(v) for v in zip(*changes))
        batch = judge._class_boundaries(unit, a, b, columns)
        assert len(batch) == len(changes) >= 3
        for (point, kind), change in zip(batch, changes):
            (alone, alone_kind), way = _one_class_boundary(unit, *change)
            ways[way] += 1
            assert kind == alone_kind
            assert np.array_equal(point, alone)  # bit for bit
            assert np.all((point >= 0.0) & (point <= 1.0))
    assert ways["newton"] >= 10 and ways["bisection"] >= 300, ways


def test_projecting_groups_of_points_in_one_batch_equals_projecting_each_group_alone():
    """Groups of chord points, each along its own direction, some converging sooner than
    others: each group's points are bit for bit those of project_along on the group alone,
    and they lie on Z."""
    c, d = _wavy_pair(4)
    field = developability_field(c, d)
    unit = judge.UnitMap(field)
    trace = max(trace_zero_set(field, DEFAULT_TOLERANCES)[0], key=lambda tr: len(tr.points))
    pairs = [(trace.points[k], trace.points[k + 3]) for k in range(0, len(trace.points) - 3, 5)]
    chords = np.array([(b - a) / np.hypot(*(b - a)) for a, b in pairs])
    normals = np.column_stack([-chords[:, 1], chords[:, 0]])
    groups = np.array([a + np.linspace(0.0, 1.0, 17)[:, None] * (b - a) for a, b in pairs])
    together = unit.project_groups(groups, normals)
    assert len(pairs) >= 8
    for group, normal, got in zip(groups, normals, together):
        assert np.array_equal(got, unit.project_along(group, normal))
    p = unit.to_params(together.reshape(-1, 2))
    assert np.max(np.abs(normalized_residual(c, d, p[:, 0], p[:, 1]))) < 1e-9
