"""What a plan costs a yard: plates, metres of weld, the narrowest plate, the class shares.

Every plate edge is welded: to a neighbouring plate of the plan (a seam between strakes or a
butt between plates of a strake) or, on the plan's outer edge, to what the plan does not
cover (the other side at the keel, the deck, the stem, strakes laid by hand next to it).
``weld_m`` counts the welds between the plan's plates, each once; ``boundary_m`` the plan's
outer edge. A grid of L x W plates welds (L + W) / (L W) metres per m^2 (DESIGN.md §8):
``weld_per_m2`` is that figure for the plan (its interior welds over its shell area).

Which edges are shared is found geometrically, not from names (an adaptive plan staggers its
butts and splits plates across the girth, so that one plate's butt meets two neighbours):
each plate's four edges are sampled on the hull (its region's boundary rows and columns), and
a piece of edge is shared when it lies on another plate's edge (its midpoint within 5 % of
its length of that edge: the two samplings of one curve differ by their chord sagittas,
which are far smaller at these spacings).

Lengths in the report are metres, areas m^2 (model units times mm_per_unit / 1000).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from flatten.patch import region_grid

from .hullplots import display_class, shell_area

# the classes as a yard counts them: flat, devflat's strip, rolled (a patch within the
# tolerance, or formed but rolling only), formed, failed
SHARE_NAMES = {"flat": "flat", "developable": "strip", "patch": "rolled", "formed": "formed", "failed": "failed"}
EDGE_SAMPLES = (33, 129)  # points across the girth (butts) and along the length (seams)
TRIM_SAMPLES = 64  # points along a grid step that a face's trim crosses, to measure the part inside
CROSS_REACH_MM = 1.0  # plates' corners this close meet at one point (each plate computes its own)
SHARED = 0.05  # a segment is shared when its midpoint lies within this share of its length of another edge


@dataclass(frozen=True)
class PlateEdges:
    """A plate's region sampled on the hull: ``points`` (R, C, 3) model units and ``params``
    (R, C, 2) surface parameters (u, v); rows run along the length (row 0 the first seam,
    row -1 the second), columns across the girth (column 0 the first butt, -1 the last)."""

    name: str
    points: np.ndarray
    params: np.ndarray

    def edges(self) -> dict[str, np.ndarray]:
        """The four edges as polylines (N, 3): seam_lo, seam_hi, butt_lo, butt_hi."""
        p = self.points
        return {"seam_lo": p[0], "seam_hi": p[-1], "butt_lo": p[:, 0], "butt_hi": p[:, -1]}

    def widths(self, trim=None) -> np.ndarray:
        """Girth width (C,) of every column: arc length across the plate (model units); with
        its face's ``trim`` (:class:`.trims.Trim`) only the length inside it, the plate the
        shop cuts (a column wholly outside has none)."""
        return self._inside_steps(0, trim).sum(axis=0)

    def lengths(self, trim=None) -> np.ndarray:
        """Length (R,) of every row along the plate (model units); with its face's ``trim``
        only the length inside it, as :meth:`widths`."""
        return self._inside_steps(1, trim).sum(axis=1)

    def _inside_steps(self, axis: int, trim) -> np.ndarray:
        """The grid's steps along ``axis`` (0: across the girth, 1: along the length), each
        as long as its part inside ``trim`` (all of it without one)."""
        steps = np.linalg.norm(np.diff(self.points, axis=axis), axis=2)
        if trim is None:
            return steps
        uv = self.params
        ends = trim.inside(uv[..., 0], uv[..., 1])
        first = ends[:-1] if axis == 0 else ends[:, :-1]
        second = ends[1:] if axis == 0 else ends[:, 1:]
        share = (first & second).astype(float)
        # a step the trim crosses: the share of TRIM_SAMPLES points along it inside (in (u, v))
        rows, cols = np.nonzero(first != second)
        step = (1, 0) if axis == 0 else (0, 1)
        t = (np.arange(TRIM_SAMPLES) + 0.5) / TRIM_SAMPLES
        start, stop = uv[rows, cols], uv[rows + step[0], cols + step[1]]
        at = start[:, None] + t[None, :, None] * (stop - start)[:, None]
        share[rows, cols] = trim.inside(at[..., 0], at[..., 1]).mean(axis=1)
        return steps * share


def plate_edges(name: str, hull, samples: tuple[int, int] = EDGE_SAMPLES) -> PlateEdges | None:
    """The region of a :class:`~pipeline.hull.region.HullPlate` on a grid of ``samples``
    (rows, columns); None when the region misses the surface."""
    planes = [None if p is None else p.as_tuple() for p in hull.butts]
    grid = region_grid(hull.surface, hull.long_axis, hull.girths[0], hull.girths[1], planes, samples[0],
                       samples[1], probe=400)
    if grid is None:
        return None
    return PlateEdges(name, grid.points, grid.params)


@dataclass(frozen=True)
class WeldLengths:
    """Model units: seams and butts between the plan's plates (each once), the outer edge."""

    seams: float
    butts: float
    boundary: float


