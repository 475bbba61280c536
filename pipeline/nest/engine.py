"""Nesting: flat parts onto a fabric roll (a marker) or onto steel stock plates.

The engine is ``spyrrow`` (Python bindings of sparrow on jagua-rs): irregular strip packing
of polygons with quantities, allowed rotations, a minimum separation, a time budget and a
seed. A marker is strip packing exactly. Stock plates are bins; they are filled sheet by
sheet: strip-pack the remaining parts on the stock width, keep the parts that end before
the stock length (a cut across the strip that goes through no part), start the next plate
with the rest. Every layout is checked afterwards with shapely, independently of the
engine. Geometry in model units; no file is written here (see :mod:`pipeline.nesting_io`).
"""

from __future__ import annotations

import math
import threading
import time
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import Polygon

from flatten.errors import DevflatError
from flatten.tolerances import DEFAULT_TOLERANCES, Tolerances

# free rotation: the narrowest extent of a polygon is found among these angles and the
# directions of its convex hull edges (rotating calipers: a minimal width rests on an edge)
FREE_SAMPLES = np.arange(0.0, 180.0, 1.0)
# engine runs per stock plate spent on fitting in parts the cut went through
FILL_TRIES = 3


class NestingError(DevflatError, ValueError):
    """The nesting input cannot be nested (a part wider than the roll, no parts, ...)."""


@dataclass(frozen=True)
class NestItem:
    """One distinct part to nest.

    id : unique label (a part name, with _PS / _SB for port/starboard pairs)
    outline : (N, 2) closed contour in the part's own coordinates, not repeated (model units)
    quantity : copies wanted (>= 1)
    orientations : allowed rotations in degrees (applied after ``base_rotation``), or None (free)
    base_rotation : degrees turning the outline into its reference orientation (the grain
        along the roll for textile pieces)
    """

    id: str
    outline: np.ndarray
    quantity: int
    orientations: tuple[float, ...] | None = (0.0,)
    base_rotation: float = 0.0

    @property
    def area(self) -> float:
        return float(Polygon(self.outline).area)

    def reference(self) -> np.ndarray:
        """The outline turned by ``base_rotation``: (N, 2)."""
        return self.outline @ rotation(self.base_rotation).T


@dataclass(frozen=True)
class Placement:
    """A copy of an item: its outline maps to the sheet by p -> R(rotation) p + translation
    (degrees, model units); rotation includes the item's base rotation."""

    item: str
    copy: int
    rotation: float
    translation: np.ndarray

    def place(self, outline: np.ndarray) -> np.ndarray:
        return outline @ rotation(self.rotation).T + self.translation


@dataclass(frozen=True)
class Sheet:
    """A stock plate or the marker: [0, length] x [0, width] holds its placements."""

    id: str
    width: float
    length: float
    placements: tuple[Placement, ...]
    stock: str = ""


@dataclass
class NestResult:
    """A layout with its checks. ``success`` iff every copy is placed and every check passes."""

    kind: str  # "marker" | "stock"
    sheets: list[Sheet]
    items: dict[str, NestItem]
    spacing: float
    edge_margin: float
    unplaced: list[dict] = field(default_factory=list)  # {"item", "copies", "reason"}
    checks: dict = field(default_factory=dict)
    engine: dict = field(default_factory=dict)
    figures: dict = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return not self.unplaced and bool(self.checks.get("passed"))

    @property
    def message(self) -> str:
        placed = sum(len(s.placements) for s in self.sheets)
        text = f"{placed} part(s) on {len(self.sheets)} {'roll' if self.kind == 'marker' else 'stock plate(s)'}"
        if self.unplaced:
            text += "; not placed: " + ", ".join(f"{u['item']} x{u['copies']} ({u['reason']})" for u in self.unplaced)
        if not self.checks.get("passed", False):
            text += "; layout check FAILED"
        return text

    def __bool__(self) -> bool:
        return self.success


