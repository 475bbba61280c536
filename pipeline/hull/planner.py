"""Seam and butt planning for a whole hull (``strake.plan``).

uniform : girth seams (iso-parameter curves along the hull) at equal girth spacing at the
          widest section, so that every strake is at most ``stock.max_width`` wide; butt
          planes x = const equally spaced, so that every plate is at most ``max_length`` long;
          the plates at either end are closed by the hull's end (stem, stern).
adaptive : the uniform layout, then every plate that is neither flat nor devflat's strip
          (fitting the hull within the tolerance and covering its region) is split in two
          where and across the way the misfit is (pipeline/hull/splitting.py: a butt plane x = X
          or a new seam at a girth fraction, chosen so that the largest share of the plate is
          expected to fit), as long as both halves stay above ``stock.min_length`` x
          ``stock.min_width``, up to ``max_splits`` times; a plate stops splitting as soon as
          it fits. Splits are local (staggered butts, drop strakes): a plate's neighbours keep
          their seams. A patch development within the tolerance does not stop the splitting:
          only flat and strip plates count as fitting here. A plate larger than the stock is
          split whatever its class, across its excess when it fits; before it is evaluated
          when its coarse grid shows it (:func:`_within_stock`; not under the yard's rules).

With ``plan.objective`` (:mod:`.objective`) the splits are chosen for it: best flat/strip area
per weld metre first within a weld budget, or by a weighted cost; the layout then follows the
yard's rules (:mod:`.yardrules`: staggered butts, stealers at the ends), as it does with
``butt_stagger`` or ``block_joints`` alone: a butt split keeps both the stagger and the
minimum width, and a girth split's seam keeps the stagger from the seams ending on its butts
(no cross joints).

The evaluator (``evaluate(part) -> result``, or an object with ``many(parts) -> results``) is
given by the caller, so the plan knows no stage; each depth (or round) of candidate plates is
handed to it as one batch, which a caller spreads over worker processes and caches
(``pipeline/runner.py``: :class:`PlateEvaluator`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from flatten.closest import SurfaceDistance
from flatten.patch import region_grid
from flatten.plane import Plane

from .region import Girth, load_plan_surfaces, long_axis_of, plate_part, seam_curve
from .seamlines import least_curvature_seams
from .sewing import overlap_cuts
from .sheets import Sheets, development_need
from .objective import PlanPoint, PlanRecord, split_priority, worth
from .splitting import choose_split, estimate, sample_region
from .yardrules import (SeamRule, YardRule, butt_rule, plate_corners, seam_rule, seam_sides, stagger_of, yard_layout,
                        yard_rules_on)


def girth_lengths(surface, axis: int, s_values: np.ndarray, n: int = 201) -> tuple[np.ndarray, np.ndarray]:
    """Cumulative girth arc length (len(s_values), n) along iso-s curves and the g samples (n,)."""
    gdom = surface.domain_v if axis == 0 else surface.domain_u
    g = np.linspace(*gdom, n)
    pts = surface.grid(s_values, g) if axis == 0 else surface.grid(g, s_values).transpose(1, 0, 2)
    seg = np.linalg.norm(np.diff(pts, axis=1), axis=2)
    return np.concatenate([np.zeros((len(s_values), 1)), np.cumsum(seg, axis=1)], axis=1), g


def uniform_layout(surface, axis: int, stock, x_limits: tuple = (None, None)) -> tuple[list[float], list[float], float]:
    """Girth seam values (iso-g), interior butt positions x, and the widest section's s;
    ``x_limits``: (lo, hi) where the face is cut (None: its own end), butts lie between."""
    sdom = surface.domain_u if axis == 0 else surface.domain_v
    s = np.linspace(*sdom, 41)
    cum, g = girth_lengths(surface, axis, s)
    widest = int(np.argmax(cum[:, -1]))
    total = cum[widest, -1]
    s_widest = float(s[widest])
    n_strakes = max(1, int(np.ceil(total / stock.max_width - 1e-9)))
    seams = equal_girth_seams(cum[widest], g, n_strakes)
    x0, x1 = x_range(surface, x_limits)
    n_butts = max(1, int(np.ceil((x1 - x0) / stock.max_length - 1e-9)))
    butts = list(np.linspace(x0, x1, n_butts + 1)[1:-1])
    return [float(v) for v in seams], [float(x) for x in butts], s_widest


def equal_girth_seams(cum: np.ndarray, g: np.ndarray, n_strakes: int) -> list[float]:
    """Girth values of ``n_strakes`` strakes of equal girth along one section: its
    cumulative girth length (n,) at the girth samples g (n,); the first and last are the
    section's ends."""
    seams = [float(v) for v in np.interp(np.linspace(0, cum[-1], n_strakes + 1), cum, g)]
    seams[0], seams[-1] = float(g[0]), float(g[-1])
    return seams


def region_size(surface, axis: int, girths, planes) -> tuple[float, float, float, float]:
    """(length, width, x_min, x_max) of a plate's region from a coarse grid of it; zeros when empty."""
    grid = region_grid(surface, axis, girths[0], girths[1], [None if p is None else p.as_tuple() for p in planes],
                       7, 17, probe=160)
    if grid is None:
        return 0.0, 0.0, 0.0, 0.0
    p = grid.points
    length = float(np.linalg.norm(np.diff(p, axis=1), axis=2).sum(axis=1).max())
    width = float(np.linalg.norm(np.diff(p, axis=0), axis=2).sum(axis=0).max())
    return length, width, float(p[..., 0].min()), float(p[..., 0].max())


def trimmed_size(surface, axis: int, girths, planes, trim) -> tuple[float, float, float]:
    """(share of the area inside ``trim``, length, width) of a plate region's part inside the
    surface's trim, the plate the shop cuts (a 17 x 49 grid of the region; model units, the
    longest row's and the widest column's length inside); zeros when the region misses it."""
    from .cost import PlateEdges

    grid = region_grid(surface, axis, girths[0], girths[1], [None if p is None else p.as_tuple() for p in planes],
                       17, 49, probe=160)
    if grid is None:
        return 0.0, 0.0, 0.0
    p = grid.points
    # area per grid point: the product of its half-neighbour spacings along and across
    ds = np.gradient(np.concatenate([np.zeros((p.shape[0], 1)), np.cumsum(
        np.linalg.norm(np.diff(p, axis=1), axis=2), axis=1)], axis=1), axis=1)
    dg = np.gradient(np.concatenate([np.zeros((1, p.shape[1])), np.cumsum(
        np.linalg.norm(np.diff(p, axis=0), axis=2), axis=0)], axis=0), axis=0)
    weight = ds * dg
    inside = trim.inside(grid.params[..., 0], grid.params[..., 1])
    total = float(weight.sum())
    share = float(weight[inside].sum()) / total if total > 0 else 0.0
    if share <= 0.0:
        return 0.0, 0.0, 0.0
    edges = PlateEdges("", p, grid.params)
    return share, float(edges.lengths(trim).max()), float(edges.widths(trim).max())


def plate_class(result) -> str:
    figures = getattr(result, "figures", {}) or {}
    return (figures.get("plate_class") or {}).get("class", "failed")


