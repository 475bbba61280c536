"""Curve pairs with closed-form answers (DESIGN §1.6), shared by the tests."""

from __future__ import annotations

import numpy as np

from flatten import nurbs_curve


def multispan_cubic(seed: int = 3, n_points: int = 8):
    """A non-planar cubic with non-uniform interior knots (5 spans)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n_points)
    points = np.column_stack([4.0 * t, np.sin(3.0 * t) + 0.3 * rng.normal(size=n_points),
                              0.5 * np.cos(2.0 * t) + 0.2 * rng.normal(size=n_points)])
    knots = [0, 0, 0, 0, 0.15, 0.35, 0.4, 0.7, 1, 1, 1, 1]
    return nurbs_curve(points, 3, knots=knots, name="c")


def cylinder_pair(seed: int = 3):
    c = multispan_cubic(seed)
    d = nurbs_curve(c.control_points + np.array([0.2, 0.4, 2.0]), 3, knots=c.knots, name="d")
    return c, d


def cone_pair(seed: int = 3, apex=(1.0, -2.0, 5.0), scale: float = 0.45):
    c = multispan_cubic(seed)
    apex = np.asarray(apex, dtype=float)
    d = nurbs_curve(apex + scale * (c.control_points - apex), 3, knots=c.knots, name="d")
    return c, d


def circular_arc(radius: float, height: float, angle: float, n_spans: int = 1, name: str = "c"):
    """Exact rational quadratic arc about the z axis from angle 0 to ``angle``."""
    step = angle / n_spans
    points, weights = [], []
    for k in range(n_spans):
        a0 = k * step
        mid = a0 + step / 2
        if k == 0:
            points.append([radius * np.cos(a0), radius * np.sin(a0), height])
            weights.append(1.0)
        r_mid = radius / np.cos(step / 2)
        points.append([r_mid * np.cos(mid), r_mid * np.sin(mid), height])
        weights.append(np.cos(step / 2))
        points.append([radius * np.cos(a0 + step), radius * np.sin(a0 + step), height])
        weights.append(1.0)
    inner = np.repeat(np.arange(1, n_spans) / n_spans, 2)
    knots = np.concatenate([[0, 0, 0], inner, [1, 1, 1]])
    return nurbs_curve(points, 2, weights=weights, knots=knots, name=name)


def frustum_pair(r1=3.0, r2=2.0, h=1.5, angle=2 * np.pi / 3, n_spans=1):
    return (circular_arc(r1, 0.0, angle, n_spans, "c"), circular_arc(r2, h, angle, n_spans, "d"))


def s_and_c_curves():
    """An S (inflection at t = 1/2) in z = 0 against a C in z = 1: polynomial cubics."""
    s_curve = nurbs_curve([[-1, -1, 0], [-1 / 3, 1, 0], [1 / 3, -1, 0], [1, 1, 0]], 3, name="c")
    c_curve = nurbs_curve([[-1, 1, 1], [-1 / 3, -1 / 3, 1], [1 / 3, -1 / 3, 1], [1, 1, 1]], 3, name="d")
    return s_curve, c_curve


def c_and_mirror():
    """A C-curve in z = 0 and its mirror image (bending the other way) in z = 1."""
    x = np.linspace(-1.0, 1.0, 6)
    c = nurbs_curve(np.column_stack([x, x**2, 0 * x]), 3, name="c")
    d = nurbs_curve(np.column_stack([x, 3.0 - x**2, 0 * x + 1.0]), 3, name="d")
    return c, d


def planar_cubics_on_parallel_planes(seed: int = 0, height: float = 1.2):
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 3.0, 6)
    c = nurbs_curve(np.column_stack([x, 0.6 * np.sin(x) + 0.1 * rng.normal(size=6), 0 * x]), 3, name="c")
    d = nurbs_curve(np.column_stack([x * 1.1 - 0.1, 0.5 * np.sin(x) + 0.8 + 0.1 * rng.normal(size=6),
                                     0 * x + height]), 3, name="d")
    return c, d


def skew_lines():
    return (nurbs_curve([[0, 0, 0], [2, 0, 0]], 1, name="c"),
            nurbs_curve([[0, 0, 1], [0, 2, 1]], 1, name="d"))
