"""Layout of a steel plate's marks and texts (mm): what the DXF and the shop drawing draw.

Marks are clipped to the plate (shapely); every text is a rotated box that must lie
inside the net outline, clear of the other texts and of every line. Heights scale with
the plate (between the configured min and max); a text that cannot be placed is left out
and named in the findings, never drawn across an edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import LineString, MultiLineString, Polygon

from flatten.rectangle import minimum_rectangle

CHAR_WIDTH = 1.0  # box width per character, in text heights (conservative for TXT / monospace fonts)
LINE_GAP = 1.5  # baseline to baseline, in text heights


@dataclass(frozen=True)
class Text:
    """A single-line text centred at ``at`` (mm), rotated ``angle`` degrees, on a mark kind
    ('text', 'edge', 'bend', 'frame'); ``names``: the point (mm) on the line of its kind it
    names, where a drawing that writes it further away starts its leader (None: none)."""

    kind: str
    text: str
    at: tuple[float, float]
    height: float
    angle: float
    names: tuple[float, float] | None = None

    def box(self) -> Polygon:
        return Polygon(text_corners([self])[0])


@dataclass
class Layout:
    """Everything drawn on one plate, in mm.

    cut : (N, 2) closed cut contour; net : (M, 2) net line when an allowance is cut, else None
    lines : [(kind, (K, 2) polyline)], kind in 'bend', 'frame'
    texts : placed texts; findings : what could not be placed, and skipped frames
    frame_names : the frame lines' names ('FR 92500'), in the order of the 'frame' lines
    """

    cut: np.ndarray
    net: np.ndarray | None
    lines: list = field(default_factory=list)
    texts: list = field(default_factory=list)
    findings: list = field(default_factory=list)
    text_height: float = 0.0
    frame_names: list = field(default_factory=list)  # the name of each 'frame' line, in their order

    def extents(self) -> tuple[np.ndarray, np.ndarray]:
        pts = [self.cut] + [line for _, line in self.lines]
        allp = np.vstack(pts + [text_corners(self.texts).reshape(-1, 2)])
        return allp.min(axis=0), allp.max(axis=0)


def text_corners(texts: list[Text]) -> np.ndarray:
    """Corners (T, 4, 2) of the rectangles the one-line texts occupy (centre-aligned, CHAR_WIDTH
    heights a character, 1.3 heights tall, turned by each text's angle about its centre), mm.
    The floats of a shapely box turned by shapely.affinity.rotate, for all texts at once."""
    at = np.array([t.at for t in texts], dtype=float).reshape(-1, 2)
    height = np.array([t.height for t in texts], dtype=float)
    half_w = CHAR_WIDTH * height * np.array([max(len(t.text), 1) for t in texts], dtype=float) / 2
    half_h = 1.3 * height / 2
    x = np.stack([at[:, 0] + half_w, at[:, 0] + half_w, at[:, 0] - half_w, at[:, 0] - half_w], axis=1)
    y = np.stack([at[:, 1] - half_h, at[:, 1] + half_h, at[:, 1] + half_h, at[:, 1] - half_h], axis=1)
    # math's cos and sin, as shapely takes them (numpy's vector kernels may differ by an ulp)
    cos_sin = np.array([(math.cos(t.angle * math.pi / 180.0), math.sin(t.angle * math.pi / 180.0)) for t in texts],
                       dtype=float).reshape(-1, 2)
    cos_sin[np.abs(cos_sin) < 2.5e-16] = 0.0
    c, s = cos_sin[:, :1], cos_sin[:, 1:]
    x0, y0 = at[:, :1], at[:, 1:]
    x_off = x0 - x0 * c + y0 * s
    y_off = y0 - x0 * s - y0 * c
    return np.stack([c * x + -s * y + x_off, s * x + c * y + y_off], axis=-1)


def block_texts(lines: list[str], at, height: float, angle: float, kind: str = "text") -> list[Text]:
    """A block of lines centred at ``at``, first line on top (as read at ``angle``)."""
    a = np.radians(angle)
    down = np.array([np.sin(a), -np.cos(a)])
    offsets = (np.arange(len(lines)) - (len(lines) - 1) / 2) * LINE_GAP * height
    return [Text(kind, t, tuple(np.asarray(at) + o * down), height, angle) for t, o in zip(lines, offsets)]


def readable(angle: float) -> float:
    """The same direction, turned so that text reads left to right or bottom to top."""
    angle = (angle + 180.0) % 360.0 - 180.0
    if angle > 90.0 + 1e-9:
        angle -= 180.0
    elif angle <= -90.0 + 1e-9:
        angle += 180.0
    return angle


def _readable(angles: np.ndarray) -> np.ndarray:
    """:func:`readable` of every angle (degrees, any shape)."""
    angles = (np.asarray(angles, dtype=float) + 180.0) % 360.0 - 180.0
    return np.where(angles > 90.0 + 1e-9, angles - 180.0, np.where(angles <= -90.0 + 1e-9, angles + 180.0, angles))


def _axes(angle, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors (n, 2) along the width and the height of rectangles turned by angle
    degrees (a number or (n,))."""
    a = np.radians(np.broadcast_to(np.asarray(angle, dtype=float), (n,)))
    c, s = np.cos(a), np.sin(a)
    return np.stack([c, s], axis=1), np.stack([-s, c], axis=1)


def _corners_on(centres: np.ndarray, width: float, height: float, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Corners (N, 4, 2) of width x height rectangles centred at centres (N, 2) with axes
    u, v (N, 2) each (row by row: any subset of rows gives the same corners)."""
    corners = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], dtype=float) * [width / 2, height / 2]
    offsets = corners[None, :, :1] * u[:, None, :] + corners[None, :, 1:] * v[:, None, :]  # (N, 4, 2)
    return centres[:, None, :] + offsets


def free_reach(centres: np.ndarray, direction: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Half-length (P,) of the longest segment centred at each of centres (P, 2) along the unit
    vector direction (2,) that no segment of segments (S, 2, 2) crosses (inf when none is in
    the way; segments along the direction are left out, so it is never an underestimate).

    A box whose middle line along direction is longer than twice this meets one of the
    segments inside (mm, as the inputs)."""
    centres = np.asarray(centres, dtype=float)
    normal = np.array([-direction[1], direction[0]])
    cn, cd = centres @ normal, centres @ direction
    an, bn = segments[:, 0] @ normal, segments[:, 1] @ normal
    ad, bd = segments[:, 0] @ direction, segments[:, 1] @ direction
    across = an != bn
    an, bn, ad, bd = an[across], bn[across], ad[across], bd[across]
    # a line along direction through a centre meets a segment iff the centre's normal
    # coordinate is within the segment's: sorted, each segment meets a run of centres
    order = np.argsort(cn, kind="stable")
    first = np.searchsorted(cn[order], np.minimum(an, bn), "left")
    counts = np.searchsorted(cn[order], np.maximum(an, bn), "right") - first
    seg = np.repeat(np.arange(len(an)), counts)
    p = order[np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts - first, counts)]
    s = np.clip((cn[p] - an[seg]) / (bn[seg] - an[seg]), 0.0, 1.0)
    reach = np.full(len(centres), np.inf)
    np.minimum.at(reach, p, np.abs(ad[seg] + s * (bd[seg] - ad[seg]) - cd[p]))
    return reach


def _segments(rings: list[np.ndarray]) -> np.ndarray:
    """The segments (S, 2, 2) of polylines (K, 2)."""
    parts = [np.stack([r[:-1], r[1:]], axis=1) for r in (np.asarray(r, dtype=float) for r in rings) if len(r) >= 2]
    return np.concatenate(parts) if parts else np.zeros((0, 2, 2))


class Placer:
    """Places text boxes one after the other inside ``room`` (a polygon), clear (by
    ``clearance``) of ``lines`` and of what it placed before."""

    def __init__(self, room: Polygon, lines: list[np.ndarray], clearance: float):
        self.room = room
        shapely.prepare(room)
        self.clearance = clearance
        geoms = [LineString(line) for line in lines if len(line) >= 2]
        self.obstacles = MultiLineString(geoms) if geoms else None
        if self.obstacles is not None:
            shapely.prepare(self.obstacles)
        # what a box may not cross: the room's edges and the lines, (S, 2, 2)
        rings = [room.exterior.coords, *(r.coords for r in room.interiors)]
        self.segments = _segments([np.asarray(r) for r in rings] + [line for line in lines if len(line) >= 2])
        self._corners: list[np.ndarray] = []  # the placed boxes' corners (4, 2): polygons only when asked
        self._boxes: list[Polygon] = []
        self._reach_of, self._reach = None, {}
        self.placed = np.zeros((0, 8))  # the placed boxes, as self.boxes: centre, unit axes, half sides
        self._radius = np.zeros(0)

    @property
    def boxes(self) -> list[Polygon]:
        """The placed boxes (not grown), in the order placed."""
        self._boxes += [Polygon(c) for c in self._corners[len(self._boxes):]]
        return self._boxes

    def reach(self, centres: np.ndarray, angle: float, count: int | None = None) -> np.ndarray:
        """Free half-lengths (count,) along the direction angle (degrees) at the first count
        centres (all by default): a box whose grown middle line along it is longer than twice
        this crosses the room's edge or a line (:func:`free_reach`); what was placed is not
        counted. Kept per direction for the last centres asked, and only as far as asked:
        each centre's reach is its own, so a longer prefix only adds the new ones."""
        count = len(centres) if count is None else count
        if centres is not self._reach_of:
            self._reach_of, self._reach = centres, {}
        key = round(angle % 180.0, 9) % 180.0
        known = self._reach.get(key, np.zeros(0))
        if len(known) < count:
            a = np.radians(angle)
            more = free_reach(centres[len(known):count], np.array([np.cos(a), np.sin(a)]), self.segments)
            known = self._reach[key] = np.concatenate([known, more])
        return known[:count]

    def place(self, centres: np.ndarray, width: float, height: float, angle) -> int | None:
        """Index of the first centre whose box (grown by the clearance) is free; the box is
        taken. None when no centre fits."""
        angle = np.broadcast_to(np.asarray(angle, dtype=float), (len(centres),))
        wide, high = width + 2 * self.clearance, height + 2 * self.clearance
        u_all, v_all = _axes(angle, len(centres))
        # only the first free centre is wanted: test them in growing chunks (the first few
        # usually fit), each test only where the cheaper ones passed: corners in the room
        # (points: this rules out nearly all that do not fit), placed boxes by circumcircles
        # and separating axes (numpy: shapely only where round-off decides); the exact tests
        # on polygons decide the rest
        start, size = 0, 16
        while start < len(centres):
            stop = min(start + size, len(centres))
            chunk, u, v = centres[start:stop], u_all[start:stop], v_all[start:stop]
            corners = _corners_on(chunk, wide, high, u, v)
            idx = np.flatnonzero(shapely.contains_xy(self.room, corners[..., 0], corners[..., 1]).all(axis=1))
            idx, near = self._apart(chunk, u, v, wide, high, idx)
            if idx.size:
                grown = shapely.polygons(corners[idx])
                fits = self._static(grown)
                fits = self._settle(grown, fits, near)
                if fits.any():
                    i = start + int(idx[np.argmax(fits)])
                    self._take(centres[i], u_all[i], v_all[i], width, height)
                    return i
            start, size = stop, 4 * size
        return None

    def place_each(self, jobs: list, head: int = 256, first: int = 2):
        """:meth:`place` of every job (centres (N, 2), width, height, angles (N,)) in turn,
        yielding what it returns: the same indices, and the same boxes taken. The tests that
        do not depend on the boxes placed before (corners in the room for the first head
        centres of each job, the exact room and line tests for the first few whose corners
        are in) run for all jobs at once; the rest when the job's turn comes (a generator:
        the caller may place more boxes between two jobs). A job none of those fit goes on
        with :meth:`place` on its centres after them."""
        if not jobs:
            return
        c = self.clearance
        heads = np.array([min(head, len(job[0])) for job in jobs])
        ends = np.cumsum(heads)
        centres = np.concatenate([job[0][:k] for job, k in zip(jobs, heads)])
        angles = np.concatenate([np.broadcast_to(np.asarray(job[3], dtype=float), (len(job[0]),))[:k]
                                 for job, k in zip(jobs, heads)])
        half = np.repeat([[0.5 * (job[1] + 2 * c), 0.5 * (job[2] + 2 * c)] for job in jobs], heads, axis=0)  # (N, 2)
        u, v = _axes(angles, len(centres))
        signs = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], dtype=float)
        offsets = signs[None] * half[:, None]  # (N, 4, 2): as _corners_on's, row by row
        corners = centres[:, None, :] + (offsets[..., :1] * u[:, None, :] + offsets[..., 1:] * v[:, None, :])
        inside = shapely.contains_xy(self.room, corners[..., 0], corners[..., 1]).all(axis=1)
        # the first few centres of each job with their corners in, and the exact tests on them
        job_of = np.repeat(np.arange(len(jobs)), heads)
        passed = np.cumsum(inside)
        rank = passed - np.concatenate([[0], passed[ends - 1]])[job_of]  # of a passer within its job, from 1
        tried = np.flatnonzero(inside & (rank <= first))
        grown = shapely.polygons(corners[tried])
        static = self._static(grown)
        for j, (job, k) in enumerate(zip(jobs, heads)):
            lo = ends[j] - k
            mine = np.flatnonzero((tried >= lo) & (tried < ends[j]))  # positions in tried
            found = None
            for t in mine[static[mine]]:
                i = tried[t]
                wide, high = 2 * half[i]
                idx, near = self._apart(centres[i:i + 1], u[i:i + 1], v[i:i + 1], wide, high, np.zeros(1, int))
                if idx.size and self._settle(grown[t:t + 1], np.ones(1, bool), near)[0]:
                    found = int(i - lo)
                    self._take(centres[i], u[i], v[i], job[1], job[2])
                    break
            # none of those: the job goes on after the last one tried
            rest = int(tried[mine[-1]] - lo + 1) if len(mine) == first else int(k)
            if found is None and rest < len(job[0]):
                angle = np.broadcast_to(np.asarray(job[3], dtype=float), (len(job[0]),))
                r = self.place(job[0][rest:], job[1], job[2], angle[rest:])
                found = None if r is None else rest + r
            yield found

    def _apart(self, chunk: np.ndarray, u: np.ndarray, v: np.ndarray, wide: float, high: float,
               idx: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Of the boxes wide x high at chunk[idx] (axes u, v), those numpy does not find
        overlapping a placed one, and (len(kept), M) the placed ones only round-off decides
        about (None: none)."""
        near = None
        if len(self.placed) and idx.size:
            # only boxes whose circumcircles meet can meet: most are far apart
            d = chunk[idx, None] - self.placed[None, :, :2]  # (N, M, 2)
            gap = np.hypot(d[..., 0], d[..., 1]) - self._radius - 0.5 * np.hypot(wide, high)
            rows = np.flatnonzero((gap <= 1e-6 * (wide + high)).any(axis=1))
            if rows.size:
                sep = np.full(gap.shape, np.inf)
                sep[rows] = _separation(chunk[idx[rows]], u[idx[rows]], v[idx[rows]], (0.5 * wide, 0.5 * high),
                                        self.placed)
                eps = 1e-9 * (np.abs(chunk).max() + np.abs(self.placed[:, :2]).max() + wide + high)
                keep = ~(sep < -eps).any(axis=1)
                idx, near = idx[keep], np.abs(sep[keep]) <= eps
        return idx, near

    def _static(self, grown: np.ndarray) -> np.ndarray:
        """Whether each grown box (polygons) lies in the room and meets no line (shapely)."""
        fits = shapely.contains(self.room, grown)
        if self.obstacles is not None:  # the prepared geometry first: only then is it used
            fits[fits] = ~shapely.intersects(self.obstacles, grown[fits])
        return fits

    def _settle(self, grown: np.ndarray, fits: np.ndarray, near: np.ndarray | None) -> np.ndarray:
        """fits, less the grown boxes shapely finds meeting a placed box of the nearly
        touching pairs near."""
        if near is not None and near.any():
            rows, cols = np.nonzero(near & fits[:, None])
            hit = shapely.intersects(grown[rows], np.array(self.boxes)[cols])
            fits = fits.copy()
            fits[rows[hit]] = False
        return fits

    def _take(self, centre: np.ndarray, u: np.ndarray, v: np.ndarray, width: float, height: float) -> None:
        """Place the box width x height at centre (2,) with axes u, v (2,)."""
        self._corners.append(_corners_on(centre[None], width, height, u[None], v[None])[0])
        taken = [*centre, *u, *v, 0.5 * width, 0.5 * height]
        self.placed = np.vstack([self.placed, taken])
        self._radius = np.hypot(self.placed[:, 6], self.placed[:, 7])  # circumradii (M,)


def _separation(centres: np.ndarray, u: np.ndarray, v: np.ndarray, half: tuple[float, float],
                placed: np.ndarray) -> np.ndarray:
    """(N, M): how far apart (mm) rectangles (centres, unit axes u, v (N, 2), half sides)
    and the placed ones (M, 8: centre, unit axes, half sides) are along the axis that
    separates them best (separating axes of both); negative: they overlap that deep."""
    n = len(centres)
    pc, pw, ph = placed[:, 0:2], placed[:, 6], placed[:, 7]
    axes, paxes = np.concatenate([u, v]), np.concatenate([placed[:, 2:4], placed[:, 4:6]])  # (2N, 2), (2M, 2)
    cross = np.abs(axes @ paxes.T)  # (2N, 2M): u.pu u.pv / v.pu v.pv
    uu, uv, vu, vv = cross[:n, :len(pc)], cross[:n, len(pc):], cross[n:, :len(pc)], cross[n:, len(pc):]
    mine = np.abs(axes @ pc.T - (axes * np.concatenate([centres, centres])).sum(axis=1)[:, None])  # (2N, M)
    theirs = np.abs((paxes * np.concatenate([pc, pc])).sum(axis=1) - centres @ paxes.T)  # (N, 2M)
    return np.maximum(np.maximum(mine[:n] - (half[0] + pw * uu + ph * uv), mine[n:] - (half[1] + pw * vu + ph * vv)),
                      np.maximum(theirs[:, :len(pc)] - (pw + half[0] * uu + half[1] * vu),
                                 theirs[:, len(pc):] - (ph + half[0] * uv + half[1] * vv)))


def inscribed_radius(plate: Polygon, relative: float = 0.05) -> float:
    """The radius (mm) of the largest circle inside the plate, to ``relative`` of the
    plate's mean width 2 area / perimeter, which lies between the radius and twice it on a
    convex plate (so within 5-10 % of the radius; 0.6 % on the strake bench's plates). It
    only scales the texts (their fit is tested exactly). GEOS refines its grid down to the
    tolerance, and along a long strip nearly every cell of the middle stays a candidate: a
    tolerance tied to the width rather than to the square root of the area keeps a strip's
    cost down (an 8 m x 0.35 m plate: 17 mm, 1.7 ms, against 1.7 mm, 7 ms). The outline is
    simplified first to a tenth of that tolerance (it lies within that of the outline, so
    the radius moves by no more; the traced outline's hundreds of vertices, 0.05 mm apart
    from its chords, cost GEOS half the time)."""
    width = 2.0 * plate.area / max(plate.length, 1e-300)
    return shapely.maximum_inscribed_circle(plate.simplify(0.1 * relative * width), relative * width).length


def heights(preferred: float, smallest: float) -> list[float]:
    """Preferred height, then smaller ones down to the smallest."""
    out = [preferred]
    while out[-1] * 0.8 > smallest:
        out.append(out[-1] * 0.8)
    if out[-1] > smallest:
        out.append(smallest)
    return out


def grid_points(room: Polygon, obstacles=None, n: int = 60) -> tuple[np.ndarray, np.ndarray]:
    """Points (P, 2) of a grid over the room, inside it, the most clear (far from its edge
    and from the obstacles, lines: the middle of the largest free area) first, and that
    clearance (P,), descending (the same floats as shapely.distance)."""
    x0, y0, x1, y1 = room.bounds
    xs, ys = np.linspace(x0, x1, n + 2)[1:-1], np.linspace(y0, y1, n + 2)[1:-1]
    pts = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    pts = pts[shapely.contains_xy(room, pts[:, 0], pts[:, 1])]  # points only for those inside
    lines = [np.asarray(room.exterior.coords)]
    lines += [np.asarray(g.coords) for g in getattr(obstacles, "geoms", [obstacles]) if obstacles is not None]
    # no point is farther from the edge than the largest inscribed circle's radius, which
    # is at most the mean width 2 area / perimeter on a convex room (a guess: a point
    # with nothing that near is measured against every segment)
    depth = line_distance(pts, lines, 0.25 * room.area / max(room.exterior.length, 1e-300))
    order = np.argsort(-depth, kind="stable")
    return pts[order], depth[order]


def _to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances (...) from points p to segments a-b (all (..., 2)), by GEOS's formula
    (Distance::pointToSegment) step by step: the same floats as shapely.distance."""
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    ax, ay = p[..., 0] - a[..., 0], p[..., 1] - a[..., 1]
    bx, by = p[..., 0] - b[..., 0], p[..., 1] - b[..., 1]
    length2 = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        r = (ax * dx + ay * dy) / length2
        out = np.abs(((a[..., 1] - p[..., 1]) * dx - (a[..., 0] - p[..., 0]) * dy) / length2) * np.sqrt(length2)
    out = np.where(r >= 1.0, np.sqrt(bx * bx + by * by), out)
    return np.where((r <= 0.0) | (length2 == 0.0), np.sqrt(ax * ax + ay * ay), out)


def line_distance(points: np.ndarray, lines: list[np.ndarray], reach: float) -> np.ndarray:
    """Distance (P,) from each of points (P, 2) to the nearest of the polylines (K, 2) (inf
    when there is none), the same floats as shapely.distance.

    reach (mm, > 0) only steers the work: square cells of that side sort the points, and
    each segment is measured from the points of the cells within reach of its bounding
    box (a sweep like :func:`free_reach`'s); the points with none of them within reach
    try again with twice the reach, until most segments would be measured from each
    point: then GEOS measures them all (its loop is quicker than numpy's per pair)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    lines = [np.asarray(line, dtype=float) for line in lines if len(line) >= 2]
    segments = _segments(lines)
    out = np.full(len(points), np.inf)
    if not len(points) or not len(segments):
        return out
    todo = np.arange(len(points))
    bottom, top = segments.min(axis=1), segments.max(axis=1)  # the segments' boxes (S, 2)
    side = max(float(reach), 1e-9 * (float(np.abs(points).max()) + float(np.abs(segments).max())))
    while todo.size:
        # pairs: beyond len(todo) S / 8, GEOS measures them all quicker (and one cell holds
        # all when side is large: at most S (segment, cell) pairs)
        limit = max(len(todo) * len(segments) // 8, len(segments))
        pairs = _pairs(points[todo], bottom, top, side, limit)
        if pairs is None:  # cells far smaller than the segments: larger ones
            side *= 2.0
            continue
        p, seg = pairs
        if len(p) > len(todo) * len(segments) // 8:
            everything = shapely.multilinestrings([LineString(line) for line in lines])
            out[todo] = shapely.distance(shapely.points(points[todo]), everything)
            break
        near = np.full(len(todo), np.inf)
        np.minimum.at(near, p, _to_segment(points[todo[p]], segments[seg, 0], segments[seg, 1]))
        done = near <= side  # the segments left out are farther than that
        out[todo[done]] = near[done]
        todo, side = todo[~done], 2.0 * side
    return out


def _pairs(points: np.ndarray, bottom: np.ndarray, top: np.ndarray, side: float,
           limit: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(point, segment) index pairs (K,), (K,): each point (P, 2) with every segment whose
    box (bottom, top (S, 2)) grown by a little more than side meets the point's cell
    (side x side cells from the points' lower left corner): all within side of it. None
    when more than limit (segment, cell) pairs would be listed."""
    lo = points.min(axis=0)
    cell = np.floor((points - lo) / side).astype(np.int64)  # (P, 2)
    last_cell = cell.max(axis=0)
    key = cell[:, 0] * (last_cell[1] + 1) + cell[:, 1]
    order = np.argsort(key, kind="stable")
    keys = key[order]
    grow = side * (1.0 + 1e-9)
    first = np.maximum(np.floor((bottom - grow - lo) / side), 0).astype(np.int64)
    last = np.minimum(np.floor((top + grow - lo) / side), last_cell).astype(np.int64)
    span = np.maximum(last - first + 1, 0)  # (S, 2): the cells each grown box meets
    if float((span[:, 0].astype(float) * span[:, 1]).sum()) > limit:  # (in floats: no overflow)
        return None
    count = span[:, 0] * span[:, 1]
    seg = np.repeat(np.arange(len(bottom)), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    cells = (first[seg, 0] + k // span[seg, 1]) * (last_cell[1] + 1) + first[seg, 1] + k % span[seg, 1]
    # each (segment, cell) with the run of the cell's points
    start = np.searchsorted(keys, cells, "left")
    runs = np.searchsorted(keys, cells, "right") - start
    p = order[np.arange(runs.sum()) - np.repeat(np.cumsum(runs) - runs - start, runs)]
    return p, np.repeat(seg, runs)


def _largest(geometry) -> Polygon | None:
    """The largest polygon of a geometry, None when it is empty."""
    polygons = [g for g in getattr(geometry, "geoms", [geometry]) if g.geom_type == "Polygon" and not g.is_empty]
    return max(polygons, key=lambda g: g.area) if polygons else None


def _inwards(poly: Polygon, points: np.ndarray, directions: np.ndarray, probe: float) -> np.ndarray:
    """:func:`_inward` at points (K, 2) with directions (K, 2), (K, 2), in one test."""
    n = np.array([[-d[1], d[0]] for d in (v / max(np.linalg.norm(v), 1e-300) for v in directions)]).reshape(-1, 2)
    probes = points + probe * n
    inside = shapely.contains_xy(poly, probes[:, 0], probes[:, 1])
    return np.where(inside[:, None], n, -n)


def _along(line: np.ndarray, fractions) -> tuple[np.ndarray, np.ndarray]:
    """Points and unit directions at arc-length fractions of a polyline (K, 2)."""
    seg = np.diff(line, axis=0)
    lengths = np.linalg.norm(seg, axis=1)
    s = np.concatenate([[0.0], np.cumsum(lengths)])
    at = np.asarray(fractions) * s[-1]
    i = np.clip(np.searchsorted(s, at) - 1, 0, len(seg) - 1)
    f = (at - s[i]) / np.maximum(lengths[i], 1e-300)
    return line[i] + f[:, None] * seg[i], seg[i] / np.maximum(lengths[i], 1e-300)[:, None]


FRACTIONS = np.array([0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8, 0.12, 0.88])


def plate_layout(net: np.ndarray, cut: np.ndarray, edges: dict, bends: list, frames: list, part_data: list[str],
                 text_height: tuple[float, float], butt_edges: list[np.ndarray] = (),
                 frame_clearance: float = 0.0, areas: list = ()) -> Layout:
    """Lay out one plate (all mm).

    net, cut : (N, 2) closed contours (the same when no allowance is cut)
    edges : {label text: (K, 2) polyline of the edge it names}
    bends : [(mark text, (2,) a, (2,) b)]
    frames : [(name, (K, 2) polyline)] unclipped
    part_data : lines of the part data block
    butt_edges : polylines of the butts: a frame nearer than frame_clearance is skipped
    areas : [(kind, (K, 2) closed ring)] marked areas ('shrink', 'stretch'), drawn as they
        are (inside the plate) and kept clear of texts like the lines
    """
    plate = _largest(shapely.make_valid(Polygon(net))) or _largest(Polygon(net).buffer(0))
    if plate is None:
        raise ValueError(f"the cut outline ({len(net)} points) encloses no area")
    findings = []
    smallest, largest = text_height
    inscribed = inscribed_radius(plate)
    preferred = float(np.clip(2.0 * inscribed / 12.0, smallest, largest))
    clearance = min(0.2 * smallest, 0.05 * inscribed)
    room = _largest(plate.buffer(-clearance)) or plate
    layout = Layout(cut=cut, net=None if cut is net else net, text_height=preferred)
    # marks clipped to the plate
    bend_lines = []
    for text, a, b in bends:
        clipped = LineString([a, b]).intersection(plate)
        parts = [g for g in getattr(clipped, "geoms", [clipped]) if g.geom_type == "LineString" and g.length > 0]
        for g in parts:
            bend_lines.append((text, np.asarray(g.coords)))
    butts = [LineString(e) for e in butt_edges if len(e) >= 2]
    frame_lines = []
    for name, line in frames:
        clipped = LineString(line).intersection(plate)
        parts = [np.asarray(g.coords) for g in getattr(clipped, "geoms", [clipped])
                 if g.geom_type == "LineString" and g.length > 0]
        if not parts:
            findings.append(f"{name}: outside the plate, not marked")
            continue
        near = min((LineString(p).distance(bt) for p in parts for bt in butts), default=np.inf)
        if near < frame_clearance:
            findings.append(f"{name}: {near:.1f} mm from a butt (frame_clearance {frame_clearance:g} mm), not marked")
            continue
        frame_lines += [(name, p) for p in parts]
    layout.lines = [("bend", p) for _, p in bend_lines] + [("frame", p) for _, p in frame_lines]
    layout.frame_names = [name for name, _ in frame_lines]
    layout.lines += [(kind, np.asarray(ring)) for kind, ring in areas]
    placer = Placer(room, [p for _, p in layout.lines], clearance)
    obstacles = placer.obstacles
    # the part data block first, in the middle of the largest free area
    centres, depth = grid_points(room, obstacles)
    angles = []
    if bend_lines:
        d = np.mean([p[-1] - p[0] for _, p in bend_lines], axis=0)
        angles.append(readable(np.degrees(np.arctan2(d[1], d[0]))))
    corners = minimum_rectangle(np.asarray(plate.exterior.coords))[:3]
    sides = np.diff(corners, axis=0)
    long_side = sides[np.argmax(np.linalg.norm(sides, axis=1))]
    angles += [readable(np.degrees(np.arctan2(long_side[1], long_side[0]))), 0.0, 90.0]
    placed = False
    if part_data:
        splits = [part_data]
        for k in (3, 2, 1):
            per = int(np.ceil(len(part_data) / k))
            if per > 1:
                splits.append(["  ".join(part_data[j:j + per]) for j in range(0, len(part_data), per)])
        for h in heights(preferred, smallest):
            for lines in splits:
                w = CHAR_WIDTH * h * max(len(t) for t in lines)
                hh = LINE_GAP * h * (len(lines) - 1) + 1.3 * h
                # a centre nearer the room's edge or a line than half the grown box's smaller
                # side cannot hold it (that point lies inside the box): only the clearer
                # ones, a prefix of the centres, are tried
                reach = np.count_nonzero(depth >= (0.5 * min(w, hh) + placer.clearance) * (1 - 1e-9))
                for angle in angles:
                    # nor one whose grown box's long middle line crosses the room's edge or a
                    # line (the short one is clear: the centre is that deep): most tries fail
                    # everywhere, and this decides most of their centres
                    free = placer.reach(centres, angle if w >= hh else angle + 90.0, reach)
                    idx = np.flatnonzero(free >= (0.5 * max(w, hh) + placer.clearance) * (1 - 1e-6))
                    i = placer.place(centres[idx], w, hh, angle) if len(idx) else None
                    if i is not None:
                        i = idx[i]
                        layout.texts += block_texts(lines, centres[i], h, angle)
                        placed = True
                        break
                if placed:
                    break
            if placed:
                break
        if not placed:
            findings.append("part data block: no room inside the plate at the smallest text height")
    # edge names (and bevels) inside the plate along their edge, then the marks' labels beside
    # them: every label's tests at the first height at once, the lower heights one by one
    labels = [("edge", text, line, None, None) for text, line in edges.items()]
    labels += [(kind, text, line, 1, long_side) for kind, marks in (("bend", bend_lines), ("frame", frame_lines))
               for text, line in marks]
    tall = heights(max(0.8 * preferred, smallest), smallest)
    jobs = [(np.zeros((0, 2)), 1.0, 1.0, np.zeros(0))] * len(labels)  # a line of one point: no room
    for side, along in ((None, None), (1, long_side)):
        mine = [k for k, label in enumerate(labels) if label[3] == side and len(label[2]) >= 2]
        for k, job in zip(mine, _candidates_of([labels[k][2] for k in mine], [labels[k][1] for k in mine], tall[0],
                                               plate, clearance, side, along)):
            jobs[k] = job
    for (kind, text, line, side, along), job, i in zip(labels, jobs, placer.place_each(jobs)):
        h = tall[0]
        for h in tall[1:] if i is None and len(line) >= 2 else ():
            job = _candidates(line, text, h, plate, clearance, side, along)
            i = placer.place(*job)
            if i is not None:
                break
        if i is not None:
            layout.texts.append(Text(kind, text, tuple(job[0][i]), h, float(job[3][i])))
        else:
            findings.append(f"edge label {text!r}: no room along its edge" if kind == "edge" else
                            f"{'bending line' if kind == 'bend' else 'frame'} label {text!r}: no room beside the line")
    layout.findings = findings
    return layout


def _candidates(line: np.ndarray, text: str, h: float, plate: Polygon, clearance: float, side,
                along=None) -> tuple[np.ndarray, float, float, np.ndarray]:
    """:func:`_candidates_of` one polyline."""
    return _candidates_of([line], [text], h, plate, clearance, side, along)[0]


def _candidates_of(lines: list[np.ndarray], texts: list[str], h: float, plate: Polygon, clearance: float, side,
                   along=None) -> list[tuple[np.ndarray, float, float, np.ndarray]]:
    """Where to try a text of height h beside each polyline (K, 2) (at least 2 points), in
    order: parallel to it, on the plate side of an edge (side None) or on either side of a
    mark line, at several places along it; then running away from it; then (``along``: (2,)
    the plate's long direction) beside it reading along the plate, where a mark line across
    a narrow plate leaves room on neither side. Per line: centres (N, 2), the box's width
    and height, angles (N,). All lines at once (L of them), each line's floats as alone."""
    if not lines:
        return []
    found = [_along(line, FRACTIONS) for line in lines]
    points, directions = np.stack([f[0] for f in found]), np.stack([f[1] for f in found])  # (L, J, 2)
    ahead = _readable(np.degrees(np.arctan2(directions[..., 1], directions[..., 0])))  # (L, J)
    left = np.stack([-directions[..., 1], directions[..., 0]], axis=-1)
    w, hh = CHAR_WIDTH * h * np.array([len(t) for t in texts], dtype=float), 1.3 * h  # (L,), one
    # a box 2 clearances off a straight edge has its grown side on the room's boundary,
    # where round-off decides whether it fits: 1 % of a clearance more decides it
    gap = 0.5 * hh + 2.01 * clearance
    # (L, J, 1 or 2, 2): the inward normal of an edge, either normal of a mark line
    normals = _inwards(plate, points.reshape(-1, 2), directions.reshape(-1, 2), gap).reshape(points.shape)[:, :, None] \
        if side is None else np.stack([left, np.stack([directions[..., 1], -directions[..., 0]], axis=-1)], axis=2)
    steps = np.array([1.0, 2.0, 3.5]) * gap
    beside = points[:, :, None, None] + steps[None, None, None, :, None] * normals[:, :, :, None]  # (L, J, n, 3, 2)
    # a short edge or a line across a narrow plate: the text runs away from it
    away = points[:, :, None] + (0.5 * w + 0.5 * hh + 3.0 * clearance)[:, None, None, None] * normals  # (L, J, n, 2)
    outward = _readable(np.degrees(np.arctan2(normals[..., 1], normals[..., 0])))  # (L, J, n)
    n = normals.shape[2]
    out = []
    for k in range(len(lines)):
        centres = np.concatenate([beside[k].reshape(-1, 2), away[k].reshape(-1, 2)])
        angles = np.concatenate([np.repeat(ahead[k], n * 3), outward[k].ravel()])
        if along is not None:
            u = np.asarray(along, dtype=float) / max(float(np.linalg.norm(along)), 1e-300)
            toward = np.where((normals[k] @ u)[..., None] >= 0.0, u, -u)  # (J, n, 2): along the plate, to that side
            shifts = 0.5 * w[k] + np.array([1.0, 2.0, 4.0]) * gap
            lengthwise = points[k][:, None, None] + shifts[None, None, :, None] * toward[:, :, None]  # (J, n, 3, 2)
            centres = np.concatenate([centres, lengthwise.reshape(-1, 2)])
            angles = np.concatenate([angles, np.full(lengthwise.shape[0] * n * 3,
                                                     _readable(np.degrees(np.arctan2(u[1], u[0]))))])
        out.append((centres, float(w[k]), hh, angles))
    return out
