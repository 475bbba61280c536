"""A face faired into the face it overlaps, so that the two meet where a plan cuts them, or
onto the face it meets edge to edge with a gap, so that the two meet along their junction.

A hull file whose faces lie on each other over a stretch describes the shell twice there, and
the two descriptions need not agree: DTMB 5415's bow and main-hull faces run 9 mm apart
(median) over 3.9 m, up to 49 mm, and 27 mm at the transverse plane where they are closest.
Wherever a plan cuts them, the plates on either side of the cut step by that distance, which no
plate within a 5 mm fit tolerance can close. A loftsman fairs such a join: one face is moved
onto the other over the overlap, by nothing at the overlap's far end and by the whole distance
at the cut, so that the faces meet at the cut and the moved one stays fair.

:func:`fair_into` does that on the NURBS face. The move at a point is the way to its foot on the
other face (which runs along that face's normal), times a C2 ramp in x (``6 s^5 - 15 s^4 + 10 s^3``, zero
slope and curvature at both ends). The moved face is carried onto its own knots with the spans
over the ramp subdivided (exactly: its spline space lies inside the refined one), and the move
is fitted by least squares on the poles that act where something moves: beyond them (a knot
span past the ramp's start) the face is reproduced to round-off.
The result says how far the face moved, how well the refit follows the intended move and how
far the two faces still are apart at the cut.

:func:`fair_junctions` does the same where two untrimmed faces meet along a whole side of one
of them further apart than half the fit tolerance (DTMB 5415's main hull ends up to 15 mm off
its stern face at ship scale): the side goes to its closest points on the other face, and the
face behind it follows by the ramp in the distance behind the side (arc length along the
side's middle cross line), over RAMP_PER_GAP times the widest gap.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np
from scipy.interpolate import BSpline

from flatten.closest import SurfaceDistance, closest_with_sides
from flatten.surface import NurbsSurface, nurbs_surface

from .sewing import _box, interior, section_distances

SAMPLES_PER_SPAN = 4  # least-squares samples per refined knot span and direction
REFINE = 8  # a knot span the ramp touches is cut into this many
SECTION_LINES = 200  # points of the cut's section measured against the other face
REFIT_SHARE = 0.25  # of the fit tolerance: a refit that strays further from the intended move is not taken
JUNCTION_REACH = 10.0  # fit tolerances: a point of a face's side this near the other face lies on their junction
JUNCTION_GAP = 0.5  # of the fit tolerance: faces that meet further apart than this are faired
RAMP_PER_GAP = 200.0  # a junction's ramp runs this many times the widest gap it closes (a slope of 0.5 %)
SIDE_SAMPLES = 61  # points of a face's side measured against the other face
SIDES = ((0, 0), (0, 1), (1, 0), (1, 1))  # (parameter, end): the sides u = u0, u = u1, v = v0, v = v1


@dataclass(frozen=True)
class Fairing:
    """What fairing one face into another did, lengths in the surfaces' units."""

    face: int
    onto: int
    ramp_x: tuple[float, float]  # from where the move is nothing to the cut, where it is whole
    moved_max: float
    moved_median: float  # over the points that moved
    refit_error: float  # largest distance of the refitted face from the intended move, between the samples
    step_at_cut_before: float
    step_at_cut_after: float
    poles: tuple[int, int]  # of the refitted face
    taken: bool = True  # False: the face was left as the file gives it (``reason``)
    reason: str = ""
    kind: str = "overlap"  # "overlap": over the stretch two faces share, up to the cut; "junction": at a side

    def as_dict(self, mm_per_unit: float = 1.0) -> dict:
        """Lengths in mm; faces numbered from 1 as the plates' notes number them (1: the
        strake's surface, then the plan's surfaces in order)."""
        out = asdict(self)
        out["face"], out["onto"] = self.face + 1, self.onto + 1
        for key in ("moved_max", "moved_median", "refit_error", "step_at_cut_before", "step_at_cut_after"):
            out[f"{key}_mm"] = round(out.pop(key) * mm_per_unit, 4)
        out["ramp_x_mm"] = [round(x * mm_per_unit, 3) for x in out.pop("ramp_x")]
        if self.kind == "junction":  # the widest gap along the junction, not a step at a cut
            for when in ("before", "after"):
                out[f"gap_{when}_mm"] = out.pop(f"step_at_cut_{when}_mm")
        return out

    def note(self, mm_per_unit: float = 1.0) -> str:
        """One line for the plates of both faces."""
        mm = mm_per_unit
        where = f"over x {self.ramp_x[0] * mm:.0f}..{self.ramp_x[1] * mm:.0f} mm"
        into = "into" if self.kind == "overlap" else "onto the junction with"
        if not self.taken:
            return f"face {self.face + 1} not faired {into} face {self.onto + 1} {where}: {self.reason}"
        at = "at the cut" if self.kind == "overlap" else "at the junction (widest)"
        return (f"face {self.face + 1} faired {into} face {self.onto + 1} {where}: moved up to "
                f"{self.moved_max * mm:.3g} mm ({self.moved_median * mm:.3g} median), refit within "
                f"{self.refit_error * mm:.3g} mm, step {at} {self.step_at_cut_before * mm:.3g} -> "
                f"{self.step_at_cut_after * mm:.3g} mm")


