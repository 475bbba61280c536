"""Erection pulls (strake.pull_steps): flat and strip plates that step pulled together elastically."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.hull.fitup import Edge, PlateEdges
from pipeline.hull.pull import (
    DEGREE,
    PULL_STRAIN,
    PullField,
    bending,
    check_pull,
    plate_frame,
    solve_pulls,
)
from pipeline.shop.rolling import E_STEEL, NU_STEEL
from tests.test_fitup_repair import shoulder


def _grid(nx: int, ny: int, h: float):
    """A flat grid of nx x ny points h apart in z = 0 (points (nx * ny, 3), faces)."""
    x, y = np.meshgrid(np.arange(nx) * h, np.arange(ny) * h, indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    idx = np.arange(nx * ny).reshape(nx, ny)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return points, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


def _rolled(points: np.ndarray, radius: float) -> np.ndarray:
    """The flat grid rolled (isometrically) onto the cylinder of ``radius`` about the y axis."""
    angle = points[:, 0] / radius
    return np.column_stack([radius * np.sin(angle), points[:, 1], radius * (1.0 - np.cos(angle))])


@settings(max_examples=30, deadline=None, derandomize=True)
@given(radius=st.floats(2000.0, 50000.0), spacing=st.floats(50.0, 300.0), unit=st.sampled_from([1.0, 1000.0]))
def test_a_grid_rolled_to_a_cylinder_bends_by_one_over_its_radius(radius, spacing, unit):
    # the edges along the axis join faces of neighbouring chords: their dihedral angle is the
    # chord's central angle h / R, and h * (h / R) / h^2 = 1 / R exactly; every other edge
    # joins two faces of one planar chord strip
    points, faces = _grid(8, 6, spacing)
    kappa = bending(points / unit, _rolled(points, radius) / unit, faces)
    assert kappa.max() == pytest.approx(unit / radius, rel=1e-9)
    assert np.sort(kappa)[: len(kappa) // 2].max() < 1e-9 * unit / radius


def test_a_flat_grid_keeps_its_curvature_under_a_rigid_motion():
    points, faces = _grid(6, 6, 100.0)
    turn = np.array([[np.cos(0.3), -np.sin(0.3), 0.0], [np.sin(0.3), np.cos(0.3), 0.0], [0.0, 0.0, 1.0]])
    assert bending(points, points @ turn.T + [5.0, -2.0, 7.0], faces).max() < 1e-12


def _plate(name: str, x0: float, lift: float, unit: float):
    """A flat square plate 1000 mm wide at x0..x0 + 1000, z = lift (mm), in model units of
    ``unit`` mm: its mesh, its edges (butt0 at x0, butt1 at x0 + 1000) and a record."""
    points, faces = _grid(11, 11, 100.0)
    points = (points + [x0, 0.0, lift]) / unit
    ys = np.linspace(0.0, 1000.0, 21) / unit

    def edge(side, x):
        p3 = np.column_stack([np.full_like(ys, x / unit), ys, np.full_like(ys, lift / unit)])
        return Edge(side, side.upper(), p3, p3[:, :2])

    edges = PlateEdges(name, "flat", True, (edge("butt0", x0), edge("butt1", x0 + 1000.0)), points[:, :])
    return points, faces, edges


@pytest.mark.parametrize("unit", [1.0, 1000.0])
@pytest.mark.parametrize("lift", [4.0, 8.0])
def test_two_flat_plates_that_step_are_pulled_to_meet_on_the_hull(monkeypatch, unit, lift):
    # two flat plates 1 m square side by side, the right one `lift` mm above the left, the hull
    # the plane halfway between: pulled together they meet across their butt, each edge
    # drawn onto the hull (their meeting and their nearness to the hull agree: both on it)
    from pipeline.hull import pull

    hull_z = 0.5 * lift / unit
    monkeypatch.setattr(pull, "hull_points", lambda hull, p: np.column_stack([p[:, 0], p[:, 1], np.full(len(p), hull_z)]))
    left, faces, left_edges = _plate("L", 0.0, 0.0, unit)
    right, _, right_edges = _plate("R", 1000.0, lift, unit)
    records = {"L": (left_edges, SimpleNamespace(hull=None)), "R": (right_edges, SimpleNamespace(hull=None))}
    pairs = [SimpleNamespace(a="L", b="R", side_a="butt1", side_b="butt0", step_max=lift, limit=2.1)]
    frames = {"L": plate_frame(left, faces), "R": plate_frame(right, faces)}
    pulls = solve_pulls(frames, ["L", "R"], records, pairs, unit, {"L": faces, "R": faces})
    met_left = pulls["L"].apply(left_edges.edge("butt1").points3)
    met_right = pulls["R"].apply(right_edges.edge("butt0").points3)
    assert np.abs(met_left - met_right).max() * unit < 0.05 * lift
    assert np.abs(met_left[:, 2] - hull_z).max() * unit < 0.05 * lift
    # each plate bends: its far edge stays near where it was (nothing pulls it), its butt goes
    # half the step: a curvature of a fraction of a millimetre per metre, well inside the limits
    for name, points in (("L", left), ("R", right)):
        check = check_pull(points, faces, (pulls[name],), lambda p: np.abs(p[:, 2] - hull_z), 5.0 / unit, 14.0,
                           "AH36", unit)
        assert check.share == 1.0 and not check.refused
        assert 0.45 * lift < check.largest_pull_mm < 0.6 * lift
        assert check.distance_mm <= 0.5 * lift + 1e-6 and check.strain < PULL_STRAIN
        # the root mean square is of the same pulled points as the largest distance
        gaps = np.abs(pulls[name].apply(points)[:, 2] - hull_z)
        assert check.distance == pytest.approx(gaps.max())
        assert check.rms_distance == pytest.approx(np.sqrt(np.mean(gaps ** 2)))


K = (DEGREE + 1) ** 2  # the pull's polynomial terms


def _term(i: int, j: int = 0) -> int:
    """The index of the term u^i v^j among the pull's K."""
    return i * (DEGREE + 1) + j