def honest_class(result) -> str:
    """flat, developable (devflat's strip between the seams fits and covers the region),
    formed (anything else: a patch development counts as formed here, whatever its misfit)
    or failed. The adaptive plan splits every plate that is not flat or developable."""
    if not getattr(result, "ok", False):
        return "failed"
    klass = (getattr(result, "figures", {}) or {}).get("plate_class") or {}
    name = klass.get("class", "failed")
    if name == "developable" and not is_strip(klass):
        return "formed"
    return name


def is_strip(klass: dict) -> bool:
    """The class record says the plate is devflat's strip (not a patch development)."""
    method = str(klass.get("method", ""))
    return "strip" in method and not method.startswith("isometric") and "patch" not in method


@dataclass
class Cell:
    """A candidate plate: surface ``k``, name, seams (Girth pair) and their names, butt planes,
    split depth; its part and result once built and evaluated."""

    k: int
    name: str
    girths: tuple
    seam_names: tuple
    pair: tuple
    depth: int
    part: object = None
    result: object = None
    settled: str = ""  # why it is split no further (the plan record's "stopped")
    parent: object = None  # the cell it was split from (an objective's plan may undo the split)
    weld_m: float = 0.0  # the weld its split from the parent added (m)
    split: object = None  # the split the plan took of it
    tried: tuple = ()  # the kinds of split taken of it and given up (an objective's plan)
    merged: str = ""  # the sliver of its face's trim the layout merged into it (:mod:`.trimslivers`)
    size: tuple = (0.0, 0.0)  # (length, width) of its region on a coarse grid when built (model units)
    order: tuple = ()  # its place in the layout: the cell's index there, then each split's half (0, 1)
    # held by a fit-up of this plan made before, where it lost its flat or strip class
    # (:mod:`.replan`): it does not fit
    lost: bool = False
    area_of: tuple = (None, 0.0)  # (result, its shell area m^2): :func:`_area`'s, while that is the result


@dataclass
class _Face:
    """What the plan knows of one surface while it plans it."""

    surface: object
    axis: int
    trim: object
    note: str
    limits: tuple


def plan_hull(spec, path, mm_per_unit: float, lines: dict, evaluate=None, record: PlanRecord | None = None,
              fairings: list | None = None, lost: frozenset | None = None) -> list:
    """The plates of a planned hull. ``evaluate``: ``evaluate(part) -> result``, or an object
    whose ``many(parts)`` evaluates a batch (spread over workers, cached); ``record``: filled
    with what an adaptive plan evaluated; ``fairings``: filled with what ``plan.overlaps:
    fair`` and ``plan.junctions: fair`` did (:class:`.fairing.Fairing`, as dicts); ``lost``:
    (name, region) of the plates a fit-up of this plan made before held and delivered neither
    flat nor a strip (:func:`.replan.lost_plates`): planned as plates that do not fit."""
    lost = lost or frozenset()
    lost_names = {name for name, _ in lost}
    strake = spec.strake
    plan = strake.plan
    sources = [strake.surface] + list(plan.surfaces)
    planned = load_plan_surfaces(sources, path.parent, mm_per_unit, strake.scale)
    loaded = [(p.surface, p.trim, p.note) for p in planned]
    surfaces = [s for s, _, _ in loaded]
    resolution = float(strake.patch_spacing or 200.0 / mm_per_unit)
    stock = plan.stock
    multi = len(surfaces) > 1
    tolerance = float(strake.fit_tolerance or 5.0 / mm_per_unit)
    yard = yard_rules_on(plan)
    stagger = stagger_of(plan, mm_per_unit)
    # faces that lie on each other are cut at a transverse plane, each keeping one side (a
    # shell's faces beyond its loft keep the side its end plane gives them)
    free = [k for k, p in enumerate(planned) if not p.fixed]
    cut, overlaps = overlap_cuts([surfaces[k] for k in free], [loaded[k][1] for k in free], tolerance) \
        if len(free) > 1 else ([(None, None)] * len(free), [])
    overlaps = [replace(o, faces=tuple(free[i] for i in o.faces)) for o in overlaps]
    limits = [p.x_limits for p in planned]
    for k, lim in zip(free, cut):  # the tighter of a loft's own ends and an overlap's cut
        limits[k] = tuple(a if b is None else b if a is None else pick(a, b)
                          for a, b, pick in zip(limits[k], lim, (max, min)))
    faired = []
    if plan.overlaps == "fair" and overlaps:
        from .fairing import fair_overlaps

        surfaces, faired = fair_overlaps(surfaces, overlaps, limits, tolerance)
        if fairings is not None:
            fairings.extend(f.as_dict(mm_per_unit) for f in faired)
    if plan.junctions == "fair" and multi:
        from .fairing import fair_junctions

        overlapping = frozenset(frozenset(o.faces) for o in overlaps)
        surfaces, joined = fair_junctions(surfaces, [trim for _, trim, _ in loaded], limits, tolerance, overlapping)
        faired = faired + joined
        if fairings is not None:
            fairings.extend(f.as_dict(mm_per_unit) for f in joined)
    distance = SurfaceDistance(surfaces)  # after any fairing: the plates measure the faces they lie on
    faces, cells, laid = [], [], []
    for k, surface in enumerate(surfaces):
        axis = long_axis_of(surface)
        seams, butts, s_widest = uniform_layout(surface, axis, stock, limits[k])
        junction_note = ""
        if yard and plan.seams != "least_curvature":
            seams, junction_note = _meet_earlier_faces(k, surface, axis, seams, s_widest, laid, limits, stagger,
                                                       stock, tolerance, mm_per_unit)
        if plan.seams == "least_curvature":
            seam_lines = least_curvature_seams(surface, axis, seams, s_widest)
        else:
            seam_lines = [Girth.iso(g) for g in seams]
        laid.append((surface, axis, seam_lines))
        cut_note = "; ".join(f"faces {o.faces[0] + 1} and {o.faces[1] + 1} overlap over x {o.x_range_mm[0]:.0f}.."
                             f"{o.x_range_mm[1]:.0f} ({o.median_distance_mm:.3g} apart, median): cut at x = "
                             f"{o.cut_x_mm:.0f}, step {o.step_at_cut_mm:.3g} there" for o in overlaps if k in o.faces)
        cut_note = "; ".join(n for n in [cut_note] + [f.note(mm_per_unit) for f in faired if k in (f.face, f.onto)]
                             + [junction_note] if n)
        faces.append(_Face(surface, axis, loaded[k][1], "; ".join(n for n in (loaded[k][2], cut_note) if n),
                           limits[k]))
        prefix = f"{spec.name}_P{k + 1}" if multi else spec.name
        names = [f"SEAM {i + 1}" for i in range(len(seam_lines))]
        if yard:
            x0, x1 = x_range(surface, limits[k])

            def width_of(lo, hi, a, b, surface=surface, axis=axis, seam_lines=seam_lines):
                return region_size(surface, axis, (seam_lines[lo], seam_lines[hi]), (_plane(a), _plane(b)))[1]

            layout = yard_layout(len(seams) - 1, x0, x1, limits[k], stock, stagger, plan.block_joints, width_of)
            merged = {}
            if loaded[k][1] is not None:
                layout, merged = _trim_slivers_merged(layout, surface, axis, seam_lines, loaded[k][1], stock, stagger,
                                                      plan.block_joints, (x0, x1), prefix, names, mm_per_unit)
            for lo, hi, xs, j in layout:
                name = f"{prefix}_{_strakes_label(lo, hi)}_B{j:02d}"
                cells.append(Cell(k, name, (seam_lines[lo], seam_lines[hi]), (names[lo], names[hi]),
                                  (_plane(xs[0]), _plane(xs[1])), 0, merged=merged.get((lo, hi, j), "")))
            continue
        ends = [None if x is None else Plane((1.0, 0.0, 0.0), x) for x in limits[k]]
        planes = [ends[0]] + [Plane((1.0, 0.0, 0.0), x) for x in butts] + [ends[1]]
        for i in range(len(seams) - 1):
            for j in range(len(planes) - 1):
                cells.append(Cell(k, f"{prefix}_S{i + 1:02d}_B{j + 1:02d}", (seam_lines[i], seam_lines[i + 1]),
                                  (names[i], names[i + 1]), tuple(planes[j:j + 2]), 0))

    # a seam's curve and its crossings with the butt planes are shared by the plates of the
    # strakes on either side and by their halves: each is made once per plan
    seam_curves: dict = {}  # (face, girth) -> its seam curve (named for the first plate that asked)
    crossings: dict = {}  # (seam curve, plane) -> parameters (region.extended_segment)

    def seam_of(cell: Cell, side: int):
        key = (cell.k, cell.girths[side])
        if key not in seam_curves:
            face = faces[cell.k]
            seam_curves[key] = seam_curve(face.surface, face.axis, key[1], f"{cell.name}.{cell.seam_names[side]}")
        return seam_curves[key]

    def build(cell: Cell):
        """The cell's part, or None when its region misses the surface or its trim."""
        face = faces[cell.k]
        length, width, xa, xb = region_size(face.surface, face.axis, cell.girths, cell.pair)
        cell.size = (length, width)
        if length <= 0:
            return None  # the region misses this surface (e.g. a butt beyond a short strake)
        butt_names = tuple("HULL END" if p is None else f"BUTT X{p.offset:.0f}" for p in cell.pair)
        curves = [seam_of(cell, side) for side in (0, 1)]
        inside = 1.0
        if face.trim is not None:
            inside, cut_length, cut_width = trimmed_size(face.surface, face.axis, cell.girths, cell.pair, face.trim)
            if inside < 1.0:
                cell.size = (cut_length, cut_width)  # the stock holds the part the shop cuts
        if inside <= 0.0:
            return None  # wholly outside the surface's trim: not shell (another surface covers it)
        part = plate_part(cell.name, face.surface, face.axis, cell.girths, curves, cell.pair, spec.steel, strake,
                          distance, cell.seam_names, butt_names, resolution, face.note, crossings)
        part.hull.inside_trim = inside
        part.hull.trim = face.trim if inside < 1.0 else None
        part.hull.x_limits = face.limits
        part.hull.face_trim = face.trim
        cell.part = part
        if cell.name in lost_names:  # (the same name may be another region: a neighbour's split moved its butts)
            from .replan import region_key

            cell.lost = (cell.name, region_key(part.hull)) in lost
        return part

    if plan.method == "uniform" or evaluate is None:
        return [c.part for c in cells if build(c) is not None]
    many = getattr(evaluate, "many", None) or (lambda parts: [evaluate(p) for p in parts])
    spread = (getattr(evaluate, "map_each", None) or getattr(evaluate, "map", None)
              or (lambda func, items: (func(item) for item in items)))
    record = record if record is not None else PlanRecord()
    develop = getattr(evaluate, "developed", None)
    sheets = Sheets.of_shop(spec.shop) if develop is not None else None
    context = _Context(faces, plan, stock, tolerance, many, record, mm_per_unit, yard, stagger, spread, develop,
                       sheets, getattr(evaluate, "remembered", None))
    if plan.objective is None:
        kept = _split_all(cells, build, context)
    else:
        kept = _split_for(cells, build, context)
    kept = _onto_sheets(kept, build, context)
    return [c.part for c in sorted(kept, key=lambda c: c.k)]  # stable: each face's plates in plan order


