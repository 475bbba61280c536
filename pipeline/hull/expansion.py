"""The shell expansion drawing: every plate in girth x length, the yard's classic.

Each section x = X of the hull is unrolled: the girth of a point is its arc length along
that section from where the section starts (the keel centreline, or the stem contour where
the keel has risen into the stem), and it is drawn at (x, girth). A section that starts on a
contour off the centre plane (a transom's edge) adds its start's girth along that contour
from the centre plane, so that it continues the girths of the sections passing the contour.
The plates' seams and butts, sampled on the hull (:class:`pipeline.hull.cost.PlateEdges`),
are mapped point by point, so that a seam is drawn where the sections cross it and a butt
(a plane x = X) as a vertical line. Frames are vertical lines at their x, as tall as the section's girth.

Girth at a point (x, g) (g the surface's girth parameter) is interpolated in a table of
sections: at stations x_k (every butt and frame of the plan, and about every 0.25 % of the
hull's length between) the section is found on each iso-g curve (the crossing of x = x_k,
narrowed by regula falsi) and its cumulative chord length tabled on g; between stations and
between g samples the table is interpolated linearly.

Waterlines and decks (``strake.waterlines``, ``strake.decks``) are drawn where the sections
reach their heights (:mod:`.levels`).

Files (millimetres): NAME_expansion.dxf (R2000, one layer per plate class, frames, seams,
butts, waterlines, decks, match lines, texts; the sheet laid out in paper space) and
NAME_expansion.pdf (one A1 or A0 sheet: the drawing in up to three parts cut at frames, at
the largest standard scale that fits; :mod:`.expansion_sheet`). A shell of several faces is
one drawing where they join: a face whose sections start on another's continues its girth,
a plate past its face's trim is drawn as cut, and only faces that overlap or stand across
the hull get bands of their own (:mod:`.expansion_faces`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flatten.metrics import polygon_area

from ..io.atomic import atomic_path
from .cost import PlateEdges
from .expansion_faces import (
    JOIN,
    clipped,
    cut_at_trim,
    face_region,
    gap_stretches,
    joined_offsets,
    open_below,
    place_bands,
    stands_across,
    true_shape,
)
from .expansion_sheet import plan_sheet, write_expansion_pdf
from .hullplots import display_class

G_SAMPLES = 401
LAYER_COLOURS = {"flat": 5, "developable": 3, "patch": 4, "formed": 30, "failed": 1}  # ACI
LAYER_NAMES = {"flat": "EXP_FLAT", "developable": "EXP_STRIP", "patch": "EXP_ROLLED", "formed": "EXP_FORMED",
               "failed": "EXP_FAILED"}
DRAWING_TOLERANCE_MM = 0.5  # polylines of the DXF thinned to this
GAP_SHOWN_MM = 0.5  # paper mm: a gap between faces this wide on the sheet is seen, and the sheet says why
LEVEL_COLOURS = {"waterline": 150, "deck": 6}  # ACI
# the DXF's other layers: name, ACI colour, linetype (ezdxf's standard set)
DXF_LAYERS = (("EXP_SEAMS", 7, "Continuous"), ("EXP_BUTTS", 7, "Continuous"), ("EXP_FRAMES", 8, "DASHED"),
              ("EXP_TEXT", 7, "Continuous"), ("EXP_WATERLINES", LEVEL_COLOURS["waterline"], "DASHDOT"),
              ("EXP_DWL", LEVEL_COLOURS["waterline"], "Continuous"), ("EXP_DECKS", LEVEL_COLOURS["deck"], "Continuous"),
              ("EXP_MATCH", 7, "CENTER"), ("EXP_SHEET", 7, "Continuous"))
LEVEL_LAYERS = {"waterline": "EXP_WATERLINES", "design": "EXP_DWL", "deck": "EXP_DECKS"}
# the layers of each line kind of the sheet's legend (:func:`.expansion_sheet.line_kinds`)
KIND_LAYERS = {"seam": ("EXP_SEAMS", "EXP_BUTTS"), "frame": ("EXP_FRAMES",), "match": ("EXP_MATCH",),
               **{kind: (layer,) for kind, layer in LEVEL_LAYERS.items()}}
ON_CENTRE = 1e-5  # of the surface's length: a contour point this near y = 0 is on the centre plane
NEAR_END = 1e-4  # of the surface's length: a station this close beyond an iso-curve's end takes the end


@dataclass(frozen=True)
class Sections:
    """Girth along the sections x = stations[k]: ``g`` (n,) girth parameters ascending,
    ``girth`` (K, n) arc length from the section's start (model units; NaN where the iso-g
    curve does not reach x = X), ``from_high``: girth is counted from the high end of g
    (when that end lies lower, e.g. a surface whose g runs from deck to keel); ``z`` (K, n)
    the z of the section points girth is tabled for."""

    stations: np.ndarray
    g: np.ndarray
    girth: np.ndarray
    from_high: bool
    starts: np.ndarray  # (K,) g where a section starts on the surface's end edge between samples (else NaN)
    start_girth: np.ndarray  # (K,) the girth there: along the contour from the centre plane (0 at a stem)
    points: np.ndarray  # (K, n, 3) the section points girth is tabled for (NaN where girth is)
    # (K,) the section starts on the surface's girth edge off the centre plane: its girth may
    # continue another face's (:func:`joined_offsets`)
    joinable: np.ndarray

    @property
    def z(self) -> np.ndarray:
        """(K, n) the section points' z (NaN where girth is), for waterlines and decks."""
        return self.points[..., 2]

    def at(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Girth (N,) of points at x (N,) on the iso-g curves g (N,): bilinear in the table
        (next to a section's end, where one neighbour is off the section, the other's value)."""
        x, g = np.asarray(x, dtype=float), np.asarray(g, dtype=float)
        k = np.clip(np.searchsorted(self.stations, x) - 1, 0, len(self.stations) - 2)
        x0, x1 = self.stations[k], self.stations[k + 1]
        w = np.clip((x - x0) / np.where(x1 > x0, x1 - x0, 1.0), 0.0, 1.0)
        dg = self.g[1] - self.g[0]
        j = np.clip(((g - self.g[0]) / dg).astype(int), 0, len(self.g) - 2)
        t = np.clip((g - self.g[j]) / dg, 0.0, 1.0)

        def along(rows):
            a, b = self.girth[rows, j], self.girth[rows, j + 1]
            value = _between(a, b, t)
            # a section that starts on the contour between the two samples, at tau: its girth
            # grows from the start's (0 on a stem) there to the present sample's
            tau = (self.starts[rows] - self.g[j]) / dg
            inside = (tau > 0.0) & (tau < 1.0)
            tau = np.where(inside, tau, 0.5)
            start = self.start_girth[rows]
            after = inside & np.isnan(a) & np.isfinite(b)  # counted up the g samples
            before = inside & np.isnan(b) & np.isfinite(a)  # counted down them (from the high end)
            value = np.where(after, start + (b - start) * np.clip((t - tau) / (1.0 - tau), 0.0, 1.0), value)
            return np.where(before, start + (a - start) * np.clip((tau - t) / tau, 0.0, 1.0), value)

        lo, hi = along(k), along(k + 1)
        # a station where this g is off the section (the hull's end): the other one's value
        lo, hi = np.where(np.isnan(lo), hi, lo), np.where(np.isnan(hi), lo, hi)
        out = (1.0 - w) * lo + w * hi
        for i in np.flatnonzero(np.isnan(out)):  # off both sections: the nearest station that has this g
            column = _between(self.girth[:, j[i]], self.girth[:, j[i] + 1], t[i])
            has = np.flatnonzero(np.isfinite(column))
            if len(has):
                out[i] = column[has[np.argmin(np.abs(self.stations[has] - x[i]))]]
        return out

    def total(self) -> np.ndarray:
        """The whole girth (K,) of each section."""
        return np.nanmax(self.girth, axis=1, initial=0.0)


def _between(a: np.ndarray, b: np.ndarray, t) -> np.ndarray:
    """a + t (b - a) elementwise; the one that is present where the other is NaN."""
    return np.where(np.isnan(a), b, np.where(np.isnan(b), a, a + t * (b - a)))


def _uv(axis: int, s, g):
    return (s, g) if axis == 0 else (g, s)


def section_table(surface, axis: int, stations: np.ndarray, n: int = G_SAMPLES, probe: int = 800) -> Sections:
    """The girth table of ``surface`` (long axis ``axis``: 0 when u runs along the hull) at
    stations (K,) (model units of x)."""
    sdom = surface.domain_u if axis == 0 else surface.domain_v
    gdom = surface.domain_v if axis == 0 else surface.domain_u
    g = np.linspace(*gdom, n)
    s = np.linspace(*sdom, probe)
    S, G = np.meshgrid(s, g)  # (n, probe)
    x = surface(*_uv(axis, S.ravel(), G.ravel()))[:, 0].reshape(n, probe)
    stations = np.asarray(stations, dtype=float)
    K = len(stations)
    lo_s = np.full((K, n), np.nan)
    hi_s = np.full((K, n), np.nan)
    lo_f = np.full((K, n), np.nan)
    hi_f = np.full((K, n), np.nan)
    near = NEAR_END * float(np.ptp(x))
    step = np.diff(x, axis=1)
    monotone = np.all(step > 0, axis=1) | np.all(step < 0, axis=1)
    # which of the surface's two ends lies in a plane x = const (within near), not on a contour
    low_end, high_end = np.minimum(x[:, 0], x[:, -1])[monotone], np.maximum(x[:, 0], x[:, -1])[monotone]
    plane_ends = [bool(len(e) and np.ptp(e) <= near) for e in (low_end, high_end)]
    for i in np.flatnonzero(monotone):  # an iso-g curve running one way along x: bisect all stations
        xr = x[i] if step[i, 0] > 0 else x[i, ::-1]
        inside = (stations >= xr[0]) & (stations <= xr[-1])  # a station at the curve's very end included
        j = np.clip(np.searchsorted(xr, stations[inside]) - 1, 0, probe - 2)
        jj = j if step[i, 0] > 0 else probe - 1 - j  # back to the curve's own order: j and j + 1
        a, b = (jj, jj + 1) if step[i, 0] > 0 else (jj - 1, jj)
        lo_s[inside, i], hi_s[inside, i] = s[a], s[b]
        lo_f[inside, i], hi_f[inside, i] = x[i, a] - stations[inside], x[i, b] - stations[inside]
        # a station just beyond the curve's end takes the end where the hull ends in a plane
        # x = const whose iso-curves end a millimetre apart: whole sections up to it, not gaps
        for end, beyond in ((0, (stations < xr[0]) & (stations >= xr[0] - near) & plane_ends[0]),
                            (-1, (stations > xr[-1]) & (stations <= xr[-1] + near) & plane_ends[1])):
            at = (0 if step[i, 0] > 0 else probe - 1) if end == 0 else (probe - 1 if step[i, 0] > 0 else 0)
            lo_s[beyond, i] = hi_s[beyond, i] = s[at]
            lo_f[beyond, i] = hi_f[beyond, i] = 0.0
    rest = np.flatnonzero(~monotone)
    for k, X in enumerate(stations if len(rest) else []):  # other curves: their first bracketing probes
        f = x[rest] - X
        change = np.sign(f[:, :-1]) * np.sign(f[:, 1:]) <= 0
        has = change.any(axis=1)
        j = np.argmax(change, axis=1)
        rows = np.flatnonzero(has)
        lo_s[k, rest[rows]], hi_s[k, rest[rows]] = s[j[rows]], s[j[rows] + 1]
        lo_f[k, rest[rows]], hi_f[k, rest[rows]] = f[rows, j[rows]], f[rows, j[rows] + 1]
    ok = ~np.isnan(lo_s)
    GG = np.broadcast_to(g, (K, n))
    XX = np.broadcast_to(stations[:, None], (K, n))
    a, b, fa, fb = lo_s[ok], hi_s[ok], lo_f[ok], hi_f[ok]
    gq, Xq = GG[ok], XX[ok]
    for _ in range(4):  # regula falsi, vectorised over every (station, g)
        denom = fb - fa
        m = np.where(np.abs(denom) > 0, a - fa * (b - a) / np.where(denom != 0, denom, 1.0), a)
        fm = surface(*_uv(axis, m, gq))[:, 0] - Xq
        left = np.sign(fm) == np.sign(fa)
        a, fa = np.where(left, m, a), np.where(left, fm, fa)
        b, fb = np.where(left, b, m), np.where(left, fb, fm)
    denom = fb - fa
    root = np.where(np.abs(denom) > 0, a - fa * (b - a) / np.where(denom != 0, denom, 1.0), a)
    pts = np.full((K, n, 3), np.nan)
    pts[ok] = surface(*_uv(axis, root, gq))
    seg = np.linalg.norm(np.diff(pts, axis=1), axis=2)  # NaN next to a missing point
    low_z = np.nanmean(pts[:, 0, 2]) if np.isfinite(pts[:, 0, 2]).any() else 0.0
    high_z = np.nanmean(pts[:, -1, 2]) if np.isfinite(pts[:, -1, 2]).any() else 0.0
    from_high = bool(high_z < low_z)
    if abs(high_z - low_z) <= near:  # both girth edges at one height (a flat bottom): from the one nearer y = 0
        from_high = bool(np.nanmean(np.abs(pts[:, -1, 1])) < np.nanmean(np.abs(pts[:, 0, 1])))
    if from_high:
        seg = seg[:, ::-1]
    girth = np.full((K, n), np.nan)
    ends = _end_edges(surface, axis, g[::-1] if from_high else g)
    on_centre = ON_CENTRE * float(np.ptp(x))
    starts = np.full(K, np.nan)
    start_girth = np.zeros(K)
    joinable = np.zeros(K, dtype=bool)
    for k in range(K):
        present = np.isfinite(pts[k, ::-1, 0] if from_high else pts[k, :, 0])
        if present.sum() < 2:
            continue
        first = int(np.argmax(present))
        # the section's longest run from its start (a gap ends it)
        run = present[first:]
        stop = first + (int(np.argmin(run)) if not run.all() else len(run))
        row = np.full(n, np.nan)
        if first:
            row[first], starts[k], start_girth[k] = _lead_in(
                ends, first, stations[k], pts[k, n - 1 - first if from_high else first], on_centre)
        else:
            row[first] = 0.0
            joinable[k] = abs(pts[k, n - 1 if from_high else 0, 1]) > on_centre
        row[first + 1:stop] = row[first] + np.cumsum(seg[k, first:stop - 1])
        girth[k] = row[::-1] if from_high else row
    pts[~np.isfinite(girth)] = np.nan
    return Sections(stations, g, girth, from_high, starts, start_girth, pts, joinable)


def _end_edges(surface, axis: int, g: np.ndarray) -> tuple:
    """The surface's two end edges (its long parameter's ends) at the girth samples ``g``
    (n,), in the order the girth counts them: two (n, 3) point arrays and their g."""
    sdom = surface.domain_u if axis == 0 else surface.domain_v
    return tuple(surface(*_uv(axis, np.full(len(g), s), g)) for s in sdom), g


def _lead_in(ends: tuple, first: int, station: float, start: np.ndarray,
             on_centre: float) -> tuple[float, float, float]:
    """The girth of a section's first tabled point ``start`` when the section begins on an end
    edge of the surface (the stem or stern contour) between girth samples first - 1 and
    first (in the order girth counts them), and the g of that beginning: the chord from the
    contour's crossing C of x = station (linear between the two samples) to the point, plus
    the girth of C itself, counted along the contour as the sections count it along
    themselves: from the centre plane (the last sample within ``on_centre`` of y = 0 before
    C; where the contour runs on the centre plane, a stem, C is on it and counts 0), or from
    the contour's start where none is (a face that does not reach the centre plane). So a
    section that starts on a transom's edge continues the girths of the sections that run
    from the keel past that edge, instead of starting again from 0. Returns the girth at
    ``start``, the g of the beginning and the girth there; (0, NaN, 0) where neither end
    edge crosses the station there."""
    (lo_edge, hi_edge), g = ends
    for edge in (lo_edge, hi_edge):
        a, b = edge[first - 1], edge[first]
        if (a[0] - station) * (b[0] - station) <= 0 and a[0] != b[0]:
            f = (station - a[0]) / (b[0] - a[0])
            crossing = a + f * (b - a)
            girth = _along_contour(edge[:first], crossing, on_centre)
            return (float(np.linalg.norm(start - crossing)) + girth, float(g[first - 1] + f * (g[first] - g[first - 1])),
                    girth)
    return 0.0, float("nan"), 0.0


def _along_contour(before: np.ndarray, crossing: np.ndarray, on_centre: float) -> float:
    """The arc length along a contour's samples ``before`` (M, 3) then to ``crossing`` (3,),
    from the last sample within ``on_centre`` of the centre plane y = 0 (0 when the crossing
    itself is that near it), else from the first sample."""
    if abs(crossing[1]) <= on_centre:
        return 0.0
    centre = np.flatnonzero(np.abs(before[:, 1]) <= on_centre)
    run = np.vstack([before[centre[-1] if len(centre) else 0:], crossing[None]])
    return float(np.linalg.norm(np.diff(run, axis=0), axis=1).sum())


def stations_for(plates: list[PlateEdges], frames: list[float], count: int = 400) -> np.ndarray:
    """Every butt's x (the end columns' mean x), the frames, ``count`` stations evenly over the
    plates' x range, and the x of every point of an end column that is no plane x = const (a
    plate's edge on the hull's end: the stem or stern contour, where each section starts at
    the contour, so that its points are tabled on sections through them)."""
    xs = np.concatenate([p.points[..., 0].ravel() for p in plates])
    lo, hi = float(xs.min()), float(xs.max())
    butts = [float(np.mean(p.points[:, c, 0])) for p in plates for c in (0, -1)]
    contour = [p.points[:, c, 0] for p in plates for c in (0, -1) if np.ptp(p.points[:, c, 0]) > 1e-3 * (hi - lo)]
    every = np.linspace(lo, hi, count)
    return np.unique(np.round(np.concatenate([every, butts, [f for f in frames if lo <= f <= hi], *contour]), 9))


@dataclass(frozen=True)
class ExpandedPlate:
    """A plate in the expansion: ``outline`` (N, 2) closed ring (x, girth), model units;
    ``seams`` and ``butts``: its two seam and two butt edges as (M, 2) polylines; its class
    (flat, developable, patch, formed, failed), ``thickness`` mm, ``band`` its surface."""

    name: str
    outline: np.ndarray
    seams: tuple
    butts: tuple
    klass: str
    thickness: float | None
    band: int
    trim_lines: tuple = ()  # where the plate is cut at its face's trim: the cut's runs (M, 2)


def _map(plate: PlateEdges, hull, to_drawing) -> tuple:
    """The plate's outline ring, seams, butts and trim lines on the drawing; ``to_drawing``
    maps points (N, 3) with their parameters (N, 2) there (N, 2). A plate that reaches past its
    face's trim (``hull.trim``) is drawn as the shop cuts it (:func:`.expansion_faces.cut_at_trim`):
    its region's part inside the trim, its seams and butts clipped to it, and the trim's run
    across it as its trim line."""
    points, params = plate.points, plate.params

    def line(rows, cols):
        return to_drawing(points[rows, cols], params[rows, cols])

    r, c = plate.points.shape[:2]
    every_c, every_r = np.arange(c), np.arange(r)
    s_lo, s_hi = line(np.zeros(c, int), every_c), line(np.full(c, r - 1), every_c)
    b_lo, b_hi = line(every_r, np.zeros(r, int)), line(every_r, np.full(r, c - 1))
    ring = np.vstack([s_lo, b_hi[1:], s_hi[::-1][1:], b_lo[::-1][1:-1]])
    cut = cut_at_trim(plate, hull, to_drawing) if getattr(hull, "trim", None) is not None else None
    if cut is None:
        return ring, (s_lo, s_hi), (b_lo, b_hi), ()
    outline, trim_lines = cut
    return outline, clipped((s_lo, s_hi), outline), clipped((b_lo, b_hi), outline), trim_lines


def girth_map(table: Sections, axis: int, offset: np.ndarray):
    """Points (N, 3) with their parameters (N, 2) -> (x, girth) (N, 2) by the face's section
    table, its girth parameter the one across ``axis``, plus its girth offset (K,) at the
    table's stations."""
    def to_drawing(points: np.ndarray, params: np.ndarray) -> np.ndarray:
        x = points[..., 0]
        return np.column_stack([x, table.at(x, params[..., 1 - axis]) + np.interp(x, table.stations, offset)])
    return to_drawing


