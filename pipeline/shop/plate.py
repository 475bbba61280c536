"""Shop data of a steel plate: exact cut outline, bending lines, marks and labels, in mm.

Runs after the pattern stage for the steel profile; the DXF, the previews and the shop
drawing draw what it holds. Every length of a :class:`ShopPlate` is in mm.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .bending import BendLine, bending_lines
from .outline import Outline, PlateTracer, exact_outline
from .rolling import RollSetup, plate_limit, rolled_lines


@dataclass(frozen=True)
class ShopPlate:
    """A plate as the shop gets it (mm, the pattern's placed coordinates scaled).

    outline : the net outline (exact development within outline.tolerance)
    bending : numbered bending lines (none on a flat plate)
    bend_spacing : their spacing across the rulings
    length_across : the plate's length across its rulings (where that spacing is measured)
    rolling : the roll set-up (radius limit, lines rolled and not), None where not decided
    """

    outline: Outline
    bending: tuple[BendLine, ...] = ()
    bend_spacing: float = 0.0
    length_across: float = 0.0
    rolling: RollSetup | None = None


def roll_setup(lines_mm: list, steel, shop) -> tuple[list, RollSetup]:
    """The bending lines (mm) a plate of ``steel``'s thickness and material is rolled at
    (:mod:`pipeline.shop.rolling`), renumbered, and its roll set-up."""
    return rolled_lines(lines_mm, plate_limit(steel.thickness, steel.material, shop.no_roll_radius))


def bend_text(line: BendLine) -> str:
    """The mark written beside a bending line: number, radius, roll side."""
    radius = "FLAT" if not np.isfinite(line.radius) or line.radius > 1e6 else f"R{line.radius:.0f}"
    if line.convex_on_drawn_side is None:  # a formed plate's roll line: its side is not decided
        return f"B{line.number} {radius}"
    return f"B{line.number} {radius} {'CVX' if line.convex_on_drawn_side else 'CCV'}"


def _roll_note(plate: ShopPlate) -> str:
    """The roll set-up's shop text where it tells the plater something: no rolling at all,
    or rolling only at the lines marked (others were flatter than the limit); else ''."""
    rolling = plate.rolling
    return rolling.text() if rolling is not None and (not rolling.needs_rolling or rolling.dropped) else ""


def _scaled(outline: Outline, factor: float) -> Outline:
    return Outline(outline.points * factor, outline.edges, outline.max_deviation * factor,
                   outline.tolerance * factor, outline.alignment_error * factor)


def stage_shop(result, config) -> None:
    """Exact outline (and the shop marks) of a solved steel plate; sets ``result.shop``,
    replaces the pattern's outline by the exact one and records the figures."""
    scale = config.mm_per_unit
    shop = config.spec.shop
    hull = result.part.hull
    tracer = plate_tracer(result)
    outline = exact_outline(tracer, shop.outline_tolerance / scale)
    outline_mm = _scaled(outline, scale)
    lines, across = ([], 0.0) if result.solution.kind == "coplanar" else bending_lines(tracer, shop.bend_spacing / scale)
    # the pattern (previews, sheet, nesting) shows what the DXF holds: the exact outline and
    # the shop's bending lines, not the solver's rulings
    lines = [dataclasses.replace(b, a=b.a * scale, b=b.b * scale, station=b.station * scale, radius=b.radius * scale)
             for b in lines]
    lines, rolling = roll_setup(lines, result.part.steel, shop) if lines else (lines, None)
    result.pattern = dataclasses.replace(result.pattern, outline=outline.points,
                                         bend_lines=np.array([(b.a / scale, b.b / scale) for b in lines])
                                         .reshape(-1, 2, 2))
    if result.solution.kind != "coplanar":
        curvature = "none" if rolling is None or not rolling.needs_rolling else "single"
        result.templates, _ = strip_templates(result, tracer, scale, outline_mm.points, curvature, shop)
    result.shop = ShopPlate(outline_mm, tuple(lines), shop.bend_spacing, across * scale, rolling)
    result.figures["bending"] = {
        "units": "mm",
        "count": len(lines),
        "spacing": shop.bend_spacing,
        "length_across_rulings": across * scale,
        **({"rolling": rolling.figures()} if rolling is not None else {}),
        "drawn_side": "the side the strip normal c' x (d - c) points to; marks CVX / CCV: convex / concave on it",
        "lines": [{"number": b.number, "station": b.station, "start": b.a.tolist(), "end": b.b.tolist(),
                   "length": float(np.linalg.norm(b.b - b.a)),
                   "radius": b.radius if np.isfinite(b.radius) else None,
                   "convex_on_drawn_side": b.convex_on_drawn_side, "mark": bend_text(b)} for b in lines],
    }
    if lines:
        from .templates import checked_by

        checked_by(result.figures["bending"]["lines"], result.templates)
    result.figures["outline"] = {
        "units": "mm",
        "vertices": len(outline_mm.points),
        "tolerance": outline_mm.tolerance,
        "max_deviation": outline_mm.max_deviation,
        "deviation_measured_at": "3 points per segment (1/4, 1/2, 3/4) on the exact development",
        "alignment_error": outline_mm.alignment_error,
        "area_m2": outline_mm.area() / 1e6,
        "edges": {name: int(outline.edges.count(name)) for name in sorted(set(outline.edges))},
    }
    if hull is not None and result.strip.trim is not None:
        trimmed_figures(result, outline)
    if outline_mm.max_deviation > outline_mm.tolerance:
        result.warnings.append(f"cut outline deviates {outline_mm.max_deviation:.3g} mm from the exact development "
                               f"(tolerance {outline_mm.tolerance:g} mm): the sampling limit was reached")


def plate_tracer(result) -> PlateTracer:
    """The tracer of a solved strip plate: its rulings kept between its butt planes."""
    hull = result.part.hull
    planes = hull.butts if hull is not None else ()
    return PlateTracer(result.part, result.solution, result.strip, result.pattern, planes, result.developed)


def strip_templates(result, tracer, scale: float, outline_mm: np.ndarray, curvature: str, shop) -> tuple:
    """The templates of a solved strip plate (mm) by the count rule of
    :mod:`pipeline.shop.templates` for its ``curvature`` ('none', 'single', 'double'),
    sections of the strip itself (exact at the vertices of a mesh about 10 mm fine); their
    figures go to the report's ``templates``. Returns (chosen, every candidate)."""
    from .templates import TEMPLATE_STEP, candidate_planes, plate_templates, templates_section, tracer_mesh

    vertices, faces, flat, ruling, normal = tracer_mesh(tracer, scale)
    hull = result.part.hull
    frames = [x * scale for x in hull.frames] if hull is not None else []
    planes = candidate_planes(frames, ruling, shop.template_spacing, shop.template_margin)
    chosen, candidates, why = plate_templates(vertices, faces, flat, outline_mm, planes, curvature, normal,
                                              shop.template_margin, TEMPLATE_STEP)
    result.figures["templates"] = templates_section(chosen, candidates, why, curvature, shop.template_spacing,
                                                    shop.template_margin, TEMPLATE_STEP)
    if hull is not None and curvature != "none":  # a rolled hull plate: its pin jig
        plate_pin_jig(result, vertices, faces, normal, frames, shop)
    return tuple(chosen), candidates


def hull_templates(result, config, params: np.ndarray, flat: np.ndarray, outline: np.ndarray, curvature: str):
    """The templates of a hull plate given by its region grid (params (R, C, 2), flat (R, C,
    2) placed, outline (N, 2), model units): sections of the hull surface itself at its
    frames (:func:`pipeline.shop.templates.patch_templates`); sets ``result.templates`` and
    the report's ``templates``."""
    from .templates import TEMPLATE_STEP, hull_mesh, patch_templates, templates_section

    shop, hull, scale = config.spec.shop, result.part.hull, config.mm_per_unit
    # a formed plate formed to meet its neighbours (pipeline.hull.follow) is checked against its moved shape
    offsets = hull.follow["offsets"] if result.figures.get("follow") else None
    vertices, faces, flat_mm, normal = hull_mesh(hull.surface, params, flat, scale, offsets=offsets)
    frames = [x * scale for x in hull.frames]
    chosen, candidates, why = patch_templates(vertices, faces, flat_mm, normal, outline * scale, frames, curvature,
                                              shop.template_spacing, shop.template_margin)
    result.figures["templates"] = templates_section(chosen, candidates, why, curvature, shop.template_spacing,
                                                    shop.template_margin, TEMPLATE_STEP)
    result.templates = tuple(chosen)
    if curvature != "none":
        plate_pin_jig(result, vertices, faces, normal, frames, shop)


def plate_pin_jig(result, vertices, faces, normal, frames_mm, shop) -> None:
    """The pin jig of a rolled or formed plate (mesh in mm): sets ``result.pinjig`` and the
    report's ``pinjig`` (:mod:`pipeline.shop.pinjig`)."""
    from .pinjig import pin_jig

    jig = pin_jig(vertices, faces, normal, frames_mm, shop.pin_spacing, shop.shortest_pin)
    result.figures["pinjig"] = dict(jig.figures(), spacing=shop.pin_spacing)
    if len(jig.heights):
        result.pinjig = jig
    else:  # a plate narrower than the grid: no table, and the report says why
        result.figures["pinjig"]["note"] = ("no point of the pin grid lies under the plate 50 mm inside its edge: "
                                            "no table written")


def trimmed_figures(result, outline: Outline) -> None:
    """The ``mesh`` and ``unroll`` figures of a hull plate describe the trimmed plate the OBJ
    and DXF hold (the stages measured the strip extended past the butts, kept under
    ``extended_strip``); its boundary figures compare the flat c and d edges of the exact
    outline with the seams' arc length between the butt planes (model units)."""
    from flatten.metrics import distortion, polyline_length
    from trimesh.grouping import group_rows

    from flatten.plane import plane_crossings

    strip, part = result.strip, result.part
    mesh = strip.mesh()
    extended_mesh, extended_unroll = result.figures.get("mesh"), result.figures.get("unroll")
    result.figures["mesh"] = {"vertices": len(mesh.vertices), "faces": len(mesh.faces), "area_3d": float(mesh.area),
                              "euler_number": int(mesh.euler_number),
                              "boundary_edges": len(group_rows(mesh.edges_sorted, require_count=1)),
                              "describes": "the trimmed plate (the OBJ's mesh)", "extended_strip": extended_mesh}
    m = len(strip.samples)
    unroll = distortion(strip.vertices, result.pattern.vertices, m, part.c, part.d, strip.rulings)
    for key, curve in (("c", part.c), ("d", part.d)):
        crossings = [plane_crossings(curve, plane) for plane in part.hull.butts if plane is not None]
        if len(crossings) != 2 or not all(len(x) for x in crossings):
            continue
        arc = float(np.diff(curve.arc_length_at(np.sort([x[0] for x in crossings])))[0])
        flat = polyline_length(outline.edge_points(key))
        unroll[f"arc_length_{key}"], unroll[f"flat_length_{key}"] = arc, flat
        unroll[f"boundary_error_{key}_mm_per_m"] = 1000.0 * (flat - arc) / arc if arc > 0 else 0.0
    unroll["describes"] = ("the trimmed plate: its mesh against its development; boundary figures: the exact "
                           "outline's c and d edges against the seams between the butt planes")
    unroll["extended_strip"] = {k: v for k, v in (extended_unroll or {}).items()}
    result.figures["unroll"] = unroll


def _fallback(result, scale: float) -> ShopPlate:
    """A plate that is no solved strip (a flat or formed hull plate): its pattern's outline
    and roll lines as they are."""
    pattern = result.pattern
    n = len(pattern.outline)
    outline = Outline(pattern.outline * scale, ("edge",) * n, float("nan"), float("nan"), 0.0)
    forming = result.figures.get("forming") or {}
    radii = forming.get("roll_line_radii")  # mm, where the roll set-up measured them
    if radii is None or len(radii) != len(pattern.bend_lines):
        lines = [BendLine(k + 1, a * scale, b * scale, float("nan"), float("nan"), True)
                 for k, (a, b) in enumerate(pattern.bend_lines)]
        return ShopPlate(outline, tuple(lines))
    lines = [BendLine(k + 1, a * scale, b * scale, float("nan"), float("inf") if r is None else float(r), None)
             for k, ((a, b), r) in enumerate(zip(pattern.bend_lines, radii))]
    rolling = forming.get("rolling")
    setup = None if rolling is None else RollSetup(rolling["no_roll_radius"], rolling["thickness"],
                                                   rolling["yield_stress_mpa"], rolling["source"],
                                                   rolling["rolled_lines"], rolling["lines_not_rolled"],
                                                   rolling["smallest_radius"] or float("inf"))
    return ShopPlate(outline, tuple(lines), rolling=setup)


def edge_names(result, shop_settings) -> dict:
    """{edge key: text} for the plate's edges: seam and butt names of a hull plate (the
    outline names its butt edges by the butt plane they lie on), with the bevel texts."""
    hull = result.part.hull
    names = {}
    if hull is not None:
        names = {"c": hull.seam_names[0], "d": hull.seam_names[1], "start": hull.butt_names[0],
                 "end": hull.butt_names[1]}
    for key in ("c", "d", "start", "end"):
        bevel = getattr(shop_settings.bevel, key)
        if bevel:
            names[key] = f"{names.get(key, 'EDGE ' + key.upper())} {bevel}"
    return names


def shop_layout(result, config, part_data: list[str]):
    """The plate's marks and texts laid out (mm) for the DXF and the shop drawing; the
    layout's findings go to the warnings and the report."""
    from .layout import plate_layout

    scale = config.mm_per_unit
    settings = config.spec.shop
    plate = result.shop if result.shop is not None else _fallback(result, scale)
    outline = plate.outline
    net = outline.points
    edges = {}
    names = edge_names(result, settings)
    if result.shop is not None:
        for key, text in names.items():
            edges[text] = outline.edge_points(key)
    else:  # labels of a flat or formed plate: a short line where its own code put them
        for text, position, angle in result.pattern.labels:
            d = np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle))])
            p = np.asarray(position) * scale
            edges[text] = np.array([p - 50.0 * d, p + 50.0 * d])
    # every stretch of a butt edge on its own: joined, two stretches of one name would make
    # a line across the plate that every frame touches ("0.0 mm from a butt")
    butts = [run for k in ("start", "end") for run in outline.edge_runs(k)] if result.part.hull is not None else []
    frames = [(f"FR {x * scale:g}", line * scale) for x, line in result.pattern.frame_lines]
    bends = [(bend_text(b) if not np.isnan(b.radius) else f"R{b.number}", b.a, b.b) for b in plate.bending]
    if plate.bending and np.isfinite(plate.bend_spacing) and plate.bend_spacing > 0:
        part_data = part_data + [f"BEND LINES B1-B{len(plate.bending)} EVERY {plate.bend_spacing:g} MM",
                                 "CVX/CCV: CONVEX/CONCAVE ON THIS SIDE"]
    if _roll_note(plate):
        part_data = part_data + [_roll_note(plate)]
    cut, allowance = allowance_cut(outline, result.part.hull, settings, result.shop is not None)
    if allowance is not None:
        part_data = part_data + [allowance["text"]]
        result.figures.setdefault("outline", {})["allowance"] = allowance
        if not allowance["per_edge"]:
            result.warnings.append(allowance["note"])
    areas = []
    strain, region = result.figures.get("strain"), result.figures.get("region")
    if result.shop is None and strain and region and region.get("grid") and result.pattern is not None:
        from .marks import strain_areas

        areas = [(kind, ring * scale) for kind, ring, _ in strain_areas(strain, region["grid"], result.pattern.vertices)]
    from .heating import layout_marks  # a formed plate's heating lines (MARK_HEAT) and its groups' texts

    heat_lines, heat_texts = layout_marks(result.figures.get("heating"))
    areas, part_data = areas + heat_lines, part_data + heat_texts
    layout = plate_layout(net, cut, edges, bends, frames, part_data, settings.text_height, butts,
                          settings.frame_clearance, areas)
    if heat_lines:  # each group of heating lines named beside its lines, as its text calls it
        from .heating import label_groups

        layout.findings += label_groups(layout, result.figures.get("heating"), net, settings.text_height[0])
    stock = stock_check(cut, settings.stock, settings.stock_margin)
    result.figures["stock"] = stock
    if stock["fits_on"] is None:
        result.warnings.append(f"no stock plate fits: the part needs {stock['needed'][0]:.0f} x {stock['needed'][1]:.0f} mm "
                               f"with {settings.stock_margin:g} mm margins; stock {stock['stock']}")
    result.figures["layout"] = {
        "units": "mm", "text_height": layout.text_height,
        "texts": len(layout.texts), "bending_lines": sum(1 for k, _ in layout.lines if k == "bend"),
        "frame_lines": sum(1 for k, _ in layout.lines if k == "frame"),
        "shrink_areas": sum(1 for k, _ in layout.lines if k == "shrink"),
        "stretch_areas": sum(1 for k, _ in layout.lines if k == "stretch"),
        "frames_marked": sorted({t.text for t in layout.texts if t.kind == "frame"}),
        "findings": list(layout.findings)}
    result.warnings += [f for f in layout.findings if "not marked" not in f]
    return layout


