"""Fit-up of a strake or shell: do neighbouring plates share their edges, and is the shell
covered once?

Every plate is measured on what it delivers: its 3D shape (the trimmed strip, the strip
trimmed by its region, the flat plate on its fitted plane, the formed plate's hull patch) and
its developed outline, vertex for vertex (the OBJ's ``v`` and ``vt``). A plate's boundary is
cut into its four named edges (seam 1 and 2, the two butts or hull ends): on a strip trimmed
by butt planes a point belongs to a butt where it lies on that plane, on a region grid the
first and last rows are the seams and the end columns the butts.

Two plates share an edge where the plan says so: the same seam (equal girth curve on the same
surface) on opposite sides, or the same butt plane on opposite sides, and their edges overlap
along it. Where a face's trim ends the plates planned on it, the shell goes on across another
face: a plate cut at its trim (:mod:`.trimcut`) has a TRIM edge, the stretch of its cut outline
along the trim, and shares it with the plates of other surfaces whose edges run along it (found
by geometry, kind "trim"); plates of two faces that meet along the faces' own edges share
those (kind "face"). On each shared edge:

- the step: the distance of each plate's edge from the other's, both ways (IACS Rec. 47
  allows butt and seam misalignment of about 0.15 t, at most 3 mm);
- the developed length of the common part on each plate; flat and strip plates develop
  isometrically, so the two must agree (this is what makes them meet at erection); a formed
  plate's edge is measured against its 3D length as well (the strain forming puts in).

Edges are interpolated by cubic splines through their vertices (by chord length) and sampled
every SAMPLE_MM, so that a polyline's chords (a strip's are up to its chord tolerance off its
boundary curve) add nothing to the step.

Coverage (:mod:`.coverage`) is counted in each surface's parameters: every delivered plate's
boundary mapped to the surface by closest points is a polygon (shapely), its area taken on the
surface. A planned shell is measured against the whole surface inside its IGES trim, a
hand-laid strake against the union of its plates' planned regions.

A flat plate's 3D shape is its region projected on its least-squares plane (the plate as cut
is planar), not the hull points its OBJ carries; a strip trimmed by its region has its edges
where the region's boundary maps onto the strip by closest points, which need not lie in the
butt plane (a plane section of the two plates there can differ from the edges' distance).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

SAMPLE_MM = 20.0  # spacing of an edge's spline samples
STEP_SHARE_OF_T = 0.15  # IACS Rec. 47: butt / seam misalignment a <= 0.15 t ...
STEP_MAX_MM = 3.0  # ... and at most 3 mm
LENGTH_LIMIT_MM = 1.0  # flat/strip neighbours: developed lengths of a shared edge agree within
MIN_COMMON = 0.01  # a shared edge overlaps by at least this share of the shorter edge
APART = 10.0  # edges whose median distance exceeds this many fit tolerances are not one edge
# edges of two surfaces' plates run along each other within this many fit tolerances (median):
# DTMB 5415's transom stands 10-18 mm off its hull's aft end; an edge that only touches
# another at its end lies half its length away
ACROSS_NEAR = 5.0
ACROSS_SLOPE = 0.1  # ... and within this share of their common length (a butt rising from a trim line at its end is no pair)
ACROSS = ("trim", "face")  # the kinds of pairs found by geometry across two surfaces
NEAR_MM = 1000.0  # candidates whose edges' boxes stay farther apart are not measured (nor reported apart)
RULE = (f"misfit where the step between the two plates' 3D edges exceeds min({STEP_SHARE_OF_T:g} t, "
        f"{STEP_MAX_MM:g} mm) (t the thinner plate; IACS Rec. 47 butt/seam alignment), or where two flat or strip "
        f"plates (isometric developments) differ by more than {LENGTH_LIMIT_MM:g} mm in the developed length of "
        "their shared edge")
SIDES = ("seam0", "seam1", "butt0", "butt1")
TRIM = "trim"  # the side of a plate cut at its face's trim that runs along the trim line
TRIM_LABEL = "TRIM"
SPREAD_MIN = 64  # pairs not measured before that are worth the workers' round trip
SPREAD_BATCH = 32  # pairs a worker measures per task


@dataclass(frozen=True)
class Edge:
    """One named edge of a delivered plate: points3 (N, 3) on the delivered 3D plate and
    points2 (N, 2) their developed positions, in order along the edge (model units)."""

    side: str  # one of SIDES
    label: str  # the seam's or butt's name
    points3: np.ndarray
    points2: np.ndarray


@dataclass(frozen=True)
class PlateEdges:
    """A delivered plate's edges and boundary ring (N, 3) on the 3D plate (model units)."""

    name: str
    klass: str
    isometric: bool  # flat or devflat's strip: the development keeps every length
    edges: tuple
    ring3: np.ndarray

    def edge(self, side: str) -> Edge | None:
        return next((e for e in self.edges if e.side == side), None)


