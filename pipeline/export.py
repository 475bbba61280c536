"""Write one part's files: NAME.dxf, NAME.obj, NAME.json and the PNG previews.

A part that failed writes its report (and its solution diagram) but no DXF or OBJ.
"""

from __future__ import annotations

from pathlib import Path

from .atomic import write_text
from .config import RunConfig
from .dxf_steel import write_steel_dxf
from .meshio import write_obj
from .plots import flat_pattern_png, solution_diagram_png
from .report import report_json
from .stages import PartResult


def steel_texts(result: PartResult) -> list[str]:
    steel = result.figures["steel"]
    return [f"PART {result.name}",
            f"THK {steel['thickness_mm']:g} MM",
            f"MAT {steel['material']}",
            f"AREA {steel['area_m2']:.3f} M2",
            f"WEIGHT {steel['weight_kg']:.1f} KG",
            f"MARKED SIDE {steel['marked_side'].upper()}"]


def export_part(result: PartResult, config: RunConfig, out_dir: Path) -> list[Path]:
    """Write the part's files; returns the paths written."""
    out = config.spec.output
    written = []
    name = result.name
    if result.ok:
        scale = config.mm_per_unit
        pattern = result.pattern
        if out.dxf:
            path = out_dir / f"{name}.dxf"
            errors = write_steel_dxf(path, pattern.outline * scale, pattern.bend_lines * scale,
                                     steel_texts(result), out.layers)
            result.figures["dxf_audit_errors"] = errors
            written.append(path)
        if out.obj:
            path = out_dir / f"{name}.obj"
            write_obj(path, result.strip.vertices, pattern.vertices, result.strip.faces, name)
            written.append(path)
        if out.png:
            path = out_dir / f"{name}_flat.png"
            flat_pattern_png(path, pattern.outline, pattern.bend_lines,
                             f"{name}: flat pattern ({len(pattern.bend_lines)} bending lines)", config.spec.units)
            written.append(path)
    if out.png and result.solution is not None and result.solution.kind != "coplanar":
        path = out_dir / f"{name}_solutions.png"
        solution_diagram_png(path, result.solution, result.part.c.domain, result.part.d.domain,
                             f"{name}: {result.solution.message}")
        written.append(path)
    path = out_dir / f"{name}.json"
    result.figures["files"] = [p.name for p in written] + [path.name]
    write_text(path, report_json(result, config.spec.units))
    written.append(path)
    return written

