"""Steel cutting pattern as DXF (DESIGN §5): R2000, millimetres, $INSUNITS = 4.

Writes a :class:`pipeline.layout.Layout`: one closed LWPOLYLINE on the cut layer (and the
net line on its own layer when an allowance is cut), bending lines and their marks on the
bend layer, frame lines and names on the frame layer, edge names and bevels on the edge
layer, the part data on the text layer, a formed plate's shrink and stretch areas as
closed outlines on their layers, its heating lines on the heat layer; $EXTMIN / $EXTMAX set to the drawing. The one
module that talks to ezdxf for steel.
"""

from __future__ import annotations

import io
from pathlib import Path

import ezdxf
from ezdxf import units
from ezdxf.enums import TextEntityAlignment

from ..io.atomic import atomic_path

# red, blue, green, magenta, cyan, yellow, orange, blue-green
LAYER_COLOURS = {"cut": 1, "bend": 5, "text": 3, "frame": 6, "edge": 4, "net": 2, "shrink": 30, "stretch": 140,
                 "heat": 10}  # heat: red-orange, the heating lines of a formed plate
AREAS = ("shrink", "stretch")  # closed outlines of marked areas (formed plates)


def build_document(layout, layers) -> ezdxf.document.Drawing:
    doc = ezdxf.new("R2000", setup=False)
    doc.units = units.MM
    doc.header["$INSUNITS"] = 4
    doc.header["$MEASUREMENT"] = 1
    for key, colour in LAYER_COLOURS.items():
        doc.layers.add(getattr(layers, key), color=colour)
    msp = doc.modelspace()
    msp.add_lwpolyline([tuple(p) for p in layout.cut], format="xy", close=True, dxfattribs={"layer": layers.cut})
    if layout.net is not None:
        msp.add_lwpolyline([tuple(p) for p in layout.net], format="xy", close=True, dxfattribs={"layer": layers.net})
    for kind, line in layout.lines:
        layer = getattr(layers, kind)
        if kind in AREAS:
            msp.add_lwpolyline([tuple(p) for p in line[:-1]], format="xy", close=True, dxfattribs={"layer": layer})
        elif len(line) == 2:
            msp.add_line(tuple(line[0]), tuple(line[1]), dxfattribs={"layer": layer})
        else:
            msp.add_lwpolyline([tuple(p) for p in line], format="xy", dxfattribs={"layer": layer})
    for text in layout.texts:
        msp.add_text(text.text, height=text.height, rotation=text.angle,
                     dxfattribs={"layer": getattr(layers, text.kind)}).set_placement(
            text.at, align=TextEntityAlignment.MIDDLE_CENTER)
    # ezdxf copies the modelspace layout's extents into $EXTMIN / $EXTMAX when saving
    lo, hi = layout.extents()
    msp.dxf.extmin = (float(lo[0]), float(lo[1]), 0.0)
    msp.dxf.extmax = (float(hi[0]), float(hi[1]), 0.0)
    msp.dxf.limmin = (float(lo[0]), float(lo[1]))
    msp.dxf.limmax = (float(hi[0]), float(hi[1]))
    doc.header["$EXTMIN"] = msp.dxf.extmin
    doc.header["$EXTMAX"] = msp.dxf.extmax
    return doc


def write_steel_dxf(target: str | Path, layout, layers) -> int:
    """Write the pattern; returns the number of audit errors (0 expected)."""
    doc = build_document(layout, layers)
    auditor = doc.audit()
    # what Drawing.saveas writes, encoded once rather than tag by tag (a tenth of the write)
    text = io.StringIO()
    doc.write(text)
    with atomic_path(target) as tmp:
        tmp.write_bytes(doc.encode(text.getvalue()))
    return len(auditor.errors)
