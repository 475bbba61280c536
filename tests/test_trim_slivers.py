"""Plates a face's trim cuts to slivers, merged into a neighbour (pipeline.hull.trimslivers).

Closed forms on a face whose strakes are straight in (x, girth) and whose trim is a straight
line across them: every plate's part inside the trim is a polygon whose widths and lengths
are exact. Checked independently of the merge's own bookkeeping: every point of the trimmed
face lies in exactly one plate, no butts closer than the stagger on a seam (the yard rules'
own checker, on the planned parts of KCS), and the merged plates within the stock.
"""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.hull.trimslivers import butt_conflicts, merge_slivers
from pipeline.hull.yardrules import yard_layout
from tests.shipped_configs import with_files_from

ROOT = Path(__file__).resolve().parents[1]
STRAKE = 1000.0  # girth of every strake (mm)


def line_trim(g_at_0: float, slope: float):
    """The trim g >= g_at_0 + slope x (girth g from the face's lower edge) as ``size_of``:
    the part of the rectangle [a, b] x [lo, hi] strakes inside it, (longest row, widest
    column), exact (the cut is linear in x)."""
    def size_of(lo, hi, a, b, x0, x1):
        a, b = (x0 if a is None else a), (x1 if b is None else b)
        g0, g1 = lo * STRAKE, hi * STRAKE

        def column(x):
            return float(np.clip(g1 - max(g0, g_at_0 + slope * x), 0.0, g1 - g0))

        def row(g):  # the x in [a, b] where g_at_0 + slope x <= g
            if slope == 0.0:
                return (b - a) if g_at_0 <= g else 0.0
            edge = (g - g_at_0) / slope
            lo_x, hi_x = (a, min(b, edge)) if slope > 0 else (max(a, edge), b)
            return max(0.0, hi_x - lo_x)

        width = max(column(a), column(b))
        return (row(g1) if width > 0.0 else 0.0), width
    return size_of


def covered_once(plates, inside, x0: float, x1: float, n_strakes: int, samples: int = 4000) -> bool:
    """Every sampled point of the face inside the trim lies in exactly one plate."""
    rng = np.random.default_rng(7)
    x = rng.uniform(x0, x1, samples)
    g = rng.uniform(0.0, n_strakes * STRAKE, samples)
    keep = inside(x, g)
    count = np.zeros(samples, dtype=int)
    for lo, hi, (a, b), _ in plates:
        a, b = (x0 if a is None else a), (x1 if b is None else b)
        count += (x >= a) & (x < b) & (g >= lo * STRAKE) & (g < hi * STRAKE)
    return bool(np.all(count[keep] == 1))


STOCK = SimpleNamespace(max_length=6000.0, max_width=2500.0, min_width=800.0)


def test_a_corner_sliver_merges_across_the_seam_into_the_plate_it_borders():
    """Two strakes of 1 m from x = 0 to 12 m, butts every 4 m (the upper strake's 300 mm
    fore); the trim g >= 850 + 0.2 (x - 8000) leaves the lower strake's last plate (8000 to
    12000 mm) 150 mm wide at its aft end and nothing beyond x = 8750: a sliver. Merged along
    its strake it would be 4750 mm long inside the trim, over a 4.5 m stock; it merges
    into the upper strake's last plate (8300 to 12000 mm, its butts kept), which is then
    1090 mm wide at x = 8300 - a drop strake: the seam between them ends at x = 8300; the
    lower strake's middle plate reaches to 8300 mm (4300 mm long)."""
    x0, x1 = 0.0, 12000.0
    plates = [(0, 1, [None, 4000.0], 1), (0, 1, [4000.0, 8000.0], 2), (0, 1, [8000.0, None], 3),
              (1, 2, [None, 4300.0], 1), (1, 2, [4300.0, 8300.0], 2), (1, 2, [8300.0, None], 3)]
    trim = line_trim(850.0 - 0.2 * 8000.0, 0.2)
    stock = SimpleNamespace(max_length=4500.0, max_width=2500.0, min_width=800.0)
    merged, merges = merge_slivers(plates, lambda lo, hi, a, b: trim(lo, hi, a, b, x0, x1), stock, 300.0,
                                   extent=(x0, x1))
    assert merged == [(0, 1, [None, 4000.0], 1), (0, 1, [4000.0, 8300.0], 2), (0, 2, [8300.0, None], 3),
                      (1, 2, [None, 4300.0], 1), (1, 2, [4300.0, 8300.0], 2)]
    (merge,) = merges
    assert merge.how == "across" and merge.width == pytest.approx(150.0)
    assert merge.merged_width == pytest.approx(STRAKE + 150.0 - 0.2 * 300.0)

    def inside(x, g):
        return g >= 850.0 + 0.2 * (x - 8000.0)

    assert covered_once(merged, inside, x0, x1, 2)


