"""Closed-form hull surfaces for tests, written as IGES entity 128 (our reader reads them).

plane: a tilted plane; cylinder: a circular cylinder whose axis runs across the hull (y), so
that its iso-curves along the hull are circular arcs; both exact rational NURBS.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _fmt(x: float) -> str:
    return repr(float(x)).replace("e", "E")


def write_iges_surface(path: Path, degree_u, degree_v, poles, weights, knots_u, knots_v) -> Path:
    """Entity 128 with poles (nu, nv, 3) and weights (nu, nv), units mm."""
    poles = np.asarray(poles, float)
    weights = np.asarray(weights, float)
    nu, nv, _ = poles.shape
    params = [128, nu - 1, nv - 1, degree_u, degree_v, 0, 0, 1 if np.allclose(weights, 1) else 0, 0, 0]
    params += list(knots_u) + list(knots_v)
    params += [weights[i, j] for j in range(nv) for i in range(nu)]
    for j in range(nv):
        for i in range(nu):
            params += list(poles[i, j])
    params += [knots_u[degree_u], knots_u[-degree_u - 1], knots_v[degree_v], knots_v[-degree_v - 1]]
    text = ",".join(str(p) if isinstance(p, int) else _fmt(p) for p in params) + ";"
    p_lines = []
    while text:
        p_lines.append(text[:64])
        text = text[64:]
    g = ("1H,,1H;,4Htest,8Htest.igs,4Htest,4Htest,32,38,6,308,15,4Htest,1.0,2,2HMM,1,0.01,"
         "15H20260101.000000,1E-6,1000.0,4Htest,4Htest,11,0,15H20260101.000000;")
    g_lines = [g[k:k + 72] for k in range(0, len(g), 72)]
    out = [f"{'devflat test surface':<72}S{1:7d}"]
    out += [f"{line:<72}G{k + 1:7d}" for k, line in enumerate(g_lines)]
    out += [f"{128:8d}{1:8d}{0:8d}{0:8d}{0:8d}{0:8d}{0:8d}{0:8d}{0:8d}D{1:7d}",
            f"{128:8d}{0:8d}{0:8d}{len(p_lines):8d}{0:8d}{'':8}{'':8}{'':8}{0:8d}D{2:7d}"]
    out += [f"{line:<64}{1:8d}P{k + 1:7d}" for k, line in enumerate(p_lines)]
    out.append(f"S{1:7d}G{len(g_lines):7d}D{2:7d}P{len(p_lines):7d}{'':40}T{1:7d}")
    path.write_text("\n".join(out) + "\n")
    return path


def plane_iges(path: Path, length=20000.0, width=4000.0, slope=0.3) -> Path:
    """z = slope * y over x in [0, length], y in [0, width]; u along x, v along y."""
    poles = np.array([[[0, 0, 0], [0, width, slope * width]],
                      [[length, 0, 0], [length, width, slope * width]]], float)
    return write_iges_surface(path, 1, 1, poles, np.ones((2, 2)), [0, 0, 1, 1], [0, 0, 1, 1])


def cylinder_iges(path: Path, radius=20000.0, angle_deg=60.0, width=4000.0) -> Path:
    """Circular cylinder of axis y through (0, 0, radius): u runs along the arc
    x = R sin(theta), z = R (1 - cos(theta)), theta in [-angle/2, angle/2] (exact rational
    quadratic), v along y in [0, width]."""
    h = np.radians(angle_deg) / 2
    arc = np.array([[-radius * np.sin(h), radius * (1 - np.cos(h))], [0.0, radius * (1 - 1 / np.cos(h))],
                    [radius * np.sin(h), radius * (1 - np.cos(h))]])
    arc[1] = [0.0, radius - radius / np.cos(h)]
    w = np.array([1.0, np.cos(h), 1.0])
    poles = np.array([[[x, 0.0, z], [x, width, z]] for x, z in arc])
    return write_iges_surface(path, 2, 1, poles, np.column_stack([w, w]), [0, 0, 0, 1, 1, 1], [0, 0, 1, 1])


def cylinder_sphere_iges(path: Path, radius=10000.0, angle_deg=60.0, cylinder=1500.0, cap=3000.0,
                         junction=0.3) -> Path:
    """A circular cylinder of axis y (through (0, 0, radius)) for y in [0, cylinder], joined
    tangentially by the sphere of the same radius centred on the axis at y = cylinder, for
    a further ``cap`` of arc: a surface of revolution about the axis, exact rational
    quadratic. u runs along x over the arc angle_deg; v along the profile, the junction at
    v = ``junction`` (v in [0, 1])."""
    h = np.radians(angle_deg) / 2
    phi = cap / radius
    # profile (r, y): the line r = R (three poles), then the arc r = R cos p, y = Y1 + R sin p
    tan = np.tan(phi / 2)
    profile = np.array([[radius, 0.0], [radius, cylinder / 2], [radius, cylinder],
                        [radius, cylinder + radius * tan], [radius * np.cos(phi), cylinder + radius * np.sin(phi)]])
    wp = np.array([1.0, 1.0, 1.0, np.cos(phi / 2), 1.0])
    # the circle about the axis over [-h, h] as (sin, cos) with weights (1, cos h, 1)
    circle = np.array([[-np.sin(h), np.cos(h)], [0.0, 1.0 / np.cos(h)], [np.sin(h), np.cos(h)]])
    wc = np.array([1.0, np.cos(h), 1.0])
    poles = np.array([[[r * cs[0], y, radius - r * cs[1]] for r, y in profile] for cs in circle])
    weights = wc[:, None] * wp[None, :]
    knots_v = [0.0, 0.0, 0.0, junction, junction, 1.0, 1.0, 1.0]
    return write_iges_surface(path, 2, 2, poles, weights, [0, 0, 0, 1, 1, 1], knots_v)


def cylinder_along_iges(path: Path, radius=3000.0, angle_deg=90.0, length=20000.0, reverse=False) -> Path:
    """Circular cylinder of axis x (a bilge of the parallel midbody): u runs along x in
    [0, length] (from x = length to 0 when ``reverse``), v along the arc y = R sin(theta),
    z = R (1 - cos(theta)), theta in [-angle/2, angle/2] (exact rational quadratic); its
    generators run along u."""
    h = np.radians(angle_deg) / 2
    arc = np.array([[-radius * np.sin(h), radius * (1 - np.cos(h))], [0.0, radius - radius / np.cos(h)],
                    [radius * np.sin(h), radius * (1 - np.cos(h))]])
    w = np.array([1.0, np.cos(h), 1.0])
    poles = np.array([[[x, y, z] for y, z in arc] for x in ((length, 0.0) if reverse else (0.0, length))])
    return write_iges_surface(path, 1, 2, poles, np.vstack([w, w]), [0, 0, 1, 1], [0, 0, 0, 1, 1, 1])


def cone_iges(path: Path, r1=10000.0, r2=9000.0, height=3000.0, angle_deg=90.0) -> Path:
    """Frustum of a circular cone of axis z: u runs along the circular arcs (radius r1 at
    z = 0, r2 at z = height) x = r sin(theta), y = -r cos(theta), theta in [-angle/2,
    angle/2] (exact rational quadratic), v along the generators, which cross from one iso-v
    circle to the other: the strip between two such seams is the cone itself."""
    h = np.radians(angle_deg) / 2
    w = np.array([1.0, np.cos(h), 1.0])

    def arc(r, z):
        return [[-r * np.sin(h), -r * np.cos(h), z], [0.0, -r / np.cos(h), z], [r * np.sin(h), -r * np.cos(h), z]]

    poles = np.array([arc(r1, 0.0), arc(r2, height)]).transpose(1, 0, 2)
    return write_iges_surface(path, 2, 1, poles, np.column_stack([w, w]), [0, 0, 0, 1, 1, 1], [0, 0, 1, 1])


def bowed_bilge_iges(path: Path, bow=138000.0, bilge=3000.0, length=20000.0, angle_deg=60.0) -> Path:
    """A torus patch: a bilge tube of radius ``bilge`` whose centre line bows along the hull
    on a circle of radius ``bow`` (a hull without parallel midbody). A surface of revolution
    about the axis parallel to y through (0, 0, bow): u runs along x over ``length`` of the
    centre line, v around the tube over angle_deg (the section at x = 0 is the circle of
    radius ``bilge`` about the origin in the y-z plane); exact rational quadratic both ways.
    The iso-v rows are circles of radius bow - bilge cos(phi) about the axis: a chord of one
    between two butts 2a apart stands off it by the sagitta r - sqrt(r^2 - a^2)."""
    h = np.arcsin(length / 2 / bow)
    k = np.radians(angle_deg) / 2
    # profile (r, y) around the tube: r = bow - bilge cos(phi), y = bilge sin(phi), phi in [-k, k]
    profile = np.array([[bow - bilge * np.cos(k), -bilge * np.sin(k)], [bow - bilge / np.cos(k), 0.0],
                        [bow - bilge * np.cos(k), bilge * np.sin(k)]])
    wp = np.array([1.0, np.cos(k), 1.0])
    circle = np.array([[-np.sin(h), np.cos(h)], [0.0, 1.0 / np.cos(h)], [np.sin(h), np.cos(h)]])
    wc = np.array([1.0, np.cos(h), 1.0])
    poles = np.array([[[r * cs[0], y, bow - r * cs[1]] for r, y in profile] for cs in circle])
    return write_iges_surface(path, 2, 2, poles, wc[:, None] * wp[None, :], [0, 0, 0, 1, 1, 1], [0, 0, 0, 1, 1, 1])


def leaning_cylinder_iges(path: Path, radius=20000.0, angle_deg=60.0, width=4000.0, lean_deg=35.0) -> Path:
    """A circular cylinder whose generators lean by ``lean_deg`` from the girth direction
    (y) towards x: axis (sin lean, cos lean, 0) through (0, 0, radius). u runs along the
    cross-section circle (perpendicular to the axis, mostly along x), v along the
    generators over ``width``; exact rational quadratic in u. Its iso-v seams are circles,
    the strip between two of them is the cylinder, and its rulings (the generators) cross
    the butt planes x = const at the lean: a plate's seam strip reaches past one butt by
    about its girth times tan(lean)."""
    h = np.radians(angle_deg) / 2
    lean = np.radians(lean_deg)
    axis = np.array([np.sin(lean), np.cos(lean), 0.0])
    across = np.array([np.cos(lean), -np.sin(lean), 0.0])
    up = np.array([0.0, 0.0, 1.0])
    arc = [(-radius * np.sin(h), radius * (1 - np.cos(h))), (0.0, radius - radius / np.cos(h)),
           (radius * np.sin(h), radius * (1 - np.cos(h)))]
    w = np.array([1.0, np.cos(h), 1.0])
    poles = np.array([[a * across + b * up + t * axis for t in (0.0, width)] for a, b in arc])
    return write_iges_surface(path, 2, 1, poles, np.column_stack([w, w]), [0, 0, 0, 1, 1, 1], [0, 0, 1, 1])


def helical_cylinder_iges(path: Path, radius=3000.0, length=20000.0, span=3.0, lead=0.2, samples=(41, 25)) -> Path:
    """A circular cylinder of axis x (generators along x) whose girth parameter turns as it
    runs along x: u = x in [0, length], the angle theta = (v - 1/2) span + lead (x - length/2)
    / radius, the point (x, radius sin theta, radius (1 - cos theta)). Its iso-u curves are
    the sections x = const (circles), its iso-v seams helices that cross the generators at
    atan(lead); a bicubic B-spline interpolating samples (u x v) of it (off the cylinder by
    about 1e-3 mm)."""
    from scipy.interpolate import make_interp_spline

    u = np.linspace(0.0, length, samples[0])
    v = np.linspace(0.0, 1.0, samples[1])
    theta = (v[None, :] - 0.5) * span + lead * (u[:, None] - length / 2) / radius
    points = np.stack([np.broadcast_to(u[:, None], theta.shape), radius * np.sin(theta),
                       radius * (1 - np.cos(theta))], axis=-1)
    along = make_interp_spline(u / length, points, k=3, axis=0)
    both = make_interp_spline(v, along.c, k=3, axis=1)  # its coefficients come (v, u, 3)
    poles = both.c.transpose(1, 0, 2)
    return write_iges_surface(path, 3, 3, poles, np.ones(poles.shape[:2]), along.t, both.t)


def write_step_faces(path: Path, faces: list) -> Path:
    """One STEP file of faces, each (surface, (u0, u1, v0, v1)): the face bounded by that box
    of its surface's parameters (a box short of the surface's own is a trim)."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from OCP.TopoDS import TopoDS_Compound

    from pipeline.io.hullmodel import ocp_surface

    builder, compound = BRep_Builder(), TopoDS_Compound()
    builder.MakeCompound(compound)
    for surface, (u0, u1, v0, v1) in faces:
        builder.Add(compound, BRepBuilderAPI_MakeFace(ocp_surface(surface), u0, u1, v0, v1, 1e-6).Face())
    writer = STEPControl_Writer()
    writer.Transfer(compound, STEPControl_AsIs)
    if int(writer.Write(str(path))) != 1:
        raise OSError(f"OpenCascade could not write {path}")
    return path
