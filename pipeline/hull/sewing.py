"""What a hull model is as a shell: its faces sewn by OpenCascade within a tolerance, the
edges sewing leaves free, the gaps between faces and the faces that overlap.

Sewing (``BRepBuilderAPI_Sewing``) joins edges of neighbouring faces that lie within the
tolerance; what it leaves free is either the shell's own boundary (deck edge, centreline,
transom, stem) or a defect: a *gap* when another face runs within ``gap_limit`` of the free
edge, an unsewn contact when one is within the tolerance. Sewing cannot see faces that lie
on top of each other (the same shell given twice over a stretch, as DTMB 5415's bow and
main-hull surfaces over about 4 m): each face is sampled inside its trim and the points
within the tolerance of another face, inside that face's trim, are the overlap.

Overlapping faces that coincide within the tolerance have no intersection curve to cut them
at (the surfaces touch along a whole area, not along a line): the report gives the stretch in
x where they overlap and a transverse plane through its middle where a cut would lose no
shell (every point there lies on both faces within the stated distance).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from flatten.closest import SurfaceDistance, closest_with_sides

from ..io.hullmodel import HullFace, HullModel, ocp_faces

SAMPLES = 48  # per parameter direction of each face, for overlaps
EDGE_SAMPLES = 16  # points of a free edge measured against the faces
DISTANCE_GRID = 64  # seeds per direction of the closest-point search
KNUCKLE_DEG = 2.0  # faces meeting at a larger angle between their normals make a knuckle
# faces whose tangent planes part by more (median over the points within reach of each other)
# meet at an angle, however close they run: not lying on each other (DTMB 5415's bow on its
# main hull: 0.8 deg; a Wigley hull's port and starboard bows at its stem: 13 deg)
OVERLAP_ANGLE_DEG = 5.0
SCHEMA = "hull-model/1"


@dataclass(frozen=True)
class Overlap:
    """Two faces lying on each other (mm, m2)."""

    faces: tuple[int, int]
    area_m2: float  # of one face's area that lies on the other
    x_range_mm: tuple[float, float]
    max_distance_mm: float  # between the faces over the overlap
    median_distance_mm: float
    cut_x_mm: float  # the transverse plane where the faces' sections are closest
    step_at_cut_mm: float  # the largest distance between them there: the step a cut leaves


@dataclass(frozen=True)
class SewingReport:
    """The shell a hull model makes (lengths mm, areas m2)."""

    file: str
    format: str
    tolerance_mm: float
    faces: list[dict]
    shell_area_m2: float
    free_edges: int
    contiguous_edges: int
    multiple_edges: int  # non-manifold: shared by more than two faces
    degenerated: int
    gaps: list[dict] = field(default_factory=list)  # free edges within gap_limit of another face
    overlaps: list[Overlap] = field(default_factory=list)
    junctions: list[dict] = field(default_factory=list)  # where two faces meet: length, angle, smooth or knuckle
    notes: list[str] = field(default_factory=list)
    file_faces: int | None = None  # faces in the file, when the report covers some of them (``faces``)

    def as_dict(self) -> dict:
        out = asdict(self)
        out["schema"] = SCHEMA
        return out

    def lines(self) -> list[str]:
        """The report as a console reads it."""
        of = "" if self.file_faces is None else f" of its {self.file_faces}"
        out = [f"{self.file} ({self.format.upper()}): {_count(len(self.faces), 'face')}{of}, "
               f"{self.shell_area_m2:.4g} m2 inside their trims",
               f"sewn at {self.tolerance_mm:g} mm: {self.contiguous_edges} shared edges, {self.free_edges} free, "
               f"{self.multiple_edges} non-manifold, {self.degenerated} degenerated"]
        for face in self.faces:
            out.append(f"  face {face['index']}: {face['area_m2']:.4g} m2, {face['poles'][0]}x{face['poles'][1]} poles "
                       f"degree {face['degree'][0]}x{face['degree'][1]}, x {face['x_mm'][0]:.1f}..{face['x_mm'][1]:.1f}, "
                       f"y {face['y_mm'][0]:.1f}..{face['y_mm'][1]:.1f}, z {face['z_mm'][0]:.1f}..{face['z_mm'][1]:.1f}"
                       f"{', trimmed' if face['trimmed'] else ''}")
        if self.gaps:
            worst = max(self.gaps, key=lambda g: g["gap_mm"])
            runs = "runs" if len(self.gaps) == 1 else "run"
            out.append(f"gaps: {_count(len(self.gaps), 'free edge')} {runs} beside another face, widest "
                       f"{worst['gap_mm']:.3g} mm "
                       f"(face {worst['face']} to face {worst['other']})")
        else:
            out.append("gaps: none")
        for o in self.overlaps:
            if o.x_range_mm[1] - o.x_range_mm[0] <= self.tolerance_mm:
                out.append(f"overlap: faces {o.faces[0]} and {o.faces[1]} lie on each other in the plane x = "
                           f"{o.x_range_mm[0]:.1f} mm over {o.area_m2:.4g} m2, {o.median_distance_mm:.3g} mm apart "
                           f"(median; up to {o.max_distance_mm:.3g}): no transverse plane separates them (a face "
                           f"given twice?); a plan should use one of them")
                continue
            out.append(f"overlap: faces {o.faces[0]} and {o.faces[1]} lie on each other over {o.area_m2:.4g} m2, "
                       f"x {o.x_range_mm[0]:.1f}..{o.x_range_mm[1]:.1f} mm, {o.median_distance_mm:.3g} mm apart "
                       f"(median; up to {o.max_distance_mm:.3g}): nearly parallel, their intersection is no "
                       f"well-placed cut; cut at x = {o.cut_x_mm:.1f} mm, where the sections are closest "
                       f"(step {o.step_at_cut_mm:.3g} mm; a plan with overlaps: fair fairs one into the other "
                       f"so that they meet there)")
        if not self.overlaps:
            out.append("overlaps: none")
        for j in self.junctions:
            out.append(f"junction: faces {j['faces'][0]} and {j['faces'][1]} meet along {j['length_mm']:.1f} mm, "
                       f"x {j['x_mm'][0]:.1f}..{j['x_mm'][1]:.1f}, normals {j['p95_angle_deg']:.3g} deg apart (p95; max "
                       f"{j['max_angle_deg']:.3g}), up to {j['max_gap_mm']:.3g} mm apart: {j['kind']}")
        out.extend(f"note: {n}" for n in self.notes)
        return out


def _count(n: int, thing: str) -> str:
    return f"{n} {thing}" + ("" if n == 1 else "s")


def sew_report(model: HullModel, tolerance: float = 1.0, gap_limit: float = 50.0,
               only: set | None = None) -> SewingReport:
    """Sew the model's faces at ``tolerance`` (mm) and report the shell; free edges within
    ``gap_limit`` (mm) of another face are gaps. ``only``: the indices of the faces to sew
    (a run's own faces, not the rest of the file; None: all), named by their file numbers."""
    if not tolerance > 0:
        raise ValueError(f"tolerance must be > 0 mm, got {tolerance}")
    if not gap_limit >= tolerance:
        raise ValueError(f"gap_limit must be >= the tolerance {tolerance}, got {gap_limit}")
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing

    shapes = _shapes(model)
    file_faces = None
    if only is not None:
        keep = [k for k, f in enumerate(model.faces) if f.index in only]
        file_faces = len(model.faces)
        shapes = [shapes[k] for k in keep]
        model = HullModel(model.path, model.format, tuple(model.faces[k] for k in keep))
    sewing = BRepBuilderAPI_Sewing(tolerance)
    for face in shapes:
        sewing.Add(face)
    sewing.Perform()
    faces = [_face_summary(f) for f in model.faces]
    notes = [f"face {f.index}: {f.trim_note}" for f in model.faces if f.trim_note]
    distances = [SurfaceDistance(f.surface, grid=DISTANCE_GRID) for f in model.faces]
    gaps = _gaps(sewing, model, distances, tolerance, gap_limit)
    overlaps = overlaps_of(model, tolerance, distances)
    overlapping = {o.faces for o in overlaps}  # their meeting is an overlap, reported as such
    junctions = [j for j in junctions_of(model, distances, tolerance) if tuple(j["faces"]) not in overlapping]
    area = sum(f["area_m2"] for f in faces)
    # the pairs above are positions in the faces sewn: named by the file's numbers
    number = [f.index for f in model.faces]
    gaps = [dict(g, face=number[g["face"]], other=number[g["other"]]) for g in gaps]
    overlaps = [replace(o, faces=tuple(number[k] for k in o.faces)) for o in overlaps]
    junctions = [dict(j, faces=[number[k] for k in j["faces"]]) for j in junctions]
    return SewingReport(str(model.path), model.format, float(tolerance), faces, float(area), sewing.NbFreeEdges(),
                        sewing.NbContigousEdges(), sewing.NbMultipleEdges(), sewing.NbDegeneratedShapes(), gaps,
                        overlaps, junctions, notes, file_faces)


def junctions_of(model: HullModel, distances: list, tolerance: float, knuckle_deg: float = KNUCKLE_DEG) -> list[dict]:
    """Where two faces meet (a face's boundary within ``tolerance`` of the other face) and
    how: the largest angle between their normals along the junction. Above ``knuckle_deg`` the
    shell has a knuckle there, which a plate cannot be rolled across: a seam or a butt must
    lie on it (or the plate is pressed with a crease); below it the faces join smoothly and
    a plate may run across (tangent continuity, as across a face boundary inside one hull form)."""
    faces = model.faces
    boxes = [_box(f.surface) for f in faces]
    found = {}
    for a, face in enumerate(faces):
        params_a = _boundary_params(face)
        points = face.surface(params_a[:, 0], params_a[:, 1])
        segment = np.linalg.norm(np.diff(points, axis=0, append=points[:1]), axis=1)
        for b in range(len(faces)):
            lo, hi = boxes[b][0] - tolerance, boxes[b][1] + tolerance
            if a == b or np.any(boxes[a][1] < lo) or np.any(hi < boxes[a][0]):
                continue
            params_b, dist = closest_with_sides(distances[b], points)  # a collapsed side of b stops the search
            on = (dist <= tolerance) & _inside(faces[b], params_b)
            if on.sum() < 3:
                continue
            na = _normals(face.surface, params_a[on])
            nb = _normals(faces[b].surface, params_b[on])
            angle = np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", na, nb)), 0.0, 1.0)))
            pair = (min(a, b), max(a, b))
            length = float(segment[on].sum())
            if pair in found and found[pair]["length_mm"] >= length:
                continue
            # judged on the 95th percentile: a collapsed corner (a pole where the normal is
            # undefined) must not make a smooth junction a knuckle
            typical = float(np.percentile(angle, 95))
            found[pair] = {"faces": list(pair), "length_mm": length,
                           "x_mm": [float(points[on, 0].min()), float(points[on, 0].max())],
                           "max_angle_deg": float(angle.max()), "p95_angle_deg": typical,
                           "max_gap_mm": float(dist[on].max()),
                           "kind": "knuckle: a seam or butt must lie on it" if typical > knuckle_deg
                           else "smooth: a plate may cross it"}
    return [found[pair] for pair in sorted(found)]


def _boundary_params(face: HullFace, per_side: int = 50) -> np.ndarray:
    """(N, 2) parameters around the face's boundary: its trim's outer loop, or its
    rectangle's four sides."""
    if face.outer is not None:
        return face.outer
    (u0, u1), (v0, v1) = face.surface.domain_u, face.surface.domain_v
    s = np.linspace(0.0, 1.0, per_side, endpoint=False)
    return np.vstack([np.column_stack([u0 + s * (u1 - u0), np.full(per_side, v0)]),
                      np.column_stack([np.full(per_side, u1), v0 + s * (v1 - v0)]),
                      np.column_stack([u1 - s * (u1 - u0), np.full(per_side, v1)]),
                      np.column_stack([np.full(per_side, u0), v1 - s * (v1 - v0)])])


def _normals(surface, params: np.ndarray) -> np.ndarray:
    """Unit normals (N, 3) by central differences inside the domain (one-sided at its edge)."""
    (u0, u1), (v0, v1) = surface.domain_u, surface.domain_v
    hu, hv = 1e-6 * (u1 - u0), 1e-6 * (v1 - v0)
    u = np.clip(params[:, 0], u0 + hu, u1 - hu)
    v = np.clip(params[:, 1], v0 + hv, v1 - hv)
    su = surface(u + hu, v) - surface(u - hu, v)
    sv = surface(u, v + hv) - surface(u, v - hv)
    n = np.cross(su, sv)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def _shapes(model: HullModel) -> list:
    """The model's OpenCascade faces; a .3dm model's are built from its surfaces, bounded by
    their trims' loops."""
    if model.shape is not None:
        return ocp_faces(model.shape)
    from ..io.hullmodel import ocp_trimmed_face

    return [ocp_trimmed_face(f.surface, f.outer, f.inner) for f in model.faces]


def _face_summary(face: HullFace) -> dict:
    s = face.surface
    u = np.linspace(*s.domain_u, 17)
    v = np.linspace(*s.domain_v, 17)
    points = s.grid(u, v).reshape(-1, 3)
    lo, hi = points.min(axis=0), points.max(axis=0)
    area = face.area_mm2 if np.isfinite(face.area_mm2) else _sampled_area(s)
    # y and z too: picking a hull's faces among a model's decks, bulkheads and appendages
    return {"index": face.index, "area_m2": float(area) * 1e-6, "poles": list(s.poles.shape[:2]),
            "degree": [s.degree_u, s.degree_v], "x_mm": [float(lo[0]), float(hi[0])],
            "y_mm": [float(lo[1]), float(hi[1])], "z_mm": [float(lo[2]), float(hi[2])], "trimmed": face.trimmed}


def _sampled_area(surface, n: int = 65) -> float:
    u = np.linspace(*surface.domain_u, n)
    v = np.linspace(*surface.domain_v, n)
    p = surface.grid(u, v)
    a, b, c = p[:-1, :-1], p[1:, :-1], p[:-1, 1:]
    d = p[1:, 1:]
    return float(0.5 * (np.linalg.norm(np.cross(b - a, c - a), axis=-1)
                        + np.linalg.norm(np.cross(b - d, c - d), axis=-1)).sum())


def _gaps(sewing, model: HullModel, distances: list, tolerance: float, gap_limit: float) -> list[dict]:
    """Free edges that run beside a face other than their own: their points' largest distance
    to that face (the own face is the one the edge lies on; a second face within the
    tolerance is a contact that sewing did not join)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve

    boxes = [_box(f.surface) for f in model.faces]
    found = []
    for i in range(1, sewing.NbFreeEdges() + 1):
        curve = BRepAdaptor_Curve(sewing.FreeEdge(i))
        t = np.linspace(curve.FirstParameter(), curve.LastParameter(), EDGE_SAMPLES)
        points = np.array([(p.X(), p.Y(), p.Z()) for p in (curve.Value(float(s)) for s in t)])
        lo, hi = points.min(axis=0) - gap_limit, points.max(axis=0) + gap_limit
        near = []
        for k, (blo, bhi) in enumerate(boxes):
            if np.any(hi < blo) or np.any(bhi < lo):
                continue
            params, dist = distances[k].closest(points)
            near.append((float(np.max(np.where(_inside(model.faces[k], params), dist, np.inf))), k))
        near.sort()
        if len(near) >= 2 and near[1][0] <= gap_limit:
            found.append({"face": near[0][1], "other": near[1][1], "gap_mm": near[1][0],
                          "within_tolerance": bool(near[1][0] <= tolerance)})
    return found


def _box(surface) -> tuple[np.ndarray, np.ndarray]:
    # the poles' box holds the surface (convex hull property)
    poles = surface.poles.reshape(-1, 3)
    return poles.min(axis=0), poles.max(axis=0)


def overlaps_of(model: HullModel, tolerance: float, distances: list | None = None,
                reach: float | None = None) -> list[Overlap]:
    """Pairs of faces that lie on each other: points of one whose closest point on the other
    is inside that face (not on its edge, where faces that merely meet at an angle have
    theirs) and within ``reach`` (default 10 tolerances), over an area wider than 10
    tolerances; each pair once, as seen from the face that shows more of it."""
    faces = model.faces
    reach = 10.0 * tolerance if reach is None else reach
    distances = distances or [SurfaceDistance(f.surface, grid=DISTANCE_GRID) for f in faces]
    samples = [_samples(f) for f in faces]  # (points, cell areas, (u, v))
    boxes = [_box(f.surface) for f in faces]
    best: dict[tuple[int, int], Overlap] = {}
    for a in range(len(faces)):
        for b in range(len(faces)):
            lo, hi = boxes[b][0] - reach, boxes[b][1] + reach
            if a == b or np.any(boxes[a][1] < lo) or np.any(hi < boxes[a][0]):
                continue
            points, weights, own = samples[a]
            params, dist = distances[b].closest(points)
            on = (dist <= reach) & interior(faces[b].surface, params) & _inside(faces[b], params)
            if on.sum() < 4:
                continue
            area = float(weights[on].sum())
            if area <= 10 * tolerance * max(float(np.ptp(points[on], axis=0).max()), 10 * tolerance):
                continue  # a sliver: faces meeting at a shallow angle, not lying on each other
            if _median_angle(faces[a].surface, own[on], faces[b].surface, params[on]) > OVERLAP_ANGLE_DEG:
                continue  # a sharp end's two sides near their junction: they meet, they do not overlap
            x = points[on, 0]
            cut, step = _cut_plane(faces[a].surface, distances[b], float(x.min()), float(x.max()),
                                   apart=float(dist[on].max()))
            pair = (min(a, b), max(a, b))
            found = Overlap(pair, area * 1e-6, (float(x.min()), float(x.max())), float(dist[on].max()),
                            float(np.median(dist[on])), cut, step)
            if pair not in best or found.area_m2 > best[pair].area_m2:
                best[pair] = found
    return [best[pair] for pair in sorted(best)]


def interior(surface, params: np.ndarray, margin: float = 1e-6) -> np.ndarray:
    """(u, v) strictly inside the surface's parameter rectangle (a closest-point search that
    ends clamped on the edge found the edge, not a foot point)."""
    (u0, u1), (v0, v1) = surface.domain_u, surface.domain_v
    du, dv = margin * (u1 - u0), margin * (v1 - v0)
    u, v = params[:, 0], params[:, 1]
    return (u > u0 + du) & (u < u1 - du) & (v > v0 + dv) & (v < v1 - dv)


def _cut_plane(surface, other: SurfaceDistance, x0: float, x1: float, stations: int = 17,
               apart: float = np.inf) -> tuple[float, float]:
    """The transverse plane x = X in [x0, x1] where the face's section lies closest to the
    other face (least largest distance): where cutting the two leaves the smallest step.
    Where no plane gives a section (faces lying in one transverse plane), the middle, and
    the step there is at most ``apart``, the faces' largest distance."""
    best = (0.5 * (x0 + x1), np.inf)
    for x in np.linspace(x0, x1, stations):
        dist = section_distances(surface, other, float(x), 60)
        if len(dist) < 2:
            continue
        step = float(dist.max())
        if step < best[1]:
            best = (float(x), step)
    return best if np.isfinite(best[1]) else (best[0], apart)