def fair_overlaps(surfaces: list, overlaps: list, limits: list, tolerance: float) -> tuple[list, list[Fairing]]:
    """The surfaces with, of each pair that lies on each other (``sewing.Overlap``), the face
    that keeps more of the overlap faired into the other up to their cut; ``limits``: each
    face's kept x range (lo, hi), None for its own end. A fairing is taken when its refit
    follows the intended move within REFIT_SHARE of the tolerance and the faces then meet
    closer at the cut than before; the ones not taken are returned too, with the reason."""
    out, done = list(surfaces), []
    for overlap in overlaps:
        x0, x1 = overlap.x_range_mm
        cut = overlap.cut_x_mm
        reach = {}  # face -> (length of the overlap on its kept side, where its ramp starts)
        for k in overlap.faces:
            lo, hi = limits[k]
            if hi is not None and np.isclose(hi, cut):
                reach[k] = (cut - x0, x0)
            elif lo is not None and np.isclose(lo, cut):
                reach[k] = (x1 - cut, x1)
        if not reach or max(length for length, _ in reach.values()) <= 0.0:
            continue
        k = max(reach, key=lambda face: reach[face][0])
        other = overlap.faces[1] if k == overlap.faces[0] else overlap.faces[0]
        faired, fairing = fair_into(out[k], out[other], reach[k][1], cut, k, other)
        fairing = _judged(fairing, tolerance, " at the cut")
        if fairing.taken:
            out[k] = faired
        done.append(fairing)
    return out, done


def _judged(fairing: Fairing, tolerance: float, where: str = "") -> Fairing:
    """The fairing, not taken (with the reason) where its refit strays from the intended move
    by more than REFIT_SHARE of the fit tolerance or the faces would meet no closer."""
    if fairing.refit_error > REFIT_SHARE * tolerance:
        return replace(fairing, taken=False, reason=f"its refit strays {fairing.refit_error:.3g} from the intended "
                       f"move, over {REFIT_SHARE} of the fit tolerance {tolerance:g}")
    if not fairing.step_at_cut_after < fairing.step_at_cut_before:
        return replace(fairing, taken=False, reason=f"the faces would meet no closer{where} "
                       f"({fairing.step_at_cut_before:.3g} -> {fairing.step_at_cut_after:.3g})")
    return fairing