def rotation(degrees: float) -> np.ndarray:
    a = math.radians(degrees)
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def extents(outline: np.ndarray, angles) -> np.ndarray:
    """Bounding box sizes of the outline turned by each angle (degrees): (A, 2) [along x, along y]."""
    a = np.radians(np.asarray(angles, dtype=float))
    c, s = np.cos(a), np.sin(a)
    x = np.outer(c, outline[:, 0]) - np.outer(s, outline[:, 1])
    y = np.outer(s, outline[:, 0]) + np.outer(c, outline[:, 1])
    return np.stack([np.ptp(x, axis=1), np.ptp(y, axis=1)], axis=1)


def candidate_angles(item: NestItem) -> np.ndarray:
    """Angles (degrees, on the reference outline) the engine may use: the allowed ones, or
    a sampling of free rotation with every convex hull edge direction."""
    if item.orientations is not None:
        return np.asarray(item.orientations, dtype=float)
    hull = np.asarray(Polygon(item.reference()).convex_hull.exterior.coords)
    edge = np.diff(hull, axis=0)
    edge_angles = -np.degrees(np.arctan2(edge[:, 1], edge[:, 0]))  # turns the edge onto the x axis
    return np.concatenate([FREE_SAMPLES, edge_angles, edge_angles + 90.0])


def fits(item: NestItem, width: float, length: float = math.inf, slack: float = 0.0) -> bool:
    """Whether some allowed orientation puts the item inside length x width."""
    ext = extents(item.reference(), candidate_angles(item))
    return bool(np.any((ext[:, 1] <= width + slack) & (ext[:, 0] <= length + slack)))


def narrowest(item: NestItem) -> tuple[float, float]:
    """(smallest extent across the strip, the shortest length among orientations that fit a
    strip that narrow) over the allowed orientations."""
    ext = extents(item.reference(), candidate_angles(item))
    k = int(np.argmin(ext[:, 1]))
    return float(ext[k, 1]), float(ext[k, 0])


