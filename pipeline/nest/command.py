"""`devflat nest`: the run's parts into a fabric marker or onto steel stock plates, and the
files: marker DXF (AAMA dialect) or one DXF per stock plate (R2000, mm), the cutting list,
the nesting report and PNGs.

The outlines nested are the pipeline's own: the textile cut line (with its allowances) of
each piece, the steel pattern outline of each plate. Everything is checked before anything
is written (bad input: exit 2, no files).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path, write_text
from ..config import ConfigError, RunConfig
from .engine import (NestingError, NestItem, NestResult, Placement, Sheet, marker_result, nest_marker,
                      nest_stock, stock_result)
from ..report import SCHEMA_VERSION, sanitize

TEXTILE_ORIENTATIONS = (0.0, 180.0)  # the grain stays along the roll
STEEL_ORIENTATIONS = (0.0, 90.0, 180.0, 270.0)


@dataclass
class NestJob:
    """What to nest: groups of items (steel: one per thickness and material) with the marks
    of each item in its own coordinates, and the parts that failed before nesting."""

    kind: str
    groups: dict = field(default_factory=dict)  # key -> list[NestItem]
    group_info: dict = field(default_factory=dict)  # key -> {"thickness_mm", "material", "density_kg_m3"}
    marks: dict = field(default_factory=dict)  # item id -> {"bend": (K, 2, 2), "frames": [(x, (N, 2))]}
    pieces: dict = field(default_factory=dict)  # item id -> TextilePiece (textile)
    failed: list = field(default_factory=list)  # [{"part", "reason"}]
    inventory: list = field(default_factory=list)  # remnants.Remnant plates to use first (steel)


def _orientations(spec, default) -> tuple[float, ...] | None:
    if spec.orientations == "free":
        return None
    return tuple(float(a) for a in (spec.orientations or default))


def check_quantities(config: RunConfig) -> dict[str, int]:
    """Copies wanted per part name; names in nesting.quantities must be parts of the run."""
    spec = config.spec.nesting
    names = [p.name for p in config.parts]
    for name, value in spec.quantities.items():
        if name not in names:
            raise ConfigError(f"{config.source}: nesting.quantities.{name} = {value}: no part {name!r} in this run "
                              f"(parts: {', '.join(names)})")
    default = config.spec.textile.quantity if config.spec.profile == "textile" else 1
    wanted = {name: spec.quantities.get(name, default) for name in names}
    if not any(wanted.values()):
        raise ConfigError(f"{config.source}: nesting.quantities: every quantity is 0: no parts to nest")
    return wanted


def build_job(results, config: RunConfig) -> NestJob:
    """Items from the pipeline's results: textile cut lines turned so that the grain runs
    along the roll; steel pattern outlines (and their mirror images for pairs)."""
    spec = config.spec.nesting
    wanted = check_quantities(config)
    job = NestJob("marker" if config.spec.profile == "textile" else "stock")
    job.failed = [{"part": r.name, "reason": r.reason} for r in results if not r.ok]
    if job.kind == "marker":
        from ..export import textile_pieces

        items = []
        orients = _orientations(spec, TEXTILE_ORIENTATIONS)
        for piece in textile_pieces(results, config):
            if wanted[piece.name] == 0:
                continue
            g = piece.grain[1] - piece.grain[0]
            items.append(NestItem(piece.name, piece.cut, wanted[piece.name], orients,
                                  -math.degrees(math.atan2(g[1], g[0]))))
            job.pieces[piece.name] = piece
        job.groups["fabric"] = items
        job.group_info["fabric"] = {"fabric": config.spec.textile.fabric}
        return job
    orients = _orientations(spec, STEEL_ORIENTATIONS)
    for r in results:
        if not r.ok or wanted[r.name] == 0:
            continue
        steel = r.part.steel
        key = f"{steel.material}-{steel.thickness:g}"
        job.group_info[key] = {"thickness_mm": steel.thickness, "material": steel.material,
                               "density_kg_m3": steel.density, "marked_side": steel.marked_side}
        outline = r.pattern.outline
        bend = r.pattern.bend_lines
        frames = list(getattr(r.pattern, "frame_lines", ()) or ())
        layout = plate_marks(r, config)  # every mark of the part's own DXF (mm)
        sides = [("", False)]
        if spec.pairs:
            own, other = ("SB", "PS") if spec.developed_side == "starboard" else ("PS", "SB")
            sides = [(f"_{own}", False), (f"_{other}", True)]
        for suffix, mirror in sides:
            ident = r.name + suffix
            if mirror:  # the other side of the ship: the mirror image, cut with the marked side up
                flip = np.array([-1.0, 1.0])
                ring = (outline * flip)[::-1]
                marks = {"bend": bend * flip, "frames": [(x, line * flip) for x, line in frames],
                         "layout": _mirrored_marks(layout)}
            else:
                ring = outline
                marks = {"bend": bend, "frames": frames, "layout": layout}
            job.groups.setdefault(key, []).append(NestItem(ident, ring, wanted[r.name], orients))
            job.marks[ident] = marks
    return job


def run_job(job: NestJob, config: RunConfig, progress=None) -> dict[str, NestResult]:
    """Nest every group; NestingError (bad input) is re-raised as ConfigError naming the file."""
    spec = config.spec.nesting
    out = {}
    try:
        if job.kind == "marker":
            items = job.groups["fabric"]
            out["fabric"] = nest_marker(items, spec.fabric_width, spec.spacing, spec.edge_margin, spec.time, spec.seed,
                                        spec.workers, progress)
            return out
        if not any(job.groups.values()):
            raise NestingError("no parts to nest: every part failed or has quantity 0")
        sizes = [(s.name or f"{s.width:g}x{s.length:g}", s.width, s.length) for s in spec.stock_sizes()]
        # one budget for the command: each group gets its area's share of what is left
        deadline = time.perf_counter() + spec.time
        left = sum(it.area * it.quantity for items in job.groups.values() for it in items)
        for key, items in job.groups.items():
            area = sum(it.area * it.quantity for it in items)
            budget = max(0.0, deadline - time.perf_counter()) * area / left
            left -= area
            remnants = [(r.id, r.width, r.length) for r in job.inventory if r.fits_group(job.group_info[key])]
            out[key] = nest_stock(items, sizes, spec.spacing, spec.edge_margin, budget,
                                  spec.seed, spec.workers, progress, remnants=remnants)
        return out
    except NestingError as exc:
        raise ConfigError(f"{config.source}: {exc}") from None


def replay_job(job: NestJob, config: RunConfig, source: Path) -> dict[str, NestResult]:
    """The layout stored in a nesting report (``NAME_nesting.json``) applied to this run's
    parts and checked again: an exact reproduction, whatever the engine would do today.
    A changed outline shows in the checks; a missing part or group is bad input."""
    spec = config.spec.nesting
    try:
        stored = json.loads(Path(source).read_text(encoding="utf-8"))
        groups = stored["groups"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ConfigError(f"--replay {source}: not a nesting report: {exc}") from None
    if stored.get("kind") != job.kind:
        raise ConfigError(f"--replay {source}: kind {stored.get('kind')!r} does not match this run ({job.kind})")
    out = {}
    for key, items in job.groups.items():
        if key not in groups:
            raise ConfigError(f"--replay {source}: no group {key!r} (groups: {', '.join(groups)})")
        ids = {it.id for it in items}
        sheets = []
        try:
            for s in groups[key]["sheets"]:
                placements = []
                for p in s["placements"]:
                    if p["item"] not in ids:
                        raise ConfigError(f"--replay {source}: part {p['item']!r} is not in this run")
                    placements.append(Placement(p["item"], int(p["copy"]) - 1, float(p["rotation"]),
                                                np.asarray(p["translation"], dtype=float)))
                sheets.append(Sheet(s["id"], float(s["width"]), float(s["length"]), tuple(placements), s["stock"]))
            unplaced = list(groups[key].get("unplaced", []))
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"--replay {source}: group {key!r}: malformed placement: {exc}") from None
        engine = {"replayed": str(source), "seconds": 0.0}
        if job.kind == "marker":
            out[key] = marker_result(items, spec.fabric_width, spec.spacing, spec.edge_margin,
                                     list(sheets[0].placements), engine)
        else:
            out[key] = stock_result(items, sheets, spec.spacing, spec.edge_margin, unplaced, engine)
    return out


# ------------------------------------------------------------------ files
def _sheet_name(style: str, key: str, sheet_id: str, single: bool) -> str:
    return f"{style}_{sheet_id}" if single else f"{style}_{key}_{sheet_id}"


def write_marker(path: Path, result: NestResult, job: NestJob, style: str, scale: float,
                 flavour: str = "aama-r12") -> None:
    """The marker in the AAMA dialect: the piece blocks of :mod:`pipeline.aama` (notch and
    validation layers of the run's flavour; ezdxf's D6673 writer makes the file), one
    INSERT per placed copy (insertion point and rotation), the roll edges and marker figures."""
    from ezdxf.addons import gerber_D6673

    from ..textile.aama import block_name, build_document

    sheet = result.sheets[0]
    pieces = [job.pieces[name] for name in result.items]
    doc = build_document(pieces, style, scale, flavour)
    msp = doc.modelspace()
    for insert in list(msp.query("INSERT")):  # the pieces' INSERTs at the origin make way for the placed copies
        msp.delete_entity(insert)
    by_piece = {p.name: block_name(p, p.settings.size) for p in pieces}
    for p in sheet.placements:
        msp.add_blockref(by_piece[p.item], tuple(p.translation * scale), dxfattribs={"layer": "1",
                                                                                   "rotation": p.rotation % 360.0})
    length, width = sheet.length * scale, sheet.width * scale
    msp.add_polyline2d([(0, 0), (length, 0), (length, width), (0, width)], close=True, dxfattribs={"layer": "15"})
    figures = result.figures
    texts = [f"Marker Length: {length:.1f}", f"Marker Width: {width:.1f}",
             f"Marker Efficiency: {100 * figures['efficiency']:.2f}%", f"Pieces: {figures['pieces']}"]
    for k, text in enumerate(texts):
        msp.add_text(text, height=5.0, dxfattribs={"layer": "1"}).set_placement((0, -10.0 * (k + 9)))
    with atomic_path(path) as tmp:
        gerber_D6673.export_file(doc, tmp)


def plate_marks(result, config: RunConfig):
    """The part's shop layout (:func:`pipeline.shop.plate.shop_layout`, mm) as its own DXF
    has it: bending lines with their numbers, radii and CVX/CCV, frame lines and names, edge
    names, marked areas and any other mark kind, and the part data; plus ``id_at``: where a
    nest's part id fits on the plate clear of every line and text (None: no room). The
    part's report figures are left as they were."""
    import copy

    from ..export import steel_texts
    from ..shop.plate import shop_layout

    figures, warnings = copy.copy(result.figures), list(result.warnings)
    try:
        layout = shop_layout(result, config, steel_texts(result))
    finally:
        result.figures, result.warnings = figures, warnings
    layout.id_at = _id_spot(layout, f"{result.name}_XX#00")
    return layout


