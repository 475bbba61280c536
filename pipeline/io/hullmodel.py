"""A hull model of many (trimmed) NURBS faces, read through the field's libraries: IGES and
STEP through OpenCascade (OCP), Rhino .3dm through rhino3dm (OpenNURBS).

Every face becomes a :class:`HullFace`: its underlying surface as a
:class:`flatten.surface.NurbsSurface` in millimetres, its trim as loops in the surface's
parameters, and its area inside the trim. OpenCascade gives IGES and STEP geometry in
millimetres whatever the file's unit; a .3dm file's model unit is read from its settings.
rhino3dm gives a Brep's trims no parameter curves: a .3dm face's loops are rebuilt from its
edges (3D curves) projected onto its surface, and its area is measured over them.

OCP is ~150 MB and takes a second or more to import: it is imported only here, only when a
model file is read. Our own IGES reader (:mod:`.iges`) stays for picking single entities
(curves and surfaces by directory number or label) in the configs that name them; the tests
show both readers give the same surfaces.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flatten.errors import DevflatError
from flatten.surface import NurbsSurface, nurbs_surface

SUFFIXES = {".igs": "iges", ".iges": "iges", ".stp": "step", ".step": "step", ".3dm": "3dm"}
LOOP_SAMPLES_PER_EDGE = 64
EDGE_ON_FACE_MM = 1.0  # a .3dm Brep edge further off its face (and off Rhino's tolerance) is not on it
# a .3dm edge is sampled finer than an OCP trim's 2D curve: the (u, v) loop is the polygon of
# these points (a circle's polygon of 200 keeps 0.02 % less area than the circle)
RHINO_SAMPLES_PER_EDGE = 200
PROJECTION_STEPS = 100  # of the closest-point search for a .3dm edge's points not on the face after 12
AREA_CELLS = 128  # per parameter direction, for the area of a .3dm face inside its trim
CORNER_DEG = 20.0  # a .3dm loop turning more between samples has a corner: an edge ends there for sewing
# Rhino's model units (rhino3dm.UnitSystem names) in millimetres
RHINO_UNIT_MM = {"Millimeters": 1.0, "Centimeters": 10.0, "Meters": 1000.0, "Inches": 25.4, "Feet": 304.8,
                 "None": 1.0, "Microns": 1e-3, "Kilometers": 1e6}


class HullModelError(DevflatError, ValueError):
    """A hull model file cannot be read (message names the file and what is wrong)."""


@dataclass(frozen=True, eq=False)
class HullFace:
    """One face of a hull model.

    surface : the face's underlying NURBS surface, mm
    outer : (N, 2) the trim's outer loop in (u, v), or None when it is the whole rectangle
    inner : holes, each (M, 2) in (u, v)
    area_mm2 : the face's area inside its trim (OpenCascade's; for .3dm, the surface's over
        the loops, :func:`trimmed_area`)
    """

    index: int
    surface: NurbsSurface
    outer: np.ndarray | None
    inner: tuple
    area_mm2: float
    trim_note: str = ""

    @property
    def trimmed(self) -> bool:
        return self.outer is not None or bool(self.inner)


@dataclass(frozen=True, eq=False)
class HullModel:
    """The faces of a hull file, in mm. ``shape``: the OpenCascade shape (IGES, STEP) the
    sewing report works on, None for a .3dm file (its faces are rebuilt for sewing)."""

    path: Path
    format: str
    faces: tuple[HullFace, ...]
    shape: object = None


def model_format(path: Path) -> str:
    fmt = SUFFIXES.get(Path(path).suffix.lower())
    if fmt is None:
        raise HullModelError(f"{path}: a hull model is read from {', '.join(sorted(SUFFIXES))}; "
                             f"got the suffix {Path(path).suffix!r}")
    return fmt


def read_hull_model(path: str | Path) -> HullModel:
    """Every face of an IGES, STEP or .3dm file (errors name the file)."""
    path = Path(path)
    fmt = model_format(path)
    if not path.is_file():
        raise HullModelError(f"{path}: no such file")
    if fmt == "3dm":
        return _read_3dm(path)
    shape = _read_ocp_shape(path, fmt)
    faces = tuple(_ocp_face(k, face, path) for k, face in enumerate(ocp_faces(shape)))
    if not faces:
        raise HullModelError(f"{path}: the file holds no surface (face) that OpenCascade can read")
    return HullModel(path, fmt, faces, shape)


def _read_ocp_shape(path: Path, fmt: str):
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.Message import Message, Message_Gravity

    if fmt == "iges":
        from OCP.IGESControl import IGESControl_Reader as Reader
    else:
        from OCP.STEPControl import STEPControl_Reader as Reader
    # OpenCascade prints its transfer statistics on stdout: a run's console is ours
    printers = Message.DefaultMessenger_s().Printers()
    for k in range(1, printers.Length() + 1):
        printers.Value(k).SetTraceLevel(Message_Gravity.Message_Fail)
    reader = Reader()
    status = reader.ReadFile(os.fspath(path))
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise HullModelError(f"{path}: OpenCascade cannot read it as {fmt.upper()} ({status.name})")
    reader.TransferRoots()
    return reader.OneShape()


def ocp_faces(shape) -> list:
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    found, explorer = [], TopExp_Explorer(shape, TopAbs_FACE)
    while explorer.More():
        found.append(TopoDS.Face(explorer.Current()))
        explorer.Next()
    return found


def surface_from_ocp(geom, name: str) -> NurbsSurface:
    """A Geom_Surface (any kind OpenCascade can convert) as our NURBS surface."""
    from OCP.Geom import Geom_BSplineSurface
    from OCP.GeomConvert import GeomConvert

    bspline = geom if isinstance(geom, Geom_BSplineSurface) else GeomConvert.SurfaceToBSplineSurface_s(geom)
    nu, nv = bspline.NbUPoles(), bspline.NbVPoles()
    poles = np.array([[_xyz(bspline.Pole(i, j)) for j in range(1, nv + 1)] for i in range(1, nu + 1)])
    weights = np.array([[bspline.Weight(i, j) for j in range(1, nv + 1)] for i in range(1, nu + 1)])
    knots_u = np.repeat([bspline.UKnot(k) for k in range(1, bspline.NbUKnots() + 1)],
                        [bspline.UMultiplicity(k) for k in range(1, bspline.NbUKnots() + 1)])
    knots_v = np.repeat([bspline.VKnot(k) for k in range(1, bspline.NbVKnots() + 1)],
                        [bspline.VMultiplicity(k) for k in range(1, bspline.NbVKnots() + 1)])
    if bspline.IsUPeriodic() or bspline.IsVPeriodic():
        raise HullModelError(f"{name}: a periodic surface (a closed hull form) is not read; split it in the CAD")
    return nurbs_surface(bspline.UDegree(), bspline.VDegree(), poles, knots_u, knots_v, weights, name=name)


def ocp_surface(surface: NurbsSurface):
    """Our NURBS surface as an OpenCascade Geom_BSplineSurface (for writing STEP)."""
    from OCP.Geom import Geom_BSplineSurface
    from OCP.collections import Array1_double, Array1_int, Array2_double, Array2_gp_Pnt
    from OCP.gp import gp_Pnt

    nu, nv, _ = surface.poles.shape
    poles, weights = Array2_gp_Pnt(1, nu, 1, nv), Array2_double(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            poles.SetValue(i + 1, j + 1, gp_Pnt(*(float(x) for x in surface.poles[i, j])))
            weights.SetValue(i + 1, j + 1, float(surface.weights[i, j]))

    def knot_arrays(knots):
        values, counts = np.unique(knots, return_counts=True)
        kk, mm = Array1_double(1, len(values)), Array1_int(1, len(values))
        for k, (value, count) in enumerate(zip(values, counts)):
            kk.SetValue(k + 1, float(value))
            mm.SetValue(k + 1, int(count))
        return kk, mm

    ku, mu = knot_arrays(surface.knots_u)
    kv, mv = knot_arrays(surface.knots_v)
    return Geom_BSplineSurface(poles, weights, ku, kv, mu, mv, surface.degree_u, surface.degree_v)


def ocp_trimmed_face(surface: NurbsSurface, outer: np.ndarray | None, inner=()):
    """An OpenCascade face of our surface bounded by loops in its (u, v) (the parameter
    rectangle without an outer loop), each loop cut at its corners into edges: degree-1 2D
    curves through its points on the surface, their 3D curves built from them. For sewing a .3dm model's faces, whose
    loops are sampled polygons (no curves to give OpenCascade)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakeWire
    from OCP.BRepLib import BRepLib
    from OCP.ShapeFix import ShapeFix_Face

    geom = ocp_surface(surface)
    if outer is None and not inner:
        return BRepBuilderAPI_MakeFace(geom, 1e-6).Face()
    if outer is None:
        (u0, u1), (v0, v1) = surface.domain_u, surface.domain_v
        outer = np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]])
    wires = []
    for loop in (outer, *inner):
        wire = BRepBuilderAPI_MakeWire()
        for piece in _corner_pieces(loop):
            wire.Add(BRepBuilderAPI_MakeEdge(_polyline_2d(piece), geom).Edge())
        wires.append(wire.Wire())
    maker = BRepBuilderAPI_MakeFace(geom, wires[0], True)
    for wire in wires[1:]:
        maker.Add(wire)
    face = maker.Face()
    BRepLib.BuildCurves3d_s(face)
    # the loops' senses are the file's: ShapeFix orients the outer wire and the holes
    fix = ShapeFix_Face(face)
    fix.FixOrientation()
    return fix.Face()


