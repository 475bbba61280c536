"""Is the shell covered once? Plates' delivered regions in each hull surface's parameters.

A delivered plate's boundary ring (3D, on the plate) is mapped to its surface by closest
points: a polygon in (u, v) (shapely). The reference is what the plan set out to cover: a
planned shell (``strake.plan``) the whole surface inside its IGES trim, a hand-laid strake the
union of its plates' planned regions (between their seams and butts, whether delivered or
not). Areas are areas on the surface, per cell of a fixed AREA_CELLS x AREA_CELLS parameter
grid: a whole cell by 2 x 2 Gauss points of the area element |S_u x S_v|, a cell the polygon
cuts by the piece's parameter area times the area element at the piece's centroid (a
midpoint rule: exact for an area element linear over the cell).

covered = area(union of plates inside the reference) / area(reference), computed as the sum
of the plates' areas inside it less the pairwise overlaps (exact where no point is covered
three times); overlap = area inside two plates / area(reference); outside = plate area
beyond the reference (steel cut for shell that is not there, e.g. beyond a trim).
"""

from __future__ import annotations

import numpy as np

from flatten.patch import grid_ring, region_grid

from .trims import valid_polygon

AREA_CELLS = 64
REGION_ROWS, REGION_COLS = 33, 129  # planned region's boundary samples (girth, length)


