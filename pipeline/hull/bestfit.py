"""Best-fit strips: a hull plate's strip moved off the hull so that the hull lies on both sides.

A strip through curves on the hull (the seams, the butt sections) meets the hull along them
and leaves it in between: along a ruling of length l over a hull that bends by kappa in the
ruling's direction, the gap grows to the sagitta kappa l^2 / 8 at the middle and is nil at
the ends. No rule asks the plate's edges to lie on the hull; the fit tolerance bounds every
point alike. Moving each ruling's two ends off the hull along the strip's normal, by the
line (in v, along the ruling) that best matches the hull's signed gaps there and by half the
gaps' remaining spread, centres the ruling in the band the hull occupies: a sagitta s is
then met within s / 2, and a ruling that the hull tilts away from is turned with it. The
strip is moved by the least share of that which brings the hull within LEAST_FIT of the
tolerance: its edges, where it meets its neighbours, stay as near the hull as the tolerance
lets them (centred, two neighbours of unequal sagittas step by half their difference).

The moved ends, taken on evenly spread rulings of the solved path, are fitted by cubic
B-splines (the new boundary curves), the strip between them is solved again by devflat and
trimmed by the plate's region as before; a few rounds settle it (each round's rulings differ
a little from the last). The result is judged like any trimmed strip: every point of the
region mapped onto the strip within the tolerance, the strip within it of the hull. Its
corners are then off the hull by the same gap as the rest (at most the tolerance), and are
judged by the fit tolerance: the cut outline is the region's boundary mapped onto the strip
by closest points, corners included, so it holds them whenever they map within it.

A second remedy lives here too: a seam strip whose rulings lean (a near-flat side plate,
where they pair points a metre apart along the two seams) reaches past one butt and stops
short of the other; solved between the seams extended far past both butts and trimmed by
the region, it covers the plate.
"""

from __future__ import annotations

import numpy as np

from flatten.trim import StripMap

from ..config import Part, RunConfig
from .region import extended_segment, seam_curve
from .platestrip import (BOUNDARY_MM, BUTT_TO_BUTT, HOPELESS, MAP_RULINGS, SEAM_TO_SEAM, Trim, butt_family,
                         _solved_and_trimmed, _strip_normals, region_boundary)
from ..io.sources import SourceError

ROUNDS = 3  # re-solves of a best-fit strip at most
WORTH = HOPELESS  # a strip further off than this many tolerances is not worth moving
BINS = 20  # ruling bins (path fraction) for the per-ruling gap line
DEGREE = 3  # of the polynomial in path fraction that smooths the offsets
CURVE_POINTS = 81  # moved ends per boundary curve, fitted by a cubic B-spline
MOVED_FIT = 0.02  # the moved curves' fit tolerance, a fraction of the fit tolerance (smooths them)
WIDE = 0.4  # a best-fit butt strip's sections reach this fraction of the girth beyond each seam
LEAST_FIT = 0.85  # a best-fit strip is moved until the hull lies within this share of the tolerance
SHARES = np.linspace(0.0, 1.0, 21)[1:]  # the shares of the centring offsets tried, least first
FAR = 0.5  # seams extended past each butt by this fraction of the plate length
# a round whose rulings, each centred in the hull's gaps around it, still leave the hull
# further off than this many tolerances is not solved: the strip solved on them would miss.
# Logged on the 160 m hull's and DTMB 5415's yard plans (300 best fits, 135 fitting): no best
# fit fitted from a round leaving more than 1.27 tolerances; the best fits whose first round
# left more than this took 20 of the 72 CPU s of all 300 (the part before the stop stays)
CENTRED_LIMIT = 1.5


def seam_family_far(part: Part, config: RunConfig, grid, corner_tolerance: float) -> Trim:
    """The strip between the plate's seams extended past both butts by FAR of its length,
    trimmed by the region (the rulings may lean: the region decides where the plate ends)."""
    hull = part.hull
    out = Trim(SEAM_TO_SEAM)
    try:
        c, d = (extended_segment(seam_curve(hull.surface, hull.long_axis, g, f"{part.name}.{n}"), hull.butts, FAR,
                                 f"{part.name}.{n}") for g, n in zip(hull.girths, hull.seam_names))
    except SourceError as exc:
        out.reason = f"seams extended past the butts: {exc}"
        return out
    trim = _solved_and_trimmed(part, c, d, config, grid, SEAM_TO_SEAM, corner_tolerance,
                               {"seams_extended": f"{FAR:g} of the plate length past each butt"})
    if not trim.ok and trim.reason:
        trim.reason = f"seams extended past the butts: {trim.reason}"
    return trim