def _corner_pieces(loop: np.ndarray, corner_deg: float = CORNER_DEG) -> list[np.ndarray]:
    """A closed (u, v) polygon (N, 2) cut at its corners (turns above ``corner_deg``) into
    open polylines, each ending where the next starts: one OpenCascade edge each, so that
    sewing meets a neighbour's edge end to end (the whole loop if it has no corner)."""
    span = float(np.ptp(loop, axis=0).max())
    step = np.linalg.norm(np.diff(loop, axis=0, append=loop[:1]), axis=1)
    points = loop[step > 1e-12 * span]  # repeated points (a trim's end, the next one's start) dropped
    ahead = np.roll(points, -1, axis=0) - points
    behind = points - np.roll(points, 1, axis=0)
    cos = np.einsum("ij,ij->i", ahead, behind) / (np.linalg.norm(ahead, axis=1) * np.linalg.norm(behind, axis=1))
    corners = np.flatnonzero(cos < np.cos(np.radians(corner_deg)))
    if len(corners) == 0:
        return [np.vstack([points, points[:1]])]
    points = np.roll(points, -int(corners[0]), axis=0)
    cuts = list(corners - corners[0]) + [len(points)]
    closed = np.vstack([points, points[:1]])
    return [closed[a:b + 1] for a, b in zip(cuts[:-1], cuts[1:])]


