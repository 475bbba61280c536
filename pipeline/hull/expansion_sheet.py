"""The shell expansion's sheet: how the drawing is cut into parts and laid on paper, and the
PDF of it.

A hull's expansion is long and low (the 160 m hull: 160 m by 30 m of girth), so one strip
across an A1 sheet draws it at 1:200 with a third of the paper used. Yards draw it in parts
stacked on the sheet, each cut at a frame (the match line) and drawn at the same scale, as a
forebody and an aftbody. :func:`plan_sheet` chooses the sheet (A1 or A0 landscape), the
number of parts (1 to 3) and the standard scale together: the largest scale at which the
parts fit up to 1:100 (at which yards draw it; a drawing that fits one part at 1:100 or
larger is not cut), then the fewest parts, then the smaller sheet.

The sheet (paper mm, origin at the lower left): a border 10 mm in; the title and a line of
what is drawn at the top; the parts stacked under it, each with a caption (its frames and
x range, FWD / AFT when the config says where the bow is) and a match line at each cut;
at the foot the legend (plate classes and line kinds), a scale bar, and the title block
(drawing, hull, plates, scale, sheet, units, side shown, girth datum).

The DXF (:func:`pipeline.hull.expansion.write_expansion_dxf`) lays out the same sheet in
paper space: one viewport per part at the scale, the title block beside them.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

import numpy as np

from flatten.metrics import polyline_length

from ..io.atomic import atomic_path

SHEETS = {"A1": (841.0, 594.0), "A0": (1189.0, 841.0)}  # landscape, mm
SCALES = (1, 2, 5, 10, 20, 25, 50, 100, 200, 250, 500, 1000, 2000, 2500, 5000, 10000)
MAX_PARTS = 3
PT_PER_MM = 72.0 / 25.4
SHIFTS = tuple(sorted((k / 100.0 for k in range(-12, 13)), key=abs))  # of a part: where a level's name may move
READABLE = 100  # a scale at least this large (1:100, as yards draw it) is not bettered by cutting into more parts
MARGIN = 20.0  # paper mm from the sheet's edge to what is drawn (the border at half of it)
HEAD = 16.0  # paper mm: the title and the line under it
FOOT = 46.0  # paper mm: legend, scale bar and title block
CAPTION = 9.0  # paper mm above each part: its caption and the frame numbers
BETWEEN = 5.0  # paper mm between one part's foot and the next part's caption
TITLE_BLOCK_W = 180.0  # paper mm
GIRTH_DATUM = "EACH SECTION'S LOWER END (KEEL AT CL), ALONG STEM / TRANSOM CONTOURS"
LEVEL_STYLES = {"waterline": {"colors": "#1f5fbf", "linewidths": 0.25, "linestyles": (0, (8, 2, 1, 2))},
                "design": {"colors": "#1f5fbf", "linewidths": 0.6, "linestyles": "solid"},
                "deck": {"colors": "#8b1a1a", "linewidths": 0.8, "linestyles": "solid"}}
LINE_KINDS = {  # legend: name, colour, width (pt, the legend's sample), dashes
    "seam": ("SEAM / BUTT", "black", 0.5, None),
    "frame": ("FRAME", "0.45", 0.4, (0, (4, 2))),
    **{kind: (name, LEVEL_STYLES[kind]["colors"], width, LEVEL_STYLES[kind]["linestyles"])
       for kind, name, width in (("waterline", "WATERLINE (WL)", 0.5), ("design", "DESIGN WATERLINE (DWL)", 0.9),
                                 ("deck", "DECK AT SIDE", 0.9))},
    "match": ("MATCH LINE", "black", 1.0, (0, (10, 2, 2, 2))),
}


@dataclass(frozen=True)
class SheetPlan:
    """Where the expansion goes on paper: the sheet (name, width, height mm), the scale
    denominator, each part's x range (model units) and each part's drawing box (left,
    bottom, width, height, paper mm); ``cuts`` the frame (number or None, x) of each match
    line."""

    sheet: str
    size: tuple
    scale: int
    parts: tuple
    boxes: tuple
    cuts: tuple

    @property
    def title_block(self) -> tuple:
        """(left, bottom, width, height) paper mm of the title block, at the foot on the right."""
        w, _ = self.size
        return (w - MARGIN - TITLE_BLOCK_W, MARGIN, TITLE_BLOCK_W, FOOT - 6.0)


def _cuts(x_range: tuple, parts: int, frames: list) -> list[tuple]:
    """(frame number or None, x) of the parts - 1 cuts: at the frame nearest each equal
    division of the length (at the division itself when there are no frames inside)."""
    x0, x1 = x_range
    inside = [(n, x) for n, x in frames if x0 < x < x1]
    cuts = []
    for k in range(1, parts):
        ideal = x0 + k * (x1 - x0) / parts
        cut = min(inside, key=lambda f: abs(f[1] - ideal)) if inside else (None, ideal)
        if cuts and cut[1] <= cuts[-1][1]:
            return []
        cuts.append(cut)
    return cuts


def plan_sheet(x_range: tuple, height: float, mm_per_unit: float, frames: list = ()) -> SheetPlan:
    """The sheet, scale and parts for an expansion over ``x_range`` (model units) and
    ``height`` (its girth, model units); ``frames``: (number, x) where parts may be cut.

    The largest standard scale wins up to 1:``READABLE``; among those as large, the fewest
    parts, then the larger scale, then the smaller sheet."""
    best = None
    for parts in range(1, MAX_PARTS + 1):
        cuts = _cuts(x_range, parts, list(frames))
        if parts > 1 and len(cuts) != parts - 1:
            continue
        edges = [x_range[0]] + [x for _, x in cuts] + [x_range[1]]
        longest = max(b - a for a, b in pairwise(edges)) * mm_per_unit
        for k, (name, (w, h)) in enumerate(SHEETS.items()):
            room_w = w - 2 * MARGIN
            room_h = (h - 2 * MARGIN - HEAD - FOOT - parts * CAPTION - (parts - 1) * BETWEEN) / parts
            n = next((s for s in SCALES if longest / s <= room_w and height * mm_per_unit / s <= room_h), None)
            if n is None:
                continue
            key = (max(n, READABLE), parts, n, k)
            if best is None or key < best[0]:
                best = (key, name, (w, h), n, tuple(pairwise(edges)), tuple(cuts))
    if best is None:
        raise ValueError(f"the expansion ({(x_range[1] - x_range[0]) * mm_per_unit:.0f} x "
                         f"{height * mm_per_unit:.0f} mm) fits no sheet at 1:{SCALES[-1]}")
    _, name, (w, h), n, parts, cuts = best
    boxes, top = [], h - MARGIN - HEAD
    box_h = height * mm_per_unit / n
    for a, b in parts:
        top -= CAPTION
        boxes.append((MARGIN, top - box_h, (b - a) * mm_per_unit / n, box_h))
        top -= box_h + BETWEEN
    return SheetPlan(name, (w, h), n, parts, tuple(boxes), cuts)


def line_kinds(drawing, plan: SheetPlan) -> set:
    """The kinds of line (keys of ``LINE_KINDS``) the drawing has on this sheet."""
    return ({"seam"} | ({"frame"} if drawing.frames else set()) | {level.kind for level in drawing.levels}
            | ({"match"} if plan.cuts else set()))


def frame_at(cut: tuple, mm: float) -> str:
    """A cut's name: its frame, or its x (m) where no frame was there to cut at."""
    number, x = cut
    return f"FR {number}" if number is not None else f"X {x * mm / 1000:.2f} M"


