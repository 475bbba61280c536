"""Run one part; a hull plate always gets a development and a class.

flat        the plate's region on the hull fits some plane within the fit tolerance (its
            minimax plane, :mod:`flatten.minimax`: the least-squares plane may miss where
            another fits): the development is its orthogonal projection on that plane,
            and the reported deviation is that plane's largest distance;
developable devflat's strip fits the hull within the tolerance and covers the whole region
            (four corners included): its rulings seam to seam (between the seams, trimmed
            by the butt planes) or butt to butt (between the butt sections, trimmed by the
            seams; :mod:`pipeline.platestrip`), whichever fits better; where neither
            fits but one misses by less than three tolerances, its best-fit strip (the
            boundary curves moved off the hull so that the hull lies on both sides of the
            rulings, :mod:`pipeline.bestfit`) is tried, and a seam strip that leans short
            of a corner is solved again between the seams extended far past the butts;
formed      neither: the region's own fine mesh flattened with minimal strain (libigl LSCM
            seed, then ARAP), with a strain map, shrink/stretch areas and roll lines;
            ``rolling_only`` when its strain is small enough to be rolled without heating;
            sized by the workshop method (``shop.workshop_method``) and given heating lines
            where it must shrink (:mod:`pipeline.shop.heating`).

A plate is complete only when its delivered 3D shape holds its four corners and its whole
region on the hull; any exception inside one plate makes that plate fail with the reason,
never the run.
"""

from __future__ import annotations

import dataclasses
import traceback

import numpy as np

from flatten.closest import SurfaceDistance
from flatten.metrics import polygon_area
from flatten.patch import grid_ring, region_grid, turn_refined_grid, weld
from flatten.minimax import flattest_plane
from flatten.patchflat import arap_development, planar_development, plane_through, triangle_stretches

from ..config import Part, RunConfig
from .bestfit import ROUNDS, best_fit, seam_family_far, worth_moving
from .plateshop import (LeanRun, OwedPatch, PatchGeometry, complete, is_lean, owe, owe_development, patch_shop,
                        trimmed_shop)
from .leaststrip import LEAST_CURVATURE, LEAST_ROUNDS, least_curvature_family
from .platestrip import BUTT_TO_BUTT, HOPELESS, SEAM_TO_SEAM, Trim, butt_family, seam_family_trimmed
from .trimcut import cut_at_trim, outside_trim
from ..stages import Pattern, PartResult, develop_part, finish_part, naive_check, place_flat
from ..stages import run_part as run_curve_part

# a principal strain beyond 1 mm/m marks an area to shrink or stretch when forming (the
# order of the 0.3-1 mm/m a shell expansion program prompts for)
FORMING_STRAIN = 1e-3
REGION_SIZE_MM = 1000.0  # strain map cells about 1 m square
# a plate grid's seam rows and butt columns are its edges against its neighbours, each of
# which samples the same seam or butt at its own points (staggered butts, split plates, two
# faces): where a chord of the grid's edge would stand off the hull's seam or butt by more
# than TURN_TRIGGER fit tolerances, its columns (rows) there are cut until within
# TURN_TARGET (:func:`flatten.patch.turn_refined_grid`). DTMB 5415's seam 2 turning up the
# stem stepped 20.6 mm between plates that sampled it 150 mm apart. The trigger is low so
# that two plates sampling one turn both cut: at one tolerance KCS's plate estimated at 4.5
# mm was left beside its neighbour at 5.04 mm, cut, and the two stepped 3.06 mm
TURN_TRIGGER = 0.2
TURN_TARGET = 0.1
TURN_PASSES = 3
# a lean-evaluated formed plate's class record until its development is done
OWED_CLASS = {"class": "formed", "development": "owed (pipeline.hull.plateshop.owe_development)"}


def run_part(part: Part, config: RunConfig) -> PartResult:
    """Any part: curve pairs through the stages, hull plates through :func:`run_plate`."""
    if part.hull is None:
        return run_curve_part(part, config)
    # an adaptive plan evaluated it already (lean: its shop data are computed here, in the
    # worker that writes its files, from the geometry the evaluation kept)
    result = part.hull.result if part.hull.result is not None else run_plate(part, config)
    result = complete(result, config)
    if "fitup_edges" not in result.figures:
        # the run's fit-up report needs each plate's edges after the worker has dropped the
        # plate's geometry; figures not named by the part report are not written to its JSON
        from .fitup import plate_edges

        try:
            result.figures["fitup_edges"] = plate_edges(result)
        except Exception as exc:  # noqa: BLE001 - the plate is delivered; the report says it went unmeasured
            result.figures["fitup_edges"] = None
            result.figures["fitup_error"] = f"{type(exc).__name__}: {exc}"
    return result


def evaluate_plate(part: Part, config: RunConfig) -> PartResult:
    """The evaluator an adaptive plan uses: the plate run, lean (class, fit, area, and the
    development of a flat or strip plate; a formed plate's development and every plate's
    shop data left owed, :mod:`.plateshop`: only the plates the plan keeps get them, in
    :func:`run_part`)."""
    return run_plate(part, LeanRun(config))


