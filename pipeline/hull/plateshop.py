"""A hull plate's shop data from its developed geometry: roll and bending lines, frame lines,
edge names, heating lines, templates and pin jig, and a strip plate's exact outline.

An adaptive plan judges many candidate plates and keeps a few; its judgement reads each
candidate's class, hull fit and area (``planner.honest_class``, ``hullplots.shell_area``),
none of its shop data, which cost about a third of a candidate's CPU on the 160 m hull
(templates and pin jig above all). So a candidate is evaluated *lean*
(:func:`pipeline.hull.plates.evaluate_plate` runs the plate with a :class:`LeanRun`): the
plate run stops where its shop data begin and leaves what they need on the result as a
:class:`ShopWork`; the plates the plan keeps get them from that same geometry, never
computed again, in the worker that writes their files (:func:`complete`, called by
``plates.run_part``). A plate run in full (a uniform plan, a hand-laid strake) calls the
same functions at once, so that the files are the same either way.
"""

from __future__ import annotations

import dataclasses
import traceback

import numpy as np

from flatten.patch import principal_curvatures
from flatten.patchflat import streamlines, triangle_maps
from flatten.trim import barycentric

from ..config import RunConfig
from ..shop.outline import Outline
from ..shop.plate import bend_text

ROLL_SPACING_MM = 500.0  # roll lines of a patch-developed plate about half a metre apart


class LeanRun(RunConfig):
    """The run's configuration for a candidate plate of an adaptive plan: the same settings
    and parts; the plate run leaves its shop data owed (:class:`ShopWork`)."""

    lean = True

    def __init__(self, config: RunConfig):
        super().__init__(config.spec, config.parts, config.source, config.lines)
        self.plan_record = config.plan_record


def is_lean(config) -> bool:
    return bool(getattr(config, "lean", False))


@dataclasses.dataclass(frozen=True)
class ShopWork:
    """The shop data a lean-evaluated plate still owes: ``fn(result, config, *args)``, with
    ``args`` the geometry its evaluation computed (read, never changed: a cached result
    shares them with the copies a plan hands out) and ``part`` the part it was evaluated as.

    The evaluation's own part, not the plan's copy of it: its seam curves carry what the
    evaluation cached on them (power-basis coefficients, arc-length tables), which the
    strip's development also refers to; the plan's copy, never evaluated, would compute
    the shop data from cold curves and move their last digits."""

    fn: object
    args: tuple = ()
    part: object = None
    develops: bool = False  # fn develops the plate first (:func:`owe_development`)


def owe(result, config, fn, *args) -> None:
    """``fn(result, config, *args)`` now, or, in a lean run, left on the result."""
    if is_lean(config):
        result.shop_work = ShopWork(fn, args, result.part)
    else:
        fn(result, config, *args)


def owe_development(result, fn, owed: OwedPatch) -> None:
    """Leave a lean-evaluated plate's development itself owed: ``fn(result, config, owed)``
    develops it and then owes (or, run in full, computes) its shop data. For a formed plate,
    whose class and wholeness the plan reads and whose development it never does: of the 160 m
    hull's 556 candidates the plan splits 224, all formed, whose patch developments took 8 %
    of its evaluation CPU. :func:`complete` does it with the shop data; :func:`develop` alone,
    for what reads a kept plate's development before its shop data (the fit-up modes). The
    figures are the same as had it been developed at once; a development that raises fails
    the plate then, not during the plan (which judged it formed, and splits formed and failed
    plates alike)."""
    result.shop_work = ShopWork(fn, (owed,), result.part, develops=True)


def owes_development(result) -> bool:
    work = getattr(result, "shop_work", None)
    return work is not None and work.develops


def develop(result, config: RunConfig):
    """The result with its owed development done (:func:`owe_development`) and its shop data
    still owed, as a lean evaluation leaves any other plate; on the part it was evaluated as,
    an exception failing the plate (as :func:`complete`). Any other result as it is."""
    if not owes_development(result):
        return result
    return _done(result, config if is_lean(config) else LeanRun(config))


