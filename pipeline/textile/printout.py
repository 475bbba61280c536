"""Printouts of textile pieces at 1:1: tiled PDF pages (A4, A3, Letter) and one SVG sheet.

``NAME_print.pdf``: page 1 is the assembly map (the pieces scaled down under the page
grid); then one page per tile. The tiles cover the bounding box of the pieces' cut lines
grown by MARGIN_MM, from its top-left corner: rows A, B, ... downwards, columns 1, 2, ...
to the right. A tile's window is the paper's printable area (the paper less ``border`` on
every side) and neighbouring windows share ``overlap`` mm (tiles that show nothing of
any piece are left out): on each page the left and top
window edges are trim (cut) lines where a neighbour exists, and the right and bottom join
lines (dash-dot, grey, marked with the neighbour's label) lie ``overlap`` mm inside the
window, where the neighbour's trimmed edge goes. Every page carries the 5 cm check square
(TILE_CHECK_MM: a 10 cm one took 40 % of an A4 page whenever it needed a band of its own)
with its label (row letter and column number) in a place no pattern line crosses; where
some page has no such place, every page reserves a band below the window for it. Piece
texts sit inside the sew line, clear of the grain line, the notches and the tile edges.
The pattern: cut line solid, sew line dashed, notches, grain line with arrows.

``NAME_print.svg``: the whole sheet at 1:1 on one page (plotters, copy shops).
"""

from __future__ import annotations

import string
from dataclasses import dataclass
from pathlib import Path

import matplotlib
import numpy as np
import shapely
import shapely.affinity
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon as PolygonPatch
from matplotlib.patches import Rectangle
from matplotlib.text import Text
from matplotlib.transforms import Affine2D, Bbox, TransformedBbox
from shapely.geometry import LineString, box

from ..io.atomic import atomic_path
from ..config import Printout
from ..lazymodules import pdf_backend
from .pieces import TextilePiece, label_anchor

PdfPages = pdf_backend().PdfPages  # without fontTools' subsetter: Type 3 fonts do not need it

MARGIN_MM = 5.0  # around the pieces, inside the tiled area
CHECK_MM = 100.0  # the check square of the sheet and the roll, which have room for it
TILE_CHECK_MM = 50.0  # the check square of the tiled pages
GAP_MM = 4.0  # clearance of the check square and texts from lines
PAPER_MM = {"A4": (210.0, 297.0), "A3": (297.0, 420.0), "Letter": (215.9, 279.4)}
PT = 72.0 / 25.4  # points per mm
LW_CUT, LW_SEW, LW_JOIN, LW_TRIM = 0.85, 0.5, 0.45, 0.35  # pt; the tests tell lines apart by width
LABEL_PT = (9.0, 6.0)  # piece text sizes tried, largest first
CHAR_EM = 0.7  # upper bound of a DejaVu Sans glyph's advance, in em


def paper_size(options: Printout) -> tuple[float, float]:
    w, h = PAPER_MM[options.paper]
    return (max(w, h), min(w, h)) if options.orientation == "landscape" else (min(w, h), max(w, h))


@dataclass(frozen=True)
class Tile:
    """One page's window on the sheet (mm): lower-left corner and size."""

    row: int
    col: int
    x0: float
    y0: float
    w: float
    h: float

    @property
    def label(self) -> str:
        return f"{row_name(self.row)}{self.col + 1}"

    @property
    def window(self):
        return box(self.x0, self.y0, self.x0 + self.w, self.y0 + self.h)


