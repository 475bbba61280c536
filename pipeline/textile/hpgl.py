"""HP-GL plotter / cutter file (NAME.plt) of a textile run's pieces, at 1:1.

One file per run, the pieces where the run's sheet and AAMA DXF put them, as a marker a
cutter takes whole. Coordinates in HP-GL plotter units (0.025 mm, 40 per mm; integers, so
a vertex moves at most 0.018 mm), origin at the sheet's origin. Each kind of line on its
own pen, the cutting room's usual mapping of pens to tools: the texts and grain lines,
then the sew lines and internal lines, then the notches, and the cut lines last, so a
cutter does not cut a piece free before everything inside it is drawn. Every closed line
returns to its first point. Only the instructions every plotter since the HP 7475 knows:
IN, SP, PU, PD, SI, DI, LB (text ended by ETX).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path
from .notchtypes import notch_strokes
from .pieces import TextilePiece, label_anchor

UNITS_PER_MM = 40  # HP-GL's plotter unit is 0.025 mm
TEXT_HEIGHT_MM = 5.0
ETX = "\x03"
_NOT_PLOTTABLE = re.compile(r"[^\x20-\x7e]|;")


def _coords(points_mm: np.ndarray) -> np.ndarray:
    """Plotter units (K, 2) int of points (K, 2) mm."""
    return np.rint(np.asarray(points_mm, dtype=float) * UNITS_PER_MM).astype(np.int64)


def _stroke(points_mm: np.ndarray, closed: bool = False) -> str:
    """Pen up to the first point, pen down through the rest (back to the first if closed)."""
    xy = _coords(points_mm)
    if closed:
        xy = np.vstack([xy, xy[:1]])
    moves = ",".join(f"{x},{y}" for x, y in xy[1:])
    return f"PU{xy[0, 0]},{xy[0, 1]};PD{moves};"


def _labels(piece: TextilePiece, scale: float) -> list[tuple[np.ndarray, str]]:
    """The piece's texts and where each line starts (mm), inside the sew line as in the DXF."""
    s = piece.settings
    texts = [f"Piece Name: {piece.name}", f"Size: {s.size}", f"Quantity: {s.quantity}", f"Fabric: {s.fabric}"]
    box = np.array([0.9 * max(map(len, texts)), 1.5 * len(texts)]) * TEXT_HEIGHT_MM
    at = label_anchor(piece, box[1] / scale, box[0] / scale)
    at = (piece.sew.mean(axis=0) if at is None else at) * scale
    return [(np.array([at[0] - box[0] / 2, at[1] + box[1] / 2 - 1.5 * TEXT_HEIGHT_MM * (k + 1)]),
             _NOT_PLOTTABLE.sub("?", text)) for k, text in enumerate(texts)]


def hpgl_text(pieces: list[TextilePiece], scale: float, pens) -> str:
    """The HP-GL program of the pieces (model units; ``scale`` mm per unit); ``pens``
    gives the pen numbers ``cut``, ``sew``, ``notch`` and ``text``."""
    out = ["IN;"]
    # character size in cm (width, height), text along +x
    out.append(f"SP{pens.text};DI1,0;SI{0.6 * TEXT_HEIGHT_MM / 10:.2f},{TEXT_HEIGHT_MM / 10:.2f};")
    for piece in pieces:
        for at, text in _labels(piece, scale):
            x, y = _coords(at[None])[0]
            out.append(f"PU{x},{y};LB{text}{ETX}")
        out.append(_stroke(piece.grain * scale))
    out.append(f"SP{pens.sew};")
    for piece in pieces:
        out.append(_stroke(piece.sew * scale, closed=True))
        out += [_stroke(line * scale) for line in piece.internal_lines]
    out.append(f"SP{pens.notch};")
    for piece in pieces:
        for notch in piece.notches:
            d = np.diff(notch.line, axis=0)[0]
            angle = float(np.degrees(np.arctan2(d[1], d[0])))
            depth = float(np.hypot(*d))
            for stroke in notch_strokes(notch.kind, notch.line[0] * scale, angle, depth * scale,
                                        notch.width * scale):
                out.append(_stroke(stroke))
    out.append(f"SP{pens.cut};")
    for piece in pieces:
        out.append(_stroke(piece.cut * scale, closed=True))
    out.append("PU;SP0;")
    return "\n".join(out) + "\n"


def write_hpgl(target: str | Path, pieces: list[TextilePiece], scale: float, pens) -> None:
    text = hpgl_text(pieces, scale, pens)
    with atomic_path(target) as tmp:
        Path(tmp).write_bytes(text.encode("ascii"))
