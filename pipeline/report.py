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


def quantity_units(units: str) -> dict:
    """What unit each kind of quantity in the report is in."""
    return {"geometry": f"{units} (areas {units}^2): resolution, curve_fits, mesh, unroll, hull_fit, trim, region, "
                        "developability lengths",
            "parameters": "none: rulings are [t, T] curve parameters",
            "shop": "mm: outline (with allowance), bending, layout, stock, sides",
            "suffixed": "_m2 m^2, _mm mm, _kg kg, _kg_m3 kg/m^3, _mm_per_m mm per metre",
            "ratios": "none: *_relative, area_ratio, coverage fractions, strains (mm/mm)"}


def part_report(result: PartResult, units: str) -> dict:
    report = {
        "schema_version": SCHEMA_VERSION,
        "name": result.name,
        "status": result.status,
        "reason": result.reason,
        "warnings": list(result.warnings),
        "units": units,
        "quantity_units": quantity_units(units),
        "solver": _solver_section(result),
        "coverage": result.figures.get("coverage"),
        "rulings": None if result.strip is None else result.strip.rulings.tolist(),
        "curve_fits": {name: vars(fit) for name, fit in result.part.fits.items()
                       if name.startswith(("curves", "sequence", "parts"))} or None,
        "resolution": result.figures.get("rulings"),
        "mesh": result.figures.get("mesh"),
        "developability": result.figures.get("developability"),
        "unroll": result.figures.get("unroll"),
        "area_m2": result.figures.get("area_m2"),
        "steel": result.figures.get("steel"),
        "outline": result.figures.get("outline"),
        "bending": result.figures.get("bending"),
        "layout": result.figures.get("layout"),
        "stock": result.figures.get("stock"),
        "sides": result.figures.get("sides"),
        "hull_fit": result.figures.get("hull_fit"),
        "plate_coverage": result.figures.get("plate_coverage"),
        "trim": result.figures.get("trim"),
        "plate_class": result.figures.get("plate_class"),
        "region": result.figures.get("region"),
        "completeness": result.figures.get("completeness"),
        "strain": result.figures.get("strain"),
        "forming": result.figures.get("forming"),
        "textile": result.figures.get("textile"),
        "files": result.figures.get("files"),
        "traceback": result.figures.get("traceback"),  # an internal error's, for the bug report
    }
    if result.figures.get("templates") is not None:  # steel plates with a formed shape to check
        report["templates"] = result.figures["templates"]
    if result.figures.get("pinjig") is not None:
        report["pinjig"] = result.figures["pinjig"]
    hull = result.part.hull
    if hull is not None and hull.plan is not None:  # the adaptive plan's depth, class and why it stopped splitting
        report["plan"] = dict(hull.plan)
    if result.figures.get("edge_fit") is not None:  # developed on the hull for its edges' fit-up
        report["edge_fit"] = result.figures["edge_fit"]
    if result.figures.get("follow") is not None:  # formed to meet its flat and strip neighbours' edges
        report["follow"] = result.figures["follow"]
    if result.figures.get("rigid_move") is not None:  # a strip moved to meet its neighbours' edges
        report["rigid_move"] = result.figures["rigid_move"]
    if result.figures.get("erection_pull") is not None:  # pulled at erection to meet its neighbours' edges
        report["erection_pull"] = result.figures["erection_pull"]
    if result.figures.get("heating") is not None:  # formed steel plates (pipeline.shop.heating)
        report["heating"] = result.figures["heating"]
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