# ------------------------------------------------------------------ engine
def strip_pack(items: list[NestItem], counts: dict[str, int], height: float, spacing: float, budget: int,
               seed: int, workers: int, progress=None) -> tuple[list[Placement], dict]:
    """Pack ``counts[id]`` copies of each item into the band [0, inf) x [0, height] with
    gaps >= spacing between parts (none required at the band edges); the engine minimises
    the band length. Returns the placements and the engine figures (seconds, length,
    whether the budget stopped it). ``progress(elapsed, length)`` is called while it runs.

    The engine keeps ``min_items_separation`` from the strip edges as well: it works in a
    strip ``height + 2 spacing`` high and the layout is moved back by ``spacing``.
    """
    import spyrrow

    todo = [it for it in items if counts.get(it.id, 0) > 0]
    if not todo:
        return [], {"seconds": 0.0, "length": 0.0, "last_improvement": 0.0}
    shapes, shifts = {}, {}
    engine_items = []
    for it in todo:
        ref = it.reference()
        # near the origin: the engine works in float32
        shifts[it.id] = -ref.min(axis=0)
        shapes[it.id] = ref + shifts[it.id]
        orients = None if it.orientations is None else [float(a) for a in it.orientations]
        engine_items.append(spyrrow.Item(it.id, [tuple(map(float, p)) for p in shapes[it.id]], int(counts[it.id]),
                                         orients))
    instance = spyrrow.StripPackingInstance("devflat", float(height + 2.0 * spacing), engine_items)
    config = spyrrow.StripPackingConfig(early_termination=True, total_computation_time=int(budget),
                                        min_items_separation=float(spacing) if spacing > 0 else None,
                                        num_workers=int(workers), seed=int(seed))
    queue = spyrrow.ProgressQueue()
    out: dict = {}

    def work():
        try:
            out["solution"] = instance.solve(config, queue)
        except BaseException as exc:  # the engine panics (a Rust panic) when a part cannot fit the strip
            out["error"] = exc

    start = time.perf_counter()
    thread = threading.Thread(target=work, daemon=True)
    thread.start()
    best, improved = math.inf, 0.0
    feasible = (spyrrow.ReportType.ExplFeas, spyrrow.ReportType.CmprFeas)
    while thread.is_alive():
        thread.join(0.2)
        now = time.perf_counter() - start
        for report, sol in queue.drain():
            if report in feasible and sol.width - 2.0 * spacing < best:
                best, improved = sol.width - 2.0 * spacing, now
        if progress is not None:
            progress(now, best)
    seconds = time.perf_counter() - start
    if "error" in out:
        raise NestingError(f"the nesting engine failed: {out['error']}")
    solution = out["solution"]
    by_id = {it.id: it for it in todo}
    copies: dict[str, int] = {}
    placements = []
    for p in solution.placed_items:
        it = by_id[p.id]
        angle = float(p.rotation)
        if it.orientations is not None:  # the engine reports the allowed angle in float32
            allowed = np.asarray(it.orientations, dtype=float)
            diff = (angle - allowed + 180.0) % 360.0 - 180.0
            k = int(np.argmin(np.abs(diff)))
            if abs(diff[k]) < 1e-3:
                angle = float(allowed[k])
        r = rotation(angle)
        shift = r @ shifts[it.id] + np.asarray(p.translation, dtype=float) - spacing
        k = copies.get(p.id, 0)
        copies[p.id] = k + 1
        placements.append(Placement(p.id, k, angle + it.base_rotation, shift))
    engine = {"seconds": seconds, "budget": int(budget), "seed": int(seed), "workers": int(workers),
              "length": float(solution.width - 2.0 * spacing), "density": float(solution.density),
              # the search runs to its budget; a layout whose last improvement came well
              # before the end does not depend on the machine's speed (same seed, same
              # layout), one still improving at the deadline may
              "last_improvement": improved}
    return placements, engine


def _moved(placements, offset) -> list[Placement]:
    offset = np.asarray(offset, dtype=float)
    return [Placement(p.item, p.copy, p.rotation, p.translation + offset) for p in placements]


# ------------------------------------------------------------------ layouts
def _check_input(items: list[NestItem], width: float, field: str) -> None:
    if not items:
        raise NestingError("no parts to nest")
    if not width > 0:
        raise NestingError(f"{field} = {width:g}: the usable width must be > 0")


def nest_marker(items: list[NestItem], fabric_width: float, spacing: float, edge_margin: float, budget: int,
                seed: int, workers: int, progress=None, tolerances: Tolerances = DEFAULT_TOLERANCES) -> NestResult:
    """Every copy of every piece on one roll ``fabric_width`` wide; the marker length is the
    roll used (to the end of the last piece, plus the edge margin). Raises NestingError
    (bad input) for no pieces or a piece wider than the roll in all its orientations."""
    band = fabric_width - 2.0 * edge_margin
    _check_input(items, band, "nesting.fabric_width - 2 edge_margin")
    for it in items:
        if not fits(it, band, slack=1e-9 * band):
            across, _ = narrowest(it)
            raise NestingError(f"nesting.fabric_width = {fabric_width:g}: piece {it.id} is {across:.6g} wide across "
                               f"the roll in its narrowest allowed orientation, more than the usable width "
                               f"{band:.6g} (orientations {_orient_text(it)})")
    counts = {it.id: it.quantity for it in items}
    placements, engine = strip_pack(items, counts, band, spacing, budget, seed, workers, progress)
    placements = _moved(placements, (edge_margin, edge_margin))
    return marker_result(items, fabric_width, spacing, edge_margin, placements, engine, tolerances)