def _grid(part: Part, config: RunConfig):
    hull = part.hull
    planes = [None if p is None else p.as_tuple() for p in hull.butts]
    coarse = region_grid(hull.surface, hull.long_axis, hull.girths[0], hull.girths[1], planes, 5, 9, probe=200)
    if coarse is None:
        return None
    p = coarse.points
    length = float(np.linalg.norm(np.diff(p, axis=1), axis=2).sum(axis=1).max())
    width = float(np.linalg.norm(np.diff(p, axis=0), axis=2).sum(axis=0).max())
    h = hull.resolution
    rows = int(np.clip(np.ceil(width / h) + 1, 5, 60))
    cols = int(np.clip(np.ceil(length / h) + 1, 9, 160))
    # rows even in 3D girth length: the plate's mesh, fit-up edges and development sample it
    return turn_refined_grid(hull.surface, hull.long_axis, hull.girths[0], hull.girths[1], planes, rows, cols,
                             TURN_TRIGGER * hull.fit_tolerance, TURN_TARGET * hull.fit_tolerance, TURN_PASSES,
                             probe=400, spacing="length")


def _grid_faces_region(shape, region_cells) -> np.ndarray:
    """Region index of every grid triangle (faces as PatchGrid.faces orders them)."""
    r, c = shape
    cell = np.arange((r - 1) * (c - 1))
    i, j = np.divmod(cell, c - 1)
    nr, nc = region_cells
    region = (i * nr // (r - 1)) * nc + (j * nc // (c - 1))
    return np.concatenate([region, region])


def strain_map(v3, uv, faces, shape, size_mm: tuple[float, float], mm_per_unit: float, valid=None) -> dict:
    """Per-triangle principal strains summarised per region of about 1 m x 1 m; ``valid``
    (F,) masks out triangles that collapse (a seam end standing still)."""
    stretch = triangle_stretches(v3, uv, faces)
    strain = stretch - 1.0
    good = np.all(np.isfinite(strain), axis=1) & (True if valid is None else valid)
    area = 0.5 * np.linalg.norm(np.cross(v3[faces[:, 1]] - v3[faces[:, 0]], v3[faces[:, 2]] - v3[faces[:, 0]]), axis=1)
    magnitude = np.where(good, np.abs(strain).max(axis=1, initial=0.0, where=good[:, None]), 0.0)
    worst = int(np.argmax(magnitude))
    centroid3 = v3[faces].mean(axis=1)
    centroid2 = uv[faces].mean(axis=1)
    nr = max(1, int(np.ceil(size_mm[1] / REGION_SIZE_MM)))
    nc = max(1, int(np.ceil(size_mm[0] / REGION_SIZE_MM)))
    region = _grid_faces_region(shape, (nr, nc))
    regions, shrink_area, stretch_area = [], 0.0, 0.0
    for k in range(nr * nc):
        sel = (region == k) & good
        if not sel.any():
            continue
        hi, lo = float(strain[sel, 0].max()), float(strain[sel, 1].min())
        kind = "shrink" if hi > FORMING_STRAIN and hi >= -lo else ("stretch" if lo < -FORMING_STRAIN else "none")
        a = float(area[sel].sum())
        shrink_area += a if kind == "shrink" else 0.0
        stretch_area += a if kind == "stretch" else 0.0
        regions.append({"region": [k // nc, k % nc], "max_strain": hi, "min_strain": lo, "kind": kind,
                        "centre_flat": centroid2[sel].mean(axis=0).tolist(),
                        "centre_3d": centroid3[sel].mean(axis=0).tolist(), "area_m2": a * (mm_per_unit / 1e3) ** 2})
    rms = float(np.sqrt(np.sum(area[good] * np.sum(strain[good] ** 2, axis=1)) / max(area[good].sum(), 1e-300)))
    return {"max_abs_strain": float(magnitude[worst]), "where_3d": centroid3[worst].tolist(),
            "where_flat": centroid2[worst].tolist(), "rms_strain": rms,
            "max_stretch_strain": float(strain[good, 0].max()), "max_compress_strain": float(strain[good, 1].min()),
            "forming_threshold": FORMING_STRAIN, "regions": regions,
            "shrink_area_m2": shrink_area * (mm_per_unit / 1e3) ** 2,
            "stretch_area_m2": stretch_area * (mm_per_unit / 1e3) ** 2}


def completeness(v3: np.ndarray, faces: np.ndarray, grid, tolerance: float, corner_tolerance: float) -> dict:
    """Is the whole region (grid points, corners) within reach of the delivered 3D plate?"""
    import igl

    corners = grid.corners()
    d2c, _, _ = igl.point_mesh_squared_distance(corners, np.ascontiguousarray(v3), np.ascontiguousarray(faces))
    pts = grid.points.reshape(-1, 3)
    d2, _, _ = igl.point_mesh_squared_distance(pts, np.ascontiguousarray(v3), np.ascontiguousarray(faces))
    gaps = np.sqrt(d2c)
    worst = int(np.argmax(d2))
    return {"corner_gaps": gaps.tolist(), "corner_tolerance": corner_tolerance,
            "max_region_gap": float(np.sqrt(d2[worst])), "worst_region_point": pts[worst].tolist(),
            "tolerance": tolerance,
            "passed": bool(gaps.max() <= corner_tolerance and np.sqrt(d2[worst]) <= tolerance)}


def run_plate(part: Part, config: RunConfig) -> PartResult:
    """Flat, developable or formed: every hull plate gets a development and a class."""
    result = PartResult(part.name, part)
    held = part.hull.held
    try:
        if held:
            _run_plate(result, config, patch_only=held["reason"], edge_limit=held.get("edge_limit"))
            result.figures["edge_fit"] = dict(held)
            return result
        _run_plate(result, config)
        if part.hull.as_strip and result.figures.get("plate_class"):
            result.figures["plate_class"]["flat_declined"] = dict(part.hull.as_strip)
        limit = part.hull.edge_tolerance
        off = edge_deviation(result) if limit is not None else None
        if off is not None and off > limit:
            was = (result.figures.get("plate_class") or {}).get("class")
            result = PartResult(part.name, part)
            _run_plate(result, config, patch_only=f"its {was} development's edges leave the hull by {off:.4g} "
                                                  f"(edge tolerance {limit:g})")
            result.figures["edge_fit"] = {"edge_tolerance": limit, "edge_deviation_before": off, "class_before": was}
    except Exception as exc:  # one plate never stops the run: report it with the evidence
        result.status = "failed"
        result.reason = f"internal error in plate {part.name}: {type(exc).__name__}: {exc}"
        result.figures["traceback"] = traceback.format_exc(limit=6)
    return result


def edge_deviation(result: PartResult) -> float | None:
    """Largest distance (config units) of a flat or strip plate's delivered 3D edges (seams,
    butts) from the hull; None for a patch (it lies on the hull) or a plate without edges."""
    from .fitup import plate_edges

    klass = (result.figures.get("plate_class") or {}).get("class")
    if klass not in ("flat", "developable") or "patch" in str((result.figures.get("plate_class") or {}).get("method")):
        return None
    edges = plate_edges(result)
    if edges is None or not edges.edges:
        return None
    hull = result.part.hull
    distance = hull.distance or SurfaceDistance(hull.surface)
    return float(max(distance(e.points3).max() for e in edges.edges))


def _run_plate(result: PartResult, config: RunConfig, patch_only: str = "", edge_limit: float | None = None) -> None:
    """The plate's class and development; ``patch_only``: why no flat or strip development is
    tried (the plate is developed on the hull as a patch); ``edge_limit``: with it, a plate that
    is flat on a plane keeping its edges within this of the hull stays flat (else a patch). A
    formed plate moved to meet its neighbours with its strips' verdict from before
    (``hull.follow['verdict']``) is developed from its moved patch at once."""
    part, hull = result.part, result.part.hull
    mm = config.mm_per_unit
    tol = hull.fit_tolerance
    corner_tol = min(tol, config.spec.resolution.tolerance(config.mm_per_unit) or tol)
    grid = _grid(part, config)
    if grid is None:
        result.reason = "the plate's region misses the hull surface (seams and butts enclose nothing)"
        result.figures["plate_class"] = {"class": "failed"}
        return
    shape = grid.shape
    v_grid = grid.points.reshape(-1, 3)
    f_grid = grid.faces()
    size = float(np.ptp(v_grid, axis=0).max())
    v3, f3, index = weld(v_grid, f_grid, 1e-9 * size)
    area3 = float(0.5 * np.linalg.norm(np.cross(v3[f3[:, 1]] - v3[f3[:, 0]], v3[f3[:, 2]] - v3[f3[:, 0]]),
                                       axis=1).sum())
    p = grid.points
    length = float(np.linalg.norm(np.diff(p, axis=1), axis=2).sum(axis=1).max())
    width = float(np.linalg.norm(np.diff(p, axis=0), axis=2).sum(axis=0).max())
    result.figures["region"] = {"corners": grid.corners().tolist(), "area_m2": area3 * (mm / 1e3) ** 2,
                                "length": length, "width": width, "grid": list(shape),
                                "seams": list(hull.seam_names), "butts": list(hull.butt_names),
                                "surface": hull.surface.name, "surface_note": hull.surface_note or None,
                                "butt_planes": [None if b is None else {"normal": list(b.normal), "offset": b.offset}
                                                for b in hull.butts]}
    verdict = (hull.follow or {}).get("verdict")
    if verdict is not None and not patch_only:
        # formed before it was moved: the strips are judged on the region as it lies on the
        # hull, which the moves leave alone, so solved again they would fail as they did
        _deliver_hull_patch(result, config, grid, v3, f3, index, (length, width), verdict["info"],
                            verdict["roll_strip"], strips_tried=True)
        return
    # flat when some plane fits, not only the least-squares one: the minimax plane, the
    # mid-plane of the thinnest slab holding the region (flatten/minimax.py)
    # a plate held on the hull for its edges is a patch: no plane to fit unless it may stay flat
    if hull.plane and not patch_only and not hull.as_strip:
        chosen = plane_through(v_grid, hull.plane["normal"], hull.plane["point"])
        if chosen.max_distance <= tol:  # else (round-off at the tolerance) its own plane, as before
            _deliver_flat(result, config, grid, v3, f3, index, chosen, tol, (length, width),
                          "orthogonal projection on the plane chosen together with its neighbours' (strake.fit_up: "
                          "follow): within the tolerance of the region, its edges meeting theirs",
                          {"joint_plane": True})
            return
    # a held plate moved by the forming (strake.hold_steps) was delivered as a patch: its
    # plane and strip were tried on the same region and failed
    edge_limit = None if hull.follow else edge_limit
    fit = None if patch_only and edge_limit is None else flattest_plane(v_grid, tol)
    if edge_limit is not None and fit.max_distance <= tol:
        # held for its fit-up: flat only on the plane that keeps its edges nearest the hull
        from flatten.edgeplane import edge_held_plane

        held = edge_held_plane(v_grid, _grid_edge(shape), tol, start=fit)
        if held is not None and held.edge_max_distance <= edge_limit:
            _deliver_flat(result, config, grid, v3, f3, index, held, tol, (length, width),
                          f"orthogonal projection on the plane within the tolerance of the region that keeps its "
                          f"edges nearest the hull ({held.edge_max_distance:.3g} off, limit {edge_limit:.3g})")
            return
    # (not a plate that reaches past its face's trim: a strip is not cut at a trim)
    if edge_limit is not None and hull.developable and hull.trim is None and \
            _edge_held_strip(result, config, grid, area3, corner_tol, edge_limit):
        return
    if patch_only:
        _deliver_hull_patch(result, config, grid, v3, f3, index, (length, width),
                            {"strip_not_delivered_because": patch_only, "families": [], "strip_max_deviation": None},
                            None, strips_tried=False)
        return
    if fit.max_distance <= tol and not hull.as_strip:
        _deliver_flat(result, config, grid, v3, f3, index, fit, tol, (length, width),
                      "orthogonal projection on the minimax (Chebyshev) plane of the region",
                      {"plane_lower_bound": fit.lower_bound, "plane_proven_minimax": fit.proven,
                       "least_squares_max_distance": fit.least_squares_max})
        return
    attempt, seam_ok, why, seam_deviation = PartResult(part.name, part), False, hull.note, None
    if hull.developable:
        attempt, seam_ok, why, seam_deviation = _seam_strip(part, config, grid, tol, corner_tol)
    butt = Trim(BUTT_TO_BUTT)
    try:
        butt = butt_family(part, config, grid, corner_tol)
    except Exception as exc:  # as above: this family is then simply not delivered
        butt.reason = _raised(exc)
    seam = Trim(SEAM_TO_SEAM)
    if not seam_ok:
        # the seams' strip trimmed by the region: an end plate's only seam strip; an interior
        # plate's when the plain one leans short of a corner (seams extended far past the butts)
        end_plate = not hull.developable and sum(b is None for b in hull.butts) == 1
        try:
            if end_plate:
                seam = seam_family_trimmed(part, config, grid, corner_tol)
            elif hull.developable and _seams_too_far(seam_deviation, tol):
                seam.reason = (f"seams extended past the butts: not tried (the strip between them stands "
                               f"{seam_deviation:.4g} off the hull, over {HOPELESS:g} tolerances)")
            elif hull.developable:
                seam = seam_family_far(part, config, grid, corner_tol)
        except Exception as exc:
            seam.reason = _raised(exc)
    least = Trim(LEAST_CURVATURE)  # tried only where no other family fits: every formed plate's verdict has it
    if not (seam_ok or seam.ok or butt.ok):
        seam, butt = _moved(seam, part, config, grid), _moved(butt, part, config, grid)
        if not (seam.ok or butt.ok):
            # neither pair of edges carries a strip on the hull: the rulings where the hull's are
            least = _moved(_least_curvature(part, config, grid, corner_tol), part, config, grid)
    if seam.reason:
        why = f"{why}; {seam.reason}" if why and hull.developable else seam.reason
    if seam.deviation is not None and (seam_deviation is None or seam.deviation < seam_deviation):
        seam_deviation, attempt = seam.deviation, seam.attempt
    families = {SEAM_TO_SEAM: why, BUTT_TO_BUTT: butt.reason, LEAST_CURVATURE: least.reason}
    if seam_ok and (not butt.ok or seam_deviation <= butt.deviation):
        _deliver_seam_strip(result, config, attempt, area3, _other(BUTT_TO_BUTT, butt.reason or (
            f"fits within {butt.deviation:.4g}, the seam family within {seam_deviation:.4g}")))
        return
    fitting = sorted((t for t in (seam, butt, least) if t.ok), key=lambda t: t.deviation)
    if fitting:
        chosen = fitting[0]
        other = _runner_up(chosen, seam, butt)
        other_why = (f"fits within {other.deviation:.4g}, the chosen family within {chosen.deviation:.4g}"
                     if other.ok else (why if other.family == SEAM_TO_SEAM else other.reason))
        _deliver_trimmed(result, config, grid, chosen, area3, _other(other.family, other_why))
        return
    deviations = {SEAM_TO_SEAM: seam_deviation, BUTT_TO_BUTT: butt.deviation, LEAST_CURVATURE: least.deviation}
    best = min((d, f) for f, d in deviations.items() if d is not None) if any(
        d is not None for d in deviations.values()) else (None, SEAM_TO_SEAM)
    nearest = {BUTT_TO_BUTT: butt, LEAST_CURVATURE: least}.get(best[1])
    roll_strip = nearest.attempt.strip if nearest is not None and nearest.attempt is not None else attempt.strip
    _deliver_hull_patch(result, config, grid, v3, f3, index, (length, width),
                        {"strip_not_delivered_because": "; ".join(f"{f}: {r}" for f, r in families.items()),
                         "families": [_other(f, r, deviations[f]) for f, r in families.items()],
                         "strip_max_deviation": best[0]},
                        roll_strip, strips_tried=True)


def _runner_up(chosen: Trim, seam: Trim, butt: Trim) -> Trim:
    """The family a delivered strip is reported against: the other pair of edges, or for the
    least-curvature strip the nearer of the two."""
    if chosen is seam or chosen is butt:
        return butt if chosen is seam else seam
    return min((seam, butt), key=lambda t: (not t.ok, np.inf if t.deviation is None else t.deviation))


def _least_curvature(part: Part, config: RunConfig, grid, corner_tol: float) -> Trim:
    """The least-curvature family's strip, or its reason when it raises (as the others)."""
    try:
        return least_curvature_family(part, config, grid, corner_tol)
    except Exception as exc:
        return Trim(LEAST_CURVATURE, reason=_raised(exc))


def _deliver_hull_patch(result, config, grid, v3, f3, index, size, verdict: dict, strip, strips_tried: bool) -> None:
    """A formed plate: its hull patch (moved as ``hull.follow`` says) developed with minimal
    strain; ``verdict`` why no strip was delivered (strip_not_delivered_because, families,
    strip_max_deviation), ``strip`` the one its roll lines follow or None; ``strips_tried``:
    the verdict is the strips' own (kept for a later move: :func:`.plateshop.formed_verdict`),
    not a reason they were not tried."""
    hull = result.part.hull
    grid, v3 = _followed(grid, v3, index, hull)
    if is_lean(config) and (hull.trim is None or not outside_trim(hull.trim, grid.params)):
        # the plan reads a formed plate's class and wholeness, not its development: owed
        check = completeness(v3, f3, grid, hull.fit_tolerance, _patch_corner_tolerance(hull, size))
        result.figures["plate_class"] = dict(OWED_CLASS)
        if check["passed"]:
            result.status = "ok"
        else:
            result.reason = _incomplete(check)
        owe_development(result, _owed_patch, OwedPatch(grid, v3, f3, index, size, verdict, strip, strips_tried, check))
        return
    _developed_patch(result, config, OwedPatch(grid, v3, f3, index, size, verdict, strip, strips_tried))


def _owed_patch(result, config, owed: OwedPatch) -> None:
    """:func:`_developed_patch` of a lean-evaluated formed plate, the state its evaluation
    left for the plan (class, ok or why incomplete) undone first: the same figures as had it
    been developed at once, with what was added to its class record since (``flat_declined``).
    A plate failed since its evaluation (by something else) is developed and stays failed, as
    it would have been developed at once and failed after. (A development that raises fails
    the plate now, at its completion, where it failed its evaluation before: the plan judged
    such a plate formed where it judged it failed, and splits both alike.)"""
    since = (result.status, result.reason)
    left = ("ok", "") if owed.check["passed"] else ("failed", _incomplete(owed.check))  # by the evaluation
    added = {k: v for k, v in result.figures.pop("plate_class", {}).items() if k not in OWED_CLASS}
    result.status, result.reason = "failed", ""
    _developed_patch(result, config, owed)
    if added and "plate_class" in result.figures:
        result.figures["plate_class"].update(added)
    if since != left:
        result.status, result.reason = since


def _developed_patch(result, config, patch: OwedPatch) -> None:
    """A formed plate's hull patch developed (ARAP) and delivered (its ``check`` reused when
    its evaluation made one)."""
    uv, iterations = arap_development(patch.v3, patch.f3)
    method = f"libigl LSCM seed then ARAP ({iterations} iterations) on the hull patch mesh"
    _deliver_patch(result, config, patch.grid, uv[patch.index], patch.v3, patch.f3, patch.index, "patch",
                   {"method": method, **patch.verdict}, patch.strip, patch.size,
                   patch.verdict if patch.strips_tried else None, patch.check)


def _flat_completeness(grid, v_grid: np.ndarray, info: dict, tolerance: float) -> dict:
    """:func:`completeness` of a flat plate, against its plane (``info``: its normal, a point
    and the region's largest distance from it): the cut plate is planar, so the region and its
    corners are measured against the plane itself (against the region's own mesh the corners
    would be 0 off by construction)."""
    normal, point = np.asarray(info["normal"], dtype=float), np.asarray(info["plane_point"], dtype=float)
    corner_gaps = np.abs((grid.corners() - point) @ normal)
    off = np.abs((v_grid - point) @ normal)
    fit = info["plane_max_distance"]
    return {"corner_gaps": corner_gaps.tolist(), "corner_tolerance": tolerance, "max_region_gap": fit,
            "worst_region_point": v_grid[int(np.argmax(off))].tolist(), "tolerance": tolerance,
            "passed": bool(fit <= tolerance and corner_gaps.max() <= tolerance)}


def _patch_corner_tolerance(hull, size) -> float:
    """A patch's corners lie on its own mesh: judged to round-off of the plate's size."""
    return min(hull.fit_tolerance, 1e-6 * max(size) + 1e-9)


def _incomplete(check: dict) -> str:
    return f"plate incomplete: largest gap to its region {check['max_region_gap']:.4g}"


def _seams_too_far(deviation: float | None, tolerance: float) -> bool:
    """Whether the strip between a plate's seams stands so far off the hull (over HOPELESS
    tolerances) that the seams extended past the butts are not tried. The ruling through a
    seam point solves an equation of that point and the other seam (DESIGN.md 1.2): the
    extension adds only rulings that lean past the butts, the remedy for a strip that stops
    short of a corner, not for one that leaves the hull. Measured, not proved: on the 160 m
    hull, DTMB 5415 and KCS, of 705 candidate plates whose plain seam strip stood that far
    off, no extended one came within HOPELESS tolerances (11, 7 and 10 CPU s of their plans)."""
    return deviation is not None and deviation > HOPELESS * tolerance


def _followed(grid, v3: np.ndarray, index: np.ndarray, hull):
    """The region grid and its welded mesh vertices (V, 3) moved as the fit-up by forming
    says (``hull.follow``, :mod:`.follow`), or as they are: a formed plate's target shape."""
    follow = hull.follow
    if not follow:
        return grid, v3
    offsets = np.asarray(follow["offsets"], dtype=np.float64)
    if offsets.shape != grid.points.shape:
        raise ValueError(f"fit-up moves of shape {offsets.shape} for a region grid of shape {grid.points.shape}")
    from .follow import first_of_groups

    moved = v3 + offsets.reshape(-1, 3)[first_of_groups(index)]  # each welded vertex's first grid point
    return dataclasses.replace(grid, points=moved[index].reshape(grid.points.shape), derived={}), moved


def _seam_strip(part: Part, config: RunConfig, grid, tol: float, corner_tol: float) -> tuple:
    """The strip between the plate's seams, cut by its butt planes, judged: (attempt, ok, why
    not, its largest distance from the hull or None)."""
    from .strake import corner_rulings, screen_at_butts, stage_trim

    hull = part.hull
    attempt = PartResult(part.name, part)
    cuts = []
    try:
        # judged on the hull in 3D first: a strip off it is not developed
        ok = develop_part(attempt, config, lambda sol: corner_rulings(sol, part.c, part.d, hull.butts), 0.0,
                          lambda solved: screen_at_butts(solved, cuts), naive=False)
        ok = ok and stage_trim(attempt, cuts[0], 0.0)
        if attempt.strip is not None and attempt.strip.trim is not None:
            # the strip mesh's edges are chords of the seams: allow its chord error on the region
            chord = float(np.max(attempt.strip.max_chord_error))
            check = completeness(attempt.strip.vertices, attempt.strip.faces, grid, tol + chord, corner_tol)
            attempt.figures["completeness"] = check
            if ok and not check["passed"]:
                ok = False
                attempt.reason = (f"strip incomplete: corner gaps {np.round(check['corner_gaps'], 2).tolist()} "
                                  f"(limit {corner_tol:g}), largest gap to the region "
                                  f"{check['max_region_gap']:.4g} (limit {tol + chord:g})")
        return attempt, ok, attempt.reason, (attempt.figures.get("hull_fit") or {}).get("max_distance")
    except Exception as exc:  # the strip attempt failed hard: the plate is still delivered
        return attempt, False, _raised(exc), None


def _deliver_seam_strip(result: PartResult, config: RunConfig, attempt: PartResult, area3: float,
                        other: dict) -> None:
    """The plate as its seam strip (``attempt``, judged by :func:`_seam_strip`)."""
    region = result.figures["region"]
    naive_check(attempt)
    result.__dict__.update({k: v for k, v in attempt.__dict__.items() if k not in ("name", "part")})
    result.figures["region"] = region
    result.figures["plate_class"] = {
        "class": "developable", "family": SEAM_TO_SEAM,
        "method": "devflat strip between the seams (rulings seam to seam), trimmed by the butt planes",
        "max_deviation": attempt.figures["hull_fit"]["max_distance"], "max_strain": 0.0,
        "area_3d_m2": area3 * (config.mm_per_unit / 1e3) ** 2, "complete": True, "other_family": other}
    if is_lean(config):  # finish_part's verdict (it fails only by raising); its shop data owed
        result.status = "ok"
    owe(result, config, finish_part)


def _edge_held_strip(result: PartResult, config: RunConfig, grid, area3: float, corner_tol: float,
                     edge_limit: float) -> bool:
    """An interior plate held for its fit-up delivered as the strip between its seams when that
    fits the hull and keeps every edge within ``edge_limit`` of it: the plain seam strip, or where its
    rulings lean short of a corner (a near-flat plate) the strip between the seams extended
    far past the butts, trimmed by the region. Its seam edges lie on the seams, on the hull;
    its butt edges are off the hull's sections by the strip's own gap there. Whether it was
    flat or a strip before, it stays developable (not a patch)."""
    part = result.part
    trial = PartResult(result.name, part)
    trial.figures["region"] = result.figures["region"]
    other = _other(BUTT_TO_BUTT, "not tried: the plate is held for its fit-up, and a seam strip's seam edges lie on "
                                 "the hull")
    try:
        attempt, ok, _, _ = _seam_strip(part, config, grid, part.hull.fit_tolerance, corner_tol)
        if ok:
            _deliver_seam_strip(trial, config, attempt, area3, other)
        else:
            far = seam_family_far(part, config, grid, corner_tol)
            if not far.ok:
                return False
            _deliver_trimmed(trial, config, grid, far, area3, other)
        off = edge_deviation(trial)
    except Exception as exc:  # as a family that raises in the plate's own run: no strip, the patch follows
        result.figures["edge_held_strip_error"] = _raised(exc)
        return False
    if off is None or off > edge_limit:
        return False
    trial.figures["plate_class"]["method"] += (f" (held for its fit-up: its edges {off:.3g} off the hull, "
                                               f"limit {edge_limit:.3g})")
    result.__dict__.update(trial.__dict__)
    return True


def _grid_edge(shape) -> np.ndarray:
    """(R*C,) bool: the region grid's boundary points (first and last row and column)."""
    edge = np.zeros(shape, dtype=bool)
    edge[0] = edge[-1] = edge[:, 0] = edge[:, -1] = True
    return edge.ravel()


def _deliver_flat(result, config, grid, v3, f3, index, fit, tol, size, method, extra=None) -> None:
    """A flat plate: the region projected on the plane ``fit`` (within ``tol`` of it)."""
    v_grid = grid.points.reshape(-1, 3)
    uv = planar_development(v_grid, fit)
    _deliver_patch(result, config, grid, uv, v3, f3, index, "flat",
                   dict({"method": method, "plane_max_distance": fit.max_distance, "normal": fit.normal.tolist(),
                         "plane_point": np.asarray(fit.centroid, dtype=float).tolist()}, **(extra or {})),
                   None, size)
    result.figures["hull_fit"] = {"max_distance": fit.max_distance,
                                  "rms_distance": float(np.sqrt(np.mean(fit.distances ** 2))),
                                  "tolerance": tol, "passed": True}


def _moved(trim: Trim, part: Part, config: RunConfig, grid) -> Trim:
    """The trim's best-fit strip when it misses the tolerance by a little (else the trim); a
    least-curvature strip gets one round (LEAST_ROUNDS)."""
    if not worth_moving(trim, part.hull.fit_tolerance):
        return trim
    try:
        return best_fit(trim, part, config, grid, LEAST_ROUNDS if trim.family == LEAST_CURVATURE else ROUNDS)
    except Exception as exc:  # the plain strip's verdict stands
        trim.reason = f"{trim.reason}; best fit: {_raised(exc)}"
        return trim


def _raised(exc: Exception) -> str:
    why = f"strip attempt raised {type(exc).__name__}: {exc}"
    frame = traceback.extract_tb(exc.__traceback__)[-1]
    return why + f" (in {frame.name}, {frame.filename.rsplit('/', 2)[-2:]}:{frame.lineno})"


def _other(family: str, why: str, deviation=None) -> dict:
    out = {"family": family, "rejected_because": why}
    if deviation is not None:
        out["max_deviation"] = deviation
    return out


def _deliver_trimmed(result, config, grid, trim, area3, other) -> None:
    """A plate delivered as a strip trimmed by its region (:mod:`pipeline.platestrip`): its
    3D shape is the strip at the closest points of the hull's patch grid, its cut outline
    the developed region boundary, its bending lines the strip's own rulings (shop data:
    :func:`.plateshop.trimmed_shop`, owed in a lean run)."""
    rows, cols = grid.shape
    flat = trim.grid_flat
    uv_grid = flat.reshape(rows, cols, 2)
    rot, shift = place_flat(flat, uv_grid[0])
    placed = flat @ rot.T + shift
    outline = trim.outline_flat @ rot.T + shift
    result.strip, result.solution, result.development, result.developed = None, None, None, None
    result.mesh = (trim.grid_3d, grid.faces())
    result.pattern = Pattern(outline, np.zeros((0, 2, 2)), placed, (rot, shift))
    attempt = trim.attempt
    naive_check(attempt)
    for key in ("coverage", "rulings", "developability", "unroll"):
        if key in attempt.figures:
            result.figures[key] = attempt.figures[key]
    result.figures["strip_solution"] = attempt.solution.message
    for key in ("hull_fit", "completeness", "trim", "sections"):
        if key in trim.figures:
            result.figures[key] = trim.figures[key]
    result.figures["plate_class"] = {
        "class": "developable", "family": trim.family,
        "method": ("devflat strip between the plate's butt sections (rulings butt to butt), trimmed by the seams"
                   if trim.family == BUTT_TO_BUTT else
                   "devflat strip between two hull curves across the region's least curvature (rulings along it), "
                   "trimmed by the seams and butts" if trim.family == LEAST_CURVATURE else
                   "devflat strip between the plate's seams (rulings seam to seam), trimmed by " +
                   ("its butt and the hull's end" if None in result.part.hull.butts else "its butts")) +
                  " (the region's boundary mapped onto the strip and developed)",
        "best_fit": trim.figures.get("best_fit"), "seams_extended": trim.figures.get("seams_extended"),
        "least_curvature": trim.figures.get("least_curvature"),
        "max_deviation": trim.deviation, "max_strain": 0.0, "area_3d_m2": area3 * (config.mm_per_unit / 1e3) ** 2,
        "complete": True, "other_family": other}
    finish_part(result, config)
    # the trim without its strip attempt (solution, development): the shop data need its rulings
    owe(result, config, trimmed_shop, grid, dataclasses.replace(trim, attempt=None, located=None))


def _deliver_patch(result, config, grid, uv_grid_flat, v3, f3, index, kind, info, strip, size, verdict=None,
                   check=None):
    """Pattern, strain map, completeness and class of a plate developed from its hull patch
    (its marks, heating lines and templates: :func:`.plateshop.patch_shop`, owed in a lean run).

    kind "flat" (planar projection) or "patch" (minimal-strain development, class formed):
    developable means devflat's strip fits, never a patch. A formed patch whose largest
    principal strain times the plate's largest dimension (how far an edge point of the flat
    plate, bent onto the hull without stretching, can land from its place) stays within the
    fit tolerance needs rolling only (no line heating): ``rolling_only`` says so."""
    hull = result.part.hull
    mm = config.mm_per_unit
    tol = hull.fit_tolerance
    shape = grid.shape
    v_grid = grid.points.reshape(-1, 3)
    f_grid = grid.faces()
    welded = index[f_grid]
    valid = (welded[:, 0] != welded[:, 1]) & (welded[:, 1] != welded[:, 2]) & (welded[:, 0] != welded[:, 2])
    scale = 1.0
    if kind == "patch" and config.spec.profile == "steel":  # the workshop method sizes the development
        uv_grid_flat, scale = _workshop_scaled(v_grid, uv_grid_flat, f_grid, valid, config.spec.shop.workshop_method)
    uv_grid = uv_grid_flat.reshape(shape[0], shape[1], 2)
    rot, shift = place_flat(uv_grid_flat, uv_grid[0])
    placed = uv_grid_flat @ rot.T + shift
    pg = placed.reshape(shape[0], shape[1], 2)
    outline = grid_ring(pg)
    keep = np.ones(len(outline), dtype=bool)
    keep[1:] = np.hypot(*np.diff(outline, axis=0).T) > 1e-9 * max(size)
    outline = outline[keep]
    strains = strain_map(v_grid, placed, f_grid, shape, (size[0] * mm, size[1] * mm), mm, valid)
    misfit = strains["max_abs_strain"] * max(size)
    if kind == "patch":
        kind = "formed"
        info = dict(info, misfit=misfit, rolling_only=bool(misfit <= tol),
                    rolling_only_rule="largest principal strain x largest plate dimension <= fit tolerance: bent "
                    "onto the hull without stretching, no edge point lands farther than the tolerance from its "
                    "place, so rolling alone forms it (no line heating); no developable strip fits it")
    region_faces, region_outline = f_grid, outline
    cut = None if hull.trim is None else cut_at_trim(hull.trim, grid.params, placed, f_grid)
    if cut is not None:  # the plate reaches past its face's trim: the shop cuts the part inside it
        if not len(cut.outline):
            result.reason = "plate region wholly outside its face's trim"
            result.figures["plate_class"] = {"class": "failed"}
            return
        outline, f_grid = cut.outline, f_grid[cut.inside_faces]
    # (a lean evaluation's, when it owed the development: the same figures)
    if kind == "flat":
        check = _flat_completeness(grid, v_grid, info, tol)
    else:
        check = completeness(v3, f3, grid, tol, _patch_corner_tolerance(hull, size)) if check is None else dict(check)
    result.strip = None
    result.mesh = (v_grid, f_grid)
    result.pattern = Pattern(outline, np.zeros((0, 2, 2)), placed, (rot, shift))
    result.figures["strain"] = strains
    result.figures["completeness"] = check
    area3 = float(result.figures["region"]["area_m2"])
    result.figures["plate_class"] = dict(
        {"class": kind, "max_deviation": info.get("plane_max_distance", 0.0), "max_strain": strains["max_abs_strain"],
         "area_3d_m2": area3, "complete": check["passed"]}, **info)
    if kind != "flat" and hull.follow:
        off = hull.follow["largest_distance_mm"] / mm
        result.figures["hull_fit"] = {"max_distance": off, "tolerance": tol, "passed": bool(off <= tol * (1 + 1e-9)),
                                      "note": "developed from the hull patch formed to meet its flat and strip "
                                              "neighbours' edges (strake.fit_up: follow): its 3D shape is the hull's "
                                              "moved, max_distance from it at most (its grid measured); its error is "
                                              "the in-plane strain"}
        result.figures["follow"] = {"neighbours": list(hull.follow["neighbours"]),
                                    "largest_move_mm": hull.follow["largest_move_mm"]}
    elif kind != "flat":
        result.figures["hull_fit"] = {"max_distance": 0.0, "tolerance": tol, "passed": True,
                                      "note": "developed from the hull patch itself: its 3D shape is the hull's; its "
                                              "error is the in-plane strain (see strain)"}
    geometry = PatchGeometry(kind, strip, v3, f3, index, uv_grid_flat, region_faces, region_outline, cut, info, scale,
                             bool(check["passed"]), verdict)
    if not check["passed"]:
        result.reason = _incomplete(check)
        owe(result, config, patch_shop, grid, geometry)  # its marks still go into its report
        return
    finish_part(result, config)
    if cut is not None:
        _cut_figures(result, cut, placed, grid, config)
    owe(result, config, patch_shop, grid, geometry)


def _workshop_scaled(v_grid, uv_flat, faces, valid, method: str):
    """The patch development sized by the workshop method (:func:`pipeline.shop.heating.method_scale`:
    contraction larger, every strain >= 0; expansion smaller, every strain <= 0; none as it
    is), about its centroid; returns (uv, scale)."""
    from ..shop.heating import method_scale, principal_strains

    strains = principal_strains(v_grid, uv_flat, faces[valid])
    scale = method_scale(strains.strain, strains.valid, method)
    if scale == 1.0:
        return uv_flat, 1.0
    centre = uv_flat.mean(axis=0)
    return centre + scale * (uv_flat - centre), scale


def _cut_figures(result, cut, placed, grid, config) -> None:
    """Area and steel figures of a plate cut at its trim: the cut outline's (the mesh keeps
    its whole triangles inside the trim, the outline cuts through them)."""
    mm = config.mm_per_unit
    area_m2 = polygon_area(cut.outline) * (mm / 1e3) ** 2
    whole = polygon_area(grid_ring(placed.reshape(*grid.shape, 2))) * (mm / 1e3) ** 2
    result.figures["trim_cut"] = {"area_m2": area_m2, "region_area_m2": whole, "share": area_m2 / whole if whole else 0.0,
                                  "outline_vertices": len(cut.outline),
                                  "method": "the region cut by the face's trim in (u, v), mapped to the development "
                                            "through the grid (piecewise linear)"}
    result.figures["area_m2"] = area_m2
    steel = result.figures.get("steel")
    if steel is not None:
        outline = np.vstack([cut.outline, cut.outline[:1]])
        steel.update(area_m2=area_m2, weight_kg=area_m2 * steel["thickness_mm"] / 1000.0 * steel["density_kg_m3"],
                     outline_length=float(np.linalg.norm(np.diff(outline, axis=0), axis=1).sum()))