def allowance_cut(outline: Outline, hull, settings, per_edge: bool):
    """The cut line (mm) around the net outline and the report's allowance section (None
    when nothing is added). A plate whose outline has no named edges (a flat or formed hull
    plate) gets the largest allowance all round, and a note saying so."""
    from .allowance import cut_outline

    widths = settings.allowance()
    if not any(widths.values()):
        return outline.points, None
    if per_edge:
        cut = cut_outline(outline.points, outline.edges, widths)
    else:
        cut = cut_outline(outline.points, ("edge",) * len(outline.points), {"edge": max(widths.values())})
    stated = {**settings.allowances(), "total": widths}
    label = dict(zip(("c", "d", "start", "end"), (*hull.seam_names, *hull.butt_names) if hull is not None
                     else ("C", "D", "START", "END")))
    text = "ALLOWANCE MM " + ", ".join(f"{label[k]} {v:g}" for k, v in widths.items() if v > 0)
    if not per_edge:
        text = f"ALLOWANCE {max(widths.values()):g} MM ALL ROUND"
    from flatten.metrics import polygon_area

    net_area, cut_area = polygon_area(outline.points), polygon_area(cut)
    return cut, {"units": "mm", **stated, "per_edge": per_edge, "text": text,
                 "net_area_m2": net_area / 1e6, "cut_area_m2": cut_area / 1e6,
                 "cut_vertices": len(cut), "net_line": "drawn on the net layer (MARK_NET by default)",
                 "note": "" if per_edge else "this plate's outline has no named edges: the largest allowance "
                 f"({max(widths.values()):g} mm) is cut all round"}


