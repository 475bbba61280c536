"""Text on the paper of a drawing (mm): the core font's metrics and a placer that keeps
every label clear of the others and of the drawn lines.

Labels are one-line Helvetica texts at a capital height (ISO 3098: 2.5 mm and up), upright
or turned 90 degrees, anchored at their baseline's start; their boxes are the glyphs' em
boxes as a PDF reader reports them (pdfminer: from the descent to one em above it), so what
the placer keeps apart is what a reader of the PDF measures. Pure numpy and shapely.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

H_LABEL, H_HEAD, H_TITLE = 2.5, 3.5, 5.0  # capital heights (ISO 3098), paper mm
CAP, DESCENT = 0.718, 0.207  # Helvetica's capital height and descent per em (its AFM)
PITCH = 1.45  # rows of a block or table, baseline to baseline, in em
GAP = 0.8  # paper mm kept between a text and any other text or line


@functools.lru_cache(maxsize=1)
def _advances() -> dict:
    """Helvetica's advance widths per character (em), read from matplotlib's copy of the
    core font's AFM file (found without importing matplotlib)."""
    import importlib.util

    spec = importlib.util.find_spec("matplotlib")
    path = Path(spec.submodule_search_locations[0]) / "mpl-data" / "fonts" / "pdfcorefonts" / "Helvetica.afm"
    widths = {}
    for line in path.read_text(encoding="latin-1").splitlines():
        if line.startswith("C "):
            fields = dict(f.strip().split(" ", 1) for f in line.split(";") if f.strip())
            code = int(fields["C"])
            if 32 <= code < 127:
                widths[chr(code)] = float(fields["WX"]) / 1000.0
    return widths


def text_width(text: str, h: float = H_LABEL) -> float:
    """Paper mm a one-line Helvetica text of capital height h takes along its baseline."""
    widths = _advances()
    return sum(widths.get(ch, 0.75) for ch in text) * h / CAP


@dataclass(frozen=True)
class Label:
    """A one-line text on the paper: anchor (baseline start) at x, y mm, capital height h,
    angle 0 or 90 degrees."""

    text: str
    x: float
    y: float
    h: float = H_LABEL
    angle: int = 0
    style: str = "black"

    def box(self) -> tuple[float, float, float, float]:
        """(x0, y0, x1, y1): the glyphs' em box as a PDF reader reports it."""
        em, w = self.h / CAP, text_width(self.text, self.h)
        if self.angle == 0:
            return self.x, self.y - DESCENT * em, self.x + w, self.y + (1 - DESCENT) * em
        return self.x - (1 - DESCENT) * em, self.y, self.x + DESCENT * em, self.y + w


def label_in(text: str, box_centre, h: float = H_LABEL, angle: int = 0, style: str = "black") -> Label:
    """The label whose box is centred at box_centre (2,)."""
    em, w = h / CAP, text_width(text, h)
    cx, cy = float(box_centre[0]), float(box_centre[1])
    if angle == 0:
        return Label(text, cx - 0.5 * w, cy - (0.5 - DESCENT) * em, h, 0, style)
    return Label(text, cx + (0.5 - DESCENT) * em, cy - 0.5 * w, h, 90, style)


def size_of(text: str, h: float, angle: int) -> np.ndarray:
    """(width, height) of a label's box on the paper."""
    em, w = h / CAP, text_width(text, h)
    return np.array([w, em]) if angle == 0 else np.array([em, w])


END_CLEAR = 2.3  # paper mm between a leader's end and any label but its own (its own: GAP)