def _polyline_2d(points: np.ndarray):
    """A (u, v) polyline (N, 2) as a degree-1 Geom2d B-spline."""
    from OCP.Geom2d import Geom2d_BSplineCurve
    from OCP.collections import Array1_double, Array1_gp_Pnt2d, Array1_int
    from OCP.gp import gp_Pnt2d

    n = len(points)
    poles, knots, mults = Array1_gp_Pnt2d(1, n), Array1_double(1, n), Array1_int(1, n)
    for k, (u, v) in enumerate(points):
        poles.SetValue(k + 1, gp_Pnt2d(float(u), float(v)))
        knots.SetValue(k + 1, float(k))
        mults.SetValue(k + 1, 2 if k in (0, n - 1) else 1)
    return Geom2d_BSplineCurve(poles, knots, mults, 1)


def _xyz(point) -> tuple[float, float, float]:
    return point.X(), point.Y(), point.Z()


def _ocp_face(index: int, face, path: Path) -> HullFace:
    from OCP.BRep import BRep_Tool
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    name = f"{path.name} face {index}"
    surface = surface_from_ocp(BRep_Tool.Surface_s(face), name)
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    outer, inner = face_loops(face)
    if outer is not None and _is_rectangle(outer, surface):
        outer = None
    return HullFace(index, surface, outer, tuple(inner), float(props.Mass()))


