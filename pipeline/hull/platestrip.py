"""The strip of a hull plate in either family of rulings, trimmed by the plate's region.

Between its two seams a plate's strip has rulings running seam to seam (across the plate);
between its two butt sections (the hull's sections by the butt planes, a little wider than
the plate) its rulings run butt to butt (along the plate). Where the hull is a cylinder
whose generators run along the seams (the parallel midbody's bilge and side), the only
strip between the seams is the plane through them, a chord across the bilge, while the
strip between the butts is the hull itself: both families are tried and the one that fits
is delivered.

A strip between sections is trimmed by the seams, which are curves on the hull and not
rulings or planes: the plate's region (its boundary densely, its interior on the patch grid)
is mapped onto the strip by closest points and developed there (:mod:`flatten.trim`). The
same trim serves end plates, whose one edge is the hull's end.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flatten.closest import SurfaceDistance
from flatten.patch import PatchGrid, region_grid
from flatten.trim import EDGE_V, StripMap, ruling_intervals

from ..config import Part, RunConfig
from ..io.sources import SourceError, fit_points
from ..stages import PartResult, develop_part, stage_unroll

SEAM_TO_SEAM = "rulings seam to seam"
BUTT_TO_BUTT = "rulings butt to butt"
SECTION_ROWS = 81  # points of a butt section fitted by a cubic B-spline
SECTION_FIT = 1e-3  # the section fit's tolerance, a fraction of the plate's fit tolerance
EXTEND = 0.15  # the sections reach this fraction of the plate's width beyond each seam
BOUNDARY_MM = 25.0  # spacing of the region's boundary points mapped onto the strip
MAP_RULINGS = 801
PROBE = 400  # samples along the whole surface where a region's rows are searched
HOPELESS = 3.0  # tolerances: a strip missing its region by more is judged on a probe of it (not moved either)
PROBE_ROWS, PROBE_COLS = 5, 9  # the probe: this sub-grid of the region's grid, corners included


@dataclass
class Trim:
    """A strip trimmed by the plate's region (model units, development frame before placing).

    grid_3d (R*C, 3), grid_flat (R*C, 2): the patch grid's points mapped onto the strip and
    developed; outline_3d (N, 3) on the strip, outline_flat (N, 2), edges (N,) the edge name
    ('c', 'd' the seams, 'start', 'end' the first and second butt) of segment i -> i+1;
    rulings: (a2, b2, a3, b3) the strip's rulings cut to the region (developed and 3D ends);
    normals (K, 3) of those rulings, seen from the side the pattern is drawn from;
    located: (points, map, mapped) of the region's points mapped onto the strip when the whole
    region was (the best fit reads their gaps again: :func:`.bestfit.signed_gaps`)."""

    family: str
    ok: bool = False
    reason: str = ""
    deviation: float | None = None
    figures: dict = field(default_factory=dict)
    attempt: PartResult | None = None
    grid_3d: np.ndarray | None = None
    grid_flat: np.ndarray | None = None
    outline_3d: np.ndarray | None = None
    outline_flat: np.ndarray | None = None
    edges: tuple = ()
    rulings: tuple | None = None
    normals: np.ndarray | None = None
    outline_deviation: float = 0.0
    located: tuple | None = None


def _girth_domain(hull):
    return hull.surface.domain_v if hull.long_axis == 0 else hull.surface.domain_u


def _widened(hull, extend: float):
    """The seams moved apart by ``extend`` times the girth between them (within the surface)."""
    g0, g1 = hull.girths
    lo, hi = _girth_domain(hull)

    def g_lo(s):
        a, b = np.asarray(g0(s), float), np.asarray(g1(s), float)
        return np.clip(a - extend * (b - a), lo, hi)

    def g_hi(s):
        a, b = np.asarray(g0(s), float), np.asarray(g1(s), float)
        return np.clip(b + extend * (b - a), lo, hi)

    return g_lo, g_hi


def _planes(hull):
    return [None if p is None else p.as_tuple() for p in hull.butts]


def _butt_side(hull, points: np.ndarray) -> int:
    """0 when the points lie on the first butt (or the hull's end next to it), else 1."""
    first, second = hull.butts
    if first is not None and np.abs(first.signed(points)).max() <= 1e-6 * (1.0 + np.abs(points).max()):
        return 0
    if second is not None and np.abs(second.signed(points)).max() <= 1e-6 * (1.0 + np.abs(points).max()):
        return 1
    return 0 if second is not None else 1


def section_curves(part: Part, tolerance: float, extend: float = EXTEND, near: PatchGrid | None = None) -> tuple:
    """The hull's two end sections of the plate between its widened seams, as NURBS curves in
    the same girth direction: the surface's iso-curve where the section is one, else a cubic
    B-spline through SECTION_ROWS exact section points within ``tolerance``. Returns
    ((curve, curve), figures); raises SourceError when there is no usable section.

    ``near``: the plate's own grid, whose longitudinal extent (twice as long) is searched
    first for the sections, at the same sample spacing as the whole surface would be; then
    the sections are kept with it (every strip family and best fit asks for them)."""
    if near is None:
        return _section_curves(part, tolerance, extend, near)
    key = ("sections", part.name, tolerance, extend)
    if key not in near.derived:
        try:
            near.derived[key] = _section_curves(part, tolerance, extend, near)
        except SourceError as exc:
            near.derived[key] = exc
    found = near.derived[key]
    if isinstance(found, SourceError):
        raise SourceError(str(found))
    curves, figures = found
    return curves, [dict(f) for f in figures]


def _section_curves(part: Part, tolerance: float, extend: float, near: PatchGrid | None) -> tuple:
    hull = part.hull
    g_lo, g_hi = _widened(hull, extend)
    sections = _region_ends(hull, g_lo, g_hi, SECTION_ROWS, near)
    if sections is None:
        raise SourceError("the widened region misses the hull")
    axis = hull.long_axis
    s_dom = hull.surface.domain_u if axis == 0 else hull.surface.domain_v
    curves, figures = [], []
    for column in (0, -1):
        pts, params = sections.points[:, column], sections.params[:, column]
        s, g = params[:, axis], params[:, 1 - axis]
        length = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
        if length <= 1e-6 * float(np.ptp(sections.points.reshape(-1, 3), axis=0).max()):
            raise SourceError("a butt section collapses to a point")
        name = f"{part.name}.section{'12'[column]}"
        if np.ptp(s) <= 1e-12 * np.ptp(s_dom):  # the section is an iso-curve: exact
            iso = hull.surface.iso_u(s[0], name) if axis == 0 else hull.surface.iso_v(s[0], name)
            curve = iso.segment(float(g.min()), float(g.max()))
            if g[0] > g[-1]:
                curve = curve.reversed()
            how, error = "iso-curve of the surface (exact)", 0.0
        else:
            curve, report = fit_points(pts, tolerance, name)
            how, error = f"cubic B-spline through {len(pts)} exact section points", report.max_error
        curves.append(curve)
        figures.append({"method": how, "fit_error": error, "length": length})
    return tuple(curves), figures


def _region_ends(hull, g_lo, g_hi, rows: int, near: PatchGrid | None) -> PatchGrid | None:
    """:func:`flatten.patch.region_grid` of ``rows`` rows and their two ends, searched only
    around the plate's grid ``near`` (its longitudinal extent doubled) at the whole surface's
    sample spacing: the same ends (every row's ends bisected to round-off) from a tenth of
    the samples. The whole surface when ``near`` is None or a row misses that range or ends
    at its end or the hull's (not on a butt plane), so that the search may go on."""
    if near is not None:
        axis = hull.long_axis
        lo, hi = hull.surface.domain_u if axis == 0 else hull.surface.domain_v
        s = near.params[..., axis]
        s0, s1 = float(s.min()), float(s.max())
        a, b = max(lo, s0 - 0.5 * (s1 - s0)), min(hi, s1 + 0.5 * (s1 - s0))
        if b > a:
            probe = max(9, int(np.ceil((PROBE - 1) * (b - a) / (hi - lo))) + 1)
            grid = region_grid(hull.surface, axis, g_lo, g_hi, _planes(hull), rows, 2, probe=probe, s_range=(a, b),
                               spacing="length")
            if grid is not None and len(grid.rows) == rows and grid.ends.all():
                return grid
    return region_grid(hull.surface, hull.long_axis, g_lo, g_hi, _planes(hull), rows, 2, probe=PROBE, spacing="length")


def region_boundary(part: Part, grid: PatchGrid, spacing: float) -> tuple[np.ndarray, tuple]:
    """The region's boundary on the hull, closed, about ``spacing`` apart: seam c (first grid
    row), the butt at the row's far end, seam d backwards, the other butt backwards. Returns
    (points (N, 3), edge name of each segment i -> i+1); computed once per grid and spacing."""
    key = ("boundary", part.name, spacing)
    if key not in grid.derived:
        grid.derived[key] = _region_boundary(part, grid, spacing)
    points, edges = grid.derived[key]
    return points.copy(), edges


def _region_boundary(part: Part, grid: PatchGrid, spacing: float) -> tuple[np.ndarray, tuple]:
    hull = part.hull
    p = grid.points
    length = float(np.linalg.norm(np.diff(p, axis=1), axis=2).sum(axis=1).max())
    width = float(np.linalg.norm(np.diff(p, axis=0), axis=2).sum(axis=0).max())
    rows = int(np.clip(np.ceil(width / spacing) + 1, 5, 600))
    cols = int(np.clip(np.ceil(length / spacing) + 1, 9, 2000))
    g0, g1 = hull.girths
    dense = _region_ends(hull, g0, g1, rows, grid)
    if dense is None:
        raise SourceError("the region misses the hull")
    axis = hull.long_axis
    seam_rows = []
    for r in (0, -1):
        s = np.linspace(dense.params[r, 0, axis], dense.params[r, -1, axis], cols)
        a, b = np.asarray(g0(s), float), np.asarray(g1(s), float)
        g = a + dense.rows[r] * (b - a)
        u, v = (s, g) if axis == 0 else (g, s)
        seam_rows.append(hull.surface(u, v))
    near, far = dense.points[:, 0], dense.points[:, -1]
    near_name, far_name = ("start", "end") if _butt_side(hull, far) == 1 else ("end", "start")
    pieces = [(seam_rows[0][:-1], "c"), (far[:-1], far_name), (seam_rows[1][::-1][:-1], "d"),
              (near[::-1][:-1], near_name)]
    points = np.vstack([pts for pts, _ in pieces])
    edges = sum(((name,) * len(pts) for pts, name in pieces), ())
    step = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    keep = step > 1e-9 * max(length, width)
    return points[keep], tuple(e for e, k in zip(edges, keep) if k)


def _strip_normals(c, d, rulings: np.ndarray) -> np.ndarray:
    pc, dc = c.derivatives(rulings[:, 0], 1)
    n = np.cross(dc, d(rulings[:, 1]) - pc)
    return n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]