def fair_junctions(surfaces: list, trims: list, limits: list, tolerance: float,
                   skip: frozenset = frozenset()) -> tuple[list, list[Fairing]]:
    """The surfaces with, of each two untrimmed faces that meet along a whole side of one of
    them (every point of it within JUNCTION_REACH fit tolerances of the other face) further
    apart than JUNCTION_GAP of the fit tolerance (DTMB 5415's hull ends up to 15 mm off its
    stern face at ship scale), that side faired onto the other face (:func:`fair_side_onto`,
    over RAMP_PER_GAP times its widest gap). Of two such sides along one junction the one on
    the face the ramp reaches least far into moves (the fairing stays local); a ramp that
    would reach the face's far side is not taken. ``trims``: each face's trim (None: untrimmed); ``limits``: each face's kept x range
    (None for its own end): a side point outside it is not on a junction; ``skip``: pairs of
    faces (frozensets) that overlap, faired as such. Taken on the rules of
    :func:`fair_overlaps`; the ones not taken are returned too, with the reason."""
    out, done = list(surfaces), []
    reach = JUNCTION_REACH * tolerance
    for a in range(len(out)):
        for b in range(a + 1, len(out)):
            if trims[a] is not None or trims[b] is not None or frozenset((a, b)) in skip or not _boxes_meet(
                    out[a], out[b], reach):
                continue
            sides = []  # (face, other face, side, widest gap) of the sides along the junction that stand off
            for k, other in ((a, b), (b, a)):
                distance = SurfaceDistance(out[other], grid=60)
                for side in SIDES:
                    if _length(out[k], side) <= reach:  # a collapsed side (a pole row) runs along nothing
                        continue
                    gaps = side_gaps(out[k], side, distance, limits[k])
                    if np.all(gaps <= reach) and gaps.max() > JUNCTION_GAP * tolerance:
                        sides.append((k, other, side, float(gaps.max()), _depth(out[k], side)))
            if not sides:
                continue
            k, other, side, widest, depth = max(sides, key=lambda c: c[4])
            length = RAMP_PER_GAP * widest
            faired, fairing = fair_side_onto(out[k], out[other], side, length, reach, k, other)
            if length >= depth:
                fairing = replace(fairing, taken=False, reason=f"its ramp ({length:.4g}) would reach the face's far "
                                  f"side ({depth:.4g} away)")
            fairing = _judged(fairing, tolerance) if fairing.taken else fairing
            if fairing.taken:
                out[k] = faired
            done.append(fairing)
    return out, done


def side_gaps(surface: NurbsSurface, side: tuple, distance: SurfaceDistance, limits=(None, None),
              samples: int = SIDE_SAMPLES) -> np.ndarray:
    """Distances (samples,) of points along a side of ``surface`` from the face ``distance``
    measures (inf outside the kept x range ``limits``)."""
    _, points = _side_points(surface, side, np.linspace(*_domains(surface)[1 - side[0]], samples))
    _, dist = closest_with_sides(distance, points)
    lo, hi = limits
    outside = np.zeros(len(points), dtype=bool) if lo is None else points[:, 0] < lo
    if hi is not None:
        outside |= points[:, 0] > hi
    return np.where(outside, np.inf, dist)


