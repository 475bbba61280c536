"""Roll printout (NAME_roll.pdf): the pieces at 1:1 on a roll plotter's paper, in rows.

A sail loft or a cutting room plots on a roll (914, 1067, 1524 mm wide) rather than tiling
A4 pages. Each piece is turned to the angle that makes it shortest along the roll while
it still fits across the usable width (every degree and every convex-hull edge direction:
a narrowest extent rests on a hull edge), then the pieces are laid in rows across the roll,
tallest first, each into the first row with room (first-fit decreasing height); rows
follow each other along the roll with GAP_MM between them. A page is the roll's width by as
much roll as its rows take, at most MAX_PAGE_MM long (PDF viewers and plotter drivers stop
near 5 m, the 200 inch page of PDF 1.x); a longer layout goes on to further pages, whole
rows each, so no piece is split. Every page starts with a band holding the 10 cm check
square and the page's text (roll width, page k of n, its length and the total).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely

from ..config import ConfigError
from ..io.atomic import atomic_path
from .pieces import TextilePiece
from .printout import CHECK_MM, GAP_MM, PdfPages, _check_square, _draw_pattern, _page_content, _Sheet, piece_drawing

EDGE_MM = 10.0  # unprinted margin along both roll edges
GAP_MM_PIECES = 10.0  # between pieces, and between rows
BAND_MM = CHECK_MM + 2 * GAP_MM + 10.0  # the check square and the page's text, at the start of every page
MAX_PAGE_MM = 5000.0
ANGLES = np.arange(0.0, 180.0, 1.0)


@dataclass(frozen=True)
class RollLayout:
    """Each piece turned (degrees) and moved (mm, on its page) and the page it is on;
    each page's length (mm) along the roll."""

    angles: tuple[float, ...]
    offsets: tuple[np.ndarray, ...]
    page_of: tuple[int, ...]
    page_lengths: tuple[float, ...]
    roll_width: float

    @property
    def length(self) -> float:
        return float(sum(self.page_lengths))