def marker_result(items: list[NestItem], fabric_width: float, spacing: float, edge_margin: float,
                  placements: list[Placement], engine: dict,
                  tolerances: Tolerances = DEFAULT_TOLERANCES) -> NestResult:
    """The marker of these placements (roll coordinates), its figures and checks."""
    lookup = {it.id: it for it in items}
    end = max(float(p.place(lookup[p.item].outline)[:, 0].max()) for p in placements)
    sheet = Sheet("marker", fabric_width, end + edge_margin, tuple(placements), "roll")
    result = NestResult("marker", [sheet], lookup, spacing, edge_margin, engine=engine)
    area = sum(lookup[p.item].area for p in placements)
    result.figures = {"fabric_width": fabric_width, "marker_length": sheet.length, "pieces_area": area,
                      "used_roll_area": fabric_width * sheet.length,
                      "efficiency": area / (fabric_width * sheet.length),
                      "pieces": len(placements)}
    result.checks = check_layout(result, tolerances)
    return result


def solve_seconds(share: float, deadline: float) -> int:
    """Whole seconds an engine run may take: its share of the budget rounded, never past
    the deadline (time.perf_counter() value). 0 asks the engine for its first layout only
    (about 0.1 s): once the budget is spent, the parts still get a layout."""
    return max(0, min(math.floor(share + 0.5), math.floor(deadline - time.perf_counter())))


