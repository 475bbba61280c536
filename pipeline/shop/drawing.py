"""Shop drawing of a steel plate (PDF, to scale): what the plater reads, at every scale.

The plate's layout (:mod:`pipeline.shop.layout`, mm) is laid lengthwise on an A4 or A3
landscape sheet (its minimum rectangle's long side along the sheet, edge d up) at the
standard scale that draws it largest; orientation, paper and scale are chosen together
with the room the labels and the bending-line table need. Every text is written at a fixed
paper height (ISO 3098: 2.5 mm capital height for labels and tables, 3.5 and 5 mm for
headings), upright or turned 90 degrees, and placed on the paper clear of every other text
and every drawn line (:class:`pipeline.shop.paper.PaperPlacer`): B-numbers beyond the d end of their lines,
frame names beyond the c end, edge names outside their edges, in as many rows as their
spacing needs. A heating group's name is written beside its line only where it is nearer
that line than any other; where it has no room there, and a B-number with none beyond
its line's ends, it is written further away with a straight leader from a dot on the line
it names, as a drafter does where lines crowd (:mod:`pipeline.shop.leaders`); a name with
no room even for that is listed in the title block. The bending lines' spacing is
dimensioned where it is measured (a chain line through the lines' middles, each figure the
distance across the rulings between two lines); the table (B-number, radius, CVX/CCV, the
station: the distance across the rulings from the plate's first end at the middles, the ends' ordinates along edges c and d from the corners at
the start butt) sits beside the plate and continues on a second page when long; the
templates that check the formed plate get a page of their own.

Everything is planned here on arrays (paper mm) in the calling process: the placement's
findings go to the report; :func:`draw_pages` only renders the planned primitives (through
:func:`pipeline.renderproc.render`, so matplotlib is imported in the render process only).
One ``Figure`` per page with the PDF canvas and the 14 core fonts (nothing embedded).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path
from ..renderproc import render
from .leaders import Leaders, slid_along
from .paper import (CAP, DESCENT, GAP, H_HEAD, H_LABEL, H_TITLE, PITCH, Label, PaperPlacer, axis_angle, beyond,
                    size_of, text_width, unit)

PAPERS = (("A4", 297.0, 210.0), ("A3", 420.0, 297.0))  # landscape, mm
SCALES = (1, 2, 5, 10, 20, 25, 50, 100, 200, 250, 500, 1000, 2000, 5000)
MARGIN = 10.0  # mm of paper outside the frame
PAD = 3.0  # mm between the frame (or a block's rule) and what is inside
PT = 72.0 / 25.4  # points per mm
CORE_FONTS = {"pdf.use14corefonts": True, "font.family": "sans-serif", "font.sans-serif": ["Helvetica"],
              "path.simplify": False}  # every vertex of the cut line drawn
# line styles: colour, width (pt), dashes
STYLES = {"cut": ("black", 0.9, None), "net": ("black", 0.4, (0, (6, 3))), "frame": ("dimgrey", 0.4, (0, (8, 2, 2, 2))),
          "bend": ("tab:blue", 0.45, (0, (4, 2))), "centre": ("tab:blue", 0.3, (0, (10, 2, 2, 2))),
          "dim": ("black", 0.3, None), "rule": ("black", 0.6, None), "template": ("black", 0.7, None),
          "sight": ("tab:red", 0.4, (0, (6, 2))), "station": ("grey", 0.25, None),
          "leader": ("black", 0.3, None)}
OTHER_COLOURS = ("tab:red", "tab:purple", "tab:brown", "tab:olive")  # mark kinds the drawing does not know
LEADER_DOT = 0.35  # radius (paper mm) of the dot where a leader meets what its label names
NEAR_OWN = GAP + 0.7  # paper mm: a label written beside its line without a leader is this near it
NEARER_BY = 0.25  # paper mm: a B-number beyond its line's end is nearer that line than any other by this
HATCH_DIRECTION = {"////": 45.0, "\\\\": 135.0}  # degrees: the direction of an area's hatch lines
PAGE_NUMBER = "PAGE 00 OF 00"  # stands for the page number until the pages are counted
UNNAMED_NOTE = "NOT NAMED FOR LACK OF ROOM (SEE THE DXF): "  # + the texts
SPACING_NOTE = "SPACING ACROSS THE LINES (CHAIN LINE THROUGH THEIR MIDDLES, TICKS AT THE LINES) "  # + the runs


@dataclass
class Page:
    """What one page draws (paper mm): lines {style: [(K, 2) polylines]}, hatched areas
    [(colour, hatch, (K, 2) ring)], labels, small circles [(x, y, r)]."""

    width: float
    height: float
    lines: dict = field(default_factory=dict)
    areas: list = field(default_factory=list)
    labels: list = field(default_factory=list)
    circles: list = field(default_factory=list)

    def add(self, style: str, polylines) -> None:
        self.lines.setdefault(style, []).extend(np.asarray(p, dtype=float) for p in polylines if len(p) >= 2)


# --- the plate's data, in plate mm ------------------------------------------------------

@dataclass(frozen=True)
class BendRow:
    """One bending line's row of the table: number, radius text, roll side, station (across
    the rulings from the plate's first end, at the middles), ordinates of its ends along
    edges c and d from the corners at the start butt (mm; nan when the edges are not known)."""

    number: int
    radius: str
    side: str
    station: float
    on_c: float
    on_d: float

    def cells(self) -> tuple[str, ...]:
        def mm(v):
            return "-" if not np.isfinite(v) else f"{v:.0f}"

        return f"B{self.number}", self.radius, self.side or "-", mm(self.station), mm(self.on_c), mm(self.on_d)


TABLE_HEAD = ("LINE", "RADIUS", "SIDE", "AT CL", "ON C", "ON D")


def bend_rows(bends: list, edges: dict) -> list[BendRow]:
    """The table's rows. bends: [(number, mark, a (2,), b (2,)[, station])] (mm); edges:
    {name: (K, 2) polyline}, the first two the c and d edges (in that order)."""
    import shapely

    names = list(edges)
    lines = [np.asarray(edges[n], dtype=float) for n in names[:2]] if len(names) >= 2 else []
    lines = [line for line in lines if len(line) >= 2]
    if len(lines) == 2:
        c, d = lines
        if np.linalg.norm(d[-1] - c[0]) < np.linalg.norm(d[0] - c[0]):
            d = d[::-1]  # both edges measured from the corners at the start butt
        lines = [shapely.LineString(c), shapely.LineString(d)]
    rows = []
    for bend in bends:
        number, mark, a, b = bend[:4]
        station = float(bend[4]) if len(bend) > 4 else float("nan")
        words = mark.split()
        radius = next((w for w in words[1:] if w.startswith("R") or w == "FLAT"), "-")
        side = next((w for w in words[1:] if w in ("CVX", "CCV")), "")
        on_c = on_d = float("nan")
        if len(lines) == 2:
            on_c = float(lines[0].project(shapely.Point(a)))
            on_d = float(lines[1].project(shapely.Point(b)))
        rows.append(BendRow(int(number), radius, side, station, on_c, on_d))
    if rows and not all(np.isfinite(r.station) for r in rows):  # no stations: chords between the middles from B1
        mids = np.array([0.5 * (np.asarray(bd[2], float) + np.asarray(bd[3], float)) for bd in bends])
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(mids, axis=0), axis=1))])
        rows = [BendRow(r.number, r.radius, r.side, float(v), r.on_c, r.on_d) for r, v in zip(rows, s)]
    return rows


def lengthwise(cut: np.ndarray, bends: list) -> np.ndarray:
    """The 2 x 2 rotation that lays the plate lengthwise: its minimum rectangle's long side
    along +x, and the bending lines' d ends above their c ends (else the first frame... the
    plate as it is turned no further)."""
    from flatten.rectangle import minimum_rectangle

    rect = minimum_rectangle(cut)[:3]
    sides = np.diff(rect, axis=0)
    long_side = sides[np.argmax(np.linalg.norm(sides, axis=1))]
    a = -np.arctan2(long_side[1], long_side[0])
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    if bends:
        up = np.mean([(np.asarray(b[3], float) - np.asarray(b[2], float)) @ rot[1] for b in bends])
        if up < 0:
            rot = -rot
    return rot


# --- the sheet ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Sheet:
    """Paper, scale and where the table goes: ``table_rows`` rows beside the plate on page 1
    (0: the whole table on the next page)."""

    paper: str
    width: float
    height: float
    scale: int
    table_rows: int
    table_width: float
    title_height: float


def _bands(rows: list[BendRow], frames: list[str], edge_names: list[str]) -> np.ndarray:
    """Paper mm kept around the plate (left, bottom, right, top) for its labels and the
    overall dimensions."""
    em = H_LABEL / CAP
    longest_b = max((text_width(f"B{r.number}") for r in rows), default=0.0)
    longest_f = max((text_width(f) for f in frames), default=0.0)
    edge = em + 2 * GAP if edge_names else 0.0
    dim = em + 4 * GAP + 2.0  # an overall dimension with its figure, on either side
    top = 3 * (longest_b + GAP) + GAP + edge + dim
    bottom = longest_f + 2 * GAP + edge + dim
    side = em + 2 * GAP + edge + dim
    return np.array([side, bottom, side, top])


def _table_columns(rows: list[BendRow]) -> np.ndarray:
    """Column widths (6,) of the table, paper mm (each its widest cell plus a gap)."""
    cells = [TABLE_HEAD] + [r.cells() for r in rows]
    return np.array([max(text_width(c[k]) for c in cells) for k in range(len(TABLE_HEAD))]) + 2.5


def choose_sheet(span: np.ndarray, bands: np.ndarray | None = None, rows: int = 0, table_width: float = 0.0,
                 title: list[str] = ()) -> Sheet:
    """The sheet that draws a plate of extent ``span`` (2,) mm (laid lengthwise) largest:
    for A4 and A3 landscape, the table beside the plate or on the next page; the smallest
    scale wins, then the fewer pages, then A4. bands: paper mm for labels (left, bottom,
    right, top); rows, table_width: the bending-line table's rows and width; title: the
    title block's lines (wrapped to each paper's width)."""
    bands = np.zeros(4) if bands is None else bands
    best = None
    for paper, w, h in PAPERS:
        title_h = title_height(title, w)
        for beside in ((True, False) if rows else (False,)):
            table_w = table_width + 2 * PAD if beside else 0.0
            room = np.array([w - 2 * MARGIN - 2 * PAD - table_w - bands[0] - bands[2],
                             h - 2 * MARGIN - title_h - 2 * PAD - bands[1] - bands[3]])
            if np.any(room <= 1.0):
                continue
            need = float(np.max(span / room))
            scale = next((s for s in SCALES if s >= need), int(np.ceil(need / 1000.0)) * 1000)
            fit = table_capacity(h - 2 * MARGIN - title_h - 2 * PAD) if beside else 0
            fit = max(min(fit, rows), 0)
            if beside and fit == 0:
                continue
            pages = (1 if fit >= rows else 2)
            key = (scale, pages, w)
            if best is None or key < best[0]:
                best = (key, Sheet(paper, w, h, scale, fit, table_width if beside else 0.0, title_h))
    if best is None:  # no room at all (labels wider than A3): A3 at the scale of the bare plate
        title_h = title_height(title, 420.0)
        need = float(np.max(span / np.array([400.0 - 2 * MARGIN, 297.0 - 2 * MARGIN - title_h])))
        scale = next((s for s in SCALES if s >= need), int(np.ceil(need / 1000.0)) * 1000)
        return Sheet("A3", 420.0, 297.0, scale, 0, 0.0, title_h)
    return best[1]


def title_height(lines: list[str], paper_width: float) -> float:
    """Paper mm the title block of these lines takes on a sheet that wide."""
    wrapped = len(_wrap(list(lines), paper_width - 2 * MARGIN - 2 * PAD))
    return 2 * PAD + H_TITLE / CAP + (wrapped + 1) * PITCH * H_LABEL / CAP


def _title_block(page: Page, title: str, lines: list[str], top: float, note: str) -> list[str]:
    """The title block under the drawing: the title, then lines (wrapped to the frame's
    width); returns the lines that did not fit."""
    width = page.width - 2 * MARGIN - 2 * PAD
    pitch = PITCH * H_LABEL / CAP
    page.add("rule", [np.array([[MARGIN, top], [page.width - MARGIN, top]])])
    y = top - PAD - (1 - DESCENT) * H_TITLE / CAP
    page.labels.append(Label(title, MARGIN + PAD, y, H_TITLE))
    if note:
        page.labels.append(Label(note, page.width - MARGIN - PAD - text_width(note), y))
    y -= pitch + 0.3 * H_TITLE / CAP
    left = []
    for line in _wrap(lines, width):
        if y - DESCENT * H_LABEL / CAP < MARGIN + 0.5:
            left.append(line)
            continue
        page.labels.append(Label(line, MARGIN + PAD, y))
        y -= pitch
    return left


def _wrap(lines: list[str], width: float) -> list[str]:
    out = []
    for line in lines:
        words, current = line.split(" "), ""
        for word in words:
            trial = word if not current else f"{current} {word}"
            if current and text_width(trial) > width:
                out.append(current)
                current = "  " + word
            else:
                current = trial
        out.append(current)
    return out


def _table(page: Page, rows: list[BendRow], columns: np.ndarray, x0: float, top: float, heading: str) -> None:
    """The bending-line table with its heading from (x0, top) down (rows that fit are the
    caller's business)."""
    pitch = PITCH * H_LABEL / CAP
    em = H_LABEL / CAP
    y = top - (1 - DESCENT) * H_HEAD / CAP
    page.labels.append(Label(heading, x0, y, H_HEAD))
    y -= pitch + 0.2 * em
    right = x0 + np.cumsum(columns) - 2.5  # numbers right-aligned in their column
    for k, cells in enumerate([TABLE_HEAD] + [r.cells() for r in rows]):
        for c, text in enumerate(cells):
            x = right[c] - text_width(text) if c >= 3 else right[c] - columns[c] + 2.5
            page.labels.append(Label(text, float(x), float(y), H_LABEL, 0, "tab:blue" if c == 0 and k else "black"))
        if k == 0:
            rule = y - DESCENT * em - 0.3
            page.add("dim", [np.array([[x0, rule], [x0 + columns.sum() - 2.5, rule]])])
        y -= pitch


def table_capacity(height: float) -> int:
    pitch = PITCH * H_LABEL / CAP
    return int((height - (H_HEAD / CAP + 2 * pitch)) // pitch)


def plan_pages(layout, title: str, part_data: list[str], bends: list, spacing: float | None, notes: list[str],
               edges: dict | None, templates=()) -> tuple[list[Page], dict]:
    """The pages (paper mm) and what the report says of them (paper, scale, pages, labels
    that found no room)."""
    edges = edges or {}
    cut = np.asarray(layout.cut, dtype=float)
    rot = lengthwise(cut, bends)
    centre = 0.5 * (cut.min(axis=0) + cut.max(axis=0))
    turned = (cut - centre) @ rot.T
    lo, hi = turned.min(axis=0), turned.max(axis=0)
    span = hi - lo
    rows = bend_rows(bends, edges)
    frames = [(k, line) for k, line in layout.lines if k == "frame"]
    frame_names = _frame_names(layout)
    bands = _bands(rows, frame_names, list(edges))
    columns = _table_columns(rows) if rows else np.zeros(len(TABLE_HEAD))
    data = ["SCALE 1:{scale}   {paper} LANDSCAPE   DIMENSIONS IN MM   "
            "PLATE LAID LENGTHWISE, DRAWN FROM THE MARKED SIDE"] + list(part_data) + list(notes)
    if rows and np.isfinite(rows[0].on_c):
        data.append("ON C / ON D: THE LINE ENDS' ORDINATES ALONG EDGES C AND D FROM THE CORNERS MARKED 0; "
                    "AT CL: STATION ACROSS THE LINES, AT THEIR MIDDLES")
    foreign = [t for t in layout.texts if t.kind not in ("text", "edge", "bend", "frame")]
    if rows:  # room for these lines, whether or not they are said
        data += ["BENDING LINE TABLE ON PAGE 2", SPACING_NOTE + ", ".join([f"B{r.number}-B{r.number}: 00000" for r in rows[1:]] or ["B0-B0: 0"])]
    sheet = choose_sheet(span, bands, len(rows), float(columns.sum()), data)
    scale, pw, ph, title_h = sheet.scale, sheet.width, sheet.height, sheet.title_height
    title_lines = len(_wrap(data, pw - 2 * MARGIN - 2 * PAD))  # the title block's room
    data[0] = data[0].format(scale=scale, paper=sheet.paper)
    if rows:
        data.pop()
        if sheet.table_rows:
            data.pop()
    page = Page(pw, ph)
    page.add("rule", [np.array([[MARGIN, MARGIN], [pw - MARGIN, MARGIN], [pw - MARGIN, ph - MARGIN],
                                [MARGIN, ph - MARGIN], [MARGIN, MARGIN]])])
    table_w = sheet.table_width + 2 * PAD if sheet.table_rows else 0.0
    area = np.array([MARGIN + PAD, MARGIN + title_h + PAD, pw - MARGIN - PAD - table_w, ph - MARGIN - PAD])
    # the plate with its bands centred in the area
    box_lo = np.array([area[0] + bands[0], area[1] + bands[1]])
    box_hi = np.array([area[2] - bands[2], area[3] - bands[3]])
    mid = 0.5 * (box_lo + box_hi)

    def paper(p):
        return (np.asarray(p, dtype=float) - centre) @ rot.T / scale + mid - 0.5 * (lo + hi) / scale

    pcut = paper(cut)
    page.add("cut", [np.vstack([pcut, pcut[:1]])])
    if layout.net is not None:
        net = paper(layout.net)
        page.add("net", [np.vstack([net, net[:1]])])
    others = sorted({k for k, _ in layout.lines} - {"frame", "bend", "shrink", "stretch"})
    for kind, line in layout.lines:
        if kind in ("shrink", "stretch"):
            colour, hatch = ("tab:orange", "////") if kind == "shrink" else ("tab:cyan", "\\\\")
            page.areas.append((colour, hatch, paper(line)))
        elif kind in ("frame", "bend"):
            page.add(kind, [paper(line)])
        else:  # a mark kind of another module (heating lines, ...): drawn in a colour of its own
            page.lines.setdefault(f"other:{OTHER_COLOURS[others.index(kind) % len(OTHER_COLOURS)]}", []).append(
                paper(line))
    findings = []
    # the centre line chain through the bending lines' middles, and the ordinates' origins
    mids = np.array([paper(0.5 * (np.asarray(b[2], float) + np.asarray(b[3], float))) for b in bends]).reshape(-1, 2)
    chain = []
    if len(mids) >= 2:
        u0, u1 = unit(mids[1] - mids[0]), unit(mids[-1] - mids[-2])
        chain = [np.vstack([mids[0] - 3.0 * u0, mids, mids[-1] + 3.0 * u1])]
        page.add("centre", chain)
        ticks = []
        for k, m in enumerate(mids):
            u = unit(mids[min(k + 1, len(mids) - 1)] - mids[max(k - 1, 0)])
            t = np.array([u[0] - u[1], u[0] + u[1]]) * 0.9  # an oblique tick (45 degrees) on the line
            ticks.append(np.array([m - t, m + t]))
        page.add("dim", ticks)
    if rows and np.isfinite(rows[0].on_c):
        c, d = (paper(edges[n]) for n in list(edges)[:2])
        if np.linalg.norm(d[-1] - c[0]) < np.linalg.norm(d[0] - c[0]):
            d = d[::-1]
        page.circles += [(float(c[0][0]), float(c[0][1]), 1.0), (float(d[0][0]), float(d[0][1]), 1.0)]

    # overall dimensions outside the bands, each on the side its extension lines are shortest
    plo, phi = pcut.min(axis=0), pcut.max(axis=0)
    em = H_LABEL / CAP
    inset = em + 3 * GAP + 1.0  # from the band's outer edge to the dimension line
    dims = []  # (text, axis, line position, side)
    for axis in (0, 1):
        other = 1 - axis
        near_lo = pcut[pcut[:, axis] <= plo[axis] + 0.3]  # the extreme points at each end of the span
        near_hi = pcut[pcut[:, axis] >= phi[axis] - 0.3]
        best = None
        for side in (-1, 1):  # below / left, above / right
            pick = np.argmin if side < 0 else np.argmax
            ends = [near_lo[pick(near_lo[:, other])], near_hi[pick(near_hi[:, other])]]
            line = (plo[other] - bands[0 if other == 0 else 1] + inset if side < 0
                    else phi[other] + bands[2 if other == 0 else 3] - inset)
            cost = sum(abs(e[other] - line) for e in ends)
            if best is None or cost < best[0]:
                best = (cost, side, line, ends)
        _, side, line, ends = best
        segs = []
        for e, v in zip(ends, (plo[axis], phi[axis])):
            start = e[other] + side * GAP
            stop = line + side * 1.0
            ext = np.array([[v, start], [v, stop]]) if axis == 0 else np.array([[start, v], [stop, v]])
            tick = np.array([[v - 0.7, line - 0.7], [v + 0.7, line + 0.7]])
            segs += [ext, tick if axis == 0 else tick[:, ::-1]]
        main = np.array([[plo[axis], line], [phi[axis], line]])
        segs.append(main if axis == 0 else main[:, ::-1])
        page.add("dim", segs)
        dims.append((f"{span[axis]:.0f}", axis, line, side))
    placer = PaperPlacer(area, [p for style in page.lines.values() for p in style], [a[2] for a in page.areas])
    # leaders cross no dimension, chain or frame line, nor run along the hatching of an area
    leaders = Leaders(placer, page.lines.get("dim", []) + page.lines.get("rule", []) + page.lines.get("centre", []),
                      [(HATCH_DIRECTION[hatch], ring) for _, hatch, ring in page.areas], [a[2] for a in page.areas],
                      [p for style in page.lines.values() for p in style])
    # the point on its line each text of a mark kind the drawing does not know names (a
    # leader's dot when it is written away from it): kept clear of the leaders drawn before
    kin = {t.kind: [paper(line) for kind, line in layout.lines if kind == t.kind] for t in foreign}
    named = {id(t): _named(t, kin[t.kind], paper) for t in foreign}
    leaders.reserved = np.array([point for point, _ in named.values()]).reshape(-1, 2)
    for p in page.circles:
        placer.boxes = np.vstack([placer.boxes, [p[0] - p[2], p[1] - p[2], p[0] + p[2], p[1] + p[2]]])
    for x, y, r in page.circles:  # the ordinates' origins
        ring8 = np.linspace(0.0, 2 * np.pi, 8, endpoint=False)
        around = np.array([x, y]) + (r + GAP + 2.2) * np.column_stack([np.cos(ring8), np.sin(ring8)])
        label = placer.place("0", np.vstack([around, np.array([x, y]) + 2.0 * (around - [x, y])]), 0)
        if label is None:
            findings.append("ordinates' origin 0: no room")
        else:
            page.labels.append(label)
    for text, axis, line, side in dims:
        lo_, hi_ = plo[axis], phi[axis]
        across = line + side * (1.0 + GAP + 0.5 * em + 0.01)
        # in the middle, slid along, or beyond the extension lines where the plate is narrow
        half = 0.5 * text_width(text) + 1.5
        along = 0.5 * (lo_ + hi_) + np.array([0.0, 0.25, -0.25, 0.4, -0.4]) * (hi_ - lo_)
        along = np.concatenate([along, [hi_ + half, lo_ - half]])
        centres = np.column_stack([along, np.full(len(along), across)])[:, ::(1 if axis == 0 else -1)]
        label = placer.place(text, centres, 90 * axis)
        if label is None:
            findings.append(f"overall dimension {text}: no room")
        else:
            page.labels.append(label)
    unnamed = []  # the names with no room even for a leader, said in the title block or on the sheet
    # B-numbers beyond the d ends, rows further out where the lines are close
    for bend, row in zip(bends, rows):
        a, b = paper(bend[2]), paper(bend[3])
        u = unit(b - a)
        angle = axis_angle(u)
        text = f"B{row.number}"
        size = size_of(text, H_LABEL, angle)
        step = abs(u[0]) * size[0] + abs(u[1]) * size[1] + GAP
        offsets = np.concatenate([GAP + np.array([0.05, 1.0, 2.0]), GAP + 2.0 + step * np.arange(1, 4)])
        # (a place beyond an end nearer another bending line than its own would name that one)
        parts, others = _own_parts(page.lines.get("bend", []), a, b)
        label = placer.place(text, _nearer(beyond(b, u, text, angle, offsets), size, parts, others, NEARER_BY),
                             angle, style="tab:blue")
        if label is None:  # beyond the c end
            label = placer.place(text, _nearer(beyond(a, -u, text, angle, offsets), size, parts, others,
                                               NEARER_BY), angle, style="tab:blue")
        if label is None:  # away, with a leader from an end of its longest part as drawn, else along it
            own = parts[0] if parts else None
            anchors = [b, a] if own is None else np.vstack(
                [sorted((own[0], own[-1]), key=lambda e: np.linalg.norm(e - b)), slid_along(own, b)[1:]])
            label = _led(page, leaders, text, anchors, angle, own, style="tab:blue")
        if label is None:
            findings.append(f"bending line B{row.number}: no room for its number")
            unnamed.append(text)
        else:
            page.labels.append(label)
    # frame names beyond the frame lines' lower ends
    for (name, line) in zip(frame_names, [line for _, line in frames]):
        p = paper(line)
        if p[0][1] > p[-1][1]:
            p = p[::-1]
        u = unit(p[0] - p[min(1, len(p) - 1)]) if len(p) > 1 else np.array([0.0, -1.0])
        angle = axis_angle(u)
        size = size_of(name, H_LABEL, angle)
        step = abs(u[0]) * size[0] + abs(u[1]) * size[1] + GAP
        offsets = np.concatenate([GAP + np.array([0.05, 1.0, 2.0]), GAP + 2.0 + step * np.arange(1, 3)])
        label = placer.place(name, beyond(p[0], u, name, angle, offsets), angle, style="dimgrey")
        if label is None:
            label = placer.place(name, beyond(p[-1], -u, name, angle, offsets), angle, style="dimgrey")
        if label is None:
            findings.append(f"frame {name}: no room for its name")
        else:
            page.labels.append(label)
    # edge names outside their edges
    ring = np.vstack([pcut, pcut[:1]])
    import shapely

    poly = shapely.Polygon(pcut)
    for name, line in edges.items():
        p = paper(line)
        if len(p) < 2:
            continue
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        centres = []
        for f in (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8):
            i = int(np.clip(np.searchsorted(s, f * s[-1]) - 1, 0, len(p) - 2))
            q = p[i] + (f * s[-1] - s[i]) / max(s[i + 1] - s[i], 1e-300) * (p[i + 1] - p[i])
            d = unit(p[i + 1] - p[i])
            n = np.array([-d[1], d[0]])
            if shapely.contains_xy(poly, *(q + 0.3 * n)):
                n = -n
            angle = axis_angle(d)
            out = np.array([0.0, np.sign(n[1]) or 1.0]) if angle == 0 else np.array([np.sign(n[0]) or 1.0, 0.0])
            size = size_of(name, H_LABEL, angle)
            gap = float(np.max(np.abs((ring - q) @ out) * (np.abs((ring - q) @ out[::-1]) < 0.5 * size.max())
                               * ((ring - q) @ out > 0), initial=0.0))
            centres.append(beyond(q + gap * out, out, name, angle,
                                   GAP + 0.05 + np.array([0.0, 2.0, 4.0, 7.0, 10.0, 14.0, 18.0, 24.0])))
            centres[-1] = (centres[-1], angle)
        label = None
        for c, angle in centres:
            label = placer.place(name, c, angle, style="darkgreen")
            if label is not None:
                break
        if label is None:
            findings.append(f"edge name {name!r}: no room")
        else:
            page.labels.append(label)
    # the spacing chain's figures: distances across the lines between their ticks
    chain_notes = []
    if len(mids) >= 2 and rows:
        steps = np.diff([r.station for r in rows])
        runs, k = [], 0
        while k < len(steps):
            j = k
            while j + 1 < len(steps) and round(steps[j + 1]) == round(steps[k]):
                j += 1
            runs.append((k, j))  # steps k..j between lines k and j + 1
            k = j + 1
        texts = []
        for k, j in runs:
            n, value = j - k + 1, round(float(steps[k]))
            text = f"{value:g}" if n == 1 else f"{n} x {value:g} = {n * value:g}"
            texts.append((text, k, j))
        # each step's figure between its two lines, or a run's "n x s = total" beside it; where
        # one finds no room there, the chain's only run goes beyond the chain's ends, and a chain
        # of several runs is written in the title block (figures away from their steps mislead)
        chain_start = len(placer.boxes)
        chain_labels = []
        for text, k, j in texts:
            kept = len(placer.boxes)
            single = []
            for i in range(k, j + 1) if j > k else ():
                label = _chain_label(placer, f"{round(float(steps[i])):g}", mids[i], mids[i + 1], mids, near=True)
                if label is None:
                    break
                single.append(label)
            if j > k and len(single) == j - k + 1:
                chain_labels += single
                continue
            placer.boxes = placer.boxes[:kept]
            label = _chain_label(placer, text, mids[k], mids[j + 1], mids, near=len(texts) > 1)
            if label is None:
                break
            chain_labels.append(label)
        if len(chain_labels) and (label is not None):
            page.labels += chain_labels
        else:  # said in the title block (its room kept)
            placer.boxes = placer.boxes[:chain_start]
            chain_notes = [f"B{rows[k].number}-B{rows[j + 1].number}: {text}" for text, k, j in texts]
    # texts of mark kinds the drawing does not know (their module's): beside the line they
    # name (nearer it than any other line of their kind), else led from a dot on it
    for t in foreign:
        at = paper(t.at)
        point, own = named[id(t)]
        r = np.array([0.0, 2.0, 4.0, 6.0, 9.0, 13.0])
        angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
        centres = np.vstack([at] + [at + rr * np.column_stack([np.cos(angles), np.sin(angles)]) for rr in r[1:]])
        if own is not None:  # beside its own line, along it from the point it names
            size = size_of(t.text, H_LABEL, 0)
            centres = _nearer(np.vstack([_along(own, point, size), centres]), size, [own],
                              [p for p in kin[t.kind] if p is not own], within=NEAR_OWN)
        label = placer.place(t.text, centres, 0) if len(centres) else None
        if label is None:
            label = _led(page, leaders, t.text, slid_along(own, point) if own is not None else [point], 0, own)
        leaders.reserved = leaders.reserved[np.linalg.norm(leaders.reserved - point, axis=1) > 1e-9]
        if label is None:
            findings.append(f"{t.kind} text {t.text!r}: no room")
            unnamed.append(t.text)
        else:
            page.labels.append(label)
    if chain_notes:
        data.insert(1, SPACING_NOTE + ", ".join(chain_notes))
    if unnamed:  # texts with no room even for a leader: said in the title block's room left, else on the sheet
        said = UNNAMED_NOTE + ", ".join(unnamed)
        if len(_wrap(data + [said], pw - 2 * MARGIN - 2 * PAD)) <= title_lines:
            data.append(said)
        else:
            label = placer.place(said, _sheet_centres(area, said), 0)
            if label is None:
                findings.append(f"title block and sheet full: {said!r} not said")
            else:
                page.labels.append(label)
    pages = [page]
    left = list(rows)
    note = PAGE_NUMBER
    if rows:
        if sheet.table_rows:
            x0 = pw - MARGIN - PAD - sheet.table_width
            page.add("rule", [np.array([[x0 - PAD, MARGIN + title_h], [x0 - PAD, ph - MARGIN]])])
            fit = table_capacity(ph - MARGIN - PAD - (MARGIN + title_h + PAD))
            more = " (CONTINUED ON PAGE 2)" if fit < len(rows) else ""
            _table(page, rows[:fit], columns, x0, ph - MARGIN - PAD, "BENDING LINES" + more)
            left = rows[fit:]
    _title_block(page, title, data, MARGIN + title_h, note)
    if left:
        pages += _table_pages(title, left, columns, sheet)
    pages += template_pages(title, templates, pw, ph)
    for k, p in enumerate(pages):  # the page numbers, right-aligned in the title block
        p.labels = [lb if lb.text != PAGE_NUMBER else
                    Label(f"PAGE {k + 1} OF {len(pages)}", p.width - MARGIN - PAD - text_width(f"PAGE {k + 1} OF "
                                                                                              f"{len(pages)}"),
                          lb.y, lb.h, lb.angle, lb.style) for lb in p.labels]
    info = {"paper": f"{sheet.paper} landscape", "scale": f"1:{scale}", "pages": len(pages),
            "plate_extent_mm": span.tolist(), "turned_deg": float(np.degrees(np.arctan2(rot[1, 0], rot[0, 0]))),
            "labels": sum(len(p.labels) for p in pages), "not_placed": findings}
    return pages, info


def _led(page: Page, leaders: Leaders, text: str, anchors, angle: int, own, style: str = "black") -> Label | None:
    """A label written away from its line with a leader from a dot on it (the first of
    ``anchors`` that leaves room, on ``own``), the leader and dot added to the page; None
    when there is no room for one."""
    led = leaders.place(text, anchors, angle, own, style=style)
    if led is None:
        return None
    label, leader = led
    page.lines.setdefault("leader", []).append(leader)
    page.circles.append((float(leader[0][0]), float(leader[0][1]), LEADER_DOT))
    return label


def _sheet_centres(area: np.ndarray, text: str) -> np.ndarray:
    """Centres (C, 2) for a one-line text anywhere in the drawing area (x0, y0, x1, y1),
    rows from the bottom up (next to the title block), each from the left: where a note is
    looked for."""
    w, h = size_of(text, H_LABEL, 0)
    xs = np.arange(area[0] + 0.5 * w, area[2] - 0.5 * w + 1e-9, 2.0)
    ys = np.arange(area[1] + 0.5 * h, area[3] - 0.5 * h + 1e-9, 1.0)
    return np.array([(x, y) for y in ys for x in xs]).reshape(-1, 2)


def _own_parts(drawn: list, a: np.ndarray, b: np.ndarray) -> tuple[list, list]:
    """The drawn polylines that lie on the segment a-b (a bending line clipped to the plate:
    one or more parts), longest first, and the others."""
    d = unit(b - a)
    on = [p for p in drawn if len(p) >= 2 and np.all(np.abs((p - a) @ np.array([-d[1], d[0]])) < 1e-6)
          and np.all((p - a) @ d >= -1e-6) and np.all((p - a) @ d <= np.linalg.norm(b - a) + 1e-6)]
    on.sort(key=lambda p: -float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))))
    return on, [p for p in drawn if not any(p is q for q in on)]