def _id_spot(layout, text: str):
    """(centre (2,), height) for a one-line text as long as ``text`` on the plate, clear of
    its lines and texts (their boxes), at the layout's text height or smaller; None."""
    import shapely

    from ..shop.layout import CHAR_WIDTH, Placer, grid_points, heights, text_corners

    plate = shapely.Polygon(layout.net if layout.net is not None else layout.cut).buffer(0)
    boxes = [np.vstack([c, c[:1]]) for c in text_corners(layout.texts)] if layout.texts else []
    lines = [line for _, line in layout.lines] + boxes
    smallest = max(min(layout.text_height, 5.0), 1.0)
    clearance = 0.2 * smallest
    room = plate.buffer(-clearance)
    if room.is_empty or room.geom_type != "Polygon":
        return None
    placer = Placer(room, lines, clearance)
    centres, _ = grid_points(room, placer.obstacles)
    for h in heights(max(layout.text_height, smallest), smallest):
        i = placer.place(centres, CHAR_WIDTH * h * len(text), 1.3 * h, 0.0)
        if i is not None:
            return centres[i], h
    return None


def _mirrored_marks(layout):
    """The layout of the other side's part as the nest flips it (x -> -x)."""
    from ..shop.plate import mirrored

    out = mirrored(layout, "")
    width = float(layout.cut[:, 0].max() + layout.cut[:, 0].min())
    shift = np.array([-width, 0.0])  # mirrored() reflects about the plate's middle; the nest about x = 0
    out.cut = out.cut + shift
    out.net = None if out.net is None else out.net + shift
    out.lines = [(k, line + shift) for k, line in out.lines]
    out.texts = [dataclasses.replace(t, at=tuple(np.asarray(t.at) + shift),
                                     names=None if t.names is None else tuple(np.asarray(t.names) + shift))
                 for t in out.texts]
    out.id_at = None if layout.id_at is None else (np.array([-layout.id_at[0][0], layout.id_at[0][1]]), layout.id_at[1])
    return out