def nest_stock(items: list[NestItem], stock: list[tuple[str, float, float]], spacing: float, edge_margin: float,
               budget: float, seed: int, workers: int, progress=None,
               tolerances: Tolerances = DEFAULT_TOLERANCES,
               remnants: list[tuple[str, float, float]] = ()) -> NestResult:
    """Every copy onto as few stock plates as possible, plate by plate.

    stock : [(name, width, length), ...] sizes available in any number
    remnants : [(name, width, length), ...] plates there is one of each, used before any
        stock size while one of them takes a part (the yard's remnants)
    budget : seconds for every engine run of this call together
    Each round strip-packs the remaining parts on each stock width, cuts the strip at each
    stock length and keeps the parts that end before it (the cut goes through no part);
    the round takes the size that holds everything left with the least plate area, else
    the size with the highest utilisation. The parts the cut went through are then tried on
    the plate one by one (a strip packing of the kept parts and the candidate, accepted if
    it ends before the stock length, at most FILL_TRIES runs); the rest go to the next round.
    Each engine run gets whole seconds out of what is left of the budget; when nothing is
    left it runs for its first layout only.
    A part wider than every plate raises NestingError; one that fits a width but no length
    is reported unplaced.
    """
    if not stock:
        raise NestingError("nesting.stock: no stock size")
    _check_input(items, min(w for _, w, _ in stock) - 2.0 * edge_margin, "nesting.stock width - 2 edge_margin")
    sizes = [(name, w, ln) for name, w, ln in stock]
    remnants = [(name, w, ln) for name, w, ln in remnants if min(w, ln) - 2.0 * edge_margin > 0]
    for name, w, ln in sizes:
        if not min(w, ln) - 2.0 * edge_margin > 0:
            raise NestingError(f"nesting.stock {name}: {w:g} x {ln:g} leaves no room inside edge_margin {edge_margin:g}")
    lookup = {it.id: it for it in items}
    unplaced = []
    remaining: dict[str, int] = {}
    for it in items:
        slack = 1e-9 * max(max(w, ln) for _, w, ln in sizes)
        if not any(fits(it, w - 2 * edge_margin, slack=slack) or fits(it, ln - 2 * edge_margin, slack=slack)
                   for _, w, ln in sizes):
            across, _ = narrowest(it)
            raise NestingError(f"nesting.stock: part {it.id} is {across:.6g} across in its narrowest allowed orientation "
                               f"({_orient_text(it)}), wider than every stock plate "
                               f"({', '.join(f'{w:g} x {ln:g}' for _, w, ln in sizes)}, edge_margin {edge_margin:g})")
        if not any(fits(it, w - 2 * edge_margin, ln - 2 * edge_margin, slack) for _, w, ln in sizes):
            across, along = narrowest(it)
            unplaced.append({"item": it.id, "copies": it.quantity,
                             "reason": f"fits no stock plate: {along:.6g} long where it is narrowest ({across:.6g}), "
                                       f"longer than every stock length"})
            continue
        remaining[it.id] = it.quantity
    start = time.perf_counter()
    deadline = start + budget
    sheets: list[Sheet] = []
    engine = {"solves": 0, "seconds": 0.0, "budget": budget, "seed": int(seed), "workers": int(workers),
              "last_improvements": [], "solve_budgets": [], "remnants_used": [], "remnants_tried": []}
    tried: set = set()  # remnants that held nothing, or were used
    round_no = 0
    while any(remaining.values()):
        # the remnants first, while any is left: stock sizes only when none takes a part
        pool = [r for r in remnants if r[0] not in tried] or sizes
        from_remnants = pool is not sizes
        widths = sorted({w for _, w, _ in pool})
        left_area = sum(lookup[k].area * n for k, n in remaining.items())
        biggest = max(w * ln for _, w, ln in sizes)
        rounds_left = max(1, math.ceil(left_area / (0.75 * biggest))) + len(pool if from_remnants else ())
        time_left = deadline - time.perf_counter()
        per_solve = max(0.0, time_left / (rounds_left * len(widths)))
        best = None
        for w in widths:
            band = w - 2.0 * edge_margin
            subset = {k: n for k, n in remaining.items() if n > 0 and fits(lookup[k], band, slack=1e-9 * band)}
            if not subset:
                continue

            def tick(elapsed, length, _sheet=len(sheets)):
                if progress is not None:
                    progress(time.perf_counter() - start, f"plate {_sheet + 1}")

            seconds = solve_seconds(per_solve, deadline)
            engine["solve_budgets"].append(seconds)
            placements, eng = strip_pack(items, subset, band, spacing, seconds, seed + round_no, workers, tick)
            engine["solves"] += 1
            engine["seconds"] += eng["seconds"]
            engine["last_improvements"].append(eng["last_improvement"])
            ends = np.array([p.place(lookup[p.item].outline)[:, 0].max() for p in placements])
            total = sum(remaining.values())
            for name, sw, ln in pool:
                if sw != w:
                    continue
                cut = ln - 2.0 * edge_margin + 1e-9 * ln
                keep = [p for p, e in zip(placements, ends) if e <= cut]
                if not keep:
                    continue
                starts = [p.place(lookup[p.item].outline)[:, 0].min() for p in placements]
                crossing = [p.item for p, a, e in zip(placements, starts, ends) if e > cut and a < cut]
                area = sum(lookup[p.item].area for p in keep)
                everything = len(keep) == total
                # everything left on one plate: the smallest such plate; else the best-used plate
                # (ties: the larger plate, fewer plates)
                score = (1, -w * ln) if everything else (0, round(area / (w * ln), 9), w * ln)
                if best is None or score > best[0]:
                    best = (score, name, w, ln, keep, crossing)
        if best is None and from_remnants:  # no remnant left takes a part: on to the stock sizes
            engine["remnants_tried"] += [r[0] for r in pool]
            tried |= {r[0] for r in pool}
            continue
        if best is None:  # no part ended before any stock length: give the largest part a plate alone
            big = max((k for k, n in remaining.items() if n > 0), key=lambda k: lookup[k].area)
            for name, w, ln in sorted(sizes, key=lambda s: s[1] * s[2]):
                band = w - 2.0 * edge_margin
                if not fits(lookup[big], band, ln - 2.0 * edge_margin, 1e-9 * ln):
                    continue
                seconds = solve_seconds(1.0, deadline)
                engine["solve_budgets"].append(seconds)
                placements, eng = strip_pack(items, {big: 1}, band, spacing, seconds, seed + round_no, workers)
                engine["solves"] += 1
                engine["seconds"] += eng["seconds"]
                end = placements[0].place(lookup[big].outline)[:, 0].max()
                if end <= ln - 2.0 * edge_margin + 1e-9 * ln:
                    best = ((0, 0.0, 0.0), name, w, ln, placements, [])
                    break
            if best is None:
                unplaced.append({"item": big, "copies": remaining[big],
                                 "reason": "the engine found no layout of it within a stock length"})
                remaining[big] = 0
                continue
        _, name, w, ln, keep, crossing = best
        # the parts the cut went through: try each on this plate with the parts kept (a
        # layout of just these may well hold it), largest first, a few tries per plate
        fills = 0
        for cand in sorted(dict.fromkeys(crossing), key=lambda k: -lookup[k].area):
            free = w * ln - sum(lookup[p.item].area for p in keep)
            # a fill is a refinement: only while the budget lasts
            if fills >= FILL_TRIES or lookup[cand].area > free or deadline - time.perf_counter() < 1.0:
                break
            fills += 1
            trial = Counter(p.item for p in keep)
            trial[cand] += 1
            seconds = solve_seconds(max(1.0, per_solve / 2), deadline)
            engine["solve_budgets"].append(seconds)
            placements, eng = strip_pack(items, dict(trial), w - 2.0 * edge_margin, spacing,
                                         seconds, seed + round_no, workers)
            engine["solves"] += 1
            engine["seconds"] += eng["seconds"]
            end = max(p.place(lookup[p.item].outline)[:, 0].max() for p in placements)
            if end <= ln - 2.0 * edge_margin + 1e-9 * ln:
                keep = placements
                engine["filled"] = engine.get("filled", 0) + 1
        numbered = []
        for p in keep:
            numbered.append(Placement(p.item, lookup[p.item].quantity - remaining[p.item], p.rotation,
                                      p.translation + edge_margin))
            remaining[p.item] -= 1
        sheets.append(Sheet(f"P{len(sheets) + 1:02d}", w, ln, tuple(numbered), name))
        if from_remnants:
            tried.add(name)
            engine["remnants_used"].append(name)
        round_no += 1
    return stock_result(items, sheets, spacing, edge_margin, unplaced, engine, tolerances)


