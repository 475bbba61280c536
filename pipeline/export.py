"""Write one part's files: NAME.dxf, NAME.obj, NAME.json and the PNG previews.

A part that failed writes its report (and its solution diagram) but no DXF or OBJ.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np

from .io.atomic import write_text
from .config import RunConfig
from .io.meshio import write_obj
from .renderproc import render
from .renderproc import wait as wait_for_images
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


def _previews(result: PartResult, config: RunConfig, out_dir: Path) -> list[tuple[Path, str, tuple]]:
    """The part's PNG previews drawn by :mod:`pipeline.plots` (matplotlib: imported only by
    the process that draws them): [(path, "module:function", its other arguments)]."""
    name = result.name
    if not config.part_previews:
        return []
    previews = []
    if result.ok and result.figures.get("textile_piece") is None:
        pattern = result.pattern
        previews.append((out_dir / f"{name}_flat.png", "pipeline.plots:flat_pattern_png",
                         (pattern.outline, pattern.bend_lines,
                          f"{name}: flat pattern ({len(pattern.bend_lines)} bending lines)", config.spec.units)))
    if result.solution is not None and result.solution.kind != "coplanar":
        # without its field (the curves' splines): the drawing needs none of it, and the
        # render process then unpickles it without importing scipy
        previews.append((out_dir / f"{name}_solutions.png", "pipeline.plots:solution_diagram_png",
                         (dataclasses.replace(result.solution, field=None), result.part.c.domain,
                          result.part.d.domain, f"{name}: {result.solution.message}")))
    return previews


def export_part(result: PartResult, config: RunConfig, out_dir: Path) -> list[Path]:
    """Write the part's files; returns the paths written."""
    out = config.spec.output
    written = []
    name = result.name
    # the previews are sent first: a render process (pipeline.renderproc) draws them while
    # this one lays out and writes the DXF; the list of files keeps its order
    previews = _previews(result, config, out_dir)
    for path, target, args in previews:
        render(target, path, *args)
    if result.ok:
        pattern = result.pattern
        if out.dxf and config.spec.profile == "steel":
            from .shop.dxf import write_steel_dxf  # ezdxf: imported only when a steel DXF is written

            from .shop.plate import shop_drawing, shop_layout

            drawing = out.png if out.drawing is None else out.drawing  # the PDF follows the previews

            texts = steel_texts(result)
            if config.spec.shop.mirror:  # both sides: the modelled plate and its reflection, P/S in the id
                from .shop.plate import mirrored

                v3 = result.strip.vertices if result.strip is not None else result.mesh[0]
                model = "P" if float(np.mean(v3[:, 1])) >= 0.0 else "S"
                other = "S" if model == "P" else "P"
                # the ids have the same length on both sides: one layout fits both
                layout = shop_layout(result, config, [f"PART {name}_{model}"] + texts[1:])
                errors = 0
                flipped = mirrored(layout, model)
                flipped.texts = [dataclasses.replace(t, text=t.text.replace(f"PART {name}_{model}", f"PART {name}_{other}"))
                                 for t in flipped.texts]
                for side, plate in ((model, layout), (other, flipped)):
                    path = out_dir / f"{name}_{side}.dxf"
                    errors += write_steel_dxf(path, plate, out.layers)
                    written.append(path)
                    if drawing:
                        written.append(shop_drawing(result, config, plate, out_dir / f"{name}_{side}_drawing.pdf"))
                result.figures["sides"] = {"modelled": model, "mirrored": other,
                                           "rule": "P where the plate's mean y >= 0 (y to port)"}
            else:
                path = out_dir / f"{name}.dxf"
                layout = shop_layout(result, config, texts)
                # the drawing before the DXF: a render process draws it while this one writes
                pdf = shop_drawing(result, config, layout, out_dir / f"{name}_drawing.pdf") if drawing else None
                errors = write_steel_dxf(path, layout, out.layers)
                written += [path] if pdf is None else [path, pdf]
            result.figures["dxf_audit_errors"] = errors
            if result.templates:  # the templates at 1:1 (pipeline.shop.templates)
                from .shop.templates import write_templates_dxf

                path = out_dir / f"{name}_templates.dxf"
                result.figures["templates"]["dxf_audit_errors"] = write_templates_dxf(path, name, list(result.templates))
                written.append(path)
            if result.pinjig is not None:  # the pin jig's table (pipeline.shop.pinjig)
                path = out_dir / f"{name}_pinjig.csv"
                write_text(path, result.pinjig.csv())
                written.append(path)
        if out.obj:
            path = out_dir / f"{name}.obj"
            v3, faces = (result.strip.vertices, result.strip.faces) if result.strip is not None else result.mesh
            write_obj(path, v3, pattern.vertices, faces, name)
            written.append(path)
        if config.part_previews and result.figures.get("textile_piece") is not None:
            from .textile.preview import textile_preview_png

            path = out_dir / f"{name}_flat.png"
            textile_preview_png(path, result.figures["textile_piece"], config.spec.units)
            written.append(path)
    written += [path for path, _, _ in previews]
    wait_for_images()  # the part's images (and their errors) before its report
    path = out_dir / f"{name}.json"
    result.figures["files"] = [p.name for p in written] + [path.name]
    write_text(path, report_json(result, config.spec.units))
    written.append(path)
    return written


