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
plus two staggers. The next column of plates from the end is merged the same way within each
merged end plate's strakes (its butt on the end plate's), and so on while a column has plates
to merge, up to half the strakes' plates: KVLCC2's flat of bottom, 27 mm wide at its loft's aft
end and 29 m amidships, left six strakes' second and third plates 0.53 and 0.94 m wide when
only end plates merged. A merged plate whose butts would lie further apart than
``stock.max_length`` is not merged.

Splits (the adaptive plan) keep the rules too: a new butt the stagger from the butts across
its plate's seams (:class:`ButtRule`), a new seam's ends the stagger from the seam ends that
the plates across its plate's butts bring there (:class:`SeamRule`): two strakes' new seams
joined across a butt, the butts on both sides in line, would make a cross joint.
:func:`cross_joints` finds the points where four plates meet.
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
    offsets = [stagger * (i % 2) for i in range(n_strakes)]
    butts = [strake_butts(x0, x1, stock.max_length, stagger, joints, offsets[i]) for i in range(n_strakes)]
    base = strake_butts(x0, x1, stock.max_length, stagger, joints, 0.0)
    # per end, per column of plates counted from it: {(lo, hi): the merged plate's inner butt};
    # of an even number of plates the aft end takes the middle butt
    aft, moved = _drop_strakes(0, butts, base, ends[0], (x0, x1), stock, stagger, joints, width_of) if base else (
        [], butts)
    # the fore end's butts stay clear of those the aft end's merges moved
    fore, _ = _drop_strakes(1, butts if len(base) == 1 else moved, base, ends[1], (x0, x1), stock, stagger, joints,
                            width_of) if base else ([], butts)
    if len(base) == 1 and aft and fore:  # two plates a strake: both ends' merged plates move its one butt
        aft, fore = _one_butt(aft[0], fore[0], stagger, joints)
    columns = {0: aft, 1: fore}
    plates = []
    for i in range(n_strakes):
        planes = [ends[0]] + list(butts[i]) + [ends[1]]
        for end, found in columns.items():
            for c, groups in enumerate(found):
                for (lo, hi), x_g in groups.items():
                    if lo <= i < hi:  # the group's plate replaces this strake's plate c from the end
                        planes[c + 1 if end == 0 else len(planes) - 2 - c] = x_g
        for j in range(len(planes) - 1):
            group = _group_at(columns, i, j, len(planes) - 1)
            if group is None:
                plates.append((i, i + 1, planes[j:j + 2], j + 1))
            elif group[0] == i:  # the merged plate once, in its lowest strake's place
                plates.append((group[0], group[1], planes[j:j + 2], j + 1))
    return plates


def _one_butt(aft: dict, fore: dict, stagger: float, joints) -> tuple[list, list]:
    """The columns ([aft], [fore]) of strakes of two plates whose merged end plates, {(lo, hi):
    butt x} at each end, share the one butt: strakes merged at both ends only as the same group,
    which then butts where the fore end put it, and merged plates side by side (across a seam)
    at different x unless no stagger is asked for or on a block joint; else the aft end's alone."""
    joint_set = {float(j) for j in joints}
    if any(a_lo < f_hi and f_lo < a_hi and (a_lo, a_hi) != (f_lo, f_hi) for a_lo, a_hi in aft for f_lo, f_hi in fore):
        return [aft], []
    both = {**aft, **fore}  # a group merged at both ends butts where the fore end put it
    for (lo, hi), x in both.items():
        beside = both.get(next(((a, b) for a, b in both if a == hi), None))
        if beside is not None and beside == x and stagger > 0.0 and x not in joint_set:
            return [aft], []
    return [{g: both[g] for g in aft}], [fore]


def _group_at(columns: dict, i: int, j: int, n_plates: int):
    for end, found in columns.items():
        c = j if end == 0 else n_plates - 1 - j
        if c < len(found):
            for lo, hi in found[c]:
                if lo <= i < hi:
                    return lo, hi
    return None