def section_distances(surface, other: SurfaceDistance, x: float, lines: int) -> np.ndarray:
    """Distances (N,) from the other face of the face's section by the plane x = ``x``
    (``lines`` iso-lines cut), over the section's points whose foot lies inside that face."""
    try:
        section = surface.plane_section_points((x, 0.0, 0.0), (1.0, 0.0, 0.0), lines)
    except ValueError:  # the plane holds the face (a transom given twice) or cuts no iso-curve once
        return np.zeros(0)
    if len(section) == 0:
        return np.zeros(0)
    params, dist = other.closest(section)
    return dist[interior(other.surfaces[0], params)]


def _samples(face: HullFace) -> tuple[np.ndarray, np.ndarray]:
    """Points of the face inside its trim on a SAMPLES x SAMPLES grid (cell centres), their
    cells' areas and their (u, v)."""
    s = face.surface
    u_edges = np.linspace(*s.domain_u, SAMPLES + 1)
    v_edges = np.linspace(*s.domain_v, SAMPLES + 1)
    grid = s.grid(u_edges, v_edges)
    a, b, c, d = grid[:-1, :-1], grid[1:, :-1], grid[:-1, 1:], grid[1:, 1:]
    cell = 0.5 * (np.linalg.norm(np.cross(b - a, c - a), axis=-1) + np.linalg.norm(np.cross(b - d, c - d), axis=-1))
    uc = 0.5 * (u_edges[:-1] + u_edges[1:])
    vc = 0.5 * (v_edges[:-1] + v_edges[1:])
    uu, vv = np.meshgrid(uc, vc, indexing="ij")
    params = np.column_stack([uu.ravel(), vv.ravel()])
    keep = _inside(face, params)
    points = s.grid(uc, vc).reshape(-1, 3)
    return points[keep], cell.ravel()[keep], params[keep]


