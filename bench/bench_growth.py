"""Growth: time and peak memory of one plate against the ruling count (1e2 .. 1e6) and of a
run against the plate count, with the fitted exponents, in one run.

    python bench/bench_growth.py [--max-rulings 1000000] [--max-plates 16]

Each ruling count runs in a fresh process (peak RSS during the strip work above the RSS
after the imports and the solve: on Linux the solve's freed heap is handed back with
malloc_trim and the peak reset through /proc/self/clear_refs, elsewhere the solve's own
peak is the base; divided by the ruling count it is the
bytes per ruling, which include the results kept alive: rulings 16 B, strip vertices
120 B and faces 192 B, flat vertices 80 B and the development 32 B at 5 samples per
ruling, 440 B in all). Measured: rulings along the chosen path, strip mesh,
libigl curvature check, exact development, distortion figures; beside them the classic
triangle-by-triangle unfolding (a Python loop, the baseline) up to 1e5 rulings. The plate
count runs whole parts (solve included) of a Series 60 strake in one process.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

from common import ROOT, machine_line, s60_curves

import numpy as np  # noqa: E402

CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, {bench!r}); sys.path.insert(0, {root!r})
import common
import numpy as np
from flatten import solve
from flatten.develop import develop, unfold_triangles
from flatten.meshcheck import strip_angle_defects
from flatten.metrics import distortion
from flatten.strip import build_strip, choose_rulings
n, baseline = int(sys.argv[1]), sys.argv[2] == "1"
c, d = common.s60_curves()
solution = solve(c, d)


def status(key):
    for line in open("/proc/self/status"):
        if line.startswith(key + ":"):
            return int(line.split()[1])  # kB


try:  # Linux: hand the solve's freed heap back (malloc_trim) and reset the peak (VmHWM) to
    # the present RSS, so that neither the solve's peak nor its freed pages hide the strip's
    import ctypes
    import gc
    gc.collect()
    ctypes.CDLL("libc.so.6").malloc_trim(0)
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")
    base_rss = status("VmRSS")
    peak_now = lambda: status("VmHWM")
except (OSError, AttributeError):  # elsewhere: the peak so far (the solve's included) is the base
    base_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    peak_now = lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
times = {{}}
start = time.perf_counter()
rulings = choose_rulings(solution, c, d, n_rulings=n)
strip = build_strip(c, d, rulings, 5)
times["strip"] = time.perf_counter() - start
t0 = time.perf_counter(); strip_angle_defects(strip); times["check"] = time.perf_counter() - t0
t0 = time.perf_counter(); dev = develop(c, d, rulings, solution.field); times["develop"] = time.perf_counter() - t0
flat = dev.vertices(strip.samples)
k = np.arange(n) * 5
t0 = time.perf_counter()
distortion(strip.vertices, flat, 5, c, d, rulings)
times["metrics"] = time.perf_counter() - t0
times["total"] = time.perf_counter() - start
if baseline:
    t0 = time.perf_counter(); unfold_triangles(strip.vertices[k], strip.vertices[k + 4], dev)
    times["triangle_unfold"] = time.perf_counter() - t0
peak = peak_now()
print(json.dumps({{"times": times, "peak_mb": peak / 1024, "base_mb": base_rss / 1024}}))
"""