def _drop_strakes(end: int, butts: list, base: list, plane_end, extent: tuple, stock, stagger: float, joints,
                  width_of) -> tuple[list[dict], list]:
    """The merged plates of each column of plates counted from one end (0: aft, 1: fore),
    [{(lo seam, hi seam): x of its inner butt}], and each strake's butts with the merged
    plates' in place, while a column has any merged plates: the end plates
    first (:func:`_stealers`), then each next column's plates within the strakes merged in
    the column before (a seam that stops at a butt does not start again further from the
    end), up to half the strakes' plates (the aft end the middle butt of an even number). A
    merged plate's inner butt lies one stagger from the column's base butt, away from the
    middle (the strakes beside it butt at the base butt or one stagger inward), or two
    staggers inward when that one lies nearer than a stagger to a butt across one of its
    seams (the merged plate beside it took it), or on a block joint; one with no such place,
    or whose butts would lie further apart than the stock is long (an end plate's measured
    from the strakes' ``extent`` (x0, x1), not from a face's cut), is not merged. ``butts``:
    each strake's butts, those the other end's merges moved included."""
    joint_set = {float(j) for j in joints}
    plates = len(base) + 1
    found, parents = [], {(0, len(butts)): plane_end}
    x_end = extent[0] if end == 0 else extent[1]
    butts = [list(b) for b in butts]  # each strake's butts as the merges move them
    for c in range(max(1, plates // 2 if end == 0 else (plates - 1) // 2)):
        x_base = base[c] if end == 0 else base[-1 - c]
        # a merged plate's inner butt: the strakes beside it butt at x_base or x_base + stagger
        choices = [x_base] if x_base in joint_set else [
            x_base - stagger, x_base + (2.0 if end == 0 else -2.0) * stagger]
        groups = {}
        for (p_lo, p_hi), x_parent in sorted(parents.items()):
            own = {i: None if not butts[i] else _plate(end, x_parent, butts[i][c] if end == 0 else butts[i][-1 - c])
                   for i in range(p_lo, p_hi)}
            merged = _plate(end, x_parent, choices[0])
            for lo, hi in _stealers(range(p_lo, p_hi), own, merged, stock, width_of):
                groups[(lo, hi)] = x_parent
        if not groups:
            break
        chosen = {}
        column = c if end == 0 else -1 - c
        for (lo, hi), x_parent in sorted(groups.items()):
            # the butts across its two seams: its neighbours' own, or a merged plate's beside it
            across = [x for k in (lo - 1, hi) if 0 <= k < len(butts) for x in butts[k]]
            for x_g in choices:
                if stagger > 0.0 and any(abs(x_g - x) < stagger * (1.0 - 1e-9) and not (x == x_g and x in joint_set)
                                         for x in across):
                    continue  # a cross joint, or butts closer than the stagger, on one of its seams
                if abs(x_g - (x_end if c == 0 else x_parent)) > stock.max_length * (1.0 + 1e-9):
                    continue
                chosen[(lo, hi)] = x_g
                for i in range(lo, hi):
                    butts[i][column] = x_g
                break
        if not chosen:
            break
        found.append(chosen)
        parents = chosen
    return found, butts


def _plate(end: int, x_outer, x_inner) -> tuple:
    """A plate's planes (aft x, fore x) from its butt toward the end (x or None: the end) and its inner one."""
    return (x_outer, x_inner) if end == 0 else (x_inner, x_outer)


def _stealers(strakes: range, own_plates: dict, merged_plate: tuple, stock, width_of) -> list:
    """Seam ranges (lo, hi) of strakes among ``strakes`` whose plates merge (drop strakes):
    ``own_plates[i]``: strake i's plate (x, x), or None (no butt: it is not merged), for i in ``strakes``;
    ``merged_plate``: a merged plate's (x, x)."""
    def width(lo, hi):
        if hi - lo == 1:
            plate = own_plates[lo]
            return np.inf if plate is None else width_of(lo, hi, *plate)
        return width_of(lo, hi, *merged_plate)

    widths = {i: width(i, i + 1) for i in strakes}
    groups = [[i, i + 1] for i in strakes]  # seam ranges
    for _ in range(len(groups)):
        changed = False
        for g, (lo, hi) in enumerate(groups):
            w = widths[lo] if hi - lo == 1 else width(lo, hi)
            if w >= stock.min_width or w <= 0.0:
                continue  # wide enough, or the plate misses the surface
            sides = [k for k in (g - 1, g + 1) if 0 <= k < len(groups)]
            if not sides:
                continue
            narrow = {k: (widths[groups[k][0]] if groups[k][1] - groups[k][0] == 1 else width(*groups[k]))
                      for k in sides}
            k = min(sides, key=lambda s: (narrow[s], s))
            a, b = min(lo, groups[k][0]), max(hi, groups[k][1])
            if width(a, b) > stock.max_width:
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


def face_junctions(parts) -> tuple[float, ...]:
    """x of the planes where plates of two faces are cut together (each plate's
    ``hull.x_limits``; faces told apart by their surface, which the plan's own parts share
    per face): every strake of both faces butts there, so the plane is a block joint of the
    plan for its cost (a cross joint there is a block joint's). Unlike a listed block joint,
    the seam ends' stagger still holds there (:class:`SeamRule` exempts only
    ``plan.block_joints``): :mod:`.faceseams` lays the seams to run on across it or keep it."""
    faces: dict = {}
    for part in parts:
        hull = getattr(part, "hull", None)
        for x in getattr(hull, "x_limits", None) or ():
            if x is not None:
                faces.setdefault(float(x), set()).add(id(hull.surface))
    return tuple(sorted(x for x, on in faces.items() if len(on) > 1))


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
    (plate, plate, x, x). Butts are the plates' plane ends where another plate of the same
    side takes the seam on (not the hull's ends, nor where the seam stops at a plate that
    spans it: a drop strake's T)."""
    joint_set = np.array(sorted(float(j) for j in joints))
    bad = []
    for girth, below, above in seam_sides(parts).values():
        if not below or not above:
            continue  # the keel or the deck edge: no plate on the other side
        ranges = [_x_range(p) for p in below + above]
        start, stop = min(r[0] for r in ranges), max(r[1] for r in ranges)

        def butts(plates):
            ends = [(p.name, float(plane.offset)) for p in plates for plane in p.hull.butts if plane is not None]
            return [(name, x) for name, x in ends if start + eps < x < stop - eps
                    and any(other != name and abs(y - x) <= eps for other, y in ends)]

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


@dataclass(frozen=True)
class SeamRule:
    """The seam rule for one plate as numbers: a new seam along it (a girth split) keeps it
    when its ends on the plate's butts lie at least ``stagger`` from every seam end that the
    plates across those butts bring there (``ends``, model units; the plate's own corners and
    block joints left out). Two strakes' new seams that met at one butt would make a cross
    joint there (four plates at a point), the butts on either side of the joined seam in line."""

    ends: tuple
    stagger: float
    eps: float = 1e-6

    def __call__(self, points) -> bool:
        if not self.ends:
            return True
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        gaps = np.linalg.norm(points[:, None, :] - np.asarray(self.ends)[None, :, :], axis=2)
        return bool(gaps.min() >= self.stagger - self.eps)


@dataclass(frozen=True)
class YardRule:
    """Both rules of one plate: where a butt split may cut it (``butts``, by x) and where a
    girth split's seam may end (``seams``, by its end points)."""

    butts: ButtRule
    seams: SeamRule


def plate_corners(parts, result_of=None) -> tuple[np.ndarray, np.ndarray]:
    """The evaluated plates' region corners, stacked: (points (N, 3), owner index (N,) into
    ``parts``); plates without a region give none. ``result_of(part)``: its evaluated result
    (default ``part.hull.result``; the identity for a list of results)."""
    points, owners = [], []
    for k, part in enumerate(parts):
        result = getattr(part.hull, "result", None) if result_of is None else result_of(part)
        corners = ((getattr(result, "figures", None) or {}).get("region") or {}).get("corners")
        if corners:
            points.extend(corners)
            owners.extend([k] * len(corners))
    return np.asarray(points, dtype=np.float64).reshape(-1, 3), np.asarray(owners, dtype=np.int64)


def seam_rule(index: int, parts, corners: tuple, stagger: float, joints) -> SeamRule:
    """:class:`SeamRule` of ``parts[index]``: the corners (:func:`plate_corners` of ``parts``)
    of the other plates that lie on its butt planes, off block joints and off its own corners
    (its seams' ends, which plates across the butt share where a seam runs on), and near
    enough to its butt edge to matter: a point of that edge (an arc at most the plate's
    largest girth width W long between its two corners c1, c2 there) lies within
    ``stagger`` of an end e only if |e - c1| + |e - c2| <= W + 2 stagger. The rest (other
    strakes' seams on the same plane) would change the rule, and the plan's choice of the
    plate's split would be made again, whenever a plate far away split."""
    points, owners = corners
    part = parts[index]
    own = points[owners == index]
    region = (getattr(getattr(part.hull, "result", None), "figures", None) or {}).get("region") or {}
    width = region.get("width")
    near = 1e-3 * stagger
    ends = []
    for plane in part.hull.butts:
        if plane is None or any(abs(plane.offset - j) <= near for j in (joints or ())):
            continue
        on = points[(owners != index) & (np.abs(plane.signed(points)) <= near)]  # (M, 3)
        mine = own[np.abs(plane.signed(own)) <= near] if len(own) else own
        keep = np.ones(len(on), dtype=bool)
        if len(own):
            keep &= np.linalg.norm(on[:, None] - own[None], axis=2).min(axis=1) > near
        if width is not None and len(mine) == 2:
            keep &= np.linalg.norm(on[:, None] - mine[None], axis=2).sum(axis=1) <= float(width) + 2.0 * stagger
        ends.extend(tuple(float(v) for v in p) for p in on[keep])
    return SeamRule(tuple(sorted(set(ends))), float(stagger))


def seam_end_violations(parts, stagger: float, joints=()) -> list[tuple[str, tuple, float]]:
    """Seam ends that meet a butt within ``stagger`` of a seam end that a plate across the butt
    brings there (:class:`SeamRule`, off block joints): (plate, its corner, the distance), the
    distance below ``stagger`` and above a thousandth of it (seam ends that meet are the
    plate's own corners to the rule: :func:`cross_joints` finds those). A plan that keeps the
    rule has none."""
    corners = plate_corners(parts)
    points, owners = corners
    bad = []
    for k, part in enumerate(parts):
        rule = seam_rule(k, parts, corners, stagger, joints)
        if not rule.ends:
            continue
        ends = np.asarray(rule.ends)
        for corner in points[owners == k]:
            if not any(plane is not None and abs(plane.signed(corner)) <= 1e-3 * stagger for plane in part.hull.butts):
                continue
            gap = float(np.linalg.norm(ends - corner, axis=1).min())
            if gap < stagger - rule.eps:
                bad.append((part.name, tuple(float(v) for v in corner), gap))
    return sorted(bad)


def cross_joints(parts, joints=(), reach: float = 1.0, result_of=None) -> list[tuple[tuple, tuple]]:
    """Points where four or more plates meet (a cross joint: two seams and two butts in line),
    off the block joints: [(point (3,), plate names)], from the plates' region corners
    within ``reach`` (model units) of each other; ``result_of`` as :func:`plate_corners`."""
    from scipy.spatial import cKDTree

    points, owners = plate_corners(parts, result_of)
    if not len(points):
        return []
    found = {}
    for hits in cKDTree(points).query_ball_point(points, r=reach):
        names = tuple(sorted({parts[owners[h]].name for h in hits}))
        where = points[min(hits)]
        if len(names) >= 4 and not any(abs(where[0] - j) <= reach for j in (joints or ())):
            found[min(hits)] = (tuple(float(v) for v in where), names)
    return [found[k] for k in sorted(found)]
