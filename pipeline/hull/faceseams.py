"""Seams across a face junction: where two faces of a plan are cut at one transverse plane
(a shell's loft and the faces beyond its end, or two faces that lie on each other), the
later face's seams meet the earlier face's there, or end at least the butt stagger from them.

Each face's seams are laid at equal girth at its own widest section, so at a junction the
two faces' seams end wherever their layouts put them: on KVLCC2's fore junction (x = 296.1 m)
the loft's seams and the bow face's ended 92 to 286 mm apart, on KCS's aft one (x = 22.5 m)
and at DTMB 5415's overlap cut (x = 20.2 m, 17 and 97 mm) alike. A seam end that close to another across
the butt leaves a few centimetres of butt weld between two T joints, which the yard's stagger
rule (:mod:`.yardrules`) is there to prevent. Every strake of both faces butts at the
junction's plane, so it is a joint like a block joint: a seam may run on across it.

:func:`meet_at_junctions` moves each of a face's seams (iso-girth values) whose end at a
junction lies within the stagger of an end of the earlier face's seams: onto that end (the
seam runs on; preferred), else to the stagger from every end there, the nearest such place;
a move is taken only while each strake stays within the stock's width at the face's widest
section and no narrower than the stagger. A seam no place suits stays where it is (the
plan then tries the face with one strake more: ``planner._meet_earlier_faces``). Only iso
seams are laid so: with ``plan.seams: least_curvature`` a face's seams are curves through its
widest section and keep their ends at a junction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .region import Girth

SECTION_SAMPLES = 801  # girth samples of a face's section at a junction
LENGTH_SAMPLES = 201  # samples along a seam where it crosses the junction's plane
BISECTIONS = 40  # refinements of each crossing (to ~1e-12 of the domain)
# a staggered seam end is placed this fraction beyond the stagger: the section's polyline
# is within a fraction of a millimetre of the face, and the rule's distance is measured on it
STAGGER_MARGIN = 1e-3


@dataclass(frozen=True)
class SeamMove:
    """One seam of a face moved at a junction: its index in the face's seams, the girth
    value before and after, what it now does at the junction (``"runs on"``: meets an end
    of the earlier face's seams; ``"staggered"``: ends the stagger from them) and the gap it
    had there (in a straight line, as the rule measures; model units)."""

    seam: int
    before: float
    after: float
    how: str
    gap: float


def shared_planes(limits: list, k: int, eps: float = 1e-9) -> list[tuple[int, float]]:
    """(j, x) for each earlier face j (j < k) cut at the same transverse plane x as face k
    (``limits``: each face's (lo, hi) x cut, None where it runs to its own end)."""
    out = []
    for x in limits[k]:
        if x is None:
            continue
        for j in range(k):
            if any(y is not None and abs(y - x) <= eps * max(1.0, abs(x)) for y in limits[j]):
                out.append((j, float(x)))
    return out


def seam_crossings(surface, axis: int, girths, x: float) -> np.ndarray:
    """Points (len(girths), 3) where each seam (a :class:`.region.Girth`) crosses the plane
    x = ``x``; NaN for a seam that does not reach it. Found on a sample of each seam along
    the surface's long parameter, then by bisection."""
    dom = surface.domain_u if axis == 0 else surface.domain_v
    s = np.linspace(*dom, LENGTH_SAMPLES)
    g = np.stack([np.asarray(girth(s), dtype=np.float64) for girth in girths])  # (N, S)
    return _crossings(surface, axis, np.broadcast_to(s, g.shape), g, x,
                      lambda t: np.stack([np.asarray(girth(row), dtype=np.float64) for girth, row in zip(girths, t)]))


def section_at(surface, axis: int, x: float, samples: int = SECTION_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """The face's iso-girth lines' crossings with the plane x = ``x``: girth values (M,) and
    points (M, 3), NaN where a line does not reach the plane."""
    gdom = surface.domain_v if axis == 0 else surface.domain_u
    sdom = surface.domain_u if axis == 0 else surface.domain_v
    g = np.linspace(*gdom, samples)
    s = np.linspace(*sdom, LENGTH_SAMPLES)
    grid_s, grid_g = np.meshgrid(s, g)  # (M, S)
    return g, _crossings(surface, axis, grid_s, grid_g, x, lambda t: np.broadcast_to(g[:, None], t.shape))


def _crossings(surface, axis: int, s: np.ndarray, g: np.ndarray, x: float, girth_of) -> np.ndarray:
    """Each row's first crossing of x = ``x`` (rows of samples s, g (N, S) in the surface's
    long and girth parameters), NaN where a row does not cross. ``girth_of(t)``: the girth
    parameter of each row at long parameters t (N, 1).

    Not :func:`flatten.plane.plane_crossings` on each iso curve: at a loft's own end plane
    (KVLCC2's, x = 15.09 and 296.11 m) its exact roots fall a round-off outside the curve's
    domain, and it found 45 and 78 of 101 of the loft's crossings and none of the stern face's
    (where it found one, it agrees within 4e-6 mm); a section's 801 lines also take it 15
    times as long as one evaluation of the grid here."""
    u, v = (s, g) if axis == 0 else (g, s)
    d = surface(u.ravel(), v.ravel())[:, 0].reshape(s.shape) - x
    rows = np.arange(len(s))
    zero = d == 0.0
    change = (np.sign(d[:, :-1]) * np.sign(d[:, 1:]) < 0) | zero[:, :-1] | zero[:, 1:]
    crosses = change.any(axis=1)
    first = np.argmax(change, axis=1)
    lo, hi = s[rows, first].copy(), s[rows, first + 1].copy()
    d_lo = d[rows, first]
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        gm = girth_of(mid[:, None])[:, 0]
        um, vm = (mid, gm) if axis == 0 else (gm, mid)
        dm = surface(um, vm)[:, 0] - x
        same = np.sign(dm) == np.sign(d_lo)
        lo, d_lo = np.where(same, mid, lo), np.where(same, dm, d_lo)
        hi = np.where(same, hi, mid)
    mid = np.where(zero[rows, first], s[rows, first],
                   np.where(zero[rows, first + 1], s[rows, first + 1], 0.5 * (lo + hi)))
    # a loft's end plane is its domain's end, where its x meets the plane only to the
    # round-off of its fit (KVLCC2's stern loft ends 1.2 um short of it): a row that does not
    # cross but ends within a millionth of x's size of the plane crosses at that end
    near = 1e-6 * max(abs(float(x)), 1.0)
    at_start = ~crosses & (np.abs(d[:, 0]) <= near)
    at_end = ~crosses & ~at_start & (np.abs(d[:, -1]) <= near)
    mid = np.where(at_start, s[:, 0], np.where(at_end, s[:, -1], mid))
    found = crosses | at_start | at_end
    gm = girth_of(mid[:, None])[:, 0]
    points = surface(*((mid, gm) if axis == 0 else (gm, mid)))
    points[~found] = np.nan
    return points


def _along(polyline: np.ndarray, arc: np.ndarray, point: np.ndarray) -> tuple[float, float]:
    """(arc length along ``polyline`` (M, 3) of its closest point to ``point`` (3,), the
    distance); ``arc``: the polyline's cumulative length (M,)."""
    seg = np.diff(polyline, axis=0)
    length2 = np.maximum(np.einsum("ij,ij->i", seg, seg), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", point - polyline[:-1], seg) / length2, 0.0, 1.0)
    gaps = np.linalg.norm(polyline[:-1] + t[:, None] * seg - point, axis=1)
    k = int(gaps.argmin())
    return float(arc[k] + t[k] * (arc[k + 1] - arc[k])), float(gaps[k])


def meet_at_junctions(surface, axis: int, seams: list, widest_girth, ends: list, stagger: float, max_width: float,
                      reach: float) -> tuple[list, list, int]:
    """A face's iso seams (girth values, ascending, the first and last its edges) moved to
    meet or keep the stagger from the seam ends of earlier faces at its junctions.

    surface, axis : the face and its long parameter (0: u)
    seams : girth parameter values (n + 1,), edges included (they never move)
    widest_girth : girth length (model units) along the face's widest section as a function
        of the girth parameter (the strakes' widths the uniform layout was laid by)
    ends : [(x, points (M, 3))]: each junction plane and the earlier faces' seam ends on it
    stagger : least distance between seam ends across a butt (model units)
    max_width : the stock's widest plate (model units)
    reach : how far off this face's section an end may lie and still be on it (the faces
        meet within a few fit tolerances)

    Returns the seams, the :class:`SeamMove` of each seam moved and how many seams within
    the stagger of an end no place suits."""
    seams = [float(v) for v in seams]
    sections = [sec for sec in (_Section.at_junction(surface, axis, x, points, reach) for x, points in ends) if sec]
    if not sections:
        return seams, [], 0

    def verdict(value) -> tuple[bool, int, float]:
        """(acceptable, ends it meets, least distance to an end it does not meet)."""
        meets, least = 0, np.inf
        for section in sections:
            met, gaps = section.gaps(value, stagger)
            meets += int(met.any())
            if (~met).any():
                least = min(least, float(gaps[~met].min()))
        return least >= stagger, meets, least

    moves, left = [], 0
    options = [value for section in sections for value in section.places(stagger * (1 + STAGGER_MARGIN))]
    for i in range(1, len(seams) - 1):
        fine, _, gap = verdict(seams[i])
        if fine:
            continue
        best = None
        for value in options:
            if not seams[i - 1] < value < seams[i + 1]:
                continue
            widths = np.diff(widest_girth(np.array([seams[i - 1], value, seams[i + 1]])))
            if widths.max() > max_width or widths.min() < stagger:
                continue
            ok, meets, _ = verdict(value)
            if ok:
                key = (-meets, abs(float(np.diff(widest_girth(np.array([seams[i], value])))[0])))
                if best is None or key < best[0]:
                    best = (key, value, meets)
        if best is None:
            left += 1
            continue
        value = best[1]
        if best[2]:
            refined = _onto_ends(surface, axis, value, ends, reach)
            value = refined if seams[i - 1] < refined < seams[i + 1] and verdict(refined)[:2] == (True, best[2]) \
                else value
        moves.append(SeamMove(i, seams[i], value, "runs on" if best[2] else "staggered", gap))
        seams[i] = value
    return seams, moves, left


@dataclass(frozen=True)
class _Section:
    """A face's section at a junction plane (a polyline of its iso-girth lines' crossings:
    girth values (M,), points (M, 3), arc length (M,)) and the earlier faces' seam ends on
    it, as arc lengths along it (E,) and their points there (E, 3)."""

    g: np.ndarray
    points: np.ndarray
    arc: np.ndarray
    marks: np.ndarray
    mark_points: np.ndarray

    @staticmethod
    def at_junction(surface, axis: int, x: float, ends, reach: float):
        """The section at x and the ends within ``reach`` of it (None when none is)."""
        g, at = section_at(surface, axis, x)
        ok = np.isfinite(at[:, 0])
        if ok.sum() < 2:
            return None
        g, at = g[ok], at[ok]
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(at, axis=0), axis=1))])
        ends = np.asarray(ends, dtype=np.float64).reshape(-1, 3)
        found = [_along(at, arc, p) for p in ends[np.isfinite(ends).all(axis=1)]]
        marks = np.unique([a for a, gap in found if gap <= reach])
        if not len(marks):
            return None
        return _Section(g, at, arc, marks, _point_at(arc, at, marks))

    def point(self, arc) -> np.ndarray:
        """Points (N, 3) of the polyline at arc lengths (N,)."""
        return _point_at(self.arc, self.points, arc)

    def gaps(self, value: float, stagger: float) -> tuple[np.ndarray, np.ndarray]:
        """Which ends the seam at girth ``value`` meets (E,) and its distance from each (E,)."""
        a = float(np.interp(value, self.g, self.arc))
        # ends a thousandth of the stagger apart are one point, as to the yard's seam rule
        met = np.abs(self.marks - a) <= 1e-3 * stagger
        return met, np.linalg.norm(self.mark_points - self.point(np.array([a])), axis=1)

    def places(self, distance: float) -> list[float]:
        """Girth values of the ends themselves and of the nearest points ``distance`` from
        each end (in a straight line, as the stagger rule measures) on either side of it."""
        out = [float(v) for v in np.interp(self.marks, self.arc, self.g)]
        chords = np.linalg.norm(self.points[None, :, :] - self.mark_points[:, None, :], axis=2)  # (E, M)
        for mark, chord in zip(self.marks, chords):
            for side in (-1, 1):
                beyond = np.nonzero((chord >= distance) & (side * (self.arc - mark) > 0))[0]
                if not len(beyond):
                    continue
                k = beyond[-1] if side < 0 else beyond[0]
                j = k + 1 if side < 0 else k - 1  # the sample before it, nearer the end
                start, near = (mark, 0.0) if side * (self.arc[j] - mark) <= 0 else (self.arc[j], chord[j])
                t = (distance - near) / (chord[k] - near) if chord[k] > near else 1.0
                at = start + np.clip(t, 0.0, 1.0) * (self.arc[k] - start)
                out.append(float(np.interp(at, self.arc, self.g)))
        return out


