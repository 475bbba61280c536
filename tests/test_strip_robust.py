"""Strips on awkward seams: a seam end with zero speed (a doubled end pole, as at a keel)."""

from __future__ import annotations

import numpy as np

from flatten import DEFAULT_TOLERANCES, solve
from flatten.nurbs import nurbs_curve
from flatten.strip import build_strip, choose_rulings


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