def complete(result, config: RunConfig):
    """The result with its owed shop data computed (as the full plate run computes them, on
    the part it was evaluated as); an exception fails the plate with the reason, as one
    inside the plate run does."""
    if result.shop_work is None:
        return result
    return _done(result, config)


def _done(result, config):
    """The result's owed work done under ``config``, on the part it was evaluated as."""
    work = result.shop_work
    result.shop_work = None
    plan_part = result.part
    result.part = plan_part if work.part is None else work.part
    try:
        work.fn(result, config, *work.args)
    except Exception as exc:  # one plate never stops the run: report it with the evidence
        result.status = "failed"
        result.reason = f"internal error in plate {result.name}: {type(exc).__name__}: {exc}"
        result.figures["traceback"] = traceback.format_exc(limit=6)
    finally:
        result.part = plan_part
    return result


# ----------------------------------------------------------------- plates trimmed from a strip
def trimmed_shop(result, config, grid, trim) -> None:
    """Bending lines (the strip's own rulings, those the plate is rolled at), frame lines and
    edge names of a plate delivered as a strip trimmed by its region; for steel its cut
    outline (mm), the report's ``bending`` and ``outline`` and its templates. The pattern's
    placement and outline are the lean run's (``result.pattern``)."""
    from ..shop.bending import lines_on_rulings
    from ..shop.plate import ShopPlate, _scaled, roll_setup

    part, hull = result.part, result.part.hull
    mm = config.mm_per_unit
    rows, cols = grid.shape
    uv_grid = trim.grid_flat.reshape(rows, cols, 2)
    rot, shift = result.pattern.placement
    placed = result.pattern.vertices
    pg = placed.reshape(rows, cols, 2)
    sides = (pg[0], pg[-1], pg[:, 0], pg[:, -1])
    outline = result.pattern.outline
    a2, b2, a3, b3 = trim.rulings
    a2, b2 = a2 @ rot.T + shift, b2 @ rot.T + shift
    spacing = config.spec.shop.bend_spacing / mm
    lines, across = lines_on_rulings(a2, b2, a3, b3, trim.normals, spacing)
    rolling = None
    if lines and config.spec.profile == "steel":  # only the lines the plate is rolled at (shop.rolling)
        kept, rolling = roll_setup([dataclasses.replace(b, radius=b.radius * mm) for b in lines], part.steel,
                                   config.spec.shop)
        lines = [dataclasses.replace(b, radius=b.radius / mm) for b in kept]
    frames = [(x, pts @ rot.T + shift) for x, pts in frame_lines(grid.points, uv_grid, hull.frames)]
    bends = np.array([[b.a, b.b] for b in lines]).reshape(-1, 2, 2)
    result.pattern = dataclasses.replace(result.pattern, bend_lines=bends, frame_lines=tuple(frames),
                                         labels=edge_labels(sides, hull, grid.points))
    if config.spec.profile != "steel":
        return
    edges = trim.edges
    n = len(outline)
    tolerance = config.spec.shop.outline_tolerance / mm
    net = Outline(outline, tuple(edges), trim.outline_deviation, tolerance, 0.0)
    outline_mm = _scaled(net, mm)
    lines_mm = [dataclasses.replace(b, a=b.a * mm, b=b.b * mm, station=b.station * mm, radius=b.radius * mm)
                for b in lines]
    result.shop = ShopPlate(outline_mm, tuple(lines_mm), config.spec.shop.bend_spacing, across * mm, rolling)
    result.figures["bending"] = {
        "units": "mm", "count": len(lines_mm), "spacing": config.spec.shop.bend_spacing,
        "length_across_rulings": across * mm, "family": trim.family,
        **({"rolling": rolling.figures()} if rolling is not None else {}),
        "drawn_side": "seen from the side the seam family draws: seam direction x across the girth",
        "lines": [{"number": b.number, "station": b.station, "start": b.a.tolist(), "end": b.b.tolist(),
                   "length": float(np.linalg.norm(b.b - b.a)), "radius": b.radius if np.isfinite(b.radius) else None,
                   "convex_on_drawn_side": b.convex_on_drawn_side, "mark": bend_text(b)} for b in lines_mm]}
    result.figures["outline"] = {
        "units": "mm", "vertices": n, "tolerance": outline_mm.tolerance, "max_deviation": outline_mm.max_deviation,
        "deviation_measured_at": "estimated from the boundary points' distance to their neighbours' chords",
        "alignment_error": 0.0, "area_m2": outline_mm.area() / 1e6,
        "edges": {name: int(edges.count(name)) for name in sorted(set(edges))}}
    if outline_mm.max_deviation > outline_mm.tolerance:
        result.warnings.append(f"cut outline deviates about {outline_mm.max_deviation:.3g} mm from the exact "
                               f"development (tolerance {outline_mm.tolerance:g} mm)")
    from ..shop.plate import hull_templates  # the hull's own sections check the rolled plate

    hull_templates(result, config, grid.params, pg, outline,
                   "none" if rolling is None or not rolling.needs_rolling else "single")
    if lines_mm:
        from ..shop.templates import checked_by

        checked_by(result.figures["bending"]["lines"], result.templates)