def _layout_on_sheet(msp, layout, p, scale: float, layers) -> None:
    """Every mark of a part's layout (mm) moved with its placement p (model units), each
    kind on its layer (the configured one, else MARK_<KIND>: kinds of other modules show)."""
    from ezdxf.enums import TextEntityAlignment

    def layer(kind):
        name = getattr(layers, kind, None) or f"MARK_{kind.upper()}"
        if name not in msp.doc.layers:
            msp.doc.layers.add(name, color=7)
        return name

    def place(points):
        return p.place(np.asarray(points, dtype=float).reshape(-1, 2) / scale) * scale

    if layout.net is not None:
        msp.add_lwpolyline([tuple(q) for q in place(layout.net)], close=True, dxfattribs={"layer": layer("net")})
    for kind, line in layout.lines:
        msp.add_lwpolyline([tuple(q) for q in place(line)], format="xy", dxfattribs={"layer": layer(kind)})
    for t in layout.texts:
        msp.add_text(t.text, height=t.height, rotation=(t.angle + p.rotation) % 360.0,
                     dxfattribs={"layer": layer(t.kind)}).set_placement(tuple(place(t.at)[0]),
                                                                        align=TextEntityAlignment.MIDDLE_CENTER)


def place_mm(p, at, scale: float) -> np.ndarray:
    """A point (2,) of a part's layout (mm) on the sheet (mm) by the placement p."""
    return p.place(np.asarray(at, dtype=float)[None] / scale)[0] * scale