def _field(points: np.ndarray, coefficients: np.ndarray) -> PullField:
    """A pull in plain coordinates (u, v) = (x, y), model units, along +z normals."""
    return PullField(np.zeros(3), np.eye(3)[:2], np.zeros(2), np.ones(2), points,
                     np.tile([0.0, 0.0, 1.0], (len(points), 1)), coefficients)


@pytest.mark.parametrize("unit", [1.0, 1000.0])
@pytest.mark.parametrize("radius", [200000.0, 50000.0])
def test_a_pull_bends_by_the_plane_strain_formula(unit, radius):
    # a flat plate 1 m square pulled into a cylinder (w = (x - 500)^2 / 2R): its bending stress
    # is E' t / 2R (pipeline.shop.rolling's plane strain), its largest pull 500^2 / 2R; at
    # R = 50 m a 40 mm AH36 plate would carry 90.5 MPa, over a quarter of 355 MPa: three
    # quarters of the pull are taken (67.9 MPa)
    points, faces = _grid(11, 11, 100.0)
    coefficients = np.zeros((K, 3))
    coefficients[_term(2), 2] = unit / (2.0 * radius)
    coefficients[_term(1), 2] = -500.0 / radius
    coefficients[_term(0), 2] = 125000.0 / (radius * unit)
    check = check_pull(points / unit, faces, (_field(points / unit, coefficients),), lambda p: np.zeros(len(p)),
                       5.0 / unit, 40.0, "AH36", unit)
    stress = E_STEEL / (1.0 - NU_STEEL ** 2) * 40.0 / (2.0 * radius)
    share = 1.0 if stress <= 0.25 * 355.0 else 0.75
    assert check.share == share and (share < 1.0) == (radius < 100000.0)
    assert check.stress_mpa == pytest.approx(share * stress, rel=1e-4)  # chord angles, not slopes
    assert check.largest_pull_mm == pytest.approx(share * 500.0 ** 2 / (2.0 * radius), rel=1e-6)
    assert ("yield stress" in check.refused) == (share < 1.0)


