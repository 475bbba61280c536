"""Templates that check a formed plate: its sections by planes, as a plater cuts them (mm).

A template is the plate's section by a plane (a frame x = X of a hull plate, or a plane
across the rulings of a rolled strip), cut from board or thin plate at 1:1: its edge follows
the section, a straight base line (the chord between its two ends, each at least ``margin``
inside the plate's edges) is drawn on it with the heights from the base line to the section
every ``step`` along the chord, and a sight line: the template's plane cut by one plane
common to all templates of the plate (parallel to the plate's mean tangent plane, 100 mm
beyond the farthest base line, on the base lines' side). Set on the formed plate, the
templates' edges touch it and their sight lines lie in one plane: a twist shows.

The plate is checked from the side its base lines are on (the concave side of a section).

How many templates (the ShipConstructor rule, stated in every report): none for a plate
that needs no rolling (pulled into place elastically) or whose sections are all arcs of one
radius (constant-radius single curvature: the radius gauge of its bending lines checks it);
one, at the candidate nearest the plate's middle, for single curvature of varying radius;
every candidate (frames, or planes at most ``spacing`` apart), at least three, for double
curvature. Constant radius: every candidate section within 0.5 mm of its own best-fit
circle and all their radii within 1 % of each other.

Everything here is geometry on arrays: a plate is given as a triangle mesh with the flat
(developed) position of every vertex.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

CIRCLE_TOLERANCE = 0.5  # mm: a section this close to its best-fit circle is an arc
RADIUS_SPREAD = 0.01  # sections' radii within 1 % of each other: one radius
SIGHT_OFFSET = 100.0  # mm: the sight plane beyond the farthest base line
TEMPLATE_STEP = 250.0  # mm between heights along a base line (AVEVA Hull's default)


@dataclass(frozen=True)
class Template:
    """One template (mm).

    ident : 'T1', 'T2', ... ; name : what its plane is ('FR 92500', or 'Z 750' along the rulings)
    origin, normal : (3,) its plane; points : (n, 3) the section between its ends (on the plate)
    flat : (n, 2) the same points on the flat plate (where the template stands)
    base : (2, 3) the base line's ends (the section's ends); length : the base line's length
    stations : (k,) positions along the base line, every ``step`` and its end
    heights : (k,) from the base line to the section at the stations (> 0 towards the plate)
    profile : (n, 2) the section in the template's own axes (along the base line, height)
    sight : (2,) heights of the sight line at the base line's two ends (< 0: beyond the base
        line, away from the plate); nan when the template has no sight line
    """

    ident: str
    name: str
    origin: np.ndarray
    normal: np.ndarray
    points: np.ndarray
    flat: np.ndarray
    base: np.ndarray
    length: float
    stations: np.ndarray
    heights: np.ndarray
    profile: np.ndarray
    sight: np.ndarray

    def figures(self) -> dict:
        return {"id": self.ident, "plane": self.name, "origin": self.origin.tolist(), "normal": self.normal.tolist(),
                "base_line": self.base.tolist(), "length": self.length,
                "flat_line": [self.flat[0].tolist(), self.flat[-1].tolist()],
                "stations": self.stations.tolist(), "heights": self.heights.tolist(),
                "max_height": float(np.max(np.abs(self.heights))) if len(self.heights) else 0.0,
                "sight_line_heights": [None if not np.isfinite(h) else float(h) for h in self.sight]}


def mesh_section(vertices: np.ndarray, faces: np.ndarray, flat: np.ndarray, origin, normal):
    """The section of a triangle mesh by the plane (origin, normal): ((n, 3) points, (n, 2)
    their flat positions), ordered along the section's longest direction; empty arrays when
    the plane misses the mesh. vertices (V, 3), faces (F, 3), flat (V, 2)."""
    origin, normal = np.asarray(origin, float), np.asarray(normal, float)
    normal = normal / np.linalg.norm(normal)
    d = (vertices - origin) @ normal
    # a vertex on the plane (to round-off) is a point of the section itself; an edge
    # crosses where its ends lie strictly on both sides
    on = np.abs(d) <= 1e-12 * max(1.0, float(np.abs(vertices).max()))
    d = np.where(on, 0.0, d)
    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True
    pts3, pts2 = [vertices[on & used]], [flat[on & used]]
    tri = d[faces]  # (F, 3) signed distances of the corners
    for i, j in ((0, 1), (1, 2), (2, 0)):  # every edge that changes sign strictly
        fi = np.flatnonzero(tri[:, i] * tri[:, j] < 0)
        a, b = faces[fi, i], faces[fi, j]
        w = (d[a] / (d[a] - d[b]))[:, None]
        pts3.append(vertices[a] + w * (vertices[b] - vertices[a]))
        pts2.append(flat[a] + w * (flat[b] - flat[a]))
    p3, p2 = np.vstack(pts3), np.vstack(pts2)
    # each edge is shared by two faces: keep one point of each pair
    _, keep = np.unique(np.round(p3, 6), axis=0, return_index=True)
    p3, p2 = p3[keep], p2[keep]
    if len(p3) < 2:
        return np.zeros((0, 3)), np.zeros((0, 2))
    # a template's section is a graph over its chord: order by the principal direction
    centred = p3 - p3.mean(axis=0)
    axis = np.linalg.svd(centred, full_matrices=False)[2][0]
    order = np.argsort(centred @ axis)
    return p3[order], p2[order]


def trimmed(points: np.ndarray, flat: np.ndarray, outline: np.ndarray, margin: float):
    """The part of a section at least ``margin`` inside the flat plate's ``outline`` (N, 2),
    its ends interpolated where the distance to the outline is exactly ``margin`` (the
    development is isometric: distance on the flat plate is distance on the plate)."""
    import shapely

    ring = shapely.LinearRing(outline)
    inside = shapely.contains_xy(shapely.Polygon(outline), flat[:, 0], flat[:, 1])
    dist = np.where(inside, shapely.distance(shapely.points(flat), ring), -1.0) - margin
    good = np.flatnonzero(dist >= 0)
    if len(good) < 2:
        return np.zeros((0, 3)), np.zeros((0, 2))
    # the longest run of consecutive points inside
    runs = np.split(good, np.flatnonzero(np.diff(good) > 1) + 1)
    run = max(runs, key=len)
    i0, i1 = run[0], run[-1]
    p3, p2 = [points[i0:i1 + 1]], [flat[i0:i1 + 1]]
    for k, nb, front in ((i0, i0 - 1, True), (i1, i1 + 1, False)):
        if 0 <= nb < len(points) and dist[nb] < 0:
            w = dist[k] / (dist[k] - dist[nb])
            e3, e2 = points[k] + w * (points[nb] - points[k]), flat[k] + w * (flat[nb] - flat[k])
            if front:
                p3.insert(0, e3[None]), p2.insert(0, e2[None])
            else:
                p3.append(e3[None]), p2.append(e2[None])
    return np.vstack(p3), np.vstack(p2)


def _axes(points: np.ndarray, normal: np.ndarray):
    """Template axes: e1 along the base line, e2 in the plane towards the section."""
    e1 = points[-1] - points[0]
    length = float(np.linalg.norm(e1))
    e1 = e1 / length
    e2 = np.cross(normal, e1)
    e2 /= np.linalg.norm(e2)
    if np.mean((points - points[0]) @ e2) < 0:
        e2 = -e2
    return e1, e2, length


def section_template(ident, name, origin, normal, points, flat, step: float) -> Template:
    """A template from a trimmed section (n, 3) with its flat points (n, 2): base line,
    heights every ``step`` along it (and at its end); no sight line yet."""
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    e1, e2, length = _axes(points, normal)
    s, h = (points - points[0]) @ e1, (points - points[0]) @ e2
    stations = np.append(np.arange(0.0, length, step), length)
    if len(stations) > 1 and stations[-1] - stations[-2] < 1e-9 * max(length, 1.0):
        stations = stations[:-1]
    order = np.argsort(s, kind="stable")
    heights = np.interp(stations, s[order], h[order])
    return Template(ident, name, np.asarray(origin, float), normal, points, flat, points[[0, -1]].copy(), length,
                    stations, heights, np.column_stack([s, h]), np.full(2, np.nan))


def with_sight_lines(templates: list[Template], plate_normal: np.ndarray, offset: float = SIGHT_OFFSET) -> list:
    """The templates with their sight lines: each one's plane cut by the common sight plane
    (normal the plate's mean normal, ``offset`` beyond the farthest base-line end, on the
    base lines' side)."""
    if not templates:
        return []
    n = np.asarray(plate_normal, float) / np.linalg.norm(plate_normal)
    # the sight plane lies on the base lines' side: away from the plate seen from the chords
    towards_plate = np.mean([_axes(t.points, t.normal)[1] for t in templates], axis=0)
    if n @ towards_plate > 0:
        n = -n
    level = max(float(np.max(t.base @ n)) for t in templates) + offset
    out = []
    for t in templates:
        e1, e2, _ = _axes(t.points, t.normal)
        along, up = n @ e1, n @ e2
        if abs(up) < 0.1:  # the template's plane nearly holds the sight plane's normal: no line
            out.append(t)
            continue
        base = n @ t.points[0]
        sight = (level - base - np.array([0.0, t.length]) * along) / up
        out.append(dataclasses.replace(t, sight=sight))
    return out


def circle_fit(profile: np.ndarray) -> tuple[float, float]:
    """(radius, largest distance of the points from the circle) of the least-squares
    (Kasa) circle through (n, 2) points; inf radius for a straight section."""
    x, y = profile[:, 0], profile[:, 1]
    a = np.column_stack([x, y, np.ones_like(x)])
    sol, *_ = np.linalg.lstsq(a, x * x + y * y, rcond=None)
    cx, cy = sol[0] / 2, sol[1] / 2
    r2 = sol[2] + cx * cx + cy * cy
    if not np.isfinite(r2) or r2 <= 0:
        return float("inf"), float(np.ptp(y))
    r = float(np.sqrt(r2))
    return r, float(np.abs(np.hypot(x - cx, y - cy) - r).max())


def count_rule(candidates: list[Template], curvature: str) -> tuple[list[int], str]:
    """Which candidates become templates, and why (see the module's rule). curvature:
    'none' (no rolling), 'single' or 'double'."""
    if curvature == "none" or not candidates:
        return [], ("no templates: the plate needs no rolling (pulled into place elastically)" if curvature == "none"
                    else "no templates: no section of the plate fits inside its margins")
    if curvature == "double":
        return list(range(len(candidates))), "double curvature: a template at every candidate plane (at least 3)"
    fits = [circle_fit(t.profile) for t in candidates]
    radii = np.array([r for r, _ in fits])
    arcs = all(dev <= CIRCLE_TOLERANCE for _, dev in fits) and np.all(np.isfinite(radii))
    if arcs and np.ptp(radii) <= RADIUS_SPREAD * radii.min():
        return [], (f"no templates: single curvature of one radius (every section an arc of R {radii.mean():.0f} "
                    f"within {CIRCLE_TOLERANCE:g} mm); the bending lines' radius checks it")
    middle = int(np.argmin([abs(k - 0.5 * (len(candidates) - 1)) for k in range(len(candidates))]))
    return [middle], "single curvature of varying radius: one template, at the candidate nearest the plate's middle"


def candidate_planes(frames: list, middle_ruling, spacing: float, margin: float):
    """[(name, origin (3,), normal (3,))]: the frames x = X of a hull plate (mm), else
    planes square to the plate's middle ruling ((2, 3) its ends on the plate, mm) through
    the middles of ``count`` equal pieces of it, count = ceil(length / spacing), so they are
    at most ``spacing`` apart (named by their distance from the ruling's first end): the
    normal sections across the rulings, where a rolled plate's curvature is. (A plane near
    a curved edge would leave the plate within a short way; the middles keep them long.)"""
    if frames:
        return [(f"FR {x:g}", np.array([x, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])) for x in frames]
    a, b = np.asarray(middle_ruling, float)
    length = float(np.linalg.norm(b - a))
    if length <= 2 * margin:
        return []
    e = (b - a) / length
    count = int(np.ceil(length / spacing))
    return [(f"R {at:.0f}", a + at * e, e) for at in (np.arange(count) + 0.5) * length / count]


def plate_templates(vertices, faces, flat, outline, planes, curvature: str, plate_normal, margin: float = 100.0,
                    step: float = 250.0) -> tuple[list[Template], list[Template], str]:
    """The plate's templates (mm): (chosen, every candidate, the count rule's reason).

    vertices (V, 3), faces (F, 3), flat (V, 2): the plate as a mesh with its development;
    outline (N, 2) the flat plate's net outline; planes from :func:`candidate_planes`;
    curvature 'none', 'single' or 'double'; plate_normal (3,) the plate's mean normal."""
    candidates = []
    for name, origin, normal in planes:
        p3, p2 = mesh_section(vertices, faces, flat, origin, normal)
        if len(p3) < 2:
            continue
        p3, p2 = trimmed(p3, p2, outline, margin)
        if len(p3) < 2 or np.linalg.norm(p3[-1] - p3[0]) < 2 * step:
            continue
        candidates.append(section_template("", name, origin, normal, p3, p2, step))
    chosen, why = count_rule(candidates, curvature)
    if curvature == "double" and 0 < len(chosen) < 3:
        why += f" (only {len(chosen)} candidate plane(s) cross the plate inside its margins)"
    picked = [dataclasses.replace(candidates[k], ident=f"T{j + 1}") for j, k in enumerate(chosen)]
    return with_sight_lines(picked, plate_normal), candidates, why


def write_templates_dxf(path, plate_name: str, templates: list[Template], text_height: float = 25.0) -> int:
    """NAME_templates.dxf: R2000, mm, 1:1; one block per template (its cut contour on
    TEMPLATE_CUT, base and sight lines on TEMPLATE_BASE / TEMPLATE_SIGHT, height lines and
    texts on TEMPLATE_TEXT), inserted one above the other. Returns the audit's error count."""
    import ezdxf
    import ezdxf.units

    from ..io.atomic import atomic_path

    doc = ezdxf.new("R2000", setup=False)
    doc.units = ezdxf.units.MM
    doc.header["$INSUNITS"] = 4
    doc.header["$MEASUREMENT"] = 1
    for name, colour in (("TEMPLATE_CUT", 7), ("TEMPLATE_BASE", 1), ("TEMPLATE_SIGHT", 3), ("TEMPLATE_TEXT", 2)):
        doc.layers.add(name, color=colour)
    msp = doc.modelspace()
    y = 0.0
    for t in templates:
        block = doc.blocks.new(f"TEMPLATE_{t.ident}")
        s, h = t.profile[:, 0], t.profile[:, 1]
        sight = np.nan_to_num(t.sight, nan=-SIGHT_OFFSET)
        top = min(float(sight.min()), 0.0) - 3.0 * text_height  # the board's straight back, beyond the sight line
        contour = [(float(a), float(b)) for a, b in zip(s, h)] + [(float(s[-1]), top), (float(s[0]), top)]
        block.add_lwpolyline(contour, close=True, dxfattribs={"layer": "TEMPLATE_CUT"})
        block.add_line((0.0, 0.0), (t.length, 0.0), dxfattribs={"layer": "TEMPLATE_BASE"})
        if np.all(np.isfinite(t.sight)):
            block.add_line((0.0, float(t.sight[0])), (t.length, float(t.sight[1])),
                           dxfattribs={"layer": "TEMPLATE_SIGHT"})
        for at, height in zip(t.stations, t.heights):
            block.add_line((float(at), 0.0), (float(at), float(height)), dxfattribs={"layer": "TEMPLATE_TEXT"})
            block.add_text(f"{height:.1f}", height=0.4 * text_height, rotation=90.0,
                           dxfattribs={"layer": "TEMPLATE_TEXT"}).set_placement(
                (float(at) - 0.1 * text_height, -0.2 * text_height), align=ezdxf.enums.TextEntityAlignment.MIDDLE_RIGHT)
        block.add_text(f"{plate_name} {t.ident} {t.name}  BASE {t.length:.0f} MM  HEIGHTS EVERY "
                       f"{t.stations[1] - t.stations[0] if len(t.stations) > 1 else 0:.0f} MM",
                       height=text_height, dxfattribs={"layer": "TEMPLATE_TEXT"}).set_placement(
            (0.5 * t.length, top + text_height), align=ezdxf.enums.TextEntityAlignment.MIDDLE_CENTER)
        y -= top
        msp.add_blockref(block.name, (0.0, y))
        y += float(h.max()) + 4.0 * text_height
    msp.dxf.extmin = (0.0, 0.0, 0.0)
    msp.dxf.extmax = (max((t.length for t in templates), default=0.0), y, 0.0)
    doc.header["$EXTMIN"], doc.header["$EXTMAX"] = msp.dxf.extmin, msp.dxf.extmax
    errors = len(doc.audit().errors)
    with atomic_path(path) as tmp:
        doc.saveas(tmp)
    return errors


def tracer_mesh(tracer, scale: float, spacing_mm: float = 10.0, samples: int = 9):
    """The plate of a solved strip as a dense mesh, exact on the strip at its vertices:
    (vertices (V, 3) mm, faces (F, 3), flat (V, 2) mm placed, the middle ruling's ends on the
    plate (2, 3) mm, mean normal (3,)). Rulings about ``spacing_mm`` apart along the plate (the mesh's chord
    error across them is spacing^2 / (8 R): 0.006 mm at R 2 m), each kept between the butts."""
    first, last, corners = tracer.plate_range()
    lam = np.linspace(first, last, 257)
    lo, hi, _, _, pc, pd = tracer.interval(lam)
    mid = pc + (0.5 * (lo + hi))[:, None] * (pd - pc)
    length = float(np.linalg.norm(np.diff(mid, axis=0), axis=1).sum()) * scale
    n = int(np.clip(length / spacing_mm, 200, 4000))
    lam = np.union1d(np.linspace(first, last, n), corners)
    lo, hi, _, _, pc, pd = tracer.interval(lam)
    ac, ad = tracer.developed_at(lam)
    v = lo[:, None] + np.linspace(0.0, 1.0, samples)[None, :] * (hi - lo)[:, None]  # (K, m)
    vertices = (pc[:, None, :] + v[..., None] * (pd - pc)[:, None, :]).reshape(-1, 3) * scale
    flat = (ac[:, None, :] + v[..., None] * (ad - ac)[:, None, :]).reshape(-1, 2) * scale
    k, m = len(lam), samples
    i, j = np.meshgrid(np.arange(k - 1), np.arange(m - 1), indexing="ij")
    a = (i * m + j).ravel()
    faces = np.vstack([np.column_stack([a, a + m, a + 1]), np.column_stack([a + 1, a + m, a + m + 1])])
    middle = (pc[k // 2] + np.outer([lo[k // 2], hi[k // 2]], pd[k // 2] - pc[k // 2])) * scale
    normal = tracer.normals(lam).mean(axis=0)
    return vertices, faces, flat, middle, normal


def templates_section(chosen: list, candidates: list, why: str, curvature: str, spacing: float, margin: float,
                      step: float) -> dict:
    """The report's ``templates`` section."""
    sections = []
    for t in candidates:
        radius, deviation = circle_fit(t.profile)
        sections.append({"plane": t.name, "length": t.length, "arc_radius": radius if np.isfinite(radius) else None,
                         "arc_deviation": deviation})
    return {"units": "mm", "count": len(chosen), "rule": why, "curvature": curvature, "candidates": len(candidates),
            "candidate_sections": sections, "margin": margin, "height_step": step,
            "spacing": spacing, "checked_from": "the side the base line is on (the concave side of each section)",
            "count_rule": "ShipConstructor: none for constant-radius single curvature (or no rolling), one for a "
                          "varying radius, at least three for double curvature",
            "templates": [t.figures() for t in chosen]}


def _subdivided(grid: np.ndarray, factor: int) -> np.ndarray:
    """A (R, C, k) grid with every cell cut into factor x factor cells, bilinearly."""
    r, c = grid.shape[:2]
    si, sj = np.linspace(0, r - 1, (r - 1) * factor + 1), np.linspace(0, c - 1, (c - 1) * factor + 1)
    i0, j0 = np.minimum(si.astype(int), r - 2), np.minimum(sj.astype(int), c - 2)
    fi, fj = (si - i0)[:, None, None], (sj - j0)[None, :, None]
    g00, g01 = grid[i0][:, j0], grid[i0][:, j0 + 1]
    g10, g11 = grid[i0 + 1][:, j0], grid[i0 + 1][:, j0 + 1]
    return (1 - fi) * ((1 - fj) * g00 + fj * g01) + fi * ((1 - fj) * g10 + fj * g11)


def grid_faces(rows: int, cols: int) -> np.ndarray:
    idx = np.arange(rows * cols).reshape(rows, cols)
    a, b, d, e = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    return np.concatenate([np.column_stack([a, b, e]), np.column_stack([a, e, d])])


def hull_mesh(surface, params: np.ndarray, flat: np.ndarray, scale: float, target_mm: float = 50.0,
              offsets: np.ndarray | None = None):
    """A hull plate's region grid as a fine mesh on the hull surface itself: params (R, C, 2)
    the grid's surface parameters, flat (R, C, 2) its developed (placed) points (model
    units; ``scale`` mm per unit), refined to cells of about ``target_mm`` (the mesh's chord
    error target^2 / (8 R): 0.06 mm at R 5 m); ``offsets`` (R, C, 3), model units: moves of
    the grid's points off the hull (a formed plate formed to meet its neighbours,
    :mod:`pipeline.hull.follow`), refined bilinearly. Returns (vertices (V, 3) mm, faces
    (F, 3), flat (V, 2) mm, area-weighted mean normal (3,))."""
    points = np.asarray(surface(params[..., 0].ravel(), params[..., 1].ravel())).reshape(params.shape[:2] + (3,))
    cell = max(float(np.linalg.norm(np.diff(points, axis=0), axis=2).max()),
               float(np.linalg.norm(np.diff(points, axis=1), axis=2).max())) * scale
    factor = int(np.clip(np.ceil(cell / target_mm), 1, 16))
    fine_params, fine_flat = _subdivided(params, factor), _subdivided(flat, factor)
    rows, cols = fine_params.shape[:2]
    vertices = np.asarray(surface(fine_params[..., 0].ravel(), fine_params[..., 1].ravel())) * scale
    if offsets is not None:
        vertices = vertices + _subdivided(np.asarray(offsets, dtype=np.float64), factor).reshape(-1, 3) * scale
    faces = grid_faces(rows, cols)
    e1, e2 = vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]]
    return vertices, faces, fine_flat.reshape(-1, 2) * scale, np.cross(e1, e2).sum(axis=0)


def patch_templates(vertices, faces, flat, normal, outline_mm: np.ndarray, frames_mm: list, curvature: str,
                    spacing: float, margin: float, step: float = TEMPLATE_STEP):
    """Templates of a hull plate from its :func:`hull_mesh` (the hull surface's own
    sections: the design shape the formed plate is checked against), at its frames (mm);
    without frames, planes x = X through the middles of equal pieces of the plate's length,
    at most ``spacing`` apart. Returns (chosen, candidates, why) as :func:`plate_templates`."""
    if frames_mm:
        planes = candidate_planes(frames_mm, None, spacing, margin)
    else:
        x = vertices[:, 0]
        along = np.array([[x.min(), 0.0, 0.0], [x.max(), 0.0, 0.0]])
        planes = [(f"X {o[0]:.0f}", o, n) for _, o, n in candidate_planes([], along, spacing, margin)]
    return plate_templates(vertices, faces, flat, outline_mm, planes, curvature, normal, margin, step)


def checked_by(line_figures: list, templates) -> None:
    """Add to each bending line's report entry (``start``, ``end`` on the flat plate, mm)
    the templates that cross it, which check its radius once rolled; a rolled line no
    template crosses is checked with a radius gauge."""
    import shapely

    paths = [(t.ident, shapely.LineString(t.flat)) for t in templates if len(t.flat) >= 2]
    for entry in line_figures:
        segment = shapely.LineString([entry["start"], entry["end"]])
        entry["checked_by"] = [ident for ident, path in paths if path.intersects(segment)] or ["radius gauge"]