def textile_pieces(results: list[PartResult], config: RunConfig) -> list:
    """Build every successful part's textile piece, side by side; raises ConfigError for
    textile options that do not fit a piece (before anything is written)."""
    from .textile.seams import match_seams
    from .textile.pieces import build_piece

    seams = match_seams(results, config)  # trims (seams: match) or fails (require_full) pieces
    settings = config.spec.textile
    if settings.match_marks is not None:
        from .textile.seams import with_match_marks

        settings = with_match_marks(settings, seams)
    for result in results:
        if not result.ok and result.figures.get("seams"):
            result.figures["textile"] = {"seams": result.figures["seams"]}
    pieces = []
    cursor = 0.0
    gap = 50.0 / config.mm_per_unit
    for result in results:
        if not result.ok:
            continue
        piece = build_piece(result, settings, result.pattern.placement)
        shift = np.array([cursor - piece.cut[:, 0].min(), -piece.cut[:, 1].min()])
        piece = piece.translated(shift)
        cursor = piece.cut[:, 0].max() + gap
        result.figures["textile"] = {
            "allowances": dict(zip(piece.edge_names, piece.allowances)),
            "sew_line_length": float(np.linalg.norm(np.diff(np.vstack([piece.sew, piece.sew[:1]]), axis=0),
                                                    axis=1).sum()),
            "cut_line_length": float(np.linalg.norm(np.diff(np.vstack([piece.cut, piece.cut[:1]]), axis=0),
                                                    axis=1).sum()),
            "notches": [{"edge": n.edge, "arc_length": n.arc_length, "sew_point": n.sew_point.tolist()}
                        for n in piece.notches],
            "grain": piece.grain.tolist(),
            "edges": {"c": (result.pattern.bend_lines[:, 0] + shift).tolist(),
                      "d": (result.pattern.bend_lines[:, 1] + shift).tolist()},
            "offset_in_sheet": shift.tolist(),
            "seams": result.figures.get("seams", []),
        }
        result.figures["textile_piece"] = piece  # for the preview; not part of the report
        flavour = settings.aama.flavour
        typed = sorted({n.kind for n in piece.notches} - {"v", "slit"})
        if typed and flavour != "astm-2010":
            result.warnings.append(f"notch type(s) {', '.join(typed)} written on layer 4 with their depth and width: "
                                   f"aama.flavour {flavour} has no notch type layers (80-83), so their shape is lost")
        pieces.append(piece)
    options = config.spec.textile.printout_options()
    if pieces and options is not None:
        from .config import ConfigError
        from .textile.printout import MAX_PAGES, count_pages

        pages = count_pages(pieces, config.mm_per_unit, options)
        if pages > MAX_PAGES:
            raise ConfigError(f"{config.source}: textile.printout: the pieces need up to {pages} pages of "
                              f"{options.paper} {options.orientation} (more than {MAX_PAGES}); choose a larger "
                              f"paper or printout: false")
        if options.roll_width is not None:  # a piece wider than the roll: bad input, before any file
            from .textile.roll import roll_layout

            roll_layout(pieces, config.mm_per_unit, options.roll_width, f"{config.source}: textile.printout")
    return pieces