@dataclass(frozen=True)
class SharedEdge:
    """A shared edge's figures (mm): steps both ways and developed / 3D lengths of the common
    part on each plate."""

    a: str
    b: str
    kind: str  # "seam", "butt", "trim" (a plate cut at its face's trim and a plate of another face) or "face"
    label: str
    step_max: float
    step_median: float
    worst_point: tuple  # (x, y, z) model units, on plate a's or b's edge
    length3: tuple  # (a, b) 3D length of the common part
    length2: tuple  # (a, b) developed length of the common part
    isometric: bool  # both plates flat or strip
    limit: float  # the step limit min(0.15 t, 3 mm) of this pair
    side_a: str = ""  # which edge of plate a (one of SIDES) ...
    side_b: str = ""  # ... meets which of plate b

    @property
    def mismatch(self) -> float:
        return abs(self.length2[0] - self.length2[1])

    @property
    def misfit(self) -> bool:
        return self.step_max > self.limit or (self.isometric and self.mismatch > LENGTH_LIMIT_MM)

    def as_dict(self) -> dict:
        return {"plates": [self.a, self.b], "kind": self.kind, "edge": self.label,
                "step_max_mm": self.step_max, "step_median_mm": self.step_median,
                "worst_point": list(self.worst_point), "length_3d_mm": list(self.length3),
                "developed_length_mm": list(self.length2), "mismatch_mm": self.mismatch,
                "isometric": self.isometric, "step_limit_mm": self.limit, "misfit": self.misfit}


@dataclass(frozen=True)
class ShellFitup:
    """The run's fit-up: shared edges, formed plates' edge strains, coverage."""

    pairs: tuple  # SharedEdge
    edge_strains: tuple  # (plate, edge label, (developed - 3D) / 3D) of formed plates' edges
    coverage: dict | None
    thickness_mm: float
    unmeasured: tuple = field(default=())  # plates without delivered geometry
    # neighbours by the plan whose edges lie apart (median distance above APART fit
    # tolerances: a seam that leaves the surface at a centreline or stem): not in the steps
    apart: tuple = field(default=())

    def warnings(self) -> list[str]:
        out = [f"fit-up: {p.kind} {p.label} between {p.a} and {p.b}: "
               f"{'their faces run beside each other' if p.kind in ACROSS else 'the plan makes them neighbours'} "
               f"but their edges lie {p.step_median:.0f} mm apart (median) near {np.round(p.worst_point, 1).tolist()}"
               for p in self.apart]
        for p in self.pairs:
            if not p.misfit:
                continue
            why = []
            if p.step_max > p.limit:
                why.append(f"step {p.step_max:.2f} mm (limit {p.limit:.2f} mm)")
            if p.isometric and p.mismatch > LENGTH_LIMIT_MM:
                why.append(f"developed lengths {p.length2[0]:.1f} and {p.length2[1]:.1f} mm differ by "
                           f"{p.mismatch:.2f} mm (limit {LENGTH_LIMIT_MM:g} mm)")
            out.append(f"fit-up: {p.kind} {p.label} between {p.a} and {p.b}: {'; '.join(why)} near "
                       f"{np.round(p.worst_point, 1).tolist()}")
        return out

    def as_dict(self) -> dict:
        steps = np.array([p.step_max for p in self.pairs])
        iso = [p for p in self.pairs if p.isometric]
        mismatch = np.array([p.mismatch for p in iso])
        strains = np.array([abs(s) for _, _, s in self.edge_strains])
        worst_strain = self.edge_strains[int(np.argmax(strains))] if len(strains) else None
        return {
            "rule": RULE, "thickness_mm": self.thickness_mm,
            "scope": ("shared edges: the same seam (girth curve) or butt plane of one hull surface on both plates, "
                      "the plane where a plan cut two overlapping surfaces, the trim line where a plate cut at "
                      "its face's trim meets a plate of another surface (kind trim), or two faces' own edges "
                      "(kind face): plates of two surfaces whose edges run along each other, their median distance "
                      f"within {ACROSS_SLOPE:g} of their common length (over {ACROSS_NEAR:g} fit tolerances: apart; "
                      f"over {APART:g}, or a common part under {ACROSS_NEAR:g} tolerances: no pair). "
                      "Steps: distances between the two plates' 3D "
                      "edges both ways along their common part; lengths: of that common part, in 3D and developed"),
            "shared_edges": len(self.pairs), "seams": sum(p.kind == "seam" for p in self.pairs),
            "butts": sum(p.kind == "butt" for p in self.pairs), "trims": sum(p.kind == "trim" for p in self.pairs),
            "faces": sum(p.kind == "face" for p in self.pairs),
            "step_mm": _stats(steps, self.pairs),
            "steps_over_3mm": int((steps > STEP_MAX_MM).sum()),
            "steps_over_limit": int(sum(p.step_max > p.limit for p in self.pairs)),
            "length_mismatch_mm": dict(_stats(mismatch, iso), edges=len(iso)),
            "mismatch_over_1mm": int((mismatch > LENGTH_LIMIT_MM).sum()),
            "formed_edge_strain": {"edges": len(strains), "max_abs": float(strains.max()) if len(strains) else None,
                                   "worst": None if worst_strain is None else list(worst_strain[:2])},
            "misfits": sum(p.misfit for p in self.pairs),
            "apart": [p.as_dict() for p in self.apart],
            "coverage": self.coverage,
            "unmeasured_plates": list(self.unmeasured),
            "warnings": self.warnings(),
            "pairs": [p.as_dict() for p in self.pairs]}

    def one_line(self) -> str:
        d = self.as_dict()
        cov = self.coverage or {}
        covered = (f"shell covered {100 * cov['covered']:.2f} %, overlap {100 * cov['overlap']:.3f} %; "
                   if cov.get("covered") is not None else "")
        step, mis = d["step_mm"], d["length_mismatch_mm"]
        text = (f"fit-up: {covered}{d['shared_edges']} shared edges, step median {_mm(step['median'])} p95 "
                f"{_mm(step['p95'])} max {_mm(step['max'])}, {d['steps_over_3mm']} over 3 mm; flat/strip length "
                f"mismatch p95 {_mm(mis['p95'])} max {_mm(mis['max'])}; {d['misfits']} misfit(s)")
        return text