def trim_by_region(attempt: PartResult, part: Part, grid: PatchGrid, family: str, tolerance: float,
                   corner_tolerance: float, mm_per_unit: float, smap: StripMap | None = None) -> Trim:
    """Map the plate's region onto the attempt's solved strip and judge it: within
    ``tolerance`` of the hull everywhere, its four corners within ``corner_tolerance``.
    ``smap``: the strip's map when the caller has it (its probe, :func:`hopeless`)."""
    pair = attempt.part
    out = Trim(family, attempt=attempt)
    smap = smap or StripMap(attempt.solution, pair.c, pair.d, MAP_RULINGS)
    hull = part.hull
    distance = hull.distance or SurfaceDistance(hull.surface)
    boundary, edges = region_boundary(part, grid, BOUNDARY_MM / mm_per_unit)
    region = grid.points.reshape(-1, 3)
    points = np.vstack([region, boundary])
    mapped = smap.closest(points)
    out.located = (points, smap, mapped)
    n = len(region)
    on_hull = distance(mapped.on_strip)
    gap = mapped.distance
    deviation = float(max(gap.max(), on_hull.max()))
    rows, cols = grid.shape
    corner_index = np.array([0, cols - 1, rows * cols - 1, (rows - 1) * cols])
    corners = gap[corner_index]
    worst = int(np.argmax(gap))
    out.deviation = deviation
    out.figures = {
        "family": family,
        "hull_fit": {"max_distance": deviation, "region_to_strip_max": float(gap.max()),
                     "strip_to_hull_max": float(on_hull.max()),
                     "rms_distance": float(np.sqrt(np.mean(gap ** 2))), "tolerance": tolerance,
                     "worst_point": points[worst].tolist(),
                     "passed": bool(deviation <= tolerance),
                     "measured_on": f"{n} patch grid points and {len(boundary)} boundary points mapped onto the "
                                    "strip (closest points), and those strip points against the hull"},
        "completeness": {"corner_gaps": corners.tolist(), "corner_tolerance": corner_tolerance,
                         "max_region_gap": float(gap.max()), "worst_region_point": points[worst].tolist(),
                         "tolerance": tolerance,
                         "passed": bool(corners.max() <= corner_tolerance and gap.max() <= tolerance)},
    }
    if deviation > tolerance:
        out.reason = (f"plate deviates from the hull by {deviation:.4g} (tolerance {tolerance:g}) at "
                      f"{np.round(points[worst], 3).tolist()}")
        return out
    if corners.max() > corner_tolerance:
        out.reason = (f"strip incomplete: corner gaps {np.round(corners, 3).tolist()} (limit {corner_tolerance:g})")
        return out
    mapped, ac, ad = smap.developed(mapped)
    flat = mapped.flat
    rulings3 = (pair.c(smap.rulings[:, 0]), pair.d(smap.rulings[:, 1]))
    normals = _strip_normals(pair.c, pair.d, smap.rulings)
    # the pattern is drawn as the seam family draws it: seen from seam' x (across the girth)
    p = grid.points
    mid = cols // 2
    along, across = p[0, -1] - p[0, 0], p[-1, mid] - p[0, mid]
    reference = np.cross(along, across)
    fg = flat[:n].reshape(rows, cols, 2)
    fa, fx = fg[0, -1] - fg[0, 0], fg[-1, mid] - fg[0, mid]
    mirror = fa[0] * fx[1] - fa[1] * fx[0] < 0
    if mirror:
        flat = flat * np.array([-1.0, 1.0])
        ac, ad = ac * np.array([-1.0, 1.0]), ad * np.array([-1.0, 1.0])
    normals = normals * np.sign(normals @ reference)[:, None]
    lam_b, v_b = mapped.lam[n:], np.clip(mapped.v[n:], 0.0, 1.0)
    intervals = ruling_intervals(smap.lam, lam_b, v_b)
    keep = ~np.isnan(intervals[:, 0])
    lo, hi = intervals[keep, 0:1], intervals[keep, 1:2]
    a2 = ac[keep] + lo * (ad[keep] - ac[keep])
    b2 = ac[keep] + hi * (ad[keep] - ac[keep])
    a3 = rulings3[0][keep] + lo * (rulings3[1][keep] - rulings3[0][keep])
    b3 = rulings3[0][keep] + hi * (rulings3[1][keep] - rulings3[0][keep])
    # the plate's 3D shape is on the strip: a hull point a hair beyond a seam (the hull's seam line
    # against the curve fitted to it) is taken on the seam, not on its ruling's line beyond it
    out.grid_3d, out.grid_flat = mapped.nearest[:n], flat[:n]
    out.outline_3d, out.outline_flat, out.edges = mapped.nearest[n:], flat[n:], edges
    out.rulings, out.normals = (a2, b2, a3, b3), normals[keep]
    out.outline_deviation = _chord_deviation(flat[n:], edges)
    out.figures["trim"] = {"method": "the region's boundary and patch grid mapped onto the strip by closest points "
                                     "and developed there (exact development along each ruling)",
                           "boundary_points": len(boundary), "rulings_kept": int(keep.sum()),
                           "mirrored_to_seam_side": bool(mirror)}
    out.ok = True
    return out