def part_captions(plan: SheetPlan, mm: float, bow: str | None) -> list[str]:
    """Each part's caption: which part, its ends (frames at the cuts) and its x range (m)."""
    count = len(plan.parts)
    names = ["" for _ in plan.parts]
    if bow is not None and count > 1:
        order = list(range(count)) if bow == "high" else list(range(count))[::-1]
        names[order[0]], names[order[-1]] = "AFTBODY ", "FOREBODY "
        if count == 3:
            names[order[1]] = "MIDBODY "
    out = []
    for k, (a, b) in enumerate(plan.parts):
        low, high = {"high": ("THE AFT END", "THE FORE END"), "low": ("THE FORE END", "THE AFT END")}.get(
            bow, ("THE END", "THE END"))
        ends = [f"THE MATCH LINE AT {frame_at(plan.cuts[k - 1], mm)}" if k > 0 else low,
                f"THE MATCH LINE AT {frame_at(plan.cuts[k], mm)}" if k < count - 1 else high]
        whose = f"PART {k + 1} OF {count}: FROM {ends[0]} TO {ends[1]}, " if count > 1 else ""
        out.append(f"{names[k]}{whose}X {a * mm / 1000:.2f} TO {b * mm / 1000:.2f} M")
    return out


def title_rows(info: dict, plan: SheetPlan) -> list[tuple[str, str]]:
    """(field, value) rows of the title block."""
    w, h = plan.size
    return [("DRAWING", info.get("drawing", "")), ("HULL", info.get("hull", "")),
            ("PLATES", str(info.get("plates", ""))),
            ("SCALE", f"1:{plan.scale}"), ("SHEET", f"{plan.sheet} {w:.0f} X {h:.0f} MM, 1 OF 1"),
            ("UNITS", "MM (X AND GIRTH ON THE HULL)"), ("SIDE SHOWN", info.get("side", "")),
            ("GIRTH FROM", GIRTH_DATUM)] + _issue_rows(info.get("issue"))


