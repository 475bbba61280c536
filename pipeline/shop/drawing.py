"""One-page shop drawing of a steel plate (PDF, to scale): what the plater reads.

The plate's layout (:mod:`pipeline.layout`, mm) drawn at a standard scale (1:1 ... 1:1000),
the smallest that fits an A4 or A3 landscape sheet (A4 when both take the same scale): the
cut line, the net line when an allowance is cut, frame lines, bending lines numbered
beyond the plate's d side with their spacing dimensioned, the overall dimensions, the
texts of the layout (edge names, bend marks, part data) at their place on the plate, and
a title block with the part data, the scale and the bending lines' radii and roll sides.
One ``Figure`` with the PDF canvas (no pyplot), few artists: a drawing costs a few
hundredths of a second. The sheet and scale are chosen where the drawing is asked for;
the page itself is drawn by :func:`draw_sheet` through :func:`pipeline.renderproc.render`
(in the render process of a one-shot run), so this module imports matplotlib only there.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path
from ..renderproc import render

PAPERS = (("A4", 297.0, 210.0), ("A3", 420.0, 297.0))  # landscape, mm
SCALES = (1, 2, 5, 10, 20, 25, 50, 100, 200, 250, 500, 1000, 2000, 5000)
MARGIN = 10.0  # mm of paper around the frame
TITLE_H = 42.0  # mm: the title block under the drawing
ROOM = 22.0  # mm of paper kept around the plate for numbers and dimensions
PT = 72.0 / 25.4  # points per mm
# the PDF's 14 standard fonts (Helvetica, Courier): nothing embedded, the page writes in
# a fraction of the time of a subsetted DejaVu, and every PDF reader has them
CORE_FONTS = {"pdf.use14corefonts": True, "font.family": "sans-serif", "font.sans-serif": ["Helvetica"],
              "font.monospace": ["Courier"],
              # every vertex of the cut line drawn (matplotlib would drop nearly collinear ones)
              "path.simplify": False}


def choose_sheet(span: np.ndarray) -> tuple[str, float, float, int]:
    """(paper, width, height, scale denominator): the largest drawing of a plate whose
    extent is ``span`` (2,) mm, on A4 or A3 landscape."""
    best = None
    for paper, w, h in PAPERS:
        room = np.array([w - 2 * MARGIN - 2 * ROOM, h - 2 * MARGIN - TITLE_H - 2 * ROOM])
        need = float(np.max(span / room))
        scale = next((s for s in SCALES if s >= need), int(np.ceil(need / 1000.0)) * 1000)
        if best is None or scale < best[3]:
            best = (paper, w, h, scale)
    return best


def write_shop_drawing(target: str | Path, layout, title: str, part_data: list[str], bends: list,
                       spacing: float | None, notes: list[str] = (), edges: dict | None = None) -> dict:
    """Write the drawing; returns what the report says of it (paper, scale).

    layout : a :class:`pipeline.layout.Layout` (mm)
    bends : [(number, mark text, (2,) a on the c side, (2,) b on the d side)] in mm
    edges : {name: (K, 2) polyline of the net edge it names}, written outside the plate
    spacing : the bending lines' spacing along the centre line (mm), None when none
    """
    cut = layout.cut
    lo, hi = cut.min(axis=0), cut.max(axis=0)
    span = hi - lo
    paper, pw, ph, scale = choose_sheet(span)
    render("pipeline.shop.drawing:draw_sheet", target, layout, title, part_data, bends, spacing, notes, edges,
           (paper, pw, ph, scale))
    return {"file": Path(target).name, "paper": f"{paper} landscape", "scale": f"1:{scale}",
            "plate_extent_mm": span.tolist()}


def draw_sheet(target, layout, title, part_data, bends, spacing, notes, edges, sheet) -> None:
    """Write the page (arguments as :func:`write_shop_drawing`'s; ``sheet`` is
    :func:`choose_sheet`'s answer)."""
    import matplotlib

    # the core fonts' AFM metrics say "medium" where matplotlib asks for "normal": its
    # font manager would log that once per text on stderr
    quiet = logging.getLogger("matplotlib.font_manager")
    level = quiet.level
    quiet.setLevel(logging.ERROR)
    try:
        with matplotlib.rc_context(CORE_FONTS):
            _draw(target, layout, title, part_data, bends, spacing, notes, edges, *sheet)
    finally:
        quiet.setLevel(level)


def _draw(target, layout, title, part_data, bends, spacing, notes, edges, paper, pw, ph, scale):
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.figure import Figure

    from ..lazymodules import pdf_backend

    cut = layout.cut
    lo, hi = cut.min(axis=0), cut.max(axis=0)
    fig = Figure(figsize=(pw / 25.4, ph / 25.4))
    pdf_backend().FigureCanvasPdf(fig)  # without fontTools' subsetter: the core fonts embed nothing
    # the drawing area in paper mm; one axes whose data unit is the plate's mm at 1:scale
    area = np.array([MARGIN + ROOM, MARGIN + TITLE_H + ROOM, pw - MARGIN - ROOM, ph - MARGIN - ROOM])
    size = area[2:] - area[:2]
    centre = 0.5 * (lo + hi)
    ax = fig.add_axes((area[0] / pw, area[1] / ph, size[0] / pw, size[1] / ph))
    ax.set_axis_off()
    ax.set_xlim(centre[0] - 0.5 * size[0] * scale, centre[0] + 0.5 * size[0] * scale)
    ax.set_ylim(centre[1] - 0.5 * size[1] * scale, centre[1] + 0.5 * size[1] * scale)
    ax.set_clip_on(False)
    paper_mm = float(scale)  # plate mm per paper mm
    # frame and title block (figure coordinates in mm through a transform)
    border = fig.add_axes((0, 0, 1, 1), facecolor="none")
    border.set_axis_off()
    border.set_xlim(0, pw)
    border.set_ylim(0, ph)
    border.add_collection(LineCollection([[(MARGIN, MARGIN), (pw - MARGIN, MARGIN), (pw - MARGIN, ph - MARGIN),
                                           (MARGIN, ph - MARGIN), (MARGIN, MARGIN)],
                                          [(MARGIN, MARGIN + TITLE_H), (pw - MARGIN, MARGIN + TITLE_H)]],
                                         colors="black", linewidths=0.6))
    closed = np.vstack([cut, cut[:1]])
    ax.plot(closed[:, 0], closed[:, 1], color="black", lw=0.9, label="cut", clip_on=False)
    if layout.net is not None:
        net = np.vstack([layout.net, layout.net[:1]])
        ax.plot(net[:, 0], net[:, 1], color="black", lw=0.4, ls=(0, (6, 3)), clip_on=False)
    frames = [line for kind, line in layout.lines if kind == "frame"]
    bend_lines = [line for kind, line in layout.lines if kind == "bend"]
    if frames:
        ax.add_collection(LineCollection(frames, colors="dimgrey", linewidths=0.4, linestyles=(0, (8, 2, 2, 2))))
    if bend_lines:
        ax.add_collection(LineCollection(bend_lines, colors="tab:blue", linewidths=0.4, linestyles=(0, (4, 2))))
    for kind, colour, hatch in (("shrink", "tab:orange", "////"), ("stretch", "tab:cyan", "\\\\")):
        rings = [line for k, line in layout.lines if k == kind]
        if rings:  # a formed plate's areas to shrink / stretch, hatched
            ax.add_collection(PolyCollection(rings, facecolors="none", edgecolors=colour, hatch=hatch,
                                             linewidths=0.4))
    # the layout's texts where they are on the plate, at true size (at least 3 pt)
    for text in layout.texts:
        ax.text(text.at[0], text.at[1], text.text, fontsize=max(text.height / paper_mm * PT, 3.0),
                rotation=text.angle, rotation_mode="anchor", ha="center", va="center",
                color="tab:blue" if text.kind == "bend" else "black")
    _edge_names(ax, edges or {}, cut, paper_mm)
    _bend_numbers(ax, bends, spacing, paper_mm)
    _overall(ax, lo, hi, paper_mm)
    # title block: part data, scale, bending lines
    left = [title, f"SCALE 1:{scale}   {paper} LANDSCAPE   DIMENSIONS IN MM"] + list(part_data)
    border.text(MARGIN + 3, MARGIN + TITLE_H - 3, "\n".join(left), fontsize=6.5, va="top", ha="left",
                family="monospace", linespacing=1.25)
    right = list(notes)
    if bends:
        marks = [f"{m}" for _, m, _, _ in bends]
        per = int(np.ceil(len(marks) / 4))
        right += ["  ".join(marks[k:k + per]) for k in range(0, len(marks), per)]
    if right:
        border.text(pw / 2, MARGIN + TITLE_H - 3, "\n".join(right), fontsize=5.5, va="top", ha="left",
                    family="monospace", linespacing=1.25, wrap=False)
    with atomic_path(target) as tmp:
        fig.savefig(tmp, format="pdf", metadata={"Title": title, "Creator": "devflat"})


def _bend_numbers(ax, bends: list, spacing: float | None, paper_mm: float) -> None:
    """Numbers beyond the d end of each bending line, and the spacing between neighbours
    dimensioned along them (positions in plate mm, offsets in paper mm)."""
    from matplotlib.collections import LineCollection

    if not bends:
        return
    ends, dirs = [], []
    for _, _, a, b in bends:
        u = (b - a) / max(float(np.linalg.norm(b - a)), 1e-300)
        ends.append(np.asarray(b, dtype=float))
        dirs.append(u)
    ends, dirs = np.array(ends), np.array(dirs)
    dim = ends + 5.0 * paper_mm * dirs
    if len(bends) > 1 and spacing:
        ax.add_collection(LineCollection([dim], colors="tab:blue", linewidths=0.3))
        ticks = [np.array([p - 1.0 * paper_mm * u, p + 1.0 * paper_mm * u]) for p, u in zip(dim, dirs)]
        ax.add_collection(LineCollection(ticks, colors="tab:blue", linewidths=0.3))
        gap = np.linalg.norm(np.diff(dim, axis=0), axis=1).min() / paper_mm
        size = float(np.clip(gap * PT / 2.6, 3.0, 6.0))
        for k in range(len(bends) - 1):
            mid = 0.5 * (dim[k] + dim[k + 1]) + 1.6 * paper_mm * dirs[k]
            ax.text(mid[0], mid[1], f"{spacing:g}", fontsize=size, ha="center", va="center", color="tab:blue")
    gap = np.linalg.norm(np.diff(ends, axis=0), axis=1).min() / paper_mm if len(ends) > 1 else 10.0
    size = float(np.clip(gap * PT / 2.2, 3.5, 7.0))
    for k, ((number, _, _, _), p, u) in enumerate(zip(bends, ends, dirs)):
        # staggered when the lines are close: even numbers further out
        at = p + (11.0 + (4.0 if k % 2 and gap < 6 else 0.0)) * paper_mm * u
        ax.text(at[0], at[1], f"B{number}", fontsize=size, ha="center", va="center", color="tab:blue",
                fontweight="bold")


def _edge_names(ax, edges: dict, cut: np.ndarray, paper_mm: float) -> None:
    """Each edge's name beside its middle, outside the cut line, along the edge."""
    import shapely

    plate = shapely.Polygon(cut)
    for name, line in edges.items():
        if len(line) < 2:
            continue
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
        i = int(np.clip(np.searchsorted(s, 0.5 * s[-1]) - 1, 0, len(line) - 2))
        p, d = 0.5 * (line[i] + line[i + 1]), line[i + 1] - line[i]
        d = d / max(float(np.linalg.norm(d)), 1e-300)
        n = np.array([-d[1], d[0]])
        if plate.contains(shapely.Point(p + 0.5 * paper_mm * n)):
            n = -n
        at = p + 4.0 * paper_mm * n + max(0.0, plate.exterior.distance(shapely.Point(p))) * n
        angle = float(np.degrees(np.arctan2(d[1], d[0])))
        angle = (angle + 90.0) % 180.0 - 90.0  # readable
        ax.text(at[0], at[1], name, fontsize=6.5, rotation=angle, rotation_mode="anchor", ha="center",
                va="center", color="darkgreen")


def _overall(ax, lo: np.ndarray, hi: np.ndarray, paper_mm: float) -> None:
    """Overall length under the plate and height on its left, with extension lines."""
    from matplotlib.collections import LineCollection

    y = lo[1] - 12.0 * paper_mm
    x = lo[0] - 12.0 * paper_mm
    segments = [[(lo[0], y), (hi[0], y)], [(lo[0], y - paper_mm), (lo[0], lo[1] - 2 * paper_mm)],
                [(hi[0], y - paper_mm), (hi[0], lo[1] - 2 * paper_mm)],
                [(x, lo[1]), (x, hi[1])], [(x - paper_mm, lo[1]), (lo[0] - 2 * paper_mm, lo[1])],
                [(x - paper_mm, hi[1]), (lo[0] - 2 * paper_mm, hi[1])]]
    ax.add_collection(LineCollection(segments, colors="black", linewidths=0.3))
    ax.text(0.5 * (lo[0] + hi[0]), y + 1.2 * paper_mm, f"{hi[0] - lo[0]:.0f}", fontsize=7, ha="center", va="bottom")
    ax.text(x - 1.2 * paper_mm, 0.5 * (lo[1] + hi[1]), f"{hi[1] - lo[1]:.0f}", fontsize=7, ha="right", va="center",
            rotation=90)


def warm_up() -> None:
    """Draw a small sheet into a temporary folder: the first PDF of a process reads the core
    fonts' metrics and fills matplotlib's caches (three to four times a later drawing's
    cost); a render process (:mod:`pipeline.renderproc`) does it while it waits."""
    import tempfile

    from .layout import Layout, Text

    square = np.array([[0.0, 0.0], [1000.0, 0.0], [1000.0, 500.0], [0.0, 500.0]])
    layout = Layout(cut=square, net=None, lines=[("bend", np.array([[500.0, 0.0], [500.0, 500.0]]))],
                    texts=[Text("text", "PART WARM-UP", (250.0, 250.0), 20.0, 0.0)])
    bends = [(1, "B1 CVX R 1000", np.array([500.0, 0.0]), np.array([500.0, 500.0]))]
    with tempfile.TemporaryDirectory() as folder:
        draw_sheet(Path(folder) / "warm-up.pdf", layout, "PART WARM-UP", ["THK 10 MM"], bends, None,
                   ["BENDING LINES B1-B1"], {"EDGE C": square[:2]}, choose_sheet(np.ptp(square, axis=0)))