def write_stock_dxf(path: Path, sheet, result: NestResult, job: NestJob, info: dict, layers, scale: float) -> int:
    """One stock plate: its edges (STOCK), every part's cut contour, bending and frame lines
    moved with it, part ids and the plate's data. R2000, mm. Returns the audit errors."""
    import ezdxf
    from ezdxf import units
    from ezdxf.enums import TextEntityAlignment

    doc = ezdxf.new("R2000", setup=False)
    doc.units = units.MM
    doc.header["$INSUNITS"] = 4
    doc.header["$MEASUREMENT"] = 1
    for name, colour in ((layers.cut, 1), (layers.bend, 5), (layers.text, 3), (layers.frame, 6), ("STOCK", 8)):
        if name not in doc.layers:
            doc.layers.add(name, color=colour)
    msp = doc.modelspace()
    length, width = sheet.length * scale, sheet.width * scale
    msp.add_lwpolyline([(0, 0), (length, 0), (length, width), (0, width)], close=True,
                       dxfattribs={"layer": "STOCK"})
    row = next(r for r in result.figures["sheets"] if r["sheet"] == sheet.id)
    height = max(min(0.01 * width, 60.0), 2.5)
    for p in sheet.placements:
        item = result.items[p.item]
        ring = p.place(item.outline) * scale
        msp.add_lwpolyline([tuple(q) for q in ring], close=True, dxfattribs={"layer": layers.cut})
        marks = job.marks.get(p.item, {})
        layout = marks.get("layout")
        if layout is not None:  # the part's own DXF's marks, texts and all
            _layout_on_sheet(msp, layout, p, scale, layers)
        else:
            for a, b in marks.get("bend", ()):
                msp.add_line(tuple(p.place(a[None])[0] * scale), tuple(p.place(b[None])[0] * scale),
                             dxfattribs={"layer": layers.bend})
            for _, line in marks.get("frames", ()):
                msp.add_lwpolyline([tuple(q) for q in p.place(line) * scale], format="xy",
                                   dxfattribs={"layer": layers.frame})
        spot = None if layout is None else layout.id_at
        if spot is not None:  # where it crosses no line nor text of the part
            at, h = spot
            msp.add_text(f"{p.item}#{p.copy + 1}", height=h, rotation=p.rotation % 360.0,
                         dxfattribs={"layer": layers.text}).set_placement(
                tuple(place_mm(p, at, scale)), align=TextEntityAlignment.MIDDLE_CENTER)
        else:
            centre = ring.mean(axis=0)
            msp.add_text(f"{p.item}#{p.copy + 1}", height=height, dxfattribs={"layer": layers.text}).set_placement(
                tuple(centre))
    texts = [f"STOCK {sheet.id} {sheet.stock} {length:.0f} X {width:.0f} MM",
             f"THK {info['thickness_mm']:g} MM {info['material']}",
             f"UTILISATION {100 * row['utilisation']:.1f} %", f"PARTS {len(sheet.placements)}"]
    for k, text in enumerate(texts):
        msp.add_text(text, height=height, dxfattribs={"layer": layers.text}).set_placement(
            (0, -1.6 * height * (k + 1)))
    auditor = doc.audit()
    with atomic_path(path) as tmp:
        doc.saveas(tmp)
    return len(auditor.errors)


