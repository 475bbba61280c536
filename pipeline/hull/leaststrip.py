"""The strip of a hull plate whose rulings follow the hull's least curvature across the region.

A developable surface's rulings are its directions of zero normal curvature, so the strip
that fits a hull patch best has its rulings along the patch's direction of least curvature.
The seam family (rulings seam to seam) and the butt family (butt to butt) fix the strip's
two boundary curves on the plate's edges, and so the rulings' general direction: across
the plate or along it. Where the hull's least-curvature lines run obliquely across a plate
(the bilge's run aft and entrance forward, where the midbody's longitudinal generators
turn toward the keel and the stem), or the hull's rulings fan out from a point, neither
pair of edges carries a developable strip that stays on the hull: the seams' strip may
not exist at all (f(t, T) keeps one sign: only cones join them) and the butt sections'
leans off the hull by the sagitta of a chord it was never meant to span.

Here the two boundary curves are chosen for the rulings instead: on the region's chart
(x along the plate, y across it, both arc lengths on the hull), the mean least-curvature
direction r is the weighted circular mean of the directions at a grid of the region's
points (doubled angles: a direction has no sign; weights |kappa_2| - |kappa_1|, so that
points where the hull bends alike every way, and say nothing of a direction, count for
little). The curves are the hull's lines through the chart's lines perpendicular to r,
just beyond the region on either side (by DELTA of its extent along r), each spanning the
region's whole extent across r and EXTEND of it more at either end (for a long plate with
oblique rulings they reach well past its seams: 3 m beside a 1.8 m wide plate at 11
degrees), mapped from the chart to the surface's parameters by the grid (linear,
extrapolated beyond it) and fitted by cubic B-splines. devflat solves the
strip between them (every branch judged as for any pair of curves); the region is mapped
onto it and judged like the other families' trimmed strips (:mod:`.platestrip`).

A solve costs about a tenth of a second, so a region is tried only where straight rulings in
that direction could fit: the hull's normal curvature along r times the squared chord across
the chart through each sampled point, over 16 (the sagitta, halved by a best fit), stays
within GATE tolerances everywhere (:func:`ruling_misfit`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flatten.patch import PatchGrid, grid_frame, principal_curvatures

from ..config import Part, RunConfig
from ..io.sources import SourceError, fit_points
from .platestrip import Trim, _solved_and_trimmed

LEAST_CURVATURE = "rulings along the least curvature"
DELTA = 0.03  # the curves stand this fraction of the region's extent along the rulings beyond it
EXTEND = 0.15  # and reach this fraction of its extent across the rulings past it at either end
CURVE_POINTS = 61  # hull points per boundary curve, fitted by a cubic B-spline
SAMPLE = (9, 17)  # rows x columns of the region's grid where the hull's curvature is read
# tolerances: a region whose estimated misfit (ruling_misfit) exceeds this is not tried; on
# 133 formed candidates of the 160 m hull every strip of this family that fitted (13, best
# fits included) had an estimate under 0.9, none of the 83 over 1 fitted
GATE = 1.0
# best-fit rounds of this family's strip: on the 160 m hull all 13 that fitted did so in their
# first round; the 21 that did not spent 6 of their 7 CPU s in the second and third
LEAST_ROUNDS = 1
CURVE_FIT = 0.02  # the boundary curves' fit tolerance, a fraction of the plate's fit tolerance


def chart(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The region grid's chart (model units): x (C,) the mean arc length along the rows from
    the first column, y (R,) the mean arc length across the columns from the first row."""
    along = np.concatenate([np.zeros(points.shape[:1] + (1,)),
                            np.cumsum(np.linalg.norm(np.diff(points, axis=1), axis=2), axis=1)], axis=1)
    across = np.concatenate([np.zeros((1,) + points.shape[1:2]),
                             np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=2), axis=0)], axis=0)
    return along.mean(axis=0), across.mean(axis=1)