def _strakes_label(lo: int, hi: int) -> str:
    return f"S{lo + 1:02d}" if hi == lo + 1 else f"S{lo + 1:02d}-{hi:02d}"


def _trim_slivers_merged(layout: list, surface, axis: int, seam_lines: list, trim, stock, stagger: float, joints,
                         extent: tuple, prefix: str, names: list, mm_per_unit: float) -> tuple[list, dict]:
    """A trimmed face's yard layout with the plates its trim cuts to slivers merged into a
    neighbour (:mod:`.trimslivers`), and a note for each merged plate by (lo, hi, B number)."""
    from .trimslivers import merge_slivers

    def cut_size(lo, hi, a, b):
        return trimmed_size(surface, axis, (seam_lines[lo], seam_lines[hi]), (_plane(a), _plane(b)), trim)[1:]

    layout, merges = merge_slivers(layout, cut_size, stock, stagger, joints or (), extent)
    notes = {}
    for m in merges:
        lo, hi = min(m.sliver[0], m.into[0]), max(m.sliver[1], m.into[1])
        sliver = f"{prefix}_{_strakes_label(*m.sliver[:2])}_B{m.sliver[4]:02d}"
        how = ("along its strake, the butt between them dropped" if m.how == "along" else
               f"across {names[m.into[0] if m.into[0] == m.sliver[1] else m.sliver[0]]}, which ends at its butts "
               "(a drop strake)")
        key = (lo, hi, m.into[4])
        notes[key] = "; ".join(n for n in (notes.get(key), (
            f"took {sliver}, {m.width * mm_per_unit:.0f} mm wide inside the face's trim, {how}: "
            f"{m.merged_width * mm_per_unit:.0f} mm wide inside it")) if n)
    return layout, notes


def _meet_earlier_faces(k: int, surface, axis: int, seams: list, s_widest: float, laid: list, limits: list,
                        stagger: float, stock, tolerance: float, mm_per_unit: float) -> tuple[list, str]:
    """Face ``k``'s seams moved to meet, or keep the stagger from, the seam ends of the faces
    laid before it at the planes where they are cut together (:mod:`.faceseams`), and a note
    of the moves for its plates."""
    from .faceseams import meet_at_junctions, seam_crossings, shared_planes

    planes = shared_planes(limits, k)
    if not planes:
        return seams, ""
    # each plane once, with the seam ends of every earlier face cut there
    ends = [(x, np.concatenate([seam_crossings(*laid[j], x) for j, at in planes if at == x]))
            for x in dict.fromkeys(x for _, x in planes)]
    cum, g = girth_lengths(surface, axis, np.array([s_widest]))

    def meet(values):
        return meet_at_junctions(surface, axis, values, lambda v: np.interp(v, g, cum[0]), ends, stagger,
                                 stock.max_width, 10.0 * tolerance)

    moved, moves, left = meet(seams)
    added = ""
    if left:
        # the strakes are too near the stock's width for a seam to move: one strake more
        # (equal girth at the widest section, as the uniform layout lays them) leaves room
        more = equal_girth_seams(cum[0], g, len(seams))
        again = meet(more)
        if again[2] < left:
            (moved, moves, left), added = again, f"one strake more ({len(more) - 1}) to meet them"
    if not moves and not added:
        return seams, ""
    where = ", ".join(f"x = {x * mm_per_unit:.0f}" for x in sorted(x for x, _ in ends))
    told = [added] if added else []
    told += [f"SEAM {m.seam + 1} {m.how} ({m.gap * mm_per_unit:.0f} mm from a seam end there before)" for m in moves]
    told += [f"{left} seams left within the stagger (no room within the stock's width)"] if left else []
    return moved, f"seams laid to the seam ends at the face junction {where}: " + "; ".join(told)