def fair_side_onto(moved: NurbsSurface, onto: NurbsSurface, side: tuple, length: float, reach: float,
                   face: int = 0, other: int = 1, name: str | None = None) -> tuple[NurbsSurface, Fairing]:
    """``moved`` refitted so that its ``side`` ((parameter, end), :data:`SIDES`) meets
    ``onto``: each point of the side goes to its closest point on ``onto`` (a point further
    than ``reach`` from it stays), and the face behind the side follows by the C2 ramp in the
    distance behind the side (arc length along the middle iso-line across it), to nothing at
    ``length``."""
    if not length > 0.0:
        raise ValueError(f"fair_side_onto: the ramp's length must be positive, got {length!r}")
    param, end = side
    own, along = _domains(moved)[param], _domains(moved)[1 - param]
    t_end = own[end]
    t = np.linspace(own[end], own[1 - end], 401)
    line = _middle_line(moved, param, t)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
    t_start = float(np.interp(length, arc, t))
    distance = SurfaceDistance(onto, grid=60)

    def target(u, v):
        points = moved.grid(u, v)
        t_values, s_values = (u, v) if param == 0 else (v, u)
        _, at_side = _side_points(moved, side, s_values)
        params, dist = closest_with_sides(distance, at_side)
        offsets = np.where((dist <= reach)[:, None], onto(params[:, 0], params[:, 1]) - at_side, 0.0)
        behind = np.interp(t_values, *((t, arc) if t[0] < t[-1] else (t[::-1], arc[::-1])))
        move = ramp(behind, length, 0.0)[:, None, None] * offsets[None, :, :]  # (Nt, Ns, 3)
        move = move if param == 0 else move.transpose(1, 0, 2)
        return points, points + move, np.linalg.norm(move, axis=-1)

    lo, hi = sorted((t_start, t_end))
    coarse = np.linspace(*own, 41)
    touched = np.append(coarse[(coarse >= lo) & (coarse <= hi)], [t_start, t_end])  # a ramp shorter than a step too
    everywhere = np.linspace(*along, 41)
    touched_u, touched_v = (touched, everywhere) if param == 0 else (everywhere, touched)
    faired, refit_error, shift = refit(moved, touched_u, touched_v, target, name)
    moving = shift > 1e-9 * max(1.0, float(np.ptp(line)))
    before, after = (side_gaps(f, side, distance) for f in (moved, faired))
    on = before <= reach
    ramp_x = (float(np.interp(length, arc, line[:, 0])), float(line[0, 0]))
    return faired, Fairing(face, other, ramp_x, float(shift.max(initial=0.0)),
                           float(np.median(shift[moving])) if moving.any() else 0.0, refit_error,
                           float(before[on].max(initial=0.0)), float(after[on].max(initial=0.0)),
                           (faired.poles.shape[0], faired.poles.shape[1]), kind="junction")


def _boxes_meet(a: NurbsSurface, b: NurbsSurface, margin: float) -> bool:
    """Whether the boxes of the two faces (:func:`.sewing._box`) come within ``margin``."""
    (lo_a, hi_a), (lo_b, hi_b) = _box(a), _box(b)
    return bool(np.all(lo_a <= hi_b + margin) and np.all(lo_b <= hi_a + margin))


def _length(surface: NurbsSurface, side: tuple) -> float:
    """Arc length of a side of the face."""
    _, points = _side_points(surface, side, np.linspace(*_domains(surface)[1 - side[0]], SIDE_SAMPLES))
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def _domains(surface: NurbsSurface) -> tuple:
    return (tuple(surface.domain_u), tuple(surface.domain_v))


