"""A shell of several faces in one expansion: girth continued from face to face, and faces
that do not overlap drawn in one band.

A yard's shell expansion counts girth along each frame from the keel over the whole shell,
whatever faces the model splits it into. A face's section that starts on its girth edge off
the centre plane (the side shell above a flat bottom, a face lofted from the flat's edge)
continues the girth of the face it starts on: the girth of the point on that face's section
at the same station nearest the start, plus the gap between them (model faces leave gaps:
KVLCC2's main hull and flat bottom part by up to 0.3 m at its loft's ends). A section
that starts on the centre plane, or on a stem or stern contour (girth counted along it),
counts from there as before. Faces placed so are drawn in one band unless their plates
overlap there, then in a band of their own, as are faces that continue no face and share
an x range with the band's (each counts from the keel there) and faces that stand across
the hull (a transom, whose sections x = const run across it anyhow).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

JOIN = 2e-3  # of the drawing's length: a section's start this near another face's section continues it
OVERLAP = 0.02  # of the smaller face's plate area: faces overlapping more are drawn in bands of their own
END_FACE = 0.7  # a face whose normals' x share (area-weighted |n_x|) is larger stands across the hull
# of the join: a start this near the other section's own start is where both begin, not a continuation
SAME_START = 0.01


def stands_across(grids: list[np.ndarray]) -> bool:
    """Whether a face whose plates' points are ``grids`` (R, C, 3) each faces along x (a
    transom, an end plate): its sections x = const run across it anyhow, so it is drawn in
    a band of its own and continues no face."""
    weighted, total = 0.0, 0.0
    for p in grids:
        n = np.cross(p[1:, 1:] - p[:-1, :-1], p[1:, :-1] - p[:-1, 1:])  # twice each cell's area along its normal
        area = np.linalg.norm(n, axis=-1)
        weighted += float(np.abs(n[..., 0]).sum())
        total += float(area.sum())
    return total > 0 and weighted / total > END_FACE



@dataclass(frozen=True)
class TrueShape:
    """A face that stands across the hull (a transom) drawn in its own plane, as a yard draws
    a transom in true shape: ``across`` (3,) the plane's direction nearest the hull's y (away
    from the centre plane), ``up`` (3,) the plane's direction normal to it, rising; drawn
    from x = ``start`` along the sheet's x by the distance across (toward ``sign`` x) and
    upward by the distance up from the face's lowest point. ``width`` and ``height``: its
    extent on the drawing (model units)."""

    centre: np.ndarray
    across: np.ndarray
    up: np.ndarray
    start: float
    sign: float
    low: tuple
    width: float
    height: float

    def __call__(self, points: np.ndarray, params=None) -> np.ndarray:
        d = np.asarray(points, dtype=float) - self.centre
        a, b = d @ self.across - self.low[0], d @ self.up - self.low[1]
        return np.column_stack([self.start + self.sign * a, b])


def true_shape(grids: list[np.ndarray], x_range: tuple) -> TrueShape:
    """The :class:`TrueShape` of a face whose plates' points are ``grids`` (R, C, 3) each:
    its plane the points' least-squares one; drawn from the face's end nearer that end of the
    drawing's ``x_range`` (x0, x1), inward (a transom at the stern from its own aft x forward)."""
    points = np.vstack([g.reshape(-1, 3) for g in grids])
    points = points[np.all(np.isfinite(points), axis=1)]
    centre = points.mean(axis=0)
    normal = np.linalg.svd(points - centre, full_matrices=False)[2][2]
    across = np.array([0.0, 1.0, 0.0]) - normal[1] * normal
    if np.linalg.norm(across) < 1e-9:  # a face square to y: across along z's normal component
        across = np.array([0.0, 0.0, 1.0]) - normal[2] * normal
    across /= np.linalg.norm(across)
    if np.mean(np.abs(points[:, 1])) > 0 and np.corrcoef(np.abs(points[:, 1]), (points - centre) @ across)[0, 1] < 0:
        across = -across  # away from the centre plane
    up = np.cross(normal, across)
    up = -up if up[2] < 0 else up
    a, b = (points - centre) @ across, (points - centre) @ up
    at_low = points[:, 0].mean() - x_range[0] <= x_range[1] - points[:, 0].mean()
    start = float(points[:, 0].min()) if at_low else float(points[:, 0].max())
    return TrueShape(centre, across, up, start, 1.0 if at_low else -1.0, (float(a.min()), float(b.min())),
                     float(np.ptp(a)), float(np.ptp(b)))