def cutting_list_csv(results: dict[str, NestResult], job: NestJob, scale: float) -> str:
    """One row per stock plate (parts, utilisation, scrap area and weight), one per part not placed."""
    m2 = (scale / 1000.0) ** 2
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["plate", "stock", "width_mm", "length_mm", "used_length_mm", "thickness_mm", "material",
                     "parts_count", "parts",
                     "parts_area_m2", "plate_area_m2", "utilisation", "scrap_area_m2", "scrap_weight_kg",
                     "plate_weight_kg", "note"])
    for key, result in results.items():
        info = job.group_info[key]
        kg_per_m2 = info["thickness_mm"] / 1000.0 * info["density_kg_m3"]
        for row in result.figures["sheets"]:
            writer.writerow([row["sheet"] if len(results) == 1 else f"{key}_{row['sheet']}", row["stock"],
                             f"{row['width'] * scale:.1f}", f"{row['length'] * scale:.1f}",
                             f"{row['used_length'] * scale:.1f}", f"{info['thickness_mm']:g}",
                             info["material"], len(row["parts"]), " ".join(row["parts"]),
                             f"{row['parts_area'] * m2:.4f}", f"{row['plate_area'] * m2:.4f}",
                             f"{row['utilisation']:.4f}", f"{row['scrap_area'] * m2:.4f}",
                             f"{row['scrap_area'] * m2 * kg_per_m2:.1f}", f"{row['plate_area'] * m2 * kg_per_m2:.1f}", ""])
        for u in result.unplaced:
            writer.writerow(["UNPLACED", "", "", "", "", f"{info['thickness_mm']:g}", info["material"], u["copies"],
                             u["item"], "", "", "", "", "", "", f"not placed: {u['reason']}"])
    return buffer.getvalue()


