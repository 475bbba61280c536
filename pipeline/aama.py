"""ASTM D6673 / AAMA DXF for textile pieces: writer and reader (DESIGN §5).

R12, numeric layers (1 cut boundary and piece texts, 4 notches, 7 grain line, 8 internal
lines, 14 sew line), one block per piece named PIECE_SIZE, INSERTs at the origin, units
stated in the model-space texts. Written with ezdxf's gerber_D6673 exporter. The reader
serves our files and the real AccuMark / CLO files alike.
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass, field
from pathlib import Path

import ezdxf
import numpy as np
from ezdxf.addons import gerber_D6673

from .atomic import atomic_path
from .textile import TextilePiece

LAYER_BOUNDARY, LAYER_NOTCH, LAYER_GRAIN, LAYER_INTERNAL, LAYER_SEW = "1", "4", "7", "8", "14"


def block_name(piece: TextilePiece, size: str) -> str:
    return f"{piece.name}_{size}"


def build_document(pieces: list[TextilePiece], style: str, scale: float) -> ezdxf.document.Drawing:
    """Pieces in model units, written in millimetres (``scale`` = mm per model unit)."""
    doc = ezdxf.new("R12")
    for layer in (LAYER_BOUNDARY, LAYER_NOTCH, LAYER_GRAIN, LAYER_INTERNAL, LAYER_SEW):
        doc.layers.add(layer)
    msp = doc.modelspace()
    now = datetime.date.today()
    sizes = sorted({p.settings.size for p in pieces})
    header = [f"Style Name: {style}", f"Creation Date: {now:%d-%m-%Y}", "Author: devflat",
              "Product: devflat", "Version: 1", f"Sample Size: {sizes[0] if sizes else ''}", "Units: METRIC"]
    for k, text in enumerate(header):
        msp.add_text(text, height=5.0, dxfattribs={"layer": LAYER_BOUNDARY}).set_placement((0, -10.0 * (k + 1)))
    for piece in pieces:
        s = piece.settings
        name = block_name(piece, s.size)
        block = doc.blocks.new(name=name)
        centre = piece.sew.mean(axis=0) * scale
        texts = [f"Piece Name: {piece.name}", f"Size: {s.size}", f"Quantity: {s.quantity}",
                 f"Material: {s.fabric}"]
        for k, text in enumerate(texts):
            block.add_text(text, height=5.0, dxfattribs={"layer": LAYER_BOUNDARY}).set_placement(
                (centre[0], centre[1] - 8.0 * k))
        block.add_polyline2d([tuple(p) for p in piece.cut * scale], close=True,
                             dxfattribs={"layer": LAYER_BOUNDARY})
        block.add_polyline2d([tuple(p) for p in piece.sew * scale], close=True, dxfattribs={"layer": LAYER_SEW})
        for notch in piece.notches:
            block.add_line(tuple(notch.line[0] * scale), tuple(notch.line[1] * scale),
                           dxfattribs={"layer": LAYER_NOTCH})
        block.add_line(tuple(piece.grain[0] * scale), tuple(piece.grain[1] * scale), dxfattribs={"layer": LAYER_GRAIN})
        for a, b in piece.internal_lines * scale:
            block.add_line(tuple(a), tuple(b), dxfattribs={"layer": LAYER_INTERNAL})
        msp.add_blockref(name, (0, 0))
    return doc


def write_aama(target: str | Path, pieces: list[TextilePiece], style: str, scale: float) -> None:
    doc = build_document(pieces, style, scale)
    with atomic_path(target) as tmp:
        gerber_D6673.export_file(doc, tmp)


# ------------------------------------------------------------------ reader
@dataclass
class ReadPiece:
    """A piece read back: texts by lower-case key, rings and lines per layer (mm or inch)."""

    block: str
    texts: dict = field(default_factory=dict)
    boundary: np.ndarray | None = None
    sew: np.ndarray | None = None
    notches: list = field(default_factory=list)
    grain: list = field(default_factory=list)
    internal: list = field(default_factory=list)

    @property
    def name(self) -> str:
        return self.texts.get("piece name", "")


@dataclass
class ReadFile:
    units: str
    header: dict
    pieces: list[ReadPiece]


def _polyline_points(entity) -> tuple[np.ndarray, bool]:
    if entity.dxftype() == "LWPOLYLINE":
        return np.array([p[:2] for p in entity.get_points("xy")]), bool(entity.closed)
    return np.array([tuple(v.dxf.location)[:2] for v in entity.vertices]), bool(entity.is_closed)


def chain_rings(parts: list[np.ndarray], tol: float) -> list[np.ndarray]:
    """Join open polylines end to end into closed rings (AccuMark splits the boundary)."""
    todo = [p for p in parts if len(p) >= 2]
    rings = []
    while todo:
        current = todo.pop(0)
        grown = True
        while grown and np.hypot(*(current[-1] - current[0])) > tol:
            grown = False
            for k, other in enumerate(todo):
                if np.hypot(*(other[0] - current[-1])) <= tol:
                    current = np.vstack([current, other[1:]])
                elif np.hypot(*(other[-1] - current[-1])) <= tol:
                    current = np.vstack([current, other[::-1][1:]])
                else:
                    continue
                todo.pop(k)
                grown = True
                break
        if np.hypot(*(current[-1] - current[0])) <= tol and len(current) > 3:
            rings.append(current[:-1])
        elif len(current) >= 3:
            rings.append(current)
    return rings


def _ring_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def read_aama(path: str | Path) -> ReadFile:
    """Pieces of an AAMA / ASTM D6673 file: one per block that holds a boundary."""
    doc = ezdxf.readfile(path)
    header = {}
    for e in doc.modelspace().query("TEXT"):
        key, _, value = e.dxf.text.partition(":")
        header[key.strip().lower()] = value.strip()
    pieces = []
    for block in doc.blocks:
        if block.name.startswith("*"):
            continue
        piece = ReadPiece(block.name)
        boundary_parts, sew_parts = [], []
        closed_boundary, closed_sew = [], []
        for e in block:
            layer = e.dxf.layer
            kind = e.dxftype()
            if kind == "TEXT":
                key, _, value = e.dxf.text.partition(":")
                piece.texts[key.strip().lower()] = value.strip()
            elif kind in ("POLYLINE", "LWPOLYLINE"):
                pts, closed = _polyline_points(e)
                if layer == LAYER_BOUNDARY:
                    (closed_boundary if closed else boundary_parts).append(pts)
                elif layer == LAYER_SEW:
                    (closed_sew if closed else sew_parts).append(pts)
                elif layer == LAYER_INTERNAL:
                    piece.internal.append(pts)
            elif kind == "LINE":
                seg = np.array([tuple(e.dxf.start)[:2], tuple(e.dxf.end)[:2]])
                if layer == LAYER_NOTCH:
                    piece.notches.append(seg)
                elif layer == LAYER_GRAIN:
                    piece.grain.append(seg)
                elif layer == LAYER_INTERNAL:
                    piece.internal.append(seg)
                elif layer == LAYER_BOUNDARY:
                    boundary_parts.append(seg)
            elif kind == "POINT" and layer == LAYER_NOTCH:
                piece.notches.append(np.array([tuple(e.dxf.location)[:2]]))
        size = max((np.ptp(p, axis=0).max() for p in boundary_parts + closed_boundary), default=1.0)
        rings = closed_boundary + chain_rings(boundary_parts, 1e-6 * size + 1e-4)
        if rings:
            piece.boundary = max(rings, key=_ring_area)
        sew_rings = closed_sew + chain_rings(sew_parts, 1e-6 * size + 1e-4)
        if sew_rings:
            piece.sew = max(sew_rings, key=_ring_area)
        if piece.boundary is not None:
            pieces.append(piece)
    return ReadFile(header.get("units", ""), header, pieces)