def probe_index(shape: tuple) -> np.ndarray:
    """Flat indices into a (rows, cols) region grid of its probe: a PROBE_ROWS x PROBE_COLS
    sub-grid, first and last rows and columns (the corners) included."""
    rows, cols = shape
    r = np.unique(np.round(np.linspace(0, rows - 1, PROBE_ROWS)).astype(int))
    c = np.unique(np.round(np.linspace(0, cols - 1, PROBE_COLS)).astype(int))
    return (r[:, None] * cols + c[None, :]).ravel()


def hopeless(out: Trim, smap: StripMap, grid: PatchGrid, distance, tolerance: float) -> bool:
    """Judge a solved strip on the region's probe first: when it misses there by more than HOPELESS
    tolerances, the whole region (each point mapped on its own, so the probe's distances are
    among the region's) misses by at least as much, the strip is rejected and is not worth
    moving either (:mod:`.bestfit`); its figures say what was measured. Most strips of a
    curved hull's candidates end here, before the strip is developed and the region's
    boundary found and mapped. (After the strip's check: a strip that fails it has no
    deviation, which the best fit reads as nothing to move.)"""
    probe = grid.points.reshape(-1, 3)[probe_index(grid.shape)]
    _, v, _, on_strip = smap.locate(probe, edges=False)
    # points found near the strip's edges are judged by the whole map (only there does it
    # finish them on exact rulings): the rest have the whole map's distances, bit for bit
    inner = (v >= EDGE_V) & (v <= 1.0 - EDGE_V)
    if not inner.any():
        return False
    probe, on_strip = probe[inner], on_strip[inner]
    gap = np.linalg.norm(probe - on_strip, axis=1)
    on_hull = distance(on_strip)
    deviation = float(max(gap.max(), on_hull.max()))
    if deviation <= HOPELESS * tolerance:
        return False
    worst = int(np.argmax(np.maximum(gap, on_hull)))
    out.deviation = deviation
    out.figures = {"family": out.family, "hull_fit": {
        "max_distance": deviation, "region_to_strip_max": float(gap.max()), "strip_to_hull_max": float(on_hull.max()),
        "tolerance": tolerance, "worst_point": probe[worst].tolist(), "passed": False,
        "measured_on": f"{len(probe)} points of the patch grid (of a {PROBE_ROWS} x {PROBE_COLS} probe, those whose "
                       f"closest strip points lie inside its edges) mapped onto the strip: it misses there by more "
                       f"than {HOPELESS:g} tolerances, so the whole region by at least as much, and the rest was "
                       "not mapped"}}
    out.reason = (f"plate deviates from the hull by at least {deviation:.4g} (tolerance {tolerance:g}) at "
                  f"{np.round(probe[worst], 3).tolist()}")
    return True