def _nearer(centres: np.ndarray, size: np.ndarray, own: list, others: list, by: float = 0.0,
            within: float = np.inf) -> np.ndarray:
    """The label centres (C, 2) whose box (size (2,)) lies within ``within`` of the nearest
    of the polylines ``own`` and nearer it than any of ``others`` by more than ``by``: a
    label there names its own line, not another (all of them when ``own`` is empty)."""
    import shapely

    centres = np.asarray(centres, dtype=float).reshape(-1, 2)
    own = [p for p in own if len(p) >= 2]
    others = [p for p in others if len(p) >= 2]
    if not own or not len(centres):
        return centres
    half = 0.5 * np.asarray(size, dtype=float)
    boxes = shapely.box(centres[:, 0] - half[0], centres[:, 1] - half[1], centres[:, 0] + half[0],
                        centres[:, 1] + half[1])

    def nearest(lines, at):
        geoms = np.array([shapely.LineString(p) for p in lines], dtype=object)
        return shapely.distance(at[:, None], geoms[None, :]).min(axis=1)

    mine = nearest(own, boxes)
    keep = mine <= within
    if keep.any() and others:
        keep[keep] = mine[keep] + by < nearest(others, boxes[keep])
    return centres[keep]


def _nearest_line(polylines: list, point) -> np.ndarray | None:
    """The polyline of ``polylines`` [(K, 2)] nearest ``point`` (2,), None when there is none."""
    import shapely

    lines = [p for p in polylines if len(p) >= 2]
    if not lines:
        return None
    at = shapely.Point(point)
    return lines[int(np.argmin([shapely.LineString(p).distance(at) for p in lines]))]