def nearest_on_section(points: np.ndarray, girth: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    """The girth of the point of a section's polyline ``points`` (n, 3) (girth (n,), NaN where
    the section has no point) nearest ``target`` (3,), and its distance (NaN, inf where the
    section has no segment)."""
    a, b = points[:-1], points[1:]
    ga, gb = girth[:-1], girth[1:]
    ok = np.isfinite(ga) & np.isfinite(gb)
    if not ok.any():
        return float("nan"), float("inf")
    a, b, ga, gb = a[ok], b[ok], ga[ok], gb[ok]
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    t = np.clip(np.einsum("ij,ij->i", target - a, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    dist = np.linalg.norm(a + t[:, None] * d - target, axis=1)
    i = int(np.argmin(dist))
    return float(ga[i] + t[i] * (gb[i] - ga[i])), float(dist[i])


def joined_offsets(tables: list, join: float, across: list) -> tuple[list, list, list, list]:
    """Each face's girth offset (K,) at its table's stations (model units, 0 where its
    sections count from the centre plane, a contour or, continuing no face, their own
    start), the faces each continues, the faces in an order where each comes after those
    it continues, and at each face's stations the face it continues there (K,), -1 where
    none.

    ``tables``: :class:`.expansion.Sections` of the faces; a section continues the face whose
    section at the same station (equal x) passes within ``join`` of its start, the nearest,
    not at that section's start (SAME_START ``join`` from it); a face that stands ``across`` the
    hull (:func:`stands_across`) continues none and none continues it."""
    count = len(tables)
    parent = [np.full(len(t.stations), -1) for t in tables]
    at_parent = [np.zeros(len(t.stations)) for t in tables]  # the parent's girth at the start, plus the gap
    parent_station = [np.zeros(len(t.stations), dtype=int) for t in tables]
    for f, table in enumerate(tables):
        best = np.full(len(table.stations), np.inf)
        start = table.points.shape[1] - 1 if table.from_high else 0
        for g, other in enumerate(tables):
            if g == f or across[f] or across[g]:
                continue
            _, i_f, i_g = np.intersect1d(table.stations, other.stations, return_indices=True)
            for k, kg in zip(i_f, i_g):
                if not table.joinable[k]:
                    continue
                girth, gap = nearest_on_section(other.points[kg], other.girth[kg], table.points[k, start])
                if gap <= join and gap < best[k] and girth > SAME_START * join:
                    best[k], parent[f][k], parent_station[f][k] = gap, g, kg
                    at_parent[f][k] = girth + gap
    order = _parents_first(parent, count)
    offsets = [np.zeros(len(t.stations)) for t in tables]
    for f in order:
        for k in np.flatnonzero(parent[f] >= 0):
            g = parent[f][k]
            offsets[f][k] = offsets[g][parent_station[f][k]] + at_parent[f][k]
    continues = [tuple(sorted({int(g) for g in parent[f] if g >= 0})) for f in range(count)]
    return offsets, continues, order, parent


def _parents_first(parent: list[np.ndarray], count: int) -> list[int]:
    """The faces in an order where every face comes after those it continues; a face in a
    cycle of faces continuing one another (none in a sound shell) drops its joins there."""
    needs = [{int(g) for g in p if g >= 0} for p in parent]
    order, placed = [], set()
    while len(order) < count:
        ready = [f for f in range(count) if f not in placed and needs[f] <= placed]
        if not ready:  # a cycle: the first face left counts its own girth
            f = min(set(range(count)) - placed)
            parent[f][:] = -1
            ready = [f]
        for f in ready:
            order.append(f)
            placed.add(f)
    return order


def face_region(rings: list[np.ndarray]):
    """The region a face's plate outlines (closed rings (N, 2)) cover together, a shapely
    geometry (an outline that crosses itself counts as make_valid reads it)."""
    from shapely import make_valid, union_all
    from shapely.geometry import Polygon

    return union_all([make_valid(Polygon(r)) for r in rings if len(r) >= 3])


def place_bands(mapped: list, continues: list, order: list, join: float, across: list) -> tuple[dict, list[bool]]:
    """The band of each face (``mapped``: its plates' (outline, seams, butts, trim lines))
    and whether it keeps its joins (``continues``, ``order``: :func:`joined_offsets`).

    Parents first, a face goes to the band of the first face it continues, else to the
    first band whose faces' x ranges it overlaps by ``join`` at most (two faces that count
    girth from the keel at one x would draw over each other), else to a new band; a face
    whose plates overlap those of its band by more than OVERLAP of the smaller area counts
    its own girth in a new band (its plates drawn so are not those the overlap was measured
    on). A face that stands ``across`` the hull gets a band of its own."""
    multi = len(mapped) > 1
    regions = [face_region([ring for ring, _, _, _ in face]) if multi else None for face in mapped]
    spans = [(min(ring[:, 0].min() for ring, _, _, _ in face), max(ring[:, 0].max() for ring, _, _, _ in face))
             for face in mapped]
    band_of, joined, members = {}, [True] * len(mapped), []

    def apart(f, g):
        return min(spans[f][1], spans[g][1]) - max(spans[f][0], spans[g][0]) <= join

    def overlaps(f, g):
        return regions[f].intersection(regions[g]).area > OVERLAP * min(regions[f].area, regions[g].area)

    for f in order:
        band = band_of.get(continues[f][0]) if continues[f] else None
        if band is not None and any(overlaps(f, g) for g in members[band]):
            joined[f], band = False, len(members)
        if band is None:
            band = len(members) if across[f] else next(
                (b for b in range(len(members)) if not any(across[g] or not apart(f, g) or overlaps(f, g)
                                                           for g in members[b])), len(members))
        if band == len(members):
            members.append([])
        members[band].append(f)
        band_of[f] = band
    return band_of, joined


def cut_at_trim(plate, hull, to_drawing):
    """(outline (N, 2), trim lines (M, 2) each) on the drawing of a plate's region (its
    :class:`.cost.PlateEdges`) inside its face's trim, as :func:`.trimcut.cut_at_trim` cuts
    it for the shop; None when the region lies inside the trim, or wholly outside it (a
    failed plate, drawn whole). ``to_drawing``: points (N, 3) with their parameters (N, 2)
    -> the drawing (N, 2)."""
    import shapely

    from .trimcut import region_in_trim

    region, kept = region_in_trim(hull.trim, plate.params)
    if kept.is_empty or kept.area >= region.area * (1.0 - 1e-9):
        return None
    if kept.geom_type != "Polygon":  # the trim leaves pieces: the plate is the largest (as the shop's cut)
        kept = max(getattr(kept, "geoms", [kept]), key=lambda g: g.area)
    uv = np.asarray(kept.exterior.coords)
    outline = to_drawing(hull.surface(uv[:, 0], uv[:, 1]), uv)
    # a segment of the cut outline off the region's boundary runs along the trim
    u0, v0, u1, v1 = region.bounds
    snap = 1e-7 * max(u1 - u0, v1 - v0)
    middle = 0.5 * (uv[:-1] + uv[1:])
    on_trim = shapely.distance(region.exterior, shapely.points(middle)) > snap
    edges = np.flatnonzero(np.diff(np.r_[0, on_trim.astype(int), 0]))
    pieces = [outline[a:b + 1] for a, b in zip(edges[::2], edges[1::2])]
    if len(pieces) > 1 and on_trim[0] and on_trim[-1]:  # a run through the ring's first point
        pieces = [np.vstack([pieces[-1], pieces[0][1:]])] + pieces[1:-1]
    return outline[:-1], tuple(pieces)


def clipped(lines: tuple, outline: np.ndarray) -> tuple:
    """The pieces (M, 2) of the polylines inside the closed outline (N, 2)."""
    from shapely import LineString, MultiLineString, Polygon, line_merge, make_valid

    area = make_valid(Polygon(outline))
    pieces = []
    for line in lines:
        inside = LineString(line).intersection(area)
        # a line along the outline comes back a segment at a time: joined again
        parts = [p for p in getattr(inside, "geoms", [inside]) if p.geom_type == "LineString" and not p.is_empty]
        merged = line_merge(MultiLineString(parts)) if parts else None
        pieces += [np.asarray(p.coords) for p in getattr(merged, "geoms", [merged]) if merged is not None]
    return tuple(pieces)


def open_below(region, stations: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """The girth (K,) left open below a face's section starts ``starts`` (K,) at x =
    ``stations`` (K,) down to the plates of the face it continues (``region``: their
    outlines' union, :func:`face_region`, in the same band), the white the drawing shows
    there (the start lies within the join of that face's untrimmed section: what is open is
    the part its trim cuts away); NaN where that face has no plate below the start."""
    from shapely.geometry import LineString

    out = np.full(len(stations), np.nan)
    lo, hi = region.bounds[1], region.bounds[3]
    for k, (x, start) in enumerate(zip(stations, starts)):
        if not np.isfinite(start):
            continue
        cut = region.intersection(LineString([(x, lo - 1.0), (x, hi + 1.0)]))
        pieces = [cut] if cut.geom_type == "LineString" else [g for g in getattr(cut, "geoms", []) if
                                                               g.geom_type == "LineString"]
        # each piece of the plates' cover along x: up to the start, or over it (a girth overlap)
        tops = [min(max(y for _, y in piece.coords), start) for piece in pieces if not piece.is_empty
                and min(y for _, y in piece.coords) <= start]
        if tops:
            out[k] = start - max(tops)
    return out


def gap_stretches(stations: np.ndarray, gaps: np.ndarray, least: float) -> list[tuple[float, float, float]]:
    """(x from, x to, largest gap) of each run of consecutive stations (K,) where ``gaps``
    (K,) is at least ``least`` (NaN: none there)."""
    wide = np.isfinite(gaps) & (np.nan_to_num(gaps, nan=0.0) >= least)
    out = []
    k = 0
    while k < len(wide):
        if not wide[k]:
            k += 1
            continue
        end = k
        while end + 1 < len(wide) and wide[end + 1]:
            end += 1
        out.append((float(stations[k]), float(stations[end]), float(np.max(gaps[k:end + 1]))))
        k = end + 1
    return out