def _issue_rows(issue) -> list[tuple[str, str]]:
    """The title block's rows of the drawing's issue (:class:`pipeline.config.Issue`, or None:
    DEVFLAT drew it)."""
    if issue is None:
        return [("DRAWN BY", "DEVFLAT")]
    rows = [("REVISION", f"{issue.revision}, ISSUED {issue.date.isoformat()}".upper()),
            ("DRAWN BY", f"{issue.drawn_by.upper()} (DEVFLAT)" if issue.drawn_by else "DEVFLAT")]
    return rows + ([("APPROVED BY", issue.approved_by.upper())] if issue.approved_by else [])


def scale_bar_length(scale: int, room: float = 120.0) -> float:
    """The scale bar's length (m on the hull): the longest of 1, 2, 5 x 10^k m that is at
    most ``room`` paper mm long at 1:scale."""
    best = 1e-3
    for decade in range(-3, 5):
        for step in (1.0, 2.0, 5.0):
            length = step * 10.0 ** decade
            if length * 1000.0 / scale <= room:
                best = max(best, length)
    return best


def ring_centre(ring: np.ndarray) -> np.ndarray:
    """Area centroid (2,) of a closed ring (N, 2) (the mean point when it has no area)."""
    x, y = ring[:, 0], ring[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2
    if abs(area) < 1e-12 * max(np.ptp(x) * np.ptp(y), 1e-300):
        return ring.mean(axis=0)
    return np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6 * area)


def plate_label(plate) -> tuple[str, str]:
    """A plate's name and its thickness' text (empty when it has none)."""
    thick = "" if plate.thickness is None else f"t {plate.thickness:g}"
    return plate.name, thick


def level_label_places(level, x_range: tuple, fractions=(0.25, 0.75)) -> list[tuple[np.ndarray, float]]:
    """Where a level's name goes (model units) and its angle (degrees, along the line): on each
    of its lines that runs over a quarter of the drawing's length at least, at ``fractions``
    of that length (a quarter and three quarters) where the line reaches (away from the ends,
    where the waterlines crowd into the stem and stern profiles); else at the middle of its
    longest line."""
    x0, x1 = x_range
    places = []
    for line in level.lines:
        if np.ptp(line[:, 0]) < 0.25 * (x1 - x0):
            continue
        for x in (x0 + f * (x1 - x0) for f in fractions):
            hit = np.flatnonzero((line[:-1, 0] - x) * (line[1:, 0] - x) <= 0)
            if len(hit):
                k = int(hit[0])
                a, b = line[k], line[k + 1]
                t = 0.0 if b[0] == a[0] else (x - a[0]) / (b[0] - a[0])
                places.append((a + t * (b - a), _along(b - a)))
    if places:
        return places
    line = max(level.lines, key=polyline_length)
    k = len(line) // 2
    return [(line[k], _along(line[min(k + 1, len(line) - 1)] - line[max(k - 1, 0)]))]


def _along(direction: np.ndarray) -> float:
    """The angle (degrees) of a text along a direction, turned to read left to right."""
    from ..shop.layout import readable

    return readable(float(np.degrees(np.arctan2(direction[1], direction[0]))))


