"""A real hull plate: the Series 60 hull surface, seams along iso-parameter curves."""

import json
from pathlib import Path

import numpy as np
import pytest

from flatten import normalized_residual, solve
from flatten.surface import expand_knots, nurbs_surface

DATA = Path(__file__).resolve().parent / "data" / "ship" / "s60_bsplines.json"


def s60_surface():
    s = json.loads(DATA.read_text())["surfaces"][0]
    return nurbs_surface(s["degree_u"], s["degree_v"], s["poles"], expand_knots(s["knots_u"], s["mults_u"]),
                         expand_knots(s["knots_v"], s["mults_v"]), name="s60")


def s60_plate(u1=0.4, u2=0.5, v0=0.3, v1=0.5):
    surface = s60_surface()
    return surface.iso_u(u1).segment(v0, v1), surface.iso_u(u2).segment(v0, v1), surface


def test_iso_curves_and_segments_lie_on_the_surface():
    c, d, surface = s60_plate()
    v = np.linspace(0.3, 0.5, 11)
    np.testing.assert_allclose(c(v), surface(np.full(11, 0.4), v), atol=1e-9)
    np.testing.assert_allclose(d(v), surface(np.full(11, 0.5), v), atol=1e-9)
    assert c.domain == (0.3, 0.5)


def test_s60_plate_with_short_spans_is_solved_not_taken_for_flat():
    c, d, _ = s60_plate()
    assert min(np.diff(c.breakpoints)) < 0.1 * max(np.diff(c.breakpoints))  # very uneven spans
    solution = solve(c, d)
    assert solution.kind == "general" and solution
    cov = solution.path.coverage
    assert cov.c_fraction > 0.9 and cov.d_fraction > 0.75
    pts = solution.path.points
    assert normalized_residual(c, d, pts[:, 0], pts[:, 1]).max() <= 1e-12


def test_s60_plate_runs_end_to_end(tmp_path):
    import yaml
    from pipeline.cli import main
    c, d, _ = s60_plate()
    curve = lambda k: {"degree": k.degree, "control_points": k.control_points.tolist(),  # noqa: E731
                       "weights": k.weights.tolist(), "knots": k.knots.tolist()}
    config = tmp_path / "s60.yaml"
    config.write_text(yaml.safe_dump({"name": "s60_plate", "units": "mm", "curves": {"c": curve(c), "d": curve(d)},
                                      "resolution": {"chord_tolerance": 1.0}}))
    assert main(["run", str(config), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    rep = json.loads((tmp_path / "o" / "s60_plate.json").read_text())
    assert rep["developability"]["passed"]
    assert rep["unroll"]["ruling_edge_max_relative_error"] <= 1e-12
    assert rep["developability"]["naive_max_abs_K_times_size_squared"] > rep["developability"]["curvature_limit"]
    assert rep["warnings"] and "partial coverage" in rep["warnings"][0]
    assert rep["steel"]["area_m2"] == pytest.approx(rep["unroll"]["area_3d"] / 1e6, rel=1e-3)


def test_a_partial_coverage_never_reads_100_percent():
    from pipeline.stages import partial_percent

    assert partial_percent(0.8966) == "89.66%"
    assert partial_percent(0.99996) == ">99.99%"  # the NAPA bilge plate read "partial coverage: 100.00%"
    assert partial_percent(0.99994) == "99.99%"
    assert partial_percent(1.0) == "100.00%"


def test_surface_distance_stops_each_point_when_it_settles_not_before():
    """SurfaceDistance's early stop is per point (a point whose Gauss-Newton move falls below
    the limit takes one more step): its distances are those of the full 12 steps, to
    round-off, for points near and off the Series 60 surface, and exact for points on it."""
    from flatten.closest import CONVERGED, SurfaceDistance

    surface = s60_surface()
    rng = np.random.default_rng(11)
    u = rng.uniform(*surface.domain_u, 3000)
    v = rng.uniform(*surface.domain_v, 3000)
    on = surface(u, v)
    size = float(np.ptp(on, axis=0).max())
    off = on + rng.normal(0.0, 2e-3 * size, on.shape)
    distance = SurfaceDistance(surface)
    for points in (on, off):
        _, early = distance.closest(points, converged=CONVERGED)
        _, full = distance.closest(points)
        np.testing.assert_allclose(early, full, atol=1e-9 * size)
    assert distance(on).max() <= 1e-9 * size


def test_distance_to_several_surfaces_is_the_nearest_ones():
    """A hull of several faces: SurfaceDistance searches a face for a point only where its
    seed grid could hold the closest point; the distance is still the least of the faces'
    own, for points near one face, near both and between them."""
    from flatten.closest import SurfaceDistance

    surface = s60_surface()
    size = float(np.ptp(surface.grid(np.linspace(*surface.domain_u, 9), np.linspace(*surface.domain_v, 9)).reshape(-1, 3),
                        axis=0).max())
    shifted = nurbs_surface(surface.degree_u, surface.degree_v, surface.poles + [0.3 * size, 0.0, 0.05 * size],
                            surface.knots_u, surface.knots_v, name="shifted")
    rng = np.random.default_rng(5)
    u = rng.uniform(*surface.domain_u, 2000)
    v = rng.uniform(*surface.domain_v, 2000)
    near_first, near_second = surface(u[:1000], v[:1000]), shifted(u[1000:], v[1000:])
    points = np.vstack([near_first, near_second]) + rng.normal(0.0, 0.05 * size, (2000, 3))
    both = SurfaceDistance([surface, shifted])(points)
    each = np.minimum(SurfaceDistance(surface)(points), SurfaceDistance(shifted)(points))
    np.testing.assert_allclose(both, each, atol=1e-9 * size)