def _plane(x):
    return None if x is None else Plane((1.0, 0.0, 0.0), float(x))


def x_range(surface, x_limits: tuple) -> tuple[float, float]:
    """The x range the face's plates span: its own extent within the cuts (model units)."""
    pts = surface.grid(np.linspace(*surface.domain_u, 65), np.linspace(*surface.domain_v, 65))
    x0, x1 = float(pts[..., 0].min()), float(pts[..., 0].max())
    x0 = x0 if x_limits[0] is None else max(x0, x_limits[0])
    x1 = x1 if x_limits[1] is None else min(x1, x_limits[1])
    return x0, x1


@dataclass
class _Context:
    faces: list
    plan: object
    stock: object
    tolerance: float
    many: object
    record: PlanRecord
    mm_per_unit: float
    yard: bool
    stagger: float
    spread: object  # spread(func, items): func over items on the evaluator's workers, the answers in order
    develop: object = None  # develop(results): the results with their owed developments done
    sheets: Sheets | None = None  # the stock sheets the kept plates' developments must fit
    # each split job's answer (:func:`_spread_remembered`), kept for the plans a run makes
    # after this one (``plan.replan_held``), or None
    remembered: dict | None = None


def _evaluate(cells: list, build, ctx: _Context) -> list:
    """Build and evaluate the cells in one batch; the cells that are plates, in order."""
    return _evaluate_built([c for c in cells if build(c) is not None], ctx)


def _evaluate_built(built: list, ctx: _Context) -> list:
    """Evaluate built cells (their parts made) in one batch; the cells, in order."""
    results = ctx.many([c.part for c in built])
    ctx.record.evaluations += len(built)
    for cell, result in zip(built, results):
        cell.result = result
        cell.part.hull.result = result
    return built


def _fits(cell: Cell) -> bool:
    return not cell.lost and honest_class(cell.result) in ("flat", "developable")


def _excess(length: float, width: float, stock) -> tuple:
    """The kinds of split a plate of that size asks for: girth when it is wider than
    ``stock.max_width``, length when longer than ``max_length``; () when it fits the stock."""
    slack = 1.0 + 1e-9
    return tuple(kind for kind, size, limit in (("girth", width, stock.max_width), ("length", length, stock.max_length))
                 if size > limit * slack)


def _oversize(cell: Cell, stock) -> tuple:
    """:func:`_excess` of an evaluated plate (its region's widest girth and longest length). A
    strake laid at the hull's widest section can be wider elsewhere (iso-parameter seams:
    KVLCC2's stern plates 5.1 m wide of a 4 m stock). A plate past its face's trim: its part
    inside the trim (:func:`trimmed_size`), which the shop cuts."""
    if getattr(cell.part.hull, "trim", None) is not None:
        return _excess(*cell.size, stock)
    region = (getattr(cell.result, "figures", None) or {}).get("region") or {}
    return _excess(region.get("length", 0.0), region.get("width", 0.0), stock)


def _coarse_oversize(cell: Cell, stock) -> tuple:
    """:func:`_excess` from the region's coarse size when built (before any evaluation): its
    chords are no longer than the region's arcs, so a plate it finds larger than the stock is
    larger (one it misses is found once evaluated)."""
    return _excess(*cell.size, stock)


def _within_stock(wave: list, build, ctx: _Context) -> tuple[list, float]:
    """The cells of a wave, each one larger than the stock (:func:`_coarse_oversize`) split
    before it is evaluated (:func:`_stock_split`), as often as it must within the depth a
    plate larger than the stock may reach (:func:`_may_split`): no sheet holds it, whatever
    its class, so its evaluation would be spent (KVLCC2: 457 of 1622 candidates, its strakes
    laid at the widest section widening to 5.2 m toward the ends). Its halves take one depth
    more, as when it is split once evaluated. Returns the cells and the metres of weld the
    splits add."""
    out, weld, limit = [], 0.0, ctx.plan.max_splits + STOCK_SPLITS
    while wave:
        kinds = [_coarse_oversize(c, ctx.stock) if c.depth < limit else () for c in wave]
        out += [c for c, k in zip(wave, kinds) if not k]
        over = [(c, k) for c, k in zip(wave, kinds) if k]
        wave = []
        jobs = [(_split_job(c, ctx), k, c.depth >= ctx.plan.max_splits) for c, k in over]
        for (cell, _), split in zip(over, _spread_remembered(_stock_split, [c for c, _ in over], jobs, ctx)):
            halves = [] if split is None else [h for h in _children(cell, split) if build(h) is not None]
            if not halves:
                out.append(cell)  # no split keeps the minimum sizes: evaluated, and settled as before
                continue
            weld += split.weld * ctx.mm_per_unit / 1000.0
            ctx.record.splits_taken += 1
            wave += halves
    return out, weld


def _area(cell: Cell) -> float:
    # read each round for every plate's share (KVLCC2's plan: 2.5 CPU s of its own process)
    if cell.area_of[0] is not cell.result or cell.result is None:
        from .hullplots import shell_area

        cell.area_of = (cell.result, shell_area(cell.result))
    return cell.area_of[1]


def _share(cells) -> float:
    """The flat + strip share of the cells' area as the plan counts it (a plate lost at a
    fit-up before, :mod:`.replan`, counts as not fitting, as it was delivered)."""
    areas = [_area(c) for c in cells]
    total = sum(areas)
    return sum(a for a, c in zip(areas, cells) if _fits(c)) / total if total > 0 else 0.0


def _uniform_weld_m(cells, ctx: _Context) -> float:
    """Metres of weld between the plates of the starting layout (seams and butts, on the hull)."""
    from .cost import plate_edges, weld_lengths

    edges = [e for e in (plate_edges(c.name, c.part.hull, (17, 65)) for c in cells) if e is not None]
    w = weld_lengths(edges)
    return (w.seams + w.butts) * ctx.mm_per_unit / 1000.0


def _splits_under_rules(cells: list, sides, chosen: dict, ctx: _Context, leaves: list) -> dict:
    """{id(cell): its best split} under each cell's yard rule in the plan of ``leaves``
    (``sides``: its seams' sides; None: no rule). A cell's split
    depends on nothing else, so ``chosen`` keeps it while its rule stands (a plate not split
    this round asks again the next); the rest are chosen on the evaluator's workers, which
    sit idle between two batches of plates."""
    rules = _yard_rules(cells, leaves, sides, ctx)
    keys = [(id(c), rule, c.tried) for c, rule in zip(cells, rules)]
    missing = [(cell, key) for cell, key in zip(cells, keys) if key not in chosen]
    jobs = [_split_job(c, ctx, k[1]) for c, k in missing]
    for (cell, key), split in zip(missing, _spread_remembered(_region_split, [c for c, _ in missing], jobs, ctx)):
        chosen[key] = (cell, split)  # the cell stays referenced: its id is not reused
    return {key[0]: chosen[key][1] for key in keys}