def write_expansion_pdf(target: str | Path, drawing, plan: SheetPlan, mm_per_unit: float, title: str,
                        info: dict, tiles: tuple[str, Path] | None = None) -> dict:
    """The sheet ``plan`` lays out, true to its scale (x along the hull, girth up); returns
    the sheet, the scale, the sheet's size in mm and the parts' x ranges. ``tiles``: (page
    size, path) to write the same sheet on A3 or A4 pages as well (:mod:`pipeline.io.tiled`)."""
    from matplotlib import rc_context
    from matplotlib.backends.backend_pdf import FigureCanvasPdf
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    w, h = plan.size
    mm = mm_per_unit
    with rc_context({"pdf.fonttype": 42}):  # TrueType text: readable (and searchable) in the PDF
        fig = Figure(figsize=(w / 25.4, h / 25.4))
        FigureCanvasPdf(fig)
        paper = fig.add_axes((0.0, 0.0, 1.0, 1.0))
        paper.set_xlim(0.0, w)
        paper.set_ylim(0.0, h)
        paper.set_axis_off()
        paper.set_zorder(10)  # over the parts: a frame number above a low section is not under the next plate
        paper.patch.set_visible(False)
        paper.add_patch(Rectangle((MARGIN / 2, MARGIN / 2), w - MARGIN, h - MARGIN, fill=False, linewidth=0.8))
        _draw_parts(fig, paper, drawing, plan, mm, info.get("bow"))
        paper.text(MARGIN, h - MARGIN, title, fontsize=11, ha="left", va="top")
        paper.text(MARGIN, h - MARGIN - 7.0,
                   f"shell expansion: girth along the sections x = const (from {drawing.girth_from}) "
                   f"upward, length x along the hull; scale 1:{plan.scale} on {plan.sheet} ({w:.0f} x {h:.0f} mm); "
                   f"dimensions mm", fontsize=6.5, ha="left", va="top")
        notes = info.get("notes", [])
        for k, note in enumerate(notes):
            paper.text(w - MARGIN, h - MARGIN - 4.0 * k, note, fontsize=5.5, ha="right", va="top")
        _legend(paper, line_kinds(drawing, plan))
        _scale_bar(paper, plan.scale, MARGIN + 150.0, MARGIN + 8.0)
        _title_block(paper, plan, title_rows(info, plan))
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format="pdf")
        if tiles is not None:
            from ..io.tiled import write_tiles

            page, path = tiles
            write_tiles(fig, paper, path, (w, h), page, str(info.get("drawing", title)))
    return {"sheet": plan.sheet, "scale": f"1:{plan.scale}", "size_mm": [w, h],
            "parts": [[a * mm, b * mm] for a, b in plan.parts]}


def _draw_parts(fig, paper, drawing, plan: SheetPlan, mm: float, bow: str | None) -> None:
    """Every part's axes (plates, frames, levels, labels, match lines)."""
    import shapely
    from matplotlib.collections import LineCollection, PolyCollection

    from .hullplots import CLASS_COLOURS

    w, h = plan.size
    n = plan.scale
    height = drawing.height
    pt_per_model = PT_PER_MM * mm / n  # font points per model unit on paper
    polys = [p.outline * mm for p in drawing.plates]
    colours = [CLASS_COLOURS.get(p.klass, CLASS_COLOURS["failed"]) for p in drawing.plates]
    frame_xs = np.array([f[0] for f in drawing.frames])
    spacing = float(np.diff(frame_xs).min()) * mm / n if len(frame_xs) > 1 else np.inf  # paper mm
    step = max(1, int(np.ceil(8.0 / max(spacing, 1e-9))))  # numbers 8 mm of paper apart at least
    captions = part_captions(plan, mm, bow)
    for k, ((a, b), (left, bottom, bw, bh)) in enumerate(zip(plan.parts, plan.boxes)):
        ax = fig.add_axes((left / w, bottom / h, bw / w, bh / h))
        ax.set_xlim(a * mm, b * mm)
        ax.set_ylim(0.0, height * mm)
        ax.set_axis_off()
        ax.add_collection(PolyCollection(polys, facecolors=colours, edgecolors="black", linewidths=0.3))
        frames = [[(x * mm, lo * mm), (x * mm, hi * mm)] for x, lo, hi, _, _ in drawing.frames]
        if frames:
            style = LINE_KINDS["frame"]
            ax.add_collection(LineCollection(frames, colors=style[1], linewidths=0.15, linestyles=style[3]))
        def to_paper(point, a=a, left=left, bottom=bottom):
            return np.array([left + (point[0] - a) * mm / n, bottom + point[1] * mm / n])

        taken = []  # paper boxes (x0, y0, x1, y1) of the plate names and frame numbers
        for p in drawing.plates:
            found = _label_place(p.outline, a, b, shapely)
            if found is None:
                continue
            place, area = found
            # the room along the name's line: the plate's width at its height (a slanted plate
            # is narrower there than its x extent), within the part
            extent = float(min(np.ptp(p.outline[:, 0]), b - a)) * pt_per_model
            plate_h = area * pt_per_model ** 2 / max(extent, 1e-300)  # the mean girth width
            plate_l = _width_at(p.outline, place, a, b, shapely) * pt_per_model
            name, thick = plate_label(p)
            size = float(np.clip(min(0.3 * plate_h, 1.5 * plate_l / max(len(name), 1)), 1.0, 9.0))
            ax.text(place[0] * mm, place[1] * mm, f"{name}\n{thick}" if thick else name, fontsize=size,
                    ha="center", va="center", linespacing=1.1, clip_on=True)
            taken.append(_text_box(to_paper(place), max(len(name), len(thick)), size, 2 if thick else 1, 0.0, 0.5))
        for j, (x, lo, hi, _, number) in enumerate(drawing.frames):
            if j % step == 0 and a <= x <= b:
                at = to_paper((x, hi)) + (0.0, 0.8)
                paper.text(at[0], at[1], f"FR {number}", fontsize=5.0, ha="center", va="bottom", color="0.3")
                taken.append(_text_box(at, len(f"FR {number}"), 5.0, 1, 0.0, 0.0))
        for level in drawing.levels:
            style = LEVEL_STYLES[level.kind]
            ax.add_collection(LineCollection([line * mm for line in level.lines], **style))
            size = 6.0 if level.kind == "deck" else 5.0
            for point, angle in _clear_level_places(level, (a, b), taken, to_paper, size):
                ax.text(point[0] * mm, point[1] * mm, level.name, fontsize=size, ha="center", va="bottom",
                        rotation=angle, rotation_mode="anchor", color=style["colors"], clip_on=True)
        for cut in plan.cuts:
            x = cut[1]
            if a <= x <= b:
                style = LINE_KINDS["match"]
                ax.plot([x * mm, x * mm], [0.0, height * mm], color=style[1], linewidth=style[2],
                        linestyle=style[3], clip_on=False)
                at = left + (x - a) * mm / n
                paper.text(at + (1.2 if x >= b else -1.2), bottom + bh / 2, f"MATCH LINE {frame_at(cut, mm)}",
                           fontsize=5.5, rotation=90, ha="left" if x >= b else "right", va="center",
                           fontweight="bold")
        paper.text(left, bottom + bh + CAPTION - 1.0, captions[k], fontsize=7.0, ha="left", va="top",
                   fontweight="bold")
        _direction(paper, left + bw, bottom + bh + CAPTION - 1.0, bow)


