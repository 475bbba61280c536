"""Textile pieces: sew line, seam allowance with mitred corners, notches, grain line.

The sew line is the developed outline itself (the net piece); the cut line lies outside
it at each edge's allowance, corners mitred where neighbouring offsets meet. Geometry in
the flat pattern's coordinates (model units). The one module that uses shapely.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import polylabel, substring

from flatten.develop import develop

from ..config import ConfigError, Textile
from .notchtypes import opening
from .seams import ruling_through
from ..stages import PartResult

@dataclass(frozen=True)
class Notch:
    edge: str
    arc_length: float  # along the 3D curve from its own start (model units); nan for ruling notches
    sew_point: np.ndarray  # (2,)
    line: np.ndarray  # (2, 2) from the cut line inwards, as long as the notch is deep
    kind: str = "slit"  # one of notchtypes.KINDS
    width: float = 0.0  # opening at the cut line (model units; 0 for a slit)


@dataclass(frozen=True)
class TextilePiece:
    """A piece in flat coordinates (model units): sew ring (N, 2), cut ring (M, 2), both
    counter-clockwise and not repeated; the edges of the sew ring in ring order, named
    by ``edge_names`` ('c', 'end', 'd', 'start'), with their allowances. ``cut_corners``
    (4,) indexes the cut ring's corners (where neighbouring offset edges meet), in edge
    order: corner k ends edge k."""

    name: str
    sew: np.ndarray
    cut: np.ndarray
    edges: tuple[np.ndarray, ...]
    edge_names: tuple[str, ...]
    allowances: tuple[float, ...]
    notches: tuple[Notch, ...]
    grain: np.ndarray
    internal_lines: np.ndarray
    settings: Textile = field(repr=False, default=None)
    cut_corners: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    def translated(self, offset: np.ndarray) -> "TextilePiece":
        move = np.asarray(offset, dtype=float)
        return TextilePiece(self.name, self.sew + move, self.cut + move, tuple(e + move for e in self.edges),
                            self.edge_names, self.allowances,
                            tuple(Notch(n.edge, n.arc_length, n.sew_point + move, n.line + move, n.kind, n.width)
                                  for n in self.notches),
                            self.grain + move, self.internal_lines + move, self.settings, self.cut_corners)

    def moved(self, turn: np.ndarray, offset: np.ndarray) -> "TextilePiece":
        """The piece turned by the rotation matrix ``turn`` (2, 2) about the origin, then
        moved by ``offset`` (2,)."""
        def f(points):
            return np.asarray(points) @ np.asarray(turn).T + offset
        return TextilePiece(self.name, f(self.sew), f(self.cut), tuple(f(e) for e in self.edges),
                            self.edge_names, self.allowances,
                            tuple(Notch(n.edge, n.arc_length, f(n.sew_point), f(n.line), n.kind, n.width)
                                  for n in self.notches),
                            f(self.grain), f(self.internal_lines), self.settings, self.cut_corners)

    @property
    def sew_corners(self) -> np.ndarray:
        """Indices of the sew ring's corners (the first point of each edge)."""
        return np.cumsum([0] + [len(e) - 1 for e in self.edges[:-1]])

    def turn_and_curve_points(self) -> tuple[np.ndarray, np.ndarray]:
        """AAMA turn points (T, 2) at the corners of the cut and sew rings, and curve
        points (C, 2) at the other vertices of their curved edges (the rings' own vertices,
        so a reader that rebuilds the curves through them gets the polylines back)."""
        turns, curves = [], []
        for ring, corners in ((self.cut, self.cut_corners), (self.sew, self.sew_corners)):
            is_corner = np.zeros(len(ring), dtype=bool)
            is_corner[np.asarray(corners, dtype=int) % len(ring)] = True
            turns.append(ring[is_corner])
            curves.append(ring[~is_corner])
        return np.vstack(turns), np.vstack(curves)


def _dedupe(points: np.ndarray) -> np.ndarray:
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.hypot(*np.diff(points, axis=0).T) > 1e-12 * (1 + np.abs(points).max())
    return points[keep]