def stock_check(outline_mm: np.ndarray, stock: list, margin: float) -> dict:
    """The smallest rectangle holding the part (any rotation) plus the margin on every side,
    and the smallest configured stock plate (by area) it fits on; None when none fits."""
    sides = part_rectangle(outline_mm)
    need = sides + 2.0 * margin
    best = smallest_sheet(need, stock)
    return {"units": "mm", "part_rectangle": sides.tolist(), "margin": margin, "needed": need.tolist(),
            "stock": [list(s) for s in stock], "fits_on": list(best) if best else None}


def part_rectangle(outline: np.ndarray) -> np.ndarray:
    """(short, long) sides of the smallest rectangle (any rotation) holding the closed outline
    (N, 2); an outline whose points lie on a line gives (0, its length)."""
    from flatten.rectangle import rectangle_sides

    return rectangle_sides(outline)


def smallest_sheet(need: np.ndarray, stock) -> tuple | None:
    """The smallest stock plate (by area; each given as two sides in any order) that holds a
    rectangle ``need`` (short, long), as (width, length); None when none does."""
    fits = [(w * h, (w, h)) for w, h in (sorted(s) for s in stock) if need[0] <= w and need[1] <= h]
    return min(fits)[1] if fits else None


def mirrored(layout, side_of_model: str):
    """The layout reflected (x -> -x, moved back to x >= 0): the plate of the other side."""
    import copy

    from .layout import Text, readable

    width = float(layout.cut[:, 0].max() + layout.cut[:, 0].min())

    def flip(p):
        p = np.array(p, dtype=float, copy=True)
        p[..., 0] = width - p[..., 0]
        return p

    out = copy.copy(layout)
    out.cut = flip(layout.cut)[::-1]
    out.net = None if layout.net is None else flip(layout.net)[::-1]
    out.lines = [(k, flip(line)) for k, line in layout.lines]
    out.texts = [Text(t.kind, t.text, tuple(flip(t.at)), t.height, readable(180.0 - t.angle),
                      None if t.names is None else tuple(flip(t.names))) for t in layout.texts]
    out.mirror_width = width  # the drawing flips the plate's own marks (bending lines, edges) the same way
    return out