def _text_box(at: np.ndarray, chars: int, size: float, lines: int, angle: float, rise: float) -> tuple:
    """The paper box (x0, y0, x1, y1, mm) a text of ``chars`` characters at ``size`` points
    takes, centred at ``at`` along its direction (``angle`` degrees) and ``rise`` of its
    height above it (0.5: centred across it too; 0: standing on it), as the box around the
    turned text."""
    # DejaVu Sans capitals and digits are about 0.68 em wide; 0.4 mm of paper kept clear around
    width, height = 0.68 * size * chars / PT_PER_MM + 0.8, 1.15 * size * lines / PT_PER_MM + 0.8
    c, s = abs(np.cos(np.radians(angle))), abs(np.sin(np.radians(angle)))
    centre = np.asarray(at, dtype=float) + (0.5 - rise) * height * np.array([-np.sin(np.radians(angle)),
                                                                          np.cos(np.radians(angle))])
    half = 0.5 * np.array([width * c + height * s, width * s + height * c])
    return (*(centre - half), *(centre + half))


def _overlaps(box: tuple, boxes: list) -> bool:
    return any(box[0] < o[2] and o[0] < box[2] and box[1] < o[3] and o[1] < box[3] for o in boxes)


def _clear_level_places(level, x_range: tuple, taken: list, to_paper, size: float) -> list:
    """A level's name places in one part (model units, angle): at a quarter and three
    quarters of its length, or moved along the line (a hundredth of the part at a time, up
    to an eighth, nearest first) where a plate's name, a frame number or another level's
    name is there (on the first place tried when every place is taken); each one chosen is
    added to ``taken`` (paper boxes, ``to_paper`` maps model points onto the paper)."""
    from dataclasses import replace

    a, b = x_range
    long = [line for line in level.lines if np.ptp(line[:, 0]) >= 0.25 * (b - a)]
    chosen = []
    for line in long or [max(level.lines, key=polyline_length)]:
        one = replace(level, lines=(line,))
        for target in (0.25, 0.75):
            found = None
            for shift in SHIFTS:
                for point, angle in level_label_places(one, x_range, (target + shift,)):
                    if not a <= point[0] <= b or any(np.array_equal(point, q) for q, _ in chosen):
                        continue
                    box = _text_box(to_paper(point), len(level.name), size, 1, angle, 0.0)
                    if found is None or not _overlaps(box, taken):
                        found = (point, angle, box)
                if found is not None and not _overlaps(found[2], taken):
                    break
            if found is not None:
                chosen.append(found[:2])
                taken.append(found[2])
    return chosen