def stock_result(items: list[NestItem], sheets: list[Sheet], spacing: float, edge_margin: float, unplaced: list,
                 engine: dict, tolerances: Tolerances = DEFAULT_TOLERANCES) -> NestResult:
    """The stock plates of these sheets, their figures and checks."""
    result = NestResult("stock", sheets, {it.id: it for it in items}, spacing, edge_margin, unplaced=unplaced,
                        engine=engine)
    result.figures = stock_figures(result)
    result.checks = check_layout(result, tolerances)
    return result


def stock_figures(result: NestResult) -> dict:
    rows = []
    for sheet in result.sheets:
        parts = sum(result.items[p.item].area for p in sheet.placements)
        plate = sheet.width * sheet.length
        used = max((p.place(result.items[p.item].outline)[:, 0].max() for p in sheet.placements), default=0.0)
        rows.append({"sheet": sheet.id, "stock": sheet.stock, "width": sheet.width, "length": sheet.length,
                     "used_length": float(used + result.edge_margin),
                     "parts": [f"{p.item}#{p.copy + 1}" for p in sheet.placements], "parts_area": parts,
                     "plate_area": plate, "utilisation": parts / plate, "scrap_area": plate - parts})
    parts = sum(r["parts_area"] for r in rows)
    plates = sum(r["plate_area"] for r in rows)
    return {"plates": len(rows), "sheets": rows, "parts_area": parts, "plates_area": plates,
            "utilisation": parts / plates if plates else 0.0}


def _orient_text(item: NestItem) -> str:
    return "free" if item.orientations is None else "/".join(f"{a:g}" for a in item.orientations)


