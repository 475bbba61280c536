"""Trimming stage of a developable hull plate: the strip between its seams, cut by its butts.

Each plate's strip is computed on its two seams extended past the butts and trimmed by
the butt planes: a ruling meets a plane in one point, so the trim line is exact at every
ruling and lies on the strip; plates on either side of a butt share its end points on the
seams. Also the fit of each plate to the design surface, judged on the cut strip in 3D
before it is developed (:func:`cut_at_butts`), and its frame lines.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from flatten import NurbsCurve
from flatten.closest import SurfaceDistance
from flatten.plane import Plane, plane_crossings
from flatten.surface import NurbsSurface

from .region import HullPlate

if TYPE_CHECKING:
    from flatten.strip import Strip


# ------------------------------------------------------------ trimming
def _polished_t(field_, t: float, T: float, bounds: tuple, steps: int = 8) -> float:
    """t of the ruling at T polished by Newton on f(., T) = 0 from the path's t. Newton may
    end beyond the traced path, even a little beyond c's end (a corner the path stops short
    of: its root there is a ruling of the same strip, which the trim needs and cuts at the
    butt; three DTMB 5415 plates are complete only so); where it leaves ``bounds`` (f nearly
    flat in t: two seams in one plane) or does not settle, the path's t stands (a step once
    reached t = 3.6e11 and NaN curve points on the 160 m hull's keel plate)."""
    if field_ is None:  # a flat pair: T(t) is the path's correspondence
        return t
    lo, hi = bounds
    x = t
    for _ in range(steps):
        ft = field_(x, T, 1, 0)[0]
        if ft == 0 or not np.isfinite(ft):
            break
        x -= field_(x, T)[0] / ft
        if not lo <= x <= hi:
            return t
    return x if abs(field_(x, T)[0]) <= abs(field_(t, T)[0]) else t


def corner_rulings(solution, c: NurbsCurve, d: NurbsCurve, planes, per_zone: int = 32) -> np.ndarray:
    """Rulings through the four plate corners (where the butt planes cross the seams), and
    ``per_zone`` more between the two corners of each butt, where the butt line crosses
    the rulings: the trim is then sampled finely whatever the ruling spacing elsewhere."""
    path = solution.path.points
    field_ = solution.field
    order = np.argsort(path[:, 1])

    def T_of(t):
        guess = np.interp(t, path[:, 0], path[:, 1])
        if field_ is None:  # a flat pair (coplanar seams): T(t) is the path's correspondence
            return np.atleast_1d(guess)
        return field_.refine_T(np.atleast_1d(t), np.atleast_1d(guess), 8)

    extra = []
    for plane in planes:
        corners_t = []
        for t in plane_crossings(c, plane):
            if path[0, 0] <= t <= path[-1, 0]:
                corners_t.append(t)
        for T in plane_crossings(d, plane):
            if path[order[0], 1] <= T <= path[order[-1], 1]:
                lo, hi = c.domain  # a ruling past c's end reads c's last span extended: within a domain's width
                t = _polished_t(field_, float(np.interp(T, path[order, 1], path[order, 0])), T,
                                (lo - (hi - lo), hi + (hi - lo)))
                extra.append((t, T))
                corners_t.append(t)
        # the zone's rulings in one batch: T_of is pointwise (a Newton per t)
        ts = np.array(corners_t[:1] if len(corners_t) < 2 else np.linspace(min(corners_t), max(corners_t), per_zone),
                      dtype=np.float64)
        if len(ts):
            extra.extend(zip(ts.tolist(), T_of(ts).tolist()))
    return np.array(extra).reshape(-1, 2)