def _mm(value) -> str:
    return "-" if value is None else f"{value:.2f} mm"


def _stats(values: np.ndarray, pairs) -> dict:
    if not len(values):
        return {"median": None, "p95": None, "max": None, "worst_pair": None}
    worst = int(np.argmax(values))
    return {"median": float(np.median(values)), "p95": float(np.percentile(values, 95)),
            "max": float(values[worst]), "worst_pair": [pairs[worst].a, pairs[worst].b, pairs[worst].label]}


# ------------------------------------------------------------ a plate's delivered edges
def kept_edges(result) -> PlateEdges | None:
    """The plate's edges as its run kept them (``figures['fitup_edges']``: a worker that
    writes a plate's files drops its geometry), else read from its geometry now."""
    return result.figures.get("fitup_edges") or plate_edges(result)


def plate_edges(result) -> PlateEdges | None:
    """The delivered plate's named edges (None for a plate that delivered nothing or is no
    hull plate). Reads the strip (seam-to-seam strips trimmed by butt planes) or the region
    grid mesh (flat, formed, strips trimmed by the region) with the pattern's vertices."""
    from .plateshop import owes_development

    if owes_development(result):  # a formed plate's edges are its development's
        raise ValueError(f"plate {result.name}: its development is owed (pipeline.hull.plateshop.develop it first)")
    part = result.part
    hull = getattr(part, "hull", None)
    if hull is None or not result.ok or result.pattern is None:
        return None
    klass = (result.figures.get("plate_class") or {})
    name = klass.get("class", "failed")
    flat2 = np.asarray(result.pattern.vertices, dtype=np.float64)
    if result.strip is not None and result.strip.trim is not None:
        ring, labels = _strip_ring(result.strip, hull)
        v3 = result.strip.vertices
        # a corner lies on its butt plane: the butts hold their corners, the seams borrow
        # them (a neighbour on a plane, not a point of an end ruling short of it)
        borrow = {"seam0": (2, 3), "seam1": (2, 3)}
        shape = None  # a strip is not cut at a face's trim (its outline is the trimmed strip's)
    elif result.mesh is not None:
        shape = tuple((result.figures.get("region") or {}).get("grid") or ())
        v3 = np.asarray(result.mesh[0], dtype=np.float64)
        if len(shape) != 2 or shape[0] * shape[1] != len(v3):
            return None
        if name == "flat":  # the cut plate is planar: its 3D shape is the region on its plane
            v3 = _on_plane(v3, klass)
        ring, labels = _grid_ring(v3.reshape(*shape, 3), hull, hull.fit_tolerance)
        borrow = {"butt0": (0, 1), "butt1": (0, 1)}  # the grid's rows hold the corners, its end columns borrow them
    else:
        return None
    from .planner import is_strip

    isometric = name == "flat" or (name == "developable" and is_strip(klass))
    names = dict(zip(SIDES, tuple(hull.seam_names) + tuple(hull.butt_names)))
    edges = []
    size = float(np.ptp(v3[ring], axis=0).max())
    # a plate that reaches past its face's trim (``hull.trim``: set only then) is cut there;
    # an incomplete formed plate keeps no trim_cut figures but is cut all the same
    cut = _TrimCut(v3, flat2, shape, result.pattern.outline) if shape and getattr(hull, "trim", None) else None
    for code, side in enumerate(SIDES):
        run = _longest_run(labels, code, borrow.get(side, ()))
        if run is None:
            continue
        p3, p2 = v3[ring[run]], flat2[ring[run]]
        if cut is not None:  # the steel the shop cuts: inside the face's trim
            clipped = cut.clipped(p3, p2)
            if clipped is None:
                continue
            p3, p2 = clipped
        keep = np.r_[True, np.linalg.norm(np.diff(p3, axis=0), axis=1) > 1e-6 * size]  # a collapsed seam end: one point
        if keep.sum() >= 2:
            edges.append(Edge(side, names[side], p3[keep], p2[keep]))
    if cut is not None and cut.edge is not None:
        edges.append(cut.edge)
    return PlateEdges(result.name, name, bool(isometric), tuple(edges), v3[ring])


