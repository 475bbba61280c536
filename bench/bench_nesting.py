"""Nesting against a bounding-box rectangle packer, on the same parts, in one run.

    python bench/bench_nesting.py [--time 20] [--seed 1] [--quantity 2]

devflat (spyrrow, irregular strip packing of the real outlines, each case with the stated
time budget) against rectpack (pip install '.[bench]'): each part replaced by its bounding
box in the same reference orientation, the best of several rectpack algorithms and sort
orders. Both keep the same spacing (rectangles grown by it) and the same allowed
orientations (textile: the grain along the roll, 0/180, so no 90-degree turn for the
rectangles; steel: 0/90/180/270).

Cases: the lampshade pieces x the config's quantity on a 900 mm roll; the eight panels of
configs/mainsail.yaml on a 1370 mm roll; the ten plates of configs/hullmod_strake.yaml on
3 x 12 m stock (they are 16 m long: none fits, which is the finding) and on 3 x 18 m stock,
and the same two strakes cut by a butt every 8 m (20 plates) on 3 x 12 m stock.
Marker figures: length and efficiency (pieces' area / roll area used); stock figures:
plates used and utilisation (parts' area / plates' area).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from pipeline.config import NestingSpec  # noqa: E402
from pipeline.nest.engine import nest_marker, nest_stock  # noqa: E402
from pipeline.nest.command import build_job  # noqa: E402
from pipeline.hull.plan import load_run  # noqa: E402
from pipeline.hull.plates import run_part  # noqa: E402

ALGORITHMS = ("MaxRectsBl", "MaxRectsBssf", "MaxRectsBaf", "MaxRectsBlsf", "SkylineBl", "SkylineMwf",
              "SkylineMwfl", "GuillotineBssfSas", "GuillotineBafSas", "GuillotineBlsfSas")
SORTS = ("SORT_AREA", "SORT_PERI", "SORT_DIFF", "SORT_SSIDE", "SORT_LSIDE", "SORT_RATIO", "SORT_NONE")


def items_of(config_path: Path, nesting: dict):
    config = load_run(config_path)
    config.spec = config.spec.model_copy(update={"nesting": NestingSpec(**nesting)})
    results = [run_part(p, config) for p in config.parts]
    failed = [r.name for r in results if not r.ok]
    job = build_job(results, config)
    return [it for items in job.groups.values() for it in items], failed


def boxes(items) -> list[tuple[str, float, float, int]]:
    """(id, extent across the roll/stock width, extent along it, quantity) of each item in
    its reference orientation."""
    out = []
    for it in items:
        ref = it.reference()
        span = np.ptp(ref, axis=0)
        out.append((it.id, float(span[1]), float(span[0]), it.quantity))
    return out


def rect_strip(items, width: float, spacing: float, rotation: bool) -> tuple[float, str]:
    """Best rectpack strip length over algorithms and sort orders: the bin is the roll
    (x across its width, y along it), rectangles grown by the spacing; bottom-left style
    packers keep y (the length) small."""
    import rectpack

    grow = spacing
    rects = [(math.ceil(w + grow), math.ceil(h + grow), f"{k}:{i}") for i, (k, w, h, q) in enumerate(boxes(items))
             for _ in range(q)]
    total = sum(r[1] for r in rects) + 10
    best = (math.inf, "")
    for algo in ALGORITHMS:
        for sort in SORTS:
            packer = rectpack.newPacker(mode=rectpack.PackingMode.Offline, bin_algo=rectpack.PackingBin.BFF,
                                        pack_algo=getattr(rectpack, algo), sort_algo=getattr(rectpack, sort),
                                        rotation=rotation)
            for w, h, rid in rects:
                packer.add_rect(w, h, rid)
            packer.add_bin(math.floor(width + grow), total)
            packer.pack()
            placed = packer.rect_list()
            if len(placed) != len(rects):
                continue
            length = max(y + h for _, x, y, w, h, _ in placed) - grow
            if length < best[0]:
                best = (length, f"{algo}/{sort}")
    return best


def rect_stock(items, width: float, length: float, spacing: float) -> tuple[int, str, int]:
    """Fewest stock plates rectpack needs (rotation allowed), over algorithms and sorts;
    also how many rectangles fit no plate."""
    import rectpack

    grow = spacing
    rects = [(math.ceil(w + grow), math.ceil(h + grow), f"{k}:{i}") for i, (k, w, h, q) in enumerate(boxes(items))
             for _ in range(q)]
    fits = [r for r in rects if (r[0] <= width + grow and r[1] <= length + grow) or
            (r[1] <= width + grow and r[0] <= length + grow)]
    best = (math.inf, "", len(rects) - len(fits))
    if not fits:
        return 0, "-", len(rects)
    for algo in ALGORITHMS:
        for sort in SORTS:
            packer = rectpack.newPacker(mode=rectpack.PackingMode.Offline, bin_algo=rectpack.PackingBin.BFF,
                                        pack_algo=getattr(rectpack, algo), sort_algo=getattr(rectpack, sort),
                                        rotation=True)
            for w, h, rid in fits:
                packer.add_rect(w, h, rid)
            packer.add_bin(math.floor(width + grow), math.floor(length + grow), count=len(fits))
            packer.pack()
            if len(packer.rect_list()) != len(fits):
                continue
            if len(packer) < best[0]:
                best = (len(packer), f"{algo}/{sort}", len(rects) - len(fits))
    return best


def marker_case(name, config, nesting, args):
    items, failed = items_of(config, nesting)
    width, spacing = nesting["fabric_width"], nesting.get("spacing", 0.0)
    area = sum(it.area * it.quantity for it in items)
    start = time.perf_counter()
    ours = nest_marker(items, width, spacing, 0.0, args.time, args.seed, 1)
    took = time.perf_counter() - start
    start = time.perf_counter()
    rect_len, algo = rect_strip(items, width, spacing, rotation=False)
    rect_took = time.perf_counter() - start
    n = sum(it.quantity for it in items)
    print(f"\n{name}: {n} pieces ({len(items)} distinct), roll {width:g} mm, spacing {spacing:g} mm, "
          f"pieces' area {area / 1e6:.4f} m2" + (f"; failed parts: {failed}" if failed else ""))
    print(f"  {'method':<44}{'length mm':>11}{'efficiency':>12}{'time s':>9}")
    eff = ours.figures["efficiency"]
    print(f"  {'devflat / spyrrow (budget %d s)' % args.time:<44}{ours.figures['marker_length']:>11.1f}"
          f"{100 * eff:>11.1f}%{took:>9.1f}")
    rect_eff = area / (width * rect_len)
    print(f"  {'rectpack bounding boxes (' + algo + ')':<44}{rect_len:>11.1f}{100 * rect_eff:>11.1f}%"
          f"{rect_took:>9.1f}")
    print(f"  gain: {100 * (eff - rect_eff):+.1f} percentage points, marker {100 * (1 - ours.figures['marker_length'] / rect_len):.1f}% "
          f"shorter; layout check {'passed' if ours.checks['passed'] else 'FAILED'} "
          f"(min gap {ours.checks['min_gap']:.3f} mm)")


def stock_case(name, config, stock, spacing, args, items=None):
    if items is None:
        items, failed = items_of(config, {"stock": {"width": stock[0], "length": stock[1]}, "spacing": spacing})
    area = sum(it.area * it.quantity for it in items)
    start = time.perf_counter()
    ours = nest_stock(items, [("stock", *stock)], spacing, 0.0, args.time, args.seed, 1)
    took = time.perf_counter() - start
    start = time.perf_counter()
    rect_n, algo, rect_unfit = rect_stock(items, stock[0], stock[1], spacing)
    rect_took = time.perf_counter() - start
    n = sum(it.quantity for it in items)
    print(f"\n{name}: {n} plates on {stock[0] / 1000:g} x {stock[1] / 1000:g} m stock, spacing {spacing:g} mm, "
          f"parts' area {area / 1e6:.2f} m2")
    print(f"  {'method':<44}{'plates':>7}{'unplaced':>10}{'utilisation':>13}{'time s':>9}")
    unplaced = sum(u["copies"] for u in ours.unplaced)
    placed_area = ours.figures["parts_area"]
    util = ours.figures["utilisation"]
    print(f"  {'devflat / spyrrow (budget %d s)' % args.time:<44}{ours.figures['plates']:>7}{unplaced:>10}"
          f"{100 * util:>12.1f}%{took:>9.1f}")
    rect_util = placed_area / (rect_n * stock[0] * stock[1]) if rect_n else 0.0
    print(f"  {'rectpack bounding boxes (' + algo + ')':<44}{rect_n:>7}{rect_unfit:>10}{100 * rect_util:>12.1f}%"
          f"{rect_took:>9.1f}")
    if ours.unplaced:
        print(f"  not placed: {ours.unplaced[0]['reason']}")
    print(f"  layout check {'passed' if ours.checks['passed'] else 'FAILED'}")
    return items


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--time", type=int, default=20, help="engine budget per case, seconds")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--quantity", type=int, default=None, help="lampshade copies of each piece "
                        "(default: the config's textile quantity)")
    args = parser.parse_args()
    import platform

    import spyrrow

    print(f"machine: {platform.machine()} {os.cpu_count()} cores, python {platform.python_version()}, "
          f"spyrrow {spyrrow.__version__}, one engine worker; budget {args.time} s per nesting")
    lamp = {"fabric_width": 900.0, "spacing": 2.0}
    if args.quantity:
        lamp["quantities"] = {f"lampshade_{k}": args.quantity for k in (1, 2, 3)}
    marker_case("lampshade (configs/lampshade.yaml)", ROOT / "configs" / "lampshade.yaml", lamp, args)
    marker_case("mainsail, 8 panels (configs/mainsail.yaml)", ROOT / "configs" / "mainsail.yaml",
                {"fabric_width": 1370.0, "spacing": 3.0}, args)
    hull = ROOT / "configs" / "hullmod_strake.yaml"
    items = stock_case("hullmod strake plates (configs/hullmod_strake.yaml)", hull, (3000.0, 12000.0), 10.0, args)
    stock_case("hullmod strake plates (configs/hullmod_strake.yaml)", hull, (3000.0, 18000.0), 10.0, args, items)
    # the same two strakes with a butt every 8 m (as bench_strake.py): plates that fit 12 m stock
    import tempfile

    import yaml

    data = yaml.safe_load(hull.read_text())
    data["strake"]["surface"]["iges"] = str(ROOT / "tests" / "data" / "ship" / "test_1_hull_exported.igs")
    data["strake"]["butts"] = [56000.0 + 8000.0 * k for k in range(11)]
    data["name"] = "hullmod_8m"
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hullmod_8m.yaml"
        path.write_text(yaml.safe_dump(data))
        stock_case("hullmod strakes, butts every 8 m", path, (3000.0, 12000.0), 10.0, args)


if __name__ == "__main__":
    main()