def trim_intervals(ends_c: np.ndarray, ends_d: np.ndarray, planes: tuple[Plane, Plane]) -> np.ndarray:
    """Per ruling, the interval of v in [0, 1] between the two butt planes (on the positive
    side of the first, the negative side of the second), (K, 2); NaN rows for rulings
    wholly outside."""
    lo = np.zeros(len(ends_c))
    hi = np.ones(len(ends_c))
    # a ruling lying in a butt plane (a cylinder cut along its generators) has s = 0 at both
    # ends up to round-off: it is on the plane, not outside it
    eps = 1e-9 * max(float(np.ptp(np.vstack([ends_c, ends_d]), axis=0).max()), 1e-300)
    for plane, sign in zip(planes, (1.0, -1.0)):
        sa, sb = sign * plane.signed(ends_c), sign * plane.signed(ends_d)
        ds = sb - sa
        parallel = np.abs(ds) <= eps
        with np.errstate(divide="ignore", invalid="ignore"):
            cut = -sa / ds  # where sign * s(v) = 0
        lo = np.where(~parallel & (ds > 0), np.maximum(lo, cut), lo)
        hi = np.where(~parallel & (ds < 0), np.minimum(hi, cut), hi)
        hi = np.where(parallel & (np.maximum(sa, sb) < -eps), -1.0, hi)
    # a ruling through a corner touches the region in one point (lo == hi to round-off):
    # keep it, or the outline misses the corner by the distance to the next ruling
    touching = hi >= lo - 1e-12
    lo, hi = np.clip(lo, 0.0, 1.0), np.clip(hi, 0.0, 1.0)
    out = np.column_stack([lo, np.maximum(lo, hi)])
    out[~touching] = np.nan
    return out


def surface_distance(surface: NurbsSurface, points: np.ndarray, grid: int = 120) -> np.ndarray:
    """Distance of each point (N, 3) to the surface (builds the search structure each call:
    plates of one hull share a :class:`flatten.closest.SurfaceDistance` instead)."""
    return SurfaceDistance(surface, grid)(points)


@dataclass(frozen=True)
class ButtCut:
    """A strip cut by a plate's butt planes in 3D, before it is developed: which rulings
    cross the region (``keep`` (K,) of the strip's), each one's v interval between the
    planes (``lo``, ``hi`` (R,)), the cut strip and its fit to the hull (the ``hull_fit``
    figures of its vertices' distances; ``passed``: within the tolerance)."""

    keep: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    strip: Strip
    hull_fit: dict


def cut_at_butts(result) -> ButtCut | None:
    """The checked strip of ``result`` cut by its plate's butt planes and measured against the
    hull: all of the trim's verdict that needs no development, so that a strip off the hull
    is rejected before it is developed (most seam strips of a curved hull's candidates). None,
    with the reason, when fewer than two rulings reach across the butts; a cut off the hull
    is kept on the result as its strip, with its ``hull_fit`` figures and the reason (a cut
    that fits is reported by :func:`stage_trim`)."""
    from flatten.strip import Strip, grid_faces

    hull: HullPlate = result.part.hull
    strip = result.strip
    m = len(strip.samples)
    k = np.arange(strip.n_rulings) * m
    a3, b3 = strip.vertices[k], strip.vertices[k + m - 1]
    intervals = trim_intervals(a3, b3, hull.butts)
    keep = ~np.isnan(intervals[:, 0])
    if keep.sum() < 2:
        result.reason = (f"the strip does not reach across the butts {hull.butts[0].describe()} and "
                         f"{hull.butts[1].describe()}")
        return None
    lo, hi = intervals[keep, 0], intervals[keep, 1]
    v = lo[:, None] + (hi - lo)[:, None] * strip.samples[None, :]
    a3, b3 = a3[keep], b3[keep]
    vertices = (a3[:, None] + v[..., None] * (b3 - a3)[:, None]).reshape(-1, 3)
    cut = Strip(strip.rulings[keep], strip.samples, vertices, grid_faces(int(keep.sum()), m),
                strip.max_chord_error, np.column_stack([lo, hi]))
    distance = (hull.distance or SurfaceDistance(hull.surface))(vertices)
    worst = int(np.argmax(distance))
    fit = {"max_distance": float(distance.max()), "rms_distance": float(np.sqrt(np.mean(distance**2))),
           "worst_point": vertices[worst].tolist(), "tolerance": hull.fit_tolerance,
           "passed": bool(distance.max() <= hull.fit_tolerance)}
    if not fit["passed"]:
        result.strip = cut
        result.figures["hull_fit"] = fit
        result.reason = (f"plate deviates from the hull by {distance.max():.4g} (tolerance "
                         f"{hull.fit_tolerance:g}) at {np.round(vertices[worst], 3).tolist()}")
    return ButtCut(keep, lo, hi, cut, fit)