def nesting_report(results: dict[str, NestResult], job: NestJob, config: RunConfig, files: list[str]) -> dict:
    spec = config.spec.nesting
    groups = {}
    for key, r in results.items():
        groups[key] = {
            "success": r.success, "message": r.message, "info": job.group_info.get(key),
            "figures": r.figures, "engine": r.engine, "checks": r.checks, "unplaced": r.unplaced,
            "items": {it.id: {"quantity": it.quantity, "area": it.area, "vertices": len(it.outline),
                              "orientations": None if it.orientations is None else list(it.orientations),
                              "base_rotation": it.base_rotation} for it in r.items.values()},
            "sheets": [{"id": s.id, "stock": s.stock, "width": s.width, "length": s.length,
                        "placements": [{"item": p.item, "copy": p.copy + 1, "rotation": p.rotation,
                                        "translation": p.translation.tolist()} for p in s.placements]}
                       for s in r.sheets],
        }
    return {"schema_version": SCHEMA_VERSION, "kind": job.kind, "units": config.spec.units,
            "success": all(r.success for r in results.values()) and not job.failed,
            "settings": spec.model_dump(), "mirroring": "never: parts are only rotated (the marked side / "
            "the fabric face stays up); pairs are nested as distinct mirror-image parts",
            "failed_parts": job.failed, "groups": groups, "files": files}


def remnant_inventory(results: dict[str, NestResult], job: NestJob, config: RunConfig) -> list:
    """The inventory after this nest: the remnants read that no plate used, then each
    plate's offcut above the configured size under a new id. Records per group, in its
    figures, the remnants used and the offcuts kept."""
    from .remnants import Remnant, next_ids, offcut

    spec = config.spec.nesting.remnants
    style = config.spec.name or config.source.stem
    known = {r.id for r in job.inventory}
    used = {s.stock for r in results.values() for s in r.sheets if s.stock in known}
    found = []
    for key, r in results.items():
        for row in r.figures["sheets"]:
            cut = offcut(row, spec.min_length, spec.min_width, r.edge_margin, r.spacing)
            if cut is not None:
                found.append((key, row, cut))
    ids = next_ids(sorted(known), len(found))
    new = []
    for key in results:
        results[key].figures["remnants"] = {"used": sorted(s.stock for s in results[key].sheets if s.stock in used),
                                            "offcuts": []}
    for ident, (key, row, (x, width, length)) in zip(ids, found):
        info = job.group_info[key]
        label = row["sheet"] if len(results) == 1 else f"{key}_{row['sheet']}"
        new.append(Remnant(ident, info["thickness_mm"], info["material"], width, length,
                           f"{style} {label} ({row['stock']}) beyond x = {x:.6g}"))
        results[key].figures["remnants"]["offcuts"].append({"remnant": ident, "sheet": row["sheet"], "cut_at": x,
                                                            "width": width, "length": length})
    return [r for r in job.inventory if r.id not in used] + new