def weld_lengths(plates: list[PlateEdges]) -> WeldLengths:
    """Interior seam and butt lengths and the outer edge of plates that tile a shell."""
    a, b, kind, owner = [], [], [], []
    for k, plate in enumerate(plates):
        for edge_name, line in plate.edges().items():
            a.append(line[:-1])
            b.append(line[1:])
            kind.append(np.full(len(line) - 1, edge_name.startswith("butt")))
            owner.append(np.full(len(line) - 1, k))
    if not a:
        return WeldLengths(0.0, 0.0, 0.0)
    a, b = np.concatenate(a), np.concatenate(b)
    is_butt, owner = np.concatenate(kind), np.concatenate(owner)
    length = np.linalg.norm(b - a, axis=1)
    keep = length > 0.0  # a seam end standing still (a sliver's tip) gives zero-length pieces
    a, b, is_butt, owner, length = a[keep], b[keep], is_butt[keep], owner[keep], length[keep]
    shared = _shared(a, b, owner, length)
    # a shared piece is met by its neighbour's piece too: half of each makes it once
    return WeldLengths(seams=0.5 * float(length[shared & ~is_butt].sum()),
                       butts=0.5 * float(length[shared & is_butt].sum()),
                       boundary=float(length[~shared].sum()))


def _shared(a: np.ndarray, b: np.ndarray, owner: np.ndarray, length: np.ndarray) -> np.ndarray:
    """(M,) whether each segment a -> b (M, 3) lies on a segment of another owner."""
    from scipy.spatial import cKDTree

    mid = 0.5 * (a + b)
    tree = cKDTree(mid)
    reach = float(length.max())
    shared = np.zeros(len(mid), dtype=bool)
    # candidate pairs: midpoints closer than the longest segment (any segment a midpoint can
    # lie on has its own midpoint within half its length of it)
    pairs = tree.query_pairs(reach, output_type="ndarray")
    if not len(pairs):
        return shared
    pairs = pairs[owner[pairs[:, 0]] != owner[pairs[:, 1]]]
    for i, j in (pairs.T, pairs[:, ::-1].T):  # both ways: is i's midpoint on j's segment?
        d = _point_segment(mid[i], a[j], b[j])
        hit = d <= SHARED * length[i]
        shared[i[hit]] = True
    return shared


def _point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances (K,) of points p (K, 3) to segments a -> b (K, 3)."""
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * ab), axis=1)


@dataclass(frozen=True)
class PlanCost:
    """The plan as a yard judges it. Lengths m, areas m^2; ``narrowest`` is the plate whose
    largest girth width is least (the stock width it needs), with that width and its least
    width (a plate tapering to the stem reaches 0 there); ``shares`` the shell area per
    class (flat, strip, rolled, formed, failed) in m^2 and as fractions; ``narrower_than_stock``
    the plates whose largest girth width is below the plan's ``stock.min_width`` (no stock
    that wide is cut to them: slivers where strakes converge, or a face's leftover), narrowest
    first (a plate past its face's trim as wide as its part inside it); ``cross_joints`` the
    points where four plates meet off the block joints and off the planes where faces are
    cut together (two seams and two butts in line,
    :func:`.yardrules.cross_joints`), each with its plates;
    ``off_sheets`` the plates no stock sheet holds, with the rectangle they need (mm: the
    shop's stock check on the cut outline, or :mod:`.sheets` on the development of a plate
    without one)."""

    plates: int
    shell_area_m2: float
    seam_weld_m: float
    butt_weld_m: float
    weld_m: float
    weld_per_m2: float
    boundary_m: float
    narrowest: dict
    shares: dict
    share_area_m2: dict
    narrower_than_stock: list
    cross_joints: list
    off_sheets: list

    def as_dict(self) -> dict:
        return asdict(self)


def plan_line(cost: dict, min_width: float | None = None, mm_per_unit: float = 1.0) -> str:
    """The plan's cost (:meth:`PlanCost.as_dict`) on one console line: its plates, weld (m,
    and m per m^2 of shell), narrowest plate, the plates narrower than the stock's least width
    (``min_width``, config units, as :func:`plan_cost` takes it; said only when the plan has
    stock), the cross joints and the class shares (a class without area left out)."""
    plates = cost["plates"]
    said = [f"{plates} plate{'' if plates == 1 else 's'}",
            f"{_metres(cost['weld_m'])} m of weld ({cost['weld_per_m2']:.3f} m per m2 of shell)"]
    if cost["narrowest"] is not None:
        said.append(f"narrowest {_metres(cost['narrowest']['width_m'])} m ({cost['narrowest']['plate']})")
    if min_width is not None:
        narrow = len(cost["narrower_than_stock"])
        said.append(f"{narrow or 'none'} narrower than the stock's {min_width * mm_per_unit / 1000.0:g} m")
    crosses = len(cost["cross_joints"])
    said.append(f"{crosses or 'no'} cross joint{'' if crosses == 1 else 's'}")
    off = cost.get("off_sheets") or []  # (said only when a plate is on none)
    if off:
        said.append(f"{len(off)} on no stock sheet")
    shares = ", ".join(f"{name} {100.0 * share:.1f} %" for name, share in cost["shares"].items()
                       if cost["share_area_m2"][name] > 0.0)
    return f"plan: {', '.join(said)}; {shares}"


def _metres(value: float) -> str:
    """A length in metres to three significant figures at least (a model-scale plan's weld is
    under a metre, its plates a few centimetres wide)."""
    return f"{value:.0f}" if abs(value) >= 100.0 else f"{value:.3g}"


def stock_min_width(spec) -> float | None:
    """The least stock width (config units) of a run's plan, None when it plans no stock."""
    stock = getattr(getattr(spec.strake, "plan", None), "stock", None)
    return None if stock is None else stock.min_width


