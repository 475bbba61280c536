"""Slivers that a face's trim cuts from a yard layout's plates, merged into a neighbour.

A trimmed face (KCS's flat of bottom keeps 1128 of its 2622 m2) is laid out in strakes and
butts over its whole parameter rectangle; where the trim line runs across a strake the plate
it crosses keeps only a corner, and the shop would cut a sliver (KCS: 87 to 855 mm wide where
the stock's least width is 1 m). Such a plate, narrower inside the trim than
``stock.min_width`` (its widest column inside the trim), is merged with a plate beside it on
the face, as a yard lets a strake run out:

- along its strake, the butt between them dropped, when the merged plate's part inside the
  trim stays within ``stock.max_length``;
- across a seam, into the plate of the next strake it shares the most length with (the seam
  between them ends at a butt: a drop strake): the merged plate keeps that plate's butts,
  and the sliver's strake's plates on either side move their butts to meet them.

The merge is taken whose merged plate is narrowest, within ``stock.max_width`` and
``stock.max_length`` (each measured inside the trim, where the shop cuts it), that leaves
no other plate of the face newly narrower than ``stock.min_width`` and adds no pair of butts
closer than the stagger on a seam (:func:`butt_conflicts`), until no sliver has such a merge.
A sliver left is one that fits nowhere beside it (KCS's flat of bottom narrowing to its keel
line over 30 m at the bow: two plates' length of a strake that has no neighbour there).

Plates are (lo seam, hi seam, [x or None, x or None], B number) as :func:`.yardrules.yard_layout`
gives them; x in model units, None the face's end.
"""

from __future__ import annotations

from dataclasses import dataclass

EPS = 1e-9  # relative slack of the stock limits, as the plan's own checks use


@dataclass(frozen=True)
class Merge:
    """One merge: the sliver's (lo, hi, x, x) and B number, the plate it went into (the same),
    its width inside the trim and the merged plate's (model units), and how (along, across)."""

    sliver: tuple
    into: tuple
    width: float
    merged_width: float
    how: str


def merge_slivers(plates: list, size_of, stock, stagger: float, joints=(), extent=(None, None)) -> tuple[list, list]:
    """The face's plates with its slivers merged, and the merges made ([:class:`Merge`]).

    ``size_of(lo, hi, a, b) -> (length, width)``: the part of the region between seams lo..hi
    and planes a, b (x or None) inside the face's trim (model units; zeros when outside);
    ``extent``: (x0, x1) of the face's ends (None in a plate's planes)."""
    x0, x1 = (float("-inf") if extent[0] is None else extent[0]), (float("inf") if extent[1] is None else extent[1])
    sizes: dict = {}

    def size(plate) -> tuple:
        key = (plate[0], plate[1], plate[2][0], plate[2][1])
        if key not in sizes:
            sizes[key] = tuple(float(v) for v in size_of(*key))
        return sizes[key]

    def width(plate) -> float:
        return size(plate)[1]

    plates = [(lo, hi, list(xs), j) for lo, hi, xs, j in plates]
    merges = []
    while True:
        slivers = sorted((p for p in plates if 0.0 < width(p) < stock.min_width), key=lambda p: (width(p), p[0]))
        taken = None
        before = butt_conflicts(plates, width, (x0, x1), stagger, joints)
        for sliver in slivers:
            options = []
            for how, merged, into, layout in _options(sliver, plates, size, (x0, x1)):
                length, merged_width = size(merged)
                if merged_width > stock.max_width * (1.0 + EPS) or length > stock.max_length * (1.0 + EPS):
                    continue
                changed = [p for p in layout if p is not merged and p not in plates]
                if any(size(p)[0] > stock.max_length * (1.0 + EPS) for p in changed):
                    continue
                if any(0.0 < width(p) < stock.min_width for p in changed):
                    continue  # a neighbour's butt moved so far that it became a sliver itself
                if not butt_conflicts(layout, width, (x0, x1), stagger, joints) <= before:
                    continue
                options.append((merged_width, how, merged, into, layout))
            if options:
                merged_width, how, merged, into, layout = min(options, key=lambda o: (o[0], o[1], o[2][0]))
                taken = Merge(_key(sliver), _key(into), width(sliver), merged_width, how)
                plates = layout
                break
        if taken is None:
            return sorted(plates, key=lambda p: (p[0], p[1], _x(p[2][0], x0))), merges
        merges.append(taken)


def _key(plate) -> tuple:
    return plate[0], plate[1], plate[2][0], plate[2][1], plate[3]


def _x(value, default: float) -> float:
    return default if value is None else value


def _overlap(a, b, extent) -> float:
    lo = max(_x(a[2][0], extent[0]), _x(b[2][0], extent[0]))
    hi = min(_x(a[2][1], extent[1]), _x(b[2][1], extent[1]))
    return hi - lo