def _width_at(outline: np.ndarray, place: np.ndarray, a: float, b: float, shapely) -> float:
    """The length (model units) of the piece of the horizontal line through ``place`` that
    lies in the plate's outline (N, 2) and holds ``place``, within x in [a, b]; the plate's x
    extent there when the line misses it (an outline that crosses itself)."""
    polygon = shapely.make_valid(shapely.Polygon(outline))
    lo, hi = max(a, float(outline[:, 0].min())), min(b, float(outline[:, 0].max()))
    cut = polygon.intersection(shapely.LineString([(lo, place[1]), (hi, place[1])]))
    pieces = [g for g in getattr(cut, "geoms", [cut]) if g.geom_type == "LineString" and not g.is_empty]
    holding = [g for g in pieces if g.distance(shapely.Point(place)) <= 1e-9 * max(1.0, hi - lo)]
    return float(max(g.length for g in holding or pieces)) if pieces else hi - lo


def _label_place(outline: np.ndarray, a: float, b: float, shapely) -> tuple[np.ndarray, float] | None:
    """Where a plate's name goes in the part x in [a, b] (model units), and the plate's area
    in the part: its centroid when it lies in the part; for a plate cut by the part's end,
    the centroid of its larger piece when that piece is in this part; else None (named in
    the other part)."""
    from flatten.metrics import polygon_area

    x_lo, x_hi = outline[:, 0].min(), outline[:, 0].max()
    if x_hi <= a or x_lo >= b:
        return None
    if a <= x_lo and x_hi <= b:
        return ring_centre(outline), polygon_area(outline)
    polygon = shapely.make_valid(shapely.Polygon(outline))
    here = shapely.clip_by_rect(polygon, a, -np.inf, b, np.inf)
    if here.is_empty or here.area < 0.5 * polygon.area:
        return None
    point = here.representative_point() if here.geom_type != "Polygon" else here.centroid
    if not here.contains(point):
        point = here.representative_point()
    return np.array([point.x, point.y]), here.area


def _direction(paper, right: float, top: float, bow: str | None) -> None:
    """The arrow that says which way along the part is forward (or +x when the bow is not
    given), at the part's upper right."""
    text = "+X" if bow is None else "FWD"
    sign = -1.0 if bow == "low" else 1.0
    tail, head = (right - 22.0, right - 6.0) if sign > 0 else (right - 6.0, right - 22.0)
    paper.annotate("", xy=(head, top - 2.5), xytext=(tail, top - 2.5),
                   arrowprops={"arrowstyle": "-|>", "linewidth": 0.8, "color": "black"})
    paper.text(0.5 * (tail + head), top - 1.2, text, fontsize=6.5, ha="center", va="bottom", fontweight="bold")


def _legend(paper, kinds: set) -> None:
    """Plate classes (swatches) and the line kinds drawn, at the foot on the left."""
    from .hullplots import CLASS_COLOURS, LABELS

    x, y = MARGIN, MARGIN + FOOT - 8.0
    paper.text(x, y + 3.0, "LEGEND", fontsize=6.5, ha="left", va="bottom", fontweight="bold")
    for k, (klass, colour) in enumerate(CLASS_COLOURS.items()):
        row = y - 4.5 * k
        paper.add_patch(_swatch(x, row, colour))
        paper.text(x + 9.0, row + 1.25, LABELS.get(klass, klass).upper(), fontsize=5.5, ha="left", va="center")
    x += 60.0
    for k, kind in enumerate(kind for kind in LINE_KINDS if kind in kinds):
        name, colour, width, dashes = LINE_KINDS[kind]
        row = y - 4.5 * k + 1.25
        paper.plot([x, x + 12.0], [row, row], color=colour, linewidth=width, linestyle=dashes or "solid")
        paper.text(x + 15.0, row, name, fontsize=5.5, ha="left", va="center")


def _swatch(x: float, y: float, colour):
    from matplotlib.patches import Rectangle

    return Rectangle((x, y), 7.0, 2.5, facecolor=colour, edgecolor="black", linewidth=0.3)


