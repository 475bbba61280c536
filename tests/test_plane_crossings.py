"""Where NURBS curves cross planes (flatten.plane.plane_crossings): only the spans that may
meet the plane are solved, and the roots are bit for bit those of solving every span."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import PPoly

from flatten.nurbs import nurbs_curve
from flatten.plane import Plane, clear_of_zero, plane_crossings


def every_span_crossings(curve, plane):
    """The crossings with every span of the curve solved (the reference)."""
    spans = curve.power_coefficients
    coef = spans[:, :, :3] @ np.asarray(plane.normal, dtype=float) - plane.offset * spans[:, :, 3]
    widths = np.diff(curve.breakpoints)
    taylor = (coef / widths[:, None] ** np.arange(curve.degree + 1)).T[::-1]
    roots = PPoly(taylor, curve.breakpoints, extrapolate=False).roots(extrapolate=False)
    lo, hi = curve.domain
    return np.unique(roots[(roots >= lo) & (roots <= hi)])


def wavy_curve(seed: int, degree: int, n_poles: int, rational: bool):
    """A curve along x with y, z waving, random interior knots (some doubled) and weights."""
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.uniform(0.5, 3.0, n_poles)) * 1000.0
    poles = np.column_stack([x, 800.0 * np.sin(x / 1500.0 + seed), 300.0 * rng.normal(size=n_poles)])
    inner = np.sort(rng.uniform(0.0, 1.0, n_poles - degree - 1))
    if len(inner) > 2 and degree > 1:
        inner[1] = inner[0]  # a doubled knot: a kink the root finder meets at a breakpoint
    knots = np.concatenate([np.zeros(degree + 1), inner, np.ones(degree + 1)])
    weights = rng.uniform(0.5, 2.0, n_poles) if rational else None
    return nurbs_curve(poles, degree, weights, knots)


@settings(max_examples=40, derandomize=True, deadline=None)
@given(seed=st.integers(0, 10_000), degree=st.integers(1, 5), extra=st.integers(1, 40), rational=st.booleans())
def test_crossings_are_bit_for_bit_those_of_every_span(seed, degree, extra, rational):
    curve = wavy_curve(seed, degree, degree + 1 + extra, rational)
    rng = np.random.default_rng(seed + 1)
    lo, hi = curve.domain
    ts = np.concatenate([rng.uniform(lo, hi, 6), curve.breakpoints])  # through breakpoints too
    planes = []
    for point, tangent in zip(curve(ts), curve.derivatives(ts, 1)[1]):
        normal = rng.normal(size=3)
        planes += [Plane((1.0, 0.0, 0.0), float(point[0])),  # a butt through the point
                   Plane(tuple(normal / np.linalg.norm(normal)), float(normal @ point / np.linalg.norm(normal)))]
        # a plane holding the tangent: the curve touches it there (a double root, or none)
        side = np.cross(tangent, rng.normal(size=3))
        side /= np.linalg.norm(side)
        planes.append(Plane(tuple(side), float(side @ point)))
    planes.append(Plane((1.0, 0.0, 0.0), float(curve(np.array([lo]))[0, 0]) - 10.0))  # missed
    for plane in planes:
        got, want = plane_crossings(curve, plane), every_span_crossings(curve, plane)
        assert got.dtype == want.dtype and np.array_equal(got, want), (plane, got, want)


def test_a_curve_along_the_plane_reports_its_spans_as_the_root_finder_does():
    # y = 0 on the first half of a degree-1 polyline: its spans there are identically zero
    poles = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 1.0, 0.0], [4.0, 2.0, 0.0]])
    curve = nurbs_curve(poles, 1)
    plane = Plane((0.0, 1.0, 0.0), 0.0)
    assert np.array_equal(plane_crossings(curve, plane), every_span_crossings(curve, plane))


def test_crossings_of_a_line_are_where_it_reaches_the_plane():
    # a straight cubic along x, its poles at the knots' Greville abscissae: x(t) = 10 000 t
    knots = np.concatenate([np.zeros(4), np.linspace(0.0, 1.0, 10)[1:-1] ** 1.5, np.ones(4)])
    greville = np.array([knots[i + 1:i + 4].mean() for i in range(len(knots) - 4)])
    curve = nurbs_curve(np.column_stack([10_000.0 * greville, np.zeros_like(greville), np.zeros_like(greville)]), 3,
                        None, knots)
    lo, hi = curve.domain
    for x in (0.0, 1234.5, 5000.0, 9999.0):
        (t,) = plane_crossings(curve, Plane((1.0, 0.0, 0.0), x))
        assert abs(curve(np.array([t]))[0, 0] - x) <= 1e-9 * 10_000.0
        assert abs(t - (lo + (hi - lo) * x / 10_000.0)) <= 1e-12
    assert plane_crossings(curve, Plane((1.0, 0.0, 0.0), 10_001.0)).size == 0


def test_clear_of_zero_never_clears_a_polynomial_that_vanishes_on_the_unit_interval():
    rng = np.random.default_rng(7)
    coef = rng.normal(size=(20_000, 4)) * 10.0 ** rng.integers(-3, 4, size=(20_000, 1))
    coef[:, 0] *= rng.uniform(0.0, 6.0, 20_000)  # some clear, some not
    clear = clear_of_zero(coef)
    s = np.linspace(0.0, 1.0, 401)
    values = coef @ s ** np.arange(4)[:, None]  # (N, 401)
    assert 0.2 < clear.mean() < 0.9
    assert np.all(np.abs(values[clear]) > 0.0)
    assert np.all((values[clear] > 0) == (coef[clear, :1] > 0))  # c_0's sign throughout
    assert not clear_of_zero(np.array([[np.nan, 0.0, 0.0], [1.0, np.nan, 0.0]])).any()
    assert not clear_of_zero(np.zeros((1, 4))).any()