def _side_points(surface: NurbsSurface, side: tuple, along: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parameters (N, 2) and points (N, 3) on the side ``(parameter, end)`` at the values
    ``along`` (N,) of the other parameter."""
    param, end = side
    return _iso_points(surface, param, np.full(len(along), _domains(surface)[param][end]), along)


def _middle_line(surface: NurbsSurface, param: int, values: np.ndarray) -> np.ndarray:
    """Points (N, 3) of the iso-line across the sides of ``param`` through the middle of the
    other parameter's domain, at ``param``'s values (N,)."""
    middle = 0.5 * sum(_domains(surface)[1 - param])
    return _iso_points(surface, param, values, np.full(len(values), middle))[1]


def _iso_points(surface: NurbsSurface, param: int, own: np.ndarray, other: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Parameters (N, 2) and points (N, 3) at ``param`` = ``own`` and the other parameter = ``other``."""
    params = np.column_stack([own, other] if param == 0 else [other, own])
    return params, surface(params[:, 0], params[:, 1])


def _depth(surface: NurbsSurface, side: tuple) -> float:
    """Arc length across the face from ``side`` to the opposite side, on the middle iso-line."""
    param = side[0]
    line = _middle_line(surface, param, np.linspace(*_domains(surface)[param], 201))
    return float(np.linalg.norm(np.diff(line, axis=0), axis=1).sum())


def ramp(x: np.ndarray, start: float, end: float) -> np.ndarray:
    """0 at and beyond ``start``, 1 at and beyond ``end``, C2 between (either order of the two)."""
    s = np.clip((np.asarray(x, dtype=np.float64) - start) / (end - start), 0.0, 1.0)
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


def fair_into(moved: NurbsSurface, onto: NurbsSurface, start: float, cut: float, face: int = 0, other: int = 1,
              name: str | None = None) -> tuple[NurbsSurface, Fairing]:
    """``moved`` refitted so that between x = ``start`` and x = ``cut`` its points ramp toward
    their foot points on ``onto`` (none of the way at ``start``, all of it at and beyond the
    cut; before ``start`` the face is itself). ``face`` and ``other`` only label the result."""
    distance = SurfaceDistance(onto, grid=60)
    coarse_u, coarse_v = np.linspace(*moved.domain_u, 41), np.linspace(*moved.domain_v, 41)
    coarse = moved.grid(coarse_u, coarse_v)
    touched = ramp(coarse[..., 0], start, cut) > 0.0
    faired, refit_error, shift = refit(moved, coarse_u[touched.any(axis=1)], coarse_v[touched.any(axis=0)],
                                       lambda u, v: _target(moved, distance, u, v, start, cut), name)
    moving = shift > 1e-9 * max(1.0, float(np.ptp(coarse)))
    return faired, Fairing(face, other, (float(start), float(cut)), float(shift.max(initial=0.0)),
                           float(np.median(shift[moving])) if moving.any() else 0.0, refit_error,
                           _step_at(moved, distance, cut), _step_at(faired, distance, cut),
                           (faired.poles.shape[0], faired.poles.shape[1]))


def refit(moved: NurbsSurface, touched_u: np.ndarray, touched_v: np.ndarray, target, name: str | None = None
          ) -> tuple[NurbsSurface, float, np.ndarray]:
    """``moved`` refitted to ``target(u, v) -> (points, intended, shift)`` (its points on the
    grid (Nu, Nv, 3), where they go, how far (Nu, Nv)): its knot spans holding the parameters
    ``touched_u`` / ``touched_v`` subdivided, the move fitted by least squares on the poles
    that act where something moves. Returns the refitted face, the largest distance of it from
    the intended move between the fit's samples, and the shifts at the samples."""
    knots_u = _refined(moved.knots_u, moved.degree_u, touched_u)
    knots_v = _refined(moved.knots_v, moved.degree_v, touched_v)
    su, sv = _samples(knots_u, moved.degree_u, 0.5), _samples(knots_v, moved.degree_v, 0.5)
    points, intended, shift = target(su, sv)
    bu = BSpline.design_matrix(su, knots_u, moved.degree_u).toarray()
    bv = BSpline.design_matrix(sv, knots_v, moved.degree_v).toarray()
    weights = _weights_at(moved, su, sv)
    # the face on the refined knots (exact: its spline space lies inside), then the move fitted
    # on the poles that act where something moves, so the rest of the face stays as it was
    net = _fit(bu, np.concatenate([points * weights[..., None], weights[..., None]], axis=-1), bv)
    moving_u, moving_v = (shift > 0.0).any(axis=1), (shift > 0.0).any(axis=0)
    acting_u = (bu[moving_u] != 0.0).any(axis=0)
    acting_v = (bv[moving_v] != 0.0).any(axis=0)
    move = np.concatenate([(intended - points) * weights[..., None], np.zeros(weights.shape + (1,))], axis=-1)
    net[np.ix_(acting_u, acting_v)] += _fit(bu[:, acting_u], move, bv[:, acting_v])
    rational = np.ptp(moved.weights) > 0
    w = net[..., 3] if rational else np.full(net.shape[:2], float(moved.weights.flat[0]))
    poles = net[..., :3] / (net[..., 3:] if rational else weights.flat[0])
    faired = nurbs_surface(moved.degree_u, moved.degree_v, poles, knots_u, knots_v, w, name=name or moved.name)
    # between the samples: where a refit would stray from the intended move
    cu, cv = _samples(knots_u, moved.degree_u, 0.0), _samples(knots_v, moved.degree_v, 0.0)
    _, between, _ = target(cu, cv)
    return faired, float(np.linalg.norm(faired.grid(cu, cv) - between, axis=-1).max()), shift


def _fit(bu: np.ndarray, values: np.ndarray, bv: np.ndarray) -> np.ndarray:
    """The net (nu, nv, k) whose tensor-product spline fits ``values`` (Nu, Nv, k) best on the
    sample grid with basis matrices ``bu`` (Nu, nu) and ``bv`` (Nv, nv), by least squares."""
    return np.einsum("ia,abk,jb->ijk", np.linalg.pinv(bu), values, np.linalg.pinv(bv), optimize=True)


def _refined(knots: np.ndarray, degree: int, touched: np.ndarray) -> np.ndarray:
    """The knot vector with every span that holds a touched parameter, and its neighbours, cut
    into REFINE (the neighbours too, so that the poles acting on the move reach past it by a
    few fine spans, not by a few of the face's own)."""
    breaks = np.unique(knots[degree:len(knots) - degree])
    span = np.clip(np.searchsorted(breaks, touched, side="right") - 1, 0, len(breaks) - 2)
    span = np.unique(np.clip(np.concatenate([span - 1, span, span + 1]), 0, len(breaks) - 2)) if len(span) else span
    new = [breaks[i] + (breaks[i + 1] - breaks[i]) * np.arange(1, REFINE) / REFINE for i in span]
    return np.sort(np.concatenate([knots] + new)) if new else knots.copy()


def _samples(knots: np.ndarray, degree: int, offset: float) -> np.ndarray:
    """SAMPLES_PER_SPAN parameters in every knot span, at (k + offset) / SAMPLES_PER_SPAN of it,
    and the domain's ends."""
    breaks = np.unique(knots[degree:len(knots) - degree])
    at = (np.arange(SAMPLES_PER_SPAN) + offset) / SAMPLES_PER_SPAN
    inside = (breaks[:-1, None] + np.diff(breaks)[:, None] * at[None, :]).ravel()
    return np.unique(np.concatenate([inside, breaks[[0, -1]]]))


def _weights_at(surface: NurbsSurface, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The rational denominator W(u_i, v_j) on the grid (Nu, Nv)."""
    bu = BSpline.design_matrix(u, surface.knots_u, surface.degree_u).toarray()
    bv = BSpline.design_matrix(v, surface.knots_v, surface.degree_v).toarray()
    return bu @ surface.weights @ bv.T


def _target(moved: NurbsSurface, distance: SurfaceDistance, u: np.ndarray, v: np.ndarray, start: float,
            cut: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The face's points on the grid (Nu, Nv, 3), the faired face's there and how far each
    moved (Nu, Nv)."""
    points = moved.grid(u, v)
    weight = ramp(points[..., 0], start, cut)
    target = points.copy()
    on = weight > 0.0
    if not on.any():
        return points, target, np.zeros(weight.shape)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    params, _ = distance.closest(points[on])
    onto = distance.surfaces[0]
    offset = onto(params[:, 0], params[:, 1]) - points[on]  # along the other face's normal: the foot is a foot
    # a foot on the other face's edge (the faces' centreline, deck edge or end) is a foot only
    # along the normal: the point moves along its own normal by the other face's edge's height
    # over its tangent plane, which carries the gap past the edge and is the foot where it is one
    edge = ~interior(onto, params)
    if edge.any():
        su, sv = moved.partials(uu[on][edge], vv[on][edge])
        normal = np.cross(su, sv)
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        offset[edge] = np.einsum("ij,ij->i", offset[edge], normal)[:, None] * normal
    move = weight[on][:, None] * offset
    target[on] += move
    shift = np.zeros(weight.shape)
    shift[on] = np.linalg.norm(move, axis=1)
    return points, target, shift


def _step_at(surface: NurbsSurface, distance: SurfaceDistance, cut: float) -> float:
    """The largest distance of the face's section at x = ``cut`` from the other face, over the
    points whose foot lies inside it."""
    dist = section_distances(surface, distance, cut, SECTION_LINES)
    return float(dist.max()) if len(dist) else float("nan")