@dataclass(frozen=True)
class Expansion:
    """The drawing's content, model units: plates, frames (x, girth bottom, girth top, band,
    frame number) and each band's girth offset and height; ``levels`` the waterlines and
    decks (:class:`.levels.Level`), ``base_line`` the z they count from, ``notes`` what is
    not drawn and why (a deck the shell does not reach)."""

    plates: tuple
    frames: tuple
    bands: tuple
    x_range: tuple
    girth_from: str
    levels: tuple = ()
    base_line: float | None = None
    notes: tuple = ()
    # faces drawn continuing another: (face, the face it continues, stations (K,), the girth
    # left open between that face's plates and its section's start there (K,), NaN where it
    # continues another or none: :func:`.expansion_faces.open_below`), names as the plates'
    joins: tuple = ()
    # faces drawn in true shape: (face, :class:`.expansion_faces.TrueShape`)
    true_shapes: tuple = ()

    @property
    def height(self) -> float:
        """The drawing's girth extent, every band and the gaps between (model units)."""
        return max((offset + height for offset, height in self.bands), default=0.0)


def expand(results, edges: dict, frames: list[tuple[int, float]], gap: float, waterlines=None, decks: list = (),
           base_line: float | None = None, snap: float = 0.0) -> Expansion:
    """Map every plate of ``results`` (with ``edges`` by name) into girth x length, the
    faces (hull surfaces) joined where one's sections start on another's and drawn in one
    band where their plates do not overlap, other bands ``gap`` (model units) apart
    (:mod:`.expansion_faces`); ``frames`` (number, x).

    ``waterlines`` (:class:`pipeline.config.WaterlineSpec`) and ``decks``
    (:class:`.levels.DeckProfile`) are drawn where the shell reaches them, heights from
    ``base_line`` (model z; default the shell's lowest point), a point within ``snap`` (model
    units) of a level on it."""
    groups: dict[int, list] = {}
    for r in results:
        e = edges.get(r.name)
        if e is not None:
            groups.setdefault(id(r.part.hull.surface), []).append((r, e))
    faces = list(groups.values())
    frame_x = [x for _, x in frames]
    # every face tabled at its own stations and the others' within its x range, so that the
    # sections of two faces meet at equal stations
    own = [stations_for([e for _, e in members], frame_x) for members in faces]
    every = np.unique(np.concatenate(own))
    tables = []
    for members, stations in zip(faces, own):
        hull = members[0][0].part.hull
        inside = every[(every >= stations[0]) & (every <= stations[-1])]
        tables.append(section_table(hull.surface, hull.long_axis, inside))
    x_all = np.concatenate([t.stations for t in tables])
    join = JOIN * float(np.ptp(x_all))
    across = [stands_across([e.points for _, e in members]) if len(faces) > 1 else False for members in faces]
    offsets, continues, order, parents = joined_offsets(tables, join, across)
    mapped = [_map_face(members, table, offset) for members, table, offset in zip(faces, tables, offsets)]
    band_of, joined = place_bands(mapped, continues, order, join, across)
    for f in range(len(faces)):
        if not joined[f]:
            offsets[f] = np.zeros(len(tables[f].stations))
            mapped[f] = _map_face(faces[f], tables[f], offsets[f])
    # a face that stands across the hull in a band of its own: in true shape, its own plane
    shapes = {f: true_shape([e.points for _, e in faces[f]], (float(x_all.min()), float(x_all.max())))
              for f in range(len(faces)) if across[f]}
    for f, shape in shapes.items():
        mapped[f] = [_map(e, r.part.hull, shape) for r, e in faces[f]]
    heights = {}
    for f, table in enumerate(tables):
        if f in shapes:
            top = shapes[f].height
        else:
            top = np.nanmax(table.girth + offsets[f][:, None]) if np.isfinite(table.girth).any() else 0.0
        heights[band_of[f]] = max(heights.get(band_of[f], 0.0), float(top))
    bands, base = [], {}
    for band in range(len(heights)):
        base[band] = bands[-1][0] + bands[-1][1] + gap if bands else 0.0
        bands.append((base[band], heights[band]))
    plates = []
    for f, members in enumerate(faces):
        by = base[band_of[f]]
        for (r, _), (ring, seams, butts, trim_lines) in zip(members, mapped[f]):
            plates.append(ExpandedPlate(r.name, _shifted(ring, by), tuple(_shifted(s, by) for s in seams),
                                        tuple(_shifted(b, by) for b in butts), display_class(r),
                                        getattr(getattr(r.part, "steel", None), "thickness", None), band_of[f],
                                        tuple(_shifted(t, by) for t in trim_lines)))
    # (a true shape has no sections x = const to draw frames, waterlines or decks along)
    placed = [(table, base[band_of[f]] + offsets[f], band_of[f]) for f, table in enumerate(tables) if f not in shapes]
    sides = {"high" if table.from_high else "low" for table in tables}
    side = "the low end of the girth parameter" if sides == {"low"} else (
        "the high end of the girth parameter" if sides == {"high"} else "the lower end of each surface's girth")
    if any(joined[f] and continues[f] for f in range(len(faces))):
        side += "; a face whose sections start on another face's continues its girth"
    levels, base_z, notes = _levels(placed, waterlines, decks, base_line, snap)
    labels = [_face_label([r.name for r, _ in members]) for members in faces]
    true_shapes = tuple((labels[f], shape) for f, shape in shapes.items())
    drawn_joins = []
    for f in range(len(faces)):
        for g in continues[f] if joined[f] and len(faces) > 1 else ():
            starts = np.where(parents[f] == g, offsets[f], np.nan)  # where its sections start, in the band
            region = face_region([ring for ring, _, _, _ in mapped[g]])
            drawn_joins.append((labels[f], labels[g], tables[f].stations,
                                open_below(region, tables[f].stations, starts)))
    return Expansion(tuple(plates), _frame_lines(placed, frames, len(bands)), tuple(bands),
                     (float(x_all.min()), float(x_all.max())), side, levels, base_z, notes, tuple(drawn_joins),
                     true_shapes)