# ------------------------------------------------------------- plates developed from their patch
@dataclasses.dataclass(frozen=True)
class PatchGeometry:
    """What a patch-developed plate's shop data need beyond its result (model units).

    kind        "flat" or "formed"
    strip       devflat's strip between the same seams (roll lines follow its rulings) or None
    v3, f3      (V, 3), (F, 3) the welded region mesh; ``index`` (R*C,) grid point -> welded vertex
    uv          (R*C, 2) the development, sized by the workshop method, not yet placed
    faces       (F', 3) grid faces of the whole region; ``outline`` (N, 2) its placed ring
    cut         the cut at the face's trim (:func:`pipeline.hull.trimcut.cut_at_trim`) or None
    info        the class record's method figures (``rolling_only`` for heating)
    scale       the workshop method's scale of the development
    complete    the delivered plate holds its region (else only its marks are drawn)
    verdict     a formed plate's strips' verdict (strip_not_delivered_because, families,
                strip_max_deviation) when they were tried, else None (:func:`formed_verdict`)
    """

    kind: str
    strip: object
    v3: np.ndarray
    f3: np.ndarray
    index: np.ndarray
    uv: np.ndarray
    faces: np.ndarray
    outline: np.ndarray
    cut: object
    info: dict
    scale: float
    complete: bool
    verdict: dict | None = None


@dataclasses.dataclass(frozen=True)
class OwedPatch:
    """What a lean-evaluated formed plate's owed development needs
    (:func:`pipeline.hull.plates._owed_patch`): its region ``grid`` and welded mesh ``v3``,
    ``f3``, ``index`` (moved as ``hull.follow`` said), ``size`` (length, width), its strips'
    ``verdict`` and the ``strip`` its roll lines follow, whether the strips were tried, and the
    region's ``check`` (:func:`pipeline.hull.plates.completeness`) the plan read (None for a
    plate developed at once: its delivery makes it)."""

    grid: object
    v3: np.ndarray
    f3: np.ndarray
    index: np.ndarray
    size: tuple
    verdict: dict
    strip: object
    strips_tried: bool
    check: dict | None = None


