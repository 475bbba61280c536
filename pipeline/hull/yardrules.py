"""A yard's rules for laying seams and butts: staggered butts and stealers (drop strakes).

Active when the plan has an objective or names ``butt_stagger`` or ``block_joints``
(``plan.objective``, README "Plans a yard would build"); otherwise the plain uniform layout
stays, so that existing configurations plan as before.

Butts of neighbouring strakes are aligned on a block joint (``plan.block_joints``, x) or else
staggered by at least ``plan.butt_stagger`` (default 300 mm: a customary yard figure, not a
class rule; IACS Rec. 47 section 8.5 "distance between welds" is where a class sets its
minimum, smaller than this): where two butts meet a seam from either side at the same point
the joint is a cross (four plates at a point), a weld detail yards avoid off the block joints.
A butt that meets a seam where the seam itself ends (a T: the seam stops at the butt) is
fine. The layout: between block joints, strakes alternate the offsets 0 and +stagger of an
equal butt spacing chosen so that every plate, offsets included, stays within
``stock.max_length``.

Stealers: where the girth shrinks toward the ends, an end plate narrower than
``stock.min_width`` (its largest girth width) is merged with its narrower neighbour (the seam
between them ends at a butt: a drop strake) while the merged plate stays within
``stock.max_width``; a merged end plate's butt is the strakes' first (last) butt moved aft by the
stagger (two staggers inward when the merged plate beside it took that one), so that it is
staggered from both neighbours (offsets 0 and +stagger); no plate is longer than the spacing
plus two staggers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DEFAULT_STAGGER_MM = 300.0


def yard_rules_on(plan) -> bool:
    return plan.objective is not None or plan.butt_stagger is not None or bool(plan.block_joints)


def stagger_of(plan, mm_per_unit: float) -> float:
    """The least butt stagger in model units."""
    return float(plan.butt_stagger) if plan.butt_stagger is not None else DEFAULT_STAGGER_MM / mm_per_unit


def strake_butts(x0: float, x1: float, max_length: float, stagger: float, joints, offset: float) -> list[float]:
    """Interior butts (x, ascending) of a strake between x0 and x1: the block joints inside,
    and between consecutive joints an equal spacing shifted by ``offset`` (0 or +-stagger),
    the spacing chosen so that a plate lengthened by two staggers (its own offset and a
    stealer's end plate's) stays within max_length."""
    inner = sorted(float(j) for j in joints if x0 < j < x1)
    cuts = [x0] + inner + [x1]
    butts = []
    usable = max(max_length - 2.0 * stagger, 0.5 * max_length)
    for k, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        n = max(1, int(np.ceil((b - a) / usable - 1e-9)))
        spacing = (b - a) / n
        butts += [a + m * spacing + offset for m in range(1, n)]
        if k < len(inner):
            butts.append(inner[k])
    return butts


def yard_layout(n_strakes: int, x0: float, x1: float, ends: tuple, stock, stagger: float, joints,
                width_of) -> list[tuple[int, int, list, int]]:
    """The plates' (lo seam, hi seam, [plane x or None, plane x or None], B number) in strake
    order. ``ends``: (x or None, x or None) of the face's ends; ``width_of(lo, hi, a, b)``:
    the largest girth width of the plate between seams lo..hi and planes a, b (model units)."""
    joint_set = {float(j) for j in joints}
    offsets = [stagger * (i % 2) for i in range(n_strakes)]
    butts = [strake_butts(x0, x1, stock.max_length, stagger, joints, offsets[i]) for i in range(n_strakes)]
    base = strake_butts(x0, x1, stock.max_length, stagger, joints, 0.0)
    groups = {}
    for end in (0, 1):
        if not base:
            break
        x_base = base[0] if end == 0 else base[-1]
        # the strakes beside a merged end plate butt at x_base or x_base + stagger: its butt
        # goes one stagger aft of x_base; a second merged plate beside it two staggers
        # inward (aft end: x_base + 2 staggers; fore end: x_base - 2 staggers)
        shifted = x_base if x_base in joint_set else x_base - stagger
        found = _stealers(n_strakes, butts, end, shifted, ends[end], stock, width_of)
        groups[end], previous = {}, None
        for lo, hi in sorted(found):
            x_g = shifted
            if previous is not None and previous[0][1] == lo and x_base not in joint_set and previous[1] == shifted:
                x_g = x_base + (2.0 if end == 0 else -2.0) * stagger
            groups[end][(lo, hi)] = x_g
            previous = ((lo, hi), x_g)
    plates = []
    for i in range(n_strakes):
        planes = [ends[0]] + list(butts[i]) + [ends[1]]
        for end, found in groups.items():
            for lo, hi in found:
                if lo <= i < hi:  # the group's end plate replaces this strake's end plate(s)
                    x_g = found[(lo, hi)]
                    # the strake's butt nearest the end moves to the merged plate's
                    if end == 0:
                        planes = [ends[0], x_g] + planes[2:]
                    else:
                        planes = planes[:-2] + [x_g, ends[1]]
        for j in range(len(planes) - 1):
            group = _group_at(groups, i, j, len(planes) - 1)
            if group is None:
                plates.append((i, i + 1, planes[j:j + 2], j + 1))
            elif group[0] == i:  # the merged plate once, in its lowest strake's place
                plates.append((group[0], group[1], planes[j:j + 2], j + 1))
    return plates


def _group_at(groups: dict, i: int, j: int, n_plates: int):
    for end, found in groups.items():
        if (end == 0 and j == 0) or (end == 1 and j == n_plates - 1):
            for lo, hi in found:
                if lo <= i < hi:
                    return lo, hi
    return None


def _stealers(n: int, butts, end: int, x_group: float, plane_end, stock, width_of) -> dict:
    """Seam ranges (lo, hi) of strakes whose end plates merge (drop strakes)."""
    def end_plate(lo, hi, x_at):
        return (plane_end, x_at) if end == 0 else (x_at, plane_end)

    def own_width(i):
        x_at = (butts[i][0] if end == 0 else butts[i][-1]) if butts[i] else None
        return width_of(i, i + 1, *end_plate(i, i + 1, x_at)) if x_at is not None else np.inf

    widths = [own_width(i) for i in range(n)]
    groups = [[i, i + 1] for i in range(n)]  # seam ranges
    for _ in range(n):
        changed = False
        for g, (lo, hi) in enumerate(groups):
            w = widths[lo] if hi - lo == 1 else width_of(lo, hi, *end_plate(lo, hi, x_group))
            if w >= stock.min_width or w <= 0.0:
                continue  # wide enough, or the end plate misses the surface
            sides = [k for k in (g - 1, g + 1) if 0 <= k < len(groups)]
            if not sides:
                continue
            narrow = {k: (widths[groups[k][0]] if groups[k][1] - groups[k][0] == 1 else
                          width_of(groups[k][0], groups[k][1], *end_plate(*groups[k], x_group))) for k in sides}
            k = min(sides, key=lambda s: (narrow[s], s))
            a, b = min(lo, groups[k][0]), max(hi, groups[k][1])
            if width_of(a, b, *end_plate(a, b, x_group)) > stock.max_width:
                continue
            groups[min(g, k)] = [a, b]
            del groups[max(g, k)]
            changed = True
            break
        if not changed:
            break
    return [(lo, hi) for lo, hi in groups if hi - lo > 1]


# ------------------------------------------------------------ the rule, checked on a plan
def _x_range(part) -> tuple[float, float]:
    lo, hi = part.hull.butts
    return (-np.inf if lo is None else lo.offset), (np.inf if hi is None else hi.offset)


def seam_sides(parts) -> dict:
    """{id(girth): (girth, [parts below it], [parts above it])} for every seam of the plan."""
    sides = {}
    for part in parts:
        for side, girth in ((1, part.hull.girths[0]), (0, part.hull.girths[1])):
            entry = sides.setdefault(id(girth), (girth, [], []))
            entry[1 + side].append(part)  # girths[0] is the seam below the plate: the plate is above it
    return sides


def butt_violations(parts, stagger: float, joints=(), eps: float = 1e-6) -> list[tuple[str, str, float, float]]:
    """Pairs of butts of plates on either side of one seam that meet the seam off its ends
    closer than ``stagger`` (0 < d < stagger), or at one point off the block joints:
    (plate, plate, x, x). Butts are the plates' plane ends (the hull's ends are not)."""
    joint_set = np.array(sorted(float(j) for j in joints))
    bad = []
    for girth, below, above in seam_sides(parts).values():
        if not below or not above:
            continue  # the keel or the deck edge: no plate on the other side
        ranges = [_x_range(p) for p in below + above]
        start, stop = min(r[0] for r in ranges), max(r[1] for r in ranges)

        def butts(plates):
            out = []
            for p in plates:
                for plane in p.hull.butts:
                    if plane is not None and start + eps < plane.offset < stop - eps:
                        out.append((p.name, float(plane.offset)))
            return out

        for name_a, xa in butts(below):
            for name_b, xb in butts(above):
                d = abs(xa - xb)
                on_joint = len(joint_set) and np.min(np.abs(joint_set - xa)) <= eps
                if d < stagger - eps and not (d <= eps and on_joint):
                    bad.append((name_a, name_b, xa, xb))
    return sorted(set(bad))


@dataclass(frozen=True)
class ButtRule:
    """The butt rule for one plate as numbers: a new butt at x keeps it when it lies at least
    ``stagger`` from every butt in ``offsets`` (those of the plates across its seams that meet
    them off the seams' ends), or on one of them at a block joint. Hashable and small: the
    plan's workers check it (:func:`.planner._region_split`), and a plate's split is chosen
    once per rule."""

    offsets: tuple
    stagger: float
    joints: tuple
    eps: float = 1e-6

    def __call__(self, x: float) -> bool:
        on_joint = any(abs(j - x) <= self.eps for j in self.joints)
        for offset in self.offsets:
            d = abs(offset - x)
            if d < self.stagger - self.eps and not (d <= self.eps and on_joint):
                return False
        return True


def butt_rule(part, sides: dict, stagger: float, joints, eps: float = 1e-6) -> ButtRule:
    """:class:`ButtRule` of ``part`` in the plan whose :func:`seam_sides` are ``sides``: the
    butts of the plates across its seams that overlap it in x, where they meet the seam
    between its ends."""
    lo, hi = _x_range(part)
    offsets = set()
    for k, girth in enumerate(part.hull.girths):
        entry = sides.get(id(girth))
        if entry is None:
            continue
        _, below, above = entry
        others = below if k == 0 else above
        if not others:
            continue
        ranges = [_x_range(p) for p in below + above]
        start, stop = min(r[0] for r in ranges), max(r[1] for r in ranges)
        for other in others:
            a, b = _x_range(other)
            if b <= lo or a >= hi:
                continue
            offsets.update(plane.offset for plane in other.hull.butts
                           if plane is not None and start + eps < plane.offset < stop - eps)
    return ButtRule(tuple(sorted(float(o) for o in offsets)), float(stagger),
                    tuple(float(j) for j in (() if joints is None else joints)), eps)