class _TrimCut:
    """A grid plate cut at its face's trim line (:mod:`.trimcut`): its region's edges clipped
    to the steel the shop cuts, and the part of its cut outline that runs along the trim,
    where the shell goes on across another face (its TRIM edge). ``v3`` (R C, 3) the plate's
    3D grid, ``placed`` (R C, 2) its development, ``shape`` (R, C), ``outline`` (N, 2) the cut
    outline developed; the outline's 3D points are interpolated over the grid's triangles in
    the development (exact on a flat plate, within the grid's second-order error elsewhere)."""

    def __init__(self, v3: np.ndarray, placed: np.ndarray, shape: tuple, outline: np.ndarray):
        import shapely

        from flatten.patch import grid_ring, grid_triangles

        self.v3, self.placed, self.triangles = v3, placed, grid_triangles(*shape)
        region = grid_ring(placed.reshape(*shape, 2))
        eps = 1e-6 * float(np.ptp(region, axis=0).max())
        outline = np.asarray(outline, dtype=np.float64)
        self.polygon = shapely.Polygon(outline).buffer(eps)
        # an outline segment runs along the trim where its midpoint lies off the region's
        # boundary (a trim cut straight across the region has no vertex of its own off it), and
        # a vertex is the trim's where a segment of the trim ends there (its corners included)
        midpoints = 0.5 * (outline + np.roll(outline, -1, axis=0))
        along = shapely.distance(shapely.LinearRing(region), shapely.points(midpoints)) > eps
        run = _longest_run(np.where(along | np.roll(along, 1), 5, 0), 5, ())
        self.edge = None
        if run is not None and len(run) >= 2:
            self.edge = Edge(TRIM, TRIM_LABEL, self.to_3d(outline[run]), outline[run])

    def to_3d(self, developed: np.ndarray) -> np.ndarray:
        """3D points (n, 3) of developed points (n, 2) of the plate."""
        from .trimcut import grid_map

        return grid_map(self.placed, self.triangles, self.v3, developed)

    def clipped(self, points3: np.ndarray, points2: np.ndarray) -> tuple | None:
        """An edge of the region (its 3D points (n, 3) and developed ones (n, 2)) clipped to
        the cut outline: the longest piece inside it, ending where it crosses the trim (3D by
        :meth:`to_3d`); the edge itself where it lies wholly inside; None where no piece is."""
        import shapely

        line = shapely.LineString(points2)
        if shapely.covers(self.polygon, line):
            return points3, points2
        piece = line.intersection(self.polygon)
        pieces = [g for g in getattr(piece, "geoms", [piece]) if g.geom_type == "LineString" and not g.is_empty]
        if not pieces:
            return None
        kept = np.asarray(max(pieces, key=lambda g: g.length).coords)
        return (self.to_3d(kept), kept) if len(kept) >= 2 else None


def _on_plane(v3: np.ndarray, klass: dict) -> np.ndarray:
    """A flat plate's region (N, 3) projected on the plane it was developed on (its normal and
    a point of it, as the plate's class records them; the least-squares plane for a plate
    that does not record its point)."""
    normal, point = klass.get("normal"), klass.get("plane_point")
    if normal is None or point is None:
        from flatten.patchflat import fit_plane

        fit = fit_plane(v3)
        return v3 - np.outer(fit.distances, fit.normal)
    normal = np.asarray(normal, dtype=np.float64)
    return v3 - np.outer((v3 - np.asarray(point, dtype=np.float64)) @ normal, normal)


def _butt_codes(points_by_end, hull) -> list[int]:
    """Side codes (2 or 3) of the plate's two ends (lists of points): the assignment to the
    butt planes with the smaller distances (a hull end, None, is infinitely far)."""
    planes = [j for j, plane in enumerate(hull.butts) if plane is not None]
    cost = np.array([[float(np.abs(hull.butts[j].signed(pts)).mean()) for j in planes] for pts in points_by_end])
    if len(planes) == 2:
        return [2, 3] if cost[0, 0] + cost[1, 1] <= cost[0, 1] + cost[1, 0] else [3, 2]
    if len(planes) == 1:  # an end plate: the end nearer the butt plane is that butt
        j = planes[0]
        near = int(np.argmin(cost[:, 0]))
        return [2 + j, 3 - j] if near == 0 else [3 - j, 2 + j]
    return [2, 3]