def _point_at(arc: np.ndarray, points: np.ndarray, at) -> np.ndarray:
    """Points (N, 3) at arc lengths ``at`` (N,) along a polyline (M, 3) of cumulative length
    ``arc`` (M,)."""
    return np.column_stack([np.interp(at, arc, points[:, c]) for c in range(3)])


def _onto_ends(surface, axis: int, value: float, ends: list, reach: float, steps: int = 4) -> float:
    """The girth value near ``value`` whose seam ends on the nearest of ``ends`` (the section's
    sampling put it within a fraction of a millimetre): Gauss-Newton steps on its crossing."""
    gdom = surface.domain_v if axis == 0 else surface.domain_u
    h = 1e-7 * (gdom[1] - gdom[0])
    for _ in range(steps):
        best = None
        for x, points in ends:
            q, q_h = seam_crossings(surface, axis, [Girth.iso(value), Girth.iso(value + h)], x)
            if not np.isfinite(q).all() or not np.isfinite(q_h).all():
                continue
            gaps = np.linalg.norm(points - q, axis=1)
            k = int(np.nanargmin(gaps))
            if gaps[k] <= reach and (best is None or gaps[k] < best[0]):
                best = (gaps[k], q, (q_h - q) / h, points[k])
        if best is None:
            return value
        _, q, dq, target = best
        step = float(np.dot(target - q, dq) / max(np.dot(dq, dq), 1e-300))
        value = float(np.clip(value + step, *gdom))
    return value
