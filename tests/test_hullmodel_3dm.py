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
from pipeline.io.hullmodel import RHINO_SAMPLES_PER_EDGE, read_hull_model

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


@pytest.mark.parametrize("domain", [None, ((100.0, 200.0), (-7.0, -6.0))])
def test_a_trimmed_disc_reads_back_as_its_circle_and_area(tmp_path, domain):
    """A plane trimmed by a circle of radius 5 m (the file in metres): the face is trimmed, its
    outer loop lies on the circle in 3D (mm), and its area is pi r^2 within 0.5 % (the loop is a
    polygon of the sampled edge: 0.02 % short). The same with the face's parameters moved to
    other intervals (the loop is found in whatever parameters the surface has)."""
    brep = disc()
    if domain is not None:
        for direction, (lo, hi) in enumerate(domain):
            assert brep.Faces[0].SetDomain(direction, rhino3dm.Interval(lo, hi))
    path = write_breps(tmp_path / "disc.3dm", [brep], "Meters")
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
    if domain is not None:
        assert (face.surface.domain_u, face.surface.domain_v) == domain


def test_a_curved_untrimmed_brep_face_is_its_surface_and_area(tmp_path):
    """The 160 m hull's side (one curved NURBS surface) as a Brep of one face, in metres: its
    four edges project onto the surface's sides, so the face is untrimmed; its area is
    OpenCascade's of the IGES face (3816.4 m2) within 1e-4."""
    from pipeline.io.hullmodel import rhino_surface

    iges = read_hull_model(DATA / "test_1_hull_exported.igs").faces[0]
    s = iges.surface
    metres = type(s)(s.degree_u, s.degree_v, s.poles / 1000.0, s.weights, s.knots_u, s.knots_v)
    brep = rhino3dm.Brep.CreateFromSurface(rhino_surface(metres))
    (face,) = read_hull_model(write_breps(tmp_path / "side.3dm", [brep], "Meters")).faces
    assert not face.trimmed and face.trim_note == ""
    assert face.area_mm2 == pytest.approx(iges.area_mm2, rel=1e-4)
    assert face.area_mm2 * 1e-6 == pytest.approx(3816.4, rel=1e-3)


def test_a_patch_with_a_side_collapsed_to_a_point_is_untrimmed(tmp_path):
    """A curved bow-like patch (degree 2 x 2) whose side u = 1 is one point (a stem): rhino3dm's
    Brep has a singular trim there and its neighbours' edges end at the pole, where any v is
    the closest point. The face reads untrimmed (the ends take v from their own edge), its
    area OpenCascade's of the surface."""
    from flatten.surface import nurbs_surface
    from pipeline.io.hullmodel import rhino_surface

    poles = np.array([[(1000.0 * i, 800.0 * j * (1 - i / 2), 100.0 * (j - 1) ** 2 * (1 - i / 2) + 50 * i)
                       for j in range(3)] for i in range(3)])
    surface = nurbs_surface(2, 2, poles, [0, 0, 0, 1, 1, 1], [0, 0, 0, 1, 1, 1])
    brep = rhino3dm.Brep.CreateFromSurface(rhino_surface(surface))
    assert -1 in [t.EdgeIndex for t in brep.Faces[0].OuterLoop.Trims]  # the singular trim
    (face,) = read_hull_model(write_breps(tmp_path / "bow.3dm", [brep])).faces
    assert not face.trimmed and face.trim_note == ""
    assert face.area_mm2 == pytest.approx(ocp_area(face), rel=1e-4)