@dataclass(frozen=True)
class CurvatureSample:
    """The hull's curvature at a sub-grid of a region (N points): chart coordinates xy (N, 2)
    and the chart's extent (x_max, y_max) (model units), principal curvatures kappa (N, 2)
    (|kappa_1| <= |kappa_2|, 1 / model units) and the angle (N,) of kappa_1's direction to the
    chart's x axis (radians)."""

    xy: np.ndarray
    extent: tuple
    kappa: np.ndarray
    angle: np.ndarray


def curvature_sample(surface, grid: PatchGrid, sample: tuple = SAMPLE) -> CurvatureSample:
    """The curvature at ``sample`` rows x columns of the region's grid."""
    p, params = grid.points, grid.params
    rows = np.unique(np.linspace(0, p.shape[0] - 1, sample[0]).round().astype(int))
    cols = np.unique(np.linspace(0, p.shape[1] - 1, sample[1]).round().astype(int))
    at = params[np.ix_(rows, cols)].reshape(-1, 2)
    kappa, least = principal_curvatures(surface, at[:, 0], at[:, 1])
    t_x, t_y = (t[np.ix_(rows, cols)].reshape(-1, 3) for t in grid_frame(p))
    x, y = chart(p)
    xy = np.stack(np.meshgrid(x[cols], y[rows]), axis=-1).reshape(-1, 2)
    angle = np.arctan2(np.sum(least * t_y, axis=1), np.sum(least * t_x, axis=1))
    return CurvatureSample(xy, (float(x[-1]), float(y[-1])), kappa, angle)


def mean_direction(sample: CurvatureSample) -> tuple[float, float]:
    """The region's mean direction of least curvature on its chart: (angle to the x axis in
    radians, in (-pi/2, pi/2]; coherence in [0, 1], 1 where every sampled point agrees)."""
    weight = np.abs(sample.kappa[:, 1]) - np.abs(sample.kappa[:, 0])
    good = np.isfinite(weight) & np.isfinite(sample.angle)
    weight, angle = weight[good], sample.angle[good]
    if weight.sum() <= 0.0:  # a plane or a sphere: no direction is preferred
        return 0.0, 0.0
    s, c = float(weight @ np.sin(2.0 * angle)), float(weight @ np.cos(2.0 * angle))
    return 0.5 * float(np.arctan2(s, c)), float(np.hypot(s, c) / weight.sum())


def ruling_misfit(sample: CurvatureSample, angle: float) -> float:
    """Estimated misfit (model units) of a best-fit strip whose rulings run straight along
    ``angle`` on the chart: at each sampled point the hull's normal curvature in that
    direction (Euler: kappa_1 cos^2 + kappa_2 sin^2 of the angle to kappa_1's direction)
    times the square of the chord through the point in that direction across the chart's
    rectangle, over 16 (the chord's sagitta, halved by the best fit); the largest."""
    turn = sample.angle - angle
    normal = sample.kappa[:, 0] * np.cos(turn) ** 2 + sample.kappa[:, 1] * np.sin(turn) ** 2
    direction = np.array([np.cos(angle), np.sin(angle)])
    enter = np.full(len(sample.xy), -np.inf)
    leave = np.full(len(sample.xy), np.inf)
    for k in range(2):  # the chord's parameter range inside [0, extent] along each axis
        if abs(direction[k]) > 1e-12:
            ends = np.sort(np.stack([-sample.xy[:, k], sample.extent[k] - sample.xy[:, k]]) / direction[k], axis=0)
            enter, leave = np.maximum(enter, ends[0]), np.minimum(leave, ends[1])
    chord = np.maximum(leave - enter, 0.0)
    misfit = np.abs(normal) * chord ** 2 / 16.0
    return float(np.max(np.where(np.isfinite(misfit), misfit, np.inf)))  # unknown curvature: not tried