def _face_label(names: list[str]) -> str:
    """A face's name as its plates' names give it: the plan's ``NAME_Pk`` (several faces)."""
    import re

    found = re.match(r"(.*_P\d+)_", names[0])
    return found.group(1) if found else (os.path.commonprefix(names).rstrip("_") or names[0])


def shape_notes(drawing: Expansion, mm: float) -> list[str]:
    """The sheet's words on the faces it draws in true shape, not in girth x length."""
    return [f"{face.upper()} STANDS ACROSS THE HULL: DRAWN IN TRUE SHAPE IN ITS OWN PLANE, ITS CENTRE-PLANE EDGE "
            f"AT X = {shape.start * mm / 1000:.1f} M, ITS BREADTH OUT FROM THE CENTRE PLANE "
            f"({shape.width * mm / 1000:.2f} M) ALONG THE SHEET TOWARD {'HIGHER' if shape.sign > 0 else 'LOWER'} X, "
            f"ITS HEIGHT UP ITS FACE ({shape.height * mm / 1000:.2f} M) UPWARD"
            for face, shape in drawing.true_shapes]


def gap_notes(drawing: Expansion, least: float, mm: float) -> list[str]:
    """The sheet's words on where the drawing leaves ``least`` or more (model units) of girth
    open between a face and the plates of the face it continues: the model's faces do not
    meet there (its shell has a hole), not a plate missing."""
    out = []
    for face, other, stations, gaps in drawing.joins:
        for x0, x1, widest in gap_stretches(stations, gaps, least):
            where = f"X = {x0 * mm / 1000:.1f} M" if x1 <= x0 else f"X = {x0 * mm / 1000:.1f} TO {x1 * mm / 1000:.1f} M"
            out.append(f"{face.upper()} DOES NOT MEET {other.upper()} AT {where}: UP TO {widest * mm:.0f} MM OF GIRTH "
                       "OPEN, A HOLE IN THE HULL MODEL (NO PLATE MISSING)")
    return out