def test_a_clockwise_polygon_s_reversed_trims_are_followed_in_their_sense(tmp_path):
    """A trapezoid given clockwise: rhino3dm's trims then run against their edges (IsReversed).
    The loop must go round the trapezoid without jumping (the edges taken in their own sense
    would zigzag across it), and the area is the trapezoid's, as is OpenCascade's. Every
    corner lies on a side of the plane's rectangle (the trim's bounding box): the face is
    still trimmed (a corner is cut off)."""
    corners = [(0, 500, 0), (1000, 800, 0), (1000, 0, 0), (0, 0, 0)]
    brep = rhino3dm.Brep.CreateTrimmedPlane(rhino3dm.Plane.WorldXY(), polyline_curve(corners))
    assert all(t.IsReversed for t in brep.Faces[0].OuterLoop.Trims)  # the case this test is about
    (face,) = read_hull_model(write_breps(tmp_path / "cw.3dm", [brep])).faces
    points = face.surface(face.outer[:, 0], face.outer[:, 1])
    step = np.linalg.norm(np.diff(points, axis=0), axis=1)
    # the longest side's spacing: straight edges are sampled at 1/200 of the Brep's diagonal
    assert step.max() <= np.hypot(1000.0, 800.0) / RHINO_SAMPLES_PER_EDGE * 1.000001
    assert face.area_mm2 == pytest.approx(0.5 * (500 + 800) * 1000, rel=1e-9)
    assert ocp_area(face) == pytest.approx(face.area_mm2, rel=1e-9)


def test_an_edge_off_its_face_is_a_note_and_the_untrimmed_surface(tmp_path, capsys):
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
    out = capsys.readouterr().out
    assert "note: face 0: its outer loop's edges lie up to 3000 mm off the face" in out
    assert "face 0: 50 m2" in out and "face 1: 78.53 m2" in out


