"""Steel cutting pattern as DXF (DESIGN §5): R2000, millimetres, $INSUNITS = 4.

One closed LWPOLYLINE on the cut layer, every ruling as a LINE on the bending layer,
part data as TEXT on the text layer. The one module that talks to ezdxf for steel.
"""

from __future__ import annotations

from pathlib import Path

import ezdxf
import numpy as np
from ezdxf import units

from .atomic import atomic_path

LAYER_COLOURS = {"cut": 1, "bend": 5, "text": 3, "frame": 6}  # red, blue, green, magenta


def polygon_centroid(points: np.ndarray) -> np.ndarray:
    x, y = points[:, 0], points[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2.0
    if abs(area) < 1e-300:
        return points.mean(axis=0)
    return np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6.0 * area)


def build_document(outline_mm: np.ndarray, bend_lines_mm: np.ndarray, texts: list[str], layers,
                   frame_lines_mm=(), labels_mm=()) -> ezdxf.document.Drawing:
    doc = ezdxf.new("R2000", setup=False)
    doc.units = units.MM
    doc.header["$INSUNITS"] = 4
    doc.header["$MEASUREMENT"] = 1
    for key, colour in LAYER_COLOURS.items():
        doc.layers.add(getattr(layers, key), color=colour)
    msp = doc.modelspace()
    msp.add_lwpolyline([tuple(p) for p in outline_mm], format="xy", close=True,
                       dxfattribs={"layer": layers.cut})
    for a, b in bend_lines_mm:
        msp.add_line(tuple(a), tuple(b), dxfattribs={"layer": layers.bend})
    size = float(np.ptp(outline_mm, axis=0).max())
    height = max(min(0.02 * size, 50.0), 2.5)
    for x, line in frame_lines_mm:
        msp.add_lwpolyline([tuple(p) for p in line], format="xy", dxfattribs={"layer": layers.frame})
        msp.add_text(f"FR x={x:g}", height=0.6 * height, dxfattribs={"layer": layers.text}).set_placement(
            tuple(line[len(line) // 2]))
    for text, position, angle in labels_mm:
        msp.add_text(text, height=0.8 * height, rotation=angle, dxfattribs={"layer": layers.text}).set_placement(
            tuple(position))
    anchor = polygon_centroid(outline_mm)
    for k, text in enumerate(texts):
        msp.add_text(text, height=height, dxfattribs={"layer": layers.text}).set_placement(
            (anchor[0], anchor[1] - 1.5 * k * height))
    return doc


def write_steel_dxf(target: str | Path, outline_mm: np.ndarray, bend_lines_mm: np.ndarray,
                    texts: list[str], layers, frame_lines_mm=(), labels_mm=()) -> int:
    """Write the pattern; returns the number of audit errors (0 expected)."""
    doc = build_document(outline_mm, bend_lines_mm, texts, layers, frame_lines_mm, labels_mm)
    auditor = doc.audit()
    with atomic_path(target) as tmp:
        doc.saveas(tmp)
    return len(auditor.errors)