# ------------------------------------------------------------------ checks
def gap_between(a: Polygon, b: Polygon) -> float:
    """Distance between two parts; when they overlap, minus the depth of the overlap
    (twice its area over its perimeter: the width of a sliver)."""
    if not a.intersects(b):
        return float(a.distance(b))
    common = a.intersection(b)
    return -2.0 * float(common.area) / float(common.length) if common.area > 0 else 0.0


def check_layout(result: NestResult, tolerances: Tolerances = DEFAULT_TOLERANCES) -> dict:
    """Independent checks of a layout with shapely, per sheet: every part inside the sheet
    (within the edge margin), no two parts closer than the spacing (no overlap deeper than
    the slack at spacing 0), every part's area as in its outline (a rigid motion), every
    copy accounted for (placed or reported unplaced). Slack: ``tolerances.nesting`` times
    the sheet size (the engine computes in float32)."""
    sheets = []
    counts: dict[str, int] = {}
    passed = True
    for sheet in result.sheets:
        tol = tolerances.nesting * max(sheet.width, sheet.length)
        m = result.edge_margin
        rings = [p.place(result.items[p.item].outline) for p in sheet.placements]
        polys = [Polygon(r) for r in rings]
        # the sheet is convex: a part is inside iff its vertices are
        outside = [float(np.max([m - r[:, 0], r[:, 0] - (sheet.length - m), m - r[:, 1], r[:, 1] - (sheet.width - m)]))
                   for r in rings]
        area_error = [abs(p.area - result.items[pl.item].area) / result.items[pl.item].area
                      for p, pl in zip(polys, sheet.placements)]
        tree = shapely.STRtree(polys)
        near = result.spacing - tol
        pairs = tree.query(polys, predicate="dwithin", distance=near) if near > 0 else \
            tree.query(polys, predicate="intersects")
        violations = []
        min_gap = math.inf
        for i, j in zip(*pairs):
            if i >= j:
                continue
            gap = gap_between(polys[i], polys[j])
            if gap < result.spacing - tol:
                violations.append({"a": _label(sheet.placements[i]), "b": _label(sheet.placements[j]), "gap": gap})
        if len(polys) > 1:
            _, dist = tree.query_nearest(polys, exclusive=True, return_distance=True)
            min_gap = float(dist.min())
        if violations:
            min_gap = min(min_gap, min(v["gap"] for v in violations))
        inside = max(outside) <= tol
        area_ok = max(area_error) <= 1e-9
        ok = inside and area_ok and not violations
        passed &= ok
        sheets.append({"sheet": sheet.id, "parts": len(polys), "inside": inside,
                       "max_outside": max(0.0, max(outside)), "min_gap": min_gap, "spacing_violations": violations,
                       "max_area_error_relative": max(area_error), "area_preserved": area_ok, "passed": ok,
                       "tolerance": tol})
        for pl in sheet.placements:
            counts[pl.item] = counts.get(pl.item, 0) + 1
    missing = {}
    for it in result.items.values():
        reported = sum(u["copies"] for u in result.unplaced if u["item"] == it.id)
        if counts.get(it.id, 0) + reported != it.quantity:
            missing[it.id] = {"wanted": it.quantity, "placed": counts.get(it.id, 0), "reported_unplaced": reported}
    passed &= not missing
    return {"passed": bool(passed), "sheets": sheets, "quantities_accounted": not missing, "quantity_errors": missing,
            "placed": counts, "spacing": result.spacing,
            "max_outside": max((s["max_outside"] for s in sheets), default=0.0),
            "min_gap": min((s["min_gap"] for s in sheets), default=math.inf),
            "max_area_error_relative": max((s["max_area_error_relative"] for s in sheets), default=0.0)}


def _label(p: Placement) -> str:
    return f"{p.item}#{p.copy + 1}"