def _yard_rules(cells: list, leaves: list, sides, ctx: _Context) -> list:
    """Each cell's :class:`.yardrules.YardRule` in the plan of ``leaves`` (None without the
    yard's rules: ``sides`` None)."""
    if sides is None:
        return [None] * len(cells)
    parts = [c.part for c in leaves]
    index = {id(part): k for k, part in enumerate(parts)}
    corners = plate_corners(parts)
    joints = ctx.plan.block_joints or ()
    return [YardRule(butt_rule(c.part, sides, ctx.stagger, joints),
                     seam_rule(index[id(c.part)], parts, corners, ctx.stagger, joints)) for c in cells]


SPLIT_KINDS = ("length", "girth")


def _untried(cell: Cell) -> tuple:
    """The kinds of split the plate may still be offered."""
    return tuple(kind for kind in SPLIT_KINDS if kind not in cell.tried)


def _retry(cell: Cell, kind: str, objective) -> bool:
    """Whether a plate whose ``kind`` of split did not pay is offered the other kind: under
    ``maximise`` (the weld comes back to the budget), once."""
    return objective.weights is None and any(k != kind for k in _untried(cell))


STOCK_SPLITS = 3  # splits beyond plan.max_splits that a plate larger than the stock may take


def _may_split(cell: Cell, oversize: tuple, max_splits: int) -> bool:
    """A plate that does not fit is split up to ``max_splits`` deep; one larger than the stock
    (``oversize``: :func:`_oversize`) also beyond that, by STOCK_SPLITS more (the stock is
    not a choice: a plate no sheet holds cannot be cut)."""
    if cell.depth < max_splits:
        return not _fits(cell) or bool(oversize)
    return bool(oversize) and cell.depth < max_splits + STOCK_SPLITS


def _stock_kinds(cell: Cell, oversize: tuple, max_splits: int) -> tuple | None:
    """The kinds of split a plate is offered: only across its excess when it is split for
    the stock alone (it fits, or it is past ``max_splits``); None: any untried kind."""
    return oversize if _fits(cell) or cell.depth >= max_splits else None


def _split_job(cell: Cell, ctx: _Context, allow=None, kinds: tuple | None = None) -> tuple:
    face = ctx.faces[cell.k]
    kinds = _untried(cell) if kinds is None else kinds
    return (face.surface, face.axis, cell.girths, cell.pair, ctx.tolerance, ctx.stock.min_length,
            ctx.stock.min_width, allow, ctx.yard, kinds)


def _spread_remembered(func, cells: list, jobs: list, ctx: _Context):
    """``func`` over the cells' ``jobs`` on the evaluator's workers (handed out now, the
    answers in order as they are read), each answer kept in ``ctx.remembered`` for any job
    asked again. A split job's answer depends on the job alone, and a plan made again
    (``plan.replan_held``) asks for most of its plates' splits again: the same regions, on
    the same faces (cell ``k``, read and faired alike in every plan of a run), under the
    same rules (the 160 m hull as shipped, three plans: the plan stage took 40.8 CPU s
    against 72.7 before, the same plans)."""
    if ctx.remembered is None:
        return ctx.spread(func, jobs)
    memo, asked = ctx.remembered, set()
    keys = [(func.__name__, cell.k, _without_surface(job)) for cell, job in zip(cells, jobs)]
    todo = [i for i, key in enumerate(keys) if key not in memo and not (key in asked or asked.add(key))]
    answers = iter(ctx.spread(func, [jobs[i] for i in todo]))
    first_asked = set(todo)

    def read():
        for i, key in enumerate(keys):
            if i in first_asked:
                memo[key] = next(answers)
            yield memo[key]

    return read()


def _without_surface(job: tuple) -> tuple:
    """A split job (:func:`_split_job`, or one holding it first) without its surface."""
    return (_without_surface(job[0]), *job[1:]) if isinstance(job[0], tuple) else job[1:]


def _region_split(job: tuple):
    """The best split of a region: job (surface, axis, girths, butt planes, tolerance, minimum
    length and width, :class:`.yardrules.YardRule` or None, strict width, kinds of split);
    module-level, so that the plan's workers can compute it (:func:`_splits_under_rules`,
    :func:`_split_all`)."""
    kinds = job[-1]
    return _splits_of(job, [kinds], False)[0] if kinds else None


def _sheet_split(job: tuple) -> list:
    """Each kind's best split (one per kind of the job's, None where there is none) of a
    plate that no stock sheet holds, from one sample of its region: a girth split may taper
    where the plate does (:func:`.splitting.choose_split`'s ``tapering``): the sheets are not
    a choice, and a half narrower than the stock where the whole is too narrow for two halves
    adds no sliver the plate did not have (DTMB 5415's stern plate tapers to a point)."""
    return _splits_of(job, [(kind,) for kind in job[-1]], True)


def _splits_of(job: tuple, kind_sets: list, tapering: bool) -> list:
    """:func:`.splitting.choose_split` of the job's region for each set of kinds of split."""
    surface, axis, girths, pair, tolerance, min_length, min_width, rule, strict, _ = job
    sample = sample_region(surface, axis, girths, pair)
    if sample is None:
        return [None] * len(kind_sets)
    butts, seams = (None, None) if rule is None else (rule.butts, rule.seams)
    return [choose_split(sample, tolerance, min_length, min_width, butts, strict, kinds, seams, tapering=tapering)
            for kinds in kind_sets]


def _stock_split(job: tuple):
    """The split of a plate larger than the stock chosen before it is evaluated: job (a
    :func:`_split_job`, the kinds of its excess, whether it is past ``max_splits``). As
    :func:`_stock_kinds` does once a plate is evaluated, it is split across its excess when it
    is expected to fit (the split estimate, :func:`.splitting.estimate`) or is past
    ``max_splits``, else wherever its misfit is."""
    (surface, axis, girths, pair, tolerance, min_length, min_width, _, strict, kinds), excess, past = job
    sample = sample_region(surface, axis, girths, pair)
    if sample is None:
        return None
    if past or estimate(sample, tolerance) <= tolerance:
        kinds = excess
    return choose_split(sample, tolerance, min_length, min_width, None, strict, kinds)