def boundary_params(grid: PatchGrid, angle: float, delta: float = DELTA, extend: float = EXTEND,
                    n: int = CURVE_POINTS) -> np.ndarray:
    """Surface parameters (2, n, 2) of the two boundary curves on the chart's lines
    perpendicular to the rulings' direction ``angle``, beyond the region by ``delta`` of its
    extent along the rulings and past it by ``extend`` of its extent across them; both run
    the same way. Extrapolated linearly beyond the grid: they may leave the surface's domain."""
    from scipy.interpolate import RegularGridInterpolator

    x, y = chart(grid.points)
    ruling = np.array([np.cos(angle), np.sin(angle)])
    across = np.array([-ruling[1], ruling[0]])
    chart_points = np.stack(np.meshgrid(x, y), axis=-1).reshape(-1, 2)
    along_r, along_a = chart_points @ ruling, chart_points @ across
    lo, hi = float(along_r.min()), float(along_r.max())
    a0, a1 = float(along_a.min()), float(along_a.max())
    offsets = (lo - delta * (hi - lo), hi + delta * (hi - lo))
    t = np.linspace(a0 - extend * (a1 - a0), a1 + extend * (a1 - a0), n)
    to_params = RegularGridInterpolator((y, x), grid.params, bounds_error=False, fill_value=None)
    out = np.empty((2, n, 2))
    for k, offset in enumerate(offsets):
        line = offset * ruling[None, :] + t[:, None] * across[None, :]
        out[k] = to_params(line[:, ::-1])
    return out


def least_curvature_family(part: Part, config: RunConfig, grid: PatchGrid, corner_tolerance: float) -> Trim:
    """The strip between two hull curves across the region's mean least-curvature direction
    (:func:`boundary_params`), trimmed by the region; its figures say the direction."""
    hull = part.hull
    surface = hull.surface
    out = Trim(LEAST_CURVATURE)
    sample = curvature_sample(surface, grid)
    angle, coherence = mean_direction(sample)
    if coherence <= 0.0:
        out.reason = "not tried: the region has no direction of least curvature (it bends alike every way)"
        return out
    misfit = ruling_misfit(sample, angle)
    if misfit > GATE * hull.fit_tolerance:
        out.reason = (f"not tried: straight rulings at {np.degrees(angle):.0f} deg to the plate's length would "
                      f"miss the hull by about {misfit:.3g} (the sagitta estimate, over the tolerance)")
        return out
    params = boundary_params(grid, angle, DELTA, EXTEND)
    domain = np.array([surface.domain_u, surface.domain_v])
    beyond = np.maximum(domain[:, 0] - params, params - domain[:, 1]).max(axis=(0, 1)) / np.ptp(domain, axis=1)
    if beyond.max() > 1e-9:
        # measured: of 47 such regions of the 160 m hull (at the keel, the deck edge, the
        # ends), none had a strip within three tolerances between curves clipped to the surface
        out.reason = (f"not tried: the curves across the least curvature would leave the surface by "
                      f"{beyond.max():.2g} of its parameter range (the region reaches its edge)")
        return out
    curves = []
    try:
        for k in range(2):
            points = surface(params[k, :, 0], params[k, :, 1])
            if np.linalg.norm(np.diff(points, axis=0), axis=1).sum() <= 0.0:
                raise SourceError("a boundary curve collapses to a point at the surface's edge")
            curves.append(fit_points(points, CURVE_FIT * hull.fit_tolerance, f"{part.name}.least{k + 1}")[0])
    except SourceError as exc:
        out.reason = f"no boundary curves across the least curvature: {exc}"
        return out
    figures = {"least_curvature": {"angle_deg": float(np.degrees(angle)), "coherence": coherence,
                                   "estimated_misfit": misfit,
                                   "method": "boundary curves on the region's chart lines perpendicular to its mean "
                                             "least-curvature direction, beyond it by "
                                             f"{DELTA:g} of its extent along that direction and past it by "
                                             f"{EXTEND:g} of its extent across it"}}
    return _solved_and_trimmed(part, curves[0], curves[1], config, grid, LEAST_CURVATURE, corner_tolerance, figures)
