"""Solver speed: batched rulings vs a per-ruling baseline, in one run.

    python bench/bench_solver.py [--rulings 1000000] [--baseline 2000]

Prints
  0. end-to-end rulings/s from the two curves to T(t): one full solve (every branch
     traced, certified and judged, the path chosen) plus the rulings on the path, at
     32, 1e3 and 1e5 rulings (what a plate run pays);
  1. the path refinement alone, after the solve (batched Newton on f(t, .) seeded by the
     traced branch) against scipy.optimize.brentq on g(t, .) one ruling at a time,
     bracketed by the same branch: this excludes the solve;
  2. the all-roots solver (every real root on every span of d, batched companion
     eigenvalues after a Bernstein sign filter) against numpy.roots per t and span;
and the ratios. Single-threaded BLAS, cubic curves with 5 spans each.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from flatten import normalized_residual, nurbs_curve, rulings_on_path, solve  # noqa: E402


def plate_pair():
    """Two cubic B-splines (8 poles, 5 spans) bounding a gently curved plate, metres."""
    x = np.linspace(0.0, 12.0, 8)
    c = nurbs_curve(np.column_stack([x, 0.4 * np.sin(x / 4), 0.05 * x]), 3,
                    knots=[0, 0, 0, 0, 0.15, 0.35, 0.45, 0.7, 1, 1, 1, 1], name="c")
    d = nurbs_curve(np.column_stack([x * 1.02, 2.2 + 0.6 * np.sin(x / 4 + 0.2), 1.5 + 0.08 * x]), 3,
                    knots=[0, 0, 0, 0, 0.2, 0.3, 0.5, 0.8, 1, 1, 1, 1], name="d")
    return c, d


def g_scalar(c, d, t, T):
    pc, dc = c.derivatives(np.array([t]), 1)
    pd, dd = d.derivatives(np.array([T]), 1)
    return float(np.cross(dc[0], dd[0]) @ (pd[0] - pc[0]))


def timed(fn, *args):
    start = time.perf_counter()
    out = fn(*args)
    return time.perf_counter() - start, out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rulings", type=int, default=1_000_000)
    parser.add_argument("--baseline", type=int, default=2000)
    args = parser.parse_args(argv)
    c, d = plate_pair()
    solve_time, solution = timed(solve, c, d)
    assert solution, solution.message
    path = solution.path
    t_lo, t_hi = path.points[0, 0], path.points[-1, 0]
    print(f"machine: {platform.machine()} {platform.processor() or ''} python {platform.python_version()}, "
          f"numpy {np.__version__}")
    print(f"full solve (all branches, judged, path chosen): {solve_time:.3f} s, "
          f"{len(solution.branches)} branches, coverage c {path.coverage.c_fraction:.4f} "
          f"d {path.coverage.d_fraction:.4f}")

    # 0. end to end: curves -> every branch -> path -> T at n rulings
    print()
    print(f"{'end to end: solve + rulings on the path':<44}{'rulings/s':>14}{'solve s':>10}{'rulings s':>11}")
    for n in (32, 1000, 100_000):
        start = time.perf_counter()
        sol = solve(c, d)
        mid = time.perf_counter()
        tt = np.linspace(sol.path.points[0, 0], sol.path.points[-1, 0], n)
        rulings_on_path(sol, tt)
        end = time.perf_counter()
        print(f"{'  ' + format(n, ',') + ' rulings':<44}{n / (end - start):>14.3e}{mid - start:>10.3f}{end - mid:>11.4f}")

    # 1. rulings on the chosen path, after the solve
    t = np.linspace(t_lo, t_hi, args.rulings)
    rulings_on_path(solution, t[:1000])  # warm up
    ours_time, T = timed(rulings_on_path, solution, t)
    sample = np.random.default_rng(0).choice(len(t), 20000, replace=False)
    residual = normalized_residual(c, d, t[sample], T[sample]).max()

    tb = np.linspace(t_lo, t_hi, args.baseline)
    guess = np.interp(tb, path.points[:, 0], path.points[:, 1])
    width = 0.02 * np.ptp(d.domain)

    def baseline_rulings():
        out = np.empty_like(tb)
        for k, (tk, Tk) in enumerate(zip(tb, guess)):
            lo, hi = max(Tk - width, d.domain[0]), min(Tk + width, d.domain[1])
            out[k] = brentq(lambda x: g_scalar(c, d, tk, x), lo, hi, xtol=1e-15, rtol=1e-15)
        return out

    base_time, T_base = timed(baseline_rulings)
    agree = np.abs(T_base - rulings_on_path(solution, tb)).max()
    ours_rate = args.rulings / ours_time
    base_rate = args.baseline / base_time
    print()
    print(f"{'path refinement only (solve excluded)':<44}{'rulings/s':>14}{'max residual':>16}")
    print(f"{'devflat batched Newton (' + str(args.rulings) + ')':<44}{ours_rate:>14.3e}{residual:>16.2e}")
    print(f"{'scipy brentq per ruling (' + str(args.baseline) + ')':<44}{base_rate:>14.3e}{'':>16}")
    print(f"{'ratio':<44}{ours_rate / base_rate:>14.1f}x   (max |T diff| {agree:.1e})")

    # 2. every real root on every span of d
    n_all = max(args.rulings // 10, 1000)
    ta = np.linspace(*c.domain, n_all)
    all_time, (line, roots, _) = timed(solution.field.roots_in_T, ta)
    tn = np.linspace(*c.domain, args.baseline)

    def baseline_all_roots():
        coefs = solution.field.polynomials_in_T(tn)
        count = 0
        for row in coefs:
            for poly in row:
                r = np.roots(poly[::-1])
                count += np.count_nonzero((np.abs(r.imag) < 1e-9) & (r.real >= 0) & (r.real <= 1))
        return count

    base_all_time, _ = timed(baseline_all_roots)
    print()
    print(f"{'all roots in T for a batch of t':<44}{'lines/s':>14}{'roots/line':>16}")
    print(f"{'devflat batched (' + str(n_all) + ')':<44}{n_all / all_time:>14.3e}{len(roots) / n_all:>16.2f}")
    print(f"{'numpy.roots per t and span (' + str(args.baseline) + ')':<44}{args.baseline / base_all_time:>14.3e}")
    print(f"{'ratio':<44}{(n_all / all_time) / (args.baseline / base_all_time):>14.1f}x")
    certification_share()
    point_evaluation(solution.field)
    refine_per_call(solution)
    growth_in_spans()
    stage_breakdown()
    return 0


def spans_pair(n_spans: int):
    """A gently curved plate's seams as cubic B-splines with n_spans uniform spans each."""
    n = n_spans + 3
    x = np.linspace(0.0, 12.0, n)
    c = nurbs_curve(np.column_stack([x, 0.4 * np.sin(x / 4), 0.05 * x]), 3, name="c")
    d = nurbs_curve(np.column_stack([x * 1.02, 2.2 + 0.6 * np.sin(x / 4 + 0.2), 1.5 + 0.08 * x]), 3, name="d")
    return c, d