def region_points(part: Part, grid, mm_per_unit: float) -> np.ndarray:
    """The plate's region as points (N, 3): its patch grid and its boundary about
    BOUNDARY_MM apart (the points a trim is judged on)."""
    boundary, _ = region_boundary(part, grid, BOUNDARY_MM / mm_per_unit)
    return np.vstack([grid.points.reshape(-1, 3), boundary])


def signed_gaps(trim: Trim, points: np.ndarray):
    """(strip map, lam, v, gap) of points (N, 3) of the region against the trim's strip:
    path fraction and position along the ruling of each point's closest strip point, and
    the signed distance along the strip's normal there (model units)."""
    attempt = trim.attempt
    c, d = attempt.part.c, attempt.part.d
    if trim.located is not None and np.array_equal(trim.located[0], points):
        # the trim mapped these very points: the same map, the same closest points
        _, smap, mapped = trim.located
        lam, v, rulings, on_strip = mapped.lam, mapped.v, mapped.rulings, mapped.on_strip
    else:
        smap = StripMap(attempt.solution, c, d, MAP_RULINGS)
        lam, v, rulings, on_strip = smap.locate(points)
    normals = _strip_normals(c, d, rulings)
    return smap, lam, v, np.einsum("ij,ij->i", points - on_strip, normals)


def end_offsets(lam: np.ndarray, v: np.ndarray, gap: np.ndarray, at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (K,) x 2 of the two ends of the rulings at path fractions ``at`` (K,), along
    the strip's normal, that centre each ruling in the hull's gaps around it.

    Per bin of path fraction: the least-squares line gap ~ a + b v, then a shifted by the
    midrange of the residuals (so the largest gaps either side are equal); end offsets
    a and a + b, or a alone where the bin's points span less than half the ruling. A bin
    holding only points near the rulings' ends (the region's edges across them) is skipped. The bins'
    offsets are smoothed by a cubic in lam (least squares, weighted by the points per bin)."""
    edges = np.linspace(0.0, 1.0, BINS + 1)
    which = np.clip(np.searchsorted(edges, lam, side="right") - 1, 0, BINS - 1)
    centres, near, far, weight = [], [], [], []
    for k in range(BINS):
        m = which == k
        if m.sum() < 3:
            continue
        vk, gk = v[m], gap[m]
        if np.ptp(vk) >= 0.5 and not np.any((vk > 0.25) & (vk < 0.75)):
            continue  # only the region's edges across the rulings: no word on the middle
        if np.ptp(vk) >= 0.5:
            b, a = np.polyfit(vk, gk, 1)
        else:
            b, a = 0.0, 0.0
        residual = gk - (a + b * vk)
        a += 0.5 * (residual.max() + residual.min())
        centres.append(float(np.mean(lam[m])))
        near.append(a)
        far.append(a + b)
        weight.append(float(m.sum()))
    if not centres:
        return np.zeros_like(at), np.zeros_like(at)
    centres, weight = np.array(centres), np.sqrt(np.array(weight))
    degree = min(DEGREE, len(centres) - 1)
    out = []
    for values in (np.array(near), np.array(far)):
        coef = np.polyfit(centres, values, degree, w=weight)
        # outside the bins with points the offsets are held, not extrapolated
        out.append(np.polyval(coef, np.clip(at, centres.min(), centres.max())))
    return out[0], out[1]


def least_share(gap: np.ndarray, offset: np.ndarray, target: float) -> float:
    """The least share of the centring offsets ``offset`` (N,) at the points (:func:`end_offsets`
    at their rulings, blended along them), a twentieth at a time, that brings every signed gap
    (N,) within ``target`` (model units); 1 when none does.

    Centring meets a sagitta s within s / 2 but stands the strip's edges off the hull by
    s / 2 too; the neighbours' edges are off by their own half sagittas, and the difference
    is a step at the weld. Moved only as far as the tolerance asks (s - target at the ends of a
    bowed ruling), the strip keeps its edges nearer the hull and its rulings nearer those
    it had."""
    for share in SHARES:
        if np.abs(gap - share * offset).max() <= target:
            return float(share)
    return 1.0


def moved_curve(curve, params: np.ndarray, offsets: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Points (CURVE_POINTS + extra, 3) of the whole curve moved by the offsets along the
    normals given at the rulings' parameters on it (held beyond the first and last ruling):
    the moved curve keeps the original's reach, so the strip solved on it can cover as much."""
    order = np.argsort(params)
    p, off, nrm = params[order], offsets[order], normals[order]
    t = np.linspace(*curve.domain, 2 * CURVE_POINTS)
    # smooth normals (a cubic in the parameter): kinks in the moved curve would show in its
    # derivatives, which the developability equation reads
    scale = max(float(np.ptp(p)), 1e-300)
    n = np.column_stack([np.polyval(np.polyfit((p - p[0]) / scale, nrm[:, k], min(3, len(p) - 1)),
                                    (np.clip(t, p[0], p[-1]) - p[0]) / scale) for k in range(3)])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    return curve(t) + np.interp(t, p, off)[:, None] * n