def _turn(degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


def best_angle(ring: np.ndarray, across: float) -> tuple[float, np.ndarray] | None:
    """The angle (degrees) turning the ring (N, 2) mm to its shortest extent along the roll
    (y) among those that fit ``across`` (x, mm), with its extents (2,) [x, y]; None when no
    angle fits."""
    hull = np.asarray(shapely.Polygon(ring).convex_hull.exterior.coords)
    edge = np.diff(hull, axis=0)
    # turning an edge onto the x or the y axis
    edge_angles = -np.degrees(np.arctan2(edge[:, 1], edge[:, 0]))
    angles = np.concatenate([ANGLES, edge_angles % 180.0, (edge_angles + 90.0) % 180.0])
    a = np.radians(angles)
    x = np.outer(np.cos(a), hull[:, 0]) - np.outer(np.sin(a), hull[:, 1])
    y = np.outer(np.sin(a), hull[:, 0]) + np.outer(np.cos(a), hull[:, 1])
    ext = np.stack([np.ptp(x, axis=1), np.ptp(y, axis=1)], axis=1)
    fits = ext[:, 0] <= across + 1e-9
    if not fits.any():
        return None
    k = np.flatnonzero(fits)[np.argmin(ext[fits, 1])]
    return float(angles[k]), ext[k]


def roll_layout(pieces: list[TextilePiece], scale: float, roll_width: float, where: str) -> RollLayout:
    """Rows of pieces across the roll (mm). Raises ConfigError (bad input, naming ``where``)
    when a piece fits across the roll at no angle."""
    usable = roll_width - 2 * EDGE_MM
    turned = []
    for piece in pieces:
        found = best_angle(piece.cut * scale, usable)
        if found is None:
            narrowest = best_angle(piece.cut * scale, np.inf)
            raise ConfigError(f"{where}.roll_width = {roll_width:g}: piece {piece.name} is at least "
                              f"{_narrowest(piece.cut * scale):.1f} mm wide at every angle, more than the "
                              f"{usable:g} mm printable across the roll (edges {EDGE_MM:g} mm)"
                              if narrowest is not None else f"{where}.roll_width: piece {piece.name} is empty")
        turned.append(found)
    order = sorted(range(len(pieces)), key=lambda k: -turned[k][1][1])
    rows: list[dict] = []  # {"height", "used", "members": [(k, x)]}
    for k in order:
        w, h = turned[k][1]
        for row in rows:
            if row["used"] + GAP_MM_PIECES + w <= usable + 1e-9:
                row["members"].append((k, row["used"] + GAP_MM_PIECES))
                row["used"] += GAP_MM_PIECES + w
                break
        else:
            rows.append({"height": h, "used": w, "members": [(k, 0.0)]})
    # rows onto pages: each page starts with its band, no longer than MAX_PAGE_MM unless one row is
    offsets, page_of = [None] * len(pieces), [0] * len(pieces)
    page_lengths = []
    y = BAND_MM
    page = 0
    for row in rows:
        if y > BAND_MM and y + row["height"] + GAP_MM_PIECES > MAX_PAGE_MM:
            page_lengths.append(y)
            page, y = page + 1, BAND_MM
        for k, x in row["members"]:
            angle = turned[k][0]
            ring = pieces[k].cut * scale @ _turn(angle).T
            offsets[k] = np.array([EDGE_MM + x, y]) - ring.min(axis=0)
            page_of[k] = page
        y += row["height"] + GAP_MM_PIECES
    page_lengths.append(y)
    return RollLayout(tuple(t[0] for t in turned), tuple(offsets), tuple(page_of), tuple(page_lengths), roll_width)


def _narrowest(ring: np.ndarray) -> float:
    hull = np.asarray(shapely.Polygon(ring).convex_hull.exterior.coords)
    a = np.radians(np.concatenate([ANGLES, np.linspace(0, 180, 3601)]))
    x = np.outer(np.cos(a), hull[:, 0]) - np.outer(np.sin(a), hull[:, 1])
    return float(np.ptp(x, axis=1).min())


def write_roll_pdf(target: Path, pieces: list[TextilePiece], scale: float, title: str, roll_width: float,
                   where: str = "textile.printout") -> dict:
    """NAME_roll.pdf; returns its figures (roll width, length, pages, each piece's page and
    angle) for the report."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    layout = roll_layout(pieces, scale, roll_width, where)
    # the pieces in page mm: model units to mm (unit turn scaled), turned, moved
    placed = [p.moved(_turn(a) * scale, o) for p, a, o in zip(pieces, layout.angles, layout.offsets)]
    n = len(layout.page_lengths)
    with atomic_path(target) as tmp, PdfPages(tmp) as pdf:
        for page, length in enumerate(layout.page_lengths):
            fig = Figure(figsize=(roll_width / 25.4, length / 25.4))
            FigureCanvasAgg(fig)
            sheet = _Sheet(fig)
            mine = [p for p, k in zip(placed, layout.page_of) if k == page]
            window = shapely.box(0, 0, roll_width, length)
            _draw_pattern(sheet, _page_content(piece_drawing(mine, 1.0, []), window))
            _check_square(sheet, np.array([EDGE_MM, GAP_MM]), "1:1",
                          f"10 cm check square: print at 100 %\nroll page {page + 1} of {n}")
            sheet.text(EDGE_MM + CHECK_MM + 2 * GAP_MM, GAP_MM + CHECK_MM,
                       f"{title}\nroll {roll_width:g} mm wide, page {page + 1} of {n}: {length / 1000:.3f} m "
                       f"of {layout.length / 1000:.3f} m\npieces: {', '.join(p.name for p in mine)}",
                       fontsize=8, va="top", linespacing=1.4)
            pdf.savefig(fig)
    return {"roll_width_mm": roll_width, "length_mm": layout.length, "pages": n,
            "page_lengths_mm": list(layout.page_lengths),
            "pieces": {p.name: {"page": k + 1, "angle_deg": a} for p, k, a in zip(pieces, layout.page_of,
                                                                                  layout.angles)}}