def test_a_sliver_merges_along_its_strake_when_that_is_narrower_and_fits_the_stock():
    """One strake; the trim g >= 900 + 0.5 (x - 9000) keeps of the plate 9000-12000 a
    triangle 100 mm wide and 200 mm long: merged with the plate before it (6000-9000), 3 m
    plus the triangle's 200 mm, within the 6 m stock (across a seam there is no strake)."""
    x0, x1 = 0.0, 12000.0
    plates = [(0, 1, [None, 3000.0], 1), (0, 1, [3000.0, 6000.0], 2), (0, 1, [6000.0, 9000.0], 3),
              (0, 1, [9000.0, None], 4)]
    trim = line_trim(900.0 - 0.5 * 9000.0, 0.5)
    merged, merges = merge_slivers(plates, lambda lo, hi, a, b: trim(lo, hi, a, b, x0, x1), STOCK, 300.0,
                                   extent=(x0, x1))
    assert merged == [(0, 1, [None, 3000.0], 1), (0, 1, [3000.0, 6000.0], 2), (0, 1, [6000.0, None], 3)]
    assert merges[0].how == "along" and merges[0].width == pytest.approx(100.0)


def test_a_sliver_with_no_merge_within_the_stock_stays():
    """The same strake's last plate merged along would be 6.2 m long inside the trim, over a
    6 m stock, and there is no strake beside it: it stays (the plan reports it)."""
    x0, x1 = 0.0, 12000.0
    plates = [(0, 1, [None, 3000.0], 1), (0, 1, [3000.0, 9000.0], 2), (0, 1, [9000.0, None], 3)]
    trim = line_trim(900.0 - 0.5 * 9000.0, 0.5)
    merged, merges = merge_slivers(plates, lambda lo, hi, a, b: trim(lo, hi, a, b, x0, x1), STOCK, 300.0,
                                   extent=(x0, x1))
    assert merged == plates and merges == []


@settings(max_examples=60, deadline=None, derandomize=True)
@given(n=st.integers(2, 5), g_at_0=st.floats(-3000.0, 4000.0), slope=st.floats(-0.6, 0.6),
       stagger=st.sampled_from([0.0, 300.0]))
def test_merging_keeps_the_face_covered_once_and_adds_no_butt_too_close(n, g_at_0, slope, stagger):
    """Any straight trim across a yard layout of n strakes (12 m long, butts staggered):
    every point inside the trim still lies in exactly one plate, no pair of butts closer than
    the stagger is added on any seam (a cross joint included), every merged plate fits the
    stock inside the trim, and no plate is left narrower than before the merges."""
    x0, x1 = 0.0, 12000.0
    stock = SimpleNamespace(max_length=4500.0, max_width=2500.0, min_width=800.0)
    plates = yard_layout(n, x0, x1, (None, None), stock, stagger, [], lambda lo, hi, a, b: (hi - lo) * STRAKE)
    trim = line_trim(g_at_0, slope)

    def size_of(lo, hi, a, b):
        return trim(lo, hi, a, b, x0, x1)

    merged, merges = merge_slivers(plates, size_of, stock, stagger, extent=(x0, x1))

    def inside(x, g):
        return g >= g_at_0 + slope * x

    def width(p):
        return size_of(p[0], p[1], *p[2])[1]

    assert covered_once(merged, inside, x0, x1, n)
    assert butt_conflicts(merged, width, (x0, x1), stagger) <= butt_conflicts(plates, width, (x0, x1), stagger)
    for m in merges:
        assert m.merged_width <= stock.max_width * (1 + 1e-9)
    assert len(merged) <= len(plates) - len(merges)  # (a moved butt may close a plate without steel)
    steel = [width(p) for p in merged if width(p) > 0.0]
    before = [width(p) for p in plates if width(p) > 0.0]
    assert min(steel, default=np.inf) >= min(before, default=np.inf) - 1e-6
    for p in merged:
        length, w = size_of(p[0], p[1], *p[2])
        if w > 0.0 and p not in plates:
            assert length <= stock.max_length * (1 + 1e-9) and w <= stock.max_width * (1 + 1e-9)