def write_outputs(results: dict[str, NestResult], job: NestJob, config: RunConfig, out_dir: Path) -> list[Path]:
    from ..plots import layout_png

    style = config.spec.name or config.source.stem
    scale = config.mm_per_unit
    units = config.spec.units
    png = config.spec.output.png
    written = []
    if job.kind == "marker":
        r = results["fabric"]
        sheet = r.sheets[0]
        if config.spec.output.dxf:
            path = out_dir / f"{style}_marker.dxf"
            write_marker(path, r, job, style, scale, config.spec.textile.aama.flavour)
            written.append(path)
        plotter = config.spec.textile.plotter_options()
        if plotter is not None:  # the marker for a cutter: every placed copy, where the DXF puts it
            from ..textile.hpgl import write_hpgl
            from .engine import rotation

            path = out_dir / f"{style}_marker.plt"
            placed = [job.pieces[p.item].moved(rotation(p.rotation), p.translation) for p in sheet.placements]
            write_hpgl(path, placed, scale, plotter)
            written.append(path)
        if png:
            path = out_dir / f"{style}_marker.png"
            layout_png(path, sheet.width, sheet.length,
                       [(f"{p.item}#{p.copy + 1}", p.place(r.items[p.item].outline)) for p in sheet.placements],
                       f"{style}: marker {sheet.length:.1f} x {sheet.width:g} {units}, efficiency "
                       f"{100 * r.figures['efficiency']:.1f}%", units, r.edge_margin)
            written.append(path)
    else:
        single = len(results) == 1
        for key, r in results.items():
            for sheet in r.sheets:
                name = _sheet_name(style, key, sheet.id, single)
                if config.spec.output.dxf:
                    path = out_dir / f"{name}.dxf"
                    errors = write_stock_dxf(path, sheet, r, job, job.group_info[key], config.spec.output.layers,
                                             scale)
                    r.figures.setdefault("dxf_audit_errors", {})[sheet.id] = errors
                    written.append(path)
                if png:
                    path = out_dir / f"{name}.png"
                    row = next(x for x in r.figures["sheets"] if x["sheet"] == sheet.id)
                    layout_png(path, sheet.width, sheet.length,
                               [(f"{p.item}#{p.copy + 1}", p.place(r.items[p.item].outline))
                                for p in sheet.placements],
                               f"{style} {key} plate {sheet.id} ({sheet.stock}): utilisation "
                               f"{100 * row['utilisation']:.1f}%", units, r.edge_margin)
                    written.append(path)
        path = out_dir / f"{style}_cutting_list.csv"
        write_text(path, cutting_list_csv(results, job, scale))
        written.append(path)
        if config.spec.nesting.remnants is not None:
            from .remnants import inventory_csv

            path = out_dir / f"{style}_remnants.csv"
            write_text(path, inventory_csv(remnant_inventory(results, job, config), scale))
            written.append(path)
    path = out_dir / f"{style}_nesting.json"
    report = nesting_report(results, job, config, [p.name for p in written] + [path.name])
    write_text(path, json.dumps(sanitize(report), indent=1, default=_json_default, allow_nan=False))
    written.append(path)
    return written


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(type(obj).__name__)


def summary_lines(results: dict[str, NestResult], job: NestJob, units: str) -> list[str]:
    lines = []
    for key, r in results.items():
        if r.kind == "marker":
            f = r.figures
            lines.append(f"marker: {f['pieces']} pieces, length {f['marker_length']:.1f} {units} on a roll "
                         f"{f['fabric_width']:g} {units} wide, efficiency {100 * f['efficiency']:.1f}%")
        else:
            f = r.figures
            lines.append(f"{key}: {f['plates']} stock plate(s), utilisation {100 * f['utilisation']:.1f}%")
            for row in f["sheets"]:
                lines.append(f"  {row['sheet']} {row['stock']}: {len(row['parts'])} part(s), "
                             f"{100 * row['utilisation']:.1f}%  {' '.join(row['parts'])}")
            kept = f.get("remnants")
            if kept is not None:
                lines.append(f"  remnants used: {', '.join(kept['used']) or 'none'}; kept: "
                             + (", ".join(f"{o['remnant']} {o['width']:g} x {o['length']:.0f} {units} "
                                          f"(from {o['sheet']})" for o in kept["offcuts"]) or "none"))
        checks = r.checks
        lines.append(f"  check: {'passed' if checks['passed'] else 'FAILED'} (max outside {checks['max_outside']:.3g}, "
                     f"min gap {checks['min_gap']:.4g} for spacing {checks['spacing']:g}, "
                     f"area error {checks['max_area_error_relative']:.2g}); engine {r.engine.get('seconds', 0):.1f} s")
        for u in r.unplaced:
            lines.append(f"  NOT PLACED: {u['item']} x{u['copies']}: {u['reason']}")
    for f in job.failed:
        lines.append(f"  NOT NESTED (part failed): {f['part']}: {f['reason']}")
    return lines