def _map_face(members: list, table: Sections, offset: np.ndarray) -> list[tuple]:
    """Each plate of a face mapped with the face's girth offset (K,) at the table's stations."""
    return [_map(e, r.part.hull, girth_map(table, r.part.hull.long_axis, offset)) for r, e in members]


def _shifted(line: np.ndarray, by: float) -> np.ndarray:
    return line + np.array([0.0, by]) if by else line


def _frame_lines(placed: list, frames: list, bands: int) -> tuple:
    """(x, girth bottom, girth top, band, number) of each frame in each band its faces reach."""
    lines = []
    totals = [table.total() for table, _, _ in placed]
    for band in range(bands):
        for number, f in frames:
            ends = []
            for (table, offset, b), total in zip(placed, totals):
                if b == band and table.stations[0] <= f <= table.stations[-1]:
                    k = int(np.argmin(np.abs(table.stations - f)))
                    top = float(total[k])
                    if top > 0:
                        ends.append((float(offset[k]), float(offset[k]) + top))
            if ends:
                lines.append((float(f), min(lo for lo, _ in ends), max(hi for _, hi in ends), band, number))
    return tuple(lines)


def _levels(tables: list, waterlines, decks: list, base_line: float | None, snap: float) -> tuple:
    """The waterlines' and decks' lines on every band, the base line, and notes."""
    from .levels import Level, crossings, waterline_heights

    if waterlines is None and not decks:
        return (), base_line, ()
    z_all = [t.z[np.isfinite(t.z)] for t, _, _ in tables]
    z_all = np.concatenate(z_all) if z_all else np.zeros(0)
    if not len(z_all):
        return (), base_line, ("no waterlines or decks: the sections have no points",)
    base = float(z_all.min()) if base_line is None else float(base_line)
    stations = np.concatenate([t.stations for t, _, _ in tables])
    deck_z = [deck.at(stations, base) for deck in decks]

    def named_by_a_deck(h: float) -> bool:  # a waterline on a deck's own line is drawn once, as the deck
        return any(np.isfinite(z).all() and np.abs(z - (base + h)).max() <= snap for z in deck_z)

    wanted = [] if waterlines is None else [
        (name, kind, lambda x, h=h: np.full(len(x), base + h))
        for name, kind, h in waterline_heights(waterlines.spacing, waterlines.design, float(z_all.max()) - base)
        if not named_by_a_deck(h)]
    wanted += [(deck.name, "deck", lambda x, deck=deck: deck.at(x, base)) for deck in decks]
    levels, notes = [], []
    for name, kind, level_at in wanted:
        found = []
        for table, offset, band in tables:
            lines = crossings(table.stations, table.girth + offset[:, None], table.z, level_at(table.stations), snap)
            if lines:
                found.append(Level(name, kind, tuple(lines), band))
        if found:
            levels += found
        elif kind == "deck":
            z = level_at(stations)
            z = z[np.isfinite(z)]
            where = (f"at z {z.min():g} to {z.max():g}" if len(z) and np.ptp(z) > 0 else
                     f"at z {z[0]:g}" if len(z) else "beyond the shell's length")
            notes.append(f"{name} ({where}) does not meet the shell (z {z_all.min():g} to {z_all.max():g}): not drawn")
    return tuple(levels), base, tuple(notes)


