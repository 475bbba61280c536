"""NURBS curves: evaluation against closed forms, spans, arc length, validation."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from flatten import InvalidCurveError, nurbs_curve
from flatten.errors import DevflatError
from flatten.nurbs import MAX_WEIGHT_RATIO
from tests.oracles import circular_arc, multispan_cubic


def test_rational_arc_lies_on_circle_with_exact_length():
    arc = circular_arc(2.5, 0.7, 3 * np.pi / 2, n_spans=3)
    t = np.linspace(0, 1, 101)
    p = arc(t)
    np.testing.assert_allclose(np.hypot(p[:, 0], p[:, 1]), 2.5, rtol=1e-14)
    np.testing.assert_allclose(p[:, 2], 0.7, atol=1e-15)
    assert arc.length == pytest.approx(2.5 * 3 * np.pi / 2, rel=1e-12)
    assert arc.is_rational


def test_derivatives_match_finite_differences():
    arc = circular_arc(1.3, 0.0, 2.0, n_spans=2)
    t = np.array([0.1, 0.37, 0.81])
    h = 1e-5
    _, d1, d2 = arc.derivatives(t, 2)
    np.testing.assert_allclose(d1, (arc(t + h) - arc(t - h)) / (2 * h), rtol=1e-8)
    np.testing.assert_allclose(d2, (arc(t + h) - 2 * arc(t) + arc(t - h)) / h**2, rtol=1e-4)
    # curvature of a circle is 1/r everywhere
    np.testing.assert_allclose(arc.curvature(t), 1 / 1.3, rtol=1e-12)


def test_power_and_bezier_spans_reproduce_the_curve():
    c = multispan_cubic()
    power = c.power_coefficients
    bez = c.bezier_control_points
    assert power.shape == (c.n_spans, 4, 4)
    b = c.breakpoints
    for i in range(c.n_spans):
        s = np.linspace(0, 1, 7)
        t = b[i] + s * (b[i + 1] - b[i])
        hom = (s[:, None] ** np.arange(4)) @ power[i]
        np.testing.assert_allclose(hom, c.homogeneous(t), atol=1e-13)
        # Bezier end points are curve points (homogeneous)
        np.testing.assert_allclose(bez[i, 0], c.homogeneous(b[i]), atol=1e-13)
        np.testing.assert_allclose(bez[i, -1], c.homogeneous(b[i + 1]), atol=1e-13)


def test_arc_length_inverse_and_reversal():
    c = multispan_cubic()
    s = np.linspace(0, c.length, 9)
    t = c.parameter_at_length(s)
    np.testing.assert_allclose(c.arc_length_at(t), s, atol=1e-12 * c.length)
    r = c.reversed()
    lo, hi = c.domain
    np.testing.assert_allclose(r(lo + hi - t), c(t), atol=1e-14)
    assert r.length == pytest.approx(c.length, rel=1e-13)


def test_knot_continuity_classes():
    c = nurbs_curve(np.random.default_rng(0).normal(size=(7, 3)), 3,
                    knots=[0, 0, 0, 0, 0.3, 0.3, 0.6, 1, 1, 1, 1])
    assert list(c.knot_continuity()) == [1, 2]


GOOD = dict(control_points=[[0, 0, 0], [1, 0, 0], [2, 1, 0], [3, 1, 1]], degree=3)

BAD_CURVES = [
    (dict(GOOD, knots=[0, 0, 0, 0, 1, 1, 1]), "knots has 7 values"),
    (dict(GOOD, knots=[0, 0, 0, 0.5, 0.4, 1, 1, 1]), "knots[4] = 0.4 < knots[3] = 0.5"),
    (dict(GOOD, weights=[1, 0, 1, 1]), "weights[1] must be finite and > 0, got 0"),
    (dict(GOOD, weights=[1, 1, -2, 1]), "weights[2] must be finite and > 0, got -2"),
    (dict(GOOD, weights=[1, 1, 1]), "weights has 3 values for 4 control points"),
    (dict(GOOD, control_points=[[0, 0, 0], [1, np.nan, 0], [2, 1, 0], [3, 1, 1]]),
     "control_points[1][1] is not finite: nan"),
    (dict(GOOD, control_points=[[0, 0, 0], [1, 0, 0], [2, 1, 0]]), "has 3 points; degree 3 needs at least 4"),
    (dict(GOOD, control_points=[[1, 2, 3]] * 4), "zero length"),
    (dict(GOOD, control_points=[[0, 0], [1, 0], [2, 1], [3, 1]]), "shape (n, 3)"),
    (dict(GOOD, degree=0), "degree must be >= 1, got 0"),
    (dict(GOOD, degree=2.5), "degree must be an integer, got 2.5"),
    (dict(GOOD, knots=[0, 0, 0, 0, np.inf, 1, 1, 1]), "knots[4] is not finite: inf"),
    (dict(GOOD, knots=[1, 1, 1, 1, 1, 1, 1, 1]), "empty domain"),
]


@pytest.mark.parametrize("kwargs, message", BAD_CURVES)
def test_invalid_curves_name_field_and_value(kwargs, message):
    with pytest.raises(InvalidCurveError) as info:
        nurbs_curve(name="curves.c", **kwargs)
    assert message in str(info.value)
    assert "curves.c" in str(info.value)
    assert isinstance(info.value, ValueError) and isinstance(info.value, DevflatError)


@settings(max_examples=60, derandomize=True, deadline=None)
@given(weights=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=5, max_size=5))
def test_weights_are_accepted_only_when_positive_and_finite(weights):
    points = np.arange(15, dtype=float).reshape(5, 3) ** 1.5
    w = np.array(weights)
    if np.all(np.isfinite(w)) and np.all(w > 0) and w.max() <= MAX_WEIGHT_RATIO * w.min():
        curve = nurbs_curve(points, 3, weights=weights)
        assert np.all(np.isfinite(curve(np.linspace(0, 1, 5))))
    else:
        with pytest.raises(InvalidCurveError, match=r"weights\[\d\]"):
            nurbs_curve(points, 3, weights=weights)


@settings(max_examples=60, derandomize=True, deadline=None)
@given(knots=st.lists(st.floats(-2, 2), min_size=9, max_size=9))
def test_random_knot_vectors_are_validated(knots):
    points = np.random.default_rng(1).normal(size=(5, 3))
    u = np.array(knots)
    try:
        curve = nurbs_curve(points, 3, knots=knots)
    except InvalidCurveError as err:
        assert "knots" in str(err)
        return
    assert np.all(np.diff(u) >= 0)
    lo, hi = curve.domain
    assert hi > lo
    assert np.all(np.isfinite(curve(np.linspace(lo, hi, 5))))


@pytest.mark.parametrize("degree", [3, 8, 9, 12])
def test_piecewise_polynomial_of_high_degree_splines_without_fitpack(degree):
    """x^p is the last Bernstein polynomial: one piece with the single coefficient 1 (scipy's
    PPoly.from_spline crashes the interpreter from degree 8 on)."""
    from scipy.interpolate import BSpline

    from flatten.nurbs import ppoly_from_spline

    coef = np.zeros(degree + 1)
    coef[-1] = 1.0
    pp = ppoly_from_spline(BSpline(np.r_[np.zeros(degree + 1), np.ones(degree + 1)], coef, degree))
    expected = np.zeros((degree + 1, 1))
    expected[0, 0] = 1.0
    assert np.allclose(pp.c, expected, atol=1e-12)
    assert np.allclose(pp.x, [0.0, 1.0])
    # two spans with a double knot: the pieces agree with the spline's own values
    t = np.r_[np.zeros(degree + 1), 0.4, 0.4, np.ones(degree + 1)]
    spline = BSpline(t, np.random.default_rng(degree).normal(size=len(t) - degree - 1), degree)
    x = np.linspace(0, 1, 41)
    assert np.allclose(ppoly_from_spline(spline)(x), spline(x), atol=1e-12)


def test_weights_equal_but_for_round_off_keep_the_quotient_rule():
    """Derivatives of a polynomial curve skip the weight's derivatives (all zero), but only
    when the weights are the same float: weights 1e-14 apart (is_rational's tolerance calls
    them equal) have a derivative that, times coordinates of 1e6, is no round-off (the
    shortcut was off by 1e-8 there). c' against the quotient rule (A' w - A w') / w^2."""
    from flatten.nurbs import nurbs_curve

    points = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 0.5], [3.0, 1.0, -1.0], [4.0, 3.0, 0.0]]) + 1e6
    for weights, rational in (([1.0, 1.0, 1.0, 1.0], False), ([1.0, 1.0 + 0.99e-14, 1.0, 1.0], False)):
        curve = nurbs_curve(points, degree=3, weights=weights)
        assert curve.is_rational is rational
        t = np.linspace(*curve.domain, 9)
        hom = curve.homogeneous_derivatives(t, 1)
        a, w = hom[..., :3], hom[..., 3:]
        quotient = (a[1] * w[0] - a[0] * w[1]) / w[0] ** 2
        got = curve.derivatives(t, 1)[1]
        assert np.abs(got - quotient).max() <= 1e-12 * np.abs(quotient).max()