def _scale_bar(paper, scale: int, x: float, y: float) -> None:
    """A bar of the longest round length within 120 mm at 1:scale, in five alternate pieces."""
    from matplotlib.patches import Rectangle

    length = scale_bar_length(scale)
    paper_len = length * 1000.0 / scale
    for k in range(5):
        paper.add_patch(Rectangle((x + k * paper_len / 5, y), paper_len / 5, 2.0, linewidth=0.4, edgecolor="black",
                                  facecolor="black" if k % 2 == 0 else "white"))
    for k in range(6):
        paper.text(x + k * paper_len / 5, y - 1.0, f"{k * length / 5:g}", fontsize=5.5, ha="center", va="top")
    paper.text(x + paper_len + 3.0, y + 1.0, "M", fontsize=5.5, ha="left", va="center")
    paper.text(x, y + 3.5, f"SCALE 1:{scale}", fontsize=6.5, ha="left", va="bottom", fontweight="bold")


def _title_block(paper, plan: SheetPlan, rows: list[tuple[str, str]]) -> None:
    """The ruled title block: one row per field, the field's name small on the left."""
    from matplotlib.patches import Rectangle

    left, bottom, width, height = plan.title_block
    paper.add_patch(Rectangle((left, bottom), width, height, fill=False, linewidth=0.8))
    pitch = height / len(rows)
    for k, (field, value) in enumerate(rows):
        y = bottom + height - (k + 1) * pitch
        if k:
            paper.plot([left, left + width], [y + pitch, y + pitch], color="black", linewidth=0.3)
        paper.text(left + 2.0, y + pitch / 2, field, fontsize=4.5, ha="left", va="center", color="0.3")
        paper.text(left + 28.0, y + pitch / 2, value, fontsize=6.5 if k else 7.5, ha="left", va="center",
                   fontweight="bold" if k == 0 else "normal")
    paper.plot([left + 26.0, left + 26.0], [bottom, bottom + height], color="black", linewidth=0.3)