def plan_frames(spec_frames, x_range: tuple[float, float]) -> list[tuple[int, float]]:
    """(number, x) of the frames over the plan's x range (model units; frame k at
    start + k spacing), or none."""
    if spec_frames is None:
        return []
    lo, hi = x_range
    first = int(np.ceil((lo - spec_frames.start) / spec_frames.spacing))
    last = int(np.floor((hi - spec_frames.start) / spec_frames.spacing))
    if last - first > 5000:
        return []
    return [(k, spec_frames.start + k * spec_frames.spacing) for k in range(first, last + 1)]


def thin(line: np.ndarray, tolerance: float) -> np.ndarray:
    """The polyline (N, 2) with the points Ramer-Douglas-Peucker keeps within ``tolerance``
    (a drawing: a butt, straight in the expansion, keeps its two ends)."""
    keep = np.zeros(len(line), dtype=bool)
    keep[[0, -1]] = True
    stack = [(0, len(line) - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        chord = line[j] - line[i]
        rel = line[i + 1:j] - line[i]
        norm = np.hypot(*chord)
        d = (np.abs(chord[0] * rel[:, 1] - chord[1] * rel[:, 0]) / norm if norm > 0 else np.hypot(rel[:, 0], rel[:, 1]))
        k = int(np.argmax(d))
        if d[k] > tolerance:
            keep[i + 1 + k] = True
            stack += [(i, i + 1 + k), (i + 1 + k, j)]
    return line[keep]


def write_expansion_dxf(target: str | Path, drawing: Expansion, mm_per_unit: float, title: str, sheet,
                        info: dict) -> None:
    """The expansion in model space at 1:1, millimetres: x along the hull, y the girth; and
    the ``sheet`` (:class:`.expansion_sheet.SheetPlan`) laid out in paper space as the PDF
    is (a viewport per part at the sheet's scale, captions, scale bar, title block), the
    linetypes scaled for plotting at that scale."""
    import ezdxf

    from .expansion_sheet import (
        add_paper_layout,
        frame_at,
        level_label_places,
        line_kinds,
        plate_label,
        ring_centre,
    )

    doc = ezdxf.new("R2000", setup=["linetypes"])
    doc.header["$INSUNITS"] = 4
    doc.header["$MEASUREMENT"] = 1
    doc.header["$LTSCALE"] = float(sheet.scale)  # dashes as long on paper at 1:scale as the pattern says
    doc.header["$PSLTSCALE"] = 0  # and in the viewports, which draw at that scale
    msp = doc.modelspace()
    for klass, layer in LAYER_NAMES.items():
        doc.layers.add(layer, color=LAYER_COLOURS[klass])
    for layer, colour, linetype in DXF_LAYERS:
        doc.layers.add(layer, color=colour, linetype=linetype)
    mm = mm_per_unit
    heights = []
    for p in drawing.plates:
        layer = LAYER_NAMES.get(p.klass, "EXP_FAILED")
        seams, butts = ([thin(line * mm, DRAWING_TOLERANCE_MM) for line in lines] for lines in (p.seams, p.butts))
        if p.trim_lines:  # cut at its face's trim: the cut outline, its corners among its points
            ring = thin(np.vstack([p.outline, p.outline[:1]]) * mm, DRAWING_TOLERANCE_MM)[:-1]
        else:  # each side thinned alone: the four corners stay vertices
            (s_lo, s_hi), (b_lo, b_hi) = seams, butts
            ring = np.vstack([s_lo, b_hi[1:], s_hi[::-1][1:], b_lo[::-1][1:-1]])
        msp.add_lwpolyline(ring.tolist(), close=True, dxfattribs={"layer": layer})
        # a trim line is the plate's joint with the next face's
        for line in seams + [thin(t * mm, DRAWING_TOLERANCE_MM) for t in p.trim_lines]:
            msp.add_lwpolyline(line.tolist(), dxfattribs={"layer": "EXP_SEAMS"})
        for line in butts:
            msp.add_lwpolyline(line.tolist(), dxfattribs={"layer": "EXP_BUTTS"})
        centre = ring_centre(p.outline) * mm
        length = float(np.ptp(p.outline[:, 0])) * mm
        width = polygon_area(p.outline) * mm * mm / max(length, 1e-300)  # the mean girth width
        name, thick = plate_label(p)
        # at most 5 mm on the paper the sheet plots at
        h = min(max(min(0.25 * width, 0.9 * length / max(len(name), 1)), 1.0), 5.0 * sheet.scale)
        heights.append(h)
        msp.add_text(name, height=h, dxfattribs={"layer": "EXP_TEXT"}).set_placement(
            (float(centre[0]), float(centre[1]) + 0.1 * h), align=ezdxf.enums.TextEntityAlignment.BOTTOM_CENTER)
        if thick:
            msp.add_text(thick, height=0.8 * h, dxfattribs={"layer": "EXP_TEXT"}).set_placement(
                (float(centre[0]), float(centre[1]) - 0.1 * h), align=ezdxf.enums.TextEntityAlignment.TOP_CENTER)
    text_h = float(np.median(heights)) if heights else 100.0
    for x, lo, hi, _, number in drawing.frames:
        msp.add_line((x * mm, lo * mm), (x * mm, hi * mm), dxfattribs={"layer": "EXP_FRAMES"})
        msp.add_text(f"FR {number}", height=0.5 * text_h, dxfattribs={"layer": "EXP_FRAMES"}).set_placement(
            (x * mm, hi * mm + 0.2 * text_h), align=ezdxf.enums.TextEntityAlignment.BOTTOM_CENTER)
    for level in drawing.levels:
        layer = LEVEL_LAYERS[level.kind]
        for line in level.lines:
            points = thin(line * mm, DRAWING_TOLERANCE_MM)
            msp.add_lwpolyline(points.tolist(), dxfattribs={"layer": layer})
        for point, angle in level_label_places(level, drawing.x_range):
            msp.add_text(level.name, height=0.4 * text_h, rotation=angle, dxfattribs={"layer": layer}).set_placement(
                (float(point[0]) * mm, float(point[1]) * mm), align=ezdxf.enums.TextEntityAlignment.BOTTOM_CENTER)
    x0 = drawing.x_range[0] * mm
    top = drawing.height * mm
    # over the frame numbers, and over what the sheet's viewports show above the drawing
    lift = max(2 * text_h, 8.0 * sheet.scale)
    msp.add_text(title, height=2 * text_h, dxfattribs={"layer": "EXP_TEXT", "insert": (x0, top + lift)})
    for k, note in enumerate(info["notes"] if "notes" in info else _level_notes(drawing, mm)):
        msp.add_text(note, height=0.6 * text_h,
                     dxfattribs={"layer": "EXP_TEXT", "insert": (x0, top + lift + (2.5 + 0.9 * k) * text_h)})
    for cut in sheet.cuts:
        x = cut[1] * mm
        msp.add_line((x, 0.0), (x, top), dxfattribs={"layer": "EXP_MATCH"})
        msp.add_text(f"MATCH LINE {frame_at(cut, mm)}", height=text_h, rotation=90.0,
                     dxfattribs={"layer": "EXP_MATCH"}).set_placement(
            (x - 0.3 * text_h, 0.5 * top), align=ezdxf.enums.TextEntityAlignment.BOTTOM_CENTER)
    drawn = {layer for kind in line_kinds(drawing, sheet) for layer in KIND_LAYERS[kind]}
    add_paper_layout(doc, drawing, sheet, mm, title, info, LAYER_NAMES,
                     [layer for layer, _, _ in DXF_LAYERS if layer in drawn])
    with atomic_path(target) as tmp:
        doc.saveas(tmp)


def _level_notes(drawing: Expansion, mm: float) -> list[str]:
    """The sheet's words on its waterlines and decks: the base line they count from, and any
    deck not drawn."""
    if not drawing.levels and not drawing.notes:
        return []
    kinds = {level.kind for level in drawing.levels}
    said = [text for kind, text in (("waterline", "WATERLINES (WL)"), ("design", "THE DESIGN WATERLINE (DWL)"),
                                    ("deck", "DECKS AT SIDE")) if kind in kinds]
    out = []
    if drawing.base_line is not None and said:
        out.append(f"{', '.join(said)}: HEIGHTS ABOVE THE BASE LINE Z = {drawing.base_line * mm:.0f} MM")
    return out + [note.upper() for note in drawing.notes]


def shell_edges(results) -> dict:
    """Every hull plate's region sampled on the hull, by name (None when it misses it)."""
    from .cost import plate_edges

    return {r.name: plate_edges(r.name, r.part.hull) for r in results
            if r.part.hull is not None and r.part.hull.girths is not None}


def write_expansion(results, edges: dict, config, out_dir: Path, style: str, dxf: bool, pdf: bool) -> list[Path]:
    """NAME_expansion.dxf and / or NAME_expansion.pdf of a strake or hull run."""
    hull = [r for r in results if edges.get(r.name) is not None]
    if not hull or not (dxf or pdf):
        return []
    xs = np.concatenate([edges[r.name].points[..., 0].ravel() for r in hull])
    strake = config.spec.strake
    frames = plan_frames(None if strake is None else strake.frames, (float(xs.min()), float(xs.max())))
    drawing = expand(hull, edges, frames, gap=0.05 * float(np.ptp(xs)),
                     waterlines=None if strake is None else strake.waterlines, decks=getattr(config, "decks", ()),
                     base_line=None if strake is None else strake.base_line,
                     snap=DRAWING_TOLERANCE_MM / config.mm_per_unit)
    title = f"{style}: shell expansion, {len(hull)} plates"
    mm = config.mm_per_unit
    sheet = plan_sheet(drawing.x_range, drawing.height, mm, frames)
    info = {"drawing": f"{style.upper()}-EXP: SHELL EXPANSION", "hull": style, "plates": len(hull),
            "side": side_shown(across(hull, edges)), "bow": None if strake is None else strake.bow,
            "issue": config.spec.output.issue,
            "notes": _level_notes(drawing, mm) + shape_notes(drawing, mm)
            + gap_notes(drawing, GAP_SHOWN_MM * sheet.scale / mm, mm)}
    written = []
    if dxf:
        written.append(out_dir / f"{style}_expansion.dxf")
        write_expansion_dxf(written[-1], drawing, mm, title, sheet, info)
    if pdf:
        written.append(out_dir / f"{style}_expansion.pdf")
        page = config.spec.output.expansion_tiles
        tiles = None if page is None else (page, out_dir / f"{style}_expansion_tiles.pdf")
        write_expansion_pdf(written[-1], drawing, sheet, mm, title, info, tiles)
        if tiles is not None:
            written.append(tiles[1])
    return written


def across(hull: list, edges: dict) -> np.ndarray:
    """The plates' points' y, across the hull (the expansion runs along x whichever of the
    surface's parameters does), model units."""
    return np.concatenate([edges[r.name].points[..., 1].ravel() for r in hull])


def side_shown(across: np.ndarray) -> str:
    """The side the expansion draws, as the title block says it: the sign of y (the
    across coordinate) over 98 % of the plates' points."""
    lo, hi = np.nanpercentile(across, [1.0, 99.0])
    if lo >= 0.0:
        return "Y > 0 (PS WHERE Y POINTS TO PORT), THE OTHER SIDE ITS MIRROR"
    if hi <= 0.0:
        return "Y < 0 (SB WHERE Y POINTS TO PORT), THE OTHER SIDE ITS MIRROR"
    return "AS MODELLED, ACROSS Y = 0"