def point_evaluation(field, n: int = 20000) -> None:
    """The tracer's unit of work: f and its gradient at one point (the continuation
    takes about three per step)."""
    from flatten.tracer import _UnitField

    unit = _UnitField(field)
    points = np.random.default_rng(1).uniform(0.0, 1.0, (n, 2)).tolist()
    start = time.process_time()
    for u, U in points:
        unit.value_gradient(u, U)
    each = (time.process_time() - start) / n
    print()
    print(f"tracer point evaluation (f and gradient at one point): {each * 1e6:.1f} us CPU   "
          "(before: ~26 us, issue 15)")


def refine_per_call(solution, repeat: int = 200) -> None:
    """CPU per call of the path refinement for the few points the pipeline asks at a time
    (strip sampling, corner rulings, marks: 1 to ~75 points a call), 8 Newton iterations."""
    path, field = solution.path.points, solution.field
    row = []
    for n in (1, 8, 75):
        t = np.linspace(path[0, 0], path[-1, 0], n)
        guess = np.interp(t, path[:, 0], path[:, 1])
        field.refine_T(t, guess, 8)
        start = time.process_time()
        for _ in range(repeat):
            field.refine_T(t, guess, 8)
        row.append(f"{n} points {(time.process_time() - start) / repeat * 1e6:.0f} us")
    print(f"path refinement per call (refine_T, 8 iterations, CPU): {', '.join(row)}")


