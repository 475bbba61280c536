"""The part report (JSON, with a schema version) and the run summary table."""

from __future__ import annotations

import json

import numpy as np

from .stages import PartResult

SCHEMA_VERSION = "1.0"


def _solver_section(result: PartResult) -> dict:
    s = result.solution
    if s is None:
        return {}
    return {
        "success": bool(s.success),
        "message": s.message,
        "kind": s.kind,
        "degree_in_T": s.degree_in_T,
        "max_branch_residual": s.max_residual,
        "findings": [{"code": f.code, "message": f.message} for f in s.findings],
        "branches": [{"index": b.index, "kind": b.kind, "ends": list(b.ends), "points": len(b.points),
                      "t_range": [float(b.points[:, 0].min()), float(b.points[:, 0].max())],
                      "T_range": [float(b.points[:, 1].min()), float(b.points[:, 1].max())]}
                     for b in s.branches],
        "turning_points": [{"t": tp.t, "T": tp.T, "kind": tp.kind, "point_c": tp.point_c.tolist(),
                            "point_d": tp.point_d.tolist()} for tp in s.turning_points],
        "curvature_mismatches": [{"t_range": list(m.t_range), "T_range": list(m.T_range),
                                  "points_c": m.points_c.tolist(), "points_d": m.points_d.tolist(),
                                  "worst": list(m.worst)} for m in s.mismatches],
        "path": None if s.path is None else {"orientation": s.path.orientation, "fans": list(s.path.fans),
                                             "coverage": s.path.coverage.as_dict()},
    }


def part_report(result: PartResult, units: str) -> dict:
    report = {
        "schema_version": SCHEMA_VERSION,
        "name": result.name,
        "status": result.status,
        "reason": result.reason,
        "warnings": list(result.warnings),
        "units": units,
        "solver": _solver_section(result),
        "coverage": result.figures.get("coverage"),
        "rulings": None if result.strip is None else result.strip.rulings.tolist(),
        "resolution": result.figures.get("rulings"),
        "mesh": result.figures.get("mesh"),
        "developability": result.figures.get("developability"),
        "unroll": result.figures.get("unroll"),
        "area_m2": result.figures.get("area_m2"),
        "steel": result.figures.get("steel"),
        "textile": result.figures.get("textile"),
        "files": result.figures.get("files"),
    }
    return report


def sanitize(value):
    """Replace non-finite floats by None so the report stays strict JSON."""
    if isinstance(value, dict):
        return {k: sanitize(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [sanitize(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    return value


def report_json(result: PartResult, units: str) -> str:
    def default(obj):
        if isinstance(obj, np.generic):
            return obj.item()
        if isinstance(obj, np.ndarray):
            return obj.tolist()
        raise TypeError(type(obj).__name__)

    return json.dumps(sanitize(part_report(result, units)), indent=1, default=default, allow_nan=False)


def summary_table(results: list[PartResult]) -> str:
    header = f"{'part':<22}{'status':<8}{'cover c/d %':>14}{'rulings':>9}{'area m2':>10}{'dist mm/m':>11}  reason"
    rows = [header, "-" * len(header)]
    for r in results:
        cov = r.figures.get("coverage") or {}
        cover = f"{100 * cov['c_fraction']:.1f}/{100 * cov['d_fraction']:.1f}" if cov else "-"
        rulings = (r.figures.get("rulings") or {}).get("count", "-")
        area = f"{r.figures['area_m2']:.4f}" if "area_m2" in r.figures else "-"
        unroll = r.figures.get("unroll") or {}
        dist = (f"{max(abs(unroll['boundary_error_c_mm_per_m']), abs(unroll['boundary_error_d_mm_per_m'])):.3f}"
                if unroll else "-")
        reason = r.reason if not r.ok else "; ".join(r.warnings)
        rows.append(f"{r.name:<22}{r.status:<8}{cover:>14}{rulings!s:>9}{area:>10}{dist:>11}  {reason}")
    return "\n".join(rows)