def _onto_sheets(kept: list, build, ctx: _Context) -> list:
    """The kept plates, each one whose development no stock sheet holds (:mod:`.sheets`)
    split until its halves are held, up to STOCK_SPLITS times. Both kinds of split are
    tried (each kind's best, :func:`.splitting.choose_split`; under the yard's rules one
    that keeps them) and judged by their halves' own developments (:func:`_sheet_rank`):
    the split whose halves a sheet holds, or else comes nearest to holding, then the one
    whose halves fit the hull over more area, then the shorter new weld (a length split
    shortens a long plate's bow, a girth split its girth; which one a sheet takes depends
    on the shape). A split that brings neither half nearer a sheet is not taken. Under the
    yard's rules the best split waits a round when it comes within the stagger of one
    taken in the same round. The plates are developed first (a formed plate's development
    is owed by its evaluation; a kept plate needs it anyway). A plate left on no sheet is
    kept, its record saying why, and the shop's stock check warns of it. The stock is not
    a choice: these splits may take an objective's plan past its weld budget."""
    if ctx.sheets is None or ctx.develop is None:
        return kept
    needs: dict = {}  # id(cell): what its development needs on a sheet (None: it has none)
    left: dict = {}  # id(cell): why it is split for the sheets no further
    taken: dict = {}  # id(cell): the splits for the sheets its lineage took
    weld, splits = 0.0, 0
    _developed(kept, ctx, needs)
    for _ in range(2 * STOCK_SPLITS):  # (a split that waits for a neighbour's loses a round)
        over = [c for c in kept if id(c) not in left and ctx.sheets.excess(needs[id(c)]) > 0.0]
        if not over:
            break
        sides = seam_sides([c.part for c in kept]) if ctx.yard else None
        rules = _yard_rules(over, kept, sides, ctx)
        jobs = [_split_job(c, ctx, rule, SPLIT_KINDS) for c, rule in zip(over, rules)]
        options = {}
        for cell, each_kind in zip(over, _spread_remembered(_sheet_split, over, jobs, ctx)):
            for split in each_kind:
                kids = [] if split is None else [h for h in _children(cell, split) if build(h) is not None]
                if len(kids) == 2:
                    options.setdefault(id(cell), []).append((split, kids))
        tried = [kid for opts in options.values() for _, kids in opts for kid in kids]
        _developed(_evaluate_built(tried, ctx), ctx, needs)
        halves, new_butts, new_ends = {}, {}, []
        for cell, rule in zip(over, rules):
            excess = ctx.sheets.excess(needs[id(cell)])
            ranked = sorted((_sheet_rank(o, needs, ctx), o) for o in options.get(id(cell), []))
            helping = [o for rank, o in ranked if rank[0] < excess - SHEET_GAIN_MM]
            if not helping:
                ruled = " and the yard's rules" if sides is not None else ""
                left[id(cell)] = (("no split within the minimum stock sizes" if not ranked
                                   else "no split brings its halves nearer a sheet") + ruled)
                continue
            split, kids = helping[0]
            if rule is not None:
                if _clash(cell, split, sides, new_butts, new_ends, rule, ctx):
                    continue  # chosen again next round, against the split it came near
                _claim(cell, split, new_butts, new_ends, ctx)
            for kid in kids:
                taken[id(kid)] = taken.get(id(cell), 0) + 1
                _settle(kid, "fits" if _fits(kid) else "split for a stock sheet (not for its fit)", ctx.plan.method)
                if taken[id(kid)] >= STOCK_SPLITS:
                    left[id(kid)] = f"{STOCK_SPLITS} splits for the sheets taken"
            halves[id(cell)] = kids
            weld += split.weld * ctx.mm_per_unit / 1000.0
            splits += 1
        kept = [k for c in kept for k in halves.get(id(c), [c])]
    for cell in kept:  # a plate left on no sheet says why (one still waiting: the splits it took)
        need = needs[id(cell)]
        if ctx.sheets.excess(need) > 0.0:
            why = left.get(id(cell), f"{taken.get(id(cell), 0)} splits for the sheets taken")
            _settle(cell, f"no stock sheet holds its development ({need[0]:.0f} x {need[1]:.0f} mm with margins): "
                    f"{why}", ctx.plan.method)
    if splits:
        ctx.record.splits_taken += splits
        last = ctx.record.points[-1]
        ctx.record.points[-1] = PlanPoint(last.round, last.plates, last.weld_m, last.flat_strip, False)
        ctx.record.add(last.round + 1, len(kept), last.weld_m + weld, _share(kept), True)
    return kept


SHEET_GAIN_MM = 1.0  # a split for the sheets must bring its worse half this much nearer a sheet


def _developed(cells: list, ctx: _Context, needs: dict) -> list:
    """The cells, their results' owed developments done (on the evaluator's workers), and
    what each development needs on a sheet in ``needs`` (by id(cell))."""
    for cell, result in zip(cells, ctx.develop([c.result for c in cells])):
        cell.result = cell.part.hull.result = result
        if cell.part.hull.plan is not None:  # a development that raised failed the plate
            cell.part.hull.plan["class_for_plan"] = honest_class(result)
        needs[id(cell)] = development_need(result, ctx.sheets, ctx.mm_per_unit)
    return cells


def _sheet_rank(option: tuple, needs: dict, ctx: _Context) -> tuple:
    """Smaller first: the worse half's distance from a sheet (:meth:`.sheets.Sheets.excess`;
    a half without a development as far as can be: a failed half is no remedy), then a
    larger share of the halves' area fitting the hull (to a hundredth, as
    :func:`.splitting.choose_split` ranks), then less weld."""
    split, kids = option
    worst = max(float("inf") if needs[id(k)] is None else ctx.sheets.excess(needs[id(k)]) for k in kids)
    return (round(min(worst, 1e12)), -round(_share(kids), 2), split.weld, split.kind, split.at)


def _children(cell: Cell, split) -> list[Cell]:
    if split.kind == "length":
        cut = Plane((1.0, 0.0, 0.0), split.at)
        halves = [Cell(cell.k, f"{cell.name}-1", cell.girths, cell.seam_names, (cell.pair[0], cut), cell.depth + 1),
                  Cell(cell.k, f"{cell.name}-2", cell.girths, cell.seam_names, (cut, cell.pair[1]), cell.depth + 1)]
    else:
        middle = cell.girths[0].between(cell.girths[1], split.at)
        label = f"{cell.seam_names[0]}+{round(100 * split.at)}%"
        halves = [Cell(cell.k, f"{cell.name}-1", (cell.girths[0], middle), (cell.seam_names[0], label), cell.pair,
                       cell.depth + 1),
                  Cell(cell.k, f"{cell.name}-2", (middle, cell.girths[1]), (label, cell.seam_names[1]), cell.pair,
                       cell.depth + 1)]
    for j, half in enumerate(halves):
        half.order = cell.order + (j,)
    return halves


def _settle(cell: Cell, why: str, method: str) -> Cell:
    """A plate the adaptive plan keeps, with why it stopped splitting (``part.hull.plan``, which
    the plate's JSON reports whatever result the fit-up delivers)."""
    if cell.part is not None:
        cell.part.hull.plan = {"depth": cell.depth, "class_for_plan": honest_class(cell.result), "method": method,
                               "stopped": why, **({"held_at_fit_up_before": True} if cell.lost else {}),
                               **({"merged_sliver": cell.merged} if cell.merged else {})}
    cell.settled = why
    return cell