def face_loops(face) -> tuple[np.ndarray | None, list[np.ndarray]]:
    """The face's wires as closed loops in (u, v): the outer one and the holes."""
    from OCP.BRepTools import BRepTools, BRepTools_WireExplorer
    from OCP.TopAbs import TopAbs_REVERSED, TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d

    outer_wire = BRepTools.OuterWire_s(face)
    outer, inner = None, []
    explorer = TopExp_Explorer(face, TopAbs_WIRE)
    while explorer.More():
        wire = TopoDS.Wire(explorer.Current())
        points = []
        edges = BRepTools_WireExplorer(wire, face)
        while edges.More():
            edge = edges.Current()
            curve = BRepAdaptor_Curve2d(edge, face)
            t = np.linspace(curve.FirstParameter(), curve.LastParameter(), LOOP_SAMPLES_PER_EDGE)
            uv = np.array([(p.X(), p.Y()) for p in (curve.Value(float(s)) for s in t)])
            points.append(uv[::-1] if edge.Orientation() == TopAbs_REVERSED else uv)
            edges.Next()
        if points:
            loop = np.concatenate(points)
            if wire.IsSame(outer_wire):
                outer = loop
            else:
                inner.append(loop)
        explorer.Next()
    return outer, inner


def _is_rectangle(loop: np.ndarray, surface: NurbsSurface, tol: float = 1e-7) -> bool:
    """Every point of the loop on the parameter rectangle's edge: no trim."""
    (u0, u1), (v0, v1) = surface.domain_u, surface.domain_v
    su, sv = u1 - u0, v1 - v0
    u, v = loop[:, 0], loop[:, 1]
    on_edge = ((np.abs(u - u0) <= tol * su) | (np.abs(u - u1) <= tol * su)
               | (np.abs(v - v0) <= tol * sv) | (np.abs(v - v1) <= tol * sv))
    return bool(on_edge.all())


def _read_3dm(path: Path) -> HullModel:
    """Every surface and every Brep face of a .3dm file, in mm. A Brep face's trim is rebuilt
    from its edges (rhino3dm gives no parameter curves): see :func:`brep_face`."""
    import rhino3dm

    model = rhino3dm.File3dm.Read(os.fspath(path))
    if model is None:
        raise HullModelError(f"{path}: rhino3dm cannot read it as a Rhino .3dm file")
    unit = str(model.Settings.ModelUnitSystem).rsplit(".", 1)[-1]
    if unit not in RHINO_UNIT_MM:
        raise HullModelError(f"{path}: model unit {unit} is not one of {', '.join(RHINO_UNIT_MM)}")
    scale = RHINO_UNIT_MM[unit]
    # an edge further off its face than Rhino's own tolerance (or EDGE_ON_FACE_MM) is a finding
    tolerance = max(EDGE_ON_FACE_MM, float(model.Settings.ModelAbsoluteTolerance) * scale)
    faces = []
    for obj in model.Objects:
        geometry = obj.Geometry
        if isinstance(geometry, rhino3dm.Brep):
            for face in geometry.Faces:
                faces.append(brep_face(geometry, face, scale, tolerance, len(faces), f"{path.name} face {len(faces)}"))
        elif isinstance(geometry, rhino3dm.Surface):
            ours = surface_from_rhino(geometry.ToNurbsSurface(), scale, f"{path.name} face {len(faces)}")
            faces.append(HullFace(len(faces), ours, None, (), trimmed_area(ours, None, ())))
    if not faces:
        raise HullModelError(f"{path}: the file holds no surface or Brep")
    return HullModel(path, "3dm", tuple(faces), None)