def _chord_deviation(points: np.ndarray, edges: tuple) -> float:
    """Estimated largest distance between the developed boundary and its polyline: a quarter
    of each point's distance from the chord of its neighbours on the same edge (the sagitta
    of a segment is a quarter of that of two)."""
    prev, nxt = np.roll(points, 1, axis=0), np.roll(points, -1, axis=0)
    same = np.array(edges) == np.roll(np.array(edges), 1)
    seg = nxt - prev
    rel = points - prev
    length = np.maximum(np.linalg.norm(seg, axis=1), 1e-300)
    dist = np.abs(seg[:, 0] * rel[:, 1] - seg[:, 1] * rel[:, 0]) / length
    return float(0.25 * dist[same].max(initial=0.0))


def butt_family(part: Part, config: RunConfig, grid: PatchGrid, corner_tolerance: float,
                extend: float = EXTEND) -> Trim:
    """The strip between the plate's two butt sections (reaching ``extend`` times the girth
    beyond each seam), trimmed by its seams."""
    hull = part.hull
    out = Trim(BUTT_TO_BUTT)
    try:
        (c, d), sections = section_curves(part, SECTION_FIT * hull.fit_tolerance, extend, grid)
    except SourceError as exc:
        out.reason = f"no butt sections: {exc}"
        return out
    return _solved_and_trimmed(part, c, d, config, grid, BUTT_TO_BUTT, corner_tolerance, {"sections": sections})