# issue 15's before-figures (bench_solver on this 2-core machine, 2026-11-23, before the
# float tracer and the cell filter of the line solver): CPU s and tracemalloc peak MB
BEFORE_SPANS = {5: (0.046, 0.6), 25: (0.064, 1.2), 50: (0.097, 4.5), 100: (0.193, 17.9), 200: (0.561, 71.3)}
TARGET_SPANS = {5: ("<= 0.010", ""), 200: ("<= 0.200", "<= 50")}


def growth_in_spans(repeat: int = 3) -> None:
    """Solve CPU time (median of ``repeat`` runs) and peak memory traced by tracemalloc
    (numpy arrays included) against the span count of both curves, beside issue 15's
    before-figures and targets."""
    import tracemalloc

    print()
    print(f"{'solve against spans (both curves)':<34}{'cpu s':>9}{'peak MB':>9}{'branches':>9}"
          f"{'before s':>10}{'before MB':>10}{'target s':>10}{'target MB':>10}")
    rows = []
    for n_spans in (5, 25, 50, 100, 200):
        c, d = spans_pair(n_spans)
        times = []
        for _ in range(repeat):
            start = time.process_time()
            solution = solve(c, d)
            times.append(time.process_time() - start)
        cpu = float(np.median(times))
        tracemalloc.start()  # a further solve for the memory (tracing slows Python down)
        solve(c, d)
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
        before_s, before_mb = BEFORE_SPANS[n_spans]
        target_s, target_mb = TARGET_SPANS.get(n_spans, ("", ""))
        rows.append((n_spans, cpu))
        print(f"{'  ' + str(n_spans) + ' x ' + str(n_spans) + ' spans':<34}{cpu:>9.4f}{peak:>9.1f}"
              f"{len(solution.branches):>9}{before_s:>10.3f}{before_mb:>10.1f}{target_s:>10}{target_mb:>10}")
    spans, cpu = np.array(rows).T
    big = spans >= 25
    slope = np.polyfit(np.log(spans[big]), np.log(cpu[big]), 1)[0]
    print(f"  fitted exponent of CPU time against spans (>= 25 spans): {slope:.2f}   (linear = 1.00; "
          "before: 2.4 above 50 spans, as issue 15 measured it)")


def random_cubic_pair(seed: int):
    """The random pairs of tests/test_solver.py (4-7 poles, polynomial cubics)."""
    rng = np.random.default_rng(seed)
    n_c, n_d = rng.integers(4, 8, size=2)
    c = nurbs_curve(rng.uniform(-1, 1, size=(n_c, 3)), 3, name="c")
    d = nurbs_curve(rng.uniform(-1, 1, size=(n_d, 3)) + [0, 0, 2.0], 3, name="d")
    return c, d


# the same 21 pairs on the code before issue 15's work (44edf27), CPU seconds, measured on
# this machine beside this code (2026-11-23, load ~12 on 2 cores): median, total
BEFORE_PAIRS_CPU = (0.230, 5.08)