def row_name(row: int) -> str:
    letters = string.ascii_uppercase
    return letters[row] if row < 26 else letters[row // 26 - 1] + letters[row % 26]


def tile_sheet(lo: np.ndarray, hi: np.ndarray, window: tuple[float, float], overlap: float) -> list[Tile]:
    """Tiles of size ``window`` (w, h) mm covering [lo, hi] (mm) from its top-left corner,
    neighbours sharing ``overlap`` mm; rows from the top."""
    w, h = window
    size = np.asarray(hi, dtype=float) - np.asarray(lo, dtype=float)
    cols = max(1, int(np.ceil((size[0] - overlap) / (w - overlap) - 1e-9)))
    rows = max(1, int(np.ceil((size[1] - overlap) / (h - overlap) - 1e-9)))
    return [Tile(r, c, lo[0] + c * (w - overlap), hi[1] - h - r * (h - overlap), w, h)
            for r in range(rows) for c in range(cols)]


@dataclass(frozen=True)
class Drawing:
    """Everything drawn of the pieces, in sheet millimetres: lines by kind and the texts
    (position of the box's centre, lines of text, font size in pt)."""

    cut: list
    sew: list
    notches: list
    grain: list
    texts: list


def _text_box(lines: list[str], size_pt: float) -> np.ndarray:
    """Width and height (mm) that hold the lines at this font size."""
    em = size_pt / PT
    return np.array([CHAR_EM * em * max(map(len, lines)), 1.25 * em * len(lines)])


def piece_drawing(pieces: list[TextilePiece], scale: float, edges: list[LineString]) -> Drawing:
    """The pieces in mm; each piece's text inside its sew line, clear of the grain line,
    the notches and the given lines (tile edges), at the largest size that fits."""
    cut, sew, notches, grain, texts = [], [], [], [], []
    for piece in pieces:
        near = shapely.box(*(piece.cut.min(axis=0) * scale), *(piece.cut.max(axis=0) * scale))
        avoid = [np.asarray(e.coords) / scale for e in edges if e.intersects(near)]
        cut.append(np.vstack([piece.cut, piece.cut[:1]]) * scale)
        sew.append(np.vstack([piece.sew, piece.sew[:1]]) * scale)
        notches += [n.line * scale for n in piece.notches]
        grain.append(piece.grain * scale)
        s = piece.settings
        lines = [piece.name, f"size {s.size}  cut {s.quantity}", s.fabric]
        for size_pt in LABEL_PT:
            w, h = _text_box(lines, size_pt)
            at = label_anchor(piece, h / scale, w / scale, GAP_MM / 2 / scale, avoid)
            if at is not None:
                texts.append((at * scale, lines, size_pt))
                break
    return Drawing(cut, sew, notches, grain, texts)


def _clip(lines: list[np.ndarray], window) -> list[np.ndarray]:
    """The parts (K, 2) of polylines inside the window (shapely), so that a page holds only
    what it shows."""
    out = []
    for line in lines:
        part = LineString(line).intersection(window)
        for g in getattr(part, "geoms", [part]):
            if g.geom_type == "LineString" and not g.is_empty:
                out.append(np.asarray(g.coords))
    return out


def _arrow_heads(line: np.ndarray, size: float) -> list[np.ndarray]:
    d = line[1] - line[0]
    d = d / np.hypot(*d)
    n = np.array([-d[1], d[0]])
    return [np.array([tip, tip - size * u + 0.35 * size * n, tip - size * u - 0.35 * size * n])
            for tip, u in ((line[1], d), (line[0], -d))]


def _page_content(drawing: Drawing, window) -> dict:
    """What of the pieces a window shows (sheet mm): clipped lines by kind, arrow heads,
    texts, and the shapes the check square and page texts must keep clear of."""
    content = {kind: _clip(getattr(drawing, kind), window) for kind in ("cut", "sew", "notches", "grain")}
    content["heads"] = [head for line in drawing.grain for head in _arrow_heads(line, 4.0)
                        if shapely.Polygon(head).intersects(window)]
    content["texts"] = []
    blocked = [LineString(part) for kind in ("cut", "sew", "notches", "grain") for part in content[kind]]
    blocked += [shapely.Polygon(head) for head in content["heads"]]
    for at, lines, size_pt in drawing.texts:
        w, h = _text_box(lines, size_pt)
        label = box(at[0] - w / 2, at[1] - h / 2, at[0] + w / 2, at[1] + h / 2)
        if label.intersects(window):
            content["texts"].append((at, lines, size_pt))
            blocked.append(label)
    content["blocked"] = blocked
    return content


def _draw_pattern(ax, content: dict) -> None:
    for kind, style in (("cut", {"lw": LW_CUT, "ls": "-"}), ("sew", {"lw": LW_SEW, "ls": (0, (4, 2))}),
                        ("notches", {"lw": LW_CUT, "ls": "-"}), ("grain", {"lw": 0.6, "ls": "-"})):
        for part in content[kind]:
            ax.plot(part[:, 0], part[:, 1], color="black", solid_capstyle="butt", **style)
    for head in content["heads"]:
        ax.add_patch(PolygonPatch(head, closed=True, color="black", lw=0))
    for at, lines, size_pt in content["texts"]:
        ax.text(at[0], at[1], "\n".join(lines), ha="center", va="center", fontsize=size_pt, linespacing=1.1)


def _free_square(blocked, window, corner: np.ndarray) -> np.ndarray | None:
    """Lower-left corner (mm) of a check square inside the window that nothing blocked
    comes within GAP_MM of, nearest to ``corner``; None when there is none."""
    shapely.prepare(blocked)
    x0, y0, x1, y1 = window.bounds
    xs = np.arange(x0 + GAP_MM, x1 - TILE_CHECK_MM - GAP_MM + 1e-9, 5.0)
    ys = np.arange(y0 + GAP_MM, y1 - TILE_CHECK_MM - GAP_MM + 1e-9, 5.0)
    if not len(xs) or not len(ys):
        return None
    grid = np.array([(x, y) for x in xs for y in ys])
    grid = grid[np.argsort(np.hypot(*(grid - corner).T), kind="stable")]
    for x, y in grid:
        if not blocked.intersects(box(x - GAP_MM, y - GAP_MM, x + TILE_CHECK_MM + GAP_MM, y + TILE_CHECK_MM + GAP_MM)):
            return np.array([x, y])
    return None


def _check_square(ax, at: np.ndarray, title: str, subtitle: str, size: float = CHECK_MM) -> None:
    """The check square ``size`` mm wide (page mm) with the page's label inside."""
    ax.add_patch(Rectangle(tuple(at), size, size, fill=False, color="black", lw=0.6))
    big = size >= CHECK_MM
    ax.text(at[0] + size / 2, at[1] + 0.62 * size, title, ha="center", va="center", fontsize=30 if big else 18)
    ax.text(at[0] + size / 2, at[1] + 0.25 * size, subtitle, ha="center", va="center", fontsize=7 if big else 5.5,
            linespacing=1.3)


class _Sheet:
    """An Axes-free drawing surface on a figure: points (mm) moved by ``-origin`` onto the
    page, 1 mm to 1 mm; artists clipped to ``clip`` (x0, y0, x1, y1 mm) when given. An Axes
    would build its ticks on every page (tens of ms per page); the few Axes methods used
    here are enough."""

    def __init__(self, fig: Figure, origin=(0.0, 0.0), clip=None):
        self.fig = fig
        self.transform = Affine2D().translate(-origin[0], -origin[1]).scale(1 / 25.4) + fig.dpi_scale_trans
        self.clip = None if clip is None else TransformedBbox(Bbox.from_extents(*clip), self.transform)

    def _add(self, artist):
        if self.clip is not None:
            artist.set_clip_box(self.clip)
        self.fig.add_artist(artist)
        return artist

    def plot(self, x, y, **style):
        return self._add(Line2D(x, y, transform=self.transform, **style))

    def add_patch(self, patch):
        patch.set_transform(self.transform)
        return self._add(patch)

    def text(self, x, y, text, **style):
        return self._add(Text(x, y, text, transform=self.transform, **style))


def _page(paper: tuple[float, float]):
    fig = Figure(figsize=(paper[0] / 25.4, paper[1] / 25.4))
    FigureCanvasAgg(fig)
    return fig, _Sheet(fig)  # page coordinates in mm


def _join_marks(page, tile: Tile, origin: np.ndarray, labels: dict, overlap: float, blocked: list) -> None:
    """Trim lines on the left and top window edges, join lines `overlap` inside the right
    and bottom edges (page mm), where neighbours exist; the neighbour's label beside the
    join line where no line crosses it."""
    x0, y0 = origin
    x1, y1 = x0 + tile.w, y0 + tile.h
    sides = {"left": ((x0, y0), (x0, y1), (tile.row, tile.col - 1), "trim"),
             "top": ((x0, y1), (x1, y1), (tile.row - 1, tile.col), "trim"),
             "right": ((x1 - overlap, y0), (x1 - overlap, y1), (tile.row, tile.col + 1), "join"),
             "bottom": ((x0, y0 + overlap), (x1, y0 + overlap), (tile.row + 1, tile.col), "join")}
    for side, (a, b, key, kind) in sides.items():
        if key not in labels:
            continue
        xs, ys = (a[0], b[0]), (a[1], b[1])
        if kind == "trim":
            page.plot(xs, ys, color="0.35", lw=LW_TRIM)
            continue
        page.plot(xs, ys, color="0.45", lw=LW_JOIN, ls=(0, (6, 2, 1, 2)))
        blocked.append(LineString([a, b]))
        text = f"{labels[key]} {'>' if side == 'right' else 'v'}"
        w, h = _text_box([text], 8.0)
        mid = 0.5 * (np.array(a) + np.array(b))
        normal = np.array([-1.0, 0.0]) if side == "right" else np.array([0.0, 1.0])
        obstacles = shapely.unary_union(blocked)
        shapely.prepare(obstacles)
        for shift in np.linspace(0, 0.4, 9):
            for sign in (1, -1):
                along = (np.array(b) - np.array(a)) * shift * sign
                centre = mid + along + normal * (w / 2 + 2.0 if side == "right" else h / 2 + 2.0)
                rect = box(centre[0] - w / 2, centre[1] - h / 2, centre[0] + w / 2, centre[1] + h / 2)
                if not obstacles.intersects(rect):
                    page.text(centre[0], centre[1], text, ha="center", va="center", fontsize=8, color="0.3")
                    blocked.append(rect)
                    break
            else:
                continue
            break


MAX_PAGES = 2000


def count_pages(pieces: list[TextilePiece], scale: float, options: Printout) -> int:
    """Pages the tiled PDF needs at most (with the check-square band), the map included."""
    paper = paper_size(options)
    printable = np.array(paper) - 2 * options.border
    pts = np.vstack([p.cut for p in pieces]) * scale
    lo, hi = pts.min(axis=0) - MARGIN_MM, pts.max(axis=0) + MARGIN_MM
    window = (printable[0], printable[1] - TILE_CHECK_MM - 2 * GAP_MM)
    size = hi - lo
    cols = max(1, int(np.ceil((size[0] - options.overlap) / (window[0] - options.overlap))))
    rows = max(1, int(np.ceil((size[1] - options.overlap) / (window[1] - options.overlap))))
    if rows * cols > 10 * MAX_PAGES:  # too many to look at one by one
        return rows * cols + 1
    shapes = shapely.unary_union([shapely.Polygon(p.cut * scale) for p in pieces])
    return 1 + sum(t.window.intersects(shapes) for t in tile_sheet(lo, hi, window, options.overlap))


def write_tiled_pdf(target: Path, pieces: list[TextilePiece], scale: float, title: str,
                    options: Printout) -> dict:
    """The assembly map and one page per tile; returns the layout (for the report)."""
    paper = paper_size(options)
    b, o = options.border, options.overlap
    printable = np.array(paper) - 2 * b
    pts = np.vstack([p.cut for p in pieces]) * scale
    lo, hi = pts.min(axis=0) - MARGIN_MM, pts.max(axis=0) + MARGIN_MM
    band = 0.0
    for attempt in range(2):
        window = (printable[0], printable[1] - band)
        # tiles that show nothing of any piece are not printed
        shapes = shapely.unary_union([shapely.Polygon(p.cut * scale) for p in pieces])
        tiles = [t for t in tile_sheet(lo, hi, window, o) if t.window.intersects(shapes)]
        edges = [LineString(e) for t in tiles for e in (
            [(t.x0, t.y0), (t.x0, t.y0 + t.h)], [(t.x0 + t.w, t.y0), (t.x0 + t.w, t.y0 + t.h)],
            [(t.x0, t.y0), (t.x0 + t.w, t.y0)], [(t.x0, t.y0 + t.h), (t.x0 + t.w, t.y0 + t.h)])]
        drawing = piece_drawing(pieces, scale, edges)
        pages = _tile_pages(tiles, drawing, paper, b, band, o)
        if pages is not None:
            break
        band = TILE_CHECK_MM + 2 * GAP_MM  # some page has no free place: every page gets a band
    labels = {(t.row, t.col): t.label for t in tiles}
    with atomic_path(target) as tmp, PdfPages(tmp) as pdf:
        pdf.savefig(_assembly_map(tiles, drawing, paper, b, title, options, len(pages)))
        for k, (tile, page_info) in enumerate(zip(tiles, pages)):
            fig = _render_tile(tile, page_info, paper, b, band, o, labels, f"page {k + 2} of {len(tiles) + 1}")
            pdf.savefig(fig)
    return {"paper": options.paper, "orientation": options.orientation, "overlap_mm": o, "border_mm": b,
            "rows": 1 + max(t.row for t in tiles), "columns": 1 + max(t.col for t in tiles),
            "pages": len(tiles) + 1, "check_square_band": band > 0,
            "tiles": [{"label": t.label, "window_mm": [t.x0, t.y0, t.w, t.h]} for t in tiles]}


def _tile_pages(tiles, drawing, paper, b, band, overlap) -> list[dict]:
    """Per tile: what it shows and where its check square goes (page mm; None: nowhere)."""
    out = []
    for tile in tiles:
        content = _page_content(drawing, tile.window)
        shift = (b - tile.x0, b + band - tile.y0)
        blocked = [shapely.affinity.translate(g, *shift) for g in content["blocked"]]
        win = box(b, b + band, b + tile.w, b + band + tile.h)
        # the overlap strips are laid under the neighbour: no square there
        blocked += [box(b + tile.w - overlap, b + band, b + tile.w, b + band + tile.h),
                    box(b, b + band, b + tile.w, b + band + overlap)]
        if band > 0:
            square = np.array([b + GAP_MM, b + GAP_MM])
        else:
            square = _free_square(shapely.unary_union(blocked), win, np.array([b, b]))
            if square is None:
                return None  # no room on this page: the caller reserves a band on every page
        out.append({"content": content, "blocked": blocked, "square": square})
    return out


def _render_tile(tile: Tile, info: dict, paper, b, band, overlap, labels, subtitle) -> Figure:
    fig, page = _page(paper)
    # 1 mm of pattern is 1 mm of paper: the window's corner goes to (b, b + band) on the page
    ax = _Sheet(fig, (tile.x0 - b, tile.y0 - b - band), tile.window.bounds)
    _draw_pattern(ax, info["content"])
    blocked = list(info["blocked"])
    square = info["square"]
    if square is not None:
        blocked.append(box(*(square - GAP_MM), *(square + TILE_CHECK_MM + GAP_MM)))
        _check_square(page, square, tile.label, f"5 cm: print at 100 %\n{subtitle}", TILE_CHECK_MM)
    _join_marks(page, tile, np.array([b, b + band]), labels, overlap, blocked)
    return fig


def _assembly_map(tiles, drawing: Drawing, paper, b, title: str, options: Printout, n_pages: int) -> Figure:
    """Page 1: the sheet scaled to fit above the check square, the page grid labelled."""
    fig, page = _page(paper)
    _check_square(page, np.array([b + GAP_MM, b + GAP_MM]), "map",
                  f"5 cm: print at 100 %\npage 1 of {n_pages + 1}", TILE_CHECK_MM)
    top = b + TILE_CHECK_MM + 2 * GAP_MM
    box_w, box_h = paper[0] - 2 * b, paper[1] - b - top - 30.0
    ax = fig.add_axes((b / paper[0], top / paper[1], box_w / paper[0], box_h / paper[1]))
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_axis_off()
    for ring in drawing.cut:
        ax.plot(ring[:, 0], ring[:, 1], color="black", lw=0.5)
    for at, lines, _ in drawing.texts:
        ax.text(at[0], at[1], lines[0], ha="center", va="center", fontsize=6)
    for t in tiles:
        ax.add_patch(Rectangle((t.x0, t.y0), t.w, t.h, fill=False, color="tab:blue", lw=0.5))
        ax.text(t.x0 + t.w / 2, t.y0 + t.h / 2, t.label, color="tab:blue", ha="center", va="center", fontsize=9,
                alpha=0.8)
    ax.autoscale_view()
    rows, cols = 1 + max(t.row for t in tiles), 1 + max(t.col for t in tiles)
    page.text(b, paper[1] - b - 4, title, fontsize=10, va="top")
    page.text(b, paper[1] - b - 11,
              f"{len(tiles)} pages in {rows} row(s) A.. x {cols} column(s) 1..; {options.paper} {options.orientation}, "
              f"overlap {options.overlap:g} mm.\nTrim each page along its left and top edges (grey line) and lay it "
              f"on the join line (dash-dot) of its neighbour.\nCut line solid, sew line dashed, grain line with "
              f"arrows. Check that the square measures 5 cm.", fontsize=7, va="top", linespacing=1.4)
    return fig


def write_sheet_svg(target: Path, pieces: list[TextilePiece], scale: float, title: str) -> tuple[float, float]:
    """The whole sheet at 1:1 on one page with the check square below the pieces; returns
    its size (mm)."""
    pts = np.vstack([p.cut for p in pieces]) * scale
    lo = pts.min(axis=0) - 20.0
    hi = pts.max(axis=0) + 20.0
    lo[1] -= CHECK_MM + 20.0  # the check square sits below the pieces
    hi[0] = max(hi[0], lo[0] + CHECK_MM + 40.0)
    size = hi - lo
    fig = Figure(figsize=(size[0] / 25.4, size[1] / 25.4))
    FigureCanvasAgg(fig)
    ax = _Sheet(fig, lo)
    _draw_pattern(ax, _page_content(piece_drawing(pieces, scale, []), box(*lo, *hi)))
    _check_square(ax, lo + 20.0, "1:1", "10 cm check square: print at 100 %")
    ax.text(lo[0] + 20.0, hi[1] - 10.0, title, fontsize=8, va="center")
    with atomic_path(target) as tmp, matplotlib.rc_context({"svg.fonttype": "none"}):  # text stays text
        fig.savefig(tmp, format="svg")
    return float(size[0]), float(size[1])