@pytest.mark.parametrize("unit", [1.0, 1000.0])
def test_a_curved_plate_pulled_along_its_normals_stretches_and_is_refused(unit):
    # a plate rolled to a 2 m radius pulled 4 mm toward its axis along its normals: its width
    # shrinks by w / R = 2e-3, twenty times what a pull may stretch a plate (any share of it
    # too); the same 4 mm as a rigid shift stretches nothing
    points, faces = _grid(11, 11, 100.0)
    curved = _rolled(points, 2000.0) / unit
    radius, w = 2000.0 / unit, 4.0 / unit
    inward = np.zeros((K, 3))  # u = w (-sin a, 0, cos a) to second order in x = R sin a
    inward[_term(1), 0] = -w / radius
    inward[_term(0), 2], inward[_term(2), 2] = w, -w / (2.0 * radius ** 2)
    check = check_pull(curved, faces, (_field(curved, inward),), lambda p: np.zeros(len(p)), 5.0 / unit, 14.0,
                       "AH36", unit)
    assert check.share == 0.0 and "stretches it by 0.002" in check.refused
    shift = np.zeros((K, 3))
    shift[_term(0), 2] = w
    check = check_pull(curved, faces, (_field(curved, shift),), lambda p: np.zeros(len(p)), 5.0 / unit, 14.0,
                       "AH36", unit)
    assert check.share == 1.0 and check.strain < 1e-12 and check.stress_mpa < 1e-6
    check = check_pull(curved, faces, (_field(curved, shift),), lambda p: np.full(len(p), 6.0 / unit), 5.0 / unit,
                       14.0, "AH36", unit)
    assert check.share == 0.0 and "off the hull" in check.refused


def test_the_shoulder_plates_pulled_at_erection_meet_and_keep_their_developments(tmp_path):
    # the shoulder's four flat plates step 6-10 mm as developed; follow's planes leave three pairs
    # over the 2.1 mm limit (2.92, 3.65 and 7.39 mm); pulled at erection every shared edge is within
    # it, every plate keeps its class and development (area, outline) and stays within the tolerance
    from pipeline.cli import main

    outs = {}
    for mode, extra in (("follow", {}), ("pull", {"pull_steps": True})):
        (tmp_path / mode).mkdir()
        path = shoulder(tmp_path / mode, fit_up="follow", **extra)
        assert main(["run", str(path), "--out", str(tmp_path / mode / "out"), "--quiet"]) == 0
        outs[mode] = tmp_path / mode / "out"
    before = json.loads((outs["follow"] / "fit_summary.json").read_text())["shell"]
    after = json.loads((outs["pull"] / "fit_summary.json").read_text())["shell"]
    assert max(p["step_max_mm"] for p in before["pairs"]) > 7.0
    assert sum(p["step_max_mm"] > p["step_limit_mm"] for p in before["pairs"]) == 3
    assert all(p["step_max_mm"] <= p["step_limit_mm"] for p in after["pairs"]), after["pairs"]
    pulled = after["follow"]["pulled"]
    assert sorted(pulled) == ["fit_S1_B1", "fit_S1_B2", "fit_S2_B1", "fit_S2_B2"]
    assert not after["follow"]["pull_refused"]
    for name, figures in pulled.items():
        plate = json.loads((outs["pull"] / f"{name}.json").read_text())
        was = json.loads((outs["follow"] / f"{name}.json").read_text())
        assert plate["plate_class"]["class"] == was["plate_class"]["class"]  # two delivered as strips by follow
        assert plate["area_m2"] == was["area_m2"] and plate["outline"] == was["outline"]
        assert plate["erection_pull"]["placed"] and plate["erection_pull"]["largest_pull_mm"] <= 10.0
        assert plate["erection_pull"]["bending_stress_mpa"] <= 0.25 * 355.0
        assert plate["erection_pull"]["stretch"] <= PULL_STRAIN
        assert plate["hull_fit"]["max_distance"] <= 5.0 and plate["hull_fit"]["passed"]
        # the rms is the pulled plate's too (no larger than its largest distance), the one before kept
        assert plate["hull_fit"]["rms_distance"] <= plate["hull_fit"]["max_distance"]
        assert plate["hull_fit"]["before_pull_rms_distance"] == was["hull_fit"]["rms_distance"]
        # the OBJ is the plate as pulled: its vertices moved by about the pull, not more (a flat
        # plate's OBJ is its region on the hull, the pull measured on its plane: within 0.1 %)
        moved = _obj(outs["pull"] / f"{name}.obj") - _obj(outs["follow"] / f"{name}.obj")
        assert 0.3 < np.linalg.norm(moved, axis=1).max() <= 1.001 * figures["largest_pull_mm"]


def _obj(path) -> np.ndarray:
    return np.array([[float(v) for v in line.split()[1:4]] for line in path.read_text().splitlines()
                     if line.startswith("v ")])


def test_pull_steps_needs_follow(tmp_path, capsys):
    from pipeline.cli import main

    path = shoulder(tmp_path, pull_steps=True)
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "pull_steps" in err and "fit_up: follow" in err
    assert not (tmp_path / "out").exists()
