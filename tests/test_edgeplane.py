"""The edge-held plane (flatten/edgeplane.py) against closed forms: a dome over a planar rim,
z = s (1 - (x/w)^2)(1 - (y/l)^2), bulges by s over its rim's plane z = 0. Among the planes within
a tolerance tol of every point, the rim's plane keeps the edges on the surface when tol >= s;
for s/2 <= tol < s the plane must rise to z = s - tol (the peak within tol), its edges s - tol
off; below s/2 no plane fits (the minimax plane's half-width is s/2)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flatten.edgeplane import edge_held_plane
from flatten.minimax import minimax_plane


def dome(s=4.0, w=1500.0, l=6000.0, tilt=0.3, shift=(100.0, 200.0, 300.0), n=(31, 61)):
    x, y = np.meshgrid(np.linspace(-w, w, n[0]), np.linspace(-l, l, n[1]), indexing="ij")
    z = s * (1 - (x / w) ** 2) * (1 - (y / l) ** 2)
    rotation = np.array([[1, 0, 0], [0, np.cos(tilt), -np.sin(tilt)], [0, np.sin(tilt), np.cos(tilt)]])
    points = np.c_[x.ravel(), y.ravel(), z.ravel()] @ rotation.T + np.asarray(shift)
    edge = np.zeros(x.shape, dtype=bool)
    edge[0] = edge[-1] = edge[:, 0] = edge[:, -1] = True
    return points, edge.ravel(), rotation


@pytest.mark.parametrize("tol, edge_off", [(5.0, 0.0), (4.0, 0.0), (3.0, 1.0), (2.5, 1.5), (2.0, 2.0)])
def test_a_dome_gets_its_rims_plane_or_the_plane_raised_by_what_the_tolerance_demands(tol, edge_off):
    points, edge, rotation = dome()
    fit = edge_held_plane(points, edge, tol, start=minimax_plane(points))
    assert fit is not None
    assert fit.edge_max_distance == pytest.approx(edge_off, abs=1e-6)
    assert fit.max_distance <= tol * (1 + 1e-9)
    assert abs(abs(fit.normal @ rotation[:, 2]) - 1.0) < 1e-12  # the rim's normal, turned by the tilt


def test_no_plane_within_less_than_half_the_bulge():
    points, edge, _ = dome(s=4.0)
    assert edge_held_plane(points, edge, 1.9) is None


def test_the_edges_are_never_further_off_than_on_the_minimax_plane():
    rng = np.random.default_rng(7)
    points, edge, _ = dome(s=3.0)
    points = points + rng.normal(scale=0.3, size=points.shape)
    mm = minimax_plane(points)
    fit = edge_held_plane(points, edge, 5.0, start=mm)
    assert fit.edge_max_distance <= np.abs(mm.distances[edge]).max() + 1e-9
    assert fit.max_distance <= 5.0 * (1 + 1e-9)


@settings(max_examples=30, deadline=None, derandomize=True)
@given(s=st.floats(0.5, 8.0), tol=st.floats(0.3, 10.0), tilt=st.floats(-1.2, 1.2))
def test_property_within_the_tolerance_and_closed_form(s, tol, tilt):
    points, edge, _ = dome(s=s, tilt=tilt, n=(13, 21))
    fit = edge_held_plane(points, edge, tol)
    if tol < 0.5 * s * (1 - 1e-6):
        assert fit is None
        return
    if tol > 0.5 * s * (1 + 1e-6):
        assert fit is not None
        assert fit.max_distance <= tol * (1 + 1e-9)
        assert fit.edge_max_distance == pytest.approx(max(0.0, s - tol), abs=1e-6 * (1 + s))


@pytest.mark.parametrize("points, edge, tol, field", [
    (np.zeros((2, 3)), np.ones(2, bool), 1.0, "points"),
    (np.zeros((5, 2)), np.ones(5, bool), 1.0, "points"),
    (np.eye(3), np.zeros(3, bool), 1.0, "edge"),
    (np.eye(3), np.ones(3, bool), 0.0, "tolerance"),
    (np.eye(3), np.ones(3, bool), float("nan"), "tolerance"),
])
def test_bad_input_names_the_argument_and_value(points, edge, tol, field):
    with pytest.raises(ValueError, match=field):
        edge_held_plane(points, edge, tol)