def summary_rows(results: list[PartResult]) -> list[dict]:
    """One flat record per part for the run summary (CSV and JSON)."""
    rows = []
    for r in results:
        cov = r.figures.get("plate_coverage") or {}
        if not cov and r.figures.get("coverage"):
            cov = {"c": r.figures["coverage"]["c_fraction"], "d": r.figures["coverage"]["d_fraction"]}
        unroll = r.figures.get("unroll") or {}
        steel = r.figures.get("steel") or {}
        fit = r.figures.get("hull_fit") or {}
        klass = r.figures.get("plate_class") or {}
        rows.append({
            "id": r.name, "status": r.status, "class": klass.get("class"),
            "region_area_m2": (r.figures.get("region") or {}).get("area_m2"),
            "max_strain": klass.get("max_strain"),
            "area_m2": r.figures.get("area_m2"), "weight_kg": steel.get("weight_kg"),
            "max_hull_deviation": fit.get("max_distance"), "rms_hull_deviation": fit.get("rms_distance"),
            "distortion_mm_per_m": (max(abs(unroll["boundary_error_c_mm_per_m"]), abs(unroll["boundary_error_d_mm_per_m"]))
                                    if unroll else None),
            "coverage_c": cov.get("c"), "coverage_d": cov.get("d"),
            "rulings": (r.figures.get("rulings") or {}).get("count"),
            "reason": r.reason, "warnings": "; ".join(r.warnings)})
    return rows


def summary_table(results: list[PartResult]) -> str:
    rows = summary_rows(results)
    width = max([22] + [len(row["id"]) + 1 for row in rows])  # the names, at least one space after each
    header = (f"{'part':<{width}}{'status':<8}{'cover c/d %':>14}{'rulings':>9}{'area m2':>10}{'dist mm/m':>11}"
              f"{'hull dev':>10}  reason (failed) / warnings (ok)")
    lines = [header, "-" * len(header)]
    for row in rows:
        cover = (f"{100 * row['coverage_c']:.1f}/{100 * row['coverage_d']:.1f}"
                 if row["coverage_c"] is not None else "-")
        area = f"{row['area_m2']:.4f}" if row["area_m2"] is not None else "-"
        dist = f"{row['distortion_mm_per_m']:.3f}" if row["distortion_mm_per_m"] is not None else "-"
        dev = f"{row['max_hull_deviation']:.2f}" if row["max_hull_deviation"] is not None else "-"
        reason = row["reason"] if row["status"] != "ok" else row["warnings"]
        lines.append(f"{row['id']:<{width}}{row['status']:<8}{cover:>14}{row['rulings'] or '-'!s:>9}{area:>10}{dist:>11}"
                     f"{dev:>10}  {reason}")
    return "\n".join(lines)


def summary_csv(results: list[PartResult]) -> str:
    import csv
    import io

    rows = summary_rows(results)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(rows[0].keys()) if rows else ["id"], lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buffer.getvalue()


def class_shares(results: list[PartResult]) -> dict | None:
    """Shell area per plate class (delivered plates; 'failed' for the rest), in m^2 and as
    shares of the whole: each plate's region on the hull times its share inside the
    surface's IGES trim (what the bench and the class picture count); None when no part is
    a hull plate."""
    areas = {"flat": 0.0, "developable": 0.0, "formed": 0.0, "failed": 0.0}
    seen = False
    for r in results:
        region = r.figures.get("region") or {}
        if not region:
            continue
        seen = True
        klass = (r.figures.get("plate_class") or {}).get("class") if r.ok else "failed"
        inside = float(getattr(getattr(r.part, "hull", None), "inside_trim", 1.0))
        areas[klass if klass in areas else "failed"] += float(region.get("area_m2") or 0.0) * inside
    if not seen:
        return None
    total = sum(areas.values()) or 1.0
    return {"area_m2": areas, "share": {k: v / total for k, v in areas.items()}}


def summary_json(results: list[PartResult], extra: dict | None = None) -> str:
    """The run summary; ``extra``: further top-level keys (a hull plan's ``plan_cost``, the hull models, the shell's fit-up)."""
    return json.dumps(sanitize({"schema_version": SCHEMA_VERSION, "parts": summary_rows(results),
                                "failed": [r.name for r in results if not r.ok],
                                "classes": class_shares(results), **(extra or {})}), indent=1)