class PaperPlacer:
    """Places label boxes inside ``bounds`` (x0, y0, x1, y1 paper mm), each GAP clear of the
    boxes placed before, of every segment of ``polylines``, of the ``areas`` (rings, their
    insides included) and of the leaders drawn before (:mod:`pipeline.shop.leaders`), and
    END_CLEAR clear of those leaders' ends."""

    def __init__(self, bounds, polylines, areas=()):
        import shapely

        self.bounds = np.asarray(bounds, dtype=float)
        segs = [np.stack([p[:-1], p[1:]], axis=1) for p in polylines if len(p) >= 2]
        segs = np.concatenate(segs) if segs else np.zeros((0, 2, 2))
        # hatched areas whole: a text on their hatching is not read
        geoms = list(shapely.linestrings(segs)) if len(segs) else []
        geoms += [shapely.Polygon(ring).buffer(0) for ring in areas if len(ring) >= 3]
        self.tree = shapely.STRtree(geoms) if geoms else None
        self.boxes = np.zeros((0, 4))
        self.leaders: list = []  # shapely LineStrings of the leaders placed, from their dots

    def first_free(self, boxes: np.ndarray) -> int | None:
        """Index of the first free box of boxes (C, 4), which is taken; None when none is."""
        idx = self.free(boxes)
        if not idx.size:
            return None
        self.boxes = np.vstack([self.boxes, np.asarray(boxes, dtype=float).reshape(-1, 4)[idx[0]]])
        return int(idx[0])

    def free(self, boxes: np.ndarray) -> np.ndarray:
        """Indices (in order) of the boxes (C, 4) inside the bounds and clear of all else."""
        import shapely

        boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
        b = self.bounds
        ok = (boxes[:, 0] >= b[0]) & (boxes[:, 1] >= b[1]) & (boxes[:, 2] <= b[2]) & (boxes[:, 3] <= b[3])
        if len(self.boxes):
            p = self.boxes
            hit = ((boxes[:, None, 0] < p[None, :, 2] + GAP) & (boxes[:, None, 2] > p[None, :, 0] - GAP)
                   & (boxes[:, None, 1] < p[None, :, 3] + GAP) & (boxes[:, None, 3] > p[None, :, 1] - GAP))
            ok &= ~hit.any(axis=1)
        if self.leaders:
            ends = np.array([leader.coords[-1] for leader in self.leaders])
            near = ((ends[None, :, 0] > boxes[:, None, 0] - END_CLEAR) & (ends[None, :, 0] < boxes[:, None, 2] + END_CLEAR)
                    & (ends[None, :, 1] > boxes[:, None, 1] - END_CLEAR) & (ends[None, :, 1] < boxes[:, None, 3] + END_CLEAR))
            ok &= ~near.any(axis=1)
        idx = np.flatnonzero(ok)
        if idx.size and self.tree is not None:
            grown = boxes[idx] + np.array([-GAP, -GAP, GAP, GAP])
            hits = self.tree.query(shapely.box(grown[:, 0], grown[:, 1], grown[:, 2], grown[:, 3]),
                                   predicate="intersects")[0]
            idx = np.delete(idx, np.unique(hits))
        if idx.size and self.leaders:
            grown = boxes[idx] + np.array([-GAP, -GAP, GAP, GAP])
            crossed = shapely.intersects(shapely.box(grown[:, 0], grown[:, 1], grown[:, 2], grown[:, 3])[:, None],
                                         np.array(self.leaders, dtype=object)[None, :]).any(axis=1)
            idx = idx[~crossed]
        return idx

    def place(self, text: str, centres: np.ndarray, angle: int, h: float = H_LABEL, style: str = "black"):
        """The label centred at the first free one of centres (C, 2), None when none is."""
        half = 0.5 * size_of(text, h, angle)
        centres = np.asarray(centres, dtype=float).reshape(-1, 2)
        i = self.first_free(np.hstack([centres - half, centres + half]))
        return None if i is None else label_in(text, centres[i], h, angle, style)


def beyond(point, direction, text: str, angle: int, offsets, h: float = H_LABEL) -> np.ndarray:
    """Centres (len(offsets), 2) of a label's box just beyond ``point`` along the unit
    ``direction``, its near side offsets (paper mm) away."""
    size = size_of(text, h, angle)
    d = np.asarray(direction, dtype=float)
    reach = 0.5 * (abs(d[0]) * size[0] + abs(d[1]) * size[1])
    return np.asarray(point, dtype=float) + (np.asarray(offsets, dtype=float)[:, None] + reach) * d


def axis_angle(direction) -> int:
    """The label angle (0 or 90) nearest a line's direction."""
    return 0 if abs(direction[0]) >= abs(direction[1]) else 90


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / max(float(np.linalg.norm(v)), 1e-300)
