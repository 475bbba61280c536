"""Strips on awkward seams: a seam end with zero speed (a doubled end pole, as at a keel)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from flatten import DEFAULT_TOLERANCES, solve
from flatten.nurbs import nurbs_curve
from flatten.strip import build_strip, choose_rulings
from tests.shipped_configs import plain_uniform, with_files_from

SHIP = Path(__file__).parent / "data" / "ship"
ROOT = Path(__file__).resolve().parents[1]


def test_rulings_by_chord_tolerance_on_a_seam_with_a_zero_speed_end_are_finite():
    """c(0) = c'(0) = 0 (its first pole doubled): its curvature there is 0/0, which used to
    make the ruling count NaN and raise."""
    poles = np.array([[0, 0, 0], [0, 0, 0], [3000, 500, 0], [6000, 600, 0], [9000, 400, 0.0]])
    c = nurbs_curve(poles, 3)
    d = nurbs_curve(poles + [0, 300, 2000], 3)
    assert np.linalg.norm(c.derivatives(np.array([0.0]), 1)[1]) == 0.0
    solution = solve(c, d, DEFAULT_TOLERANCES)
    assert solution
    rulings = choose_rulings(solution, c, d, chord_tolerance=0.5)
    assert len(rulings) >= 2 and np.isfinite(rulings).all()
    strip = build_strip(c, d, rulings)
    assert np.isfinite(strip.vertices).all()
    assert max(strip.max_chord_error) <= 0.5


def _keel_plate(tmp_path):
    """The run of the 160 m hull's keel plate S01_B02 (seams v = 0 and 0.6337, butts 13.3 m
    and 26.7 m), a hand-laid strake of one plate."""
    import yaml

    from pipeline.hull.plan import load_run

    strake = {"surface": {"iges": str(SHIP / "test_1_hull_exported.igs")}, "margin": 0.2,
              "seams": [{"iso": {"v": 0.0}}, {"iso": {"v": 0.6337212004946158}}],
              "butts": [13333.333333333334, 26666.666666666668]}
    path = tmp_path / "keel.yaml"
    path.write_text(yaml.safe_dump({"name": "keel", "units": "mm", "strake": strake}))
    return load_run(path)


def test_the_curvature_check_ignores_round_off_on_the_160m_hull_keel_plate(tmp_path):
    """The keel plate S01_B02 of the 160 m hull (seams v = 0 and 0.6337, butts 13.3 m and
    26.7 m): its strip between the seams is developable (residual 2e-15), but its angle
    defects are round-off (5e-11 rad at vertices 13 to 27 m from the origin) and, divided by
    the Voronoi areas of corner rulings a few mm apart, read as |K| size^2 = 2.4e-5, above
    the 1e-6 limit. Only the defect above the round-off floor of the vertex positions counts."""
    from pipeline.stages import PartResult, develop_part
    from pipeline.hull.strake import corner_rulings

    config = _keel_plate(tmp_path)
    part = config.parts[0]
    result = PartResult(part.name, part)
    assert develop_part(result, config, lambda sol: corner_rulings(sol, part.c, part.d, part.hull.butts), 0.0), \
        result.reason
    check = result.figures["developability"]
    size = float(np.ptp(result.strip.vertices, axis=0).max())
    assert check["passed"] and check["max_residual"] < 1e-12
    assert check["mesh"]["max_angle_defect"] < 1e-9  # round-off, not curvature
    assert check["mesh"]["max_abs_gaussian_curvature_raw"] * size**2 > 1e-6  # what the check used to see


def test_a_butt_corner_the_strip_does_not_reach_keeps_its_ruling_on_the_strip(tmp_path):
    """The keel plate S01_B08 of the 160 m hull's uniform shell plan (seams v = 0 and 0.6337,
    butts 93.3 m and 106.7 m): the seams' strip ends at t = -5.99 (its rulings lean), short of
    the aft butt's crossing of c at -5.86, while the butt crosses d inside the path. Newton on
    f(., T) from the path's t there left the domain (t = 3.6e11: f is nearly flat in t over the
    flat keel) and the corner ruling evaluated the curves at it: a divide by zero, NaN
    points, and the family reported as raised. The corner now keeps the path's t there."""
    import warnings

    import yaml

    from pipeline.hull.plan import load_run
    from pipeline.stages import PartResult, develop_part
    from pipeline.hull.strake import corner_rulings

    data = plain_uniform(yaml.safe_load((ROOT / "configs" / "hull160_shell.yaml").read_text()))
    data = with_files_from(data, ROOT / "configs")
    path = tmp_path / "hull160.yaml"
    path.write_text(yaml.safe_dump(data))
    config = load_run(path)
    part = next(p for p in config.parts if p.name.endswith("S01_B08"))
    solutions = []

    def corners(solution):
        solutions.append(solution)
        return corner_rulings(solution, part.c, part.d, part.hull.butts)

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        develop_part(PartResult(part.name, part), config, corners, 0.0)
        extra = corners(solutions[0])
    path_t = solutions[0].path.points[:, 0]
    assert path_t.max() < -5.9  # the strip stops short of the aft butt on c
    assert np.isfinite(extra).all()
    lo, hi = part.c.domain
    assert (extra[:, 0] >= 2 * lo - hi).all() and (extra[:, 0] <= 2 * hi - lo).all()