def slope(x, y) -> float:
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-rulings", type=int, default=1_000_000)
    parser.add_argument("--max-plates", type=int, default=16)
    args = parser.parse_args(argv)
    print(machine_line())
    script = CHILD.format(bench=str(ROOT / "bench"), root=str(ROOT))
    sizes = [n for n in (100, 1_000, 10_000, 100_000, 1_000_000) if n <= args.max_rulings]
    header = (f"{'rulings':>9}{'strip s':>10}{'check s':>10}{'develop s':>11}{'metrics s':>11}{'total s':>10}"
              f"{'peak MB':>10}{'B/ruling':>10}{'unfold s (baseline)':>22}")
    print(header)
    print("-" * len(header))
    totals, peaks, unfolds = [], [], []
    for n in sizes:
        done = subprocess.run([sys.executable, "-c", script, str(n), "1" if n <= 100_000 else "0"],
                              capture_output=True, text=True, timeout=3000)
        if done.returncode != 0:
            print(f"{n:>9}  failed: {done.stderr.strip()[-300:]}")
            continue
        out = json.loads(done.stdout.strip().splitlines()[-1])
        t = out["times"]
        peak = out["peak_mb"] - out["base_mb"]
        totals.append((n, t["total"]))
        peaks.append((n, max(peak, 1e-3)))
        unfold = t.get("triangle_unfold")
        if unfold is not None:
            unfolds.append((n, unfold))
        print(f"{n:>9}{t['strip']:>10.3f}{t['check']:>10.3f}{t['develop']:>11.3f}{t['metrics']:>11.3f}"
              f"{t['total']:>10.3f}{peak:>10.1f}{peak * 2**20 / n:>10.0f}{'' if unfold is None else f'{unfold:.3f}':>22}")
    big = [(n, v) for n, v in totals if n >= 10_000]
    if len(big) >= 2:
        print(f"fitted exponent of time (>= 1e4 rulings): {slope(*zip(*big)):.2f}   (linear = 1.00)")
    if peaks:
        n, peak = peaks[-1]
        print(f"bytes per ruling at {n} rulings: {peak * 2**20 / n:.0f} (target <= 600; 2850 before the batched "
              "temporaries, as issue 15 measured it: not re-measured here)")
    bigm = [(n, v) for n, v in peaks if n >= 10_000]
    if len(bigm) >= 2:
        print(f"fitted exponent of peak memory (>= 1e4 rulings): {slope(*zip(*bigm)):.2f}   (linear = 1.00)")
    if len(unfolds) >= 2:
        ours = dict(totals)
        print("triangle unfolding baseline exponent: "
              f"{slope(*zip(*[(n, v) for n, v in unfolds if n >= 1_000])):.2f}; at {unfolds[-1][0]} rulings it "
              f"takes {unfolds[-1][1] / ours[unfolds[-1][0]]:.1f}x devflat's whole per-plate work")

    # plate count: whole parts (solve, strip, check, unroll) of a strake, one process
    from pipeline.config import Check, Output, Resolution, RunSpec, Steel
    from pipeline.config import CurveSpec, CurvesSpec, Part, RunConfig
    from pipeline.stages import run_part

    spec = RunSpec(name="strake", curves=CurvesSpec(c=CurveSpec(control_points=[[0, 0, 0], [1, 0, 0]], degree=1),
                                                    d=CurveSpec(control_points=[[0, 1, 0], [1, 1, 0]], degree=1)),
                   resolution=Resolution(rulings=200), steel=Steel(), check=Check(min_coverage=0.0), output=Output())
    counts = [k for k in (1, 2, 4, 8, 16, 32) if k <= args.max_plates]
    print()
    print(f"{'plates':>7}{'time s':>10}{'s/plate':>10}{'ok':>5}")
    rows = []
    for k in counts:
        bands = np.linspace(0.15, 0.85, k + 1)
        length = np.linspace(0.3, 0.5, 2)
        parts = [Part(f"p{j}", *s60_curves(bands[j], bands[j + 1], *length), Steel()) for j in range(k)]
        config = RunConfig(spec, parts, ROOT / "bench")
        start = time.perf_counter()
        results = [run_part(p, config) for p in parts]
        elapsed = time.perf_counter() - start
        rows.append((k, elapsed))
        print(f"{k:>7}{elapsed:>10.3f}{elapsed / k:>10.3f}{sum(r.ok for r in results):>5}")
    if len(rows) >= 3:
        print(f"fitted exponent of time against plate count: {slope(*zip(*rows[1:])):.2f}   (linear = 1.00)")
    print(f"peak RSS of this process: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