def _split_all(cells: list, build, ctx: _Context) -> list:
    """Without an objective: every plate that does not fit (nor a plate larger than the stock:
    :func:`_oversize`) is split while it may, breadth
    first (each depth's plates evaluated as one batch, so the workers share them). The record
    gets the plan after each depth: the plates kept so far and that depth's plates whole.
    A depth's splits are chosen on the workers, and each split's halves are built here as
    soon as it is chosen, while the workers choose the next (they would wait for a whole
    depth built here one plate after another). With the yard's rules (``butt_stagger``,
    ``block_joints``) a butt split keeps the rule against the butts across its plate's seams
    and a girth split against the seams ending on its butts (:mod:`.yardrules`), and one that
    comes within the stagger of a butt or seam end another plate takes at the same depth
    waits (for the next pass, behind the new depth's plates), to be chosen again against it."""
    plan = ctx.plan
    kept, round_, weld, presplit = [], 0, None, 0.0
    for i, cell in enumerate(cells):
        cell.order = (i,)
    wave, waiting = [c for c in cells if build(c) is not None], []
    layout = list(wave)
    while wave or waiting:
        if not ctx.yard:  # (under the yard's rules a split waits for its neighbours': below)
            wave, more = _within_stock(wave, build, ctx)
            presplit += more
        built = _evaluate_built(wave, ctx) + waiting
        # a plate that fits but is larger than the stock is split too, across its excess
        oversize = {id(c): _oversize(c, ctx.stock) for c in built}
        splitting = [c for c in built if _may_split(c, oversize[id(c)], plan.max_splits)]
        sides = seam_sides([c.part for c in kept + built]) if ctx.yard else None
        rules = _yard_rules(splitting, kept + built, sides, ctx)
        # handed out before the weld and the record are computed, which the workers need not wait for
        chosen = _spread_remembered(_region_split, splitting, [
            _split_job(c, ctx, rule, _stock_kinds(c, oversize[id(c)], plan.max_splits)) for c, rule in zip(splitting, rules)],
            ctx)
        if weld is None:
            weld = ctx.record.uniform_weld_m = _uniform_weld_m(layout, ctx)
        weld, presplit = weld + presplit, 0.0
        ctx.record.add(round_, len(kept) + len(built), weld, _share(kept + built), False)
        splits, halves, new_butts, new_ends, waiting = {}, {}, {}, [], []
        for cell, split, rule in zip(splitting, chosen, rules):
            if split is not None and rule is not None:
                if _clash(cell, split, sides, new_butts, new_ends, rule, ctx):
                    waiting.append(cell)
                    continue
                _claim(cell, split, new_butts, new_ends, ctx)
            splits[id(cell)] = split
            if split is not None:  # built now, while the workers choose the next splits
                halves[id(cell)] = [half for half in _children(cell, split) if build(half) is not None]
        nxt = []
        for cell in built:
            fits = _fits(cell) and not oversize[id(cell)]
            if fits or not _may_split(cell, oversize[id(cell)], plan.max_splits):
                kept.append(_settle(cell, "fits" if fits else f"max_splits = {plan.max_splits}", plan.method))
                continue
            if id(cell) not in splits:
                continue  # waiting a depth
            split = splits[id(cell)]
            if split is None:
                ruled = " and the yard's rules" if sides is not None else ""
                larger = f" (larger than the stock: {' and '.join(oversize[id(cell)])})" if oversize[id(cell)] else ""
                kept.append(_settle(cell, f"no split keeps both halves within the minimum stock sizes{ruled}{larger}",
                                    plan.method))
                continue
            weld += split.weld * ctx.mm_per_unit / 1000.0
            ctx.record.splits_taken += 1
            nxt += halves[id(cell)]
        wave, round_ = nxt, round_ + 1
    last = ctx.record.points[-1]
    ctx.record.points[-1] = PlanPoint(last.round, last.plates, last.weld_m, last.flat_strip, True)
    if not ctx.yard:  # breadth first, as the depths were evaluated: a plate split before it was evaluated keeps its place
        kept.sort(key=lambda c: (c.depth, c.order))
    return kept


def _clash(cell: Cell, split, sides: dict, new_butts: dict, new_ends: list, rule, ctx: _Context) -> bool:
    """Whether ``split`` of ``cell`` comes within the stagger of what another plate's split
    took at the same depth: a new butt of a plate across its seams (``new_butts``:
    {id(part): x}; ``rule``: the cell's :class:`.yardrules.YardRule`) off a shared block
    joint, or a new seam's end (``new_ends``) off the block joints."""
    if split.kind == "girth":
        return not SeamRule(tuple(new_ends), ctx.stagger)(split.ends)
    for girth in cell.part.hull.girths:
        _, below, above = sides.get(id(girth), (None, [], []))
        for other in below + above:
            if other is cell.part or id(other) not in new_butts:
                continue
            if not replace(rule.butts, offsets=(new_butts[id(other)],))(split.at):
                return True
    return False


def _claim(cell: Cell, split, new_butts: dict, new_ends: list, ctx: _Context) -> None:
    """Record what a split takes, for :func:`_clash` of the splits after it."""
    if split.kind == "length":
        new_butts[id(cell.part)] = split.at
        return
    near = 1e-3 * ctx.stagger
    new_ends.extend(end for end in split.ends
                    if not any(abs(end[0] - j) <= near for j in (ctx.plan.block_joints or ())))


def _undo(leaves: list, objective, done: set, ctx: _Context, final: bool = False) -> tuple[list, float]:
    """Undo the look-ahead splits whose plates, all split as far as they will be (``final``:
    whatever their state), deliver no flat or strip area: the plate they came from comes back
    whole. Returns the leaves and the weld (m) given back."""
    refund = 0.0
    while True:
        families: dict = {}
        for cell in leaves:
            if cell.parent is not None:
                families.setdefault(id(cell.parent), (cell.parent, []))[1].append(cell)
        undone = False
        for parent, kids in families.values():
            if len(kids) != 2 or (not final and any(id(k) not in done for k in kids)) or any(_fits(k) for k in kids):
                continue  # a half still splitting, a half split further, or a half that pays
            first = leaves.index(kids[0])
            leaves = [c for c in leaves if c not in kids]
            leaves.insert(first, parent)
            parent.part.hull.result = parent.result
            if _retry(parent, parent.split.kind, objective):
                parent.tried += (parent.split.kind,)  # offered the other kind of split
            else:
                _settle(parent, "split undone by the objective (its halves did not pay for the weld)", ctx.plan.method)
                done.add(id(parent))
            refund += sum(k.weld_m for k in kids)
            ctx.record.splits_rejected += 1
            ctx.record.splits_taken -= 1
            undone = True
        if not undone:
            return leaves, refund


def _take(options: list, weld: float, budget: float, sides, leaves: list, ctx: _Context) -> tuple[list, float]:
    """The splits of ``options`` (in order) taken this round within the weld budget, and the
    weld (m) they reserve. A butt split's new butt is not yet in ``sides`` (the yard's seam
    sides): the plates across its seams wait a round. A girth split's new seam is not yet in
    the others' seam rules: one ending within the stagger of a seam taken this round waits."""
    taken, reserved, blocked, new_ends = [], 0.0, set(), []
    for _, _, cell, split, _, cost in options:
        if id(cell) in blocked or weld + reserved + cost > budget + 1e-9:
            continue
        if sides is not None and split.kind == "girth":
            if _clash(cell, split, sides, {}, new_ends, None, ctx):
                continue
            _claim(cell, split, {}, new_ends, ctx)
        taken.append((cell, split, cost))
        reserved += cost
        if split.kind == "length" and sides is not None:
            for girth in cell.girths:
                _, below, above = sides.get(id(girth), (None, [], []))
                for other in below + above:
                    blocked.update(id(c) for c in leaves if c.part is other)
    return taken, reserved