def _named(text, kin: list, paper) -> tuple[np.ndarray, np.ndarray | None]:
    """The point a text of another module's mark kind names (paper mm) and its line among
    ``kin`` (its kind's polylines on the paper; None when it has none): the text's own
    ``names`` point, else the nearest point of its kind's lines."""
    import shapely

    at = paper(text.names if text.names is not None else text.at)
    own = _nearest_line(kin, at)
    if own is None:
        return at, None
    path = shapely.LineString(own)
    return np.asarray(path.interpolate(path.project(shapely.Point(at))).coords[0]), own


def _along(line: np.ndarray, point: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Centres (C, 2) of a label's box (size (2,)) GAP + 0.2 mm off either side of the
    polyline (K, 2), beside the point it names and then along the line (nearest first)."""
    line = np.asarray(line, dtype=float)
    at = slid_along(line, point)
    seg = line[1:] - line[:-1]
    mid = 0.5 * (line[1:] + line[:-1])
    d = seg[np.argmin(np.linalg.norm(at[:, None, :] - mid[None, :, :], axis=2), axis=1)]
    d = d / np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
    n = np.column_stack([-d[:, 1], d[:, 0]])
    reach = np.abs(n) @ (0.5 * np.asarray(size, dtype=float)) + GAP + 0.2
    return np.stack([at + reach[:, None] * n, at - reach[:, None] * n], axis=1).reshape(-1, 2)


def _chain_label(placer: PaperPlacer, text: str, a: np.ndarray, b: np.ndarray, mids: np.ndarray, near: bool):
    """A spacing figure for the stretch of the centre line chain from a to b (paper mm):
    beside the chain between them; unless near, also beyond the chain's ends."""
    u = unit(b - a)
    angle = axis_angle(u)
    n = np.array([-u[1], u[0]]) if u[0] >= 0 else np.array([u[1], -u[0]])
    size = size_of(text, H_LABEL, angle)
    reach = 0.5 * (abs(n[0]) * size[0] + abs(n[1]) * size[1]) + GAP + 0.05
    centres = [0.5 * (a + b) + s * (reach + off) * n for off in (0.0, 1.5, 3.0) for s in (1, -1)]
    if not near:
        first, last = unit(mids[0] - mids[1]), unit(mids[-1] - mids[-2])
        for end, d in ((mids[0] + 3.5 * first, first), (mids[-1] + 3.5 * last, last)):
            along = beyond(end, d, text, angle, GAP + np.array([0.0, 3.0, 8.0, 14.0, 20.0, 28.0, 36.0]))
            centres += list(along) + [c + s * (reach + 1.0) * n for c in along for s in (1, -1)]
    return placer.place(text, np.array(centres), angle, style="tab:blue")


def _frame_names(layout) -> list[str]:
    """The name of each frame line of the layout (its ``frame_names``; for a layout without
    them the nearest frame text, 'FR' when none)."""
    count = sum(1 for kind, _ in layout.lines if kind == "frame")
    named = list(getattr(layout, "frame_names", []) or [])
    if len(named) == count:
        return named
    texts = [t for t in layout.texts if t.kind == "frame"]
    names = []
    for kind, line in layout.lines:
        if kind != "frame":
            continue
        if texts:
            d = [float(np.min(np.linalg.norm(np.asarray(line) - np.asarray(t.at), axis=1))) for t in texts]
            names.append(texts[int(np.argmin(d))].text)
        else:
            names.append("FR")
    return names


def _table_pages(title: str, rows: list[BendRow], columns: np.ndarray, sheet: Sheet) -> list[Page]:
    """The rest of the table on pages of their own, in as many column groups as fit."""
    pw, ph = sheet.width, sheet.height
    pages = []
    group_w = float(columns.sum()) + 4 * PAD
    groups = max(int((pw - 2 * MARGIN - 2 * PAD) // group_w), 1)
    title_h = 2 * PAD + H_TITLE / CAP + 2 * PITCH * H_LABEL / CAP
    fit = table_capacity(ph - 2 * MARGIN - title_h - 2 * PAD)
    while rows:
        page = Page(pw, ph)
        page.add("rule", [np.array([[MARGIN, MARGIN], [pw - MARGIN, MARGIN], [pw - MARGIN, ph - MARGIN],
                                    [MARGIN, ph - MARGIN], [MARGIN, MARGIN]])])
        for g in range(groups):
            if not rows:
                break
            _table(page, rows[:fit], columns, MARGIN + PAD + g * group_w, ph - MARGIN - PAD,
                   "BENDING LINES (CONTINUED)")
            rows = rows[fit:]
        _title_block(page, title, [], MARGIN + title_h, PAGE_NUMBER)
        pages.append(page)
    return pages


def template_pages(title: str, templates, pw: float, ph: float) -> list[Page]:
    """The templates (:class:`pipeline.shop.templates.Template`), one below the other at one
    standard scale: the section's edge over its base line, the heights every station
    (figures in a row under each), the sight line; as many pages as they take."""
    templates = list(templates or ())
    if not templates:
        return []
    em = H_LABEL / CAP
    pitch = PITCH * em
    title_h = 2 * PAD + H_TITLE / CAP + 2 * pitch
    width = pw - 2 * MARGIN - 4 * PAD
    longest = max(float(t.length) for t in templates)
    scale = next((s for s in SCALES if longest / s <= width), SCALES[-1])
    pages, page, y = [], None, 0.0
    for t in templates:
        prof = np.asarray(t.profile, dtype=float)
        h_all = np.concatenate([prof[:, 1], [0.0], np.nan_to_num(np.asarray(t.sight, float))])
        lo_h, hi_h = float(h_all.min()) / scale, float(h_all.max()) / scale
        figures = [f"{round(float(v)) + 0:.0f}" for v in t.heights]  # no "-0"
        stations = [f"{round(float(v)) + 0:.0f}" for v in t.stations]
        cell = max([text_width(s) for s in figures + stations] + [1.0]) + 2.0
        per_row = max(int((width - text_width("HEIGHT  ")) // cell), 1)
        table_rows = 2 * int(np.ceil(len(figures) / per_row))
        need = 2 * pitch + (hi_h - lo_h) + table_rows * pitch + 2 * PAD
        if page is None or y - need < MARGIN + title_h + PAD:
            if page is not None:
                pages.append(page)
            page = Page(pw, ph)
            page.add("rule", [np.array([[MARGIN, MARGIN], [pw - MARGIN, MARGIN], [pw - MARGIN, ph - MARGIN],
                                        [MARGIN, ph - MARGIN], [MARGIN, MARGIN]])])
            _title_block(page, f"{title}: TEMPLATES", [f"TEMPLATES AT 1:{scale} (CUT AT 1:1 FROM THE TEMPLATES DXF); "
                                                      "HEIGHTS FROM THE BASE LINE IN MM"],
                         MARGIN + title_h, PAGE_NUMBER)
            y = ph - MARGIN - PAD
        x0 = MARGIN + 2 * PAD
        y -= (1 - DESCENT) * em
        page.labels.append(Label(f"{t.ident}  {t.name}  BASE LINE {t.length:.0f}", x0, y))
        base_y = y - DESCENT * em - GAP - 1.0 - hi_h
        page.add("template", [np.column_stack([x0 + prof[:, 0] / scale, base_y + prof[:, 1] / scale])])
        page.add("dim", [np.array([[x0, base_y], [x0 + t.length / scale, base_y]])])
        page.add("station", [np.array([[x0 + s / scale, base_y], [x0 + s / scale, base_y + hh / scale]])
                             for s, hh in zip(t.stations, t.heights)])
        if np.all(np.isfinite(t.sight)):
            page.add("sight", [np.array([[x0, base_y + t.sight[0] / scale], [x0 + t.length / scale,
                                                                            base_y + t.sight[1] / scale]])])
        y = base_y + lo_h - GAP - 1.0
        for k in range(0, len(figures), per_row):
            for head, cells in (("AT", stations[k:k + per_row]), ("HEIGHT", figures[k:k + per_row])):
                y -= pitch
                page.labels.append(Label(head, x0, y))
                for j, text in enumerate(cells):
                    right = x0 + text_width("HEIGHT  ") + (j + 1) * cell
                    page.labels.append(Label(text, right - text_width(text), y))
        y -= DESCENT * em + 2 * PAD
    pages.append(page)
    return pages


def write_shop_drawing(target: str | Path, layout, title: str, part_data: list[str], bends: list,
                       spacing: float | None, notes: list[str] = (), edges: dict | None = None,
                       templates=()) -> dict:
    """Write the drawing; returns what the report says of it (paper, scale, pages).

    layout : a :class:`pipeline.shop.layout.Layout` (mm)
    bends : [(number, mark text, (2,) a on the c side, (2,) b on the d side[, station: the
        distance across the rulings from the plate's first end])] in mm
    edges : {name: (K, 2) polyline of the net edge it names}, c and d first
    spacing : the bending lines' spacing across them (mm), None when none
    templates : the plate's templates: a page of them
    """
    pages, info = plan_pages(layout, title, part_data, bends, spacing, list(notes), edges, templates)
    render("pipeline.shop.drawing:draw_pages", target, pages, title)
    return {"file": Path(target).name, **info}


def draw_pages(target, pages: list[Page], title: str) -> None:
    """Render planned pages into one PDF (in the render process)."""
    import matplotlib

    quiet = logging.getLogger("matplotlib.font_manager")
    level = quiet.level
    quiet.setLevel(logging.ERROR)  # the core fonts' AFM say "medium" where matplotlib asks "normal"
    try:
        with matplotlib.rc_context(CORE_FONTS):
            _render(target, pages, title)
    finally:
        quiet.setLevel(level)


def _render(target, pages: list[Page], title: str) -> None:
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.figure import Figure
    from matplotlib.transforms import Affine2D

    from ..lazymodules import pdf_backend

    backend = pdf_backend()
    with atomic_path(target) as tmp:
        with backend.PdfPages(tmp, metadata={"Title": title, "Creator": "devflat"}) as pdf:
            for page in pages:
                fig = Figure(figsize=(page.width / 25.4, page.height / 25.4))
                backend.FigureCanvasPdf(fig)
                # the page's millimetres drawn straight on the figure: an Axes (its ticks,
                # spines and clearing, all hidden) cost a third of a shop drawing's time
                mm = Affine2D().scale(1.0 / 25.4) + fig.dpi_scale_trans
                for style, lines in page.lines.items():
                    if style.startswith("other:"):
                        colour, width, dash = style[6:], 0.6, (0, (2, 1))
                    else:
                        colour, width, dash = STYLES[style]
                    fig.add_artist(LineCollection(lines, colors=colour, linewidths=width, linestyles=dash or "solid",
                                                  transform=mm))
                for colour, hatch, ring in page.areas:
                    fig.add_artist(PolyCollection([ring], facecolors="none", edgecolors=colour, hatch=hatch,
                                                  linewidths=0.4, transform=mm))
                for x, y, r in page.circles:
                    fig.add_artist(_circle(x, y, r, mm))
                fig.add_artist(_labels_artist(page.labels, mm))
                pdf.savefig(fig)


def _labels_artist(labels: list, mm):
    """One artist that writes every label straight through the renderer (baseline start at
    the anchor, turned by its angle): a matplotlib Text per label would lay each out again,
    at several times the cost, to the same place. ``mm``: page millimetres to the display."""
    from matplotlib.artist import Artist
    from matplotlib.font_manager import FontProperties

    class Labels(Artist):
        def draw(self, renderer):
            gc = renderer.new_gc()
            props = {}
            xy = mm.transform(np.array([(lb.x, lb.y) for lb in labels]).reshape(-1, 2))
            for lb, (x, y) in zip(labels, xy):
                size = lb.h / CAP * PT
                prop = props.get(size)
                if prop is None:
                    prop = props[size] = FontProperties(family="sans-serif", size=size)
                gc.set_foreground(lb.style)
                renderer.draw_text(gc, float(x), float(y), lb.text, prop, lb.angle)
            gc.restore()

    return Labels()


def _circle(x, y, r, mm):
    from matplotlib.patches import Circle

    return Circle((x, y), r, fill=r <= LEADER_DOT, lw=0.4, color="black", transform=mm)


def warm_up() -> None:
    """Draw a small sheet into a temporary folder: the first PDF of a process reads the core
    fonts' metrics and fills matplotlib's caches (three to four times a later drawing's
    cost); a render process (:mod:`pipeline.renderproc`) does it while it waits."""
    import tempfile

    page = Page(297.0, 210.0)
    page.add("cut", [np.array([[50.0, 50.0], [150.0, 50.0], [150.0, 100.0], [50.0, 100.0], [50.0, 50.0]])])
    page.labels.append(Label("B1 WARM-UP 0123456789", 60.0, 120.0))
    page.labels.append(Label("FR 1000", 60.0, 30.0, angle=90))
    with tempfile.TemporaryDirectory() as folder:
        draw_pages(Path(folder) / "warm-up.pdf", [page], "WARM-UP")