def test_two_trimmed_faces_sharing_a_side_sew_along_it(tmp_path, capsys):
    """Two trapezoids meeting along x = 1000 mm from y 0 to 800: rebuilt as OpenCascade faces
    from their loops (cut at their corners into edges), sewing joins that side once and leaves
    the other six free; both faces report their own area (0.65 m2 each, by the shoelace)."""
    left = [(0, 0, 0), (1000, 0, 0), (1000, 800, 0), (0, 500, 0)]
    right = [(1000, 0, 0), (2000, 0, 0), (1500, 900, 0), (1000, 800, 0)]
    breps = [rhino3dm.Brep.CreateTrimmedPlane(rhino3dm.Plane.WorldXY(), polyline_curve(c)) for c in (left, right)]
    path = write_breps(tmp_path / "two.3dm", breps)
    assert main(["hull", "inspect", str(path), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["contiguous_edges"] == 1 and report["free_edges"] == 6
    assert [f["trimmed"] for f in report["faces"]] == [True, True]
    assert [f["area_m2"] for f in report["faces"]] == pytest.approx([0.65, 0.65], rel=1e-9)
    (junction,) = report["junctions"]
    assert junction["length_mm"] == pytest.approx(800.0, rel=0.01)


@pytest.fixture(scope="module")
def kcs_3dm(tmp_path_factory) -> Path:
    """KCS's trimmed flat bottom (face 0 as OpenCascade reads the IGES: a degree-1 plane)
    written as a rhino3dm trimmed plane, in metres: the plane's axes along the face's u and
    v, its trim the face's outer loop mapped to 3D (a polyline, one edge per side)."""
    face = read_hull_model(DATA / "ship_kcs.igs").faces[0]
    s = face.surface
    (u0, u1), (v0, v1) = s.domain_u, s.domain_v
    origin, at_u, at_v = s(np.array([u0, u1, u0]), np.array([v0, v0, v1])) / 1000.0
    loop = s(face.outer[:, 0], face.outer[:, 1]) / 1000.0
    loop = loop[np.linalg.norm(np.diff(loop, axis=0, append=loop[:1]), axis=1) > 1e-9]  # joints given twice
    plane = rhino3dm.Plane(rhino3dm.Point3d(*origin), rhino3dm.Vector3d(*(at_u - origin)),
                           rhino3dm.Vector3d(*(at_v - origin)))
    brep = rhino3dm.Brep.CreateTrimmedPlane(plane, polyline_curve(loop))
    return write_breps(tmp_path_factory.mktemp("kcs3dm") / "kcs_bottom.3dm", [brep], "Meters")


def test_kcs_flat_bottom_from_3dm_keeps_its_trim_and_area(kcs_3dm, capsys):
    """1.129 m2 inside the trim at the file's scale (1128 m2 at ship scale), as OpenCascade
    gives it from the IGES, within 0.5 % (not the untrimmed 2.62 m2); and the trim loop is
    the IGES face's outline in 3D."""
    iges = read_hull_model(DATA / "ship_kcs.igs").faces[0]
    (face,) = read_hull_model(kcs_3dm).faces
    assert face.trimmed and face.trim_note == ""
    assert face.area_mm2 == pytest.approx(iges.area_mm2, rel=5e-3)
    assert face.area_mm2 < 0.5 * np.ptp(iges.surface.poles, axis=(0, 1))[:2].prod()  # the plane: 2.62 m2
    # every point of the .3dm loop lies on the IGES trim's outline (its polygon, in 3D)
    import shapely

    outline = shapely.LinearRing(iges.surface(iges.outer[:, 0], iges.outer[:, 1])[:, :2])
    back = face.surface(face.outer[:, 0], face.outer[:, 1])
    assert np.abs(back[:, 2]).max() < 1e-9
    assert max(outline.distance(shapely.Point(p)) for p in back[:, :2]) < 1e-6
    assert main(["hull", "inspect", str(kcs_3dm)]) == 0
    out = capsys.readouterr().out
    assert f"face 0: {face.area_mm2 * 1e-6:.4g} m2" in out and "trimmed" in out and "1.129 m2" in out


def kcs_run(tmp_path: Path, kind: str, source: dict) -> dict:
    """The KCS flat-bottom plan (tests/test_hullmodel's config) run from ``source``: the
    delivered plates (id without the run's name: area, class) and the coverage."""
    from tests.test_hullmodel import kcs_bottom_config

    data = yaml.safe_load(kcs_bottom_config(tmp_path, dxf=False).read_text())
    data["name"], data["strake"]["surface"] = kind, source
    path = tmp_path / f"{kind}.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["run", str(path), "--out", str(tmp_path / kind), "--quiet", "--jobs", "2"]) == 0
    summary = json.loads((tmp_path / kind / f"{kind}_summary.json").read_text())
    plates = {p["id"].split("_", 1)[1]: (p["area_m2"], p["class"]) for p in summary["parts"]}
    return {"plates": plates, "coverage": summary["shell"]["coverage"]}


def test_kcs_flat_bottom_from_3dm_plans_as_from_the_iges(kcs_3dm, tmp_path):
    """The plan from the .3dm and from the IGES (face 0 through OpenCascade): the same plates
    (names and classes), each plate's delivered area within 0.5 % (the .3dm plane is the trim's
    bounding rectangle, 2.7e-5 narrower than the IGES plane: whole plates differ by that), the
    shell covered once and no steel outside the trim."""
    iges = kcs_run(tmp_path, "iges", {"model": str(DATA / "ship_kcs.igs"), "face": 0})
    rhino = kcs_run(tmp_path, "rhino", {"model": str(kcs_3dm), "face": 0})
    assert len(rhino["plates"]) == len(iges["plates"]) >= 30
    assert rhino["plates"].keys() == iges["plates"].keys()
    for name, (area, cls) in iges["plates"].items():
        assert rhino["plates"][name][1] == cls
        assert rhino["plates"][name][0] == pytest.approx(area, rel=5e-3), name
    total = sum(a for a, _ in rhino["plates"].values())
    assert total == pytest.approx(sum(a for a, _ in iges["plates"].values()), rel=1e-4)
    assert total == pytest.approx(1128.0, rel=5e-3)  # the trimmed shell, not the 2622 m2 plane
    coverage = rhino["coverage"]
    assert coverage["covered"] == pytest.approx(1.0, abs=2e-3) and coverage["overlap"] == pytest.approx(0.0, abs=1e-6)
    assert coverage["outside_m2"] < 1e-3 * coverage["shell_m2"]