def _split_for(cells: list, build, ctx: _Context) -> list:
    """With an objective (:mod:`.objective`): rounds of splits, best first, within the weld
    budget or while they lower the weighted cost; each round's new plates evaluated as one
    batch; a split that does not pay once evaluated is undone."""
    plan, objective, metre = ctx.plan, ctx.plan.objective, ctx.mm_per_unit / 1000.0
    leaves = _evaluate(cells, build, ctx)
    weld = ctx.record.uniform_weld_m = _uniform_weld_m(leaves, ctx)
    budget = weld * objective.weld_factor if objective.weights is None else float("inf")
    ctx.record.weld_budget_m = budget if objective.weights is None else None
    ctx.record.add(0, len(leaves), weld, _share(leaves), False)
    done: set = set()  # ids of cells split no further
    chosen: dict = {}  # (id(cell), its butt rule, kinds tried): (cell, its best split under the rule)
    round_ = 0
    while True:
        round_ += 1
        sides = seam_sides([c.part for c in leaves]) if ctx.yard else None
        options = []
        for cell in leaves:
            if id(cell) in done:
                continue
            if _fits(cell):
                _settle(cell, "fits", plan.method)
                done.add(id(cell))
            elif cell.depth >= plan.max_splits:
                _settle(cell, f"max_splits = {plan.max_splits}", plan.method)
                done.add(id(cell))
        splits = _splits_under_rules([c for c in leaves if id(c) not in done], sides, chosen, ctx, leaves)
        for cell in leaves:
            if id(cell) in done:
                continue
            split = splits[id(cell)]
            if split is None:
                paid_not = f"{cell.tried[0]} split did not pay for its weld; no other " if cell.tried else "no "
                _settle(cell, f"{paid_not}split keeps both halves within the minimum stock sizes and the yard's rules",
                        plan.method)
                done.add(id(cell))
                continue
            gain, cost = split.fitting_share * _area(cell), split.weld * metre
            options.append((split_priority(objective, gain, cost), len(options), cell, split, gain, cost))
        options.sort(key=lambda o: (-o[0], o[1]))
        paying = [o for o in options if worth(objective, o[4], o[5]) > 0]
        taken, reserved = _take(paying, weld, budget, sides, leaves, ctx)
        if not taken and objective.weights is None:
            # no split expected to pay can be taken (none left, or none within the budget):
            # the budget left goes to splits expected to gain nothing, nearest to fitting
            # first; the estimate is coarse (a strip's verdict is the solve's) and a split
            # whose halves never pay is undone, its weld refunded
            hopeful = sorted(options, key=lambda o: (min(o[3].estimates), o[1]))
            taken, reserved = _take(hopeful, weld, budget, sides, leaves, ctx)
        if not taken:
            leaves, refund = _undo(leaves, objective, done, ctx, final=True)
            if refund <= 0:
                break
            weld -= refund  # weld given back: the budget may take splits it could not before
            ctx.record.add(round_, len(leaves), weld, _share(leaves), False)
            continue
        families = [(cell, split, cost, _children(cell, split)) for cell, split, cost in taken]
        _evaluate([child for *_, kids in families for child in kids], build, ctx)
        trial = []
        for cell in leaves:
            family = next((f for f in families if f[0] is cell), None)
            trial += [cell] if family is None else [k for k in family[3] if k.part is not None]
        ctx.record.add(round_, len(trial), weld + reserved, _share(trial), False)
        accepted = {}
        for cell, split, cost, kids in families:
            kids = [k for k in kids if k.part is not None]
            gained = sum(_area(k) for k in kids if _fits(k))
            # a split that gains nothing yet is kept while its halves may still split (the
            # plan looks ahead); undone at the end if its halves never pay (_undo)
            ahead = objective.weights is None and cell.depth + 1 < plan.max_splits and len(kids) == 2
            if kids and (worth(objective, gained, cost) > 0 or ahead):
                for kid in kids:
                    kid.parent, kid.weld_m = cell, cost / len(kids)
                cell.split = split
                accepted[id(cell)] = kids
                weld += cost
                ctx.record.splits_taken += 1
            else:
                cell.part.hull.result = cell.result
                ctx.record.splits_rejected += 1
                if _retry(cell, split.kind, objective):
                    cell.tried += (split.kind,)  # offered the other kind of split next round
                    continue
                _settle(cell, "split rejected by the objective (its halves did not pay for the weld)", plan.method)
                done.add(id(cell))
        leaves = [k for c in leaves for k in accepted.get(id(c), [c])]
        ctx.record.add(round_, len(leaves), weld, _share(leaves), False)
        leaves, refund = _undo(leaves, objective, done, ctx)
        weld -= refund
        if refund:
            ctx.record.add(round_, len(leaves), weld, _share(leaves), False)
    for cell in leaves:
        if not cell.settled:
            _settle(cell, "fits" if _fits(cell) else "no split within the objective", plan.method)
    last = ctx.record.points[-1]
    ctx.record.points[-1] = PlanPoint(last.round, last.plates, last.weld_m, last.flat_strip, True)
    return leaves


def plate_key(part, config=None) -> str:
    """What a plate's evaluation depends on, as a digest: the hull surface (its control net,
    knots and weights), the plate's seams (in the surface's parameters), butt planes, seam and
    butt names, the plate's settings and the run's settings other than the plan. Two plans
    that ask for the same plate get one evaluation (:class:`pipeline.runner.PlateEvaluator`)."""
    import hashlib

    hull = part.hull
    digest = hashlib.sha256()
    surface = hull.surface
    for array in (surface.poles, surface.weights, surface.knots_u, surface.knots_v):
        digest.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
    digest.update(repr((surface.degree_u, surface.degree_v, hull.long_axis,
                        tuple((g.s, g.g) for g in hull.girths),
                        tuple(None if p is None else p.as_tuple() for p in hull.butts),
                        hull.seam_names, hull.butt_names, hull.fit_tolerance, hull.resolution, repr(hull.frames),
                        hull.inside_trim, hull.x_limits, hull.surface_note, hull.developable, hull.note, hull.held,
                        part.steel)).encode())
    if hull.follow:  # a formed plate moved to meet its neighbours: its moves too
        digest.update(np.ascontiguousarray(hull.follow["offsets"], dtype=np.float64).tobytes())
        digest.update(repr(hull.follow["neighbours"]).encode())  # named in the plate's figures
        # not its strips' verdict: that follows from the region, which the key holds
    if hull.as_strip:  # a flat plate asked for as a strip: no plane tried
        digest.update(repr(sorted(hull.as_strip.items())).encode())
    if hull.plane:  # a flat plate's plane chosen with its neighbours'
        digest.update(np.asarray([*hull.plane["normal"], *hull.plane["point"]], dtype=np.float64).tobytes())
    if config is not None:
        spec = config.spec
        digest.update(spec.model_dump_json(exclude={"strake": {"plan"}, "name": True}).encode())
    return digest.hexdigest()
