"""Seams between textile pieces: the curves two pieces of a run share (the inner curves of
a `sequence:`), which are sewn edge to edge.

A developable strip rarely covers both of its curves whole: it starts and ends where its
rulings reach the end of one curve, so the neighbouring pieces along a shared curve may
cover different stretches of it. Per seam this module measures, as arc lengths from the
shared curve's own start (model units), the stretch each piece's edge covers, the stretch
both cover (sewable) and, per piece, what lies outside it (unsewable) and why. The run's
``textile.seams`` then decides:

- ``match``: each piece is trimmed, by an exact ruling through the shared curve, to the
  sewable stretch (repeated until every seam agrees, since trimming a piece also shortens
  its other edge); the seam edges then have the same length;
- ``report``: the pieces keep their strips; each unsewable stretch is a warning;
- ``require_full``: every shared curve must be covered whole by both pieces, otherwise
  those pieces fail (exit 1) with the reason.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import NotchSpec, RunConfig, Textile
from ..stages import PartResult, finish_part, stage_check, stage_strip, stage_unroll

MAX_ROUNDS = 20


def ruling_through(result: PartResult, axis: int, param: float) -> np.ndarray:
    """The exact ruling [t, T] of the part's strip through c(param) (axis 0) or d(param)
    (axis 1): interpolated on the strip's rulings, then polished on f = 0."""
    rulings = result.strip.rulings
    field_ = result.solution.field
    values = rulings[:, axis]
    order = np.argsort(values, kind="stable")
    other = float(np.interp(param, values[order], rulings[order, 1 - axis]))
    if axis == 0:
        ruling = np.array([param, other])
        if field_ is not None:
            ruling[1] = float(field_.refine_T(np.array([param]), np.array([other]), 8)[0])
        return ruling
    ruling = np.array([other, param])
    if field_ is not None:  # polish t on f(., T) = 0 by a few Newton steps
        for _ in range(8):
            f = field_(ruling[0], ruling[1])[0]
            ft = field_(ruling[0], ruling[1], 1, 0)[0]
            if ft == 0:
                break
            ruling[0] -= f / ft
    return ruling


@dataclass(frozen=True)
class SeamEdge:
    """One piece's edge along a shared curve: the covered stretch (arc lengths from the
    curve's start) and why the edge stops at each end short of the curve's ends."""

    piece: str
    edge: str  # 'c' or 'd' of that piece
    interval: tuple[float, float]
    why: tuple[str, str]


@dataclass(frozen=True)
class Seam:
    curve: str
    length: float  # 3D arc length of the shared curve (model units)
    edges: tuple[SeamEdge, ...]

    @property
    def sewable(self) -> tuple[float, float]:
        return (max(e.interval[0] for e in self.edges), min(e.interval[1] for e in self.edges))

    def unsewable(self, tol: float) -> list[dict]:
        """Per edge, the stretches outside the sewable one, their length, and why: the
        other edge stops there."""
        lo, hi = self.sewable
        out = []
        for e in self.edges:
            others = [o for o in self.edges if o is not e]
            for a, b, end in ((e.interval[0], lo, 0), (hi, e.interval[1], 1)):
                if b - a > tol:
                    # the edge that stops first at this end
                    stop = max(others, key=lambda o: o.interval[0]) if end == 0 else \
                        min(others, key=lambda o: o.interval[1])
                    out.append({"piece": e.piece, "edge": e.edge, "from": a, "to": b, "length": b - a,
                                "because": f"{stop.piece} stops at s = {stop.interval[end]:.6g}: {stop.why[end]}"})
        return out

    def as_dict(self, tol: float) -> dict:
        lo, hi = self.sewable
        return {"curve": self.curve, "curve_length": self.length,
                "edges": [{"piece": e.piece, "edge": e.edge, "from": e.interval[0], "to": e.interval[1],
                           "length": e.interval[1] - e.interval[0], "why": list(e.why)} for e in self.edges],
                "sewable": [lo, hi], "sewable_length": max(hi - lo, 0.0), "unsewable": self.unsewable(tol)}