def test_kcs_flat_of_bottom_slivers_merge_into_drop_strakes(tmp_path):
    """KCS's yard layout (the shipped config, planned without evaluating): its flat of bottom,
    trimmed to 1128 of its 2622 m2, left three strakes' end plates at the trim 0.26, 0.58 and
    0.87 m wide (of 3.15 m) where the stock's least width is 1 m. Each merges across its seam
    into the next strake's plate there (a drop strake), 3.3 to 4.0 m wide inside the trim;
    what stays is the centreline strake's run-out at the bow, 30 m of a flat of bottom
    narrowing to nothing (0.28 and 0.09 m), which no plate beside it on the face can take.
    Independently (the face is a horizontal plane: (x, y) is its development): the plates cut
    at the trim add up to the trimmed area and do not overlap, and no butts meet a seam closer
    than the 300 mm stagger."""
    import shapely
    from shapely.geometry import Polygon

    from flatten.patch import region_grid
    from pipeline.hull.plan import load_run
    from pipeline.hull.planner import trimmed_size
    from pipeline.hull.trimcut import cut_at_trim
    from pipeline.hull.trims import trimmed_area
    from pipeline.hull.yardrules import butt_violations

    source = ROOT / "configs" / "kcs_shell.yaml"
    data = with_files_from(yaml.safe_load(source.read_text()), source.parent)
    path = tmp_path / "kcs.yaml"
    path.write_text(yaml.safe_dump(data))
    parts = [p for p in load_run(path).parts if p.name.startswith("kcs_P4_")]
    widths, pieces = {}, []
    for p in parts:
        h = p.hull
        widths[p.name] = trimmed_size(h.surface, h.long_axis, h.girths, h.butts, h.face_trim)[2]
        grid = region_grid(h.surface, h.long_axis, h.girths[0], h.girths[1],
                           [None if b is None else b.as_tuple() for b in h.butts], 41, 161)
        assert np.ptp(grid.points[..., 2]) < 1e-6
        xy = grid.points[..., :2].reshape(-1, 2)
        cut = cut_at_trim(h.face_trim, grid.params, xy, grid.faces())
        ring = xy.reshape(*grid.points.shape[:2], 2)
        ring = np.vstack([ring[0], ring[1:, -1], ring[-1, -2::-1], ring[-2:0:-1, 0]]) if cut is None else cut.outline
        pieces.append(Polygon(ring).buffer(0))
    merged = sorted(n for n in widths if "-" in n.split("_")[2])
    assert merged == ["kcs_P4_S01-02_B09", "kcs_P4_S02-03_B10", "kcs_P4_S03-04_B11"]
    assert all(3300.0 <= widths[n] <= 4000.0 for n in merged), {n: widths[n] for n in merged}
    assert sorted(n for n, w in widths.items() if w < 1000.0) == ["kcs_P4_S04_B13", "kcs_P4_S04_B14"]
    _, inside = trimmed_area(parts[0].hull.surface, parts[0].hull.face_trim, 401)
    total = sum(piece.area for piece in pieces)
    assert total == pytest.approx(inside, rel=3e-3)
    assert shapely.unary_union(pieces).area == pytest.approx(total, rel=1e-4)  # no two plates over each other
    assert butt_violations(parts, 300.0) == []