def _solved_and_trimmed(part: Part, c, d, config: RunConfig, grid: PatchGrid, family: str,
                        corner_tolerance: float, figures: dict | None = None) -> Trim:
    """The strip between curves c and d solved, checked and (unless the region's probe finds
    it hopeless: :func:`hopeless`) trimmed by the plate's region, and developed when the trim
    fits (the trim develops the region on its own, from the strip's map; the whole strip's
    development gives the delivered plate's unroll figures); ``figures`` are added to the
    trim's once the strip is solved."""
    attempt = PartResult(part.name, Part(part.name, c, d, part.steel))
    hull, probed = part.hull, Trim(family, attempt=attempt)
    smap = None

    def screen(solved: PartResult) -> bool:
        nonlocal smap
        smap = StripMap(solved.solution, c, d, MAP_RULINGS)
        if hopeless(probed, smap, grid, hull.distance or SurfaceDistance(hull.surface), hull.fit_tolerance):
            solved.reason = probed.reason
            return False
        return True

    if not develop_part(attempt, config, None, 0.0, screen, naive=False, unroll=False):
        if probed.reason:
            probed.figures.update(figures or {})
            return probed
        return Trim(family, reason=attempt.reason, attempt=attempt)
    trim = trim_by_region(attempt, part, grid, family, hull.fit_tolerance, corner_tolerance, config.mm_per_unit, smap)
    if trim.ok:
        stage_unroll(attempt)
    trim.figures.update(figures or {})
    return trim


