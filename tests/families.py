"""Curve pairs whose solution curve is hard to trace (issue 9), and an independent
enclosure of the zero set to judge the solver by.

The enclosure evaluates f = det[C, C', D, D'] directly from the homogeneous curves
(scipy B-splines and numpy determinants: no code of flatten.equation, plucker, certify
or tracer) on a grid, and labels the grid cells where f changes sign (marching squares).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.interpolate import insert

from flatten import nurbs_curve

S_POLES = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, -1.0, 0.0], [3.0, 0.0, 0.0]])
# tangent angle of the S: slope y'/x' = 6 t^2 - 6 t + 1, smallest (-1/2) at its inflection t = 1/2
S_ANGLE_MIN = float(np.arctan(-0.5))


def s_angle(t):
    return np.arctan(6.0 * t**2 - 6.0 * t + 1.0)


def rotate(points, angle, centre=(1.5, 0.0, 0.0)):
    p = np.asarray(points, dtype=float) - centre
    cos, sin = np.cos(angle), np.sin(angle)
    return np.column_stack([cos * p[:, 0] - sin * p[:, 1], sin * p[:, 0] + cos * p[:, 1], p[:, 2]]) + centre


def _finish(poles_c, poles_d, tilt, height, knots_extra=()):
    poles_d = np.array(poles_d, dtype=float)
    poles_d[:, 2] = height + tilt * poles_d[:, 0]
    c = nurbs_curve(poles_c, 3, name="c")
    d = nurbs_curve(poles_d, 3, name="d")
    if len(knots_extra):
        c, d = (refine(curve, knots_extra) for curve in (c, d))
    return c, d


def refine(curve, knots):
    """The same curve with extra knots (exact knot insertion): uneven spans."""
    pw = np.hstack([curve.control_points * curve.weights[:, None], curve.weights[:, None]])
    from scipy.interpolate import BSpline
    spline = BSpline(curve.knots, pw, curve.degree)
    for k in knots:
        spline = insert(k, spline)
    n = len(spline.t) - curve.degree - 1
    c = spline.c[:n]
    return nurbs_curve(c[:, :3] / c[:, 3:], curve.degree, weights=c[:, 3], knots=spline.t, name=curve.name)


def loop_pair(eps, tilt=0.0, height=1.0, knots_extra=()):
    """An S against its mirror image rotated so that the tangent-angle extrema nearly meet:
    on parallel planes Z is {θ(t) + θ(T) = 2 θ_min + eps}, a small loop about (1/2, 1/2)
    of radius ~ sqrt(eps / 4.8) for eps > 0, one point for eps = 0, nothing for eps < 0.
    ``tilt`` tilts d's plane (general case)."""
    mirrored = rotate(S_POLES * [1, -1, 1], 2 * S_ANGLE_MIN + eps)
    return _finish(S_POLES, mirrored, tilt, height, knots_extra)


def saddle_pair(gap, tilt=0.0, height=1.0):
    """An S against itself rotated by ``gap`` radians: Z = {θ(t) = θ(T) + gap} has a
    near-tangent saddle at (1/2, 1/2); the sign of gap picks which arms join."""
    return _finish(S_POLES, rotate(S_POLES, gap), tilt, height)


def hugging_pair(offset, rise=0.01, tilt=0.0, height=1.0):
    """Slopes y'/x' = offset + rise t on c and T on d: on parallel planes Z is the line
    T = offset + rise t, ``offset`` from the side T = 0 (outside it where negative)."""
    # c(t) = (3t, 3 offset t + 1.5 rise t^2), d(T) = (3T, 1.5 T^2): cubic Bezier poles
    def poles(a, b):  # x = 3t, y = a t + b t^2 in Bernstein form (degree 3)
        return np.array([[0.0, 0.0, 0.0], [1.0, a / 3, 0.0], [2.0, 2 * a / 3 + b / 3, 0.0], [3.0, a + b, 0.0]])
    return _finish(poles(3 * offset, 1.5 * rise), poles(0.0, 1.5) + [0.0, 0.5, 0.0], tilt, height)


def corner_pair(jump=0.3, tilt=0.0, height=1.0):
    """c turns left with a corner at t = 1/2 (knot of multiplicity 3) where its tangent
    angle jumps up by ``jump`` (about); d turns left smoothly through all of c's tangent
    angles. On parallel planes T(t) matches the angles and jumps at t = 1/2: a corner fan
    with apex c(1/2) joins the two one-sided roots."""
    turn = np.array([[np.cos(jump), -np.sin(jump)], [np.sin(jump), np.cos(jump)]])
    first = np.array([[0, 0], [1, 0], [2, 0.3], [3, 0.8]], dtype=float)
    second = np.array([[1, 0.5], [1.8, 1.4], [2.3, 2.9]], dtype=float) @ turn.T + first[-1]
    poles_c = np.column_stack([np.vstack([first, second]), np.zeros(7)])
    c = nurbs_curve(poles_c, 3, knots=[0, 0, 0, 0, 0.5, 0.5, 0.5, 1, 1, 1, 1], name="c")
    end = second[-1] - second[-2]
    poles_d = np.array([[0, 0, 0], [2, 0, 0], [3.5, 1, 0], [3.5 + 0.5 * end[0] / np.hypot(*end),
                                                              1 + 0.5 * end[1] / np.hypot(*end), 0]]) + [0.5, -1.0, 0]
    poles_d[:, 2] = height + tilt * poles_d[:, 0]
    return c, nurbs_curve(poles_d, 3, name="d")


# ------------------------------------------------------------ independent enclosure
def f_direct(c, d, t, T):
    """det[C(t), C'(t), D(T), D'(T)] from the homogeneous B-splines, any shape."""
    t, T = np.broadcast_arrays(np.asarray(t, float), np.asarray(T, float))
    hc = c.homogeneous_derivatives(t.ravel(), 1)
    hd = d.homogeneous_derivatives(T.ravel(), 1)
    m = np.stack([hc[0], hc[1], hd[0], hd[1]], axis=-1)
    return np.linalg.det(m).reshape(t.shape)


def sign_change_components(c, d, window=None, n=401):
    """Connected sets of grid cells where f changes sign, as a list of (K, 2) arrays of
    cell centres [t, T]; ``window`` = (t0, t1, T0, T1), default the whole rectangle."""
    t0, t1, T0, T1 = window or (*c.domain, *d.domain)
    t = np.linspace(t0, t1, n)
    T = np.linspace(T0, T1, n)
    sign = np.sign(f_direct(c, d, *np.meshgrid(t, T, indexing="ij")))
    corners = np.stack([sign[:-1, :-1], sign[1:, :-1], sign[:-1, 1:], sign[1:, 1:]])
    changes = (corners.max(axis=0) > 0) & (corners.min(axis=0) < 0) | np.any(corners == 0, axis=0)
    labels, count = ndimage.label(changes, structure=np.ones((3, 3)))
    tc, Tc = 0.5 * (t[1:] + t[:-1]), 0.5 * (T[1:] + T[:-1])
    out = []
    for k in range(1, count + 1):
        i, j = np.nonzero(labels == k)
        out.append(np.column_stack([tc[i], Tc[j]]))
    return out, (t[1] - t[0], T[1] - T[0])