def block_joints(spec) -> tuple:
    """The block joints (x, config units) of a run's plan, () when it names none."""
    plan = getattr(spec.strake, "plan", None)
    return tuple(getattr(plan, "block_joints", None) or ())


def class_areas(results) -> dict[str, float]:
    """m^2 of shell each share's plates cover (flat, strip, rolled, formed, failed)."""
    area = {name: 0.0 for name in SHARE_NAMES.values()}
    for r in results:
        area[SHARE_NAMES[display_class(r)]] += shell_area(r)
    return area


def plan_cost(results, edges: dict[str, PlateEdges], mm_per_unit: float, min_width: float | None = None,
              joints=(), sheets=None) -> PlanCost:
    """The cost of the plan whose plates are ``results`` (hull plates; ``edges`` by plate name,
    from :func:`plate_edges`); ``min_width``: the stock's least width (config units), if any;
    ``joints``: the plan's block joints (x, config units), to which the planes where faces
    are cut together are added (:func:`.yardrules.face_junctions`); ``sheets``: the stock sheets
    (:class:`.sheets.Sheets`) a plate without the shop's stock check is judged against."""
    from .yardrules import cross_joints, face_junctions

    joints = tuple(joints) + face_junctions([r.part for r in results if getattr(r, "part", None) is not None])
    metre = mm_per_unit / 1000.0
    sampled = [edges[r.name] for r in results if edges.get(r.name) is not None]
    weld = weld_lengths(sampled)
    area = class_areas(results)
    total = sum(area.values())
    narrow, below = None, []
    trims = {r.name: getattr(getattr(getattr(r, "part", None), "hull", None), "trim", None) for r in results}
    for plate in sampled:
        widths = plate.widths(trims.get(plate.name))  # a plate past its face's trim: as the shop cuts it
        if narrow is None or widths.max() < narrow[1]:
            narrow = (plate.name, float(widths.max()), float(widths.min()))
        if min_width is not None and widths.max() < min_width:
            below.append((float(widths.max()), plate.name))
    seams, butts = weld.seams * metre, weld.butts * metre
    return PlanCost(
        plates=len(results), shell_area_m2=total, seam_weld_m=seams, butt_weld_m=butts, weld_m=seams + butts,
        weld_per_m2=(seams + butts) / total if total > 0 else float("nan"), boundary_m=weld.boundary * metre,
        narrowest=None if narrow is None else {"plate": narrow[0], "width_m": narrow[1] * metre,
                                                "least_width_m": narrow[2] * metre},
        shares={k: (v / total if total > 0 else 0.0) for k, v in area.items()}, share_area_m2=area,
        narrower_than_stock=[{"plate": name, "width_m": width * metre} for width, name in sorted(below)],
        cross_joints=[{"at": list(at), "plates": list(names)}
                      for at, names in cross_joints(results, joints, CROSS_REACH_MM / mm_per_unit, lambda r: r)],
        off_sheets=off_sheets(results, mm_per_unit, sheets))


def off_sheets(results, mm_per_unit: float, sheets=None) -> list:
    """[{plate, needed_mm}] of the plates no stock sheet holds: by the shop's stock check
    (``figures['stock']``) where the plate has one, else by its development against
    ``sheets`` (:mod:`.sheets`; none judged without)."""
    from .sheets import development_need

    off = []
    for r in results:
        stock = r.figures.get("stock")
        if stock is not None:
            need, held = stock["needed"], stock["fits_on"] is not None
        elif sheets is not None and (need := development_need(r, sheets, mm_per_unit)) is not None:
            held = sheets.holding(need) is not None
        else:
            continue
        if not held:
            off.append({"plate": r.name, "needed_mm": [float(v) for v in need]})
    return off