def brep_face(brep, face, scale: float, tolerance: float, index: int, name: str) -> HullFace:
    """A rhino3dm Brep face as a :class:`HullFace`: its underlying surface, its loops in that
    surface's (u, v) and its area inside them (mm, mm2).

    A trim in rhino3dm carries no 2D curve, only its edge (a 3D curve) and whether it runs
    against it; each loop is rebuilt by sampling its trims' edges in 3D, in the trim's sense,
    and projecting the points onto the surface (closest point). The (u, v) found so are the
    NURBS form's parameters, the ones our surface has (the face's own domain may differ).
    A loop whose edges lie further than ``tolerance`` (mm) off the surface, or a face that
    uses one edge twice (a seam of a closed surface, where the projection cannot tell its
    two sides apart), keeps the untrimmed surface and says why in ``trim_note``."""
    surface = surface_from_rhino(face.UnderlyingSurface().ToNurbsSurface(), scale, name)
    untrimmed = surface, None, ()
    edges = [t.EdgeIndex for loop in face.Loops for t in loop.Trims]
    seams = sorted({e for e in edges if e >= 0 and edges.count(e) > 1})
    if seams:
        return HullFace(index, *untrimmed, trimmed_area(surface, None, ()),
                        f"its trim uses edge {seams[0]} twice (a seam of a closed surface): the trim is not read, "
                        f"the untrimmed surface")
    from flatten.closest import SurfaceDistance

    distance = SurfaceDistance(surface)
    outer, inner, skipped = None, [], []
    for loop in face.Loops:
        kind = str(loop.LoopType).rsplit(".", 1)[-1]
        if kind not in ("Outer", "Inner"):
            skipped.append(kind)
            continue
        pieces = _loop_points(brep, loop, scale, tolerance)
        points = np.concatenate(pieces) if pieces else np.empty((0, 3))
        if len(points) < 3:
            skipped.append(f"{kind} of {len(points)} points")
            continue
        params, dist = distance.closest(points)
        # an edge point on the rectangle's side (clamped there) may take Gauss-Newton more than
        # the default 12 steps (the 160 m hull's stern corner: 10.5 mm off after 12, 1e-10 after 20)
        slow = dist > 1e-3 * tolerance
        if slow.any():
            params[slow], dist[slow] = distance.closest(points[slow], iterations=PROJECTION_STEPS)
        worst = int(np.argmax(dist))
        if dist[worst] > tolerance:
            x, y, z = points[worst]
            return HullFace(index, *untrimmed, trimmed_area(surface, None, ()),
                            f"its {kind.lower()} loop's edges lie up to {dist[worst]:.4g} mm off the face (at "
                            f"({x:.1f}, {y:.1f}, {z:.1f}) mm; tolerance {tolerance:g} mm): the trim is not read, "
                            f"the untrimmed surface")
        params = np.concatenate(_pin_poles(surface, np.split(params, np.cumsum([len(p) for p in pieces])[:-1])))
        if kind == "Outer":
            outer = params
        else:
            inner.append(params)
    if outer is not None and _is_rectangle(outer, surface) and _fills_rectangle(outer, surface):
        outer = None
    note = f"loops not read: {', '.join(skipped)}" if skipped else ""
    return HullFace(index, surface, outer, tuple(inner), trimmed_area(surface, outer, inner), note)


def _fills_rectangle(loop: np.ndarray, surface: NurbsSurface, tol: float = 1e-7) -> bool:
    """The loop's polygon has the parameter rectangle's area: a loop with few points (a
    quadrilateral of straight edges) may have every point on the rectangle's sides and still
    cut a corner off."""
    from flatten.metrics import polygon_area

    (u0, u1), (v0, v1) = surface.domain_u, surface.domain_v
    return polygon_area(loop) >= (1.0 - tol) * (u1 - u0) * (v1 - v0)