def piece_edges(c_side: np.ndarray, d_side: np.ndarray) -> tuple[tuple[np.ndarray, ...], tuple[str, ...]]:
    """The four edges of the sew ring in counter-clockwise order, with their names
    ('c', 'end', 'd', 'start'); each edge runs in the ring's direction."""
    edges = (_dedupe(c_side), np.vstack([c_side[-1], d_side[-1]]), _dedupe(d_side[::-1]),
             np.vstack([d_side[0], c_side[0]]))
    names = ("c", "end", "d", "start")
    ring = np.vstack([e[:-1] for e in edges])
    if _signed_area(ring) < 0:  # traverse the other way round
        edges = tuple(e[::-1] for e in edges[::-1])
        names = names[::-1]
    return edges, names


def _signed_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _extend(line: np.ndarray, length: float) -> np.ndarray:
    start_dir = line[0] - line[1]
    end_dir = line[-1] - line[-2]
    start_dir /= max(np.hypot(*start_dir), 1e-300)
    end_dir /= max(np.hypot(*end_dir), 1e-300)
    return np.vstack([line[0] + length * start_dir, line, line[-1] + length * end_dir])


def offset_edge(edge: np.ndarray, width: float) -> np.ndarray:
    """The edge moved outwards (to the right of a counter-clockwise ring) by ``width``."""
    if width == 0.0:
        return edge.copy()
    moved = LineString(edge).offset_curve(-width, join_style="mitre", mitre_limit=10.0)
    pts = np.asarray(moved.coords)
    # shapely keeps the direction; guard against a reversed result all the same
    if np.hypot(*(pts[0] - edge[0])) > np.hypot(*(pts[-1] - edge[0])):
        pts = pts[::-1]
    return pts