# ------------------------------------------------------------------ command
def _previous_files(out: Path, config: RunConfig) -> list[str]:
    """The files an earlier nesting of this config wrote into ``out`` (its report lists them):
    sheets it had and this run has not are stale."""
    style = config.spec.name or config.source.stem
    try:
        files = json.loads((out / f"{style}_nesting.json").read_text(encoding="utf-8"))["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    return [f for f in files if isinstance(f, str) and f.startswith(style)] if isinstance(files, list) else []


def command_nest(args) -> int:
    """Run the parts, nest them, write the nesting files. Exit 0 all placed and checked,
    1 a part failed or could not be placed or a check failed, 2 bad input (nothing written)."""
    from ..hull.plates import evaluate_plate, run_part
    from ..outdir import OutputFolder
    from ..validate import check_jobs, validate

    check_jobs(args.jobs)
    config = validate(args.config, evaluate_plate)
    spec = config.spec.nesting
    if spec is None:
        raise ConfigError(f"{args.config}: nesting: missing: `devflat nest` needs a nesting section "
                          "(fabric_width for textile, stock for steel)")
    updates = {k: v for k, v in (("time", args.time), ("seed", args.seed), ("workers", args.workers)) if v is not None}
    for key, value in updates.items():
        if value < (1 if key != "seed" else 0):
            raise ConfigError(f"--{key} {value}: must be >= {1 if key != 'seed' else 0}")
    if updates:
        spec = spec.model_copy(update=updates)
        config.spec = config.spec.model_copy(update={"nesting": spec})
    check_quantities(config)
    inventory = []
    if spec.remnants is not None and spec.remnants.inventory is not None:
        from .remnants import read_inventory

        inventory = read_inventory(config.source.parent / spec.remnants.inventory, config.mm_per_unit)
    parts = config.parts
    if args.jobs > 1 and len(parts) > 1:
        from concurrent.futures import ProcessPoolExecutor
        from functools import partial

        with ProcessPoolExecutor(max_workers=args.jobs) as pool:
            results = list(pool.map(partial(run_part, config=config), parts))
    else:
        results = [run_part(p, config) for p in parts]
    job = build_job(results, config)
    job.inventory = inventory
    bar = None
    progress = None
    if not args.quiet and args.replay is None:
        from tqdm import tqdm

        bar = tqdm(total=spec.time, unit="s", file=sys.stderr, desc="nesting",
                   bar_format="{desc}: {bar} {n:.0f}/{total} s{postfix}")

        def progress(elapsed, best):
            bar.n = min(elapsed, spec.time)
            if isinstance(best, str):
                bar.set_postfix_str(best, refresh=False)
            elif math.isfinite(best):
                bar.set_postfix_str(f"length {best:.1f}", refresh=False)
            bar.refresh()
    try:
        if args.replay is not None:
            results_by_group = replay_job(job, config, args.replay)
        else:
            results_by_group = run_job(job, config, progress)
    finally:
        if bar is not None:
            bar.close()
    with OutputFolder(args.out, config) as folder:
        written = write_outputs(results_by_group, job, config, folder.run_folder)
        folder.commit_files(folder.run_folder, [p.name for p in written], _previous_files(args.out, config))
    if not args.quiet:
        print("\n".join(summary_lines(results_by_group, job, config.spec.units)))
    ok = all(r.success for r in results_by_group.values()) and not job.failed
    return 0 if ok else 1
