"""Labels written away from what they name, with a straight leader to it (paper mm).

Where lines crowd (a formed plate's heating lines, close bending lines) a label has no room
beside its line. A drafter then writes it where there is room and draws a thin leader from
a dot on the line to the label. A plater must still read at a glance which line a label
names, so a leader here:

- starts at a dot on the label's own line, at the point the label names or slid along that
  line, DOT_APART from every other dot, DOT_OFF_LINES from every other drawn line and
  DOT_OFF_EDGES from a hatched area's edge, unless that runs alongside its own (a bending
  line on the plate's edge may have its dot there);
- runs straight toward its label's centre and stops GAP short of the side it meets, its end
  END_CLEAR from every other label (the nearer label is always its own), and the label stands
  WORD_GAP from any text on its line of text (two names would read as one);
- crosses no label, no other leader, no dimension, chain or frame line (``barriers``), and passes
  DOT_CLEAR from every other dot and from the points still to be led (``reserved``);
- crosses drawn lines rather than running along them: within LEADER_BAND of a line or an
  area's edge for no more than LEADER_ALONG, and not within HATCH_CLEAR degrees of the
  hatching of an area it crosses;
- is as short as the room allows (LEADER_REACH, at most 40 mm).

Pure numpy and shapely, on a :class:`pipeline.shop.paper.PaperPlacer`.
"""

from __future__ import annotations

import numpy as np

from .paper import END_CLEAR, GAP, H_LABEL, Label, PaperPlacer, label_in, size_of

LEADER_REACH = (10.0, 14.0, 19.0, 25.0, 32.0, 40.0)  # a label's centre from its dot, paper mm
LEADER_DIRECTIONS = 24
LEADER_BAND, LEADER_ALONG = 0.45, 4.0  # no nearer than 0.45 mm to a line for more than 4 mm
DOT_APART = 2.5  # paper mm between two leaders' dots
DOT_CLEAR = 1.5  # paper mm between a leader and another's dot or a point still to be led
DOT_OFF_LINES = 1.0  # paper mm between a dot and every drawn line but its own (or alongside it)
DOT_OFF_EDGES = 0.5  # paper mm between a dot and a hatched area's edge (or alongside it)
ALONGSIDE = np.sin(np.radians(15.0))  # a line within 15 degrees of a dot's own line runs alongside it
WORD_GAP = 2.5  # paper mm between a led label and a text beside it on its line (else read as one)
HATCH_CLEAR = 10.0  # degrees between a leader and the hatching of an area it crosses
SLIDE = (0.5, 0.35, 0.65, 0.2, 0.8, 0.1, 0.9)  # where else on its line a dot may go (arc fractions)