def export_textile(pieces: list, config: RunConfig, out_dir: Path, style: str,
                   figures: dict | None = None) -> list[Path]:
    """All pieces into one AAMA DXF, and the 1:1 printout; ``figures`` (when given) gets
    the printouts' page counts and roll length."""
    figures = {} if figures is None else figures
    from .textile.aama import write_aama
    from .textile.printout import write_sheet_svg, write_tiled_pdf

    written = []
    if not pieces:
        return written
    if config.spec.output.dxf:
        path = out_dir / f"{style}.dxf"
        write_aama(path, pieces, style, config.mm_per_unit, config.spec.textile.aama.flavour)
        written.append(path)
    plotter = config.spec.textile.plotter_options()
    if plotter is not None:
        from .textile.hpgl import write_hpgl

        path = out_dir / f"{style}.plt"
        write_hpgl(path, pieces, config.mm_per_unit, plotter)
        written.append(path)
    options = config.spec.textile.printout_options()
    if options is not None:
        title = f"{style}: {len(pieces)} piece(s), 1:1, units mm"
        targets = [out_dir / f"{style}_print.pdf", out_dir / f"{style}_print.svg"]
        figures["print"] = write_tiled_pdf(targets[0], pieces, config.mm_per_unit, title, options)
        write_sheet_svg(targets[1], pieces, config.mm_per_unit, title)
        written += targets
        if options.roll_width is not None:
            from .textile.roll import write_roll_pdf

            path = out_dir / f"{style}_roll.pdf"
            figures["roll"] = write_roll_pdf(path, pieces, config.mm_per_unit, title, options.roll_width)
            written.append(path)
    return written


def model_sources(config: RunConfig) -> list:
    """The strake's hull surfaces given as faces of a model file (IGES, STEP, .3dm)."""
    strake = config.spec.strake
    if strake is None:
        return []
    surfaces = [strake.surface] + (list(strake.plan.surfaces) if strake.plan is not None else [])
    return [s for s in surfaces if getattr(s, "model", None) is not None]


def printout_line(figures: dict, style: str) -> str | None:
    """The console's line on the printouts: pages to print, metres of roll."""
    parts = []
    if "print" in figures:
        f = figures["print"]
        parts.append(f"{style}_print.pdf {f['pages']} pages {f['paper']} {f['orientation']} (map + {f['pages'] - 1} tiles)")
    if "roll" in figures:
        f = figures["roll"]
        parts.append(f"{style}_roll.pdf {f['length_mm'] / 1000:.2f} m of a {f['roll_width_mm']:g} mm roll "
                     f"({f['pages']} page(s))")
    return "printouts: " + "; ".join(parts) if parts else None


def summary_edges(results: list[PartResult]) -> dict:
    """Every hull plate's region sampled on the hull, by name ({} for a run without hull
    plates): what the plan's cost and the shell expansion drawing both read."""
    if not any(r.part.hull is not None for r in results):
        return {}
    from .hull.expansion import shell_edges

    return shell_edges(results)


def summary_drawings(results: list[PartResult], config: RunConfig, out_dir: Path, edges: dict) -> list[Path]:
    """The run's drawings beside its summary: for a hull the shell expansion (DXF, PDF) and
    the plan DXF, and the sheet of all patterns and the hull PNGs when the run writes
    images (:func:`summary_drawing_jobs`, one after the other). Needs nothing of the fit-up."""
    return [path for job in summary_drawing_jobs(results, config, out_dir, edges) for path in job()]


def summary_drawing_jobs(results: list[PartResult], config: RunConfig, out_dir: Path, edges: dict) -> list:
    """:func:`summary_drawings` as independent jobs, each ``job() -> [paths]`` (in the order
    of the paths): the shell expansion, the plan DXF and the images, which
    :func:`pipeline.forked.beside_all` draws in forked copies (one per free core) while the
    run computes the fit-up, the run drawing those no copy has started once it is done (on
    the 160 m hull 2.3, 1.5 and 1.2 s)."""
    style = config.spec.name or config.source.stem
    jobs = []
    if edges:  # the shell expansion drawing: every plate in girth x length
        jobs.append(functools.partial(_expansion, results, edges, config, out_dir, style))
    classed = [r for r in results if r.part.hull is not None and (r.figures.get("plate_class") or {}).get("class")]
    planned = config.spec.strake is not None and config.spec.strake.plan is not None
    if classed and planned and config.spec.output.dxf:  # the plan: every plate's outline on the hull, by class
        jobs.append(functools.partial(_plan_dxf, out_dir / f"{style}_plan.dxf", classed, config.mm_per_unit))
    if config.spec.output.png and len(results) > 1:  # matplotlib only when there are images
        jobs.append(functools.partial(_images, results, classed, config, out_dir, style))
    return jobs


def _expansion(results, edges: dict, config: RunConfig, out_dir: Path, style: str) -> list[Path]:
    from .hull.expansion import write_expansion

    out = config.spec.output
    return write_expansion(results, edges, config, out_dir, style, out.dxf, out.png)


def _plan_dxf(path: Path, classed: list, mm_per_unit: float) -> list[Path]:
    from .hull.planout import write_plan_dxf

    write_plan_dxf(path, classed, mm_per_unit)
    return [path]