def formed_verdict(result) -> dict | None:
    """What a lean-evaluated formed plate's strip attempts found: its class record's reasons
    and deviations (``info``) and the strip its roll lines follow (``roll_strip``), from its
    owed shop data; None for any other result (flat, a strip, a patch whose strips were not
    tried, a plate run in full). The strips are judged on the region as it lies on the hull:
    a formed plate moved to meet its neighbours (``hull.follow``, :mod:`.follow`) would solve
    and fail them again alike, so with its verdict only its moved patch is developed
    (:func:`pipeline.hull.plates._run_plate`)."""
    work = getattr(result, "shop_work", None)
    if work is not None and work.develops:
        owed = work.args[-1]
        return {"info": owed.verdict, "roll_strip": owed.strip} if owed.strips_tried else None
    if work is None or work.fn is not patch_shop:
        return None
    geometry = work.args[-1]  # patch_shop(result, config, grid, geometry)
    if geometry.kind != "formed" or geometry.verdict is None:
        return None
    return {"info": geometry.verdict, "roll_strip": geometry.strip}


def patch_shop(result, config, grid, geo: PatchGeometry) -> None:
    """Roll lines (devflat's strip rulings, else the hull's least-curvature lines; for steel
    those it is rolled at), frame lines and edge names (inside the cut outline of a plate cut
    at its trim), the report's ``forming``; for a complete formed steel plate its heating
    lines and templates."""
    part, hull = result.part, result.part.hull
    mm = config.mm_per_unit
    shape = grid.shape
    rot, shift = result.pattern.placement
    placed = result.pattern.vertices
    uv_grid = geo.uv.reshape(shape[0], shape[1], 2)
    pg = placed.reshape(shape[0], shape[1], 2)
    sides = (pg[0], pg[-1], pg[:, 0], pg[:, -1])
    outline = geo.outline
    spacing = ROLL_SPACING_MM / mm
    if geo.kind == "flat":
        rolls, roll_method = np.zeros((0, 2, 2)), "none (flat plate)"
    elif geo.strip is not None:
        on_welded = np.zeros((len(geo.v3), 2))
        on_welded[geo.index] = geo.uv
        rolls, roll_method = roll_lines(geo.strip, geo.v3, on_welded, geo.f3,
                                        shape, grid.points, uv_grid, spacing)
        rolls = rolls @ rot.T + shift if len(rolls) else rolls
    else:
        rolls, roll_method = np.zeros((0, 2, 2)), ""
    if not len(rolls) and geo.kind != "flat":
        rolls, roll_method = least_bending_lines(hull.surface, grid, placed, geo.faces, outline, spacing)
    rolling = None
    if geo.kind != "flat" and len(rolls) and config.spec.profile == "steel":
        rolls, rolling = rolled(rolls, hull.surface, grid, placed, geo.faces, outline, part.steel, config)
    frames = [(x, pts @ rot.T + shift) for x, pts in frame_lines(grid.points, uv_grid, hull.frames)]
    labels = edge_labels(sides, hull, grid.points)
    if geo.cut is not None:  # the shop cuts the part inside the face's trim: its marks too
        rolls, frames, labels = clipped(rolls, frames, labels, result.pattern.outline)
    result.pattern = dataclasses.replace(result.pattern, bend_lines=rolls, frame_lines=tuple(frames), labels=labels)
    strains = result.figures["strain"]
    result.figures["forming"] = {"roll_lines": len(rolls), "roll_line_method": roll_method,
                                 "shrink_area_m2": strains["shrink_area_m2"],
                                 "stretch_area_m2": strains["stretch_area_m2"],
                                 **(rolling or {})} if geo.kind != "flat" else None
    if not geo.complete or geo.kind != "formed" or config.spec.profile != "steel":
        return
    v_grid, faces, cut_outline = grid.points.reshape(-1, 3), result.mesh[1], result.pattern.outline
    result.figures["heating"] = heating(v_grid, placed, faces, cut_outline, part.steel, config, geo.info, geo.scale)
    from ..shop.plate import hull_templates  # double curvature: templates at every frame

    hull_templates(result, config, grid.params, pg, cut_outline, "double")


