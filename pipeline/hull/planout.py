"""The plan of a shell expansion as a DXF: every plate's outline on the hull as a closed 3D
polyline (seams and butts as laid), one layer per class (PLAN_FLAT, PLAN_DEVELOPABLE,
PLAN_FORMED, PLAN_FAILED), with the plate's name as a text at its centre. Millimetres.
Long outlines are thinned to about 400 points (a layout, not a cut file)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path
from .hullplots import plate_ring

LAYER_COLOURS = {"flat": 5, "developable": 3, "formed": 30, "failed": 1}


def write_plan_dxf(target: str | Path, results, mm_per_unit: float) -> None:
    import ezdxf

    doc = ezdxf.new("R2000")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    for klass in LAYER_COLOURS:  # the classes of the plates' reports (a patch development is "developable")
        doc.layers.add(f"PLAN_{klass.upper()}", color=LAYER_COLOURS[klass])
    for r in results:
        ring = plate_ring(r)
        if ring is None:
            continue
        klass = (r.figures.get("plate_class") or {}).get("class", "failed") if r.ok else "failed"
        layer = f"PLAN_{klass.upper()}"
        if len(ring) > 400:  # a layout drawing, not a cut file: about 400 points a plate
            ring = ring[np.unique(np.r_[np.linspace(0, len(ring) - 1, 400).round().astype(int)])]
        pts = [tuple(float(c) * mm_per_unit for c in p) for p in ring]
        msp.add_polyline3d(pts, close=True, dxfattribs={"layer": layer})
        centre = ring.mean(axis=0) * mm_per_unit
        msp.add_text(r.name, dxfattribs={"layer": layer, "height": 150.0, "insert": tuple(float(c) for c in centre)})
    with atomic_path(target) as tmp:
        doc.saveas(tmp)