def _median_angle(surface_a, params_a: np.ndarray, surface_b, params_b: np.ndarray) -> float:
    """Median angle (degrees) between the two surfaces' tangent planes at matching points."""
    na, nb = _normals(surface_a, params_a), _normals(surface_b, params_b)
    return float(np.median(np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", na, nb)), 0.0, 1.0)))))


def _inside(face: HullFace, params: np.ndarray) -> np.ndarray:
    """Which (u, v) lie inside the face's trim (all of them for an untrimmed face)."""
    if not face.trimmed:
        return np.ones(len(params), dtype=bool)
    from matplotlib.path import Path as MplPath

    keep = np.ones(len(params), dtype=bool)
    if face.outer is not None:
        keep &= MplPath(face.outer).contains_points(params)
    for loop in face.inner:
        keep &= ~MplPath(loop).contains_points(params)
    return keep



def model_reports(sources, base: Path, tolerance: float = 1.0) -> list[dict]:
    """The sewing report of every model file that ``sources`` (surface sources with a
    ``model`` path, relative to ``base``) read faces from, each file once."""
    from ..io.hullmodel import read_hull_model
    from ..io.sources import source_path

    used: dict = {}
    for source in sources:
        faces = source.faces if getattr(source, "faces", None) else [source.face]
        used.setdefault(source_path(base, source.model), set()).update(faces)
    reports = []
    for path, faces in used.items():
        try:
            reports.append(sew_report(read_hull_model(path), tolerance, only=faces).as_dict())
        except Exception as exc:  # noqa: BLE001 - the plates are made; the report says what its sewing met
            reports.append({"file": str(path), "schema": SCHEMA, "faces_used": sorted(faces),
                            "error": f"the sewing report failed: {type(exc).__name__}: {exc}"})
    return reports


def overlap_cuts(surfaces: list, trims: list, tolerance: float) -> tuple[list[tuple], list[Overlap]]:
    """Where a plan cuts faces that lie on each other: for each face the x range it keeps,
    (lo, hi) with None for no cut, and the overlaps found. Of two overlapping faces, the one
    whose middle lies aft of the cut plane keeps the part aft of it, the other the part fore
    of it, so that the shell is covered once (their plates meet at the plane)."""
    faces = tuple(HullFace(k, s, None if t is None else t.outer, () if t is None else tuple(t.inner), float("nan"))
                  for k, (s, t) in enumerate(zip(surfaces, trims)))
    model = HullModel(Path("plan"), "plan", faces)
    overlaps = overlaps_of(model, tolerance) if len(faces) > 1 else []
    limits = [[None, None] for _ in faces]
    for overlap in overlaps:
        for k in overlap.faces:
            x = faces[k].surface.grid(np.linspace(*faces[k].surface.domain_u, 9),
                                      np.linspace(*faces[k].surface.domain_v, 9))[..., 0]
            if 0.5 * (x.min() + x.max()) < overlap.cut_x_mm:
                limits[k][1] = overlap.cut_x_mm if limits[k][1] is None else min(limits[k][1], overlap.cut_x_mm)
            else:
                limits[k][0] = overlap.cut_x_mm if limits[k][0] is None else max(limits[k][0], overlap.cut_x_mm)
    return [tuple(lim) for lim in limits], overlaps