class Leaders:
    """The leaders of one page: the placer that keeps the labels apart, the lines a leader
    may not cross (``barriers``, (K, 2) polylines), the hatched areas [(hatch direction in
    degrees, (K, 2) ring)] and the points still to be led (``reserved``, (R, 2))."""

    def __init__(self, placer: PaperPlacer, barriers=(), hatched=(), edges=(), lines=()):
        import shapely

        self.placer = placer
        segs = [shapely.LineString(p) for p in barriers if len(p) >= 2]
        self.barriers = shapely.STRtree(segs) if segs else None
        self.hatched = [(float(angle), shapely.Polygon(ring).buffer(0)) for angle, ring in hatched if len(ring) >= 3]
        rings = [shapely.LineString(np.vstack([ring, ring[:1]])) for ring in edges if len(ring) >= 3]
        self.edges = shapely.STRtree(rings) if rings else None
        # whole lines (the placer keeps their segments): how long a leader runs along one
        whole = [shapely.LineString(p) for p in lines if len(p) >= 2] + rings
        self.whole = shapely.STRtree(whole) if whole else None
        self.reserved = np.zeros((0, 2))
        self._dots = np.zeros((0, 2))

    def dots(self) -> np.ndarray:
        """The dots (D, 2) of the leaders placed."""
        return self._dots

    def place(self, text: str, anchors, angle: int, own=None, h: float = H_LABEL,
              style: str = "black") -> tuple[Label, np.ndarray] | None:
        """The label and its leader (2, 2) from the first of ``anchors`` (A, 2) that allows
        the shortest leader (``own``: the (K, 2) polyline the anchors lie on, else None);
        None when no anchor leaves room."""
        import shapely

        anchors = [np.asarray(a, dtype=float) for a in np.asarray(anchors, dtype=float).reshape(-1, 2)]
        own_line = shapely.LineString(own) if own is not None and len(own) >= 2 else None
        verdicts = [self._dot_ok(a, own_line) for a in anchors]
        # dots clear of every other line first; on a line alongside their own only if none leaves room
        for accept in ("clear", "alongside"):
            led = self._place_from([a for a, v in zip(anchors, verdicts) if v == accept], anchors[0], text, angle,
                                   h, style)
            if led is not None:
                return led
        return None

    def _place_from(self, anchors: list, named: np.ndarray, text: str, angle: int, h: float, style: str):
        """:meth:`place` from these anchors, all of them fit for a dot (``named``: the point
        the label names, whose reservation is its own)."""
        import shapely

        if not anchors:
            return None
        turn = np.linspace(0.0, 2 * np.pi, LEADER_DIRECTIONS, endpoint=False)
        ways = np.column_stack([np.cos(turn), np.sin(turn)])
        half = 0.5 * size_of(text, h, angle)
        # nearest first: by reach, then by anchor (the named point first), then by direction
        reach = np.asarray(LEADER_REACH)[:, None, None, None]
        centres = (np.array(anchors)[None, :, None, :] + reach * ways[None, None]).reshape(-1, 2)
        which = np.broadcast_to(np.arange(len(anchors))[None, :, None], (len(LEADER_REACH), len(anchors),
                                                                          LEADER_DIRECTIONS)).ravel()
        boxes = np.hstack([centres - half, centres + half])
        placed = self.placer.boxes
        labels = shapely.box(placed[:, 0], placed[:, 1], placed[:, 2], placed[:, 3])
        grown = shapely.box(placed[:, 0] - GAP, placed[:, 1] - GAP, placed[:, 2] + GAP, placed[:, 3] + GAP)
        for i in self.placer.free(boxes):
            point = anchors[which[i]]
            d = centres[i] - point
            # the line from the dot to the box's centre enters the box through the side
            # across axis k at 1 - half_k / |d_k|; it stops GAP before that side
            k = min((k for k in range(2) if d[k] != 0.0), key=lambda k: half[k] / abs(d[k]))
            end = point + d * max(0.0, 1.0 - (half[k] + GAP) / abs(d[k]))
            leader = shapely.LineString([point, end])
            if len(placed) and (shapely.intersects(leader, grown).any()
                                or shapely.distance(shapely.Point(end), labels).min() < END_CLEAR
                                or _run_on(boxes[i], placed, 0 if angle == 0 else 1)):
                continue
            if self._meets_a_leader(leader) or self._passes_points(point, end, named):
                continue
            if self._crosses_barrier(leader) or self._runs_along(leader) or self._along_hatching(leader, d):
                continue
            self.placer.boxes = np.vstack([self.placer.boxes, boxes[i]])
            self.placer.leaders.append(leader)
            self._dots = np.vstack([self._dots, point])
            return label_in(text, centres[i], h, angle, style), np.array([point, end])
        return None

    def _dot_ok(self, point: np.ndarray, own_line) -> str | None:
        """Whether a dot may go here: 'clear' when it is DOT_APART from the other dots,
        DOT_CLEAR from the other leaders, DOT_OFF_EDGES from every hatched area's edge and
        DOT_OFF_LINES from every drawn line but its own; 'alongside' when the only lines that
        near run alongside its own (a bending line on the plate's edge: one line to the eye);
        else None."""
        import shapely

        dots = self.dots()
        if len(dots) and np.min(np.linalg.norm(dots - point, axis=1)) < DOT_APART:
            return None
        at = shapely.Point(point)
        if any(leader.distance(at) < DOT_CLEAR for leader in self.placer.leaders):
            return None
        if self.edges is not None and len(self.edges.query(at.buffer(DOT_OFF_EDGES), predicate="intersects")):
            return None
        tree = self.placer.tree
        near = [] if tree is None else [
            g for g in tree.geometries[tree.query(at.buffer(DOT_OFF_LINES), predicate="intersects")]
            if g.geom_type == "LineString"]
        if own_line is not None:
            mine = own_line.buffer(1e-6)
            near = [g for g in near if not mine.contains(g)]
        if not near:
            return "clear"
        if own_line is None:
            return None
        d = _direction(own_line, at)
        return "alongside" if all(abs(_cross(d, _direction(g, at))) < ALONGSIDE for g in near) else None

    def _meets_a_leader(self, leader) -> bool:
        """Whether the leader crosses one placed before (two from one dot meet only there)."""
        start = leader.coords[0]
        for other in self.placer.leaders:
            if other.coords[0] == start:
                if leader.intersection(other).length > 0.0:  # one along the other
                    return True
            elif leader.intersects(other):
                return True
        return False

    def _passes_points(self, a: np.ndarray, b: np.ndarray, named: np.ndarray) -> bool:
        """Whether the segment a-b passes within DOT_CLEAR of another leader's dot or of a
        point still to be led (other than its own)."""
        pts = np.vstack([self.dots(), self.reserved])
        pts = pts[np.linalg.norm(pts - a, axis=1) > 1e-9]
        pts = pts[np.linalg.norm(pts - named, axis=1) > 1e-9]
        if not len(pts):
            return False
        d = b - a
        t = np.clip((pts - a) @ d / max(float(d @ d), 1e-300), 0.0, 1.0)
        return bool(np.any(np.linalg.norm(a + t[:, None] * d - pts, axis=1) < DOT_CLEAR))

    def _crosses_barrier(self, leader) -> bool:
        return self.barriers is not None and len(self.barriers.query(leader, predicate="intersects")) > 0

    def _runs_along(self, leader) -> bool:
        """Within LEADER_BAND of a drawn line or an area's edge for more than LEADER_ALONG
        (a crossing under about 13 degrees)."""
        import shapely

        if self.whole is None:
            return False
        band = leader.buffer(LEADER_BAND, cap_style="flat")
        near = self.whole.geometries[self.whole.query(band, predicate="intersects")]
        return bool(len(near)) and bool(np.any(shapely.length(shapely.intersection(near, band)) > LEADER_ALONG))

    def _along_hatching(self, leader, d: np.ndarray) -> bool:
        """Within HATCH_CLEAR degrees of the hatching of an area the leader crosses."""
        direction = np.degrees(np.arctan2(d[1], d[0])) % 180.0
        for hatch, area in self.hatched:
            off = abs((direction - hatch + 90.0) % 180.0 - 90.0)
            if off < HATCH_CLEAR and leader.intersects(area):
                return True
        return False