def cut_ring(edges: tuple[np.ndarray, ...], widths: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Cut line: each edge offset by its width, neighbouring offsets cut where they meet
    (mitred corners, also between different widths). Returns the ring (M, 2) and the
    indices (len(edges),) of its corners, corner k ending edge k."""
    size = max(np.ptp(np.vstack(edges), axis=0).max(), 1e-9)
    reach = 10.0 * max(widths) + 0.1 * size
    offsets = [LineString(_extend(offset_edge(e, w), reach)) for e, w in zip(edges, widths)]
    corners = []
    n = len(edges)
    for k in range(n):
        a, b = offsets[k], offsets[(k + 1) % n]
        corner = edges[k][-1]
        hit = a.intersection(b)
        points = [np.asarray(g.coords[0]) for g in getattr(hit, "geoms", [hit]) if not g.is_empty and g.geom_type == "Point"]
        if points:
            corners.append(min(points, key=lambda p: np.hypot(*(p - corner))))
        else:  # collinear continuation: meet half way
            corners.append(0.5 * (np.asarray(a.coords[-2]) + np.asarray(b.coords[1])))
    pieces = []
    for k in range(n):
        line = offsets[k]
        s0 = line.project(Point(corners[k - 1]))
        s1 = line.project(Point(corners[k]))
        part = _dedupe(np.asarray(substring(line, s0, s1).coords))
        pieces.append(part[:-1] if len(part) > 1 else part)
    # corner k ends piece k, i.e. is the first point of piece k + 1
    starts = np.cumsum([0] + [len(p) for p in pieces])
    return np.vstack(pieces), np.roll(starts[:-1], -1)


def _snap_to_edge(edge: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest point of the edge polyline (the exact developed point is off the chords by
    at most the chord tolerance) and the unit tangent of its segment."""
    seg = np.diff(edge, axis=0)
    rel = point - edge[:-1]
    frac = np.clip(np.einsum("ij,ij->i", rel, seg) / np.maximum(np.einsum("ij,ij->i", seg, seg), 1e-300), 0, 1)
    foot = edge[:-1] + frac[:, None] * seg
    k = int(np.argmin(np.hypot(*(foot - point).T)))
    return foot[k], seg[k] / np.hypot(*seg[k])


def _flat_point_at(result: PartResult, which: str, param: float, transform) -> np.ndarray:
    """Exact developed position of c(param) or d(param): the development with one more ruling."""
    part, strip = result.part, result.strip
    rulings = strip.rulings
    axis = 0 if which == "c" else 1
    values = rulings[:, axis]
    lo, hi = min(values[0], values[-1]), max(values[0], values[-1])
    if not lo - 1e-12 <= param <= hi + 1e-12:
        return None
    extra = ruling_through(result, axis, param)
    merged = np.vstack([rulings, extra])
    merged = merged[np.lexsort((merged[:, 1] * (1 if result.solution.path is None else result.solution.path.orientation),
                                merged[:, 0]))]
    dev = develop(part.c, part.d, merged, result.solution.field)
    k = int(np.argmin(np.hypot(*(merged - extra).T)))
    point = dev.along_c[k] if axis == 0 else dev.along_d[k]
    rot, shift = transform
    return point @ rot.T + shift


def build_piece(result: PartResult, settings: Textile, transform) -> TextilePiece:
    """Raise ConfigError (bad input) when the allowance, a notch or the grain option does
    not fit this piece."""
    name = result.name
    bend = result.pattern.bend_lines
    c_side, d_side = bend[:, 0], bend[:, 1]
    edges, names = piece_edges(c_side, d_side)
    sew = np.vstack([e[:-1] for e in edges])
    a = settings.allowances()
    widths = tuple(getattr(a, n) for n in names)
    width_of_piece = float(np.hypot(*(d_side - c_side).T).min())
    for edge_name, w in zip(names, widths):
        if w >= width_of_piece:
            raise ConfigError(f"textile.seam_allowance.{edge_name} = {w:g} is larger than the piece {name} "
                              f"(narrowest width {width_of_piece:.6g})")
    cut, cut_corners = cut_ring(edges, widths)
    sew_poly, cut_poly = Polygon(sew), Polygon(cut)
    if not cut_poly.is_valid or not cut_poly.buffer(1e-9 * width_of_piece).contains(sew_poly):
        raise ConfigError(f"textile.seam_allowance {widths} does not fit piece {name}: "
                          f"{shapely.is_valid_reason(cut_poly)}")
    notches = []
    for k, spec in enumerate(settings.notches):
        shape = _notch_shape(spec, settings)
        if spec.ruling is not None:
            if spec.ruling >= len(bend):
                raise ConfigError(f"textile.notches[{k}].ruling = {spec.ruling} lies outside piece {name} "
                                  f"({len(bend)} rulings)")
            for edge_name, point in (("c", c_side[spec.ruling]), ("d", d_side[spec.ruling])):
                notches.append(_notch(edge_name, float("nan"), point, edges, names, widths, *shape))
            continue
        for which, curve_id in zip(("c", "d"), result.part.curve_ids):
            if spec.curve != curve_id:
                continue
            curve = result.part.c if which == "c" else result.part.d
            for j, s in enumerate(spec.at):
                param = float(curve.parameter_at_length(np.array([s]))[0])
                point = _flat_point_at(result, which, param, transform)
                if point is None:
                    raise ConfigError(f"textile.notches[{k}].at[{j}] = {s:g} lies outside the {which} edge of "
                                      f"piece {name} (the strip covers only part of curve {curve_id!r})")
                notches.append(_notch(which, s, point, edges, names, widths, *shape))
    grain = _grain(result, settings, sew_poly)
    internal = bend.copy() if settings.internal_rulings else np.zeros((0, 2, 2))
    return TextilePiece(name, sew, cut, edges, names, widths, tuple(notches), grain, internal, settings, cut_corners)


def _notch_shape(spec, settings: Textile) -> tuple[float, str, float]:
    """Depth, type and opening width of the notches of one ``textile.notches`` entry: its
    own, else the textile section's."""
    kind = spec.type or settings.notch_type
    depth = spec.depth if spec.depth is not None else settings.notch_length
    return depth, kind, opening(kind, spec.width if spec.width is not None else settings.notch_width)


def _notch(edge_name, arc_length, point, edges, names, widths, length, kind="slit", width=0.0) -> Notch:
    index = names.index(edge_name)
    foot, tangent = _snap_to_edge(edges[index], np.asarray(point, dtype=float))
    outward = np.array([tangent[1], -tangent[0]])  # right of a counter-clockwise ring
    start = foot + widths[index] * outward  # on the cut line: the slit starts at the edge
    return Notch(edge_name, arc_length, foot, np.vstack([start, start - length * outward]), kind, width)


def _grain(result: PartResult, settings: Textile, sew_poly: Polygon) -> np.ndarray:
    grain = settings.grain
    bend = result.pattern.bend_lines
    if grain.ruling is not None:
        if grain.ruling >= len(bend):
            raise ConfigError(f"textile.grain.ruling = {grain.ruling} lies outside piece {result.name} "
                              f"({len(bend)} rulings)")
        a, b = bend[grain.ruling]
        return np.vstack([a + 0.2 * (b - a), a + 0.8 * (b - a)])
    if grain.angle is not None:
        direction = np.array([np.cos(np.radians(grain.angle)), np.sin(np.radians(grain.angle))])
    else:
        mid = len(bend) // 2
        t, T = result.strip.rulings[mid]
        part = result.part
        pc, dc = part.c.derivatives([t], 1)
        ruling3 = part.d([T])[0] - pc[0]
        normal = np.cross(dc[0], ruling3)
        normal /= np.linalg.norm(normal)
        r_hat = ruling3 / np.linalg.norm(ruling3)
        b_hat = np.cross(normal, r_hat)
        g = np.asarray(grain.direction, dtype=float)
        g_r, g_b = g @ r_hat, g @ b_hat
        if np.hypot(g_r, g_b) <= 1e-9 * np.linalg.norm(g):
            raise ConfigError(f"textile.grain.direction {list(grain.direction)} is normal to piece "
                              f"{result.name}: it has no projection onto the piece")
        rho = bend[mid, 1] - bend[mid, 0]
        rho /= np.hypot(*rho)
        # the developed frame is seen from the strip normal: n x r maps to r turned +90 degrees
        direction = g_r * rho + g_b * np.array([-rho[1], rho[0]])
        direction /= np.hypot(*direction)
    centre = np.asarray(sew_poly.centroid.coords[0])
    reach = 2.0 * max(np.ptp(np.asarray(sew_poly.exterior.coords), axis=0))
    line = LineString([centre - reach * direction, centre + reach * direction]).intersection(sew_poly)
    if line.is_empty or line.geom_type != "LineString":
        line = max(getattr(line, "geoms", []), key=lambda g: g.length, default=None)
        if line is None:
            raise ConfigError(f"textile.grain: no grain line fits inside piece {result.name}")
    pts = np.asarray(line.coords)
    a, b = pts[0], pts[-1]
    return np.vstack([a + 0.15 * (b - a), a + 0.85 * (b - a)])


def _swept_box(segments: np.ndarray, half: np.ndarray):
    """Union of the segments (S, 2, 2) each swept by the axis-aligned box of half sizes (2,)."""
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half
    pts = (np.asarray(segments)[:, :, None, :] + corners[None, None]).reshape(len(segments), 8, 2)
    return shapely.union_all(shapely.convex_hull(shapely.multipoints(pts)))


def label_anchor(piece: TextilePiece, height: float, width: float, clearance: float = 0.0,
                 avoid: list[np.ndarray] = ()) -> np.ndarray | None:
    """Centre (2,) of a text box width x height (model units, axis-aligned) that lies
    inside the sew line and clear of the grain line, the notches and the ``avoid``
    polylines (each (K, 2), e.g. page edges) by ``clearance``: the pole of inaccessibility
    of the allowed region (the point farthest from everything the text must not touch).
    None when no such box fits."""
    half = np.array([width, height]) / 2 + clearance
    ring = np.vstack([piece.sew, piece.sew[:1]])
    blocked = [np.stack([ring[:-1], ring[1:]], axis=1), piece.grain[None]]
    blocked += [n.line[None] for n in piece.notches]
    blocked += [np.stack([line[:-1], line[1:]], axis=1) for line in avoid]
    allowed = Polygon(piece.sew).difference(_swept_box(np.vstack(blocked), half))
    if allowed.is_empty:
        return None
    largest = max(getattr(allowed, "geoms", [allowed]), key=lambda g: g.area)
    if largest.area <= 0:
        return None
    tolerance = 1e-3 * float(np.sqrt(largest.area)) + 1e-12
    return np.asarray(polylabel(largest, tolerance).coords[0])