def heating(v_grid, placed, faces, outline, steel, config, info, scale) -> dict:
    """The report's ``heating`` section of a formed plate (mm), its lines (placed flat plate,
    mm) under ``polylines``: none when the plate rolls without heating (``rolling_only``)."""
    from ..shop.heating import LineModel, heating_lines

    shop, mm = config.spec.shop, config.mm_per_unit
    model = LineModel(steel.thickness, shop.heat_input, shop.heat_shrinkage)
    return heating_lines(v_grid * mm, placed * mm, faces, outline * mm, model, shop.workshop_method,
                         shop.heat_strain, shop.heat_spacing, shop.heat_margin, scale,
                         bool(info.get("rolling_only"))).figures


# ---------------------------------------------------------------------------- the marks
def frame_lines(points, uv_grid, frames):
    """Frame planes x = X across the patch: per grid row the crossing between columns,
    interpolated linearly in the grid (2D image of the exact-on-hull grid)."""
    lines = []
    for x in frames:
        pts = []
        for row3, row2 in zip(points, uv_grid):
            xs = row3[:, 0] - x
            idx = np.flatnonzero(np.sign(xs[:-1]) * np.sign(xs[1:]) <= 0)
            if len(idx):
                i = idx[0]
                f = xs[i] / (xs[i] - xs[i + 1]) if xs[i] != xs[i + 1] else 0.0
                pts.append(row2[i] + f * (row2[i + 1] - row2[i]))
        if len(pts) >= 2:
            lines.append((float(x), np.array(pts)))
    return lines


def roll_lines(strip, v3, uv, faces, grid_shape, points, uv_grid, spacing: float):
    """Roll lines: rulings of devflat's strip between the same seams (the best-fit
    developable the solver found), projected onto the patch and mapped into the flat
    plate (unplaced); none when there is no usable strip."""
    import igl

    lines = []
    if strip is not None and strip.n_rulings >= 2:
        m = len(strip.samples)
        k = np.arange(strip.n_rulings) * m
        a3, b3 = strip.vertices[k], strip.vertices[k + m - 1]
        mid = 0.5 * (a3 + b3)
        d2, _, _ = igl.point_mesh_squared_distance(mid, v3, faces)
        inside = np.sqrt(d2) <= 0.05 * float(np.linalg.norm(b3 - a3, axis=1).mean())
        order = np.flatnonzero(inside)
        if len(order) >= 2:
            along = np.cumsum(np.r_[0.0, np.linalg.norm(np.diff(mid[order], axis=0), axis=1)])
            picks = order[np.unique(np.searchsorted(along, np.arange(0.0, along[-1] + 1e-9, spacing)))
                          .clip(0, len(order) - 1)]
            s = np.linspace(0.0, 1.0, 21)
            for i in picks:
                seg = a3[i] + s[:, None] * (b3[i] - a3[i])
                d2, fi, closest = igl.point_mesh_squared_distance(seg, v3, faces)
                tri = v3[faces[fi]]
                bary = barycentric(closest, tri)
                flat = np.einsum("nk,nkd->nd", bary, uv[faces[fi]])
                keep = np.sqrt(d2) <= 0.02 * float(np.linalg.norm(b3[i] - a3[i]))
                if keep.sum() >= 2:
                    lines.append(np.array([flat[keep][0], flat[keep][-1]]))
        if lines:
            return np.array(lines), "rulings of devflat's strip between the same seams (best-fit developable), " \
                                    "projected onto the hull patch"
    return np.zeros((0, 2, 2)), ""