def _edge(result: PartResult, axis: int, trimmed: dict) -> SeamEdge:
    part = result.part
    curve = part.c if axis == 0 else part.d
    other = part.d if axis == 0 else part.c
    other_id = part.curve_ids[1 - axis]
    rulings = result.strip.rulings
    order = np.argsort(rulings[:, axis], kind="stable")
    ends = rulings[order[[0, -1]]]
    s = curve.arc_length_at(ends[:, axis])
    why = []
    for k, ruling in enumerate(ends):
        if abs(s[k] - (0.0 if k == 0 else curve.length)) <= 1e-9 * curve.length:
            why.append("the end of the curve")
        elif (result.name, axis, k) in trimmed:
            why.append(trimmed[(result.name, axis, k)])
        else:
            u = ruling[1 - axis]
            lo, hi = other.domain
            span = hi - lo
            if abs(u - lo) <= 1e-9 * span or abs(u - hi) <= 1e-9 * span:
                which = "start" if abs(u - lo) <= 1e-9 * span else "end"
                why.append(f"its strip reaches the {which} of curve {other_id} (the piece's other edge) "
                           f"there; no ruling of a developable strip joins the rest of curve "
                           f"{part.curve_ids[axis]} to curve {other_id}")
            else:
                why.append("the acceptable strip ends there (beyond it the rulings would cross or turn back)")
    return SeamEdge(result.name, "c" if axis == 0 else "d", (float(s[0]), float(s[1])), tuple(why))


def find_seams(results: list[PartResult], trimmed: dict | None = None) -> list[Seam]:
    """Every curve shared by two or more successful pieces, with each piece's edge on it."""
    trimmed = trimmed or {}
    users: dict = {}
    for r in results:
        if r.ok:
            for axis, cid in enumerate(r.part.curve_ids):
                # only a sequence's curves (indices) are shared; the 'c' and 'd' of separate
                # parts are each part's own
                if not isinstance(cid, str):
                    users.setdefault(cid, []).append((r, axis))
    seams = []
    for cid, edges in users.items():
        if len(edges) < 2:
            continue
        r, axis = edges[0]
        curve = r.part.c if axis == 0 else r.part.d
        seams.append(Seam(str(cid), curve.length, tuple(_edge(r, a, trimmed) for r, a in edges)))
    return seams


def trim(result: PartResult, config: RunConfig, axis: int, interval: tuple[float, float]) -> None:
    """Cut the part's strip to the rulings through the stretch [s0, s1] (arc lengths) of
    its c (axis 0) or d (axis 1) curve, ends exact; strip, check and development redone."""
    curve = result.part.c if axis == 0 else result.part.d
    p0, p1 = curve.parameter_at_length(np.array(interval, dtype=float))
    rulings = result.strip.rulings
    values = rulings[:, axis]
    tol = 1e-9 * max(float(np.ptp(values)), 1e-300)
    keep = rulings[(values >= p0 - tol) & (values <= p1 + tol)]
    # an end ruling exactly through the cut, unless the strip has one there already
    ends = [ruling_through(result, axis, float(p)) for p in (p0, p1)
            if len(keep) == 0 or np.abs(keep[:, axis] - p).min() > tol]
    merged = np.vstack([keep] + ends)
    orientation = 1 if result.solution.path is None else result.solution.path.orientation
    merged = merged[np.lexsort((merged[:, 1] * orientation, merged[:, 0]))]
    distinct = np.ones(len(merged), dtype=bool)
    distinct[1:] = np.any(np.abs(np.diff(merged, axis=0)) > 1e-12, axis=1)
    stage_strip(result, config, given=merged[distinct])
    if not stage_check(result, config):
        result.status = "failed"
        return
    stage_unroll(result)
    finish_part(result, config)


