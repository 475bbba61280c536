"""A large sheet printed on small pages: tiles that keep the sheet's scale.

An office without a plotter prints an A0 drawing on A3 or A4 pages at 100 % and tapes them
together, as poster printing does. Each page shows a window of the sheet at full size; the
windows of neighbouring pages overlap by OVERLAP mm, the last reaching the sheet's edge, so
that a page lies on its neighbour's overlap. The page says where it goes (row and column,
row 1 at the top) and marks, with a dashed line, where the neighbour's window begins: the
line to cut or fold along when taping.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import ceil
from pathlib import Path

from .atomic import atomic_path

PAGES = {"A3": (420.0, 297.0), "A4": (297.0, 210.0)}  # landscape, mm
OVERLAP = 15.0  # mm of the sheet on both of two neighbouring pages
LABEL_MM = 5.0  # from the page's top left corner to its label


@dataclass(frozen=True)
class Tile:
    """A page's window on the sheet: ``row`` and ``col`` from the top left (from 1),
    ``x0``, ``y0`` its lower left corner in sheet mm (y up), ``size`` the page's (w, h) mm."""

    row: int
    col: int
    x0: float
    y0: float
    size: tuple[float, float]


def tile_windows(sheet: tuple[float, float], page: str) -> list[Tile]:
    """The tiles of a sheet (w, h) mm on pages of size ``page`` (A3 or A4 landscape), row by
    row from the top: as few as cover it with OVERLAP between neighbours, spread evenly so
    that the first and the last reach the sheet's edges."""
    if page not in PAGES:
        raise ValueError(f"tile pages are one of {sorted(PAGES)}, not {page!r}")
    w, h = sheet
    pw, ph = PAGES[page]

    def starts(length: float, window: float) -> list[float]:
        if length <= window:
            return [0.0]
        count = ceil((length - OVERLAP) / (window - OVERLAP))
        return [k * (length - window) / (count - 1) for k in range(count)]

    columns, rows = starts(w, pw), starts(h, ph)[::-1]
    return [Tile(r + 1, c + 1, x0, y0, (pw, ph)) for r, y0 in enumerate(rows) for c, x0 in enumerate(columns)]


def write_tiles(fig, paper, target: str | Path, sheet: tuple[float, float], page: str, title: str) -> None:
    """Every tile of ``fig`` (the sheet, ``paper`` its axes in sheet mm over the whole
    figure) as one page of a PDF at ``target``, in :func:`tile_windows`' order."""
    from matplotlib.backends.backend_pdf import PdfPages
    from matplotlib.transforms import Bbox

    tiles = tile_windows(sheet, page)
    rows, cols = max(t.row for t in tiles), max(t.col for t in tiles)
    by_place = {(t.row, t.col): t for t in tiles}
    with atomic_path(target) as tmp, PdfPages(tmp) as pdf:
        for tile in tiles:
            pw, ph = tile.size
            x1, y1 = tile.x0 + pw, tile.y0 + ph
            marks = [paper.text(tile.x0 + LABEL_MM, y1 - LABEL_MM,
                                f"{title}: PAGE {tile.row}-{tile.col}, ROW {tile.row} OF {rows}, COLUMN {tile.col} OF "
                                f"{cols} (ROW 1 AT THE TOP); PRINT AT 100 %; DASHED: WHERE THE NEXT PAGE BEGINS",
                                fontsize=5.0, ha="left", va="top", color="0.35", zorder=30,
                                bbox={"facecolor": "white", "edgecolor": "none", "pad": 0.6})]
            right, below = by_place.get((tile.row, tile.col + 1)), by_place.get((tile.row + 1, tile.col))
            if right is not None:
                marks += paper.plot([right.x0] * 2, [tile.y0, y1], color="0.35", linewidth=0.3,
                                    linestyle=(0, (3, 2)), zorder=30)
            if below is not None:
                marks += paper.plot([tile.x0, x1], [below.y0 + below.size[1]] * 2, color="0.35", linewidth=0.3,
                                    linestyle=(0, (3, 2)), zorder=30)
            pdf.savefig(fig, bbox_inches=Bbox([[tile.x0 / 25.4, tile.y0 / 25.4], [x1 / 25.4, y1 / 25.4]]))
            for artist in marks:
                artist.remove()