def _loop_points(brep, loop, scale: float, tolerance: float) -> list[np.ndarray]:
    """Points (M, 3) of each trim of a Brep loop, mm: its edge sampled in the trim's sense, a
    curved edge at RHINO_SAMPLES_PER_EDGE points, a straight one (a polyline trim gives one
    per segment) at the spacing of that many over the Brep's size, at least its two ends. A
    singular trim (no edge) and an edge shorter than ``tolerance`` (a side of the surface
    collapsed to a point: the stem of a bow patch) add no points: their (u, v) is a whole
    side of the rectangle, which the neighbouring trims' ends give (:func:`_pin_poles`)."""
    box = brep.GetBoundingBox()
    spacing = float(np.linalg.norm(np.subtract(_xyz_rhino(box.Max), _xyz_rhino(box.Min)))) / RHINO_SAMPLES_PER_EDGE
    pieces = []
    for trim in loop.Trims:
        if trim.EdgeIndex < 0:
            continue
        edge = brep.Edges[trim.EdgeIndex]
        domain = edge.Domain
        count = RHINO_SAMPLES_PER_EDGE
        if edge.IsLinear():
            # a polyline trim of many short sides (one edge each) needs no 200 points a side;
            # a long straight side keeps the spacing (its (u, v) image is straight only where
            # the surface is parametrised evenly along it)
            length = float(np.linalg.norm(np.subtract(_xyz_rhino(edge.PointAtEnd), _xyz_rhino(edge.PointAtStart))))
            count = int(np.clip(np.ceil(length / max(spacing, 1e-300)) + 1, 2, RHINO_SAMPLES_PER_EDGE))
        t = np.linspace(domain.T0, domain.T1, count)
        xyz = np.array([_xyz_rhino(edge.PointAt(float(s))) for s in t]) * scale
        if np.linalg.norm(np.diff(xyz, axis=0), axis=1).sum() <= tolerance:
            continue
        pieces.append(xyz[::-1] if trim.IsReversed else xyz)
    return pieces


def _pin_poles(surface: NurbsSurface, pieces: list[np.ndarray]) -> list[np.ndarray]:
    """Each trim's (u, v) (M, 2) with its ends at a pole mended: where a side of the surface
    is collapsed to a point, every parameter along that side is the point, and the closest-
    point search returns any of them; the end takes that parameter from its neighbour on
    the trim (the trim's own direction into the pole)."""
    (u0, u1), (v0, v1) = surface.domain_u, surface.domain_v
    size = float(np.ptp(surface.poles.reshape(-1, 3), axis=0).max())
    out = []
    for uv in pieces:
        uv = uv.copy()
        if len(uv) >= 2:
            ends = uv[[0, -1]]
            hu, hv = 1e-6 * (u1 - u0), 1e-6 * (v1 - v0)
            u = np.clip(ends[:, 0], u0 + hu, u1 - hu)
            v = np.clip(ends[:, 1], v0 + hv, v1 - hv)
            # how far the point moves over the whole domain of each parameter, there
            along_u = np.linalg.norm(surface(u + hu, v) - surface(u - hu, v), axis=1) / (2e-6)
            along_v = np.linalg.norm(surface(u, v + hv) - surface(u, v - hv), axis=1) / (2e-6)
            for k, (end, near) in enumerate(((0, 1), (-1, -2))):
                if along_u[k] <= 1e-6 * size:
                    uv[end, 0] = uv[near, 0]
                if along_v[k] <= 1e-6 * size:
                    uv[end, 1] = uv[near, 1]
        out.append(uv)
    return out


def _xyz_rhino(point) -> tuple[float, float, float]:
    return point.X, point.Y, point.Z