def match_seams(results: list[PartResult], config: RunConfig) -> list[Seam]:
    """Apply ``textile.seams`` to the successful pieces (may trim or fail some) and
    record, per piece, its seams in ``figures['seams']``; returns the final seams."""
    mode = config.spec.textile.seams
    units = config.spec.units
    seams = find_seams(results)
    first = seams
    spans_before = {r.name: _spans(r) for r in results if r.ok}
    trimmed: dict = {}
    by_name = {r.name: r for r in results}
    if mode == "match":
        for _ in range(MAX_ROUNDS):
            changed = False
            for seam in seams:
                tol = 1e-9 * seam.length
                lo, hi = seam.sewable
                if hi - lo <= tol:
                    continue  # nothing sewable: reported below, nothing to trim to
                for e in seam.edges:
                    if e.interval[0] < lo - tol or e.interval[1] > hi + tol:
                        r = by_name[e.piece]
                        axis = 0 if e.edge == "c" else 1
                        for k, (mine, target) in enumerate(((e.interval[0], lo), (e.interval[1], hi))):
                            if abs(mine - target) > tol:
                                stop = [o for o in seam.edges if o is not e and abs(o.interval[k] - target) <= tol][0]
                                trimmed[(r.name, axis, k)] = (f"trimmed to match {stop.piece}, which stops "
                                                              f"there: {stop.why[k]}")
                        trim(r, config, axis, (max(e.interval[0], lo), min(e.interval[1], hi)))
                        changed = True
            seams = find_seams(results, trimmed)
            if not changed:
                break
    for seam in seams:
        tol = 1e-9 * seam.length
        for item in seam.unsewable(tol):
            r = by_name[item["piece"]]
            text = (f"seam on curve {seam.curve}: {item['length']:.1f} {units} of edge {item['edge']} unsewable "
                    f"(s = {item['from']:.1f} to {item['to']:.1f}): {item['because']}")
            if mode == "require_full":
                r.status, r.reason = "failed", f"textile.seams = require_full: {text}"
            else:
                r.warnings.append(text)
        if mode == "require_full":
            for e in seam.edges:
                short = seam.length - (e.interval[1] - e.interval[0])
                if short > tol and by_name[e.piece].ok:
                    r = by_name[e.piece]
                    r.status = "failed"
                    short_ends = [w for w, at, end in zip(e.why, e.interval, (0.0, seam.length))
                                  if abs(at - end) > tol]
                    r.reason = (f"textile.seams = require_full: edge {e.edge} covers {e.interval[1] - e.interval[0]:.1f} "
                                f"of the {seam.length:.1f} {units} of curve {seam.curve}: {'; '.join(short_ends)}")
    before = {s.curve: s for s in first}
    for r in results:
        mine = [s for s in seams if any(e.piece == r.name for e in s.edges)]
        if mine:
            r.figures["seams"] = [dict(s.as_dict(1e-9 * s.length), mode=mode,
                                       before_matching=before[s.curve].as_dict(1e-9 * s.length)
                                       if mode == "match" else None) for s in mine]
    for r in results:
        if r.ok and r.name in spans_before:
            for axis, (a, b) in enumerate(_spans(r)):
                (a0, b0), cid = spans_before[r.name][axis], r.part.curve_ids[axis]
                lost = (b0 - a0) - (b - a)
                if lost > 1e-9 * (b0 - a0):
                    r.warnings.append(f"edge {'cd'[axis]} (curve {cid}) trimmed by {lost:.1f} {units} "
                                      f"(s = {a0:.1f}..{b0:.1f} -> {a:.1f}..{b:.1f}) to match the seams")
    return seams


def _spans(result: PartResult) -> list[tuple[float, float]]:
    """Arc-length stretches of c and d the part's strip covers."""
    out = []
    for axis, curve in enumerate((result.part.c, result.part.d)):
        values = result.strip.rulings[:, axis]
        s = curve.arc_length_at(np.array([values.min(), values.max()]))
        out.append((float(s[0]), float(s[1])))
    return out


def match_mark_positions(seam: Seam, spacing: float) -> list[float]:
    """Arc lengths (from the shared curve's start) of a seam's match marks: every
    ``spacing`` from the start of its sewable stretch, none closer than a quarter spacing
    to its end (the corner is matched already)."""
    lo, hi = seam.sewable
    count = int(np.floor((hi - lo - 0.25 * spacing) / spacing)) if hi - lo > 1.25 * spacing else 0
    return [float(lo + k * spacing) for k in range(1, count + 1)]


def with_match_marks(settings: Textile, seams: list[Seam]) -> Textile:
    """The textile settings with one notch entry per seam: its match marks, at the same arc
    lengths of the shared curve on every piece sewn along it."""
    marks = settings.match_marks
    if marks is None:
        return settings
    extra = []
    for seam in seams:
        at = match_mark_positions(seam, marks.spacing)
        if at:
            extra.append(NotchSpec(curve=int(seam.curve), at=at, type=marks.type, depth=marks.depth,
                                   width=marks.width))
    return settings.model_copy(update={"notches": list(settings.notches) + extra})