def _grid_ring(p: np.ndarray, hull, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Boundary ring (indices into the row-major grid (R, C, 3)) and side codes: row 0 seam
    0, last row seam 1, end columns the butts; an end column's points farther from its butt
    plane than the column's nearest point by more than ``tolerance`` (rows that end on the
    surface's own edge, a centreline or stem, before reaching the butt) are on no edge (4)."""
    r, c = p.shape[:2]
    idx = np.arange(r * c).reshape(r, c)
    first, last = _butt_codes((p[:, 0], p[:, -1]), hull)
    pieces = [(idx[0, :], 0), (idx[1:-1, -1], last), (idx[-1, ::-1], 1), (idx[-2:0:-1, 0], first)]
    ring = np.concatenate([i for i, _ in pieces])
    codes = np.concatenate([np.full(len(i), k) for i, k in pieces])
    pts = p.reshape(-1, 3)[ring]
    for j, plane in enumerate(hull.butts):
        mine = codes == 2 + j
        if plane is not None and mine.any():
            # measured from the column's nearest point: a plate moved as a whole keeps its butt
            d = np.abs(plane.signed(pts))
            codes = np.where(mine & (d > d[mine].min() + tolerance), 4, codes)
    return ring, codes


def _strip_ring(strip, hull) -> tuple[np.ndarray, np.ndarray]:
    """Boundary ring of a strip trimmed by butt planes (indices into its vertices) and side
    codes: a point on a butt plane (to round-off) is on that butt; otherwise the first sample
    of a ruling is on seam 0 (curve c), the last on seam 1, and the end rulings' samples off
    the planes (a corner ruling kept a hair inside the plane) are on no edge (code 4)."""
    m = len(strip.samples)
    k = strip.n_rulings
    idx = np.arange(k * m).reshape(k, m)
    v = strip.vertices
    pieces = [(idx[:, 0], 0), (idx[-1, 1:-1], 4), (idx[::-1, -1], 1), (idx[0, -2:0:-1], 4)]
    ring = np.concatenate([i for i, _ in pieces])
    codes = np.concatenate([np.full(len(i), c) for i, c in pieces])
    pts = v[ring]
    eps = 1e-9 * (1.0 + float(np.abs(pts).max()))
    for j, plane in enumerate(hull.butts):
        if plane is not None:
            codes = np.where(np.abs(plane.signed(pts)) <= eps, 2 + j, codes)
    return ring, codes


def _longest_run(codes: np.ndarray, code: int, borrow: tuple) -> np.ndarray | None:
    """Ring positions of the longest cyclic run of ``code``, and its neighbour either side
    where that neighbour's code is in ``borrow`` (the corners it shares with the adjacent
    edges, labelled theirs)."""
    n = len(codes)
    hit = codes == code
    if not hit.any():
        return None
    if hit.all():
        return np.arange(n)
    start = int(np.flatnonzero(~hit)[0])  # roll so that no run wraps around
    rolled = np.roll(hit, -start)
    best, begin = (0, 0), None
    for i, h in enumerate(np.r_[rolled, False]):
        if h and begin is None:
            begin = i
        elif not h and begin is not None:
            best = max(best, (i - begin, begin))
            begin = None
    length, first = best
    lo, hi = (first - 1 + start) % n, (first + length + start) % n
    run = (np.arange(first, first + length) + start) % n
    return np.r_[[lo] if codes[lo] in borrow else [], run, [hi] if codes[hi] in borrow else []].astype(int)


# ------------------------------------------------------------ measuring a shared edge
@dataclass(frozen=True)
class _Dense:
    t: np.ndarray  # (n,) spline parameter (3D chord length through the edge's vertices)
    p3: np.ndarray  # (n, 3)
    s3: np.ndarray  # (n,) cumulative 3D length
    s2: np.ndarray  # (n,) cumulative developed length
    spline: object  # the (t -> 3D + 2D) cubic spline, None for an edge of two or three points
    tree: object  # cKDTree of p3


def _dense(edge: Edge, spacing: float) -> _Dense:
    """The edge's cubic spline (by 3D chord length, through its 3D and developed points
    together) sampled about ``spacing`` apart."""
    from scipy.interpolate import make_interp_spline

    data = np.hstack([edge.points3, edge.points2])
    t = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(edge.points3, axis=0), axis=1))]
    n = int(np.clip(np.ceil(t[-1] / spacing) + 1, 16, 20000))
    s = np.linspace(0.0, t[-1], n)
    if len(t) >= 4:
        spline = make_interp_spline(t, data, k=3)
        dense, speed = spline(s), spline.derivative()(s)
        # lengths from the spline's speed (trapezoid): the samples' chords would be short
        # of the arc by (h kappa)^2 / 24 (2e-6 on a 3 m bilge radius at 20 mm)
        s3, s2 = (np.r_[0.0, np.cumsum(0.5 * np.diff(s) * (v[1:] + v[:-1]))]
                  for v in (np.linalg.norm(speed[:, :3], axis=1), np.linalg.norm(speed[:, 3:], axis=1)))
    else:
        spline = None
        dense = np.column_stack([np.interp(s, t, data[:, k]) for k in range(5)])
        s3, s2 = (np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(d, axis=0), axis=1))]
                  for d in (dense[:, :3], dense[:, 3:]))
    from scipy.spatial import cKDTree

    return _Dense(s, dense[:, :3], s3, s2, spline, cKDTree(dense[:, :3]))


def project(points: np.ndarray, edge: _Dense) -> tuple[np.ndarray, np.ndarray]:
    """Distance (N,) of points (N, 3) to the edge's curve and the arc length (N,) of their
    closest points on it (:func:`closest_on`)."""
    feet, s = closest_on(points, edge)
    return np.linalg.norm(feet - points, axis=1), s