def screen_at_butts(result, cuts: list) -> bool:
    """A screen for :func:`pipeline.stages.develop_part`: :func:`cut_at_butts`, appended to
    ``cuts`` for :func:`stage_trim`; False when the strip misses the butts or the hull."""
    cut = cut_at_butts(result)
    cuts.append(cut)
    return cut is not None and cut.hull_fit["passed"]


def stage_trim(result, cut: ButtCut, min_coverage: float = 0.0) -> bool:
    """The developed strip cut out by the butt planes (``cut``: :func:`cut_at_butts` of it, on
    the hull within the tolerance) laid flat, with its frame lines and edge labels; False
    (with the reason) when it covers less than ``min_coverage`` of its seams between the butts."""
    from ..shop.marks import edge_labels, frame_polylines
    from ..stages import Pattern, place_flat

    hull: HullPlate = result.part.hull
    dev, keep, lo, hi = result.development, cut.keep, cut.lo, cut.hi
    m = len(result.strip.samples)
    v = lo[:, None] + (hi - lo)[:, None] * result.strip.samples[None, :]
    a2, b2 = dev.along_c[keep], dev.along_d[keep]
    flat = (a2[:, None] + v[..., None] * (b2 - a2)[:, None]).reshape(-1, 2)
    rot, shift = place_flat(flat, flat.reshape(-1, m, 2)[:, 0])
    placed = flat @ rot.T + shift
    grid = placed.reshape(-1, m, 2)
    lower, upper = grid[:, 0], grid[:, -1]
    outline = np.vstack([lower, upper[::-1]])
    frame_lines = [(x, pts @ rot.T + shift) for x, pts in frame_polylines(result, hull.frames, lo, hi, keep)]
    labels = edge_labels(hull, lower, upper, cut.strip.vertices.reshape(-1, m, 3))
    # how much of each seam between the butts the plate covers (the extended seams' own
    # coverage is partial by design)
    path = result.solution.path.points
    covered = {}
    for key, curve, column in (("c", result.part.c, 0), ("d", result.part.d, 1)):
        ends = np.sort([plane_crossings(curve, plane)[0] for plane in hull.butts])
        lo_t, hi_t = np.sort(path[[0, -1], column])
        span = curve.arc_length_at(ends)
        inside = curve.arc_length_at(np.clip(ends, lo_t, hi_t))
        covered[key] = float((inside[1] - inside[0]) / (span[1] - span[0]))
    result.figures["plate_coverage"] = covered
    result.warnings = [w for w in result.warnings if not w.startswith("partial coverage")]
    if min(covered.values()) < min_coverage:
        result.reason = (f"plate incomplete: the strip covers {100 * covered['c']:.1f}% and {100 * covered['d']:.1f}% "
                         f"of its seams between the butts (min_coverage {min_coverage:g}); increase strake.margin")
        return False
    if min(covered.values()) < 1.0 - 1e-9:
        result.warnings.append(f"plate incomplete: the strip covers {100 * covered['c']:.2f}% of seam "
                               f"{hull.seam_names[0]} and {100 * covered['d']:.2f}% of {hull.seam_names[1]} "
                               "between the butts; increase strake.margin")
    result.strip = cut.strip
    result.pattern = Pattern(outline, np.stack([lower, upper], axis=1), placed, (rot, shift),
                             tuple(frame_lines), tuple(labels))
    result.figures["hull_fit"] = cut.hull_fit
    result.figures["trim"] = {"butt_planes": [{"normal": list(p.normal), "offset": p.offset} for p in hull.butts],
                              "rulings_kept": int(keep.sum()),
                              "frames": [x for x, _ in frame_lines]}
    return True