def add_paper_layout(doc, drawing, plan: SheetPlan, mm: float, title: str, info: dict, class_layers: dict,
                     line_layers: list) -> None:
    """The sheet in the DXF's paper space (layout ``SHELL EXPANSION``, mm): a viewport per
    part onto the model space at 1:scale (with the frame numbers over it and the match line
    at its ends), the border, the title, the notes, the parts' captions, a legend of the
    layers (``class_layers`` {class: layer}, ``line_layers`` the line layers drawn), the scale
    bar and the title block, so that the layout plots as the PDF's sheet."""
    from ezdxf.enums import TextEntityAlignment

    w, h = plan.size
    n = plan.scale
    doc.layouts.rename("Layout1", "SHELL EXPANSION")
    paper = doc.layouts.get("SHELL EXPANSION")
    paper.page_setup(size=(w, h), margins=(0, 0, 0, 0), units="mm")
    if "VIEWPORTS" not in doc.layers:  # the layout's own viewport's layer
        doc.layers.add("VIEWPORTS")
    sheet = {"layer": "EXP_SHEET"}
    height = drawing.height * mm
    # paper mm: the frame numbers over a part; beyond its ends, the match line and its frame number whole
    above, side = CAPTION - 4.0, 3.0
    for (a, b), (left, bottom, bw, bh) in zip(plan.parts, plan.boxes):
        paper.add_viewport(center=(left + bw / 2, bottom + (bh + above) / 2), size=(bw + 2 * side, bh + above),
                           view_center_point=((a + b) / 2 * mm, (height + above * n) / 2),
                           view_height=(bh + above) * n, dxfattribs=sheet)
    paper.add_lwpolyline([(MARGIN / 2, MARGIN / 2), (w - MARGIN / 2, MARGIN / 2), (w - MARGIN / 2, h - MARGIN / 2),
                          (MARGIN / 2, h - MARGIN / 2)], close=True, dxfattribs=sheet)
    paper.add_text(title, height=5.0, dxfattribs=dict(sheet, insert=(MARGIN, h - MARGIN - 5.0)))
    paper.add_text(f"SHELL EXPANSION: GIRTH ALONG THE SECTIONS X = CONST UPWARD, LENGTH X ALONG THE HULL; "
                   f"SCALE 1:{n} ON {plan.sheet}; DIMENSIONS MM", height=2.0,
                   dxfattribs=dict(sheet, insert=(MARGIN, h - MARGIN - 10.0)))
    for k, note in enumerate(info.get("notes", [])):
        paper.add_text(note, height=1.8, dxfattribs=dict(sheet, insert=(w / 2, h - MARGIN - 5.0 - 3.5 * k)))
    _paper_legend(paper, plan, sheet, class_layers, line_layers)
    direction = "+X ->" if info.get("bow") is None else ("FWD ->" if info["bow"] == "high" else "<- FWD")
    for caption, (a, b), (left, bottom, bw, bh) in zip(part_captions(plan, mm, info.get("bow")), plan.parts,
                                                       plan.boxes):
        paper.add_text(caption, height=2.5, dxfattribs=dict(sheet, insert=(left, bottom + bh + CAPTION - 3.5)))
        for cut in plan.cuts:  # named beside the viewport, as on the PDF
            if a <= cut[1] <= b:
                at = left + (cut[1] - a) * mm / n + (side + 1.0 if cut[1] >= b else -side - 1.0)
                paper.add_text(f"MATCH LINE {frame_at(cut, mm)}", height=2.0, rotation=90.0, dxfattribs=sheet
                               ).set_placement((at, bottom + bh / 2), align=TextEntityAlignment.TOP_CENTER
                                               if cut[1] >= b else TextEntityAlignment.BOTTOM_CENTER)
        paper.add_text(direction, height=2.5,
                       dxfattribs=dict(sheet, insert=(left + bw - 20.0, bottom + bh + CAPTION - 3.5)))
    length = scale_bar_length(n)
    x, y, bar = MARGIN + 150.0, MARGIN + 8.0, length * 1000.0 / n
    for k in range(5):
        corners = [(x + k * bar / 5, y), (x + (k + 1) * bar / 5, y), (x + (k + 1) * bar / 5, y + 2.0),
                   (x + k * bar / 5, y + 2.0)]
        paper.add_lwpolyline(corners, close=True, dxfattribs=sheet)
        if k % 2 == 0:
            paper.add_solid([corners[0], corners[1], corners[3], corners[2]], dxfattribs=sheet)
    paper.add_text(f"SCALE 1:{n}", height=2.5, dxfattribs=dict(sheet, insert=(x, y + 3.5)))
    for k in range(6):
        paper.add_text(f"{k * length / 5:g}", height=1.8, dxfattribs=dict(sheet, insert=(x + k * bar / 5, y - 3.0)))
    paper.add_text("M", height=1.8, dxfattribs=dict(sheet, insert=(x + bar + 3.0, y)))
    left, bottom, width, block_h = plan.title_block
    rows = title_rows(info, plan)
    pitch = block_h / len(rows)
    paper.add_lwpolyline([(left, bottom), (left + width, bottom), (left + width, bottom + block_h),
                          (left, bottom + block_h)], close=True, dxfattribs=sheet)
    paper.add_line((left + 26.0, bottom), (left + 26.0, bottom + block_h), dxfattribs=sheet)
    for k, (field, value) in enumerate(rows):
        y = bottom + block_h - (k + 1) * pitch
        if k:
            paper.add_line((left, y + pitch), (left + width, y + pitch), dxfattribs=sheet)
        paper.add_text(field, height=1.5, dxfattribs=dict(sheet, insert=(left + 2.0, y + pitch / 2 - 0.75)))
        paper.add_text(value, height=2.0, dxfattribs=dict(sheet, insert=(left + 28.0, y + pitch / 2 - 1.0)))


def _paper_legend(paper, plan: SheetPlan, sheet: dict, class_layers: dict, line_layers: list) -> None:
    """The DXF layout's legend at the foot on the left: a sample of each plate class's
    layer ({class: layer}, its outline) and of each line layer drawn, by name."""
    x, y = MARGIN, MARGIN + FOOT - 8.0
    paper.add_text("LEGEND (LAYERS)", height=2.5, dxfattribs=dict(sheet, insert=(x, y + 3.0)))
    for k, (klass, layer) in enumerate(class_layers.items()):
        row = y - 4.5 * k
        paper.add_lwpolyline([(x, row), (x + 7.0, row), (x + 7.0, row + 2.5), (x, row + 2.5)], close=True,
                             dxfattribs={"layer": layer})
        paper.add_text(f"{layer}: {klass.upper()}", height=1.8, dxfattribs=dict(sheet, insert=(x + 9.0, row + 0.4)))
    for k, layer in enumerate(line_layers):
        row = y - 4.5 * k + 1.25
        paper.add_line((x + 60.0, row), (x + 72.0, row), dxfattribs={"layer": layer, "ltscale": 1.0 / plan.scale})
        paper.add_text(layer, height=1.8, dxfattribs=dict(sheet, insert=(x + 75.0, row - 0.9)))
