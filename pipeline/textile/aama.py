"""ASTM D6673 / AAMA DXF for textile pieces: writer and reader (DESIGN §5, §7).

Written the way Gerber AccuMark and CLO write it (the real files in tests/data/textile):
R12, one block per piece named PIECE_SIZE (block flags 64) holding the cut line (layer
1, closed POLYLINE) and the piece texts `Piece Name:`, `Size:`, `Quantity:`,
`Fabric:`; turn points (layer 2) at the corners and curve points (layer 3) at the other
vertices of the cut and sew lines; notches as POINTs on layer 4 at the cut line (group
30 depth, 39 opening width: 0 for a slit, > 0 for a V notch, 50 the direction into the
piece in degrees); the grain line (LINE, layer 7); internal lines (layer 8) and the sew
line, a closed POLYLINE on layer 8 (an internal line: drawn, not cut) or on the
standard's layer 14. Model space: the style texts (`Style Name:`, `Creation Date:`,
`Creation Time:`, `Author:`, `Product:`, `Version:`, `Sample Size:`, `Units:`) and one
INSERT per piece at the origin on layer 1. Unlike the real files a LAYER table declares
the layers (FreeCAD's importer needs one). Like ezdxf's gerber_D6673 exporter the file has
no $MODEL_SPACE / $PAPER_SPACE blocks and no HEADER variables: AAMA readers take every
block for a piece. The reader serves our files and the real AccuMark / CLO files alike.

Flavours (``textile.aama.flavour``): ``aama-r12`` (the default) is the file above, every
notch on layer 4; ``astm-2010`` adds what ASTM D6673-10 adds: T, castle, check and U notches
on layers 80-83 (``notchtypes``) and the mandatory quality validation curves, a copy of
each layer 1 polyline on layer 84 and of each layer 8 polyline on layer 85 (as AccuMark's
ASTM export and CLO write them); ``r10-compat`` is ``aama-r12`` with a HEADER naming AC1006
and the extents and no TABLES section, as CLO's R10 files.
"""

from __future__ import annotations

import datetime
import io
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path

import ezdxf
import numpy as np
from ezdxf.lldxf.tagwriter import TagWriter

from flatten.metrics import polygon_area

from ..io.atomic import atomic_path
from .notchtypes import KIND_OF_LAYER, notch_layer
from .pieces import TextilePiece, label_anchor

LAYER_BOUNDARY, LAYER_TURN, LAYER_CURVE, LAYER_NOTCH = "1", "2", "3", "4"
LAYER_GRAIN, LAYER_INTERNAL, LAYER_SEW = "7", "8", "14"
# colours only help a person looking at the file in a CAD viewer
LAYER_COLOURS = {LAYER_BOUNDARY: 7, LAYER_TURN: 3, LAYER_CURVE: 4, LAYER_NOTCH: 1, LAYER_GRAIN: 5,
                 LAYER_INTERNAL: 6, LAYER_SEW: 2}
TEXT_HEIGHT_MM = 5.0
FLAVOURS = ("astm-2010", "aama-r12", "r10-compat")
# the $ACADVER a flavour's HEADER names (the others write an empty HEADER, as AccuMark does)
ACADVER = {"r10-compat": "AC1006"}
# ASTM D6673-10's quality validation curves of the boundary (layer 1) and internal lines (8)
LAYER_CHECK_BOUNDARY, LAYER_CHECK_INTERNAL = "84", "85"


def block_name(piece: TextilePiece, size: str) -> str:
    return f"{piece.name}_{size}"