def certification_share(n_pairs: int = 20) -> None:
    """Share of a solve spent certifying (Bernstein exclusion, critical points, the
    check that every sign-change box is met by a branch), per the CERTIFICATE finding;
    and the CPU time of the same solves beside the code before issue 15's work."""
    rows = []
    pairs = [plate_pair()] + [random_cubic_pair(seed) for seed in range(n_pairs)]
    for c, d in pairs:
        start, cpu = time.perf_counter(), time.process_time()
        solution = solve(c, d)
        total, cpu = time.perf_counter() - start, time.process_time() - cpu
        cert = next(f for f in solution.findings if f.code == "CERTIFICATE").data
        rows.append((total, cert["certify_seconds"], cpu))
    rows = np.array(rows)
    print()
    print(f"certification share of a solve ({len(pairs)} cubic pairs: the plate + {n_pairs} random pairs)")
    print(f"{'':<44}{'median s':>12}{'total s':>12}")
    print(f"{'full solve (certified), wall':<44}{np.median(rows[:, 0]):>12.4f}{rows[:, 0].sum():>12.3f}")
    print(f"{'  of which certification':<44}{np.median(rows[:, 1]):>12.4f}{rows[:, 1].sum():>12.3f}")
    print(f"{'  solve without it (trace + judge)':<44}{np.median(rows[:, 0] - rows[:, 1]):>12.4f}"
          f"{(rows[:, 0] - rows[:, 1]).sum():>12.3f}")
    print(f"{'certification share':<44}{np.median(rows[:, 1] / rows[:, 0]):>11.1%} {rows[:, 1].sum() / rows[:, 0].sum():>11.1%}")
    print(f"{'full solve, CPU':<44}{np.median(rows[:, 2]):>12.4f}{rows[:, 2].sum():>12.3f}")
    print(f"{'  before (44edf27, CPU, printed constant)':<44}{BEFORE_PAIRS_CPU[0]:>12.4f}{BEFORE_PAIRS_CPU[1]:>12.3f}")


def stage_breakdown() -> None:
    """One plate end to end (configs/plate.yaml), time per stage, warm: an untimed first
    pass does the stages' imports (trimesh, ezdxf, matplotlib: ~0.6 s that a first pass
    would put on the strip and the export)."""
    import tempfile
    from pathlib import Path

    from pipeline.config import load_config
    from pipeline.export import export_part
    from pipeline.stages import PartResult, stage_check, stage_strip, stage_unroll

    root = Path(__file__).resolve().parents[1]
    config = load_config(root / "configs" / "plate.yaml")
    part = config.parts[0]

    def one_pass() -> tuple[dict, PartResult]:
        result = PartResult(part.name, part)
        times = {}
        start = time.perf_counter()
        result.solution = solve(part.c, part.d)
        times["solve (all branches)"] = time.perf_counter() - start
        t0 = time.perf_counter()
        stage_strip(result, config)
        times["strip"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        stage_check(result, config)
        times["check (libigl, 256-ruling check mesh)"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        stage_unroll(result)
        times["unroll + cross-check + metrics"] = time.perf_counter() - t0
        result.status = "ok"
        result.figures["steel"] = {"thickness_mm": 12, "material": "S355", "area_m2": 1.0, "weight_kg": 1.0,
                                   "marked_side": "moulded"}
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            export_part(result, config, Path(tmp))
            times["export (DXF, OBJ, JSON, 2 PNG, PDF)"] = time.perf_counter() - t0
        return times, result

    one_pass()  # the imports
    times, result = one_pass()
    total = sum(times.values())
    print()
    print(f"one plate end to end, warm (imports done): configs/plate.yaml, {result.strip.n_rulings} rulings")
    for name, value in times.items():
        print(f"  {name:<42}{value:>8.3f} s {100 * value / total:>5.1f}%")
    print(f"  {'total':<42}{total:>8.3f} s")
    cpu = []
    for _ in range(5):
        t0 = time.process_time()
        solve(part.c, part.d)
        cpu.append(time.process_time() - t0)
    print(f"  solve again, CPU median of 5: {np.median(cpu):.4f} s   (before, issue 15's run: 0.155 s wall "
          "in this table; ~55 ms fixed cost per solve on a quiet machine)")


if __name__ == "__main__":
    sys.exit(main())