def test_the_curvature_check_still_fails_a_strip_that_is_not_developable():
    """The naive ruled surface T = t between two skew lines (a hyperbolic paraboloid, K < 0
    everywhere) at the same distance from the origin: its |K| size^2 is far above the limit
    with or without the round-off floor."""
    from flatten.meshcheck import strip_angle_defects
    from flatten.nurbs import nurbs_curve as curve

    offset = 160000.0
    c = curve(np.array([[offset, 0, 0], [offset + 14000.0, 0, 0]]), 1)
    d = curve(np.array([[offset, 1500.0, 0.0], [offset + 14000.0, 1500.0, 900.0]]), 1)
    t = np.linspace(0, 1, 257)
    strip = build_strip(c, d, np.column_stack([t, t]), 5)
    size = float(np.ptp(strip.vertices, axis=0).max())
    figures = strip_angle_defects(strip)
    assert figures.max_abs_K * size**2 > 1e-2
    assert figures.max_abs_K == pytest.approx(figures.max_abs_K_raw, rel=1e-3)
    # closed form at the middle of the saddle z = 900 x y / (14000 1500): K = -a^2 / (1 + ...)^2
    a = 900.0 / (14000.0 * 1500.0)
    assert figures.max_abs_K <= 1.01 * a**2


def test_collapsed_triangles_give_no_nan_curvature():
    """Seams meeting at an end (a ruling of zero length there) make zero-area triangles, whose
    angles and Voronoi areas libigl returns as NaN, at different vertices: the check read
    |K| = NaN and failed the strip (DTMB 5415 plates, the issue's converging seams). They carry
    no curvature and are left out; the triangles around them still count."""
    from flatten.meshcheck import angle_defects, strip_angle_defects
    from flatten.nurbs import nurbs_curve as curve

    poles = np.array([[0, 0, 0], [3000, 800, 0], [6000, 900, 0], [9000, 500, 0.0]])
    c = curve(poles, 3)
    d = curve(poles + np.array([[0, 0, 0], [0, 200, 1500], [0, -300, 1500], [0, 200, 900]]), 3)  # twisted
    t = np.linspace(0, 1, 41)
    strip = build_strip(c, d, np.column_stack([t, t]), 5)
    figures = strip_angle_defects(strip)
    assert np.isfinite(figures.max_abs_K) and np.isfinite(figures.max_abs_K_raw) and figures.interior_vertices > 100
    # the same strip without the collapsed end ruling: the same largest |K| (it lies inside)
    inner = build_strip(c, d, np.column_stack([t[1:], t[1:]]), 5)
    assert figures.max_abs_K >= 0.99 * angle_defects(inner.vertices, inner.faces).max_abs_K > 0


def test_the_naive_surfaces_figures_owed_by_a_strip_attempt_are_those_of_the_checked_strip(tmp_path, monkeypatch):
    """A hull plate's strip attempts leave the naive surface T = t's figures (a reference
    that judges nothing) owed; where a strip is delivered they are filled in as the check
    would have: the same figures, at the size of the strip it checked. A reference that
    raises is recorded and fails nothing."""
    from pipeline import stages
    from pipeline.hull.strake import corner_rulings
    from pipeline.stages import PartResult, develop_part, naive_check

    config = _keel_plate(tmp_path)
    part = config.parts[0]
    corners = lambda sol: corner_rulings(sol, part.c, part.d, part.hull.butts)
    at_once, owed = PartResult(part.name, part), PartResult(part.name, part)
    assert develop_part(at_once, config, corners, 0.0) and develop_part(owed, config, corners, 0.0, naive=False)
    assert owed.figures["developability"]["naive_T_equals_t"] is None and owed.naive_size is not None
    owed.strip = dataclasses.replace(owed.strip, vertices=owed.strip.vertices[: len(owed.strip.vertices) // 2])
    naive_check(owed)  # after the strip changed (a seam strip is trimmed by its butts)
    assert list(owed.figures["developability"].items()) == list(at_once.figures["developability"].items())
    assert owed.naive_size is None and at_once.naive_size is None

    def broken(*args):
        raise RuntimeError("no mesh")

    monkeypatch.setattr(stages, "naive_reference", broken)
    failing = PartResult(part.name, part)
    assert develop_part(failing, config, corners, 0.0, naive=False)
    naive_check(failing)
    assert failing.figures["developability"]["naive_T_equals_t"] == {"error": "RuntimeError: no mesh"}
    assert failing.figures["developability"]["passed"]