def area_element(surface, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """|S_u x S_v| (N,) by central differences (one-sided at the domain's edges)."""
    su, sv = surface.partials(u, v)
    return np.linalg.norm(np.cross(su, sv), axis=1)


def surface_area(surface, geom, cells: int = AREA_CELLS) -> float:
    """Area on the surface (model units^2) of a shapely geometry in its (u, v)."""
    import shapely

    if geom is None or geom.is_empty:
        return 0.0
    ue, ve = _cell_edges(surface.domain_u, surface.knots_u, surface.degree_u, cells), \
        _cell_edges(surface.domain_v, surface.knots_v, surface.degree_v, cells)
    bu0, bv0, bu1, bv1 = geom.bounds
    iu = np.arange(max(0, np.searchsorted(ue, bu0, "right") - 1),
                   min(len(ue) - 1, np.searchsorted(ue, bu1, "left") + 1))
    iv = np.arange(max(0, np.searchsorted(ve, bv0, "right") - 1),
                   min(len(ve) - 1, np.searchsorted(ve, bv1, "left") + 1))
    if not len(iu) or not len(iv):
        return 0.0
    i, j = np.meshgrid(iu, iv, indexing="ij")
    i, j = i.ravel(), j.ravel()
    boxes = shapely.box(ue[i], ve[j], ue[i + 1], ve[j + 1])
    pieces = shapely.intersection(boxes, geom)
    area = shapely.area(pieces)
    du, dv = ue[i + 1] - ue[i], ve[j + 1] - ve[j]
    cell = du * dv
    full = area >= cell * (1.0 - 1e-12)
    part = (area > 0) & ~full
    total = 0.0
    if full.any():  # whole cells: 2 x 2 Gauss points (exact for a bicubic area element)
        g = 0.5 + np.array([-0.5, 0.5]) / np.sqrt(3.0)
        cu = ue[i[full]][:, None, None] + du[full][:, None, None] * g[None, :, None]
        cv = ve[j[full]][:, None, None] + dv[full][:, None, None] * g[None, None, :]
        cu, cv = np.broadcast_arrays(cu, cv)
        elements = area_element(surface, cu.ravel(), cv.ravel()).reshape(-1, 4)
        total += 0.25 * float((cell[full] * elements.sum(axis=1)).sum())
    if part.any():  # cut cells: the area element at the piece's centroid
        centre = shapely.centroid(pieces[part])
        total += float(np.sum(area[part] * area_element(surface, shapely.get_x(centre), shapely.get_y(centre))))
    return total


def _cell_edges(domain, knots, degree: int, cells: int) -> np.ndarray:
    """Cell edges along one parameter: ``cells`` equal cells, split at the surface's knots of
    full multiplicity (where it may turn, C0: its area element jumps there, which Gauss points
    straddling it would smooth over; a lofted shell's girth knot at its faces' junction sits
    where KVLCC2's loft crowds 42 % of its girth parameter on a flat 29 mm wide)."""
    lo, hi = domain
    values, counts = np.unique(np.asarray(knots, dtype=float), return_counts=True)
    breaks = values[(counts >= degree) & (values > lo) & (values < hi)]
    return np.union1d(np.linspace(lo, hi, cells + 1), breaks)


def planned_region(hull):
    """The plate's region between its seams and butts as a polygon in (u, v) (None if empty)."""
    planes = [None if p is None else p.as_tuple() for p in hull.butts]
    grid = region_grid(hull.surface, hull.long_axis, hull.girths[0], hull.girths[1], planes, REGION_ROWS,
                       REGION_COLS, probe=400)
    if grid is None:
        return None
    return valid_polygon(grid_ring(grid.params))


def _trim_region(surface, trim):
    import shapely

    if trim is not None:
        return trim.face_region(surface)
    (u0, u1), (v0, v1) = surface.domain_u, surface.domain_v
    return shapely.box(u0, v0, u1, v1)


def _shell_references(parts) -> dict:
    """id(surface) -> (region in (u, v), what it is) for a planned shell: each surface inside
    its trim (the plan's, ``HullPlate.face_trim``), and within the x range a plan keeps of it."""
    import shapely

    out = {}
    for part in parts:
        key, hull = id(part.hull.surface), part.hull
        if key in out:
            continue
        trim = hull.face_trim
        out[key] = (_trim_region(hull.surface, trim), "the surface inside its trim" if trim is not None
                    else "the whole surface")
    # a face the plan cut where it overlaps another keeps one side of the cut; a face planned
    # beyond both ends of a loft keeps both its ends (the union of the x ranges its plates keep)
    kept = {}
    for part in parts:
        limits, key = tuple(part.hull.x_limits), id(part.hull.surface)
        if any(x is not None for x in limits):
            kept.setdefault(key, {})[limits] = part.hull
    for key, ranges in kept.items():
        region, what = out[key]
        hull = next(iter(ranges.values()))
        keep = shapely.union_all([x_range_region(hull.surface, hull.long_axis, lim) for lim in ranges])
        cuts = sorted({x for lim in ranges for x in lim if x is not None})
        out[key] = (region.intersection(keep), f"{what}, cut at x = {' and '.join(f'{x:.0f}' for x in cuts)}")
    return out


def x_range_region(surface, axis: int, limits: tuple, lines: int = 201, samples: int = 2001):
    """The part of the surface's parameter rectangle where x lies within ``limits`` (lo, hi;
    None: open), as a polygon in (u, v): on each of ``lines`` girth lines the parameter
    along the hull where x crosses a limit (x runs monotone along the hull), interpolated on
    ``samples`` points."""
    import shapely

    s_dom = surface.domain_u if axis == 0 else surface.domain_v
    g_dom = surface.domain_v if axis == 0 else surface.domain_u
    s = np.linspace(*s_dom, samples)
    g = np.linspace(*g_dom, lines)
    x = (surface.grid(s, g) if axis == 0 else surface.grid(g, s).transpose(1, 0, 2))[..., 0]  # (samples, lines)
    bounds = []
    for limit, extreme in zip(limits, (np.argmin, np.argmax)):
        crossing = np.empty(lines)
        for k in range(lines):
            xs = x[:, k]
            order = np.argsort(xs)
            # an open side runs to the hull's end, wherever x has its extreme on the line
            crossing[k] = s[extreme(xs)] if limit is None else np.interp(limit, xs[order], s[order])
        bounds.append(crossing)
    ring_s = np.concatenate([bounds[0], bounds[1][::-1]])
    ring_g = np.concatenate([g, g[::-1]])
    ring = np.column_stack([ring_s, ring_g] if axis == 0 else [ring_g, ring_s])
    return shapely.make_valid(shapely.Polygon(ring))


def shell_coverage(records: dict, parts, config) -> dict | None:
    """Coverage, overlap and area outside the reference, over all surfaces and per surface.

    records : plate name -> (PlateEdges, Part) of the delivered plates
    parts : every hull plate of the run (delivered or not)"""
    import shapely
    from shapely.strtree import STRtree

    from flatten.closest import SurfaceDistance

    if not parts:
        return None
    mm2 = (config.mm_per_unit / 1e3) ** 2
    planned = config.spec.strake is not None and config.spec.strake.plan is not None
    if planned:
        references = _shell_references(parts)
    else:
        regions = {}
        for p in parts:
            poly = planned_region(p.hull)
            if poly is not None:
                regions.setdefault(id(p.hull.surface), []).append(poly)
        references = {k: (shapely.union_all(v), "the strake's planned plate regions") for k, v in regions.items()}
    by_surface = {}
    for name, (rec, part) in records.items():
        by_surface.setdefault(id(part.hull.surface), (part.hull.surface, []))[1].append((name, rec))
    totals = {"shell": 0.0, "covered": 0.0, "overlap": 0.0, "outside": 0.0}
    surfaces = []
    for key, (reference, what) in references.items():
        surface, plates = by_surface.get(key, (next(p.hull.surface for p in parts if id(p.hull.surface) == key), []))
        shell = surface_area(surface, reference)
        polys = []
        if plates:
            distance = SurfaceDistance(surface)
            for name, rec in plates:
                uv, _ = distance.closest(rec.ring3)
                poly = valid_polygon(uv)
                trim = next((p.hull.trim for p in parts if p.name == name), None)
                if trim is not None and rec.klass in ("flat", "formed"):
                    # a patch plate reaching past its face's trim is cut there (pipeline.hull.trimcut)
                    poly = poly.intersection(_trim_region(surface, trim))
                polys.append(poly)
        inside = sum(surface_area(surface, p.intersection(reference)) for p in polys)
        outside = sum(surface_area(surface, p.difference(reference)) for p in polys)
        overlap_pieces = []
        if len(polys) > 1:
            tree = STRtree(polys)
            a, b = tree.query(polys, predicate="intersects")
            for i, j in zip(a, b):
                if i < j:
                    piece = polys[i].intersection(polys[j]).intersection(reference)
                    if piece.area > 0:
                        overlap_pieces.append(piece)
        overlap = sum(surface_area(surface, p) for p in overlap_pieces)
        covered = inside - overlap
        totals["shell"] += shell
        totals["covered"] += covered
        totals["overlap"] += overlap
        totals["outside"] += outside
        surfaces.append({"surface": surface.name, "reference": what, "plates": len(polys),
                         "shell_m2": shell * mm2, "covered": covered / shell if shell else None,
                         "overlap": overlap / shell if shell else None, "outside_m2": outside * mm2})
    shell = totals["shell"]
    return {"covered": totals["covered"] / shell if shell else None,
            "overlap": totals["overlap"] / shell if shell else None,
            "shell_m2": shell * mm2, "covered_m2": totals["covered"] * mm2, "overlap_m2": totals["overlap"] * mm2,
            "outside_m2": totals["outside"] * mm2,
            "method": "delivered plate boundaries mapped to the surface by closest points, areas on the surface "
                      f"({AREA_CELLS} x {AREA_CELLS} parameter cells: whole cells by 2 x 2 Gauss points, cut ones by the "
                      "midpoint rule); covered = plates "
                      "inside the reference less pairwise overlaps",
            "surfaces": surfaces}