def shop_drawing(result, config, layout, target):
    """Write the plate's one-page shop drawing (PDF); its paper and scale go to the report."""
    from .drawing import write_shop_drawing

    plate = result.shop if result.shop is not None else _fallback(result, config.mm_per_unit)
    bends = [(b.number, bend_text(b) if not np.isnan(b.radius) else f"R{b.number}", b.a, b.b, b.station)
             for b in plate.bending]
    steel = result.figures.get("steel") or {}
    data = [f"PART {result.name}   THK {steel.get('thickness_mm', 0):g} MM   MAT {steel.get('material', '')}",
            f"NET AREA {steel.get('area_m2', 0):.3f} M2   WEIGHT {steel.get('weight_kg', 0):.1f} KG",
            f"MARKED SIDE {str(steel.get('marked_side', '')).upper()}; DRAWN FROM THE SIDE THE STRIP NORMAL "
            "POINTS TO",
            f"OVERALL {np.ptp(layout.cut[:, 0]):.0f} x {np.ptp(layout.cut[:, 1]):.0f} MM (CUT LINE)"]
    allowance = (result.figures.get("outline") or {}).get("allowance")
    if allowance:
        data.append(allowance["text"] + " (CUT LINE SOLID, NET LINE DASHED)")
    issue = config.spec.output.issue
    if issue is not None:
        data.append(issue.text())
    notes = []
    if plate.bending:
        spacing = plate.bend_spacing if np.isfinite(plate.bend_spacing) and plate.bend_spacing > 0 else None
        notes.append(f"BENDING LINES B1-B{len(plate.bending)}" + (f" EVERY {spacing:g} MM ACROSS THE LINES"
                                                                   if spacing else ""))
        notes.append("CVX / CCV: CONVEX / CONCAVE ON THE DRAWN SIDE; R: RADIUS ACROSS THE LINE")
    else:
        spacing = None
    if _roll_note(plate):
        notes.append(_roll_note(plate))
    edges = {}
    if result.shop is not None:
        names = {key: f"EDGE {key.upper()}" for key in ("c", "d", "start", "end")}
        names.update(edge_names(result, config.spec.shop))
        edges = {text: plate.outline.edge_points(key) for key, text in names.items()}
    width = getattr(layout, "mirror_width", None)
    if width is not None:  # the other side's plate: its marks where the mirrored layout has them
        def flip(p):
            return np.array([width - p[..., 0], p[..., 1]]).T if np.ndim(p) == 2 else np.array([width - p[0], p[1]])

        bends = [(n, m, flip(np.asarray(a)), flip(np.asarray(b)), s) for n, m, a, b, s in bends]
        edges = {k: flip(np.asarray(v)) for k, v in edges.items()}
    info = write_shop_drawing(target, layout, f"{result.name}: SHOP DRAWING", data, bends, spacing, notes, edges,
                              result.templates)
    result.figures["layout"].setdefault("drawings", []).append(info)
    if info.get("not_placed"):  # a label the drawing found no room for is a finding, never drawn across
        result.warnings.append(f"{info['file']}: " + "; ".join(info["not_placed"]))
    return target