def creation_time() -> datetime.datetime:
    """Now, or SOURCE_DATE_EPOCH when set (reproducible files)."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch and epoch.isdigit():
        return datetime.datetime.fromtimestamp(int(epoch), tz=datetime.timezone.utc)
    return datetime.datetime.now()


def notch_angle(line: np.ndarray) -> float:
    """Direction (degrees, counter-clockwise from +x) of a notch line (2, 2) into the piece."""
    d = line[1] - line[0]
    return float(np.degrees(np.arctan2(d[1], d[0])))


def _new_r12() -> ezdxf.document.Drawing:
    """An empty R12 document. ezdxf.new warns on every R12 document that $INSUNITS is not
    written (AAMA states its units in the `Units:` text instead): not a finding, so that
    one warning is kept off the console."""
    log = logging.getLogger("ezdxf")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        return ezdxf.new("R12")
    finally:
        log.setLevel(level)


def build_document(pieces: list[TextilePiece], style: str, scale: float,
                   flavour: str = "aama-r12") -> ezdxf.document.Drawing:
    """Pieces in model units, written in millimetres (``scale`` = mm per model unit);
    notches on the layers of their type in this flavour."""
    if flavour not in FLAVOURS:
        raise ValueError(f"aama.flavour {flavour!r} is none of {', '.join(FLAVOURS)}")
    doc = _new_r12()
    for layer, colour in LAYER_COLOURS.items():
        doc.layers.add(layer, color=colour)
    # the ASTM notch layers only when a notch uses them: files without typed notches stay as they were
    for layer in sorted({notch_layer(n.kind, flavour) for p in pieces for n in p.notches} - set(LAYER_COLOURS)):
        doc.layers.add(layer, color=LAYER_COLOURS[LAYER_NOTCH])
    astm = flavour == "astm-2010"
    if astm:
        doc.layers.add(LAYER_CHECK_BOUNDARY, color=LAYER_COLOURS[LAYER_BOUNDARY])
        doc.layers.add(LAYER_CHECK_INTERNAL, color=LAYER_COLOURS[LAYER_INTERNAL])
    msp = doc.modelspace()
    now = creation_time()
    sizes = sorted({p.settings.size for p in pieces})
    from importlib.metadata import PackageNotFoundError, version
    try:
        ours = version("devflat")
    except PackageNotFoundError:
        ours = "source"
    header = [f"Style Name: {style}", f"Creation Date: {now.day:2d}-{now.month:d}-{now.year:d}",
              f"Creation Time: {now.hour:2d}:{now.minute:02d}", "Author: devflat", "Product: devflat",
              f"Version: {ours}", f"Sample Size: {sizes[0] if sizes else ''}", "Units: METRIC"]
    for k, text in enumerate(header):
        msp.add_text(text, height=TEXT_HEIGHT_MM, dxfattribs={"layer": LAYER_BOUNDARY}).set_placement(
            (0, -1.5 * TEXT_HEIGHT_MM * (k + 1)))
    for piece in pieces:
        s = piece.settings
        name = block_name(piece, s.size)
        block = doc.blocks.new(name=name)
        block.block.dxf.flags = 64  # as AccuMark and CLO write their piece blocks
        texts = [f"Piece Name: {piece.name}", f"Size: {s.size}", f"Quantity: {s.quantity}", f"Fabric: {s.fabric}"]
        # the texts sit inside the sew line, clear of the grain line and the notches
        box = np.array([0.9 * max(map(len, texts)), 1.5 * len(texts)]) * TEXT_HEIGHT_MM
        at = label_anchor(piece, box[1] / scale, box[0] / scale)
        at = (piece.sew.mean(axis=0) if at is None else at) * scale
        for k, text in enumerate(texts):
            block.add_text(text, height=TEXT_HEIGHT_MM, dxfattribs={"layer": LAYER_BOUNDARY}).set_placement(
                (at[0] - box[0] / 2, at[1] + box[1] / 2 - 1.5 * TEXT_HEIGHT_MM * (k + 1)))
        block.add_polyline2d([tuple(p) for p in piece.cut * scale], close=True,
                             dxfattribs={"layer": LAYER_BOUNDARY})
        if astm:  # our boundary is the curve itself, to the chord tolerance: its own validation curve
            block.add_polyline2d([tuple(p) for p in piece.cut * scale], close=True,
                                 dxfattribs={"layer": LAYER_CHECK_BOUNDARY})
        turns, curves = piece.turn_and_curve_points()
        for layer, points in ((LAYER_TURN, turns), (LAYER_CURVE, curves)):
            for p in points * scale:
                block.add_point((p[0], p[1]), dxfattribs={"layer": layer})
        for notch in piece.notches:
            x, y = notch.line[0] * scale
            depth = float(np.hypot(*np.diff(notch.line, axis=0)[0])) * scale
            block.add_point((x, y, depth), dxfattribs={"layer": notch_layer(notch.kind, flavour),
                                                       "thickness": notch.width * scale,
                                                       "angle": notch_angle(notch.line)})
        block.add_line(tuple(piece.grain[0] * scale), tuple(piece.grain[1] * scale), dxfattribs={"layer": LAYER_GRAIN})
        if s.sew_line_layer is not None:
            block.add_polyline2d([tuple(p) for p in piece.sew * scale], close=True,
                                 dxfattribs={"layer": str(s.sew_line_layer)})
            if astm and str(s.sew_line_layer) == LAYER_INTERNAL:
                block.add_polyline2d([tuple(p) for p in piece.sew * scale], close=True,
                                     dxfattribs={"layer": LAYER_CHECK_INTERNAL})
        for a, b in piece.internal_lines * scale:
            block.add_line(tuple(a), tuple(b), dxfattribs={"layer": LAYER_INTERNAL})
        msp.add_blockref(name, (0, 0), dxfattribs={"layer": LAYER_BOUNDARY})
    return doc


def _extents(doc: ezdxf.document.Drawing) -> tuple[np.ndarray, np.ndarray]:
    """Lower-left and upper-right corners (2,) of every vertex, point and text insertion
    of the file (blocks are inserted at the origin)."""
    points = [(0.0, 0.0)]
    for layout in [doc.modelspace()] + [b for b in doc.blocks if not b.name.startswith("*")]:
        for e in layout:
            kind = e.dxftype()
            if kind == "POLYLINE":
                points += [tuple(v.dxf.location)[:2] for v in e.vertices]
            elif kind in ("POINT",):
                points.append(tuple(e.dxf.location)[:2])
            elif kind == "LINE":
                points += [tuple(e.dxf.start)[:2], tuple(e.dxf.end)[:2]]
            elif kind == "TEXT":
                points.append(tuple(e.dxf.insert)[:2])
    xy = np.array(points, dtype=float)
    return xy.min(axis=0), xy.max(axis=0)


def _write_header(writer: TagWriter, doc: ezdxf.document.Drawing, flavour: str) -> None:
    """An empty HEADER (as AccuMark writes it), but in r10-compat the version and the
    drawing's extents, as CLO's R10 files: readers of that era size their view from them."""
    writer.write_str("  0\nSECTION\n  2\nHEADER\n")
    if flavour in ACADVER:
        low, high = _extents(doc)
        writer.write_tag2(9, "$ACADVER")
        writer.write_tag2(1, ACADVER[flavour])
        writer.write_tag2(9, "$INSBASE")
        for code in (10, 20, 30):
            writer.write_tag2(code, "0.0")
        for name, corner in (("$EXTMIN", low), ("$EXTMAX", high)):
            writer.write_tag2(9, name)
            writer.write_tag2(10, f"{corner[0]:.6f}")
            writer.write_tag2(20, f"{corner[1]:.6f}")
    writer.write_tag2(0, "ENDSEC")


def export_text(doc: ezdxf.document.Drawing, flavour: str = "aama-r12") -> str:
    """The R12 file: HEADER (empty but in r10-compat), TABLES with the line types and
    layers (none in r10-compat, as CLO's R10 files), the piece blocks only (no layout
    blocks), ENTITIES."""
    if doc.dxfversion != ezdxf.const.DXF12:
        raise ezdxf.DXFVersionError("AAMA files are DXF R12")
    if flavour not in FLAVOURS:
        raise ValueError(f"aama.flavour {flavour!r} is none of {', '.join(FLAVOURS)}")
    stream = io.StringIO()
    writer = TagWriter(stream, write_handles=False, dxfversion=ezdxf.const.DXF12)
    _write_header(writer, doc, flavour)
    if flavour != "r10-compat":
        writer.write_str("  0\nSECTION\n  2\nTABLES\n")
        doc.tables.linetypes.export_dxf(writer)
        doc.tables.layers.export_dxf(writer)
        writer.write_tag2(0, "ENDSEC")
    writer.write_str("  0\nSECTION\n  2\nBLOCKS\n")
    for record in doc.block_records:
        if record.is_block_layout:
            record.export_block_definition(writer)
    writer.write_tag2(0, "ENDSEC")
    writer.write_str("  0\nSECTION\n  2\nENTITIES\n")
    doc.modelspace().entity_space.export_dxf(writer)
    writer.write_tag2(0, "ENDSEC")
    writer.write_tag2(0, "EOF")
    return stream.getvalue()


def write_aama(target: str | Path, pieces: list[TextilePiece], style: str, scale: float,
               flavour: str = "aama-r12") -> None:
    text = export_text(build_document(pieces, style, scale, flavour), flavour)
    with atomic_path(target) as tmp:
        # the standard allows 7-bit ASCII only
        Path(tmp).write_bytes(text.encode("ascii", errors="replace"))


# ------------------------------------------------------------------ reader
@dataclass
class ReadNotch:
    """A notch read back: position (2,), direction into the piece (degrees, None when the
    file gives none), depth and opening width (file units; width 0 is a slit)."""

    point: np.ndarray
    angle: float | None = None
    depth: float = 0.0
    width: float = 0.0
    kind: str = "slit"  # by its layer (ASTM 80-83), else v when it opens, else slit


@dataclass
class ReadPiece:
    """A piece read back: texts by lower-case key, rings, points and lines per layer (mm or inch)."""

    block: str
    texts: dict = field(default_factory=dict)
    boundary: np.ndarray | None = None
    sew: np.ndarray | None = None
    notches: list = field(default_factory=list)
    grain: list = field(default_factory=list)
    internal: list = field(default_factory=list)
    turn_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    curve_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    flags: int = 0

    @property
    def name(self) -> str:
        return self.texts.get("piece name", "")


@dataclass
class ReadFile:
    units: str
    header: dict
    pieces: list[ReadPiece]
    layers: tuple[str, ...] = ()
    insert_layers: tuple[str, ...] = ()


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


def _notch(entity) -> ReadNotch:
    if entity.dxftype() == "LINE":  # devflat before AAMA notch points: a slit from the cut line inwards
        a, b = np.array(tuple(entity.dxf.start)[:2]), np.array(tuple(entity.dxf.end)[:2])
        return ReadNotch(a, notch_angle(np.vstack([a, b])), float(np.hypot(*(b - a))), 0.0)
    loc = tuple(entity.dxf.location)
    angle = float(entity.dxf.angle) if entity.dxf.hasattr("angle") else None
    width = float(entity.dxf.get("thickness", 0.0))
    kind = KIND_OF_LAYER.get(entity.dxf.layer, "v" if width > 0 else "slit")
    return ReadNotch(np.array(loc[:2]), angle, abs(float(loc[2])), width, kind)


def read_aama(path: str | Path) -> ReadFile:
    """Pieces of an AAMA / ASTM D6673 file: one per block that holds a boundary. The sew
    line is the ring on layer 14, else a closed polyline on layer 8 (how devflat writes
    it; the real files have no closed internal lines)."""
    doc = ezdxf.readfile(path)
    header = {}
    msp = doc.modelspace()
    for e in msp.query("TEXT"):
        key, _, value = e.dxf.text.partition(":")
        header[key.strip().lower()] = value.strip()
    pieces = []
    for block in doc.blocks:
        if block.name.startswith("*"):
            continue
        piece = ReadPiece(block.name, flags=int(block.block.dxf.get("flags", 0)))
        boundary_parts, sew_parts = [], []
        closed_boundary, closed_sew, closed_internal = [], [], []
        turns, curves = [], []
        for e in block:
            layer = e.dxf.layer
            kind = e.dxftype()
            if kind == "TEXT":
                key, _, value = e.dxf.text.partition(":")
                if layer == LAYER_BOUNDARY:
                    piece.texts[key.strip().lower()] = value.strip()
            elif kind in ("POLYLINE", "LWPOLYLINE"):
                pts, closed = _polyline_points(e)
                if layer == LAYER_BOUNDARY:
                    (closed_boundary if closed else boundary_parts).append(pts)
                elif layer == LAYER_SEW:
                    (closed_sew if closed else sew_parts).append(pts)
                elif layer == LAYER_INTERNAL:
                    (closed_internal if closed else piece.internal).append(pts)
            elif kind == "LINE":
                seg = np.array([tuple(e.dxf.start)[:2], tuple(e.dxf.end)[:2]])
                if layer == LAYER_NOTCH:
                    piece.notches.append(_notch(e))
                elif layer == LAYER_GRAIN:
                    piece.grain.append(seg)
                elif layer == LAYER_INTERNAL:
                    piece.internal.append(seg)
                elif layer == LAYER_BOUNDARY:
                    boundary_parts.append(seg)
            elif kind == "POINT":
                if layer == LAYER_NOTCH or layer in KIND_OF_LAYER:
                    piece.notches.append(_notch(e))
                elif layer == LAYER_TURN:
                    turns.append(tuple(e.dxf.location)[:2])
                elif layer == LAYER_CURVE:
                    curves.append(tuple(e.dxf.location)[:2])
        piece.turn_points = np.array(turns).reshape(-1, 2)
        piece.curve_points = np.array(curves).reshape(-1, 2)
        size = max((np.ptp(p, axis=0).max() for p in boundary_parts + closed_boundary), default=1.0)
        rings = closed_boundary + chain_rings(boundary_parts, 1e-6 * size + 1e-4)
        if rings:
            piece.boundary = max(rings, key=polygon_area)
        sew_rings = closed_sew + chain_rings(sew_parts, 1e-6 * size + 1e-4)
        if not sew_rings:
            sew_rings = closed_internal
        else:
            piece.internal += closed_internal
        if sew_rings:
            piece.sew = max(sew_rings, key=polygon_area)
        if piece.boundary is not None:
            pieces.append(piece)
    return ReadFile(header.get("units", ""), header, pieces, tuple(layer.dxf.name for layer in doc.layers),
                    tuple(e.dxf.layer for e in msp.query("INSERT")))