def best_fit(trim: Trim, part: Part, config: RunConfig, grid, rounds: int = ROUNDS) -> Trim:
    """The trim's strip moved off the hull to fit it best, re-solved up to ``rounds`` times;
    the best trim found (the input when no round does better)."""
    from ..io.sources import fit_points

    tol = part.hull.fit_tolerance
    best = trim
    current = trim
    if trim.family == BUTT_TO_BUTT:
        # sections reaching well past the seams: the moved strip's rulings near its ends
        # shift more than those in the middle, and the region must stay clear of them
        wide = butt_family(part, config, grid, tol, WIDE)
        if wide.deviation is not None and wide.attempt is not None and wide.attempt.solution:
            current = wide
            if wide.ok:
                return wide
    moved, shares, stopped = 0.0, [], ""
    points = region_points(part, grid, config.mm_per_unit)  # the same for every round
    for round_ in range(rounds):
        if current.attempt is None or current.attempt.solution is None or not current.attempt.solution:
            break
        smap, lam, v, gap = signed_gaps(current, points)
        at = np.linspace(0.0, 1.0, CURVE_POINTS)
        # the offsets at the moved curves' rulings and at the region's points, from one fit
        near, far = end_offsets(lam, v, gap, np.concatenate([at, lam]))
        at_points = near[len(at):] * (1.0 - v) + far[len(at):] * v
        centred = float(np.abs(gap - at_points).max())
        if centred > CENTRED_LIMIT * tol:
            stopped = (f"centring its rulings in the hull's gaps leaves the hull {centred:.4g} off (over "
                       f"{CENTRED_LIMIT:g} tolerances), so no strip was solved on them")
            break
        if round_ and best.deviation is not None and centred >= best.deviation:
            # the moved strip's rulings, centred again, promise nothing nearer than the best
            # strip so far. Logged on the four hulls' yard plans (716 best fits), such rounds
            # (mostly butt strips', each within 1 % of the last) never made a strip fit and
            # brought one nearer once (KVLCC2, 1.128 to 1.125 tolerances); 6.3 of 100 CPU s
            break
        share = least_share(gap, at_points, LEAST_FIT * tol)
        near, far = share * near[:len(at)], share * far[:len(at)]
        rulings, _, _ = smap.ends(at)
        normals = _strip_normals(smap.c, smap.d, rulings)
        name = f"{part.name}.bestfit{round_ + 1}"
        try:
            c, _ = fit_points(moved_curve(smap.c, rulings[:, 0], near, normals), MOVED_FIT * tol, f"{name}.c")
            d, _ = fit_points(moved_curve(smap.d, rulings[:, 1], far, normals), MOVED_FIT * tol, f"{name}.d")
        except SourceError:
            break
        moved = max(moved, float(np.abs(np.concatenate([near, far])).max()))
        shares.append(share)
        # the corners now sit off the hull like every other point: judged by the fit tolerance
        # the family's own figures (the least-curvature strip's direction) stay with it
        kept = {key: trim.figures[key] for key in ("least_curvature",) if key in trim.figures}
        candidate = _solved_and_trimmed(part, c, d, config, grid, trim.family, tol, kept)
        if candidate.deviation is None:
            break
        candidate.figures["best_fit"] = {
            "rounds": round_ + 1, "largest_end_offset": moved, "shares_of_centring": list(shares),
            "method": "each ruling's ends moved along the strip's normal towards centring it in the hull's gaps "
                      "(least-squares line along the ruling, shifted by the residuals' midrange), by the least "
                      f"share of that (a twentieth at a time) that brings the hull within {LEAST_FIT:g} of the "
                      "tolerance; the moved ends fitted by cubic B-splines and the strip solved again between them",
            "deviation_before": trim.deviation}
        current = candidate
        if best.deviation is None or candidate.deviation < best.deviation or (candidate.ok and not best.ok):
            best = candidate
        if candidate.ok:
            break
    if best is not trim and not best.ok and best.reason:
        best.reason = f"best fit ({best.figures.get('best_fit', {}).get('rounds', 0)} rounds): {best.reason}"
    if stopped and not best.ok:
        best.reason = f"{best.reason}; best fit stopped: {stopped}" if best.reason else f"best fit stopped: {stopped}"
    return best


def worth_moving(trim: Trim, tolerance: float) -> bool:
    """A solved strip that misses the tolerance by less than WORTH times it."""
    return (not trim.ok and trim.deviation is not None and trim.attempt is not None
            and trim.attempt.solution is not None and tolerance < trim.deviation <= WORTH * tolerance)