def edge_labels(outline_sides, hull, points):
    """Seam names along the first and last grid rows, butt names along the end columns,
    each butt named by where its column lies in 3D (columns run along s, which may run
    towards -x)."""
    first, last = (0, 1) if points[:, 0, 0].mean() <= points[:, -1, 0].mean() else (1, 0)
    labels = []
    for text, line in zip((hull.seam_names[0], hull.seam_names[1], hull.butt_names[first], hull.butt_names[last]),
                          outline_sides):
        mid = line[len(line) // 2] if len(line) > 2 else line.mean(axis=0)
        direction = line[-1] - line[0]
        labels.append((text, mid, float(np.degrees(np.arctan2(direction[1], direction[0])))))
    return tuple(labels)


def clipped(rolls, frames, labels, outline):
    """Roll lines, frame lines and edge names of a plate cut at its trim: the parts inside
    the cut outline (a label whose place is outside it is dropped)."""
    from shapely.geometry import LineString, Point, Polygon

    plate = Polygon(outline).buffer(1e-9 * float(np.ptp(outline, axis=0).max()))

    def inside(line):
        piece = plate.intersection(LineString(line))
        pieces = [g for g in getattr(piece, "geoms", [piece]) if g.geom_type == "LineString" and not g.is_empty]
        return [np.asarray(g.coords) for g in pieces]

    rolls = np.array([pts[[0, -1]] for a, b in rolls for pts in inside([a, b])]).reshape(-1, 2, 2)
    frames = [(x, pts) for x, line in frames for pts in inside(line)]
    labels = tuple(label for label in labels if plate.contains(Point(label[1])))
    return rolls, frames, labels


def rolled(rolls, surface, grid, placed, faces, outline, steel, config):
    """The roll lines of a patch-developed plate that it must be rolled at (the radius across
    each, the hull's largest principal radius along it, below the plate's no-roll radius:
    :mod:`pipeline.shop.rolling`) and the report's roll figures (mm)."""
    from ..shop.rolling import line_radii, plate_limit

    radii = line_radii(surface, grid.params.reshape(-1, 2), placed, faces, outline, rolls) * config.mm_per_unit
    setup = plate_limit(steel.thickness, steel.material, config.spec.shop.no_roll_radius)
    keep = radii < setup.limit
    finite = radii[np.isfinite(radii)]
    setup = dataclasses.replace(setup, rolled=int(keep.sum()), dropped=int((~keep).sum()),
                                smallest_radius=float(finite.min()) if finite.size else float("inf"))
    return rolls[keep], {"roll_line_radii": [float(r) for r in radii[keep]], "rolling": setup.figures(),
                         "roll_line_radius": "the hull's largest principal radius along the line (5 points), mm"}


def least_bending_lines(surface, grid, placed, faces, outline, spacing):
    """Roll lines along the direction of least normal curvature of the hull (the rulings
    of a developable surface), traced as streamlines across the flat plate from seeds
    ``spacing`` apart on the line through its centre, each replaced by its chord."""
    uvp = grid.params.reshape(-1, 2)[faces].mean(axis=1)
    _, d3 = principal_curvatures(surface, uvp[:, 0], uvp[:, 1])
    maps = triangle_maps(grid.points.reshape(-1, 3), placed, faces)
    d2 = np.einsum("fij,fj->fi", maps, d3)
    norm = np.linalg.norm(d2, axis=1)
    good = norm > 0
    d2 = d2[good] / norm[good, None]
    centres = placed[faces].mean(axis=1)[good]
    if not len(d2):
        return np.zeros((0, 2, 2)), "none"
    # mean axis of the sign-free field: principal eigenvector of sum d d^T
    w, vecs = np.linalg.eigh(d2.T @ d2)
    axis = vecs[:, -1]
    across = np.array([-axis[1], axis[0]])
    centre = outline.mean(axis=0)
    extent = np.abs((outline - centre) @ across).max()
    seeds = centre + np.arange(-extent, extent + 1e-9, spacing)[:, None] * across
    from matplotlib.path import Path as MplPath

    seeds = seeds[MplPath(outline).contains_points(seeds)]
    lines = streamlines(centres, d2, outline, seeds, step=spacing / 5)
    segs = np.array([[line[0], line[-1]] for line in lines if np.linalg.norm(line[-1] - line[0]) > spacing])
    return segs.reshape(-1, 2, 2), ("chords of streamlines of the hull's direction of least normal curvature "
                                    "(principal directions of the design surface)")