def _options(sliver, plates: list, size, extent) -> list:
    """(how, merged plate, the plate it went into, the face's plates after) of each merge of
    ``sliver`` with a plate beside it that has steel inside the trim."""
    lo, hi, (a, b), _ = sliver
    out = []
    for other in plates:
        if other is sliver or size(other)[1] <= 0.0:
            continue
        if (other[0], other[1]) != (lo, hi):
            continue
        if a is not None and other[2][1] == a:  # along the strake, the butt between them dropped
            merged = (lo, hi, [other[2][0], b], other[3])
        elif b is not None and other[2][0] == b:
            merged = (lo, hi, [a, other[2][1]], other[3])
        else:
            continue
        out.append(("along", merged, other, [p for p in plates if p is not sliver and p is not other] + [merged]))
    across = [p for p in plates if (p[1] == lo or p[0] == hi) and size(p)[1] > 0.0 and _overlap(p, sliver, extent) > 0.0]
    if across:
        for side in (lo, hi):
            beside = [p for p in across if (p[1] == lo if side == lo else p[0] == hi)]
            if not beside:
                continue
            into = max(beside, key=lambda p: _overlap(p, sliver, extent))
            layout = _across(sliver, into, plates, size, extent)
            if layout is not None:
                out.append(("across", layout[-1], into, layout))
    return out


def _across(sliver, into, plates: list, size, extent):
    """The face's plates after ``sliver`` merged across a seam into ``into`` (the merged plate
    last), or None when the sliver's strake cannot meet the merged plate's butts: a moved butt
    would pass its plate's other butt, or steel of the sliver's strake would be left
    uncovered."""
    lo, hi, (a, b), _ = sliver
    qa, qb = into[2]
    merged = (min(lo, into[0]), max(hi, into[1]), [qa, qb], into[3])
    layout = [p for p in plates if p is not sliver and p is not into]
    for end, (old, new) in enumerate(((a, qa), (b, qb))):
        if old == new:
            continue
        moved = None if old is None else _move_butt(layout, range(lo, hi), old, new, size, extent)
        if moved is None or moved is layout:
            # nothing meets the sliver there: the strake's part the merged plate leaves must hold no steel
            inward = new is not None and (old is None or (new > old if end == 0 else new < old))
            if moved is None and old is not None:
                return None
            if inward and size((lo, hi, [old, new] if end == 0 else [new, old], None))[1] > 0.0:
                return None
            continue
        layout = moved
    return layout + [merged]


def _move_butt(plates: list, strakes, old: float, new, size, extent):
    """The plates with the butt at ``old`` of ``strakes`` moved to ``new`` (x or None: the
    face's end), and of every strake a plate so moved spans (its neighbours along those
    strakes move with it): the same list when none lies there, None when a plate with steel
    would vanish (a plate without steel that would is dropped)."""
    strakes = set(strakes)
    while True:
        hit = [p for p in plates if old in p[2] and any(p[0] <= i < p[1] for i in strakes)]
        wider = {i for p in hit for i in range(p[0], p[1])} - strakes
        if not wider:
            break
        strakes |= wider
    if not hit:
        return plates
    out = []
    for p in plates:
        if not any(p is h for h in hit):
            out.append(p)
            continue
        xa, xb = (new if x == old else x for x in p[2])
        if _x(xb, extent[1]) <= _x(xa, extent[0]):
            if size(p)[1] > 0.0:
                return None
            continue
        out.append((p[0], p[1], [xa, xb], p[3]))
    return out


def butt_conflicts(plates: list, width, extent, stagger: float, joints=()) -> set:
    """Pairs of butts that meet a seam from either side closer than ``stagger`` (a cross joint
    when they coincide off the block ``joints``): {(seam, x below, x above)}. A butt is where
    two plates with steel (``width(plate) > 0``) of one side meet along it; a seam is where
    plates with steel lie on both sides (a strake run out, or merged across it, has none)."""
    if stagger <= 0.0:
        return set()
    joint_set = {float(j) for j in joints}
    steel = [p for p in plates if width(p) > 0.0]
    found = set()
    for seam in {p[1] for p in steel} & {p[0] for p in steel}:
        sides = ([p for p in steel if p[1] == seam], [p for p in steel if p[0] == seam])
        spans = [[(_x(p[2][0], extent[0]), _x(p[2][1], extent[1])) for p in side] for side in sides]
        butts = [sorted({s1 for s0, s1 in side for t0, t1 in side if s1 == t0}) for side in spans]

        def on_seam(x, other):
            return any(s0 <= x <= s1 for s0, s1 in other)

        for xb in butts[0]:
            if not on_seam(xb, spans[1]):
                continue
            for xt in butts[1]:
                if abs(xb - xt) < stagger * (1.0 - 1e-9) and on_seam(xt, spans[0]) and not (
                        xb == xt and xb in joint_set):
                    found.add((seam, xb, xt))
    return found