def trimmed_area(surface: NurbsSurface, outer: np.ndarray | None, inner, cells: int = AREA_CELLS) -> float:
    """The surface's area (mm2) inside the loops (the whole rectangle without an outer loop):
    the parameter rectangle in ``cells`` x ``cells`` cells, each cell's area (two triangles
    on its corners, as the sewing report measures an untrimmed face) times the share of the
    cell's (u, v) inside the loops (exact for the polygonal loops, by shapely)."""
    import shapely

    (u0, u1), (v0, v1) = surface.domain_u, surface.domain_v
    u, v = np.linspace(u0, u1, cells + 1), np.linspace(v0, v1, cells + 1)
    p = surface.grid(u, v)
    a, b, c, d = p[:-1, :-1], p[1:, :-1], p[:-1, 1:], p[1:, 1:]
    cell = 0.5 * (np.linalg.norm(np.cross(b - a, c - a), axis=-1) + np.linalg.norm(np.cross(b - d, c - d), axis=-1))
    if outer is None and not inner:
        return float(cell.sum())
    region = shapely.box(u0, v0, u1, v1) if outer is None else _polygon(outer)
    for loop in inner:
        region = region.difference(_polygon(loop))
    shapely.prepare(region)
    uu0, vv0 = np.meshgrid(u[:-1], v[:-1], indexing="ij")
    uu1, vv1 = np.meshgrid(u[1:], v[1:], indexing="ij")
    boxes = shapely.box(uu0.ravel(), vv0.ravel(), uu1.ravel(), vv1.ravel())
    share = shapely.contains(region, boxes).astype(float)
    edge = ~share.astype(bool) & shapely.intersects(region, boxes)
    share[edge] = shapely.area(shapely.intersection(boxes[edge], region)) / shapely.area(boxes[edge])
    return float((cell.ravel() * share).sum())


def _polygon(loop: np.ndarray):
    """A loop (N, 2) as a valid shapely polygon (a loop touching itself made valid)."""
    import shapely

    polygon = shapely.Polygon(loop)
    return polygon if polygon.is_valid else shapely.make_valid(polygon)


def surface_from_rhino(surface, scale: float, name: str) -> NurbsSurface:
    """A rhino3dm NurbsSurface as ours, coordinates times ``scale`` (to mm). OpenNURBS keeps
    no end knots beyond the degree's: one is added at each end (clamped or not, the spline
    on its domain does not depend on it)."""
    if surface is None:  # ToNurbsSurface() of a surface OpenNURBS cannot convert
        raise HullModelError(f"{name}: rhino3dm gives no NURBS form of the surface")
    nu, nv = surface.Points.CountU, surface.Points.CountV
    poles, weights = np.empty((nu, nv, 3)), np.empty((nu, nv))
    for i in range(nu):
        for j in range(nv):
            point = surface.Points[i, j]  # homogeneous: w x, w y, w z, w
            poles[i, j] = (point.X / point.W, point.Y / point.W, point.Z / point.W)
            weights[i, j] = point.W
    knots_u = [surface.KnotsU[k] for k in range(len(surface.KnotsU))]
    knots_v = [surface.KnotsV[k] for k in range(len(surface.KnotsV))]
    return nurbs_surface(surface.OrderU - 1, surface.OrderV - 1, poles * scale, [knots_u[0]] + knots_u + [knots_u[-1]],
                         [knots_v[0]] + knots_v + [knots_v[-1]], weights, name=name)


def rhino_surface(surface: NurbsSurface):
    """Our surface as a rhino3dm NurbsSurface (for writing .3dm test files)."""
    import rhino3dm

    nu, nv, _ = surface.poles.shape
    out = rhino3dm.NurbsSurface.Create(3, True, surface.degree_u + 1, surface.degree_v + 1, nu, nv)
    for i in range(nu):
        for j in range(nv):
            w = float(surface.weights[i, j])
            x, y, z = (float(c) * w for c in surface.poles[i, j])
            out.Points[i, j] = rhino3dm.Point4d(x, y, z, w)  # OpenNURBS keeps homogeneous control points
    for k, value in enumerate(surface.knots_u[1:-1]):
        out.KnotsU[k] = float(value)
    for k, value in enumerate(surface.knots_v[1:-1]):
        out.KnotsV[k] = float(value)
    return out