def closest_on(points: np.ndarray, edge: _Dense) -> tuple[np.ndarray, np.ndarray]:
    """Closest points (N, 3) on the edge's curve of points (N, 3) and their arc lengths (N,)
    along it: the nearest sample by KD-tree, the closer of the two chords at it, then Newton
    on the spline (a chord alone would stand off the curve by its sagitta, 0.017 mm for 20
    mm on a 3 m radius)."""
    poly, t = edge.p3, edge.t
    _, i = edge.tree.query(points)
    best_d = np.full(len(points), np.inf)
    best_t = np.zeros(len(points))
    feet = np.zeros((len(points), 3))
    for j in (np.clip(i - 1, 0, len(poly) - 2), np.clip(i, 0, len(poly) - 2)):
        a, b = poly[j], poly[j + 1]
        ab = b - a
        f = np.clip(np.einsum("ij,ij->i", points - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
        foot = a + f[:, None] * ab
        d = np.linalg.norm(foot - points, axis=1)
        better = d < best_d
        best_d = np.where(better, d, best_d)
        best_t = np.where(better, t[j] + f * (t[j + 1] - t[j]), best_t)
        feet = np.where(better[:, None], foot, feet)
    if edge.spline is not None:
        d1, d2 = edge.spline.derivative(1), edge.spline.derivative(2)
        for _ in range(4):  # Newton on (S(t) - q) . S'(t) = 0, kept on the edge
            r = edge.spline(best_t)[:, :3] - points
            s1, s2 = d1(best_t)[:, :3], d2(best_t)[:, :3]
            g = np.einsum("ij,ij->i", r, s1)
            h = np.einsum("ij,ij->i", s1, s1) + np.einsum("ij,ij->i", r, s2)
            best_t = np.clip(best_t - g / np.where(h > 0, h, np.inf), t[0], t[-1])
        feet = edge.spline(best_t)[:, :3]
    return feet, np.interp(best_t, t, edge.s3)


def _common(a: _Dense, b: _Dense) -> tuple[float, float]:
    """Arc-length interval on a's edge that b's edge spans (b's ends projected onto a)."""
    _, s = project(b.p3[[0, -1]], a)
    return float(s.min()), float(s.max())


class EdgeMeasures:
    """Edges sampled and shared edges measured, kept across the measurements of one fit-up:
    a fit-up measures the whole shell again after each of its steps, which move a few of its
    hundreds of plates, so an edge whose points are unchanged is not sampled again and a pair
    of such edges not measured again. Keyed by the edges' points (a plate's record read again
    from its result hits too), the results are those of measuring afresh, bit for bit.
    ``spacing``: the samples' spacing (model units); ``workers``: worker processes that
    measure a batch of SPREAD_MIN pairs or more not measured before while they run (the
    first measurement of a shell: they wait for the fit-up; the edges they sample are not
    kept here), an object with ``running`` (bool) and ``map(func, items)`` (answers in the
    items' order; :class:`pipeline.hull.plan._Judge`), or None: all measured here."""

    def __init__(self, spacing: float, workers=None):
        self.spacing = float(spacing)
        self.workers = workers
        self._sampled: dict = {}  # edge key -> _Dense
        self._measured: dict = {}  # (edge key, edge key) -> _measure's tuple or None

    @staticmethod
    def _key(edge: Edge) -> tuple:
        """What an edge's measurements depend on (its 3D and developed points): edges of
        equal keys are measured alike."""
        return tuple(x for points in (edge.points3, edge.points2)
                     for x in (points.shape, points.dtype.str, points.tobytes()))

    def dense(self, edge: Edge) -> _Dense:
        """The edge sampled (:func:`_dense`)."""
        key = self._key(edge)
        if key not in self._sampled:
            self._sampled[key] = _dense(edge, self.spacing)
        return self._sampled[key]

    def measure_all(self, edge_pairs: list) -> list:
        """:func:`_measure` of each pair of edges (a, b) in ``edge_pairs``."""
        keys = [(self._key(a), self._key(b)) for a, b in edge_pairs]
        todo: dict = {}
        for key, pair in zip(keys, edge_pairs):
            if key not in self._measured:
                todo.setdefault(key, pair)
        if len(todo) >= SPREAD_MIN and self.workers is not None and self.workers.running:
            items = list(todo.items())
            batches = [items[k:k + SPREAD_BATCH] for k in range(0, len(items), SPREAD_BATCH)]
            answers = self.workers.map(_measured_batch, [(self.spacing, [pair for _, pair in batch])
                                                         for batch in batches])
            for batch, got in zip(batches, answers, strict=True):
                self._measured.update(zip((key for key, _ in batch), got, strict=True))
        else:
            for key, (a, b) in todo.items():
                self._measured[key] = _measure(self.dense(a), self.dense(b))
        return [self._measured[key] for key in keys]


def _measured_batch(task: tuple) -> list:
    """:func:`_measure` of each pair of edges in ``task`` (spacing, [(a, b), ...]), each edge
    sampled once (a worker's share of :meth:`EdgeMeasures.measure_all`)."""
    spacing, edge_pairs = task
    return EdgeMeasures(spacing).measure_all(edge_pairs)


def _measure(da: _Dense, db: _Dense) -> tuple | None:
    """(steps (N,), worst point (3,), 3D lengths (2,), developed lengths (2,)) of the common
    part of two sampled edges, model units; None when they do not overlap along their length."""
    lo_a, hi_a = _common(da, db)
    lo_b, hi_b = _common(db, da)
    shorter = min(da.s3[-1], db.s3[-1])
    if hi_a - lo_a <= MIN_COMMON * shorter or hi_b - lo_b <= MIN_COMMON * shorter:
        return None
    ina = (da.s3 >= lo_a) & (da.s3 <= hi_a)
    inb = (db.s3 >= lo_b) & (db.s3 <= hi_b)
    steps_a, _ = project(da.p3[ina], db)
    steps_b, _ = project(db.p3[inb], da)
    steps = np.r_[steps_a, steps_b]
    where = np.vstack([da.p3[ina], db.p3[inb]])[int(np.argmax(steps))].copy()  # not a view that keeps the stack
    length3 = (hi_a - lo_a, hi_b - lo_b)
    length2 = tuple(float(np.interp(hi, d.s3, d.s2) - np.interp(lo, d.s3, d.s2))
                    for d, lo, hi in ((da, lo_a, hi_a), (db, lo_b, hi_b)))
    return steps, where, length3, length2


# ------------------------------------------------------------ the run
def shell_fitup(results, config) -> ShellFitup | None:
    """The fit-up of every hull plate of a run (None when the run has no hull plate)."""
    hull_results = [r for r in results if getattr(r.part, "hull", None) is not None]
    if not hull_results:
        return None
    mm = config.mm_per_unit
    records, unmeasured = {}, []
    for r in hull_results:
        rec = kept_edges(r)
        if rec is None:
            unmeasured.append(r.name)
        else:
            records[r.name] = (rec, r.part)
    thickness = float(config.spec.steel.thickness)
    measures = EdgeMeasures(SAMPLE_MM / mm)  # a formed plate's strains read the edges its pairs sampled
    pairs, apart = shared_edges(records, mm, thickness, measures)
    strains = []
    for rec, _ in records.values():
        if rec.klass != "formed":
            continue
        for e in rec.edges:
            d = measures.dense(e)
            strains.append((rec.name, e.label, float((d.s2[-1] - d.s3[-1]) / d.s3[-1])))
    from .coverage import shell_coverage

    try:
        coverage = shell_coverage(records, [r.part for r in hull_results], config)
    except Exception as exc:  # noqa: BLE001 - the run's plates are written; the report says why it has no coverage
        coverage = {"error": f"{type(exc).__name__}: {exc}"}
    return ShellFitup(tuple(pairs), tuple(strains), coverage, thickness, tuple(unmeasured), tuple(apart))


def shared_edges(records: dict, mm: float, thickness: float,
                 measures: EdgeMeasures | None = None) -> tuple[list, list]:
    """(pairs, apart): every shared edge of the plates in ``records`` ({plate name:
    (PlateEdges, part)}) measured (:class:`SharedEdge`), and the neighbours by the plan whose
    edges lie apart. ``mm``: millimetres per model unit; ``thickness``: the run's plate
    thickness (mm), for plates that do not give their own; ``measures``: the edges measured
    before in this fit-up (:class:`EdgeMeasures`; None: all measured here)."""
    if measures is None:
        measures = EdgeMeasures(SAMPLE_MM / mm)
    if measures.spacing != SAMPLE_MM / mm:
        raise ValueError(f"shared_edges: measures sampled {measures.spacing} apart, "
                         f"not {SAMPLE_MM / mm} (SAMPLE_MM at {mm} mm per unit)")
    pairs, apart, candidates = [], [], []
    for (na, nb, side_a, side_b, kind) in _neighbours(records):
        ea, eb = records[na][0].edge(side_a), records[nb][0].edge(side_b)
        if ea is not None and eb is not None and _near(ea, eb, NEAR_MM / mm):
            candidates.append((na, nb, side_a, side_b, kind, ea, eb))
    measured = measures.measure_all([(ea, eb) for *_, ea, eb in candidates])
    for (na, nb, side_a, side_b, kind, ea, eb), got in zip(candidates, measured):
        if got is None:
            continue
        (ra, pa), (rb, pb) = records[na], records[nb]
        steps, where, l3, l2 = got
        t = min(_thickness(pa, thickness), _thickness(pb, thickness))
        tolerance = min(pa.hull.fit_tolerance, pb.hull.fit_tolerance)
        median = float(np.median(steps))
        far = median > APART * tolerance
        if kind in ACROSS:
            if far or median > ACROSS_SLOPE * min(l3) or min(l3) < ACROSS_NEAR * tolerance:
                # found by its box, not by the plan: an edge that only touches another (a butt
                # rising from the trim line at its end, at an angle), crosses it or shares a
                # stub of it (a 33 mm leftover's end) is no pair
                continue
            far = median > ACROSS_NEAR * tolerance  # two faces that run beside each other apart
        label = f"{ea.label} | {eb.label}" if kind == "face" else ea.label  # two faces' edges: both names
        (apart if far else pairs).append(SharedEdge(
            na, nb, kind, label, float(steps.max() * mm), median * mm,
            tuple(float(x) for x in where), (l3[0] * mm, l3[1] * mm), (l2[0] * mm, l2[1] * mm),
            ra.isometric and rb.isometric, min(STEP_SHARE_OF_T * t, STEP_MAX_MM), side_a, side_b))
    return _once_across(pairs, apart)


def _once_across(pairs: list, apart: list) -> tuple[list, list]:
    """(pairs, apart), two plates of two surfaces that meet along a trim counted there once:
    their TRIM edges against each other where both are cut, and no other edges of theirs
    beside it, paired or apart (a seam clipped where the trim reaches the face's own edge, or
    crossing the trim line, runs along the same stretch)."""
    both = {frozenset((p.a, p.b)) for p in pairs if p.kind == "trim" and p.side_a == TRIM == p.side_b}
    met = {frozenset((p.a, p.b)) for p in pairs if p.kind == "trim"}
    return ([p for p in pairs if p.kind not in ACROSS
             or (p.kind == "trim" and (frozenset((p.a, p.b)) not in both or p.side_a == TRIM == p.side_b))
             or (p.kind == "face" and frozenset((p.a, p.b)) not in met)],
            [p for p in apart if p.kind not in ACROSS or frozenset((p.a, p.b)) not in met])


def _near(a: Edge, b: Edge, margin: float) -> bool:
    """The edges' bounding boxes, grown by ``margin``, meet (plates that share a seam or butt
    plane but lie apart along it are not measured)."""
    lo_a, hi_a = a.points3.min(axis=0) - margin, a.points3.max(axis=0) + margin
    return bool(np.all(b.points3.max(axis=0) >= lo_a) and np.all(b.points3.min(axis=0) <= hi_a))


def _thickness(part, default: float) -> float:
    steel = getattr(part, "steel", None)
    return float(getattr(steel, "thickness", None) or default)


def _neighbours(records: dict) -> list[tuple]:
    """(plate a, plate b, a's side, b's side, kind) for every two plates the plan puts side
    by side: the same seam (equal girth curve, same surface) as a's seam 1 and b's seam 0,
    or the same butt plane as a's far butt and b's near butt (across two faces at the plane
    where a plan cut them)."""
    seam_hi, butt_hi = {}, {}
    for name, (_, part) in records.items():
        hull = part.hull
        if hull.girths is not None:
            seam_hi.setdefault((id(hull.surface), hull.girths[1]), []).append(name)
        if hull.butts[1] is not None:
            butt_hi.setdefault(_butt_key(hull, hull.butts[1]), []).append(name)
    out = []
    for name, (_, part) in records.items():
        hull = part.hull
        if hull.girths is not None:
            for other in seam_hi.get((id(hull.surface), hull.girths[0]), []):
                if other != name:
                    out.append((other, name, "seam1", "seam0", "seam"))
        if hull.butts[0] is not None:
            for other in butt_hi.get(_butt_key(hull, hull.butts[0]), []):
                if other != name:
                    out.append((other, name, "butt1", "butt0", "butt"))
    return out + _across_surfaces(records, {frozenset(pair[:2]) for pair in out})


def _across_surfaces(records: dict, planned: set) -> list[tuple]:
    """(plate a, plate b, a's side, b's side, kind) for every two edges of plates on different
    surfaces that the plan does not make neighbours (``planned``: frozensets of two plate
    names) whose boxes come within APART fit tolerances of each other: kind "trim" where one is
    a TRIM edge (a face's trim ends the plates planned on it and another face carries the
    shell on), "face" otherwise (two faces meeting along their own edges: DTMB 5415's transom
    and its hull's aft ends). Candidates only: the measurement keeps those that run along each
    other."""
    edges = [(name, e, id(part.hull.surface), part.hull.fit_tolerance)
             for name, (rec, part) in sorted(records.items()) for e in rec.edges]
    if len({surface for _, _, surface, _ in edges}) < 2:
        return []
    lo = np.array([e.points3.min(axis=0) for _, e, _, _ in edges])
    hi = np.array([e.points3.max(axis=0) for _, e, _, _ in edges])
    out = []
    for i, (name, edge, surface, tolerance) in enumerate(edges):
        margin = APART * tolerance  # further apart than ACROSS_NEAR: measured, and listed apart
        after = slice(i + 1, None)  # each two edges once
        near = np.all(lo[after] <= hi[i] + margin, axis=1) & np.all(hi[after] >= lo[i] - margin, axis=1)
        for k in np.flatnonzero(near) + i + 1:
            other, theirs, their_surface, _ = edges[k]
            if their_surface == surface or frozenset((name, other)) in planned:
                continue
            if theirs.side == TRIM and edge.side != TRIM:  # the TRIM edge first: it names the pair
                out.append((other, name, TRIM, edge.side, "trim"))
            else:
                out.append((name, other, edge.side, theirs.side, "trim" if edge.side == TRIM else "face"))
    return out


def _butt_key(hull, plane) -> tuple:
    """A butt plane on one surface; the plane where a plan cut two overlapping faces
    (HullPlate.x_limits) is one butt of both faces' plates, whatever their surface."""
    if plane.offset in tuple(getattr(hull, "x_limits", (None, None))):
        return ("cut", plane)
    return (id(hull.surface), plane)