def _run_on(box: np.ndarray, placed: np.ndarray, along: int) -> bool:
    """Whether the box (4,) stands on a line of text with a placed box (P, 4), less than
    WORD_GAP from it along that line (axis ``along``): the two would read as one text."""
    across = 1 - along
    side = (placed[:, across] < box[across + 2]) & (placed[:, across + 2] > box[across])
    gap = np.maximum(placed[:, along] - box[along + 2], box[along] - placed[:, along + 2])
    return bool(np.any(side & (gap < WORD_GAP)))


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _direction(line, at) -> np.ndarray:
    """The unit direction (2,) of the segment of the shapely ``line`` nearest the point ``at``."""
    xy = np.asarray(line.coords, dtype=float)
    p = np.asarray(at.coords[0], dtype=float)
    seg = xy[1:] - xy[:-1]
    t = np.clip(np.einsum("ij,ij->i", p - xy[:-1], seg) / np.maximum(np.einsum("ij,ij->i", seg, seg), 1e-300), 0, 1)
    k = int(np.argmin(np.linalg.norm(xy[:-1] + t[:, None] * seg - p, axis=1)))
    return seg[k] / max(float(np.linalg.norm(seg[k])), 1e-300)


def slid_along(line: np.ndarray, named: np.ndarray) -> np.ndarray:
    """Anchors (A, 2) on the polyline (K, 2): the named point, then the points at SLIDE's arc
    fractions nearest it first."""
    line = np.asarray(line, dtype=float)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
    if s[-1] <= 0.0:
        return np.asarray(named, dtype=float)[None, :]
    at = np.array([np.interp(f * s[-1], s, line[:, 0]) for f in SLIDE])
    pts = np.column_stack([at, [np.interp(f * s[-1], s, line[:, 1]) for f in SLIDE]])
    order = np.argsort(np.linalg.norm(pts - named, axis=1), kind="stable")
    return np.vstack([np.asarray(named, dtype=float)[None, :], pts[order]])
