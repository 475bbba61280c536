"""Notch types of a cutting room: where ASTM D6673 files them and what a cutter cuts.

ASTM D6673-10 gives each notch type a layer: V and slit notches on layer 4 (the one
notch layer of AAMA, where every reader looks), T on 80, castle on 81, check on 82 and
U on 83. Each notch is a POINT on the cut line with its depth (group 30), opening width
(group 39, 0 for a slit) and direction into the piece (group 50, degrees). Readers of the
older flavours know layer 4 only: there every type is written on layer 4.

``notch_strokes`` gives the pen strokes of a notch (what a plotter draws or a cutter's
notch tool cuts), in the notch's own frame turned into the piece: the x axis points into
the piece, the cut line runs along y.
"""

from __future__ import annotations

import numpy as np

KINDS = ("slit", "v", "t", "castle", "check", "u")
# ASTM D6673-10's notch layers
ASTM_LAYERS = {"slit": "4", "v": "4", "t": "80", "castle": "81", "check": "82", "u": "83"}
KIND_OF_LAYER = {"80": "t", "81": "castle", "82": "check", "83": "u"}
# segments a U notch's half circle is drawn with (0.03 % of its radius off the arc)
ARC_SEGMENTS = 16


def notch_layer(kind: str, flavour: str) -> str:
    """The DXF layer of a notch of this kind in a file of this flavour: the ASTM layers in
    astm-2010, layer 4 for every kind in the flavours that predate them."""
    if kind not in ASTM_LAYERS:
        raise ValueError(f"notch type {kind!r} is none of {', '.join(KINDS)}")
    return ASTM_LAYERS[kind] if flavour == "astm-2010" else "4"


def opening(kind: str, width: float) -> float:
    """The opening width a notch of this kind carries (a slit has none)."""
    return 0.0 if kind == "slit" else float(width)


def local_strokes(kind: str, depth: float, width: float) -> list[np.ndarray]:
    """Polylines (each (K, 2)) of a notch in its frame: x into the piece from the cut
    line's point at the origin, y along the cut line; depth and width in any one unit."""
    d, h = float(depth), 0.5 * float(width)
    if kind == "slit":
        return [np.array([[0.0, 0.0], [d, 0.0]])]
    if kind == "v":
        return [np.array([[0.0, -h], [d, 0.0], [0.0, h]])]
    if kind == "t":  # a slit with a cross cut at its end
        return [np.array([[0.0, 0.0], [d, 0.0]]), np.array([[d, -h], [d, h]])]
    if kind == "castle":  # a rectangular bay
        return [np.array([[0.0, -h], [d, -h], [d, h], [0.0, h]])]
    if kind == "check":  # one side square to the cut line, the other slanted back to it
        return [np.array([[0.0, -h], [d, -h], [0.0, h]])]
    if kind == "u":  # straight sides ending in a half circle of the width's diameter
        straight = max(d - h, 0.0)
        radius_x = min(h, d)
        a = np.linspace(-0.5 * np.pi, 0.5 * np.pi, ARC_SEGMENTS + 1)
        arc = np.column_stack([straight + radius_x * np.cos(a), h * np.sin(a)])
        return [np.vstack([[0.0, -h], arc, [0.0, h]])]
    raise ValueError(f"notch type {kind!r} is none of {', '.join(KINDS)}")


def notch_strokes(kind: str, point: np.ndarray, angle_deg: float, depth: float, width: float) -> list[np.ndarray]:
    """Polylines (each (K, 2), the point's units) of a notch at ``point`` (2,) on the cut
    line, pointing into the piece at ``angle_deg`` (counter-clockwise from +x)."""
    a = np.radians(angle_deg)
    into = np.array([np.cos(a), np.sin(a)])
    along = np.array([-into[1], into[0]])
    frame = np.vstack([into, along])  # rows: where the local x and y go
    return [np.asarray(point, dtype=float) + stroke @ frame for stroke in local_strokes(kind, depth, width)]