def end_plate_seams(part: Part, margin: float) -> tuple:
    """The seams of an end plate (one butt is the hull's end) as the curve pair of its strip:
    from the hull's end (a little short of a seam end that stands still) to past the butt
    plane by ``margin`` times the plate's length along the seam."""
    from flatten.plane import plane_crossings

    from .region import usable_end

    hull = part.hull
    index = 0 if hull.butts[0] is not None else 1
    plane = hull.butts[index]
    out = []
    for curve in (part.c, part.d):
        lo, hi = curve.domain
        cross = plane_crossings(curve, plane)
        if len(cross) != 1:
            raise SourceError(f"seam {curve.name} crosses the butt plane {plane.describe()} {len(cross)} times")
        t = float(cross[0])
        # the region lies on the plane's positive side for a first butt, negative for a second
        sign = 1.0 if index == 0 else -1.0
        ends = np.array([lo, hi])
        inside = sign * plane.signed(curve(ends)) > 0
        if inside.all() or not inside.any():
            raise SourceError(f"seam {curve.name} does not end on the plate's side of {plane.describe()}")
        end = float(ends[inside][0])
        length = float(curve.arc_length_at(np.array([min(t, end), max(t, end)])) @ np.array([-1.0, 1.0]))
        past = plane_crossings(curve, plane.shifted(-sign * margin * length))
        beyond = float(past[0]) if len(past) == 1 else float(ends[~inside][0])
        a, b = sorted((usable_end(curve, end, t), beyond))
        out.append(curve.segment(a, b))
    return tuple(out)


def seam_family_trimmed(part: Part, config: RunConfig, grid: PatchGrid, corner_tolerance: float) -> Trim:
    """The strip between an end plate's seams, trimmed by its region (its butt plane and the
    hull's end alike)."""
    out = Trim(SEAM_TO_SEAM)
    margin = float(getattr(config.spec.strake, "margin", 0.1) or 0.1)
    try:
        c, d = end_plate_seams(part, margin)
    except SourceError as exc:
        out.reason = f"end plate: {exc}"
        return out
    return _solved_and_trimmed(part, c, d, config, grid, SEAM_TO_SEAM, corner_tolerance)