def _images(results, classed: list, config: RunConfig, out_dir: Path, style: str) -> list[Path]:
    """The sheet of all patterns, the plates by class and the strips on the hull (PNG)."""
    written = []
    ok = [r for r in results if r.ok]
    if ok:
        path = out_dir / f"{style}_sheet.png"
        render("pipeline.plots:sheet_png", path, [(r.name, r.pattern.outline, r.pattern.bend_lines) for r in ok],
               config.spec.units, config.mm_per_unit)
        written.append(path)
    if classed:
        from .hull.hullplots import class_hull_png

        path = out_dir / f"{style}_classes.png"
        class_hull_png(path, classed, config.spec.units, config.mm_per_unit)
        written.append(path)
    plates = hull_image_plates(results)
    if plates:
        tolerance = next(r.part.hull.fit_tolerance for r in results if r.part is not None and r.part.hull is not None)
        path = out_dir / f"{style}_hull.png"
        render("pipeline.plots:hull_png", path, plates, tolerance, config.spec.units)
        written.append(path)
    wait_for_images()
    return written


def hull_image_plates(results) -> list[tuple[str, np.ndarray, float]]:
    """The plates of ``NAME_hull.png``: every hull plate delivered with a 3D shape (its strip,
    or the mesh of a flat, trimmed-strip or formed plate; failed ones too when they have
    one) as (name, its boundary on the hull (N, 3), its deviation): the largest distance of
    its 3D shape from the hull, ``hull_fit`` ``max_distance`` (what the summary calls its
    hull deviation), NaN (drawn grey) for a plate without that figure."""
    from .hull.hullplots import plate_ring

    plates = []
    for r in results:
        if r.part is None or r.part.hull is None or (r.strip is None and r.mesh is None):
            continue
        ring = plate_ring(r)
        if ring is None:
            continue
        deviation = (r.figures.get("hull_fit") or {}).get("max_distance")
        plates.append((r.name, ring, float("nan") if deviation is None else float(deviation)))
    return plates


def export_summary(results: list[PartResult], config: RunConfig, out_dir: Path, shell=None, edges: dict | None = None,
                   drawn=None) -> list[Path]:
    """The run summary: summary.csv and summary.json of every part, and its drawings
    (:func:`summary_drawings`). ``shell``: the run's :class:`pipeline.hull.fitup.ShellFitup`
    (computed here when None); ``edges``: :func:`summary_edges` (computed here when None);
    ``drawn``: the drawings being drawn beside the run (a :class:`pipeline.forked.BesideAll`,
    whose result is their paths), else they are drawn here."""
    from .report import summary_csv, summary_json

    if shell is None:
        from .hull.fitup import shell_fitup

        shell = shell_fitup(results, config)
    if edges is None:
        edges = summary_edges(results)
    style = config.spec.name or config.source.stem
    written = [out_dir / f"{style}_summary.csv", out_dir / f"{style}_summary.json"]
    cost = None
    if any(r.part.hull is not None for r in results):  # a strake or hull: what the plan costs
        from .hull.cost import block_joints, plan_cost, stock_min_width
        from .hull.sheets import Sheets

        cost = plan_cost([r for r in results if r.part.hull is not None], edges, config.mm_per_unit,
                         stock_min_width(config.spec), block_joints(config.spec),
                         Sheets.of_shop(config.spec.shop)).as_dict()
    write_text(written[0], summary_csv(results))
    extra = {} if cost is None else {"plan_cost": cost}
    config.plan_cost = cost  # the console's plan line reads it
    if shell is not None:  # a hull run's fit-up and coverage (pipeline.hull.fitup)
        extra["shell"] = shell.as_dict()
        if getattr(config, "fitup_repair", None) is not None:
            extra["shell"]["repair"] = config.fitup_repair.as_dict()
        if getattr(config, "fitup_follow", None) is not None:
            extra["shell"]["follow"] = config.fitup_follow.as_dict()
        if getattr(config, "replan", None) is not None:
            extra["shell"]["replan"] = config.replan.as_dict()
    for kind, key in (("overlap", "faired_overlaps"), ("junction", "faired_junctions")):
        # faces faired into the faces they overlap, or onto the faces they meet
        done = [{k: v for k, v in f.items() if k != "kind"} for f in getattr(config, "plan_fairings", None) or []
                if f["kind"] == kind]
        if done:
            extra[key] = done
    models = model_sources(config)
    if models:  # a hull read as a model of faces: what its faces make as a shell
        from .hull.sewing import model_reports

        extra["hull_models"] = model_reports(models, config.source.parent)
    write_text(written[1], summary_json(results, extra))
    written += summary_drawings(results, config, out_dir, edges) if drawn is None else drawn.result()
    wait_for_images()
    return written
