"""A whole strake of >= 100 hull plates in one run: plates per second and peak memory,
single process and with --jobs 2, side by side.

    python bench/bench_strake.py [--seams 13] [--butts 11] [--repeat 3] [--before DIR]

The 160 m hull of tests/data/ship (hullmod): seams are iso-curves v = 4.0, 4.05, ... of its
surface, butts every 8 m from x = 56 m; (seams - 1) x (butts - 1) plates, each solved,
trimmed, checked, unrolled, fitted to the hull and written (DXF, OBJ, JSON; no PNGs).
Each run is a fresh process started as the ``devflat`` program starts (its time includes
the interpreter's start and the imports), with its bytecode compiled once, by an untimed
one-plate run, as an installed devflat has it.
Besides wall time it prints the CPU time of the run (parent and workers): on a machine
shared with other jobs wall time measures them too, so the last line gives the plates per
second the CPU time allows on idle cores. The runs are repeated ``--repeat`` times,
single process and ``--jobs 2`` interleaved, and the median run of each is printed with
every round's plates per second (this machine's speed moves by half within an hour).

    python bench/bench_strake.py --before DIR

runs an earlier checkout (``git worktree add DIR REV``) in the same rounds, interleaved
with this one, and prints the ratios: the comparison that a noisy machine still allows.

    python bench/bench_strake.py --stages [--every 4]

runs every 4th plate in this process instead and prints the CPU time per plate of each
stage (nested stages are inside their callers: the column does not add up).
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def config(seams: int, butts: int) -> dict:
    return {"name": "bench", "units": "mm",
            "strake": {"surface": {"iges": str(ROOT / "tests" / "data" / "ship" / "test_1_hull_exported.igs")},
                       "seams": [{"iso": {"v": round(4.0 + 0.05 * k, 4)}} for k in range(seams)],
                       "butts": [56000.0 + 8000.0 * k for k in range(butts)],
                       "frames": {"spacing": 2500}, "margin": 0.2, "fit_tolerance": 5.0},
            "resolution": {"chord_tolerance": 1.0}, "output": {"png": False}}


def one(args) -> int:
    """One run in this fresh process, as the ``devflat`` program runs it
    (:func:`pipeline.cli.run_program`: one BLAS thread, the collector paused for the
    imports, ``one_shot``)."""
    if args.root:  # the code of another checkout (--before): first on the path
        sys.path.insert(0, args.root)
    from pipeline.cli import run_program

    code = run_program(["run", args.config, "--out", args.out, "--quiet", "--jobs", str(args.jobs)])
    self_use, child_use = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = self_use.ru_utime + self_use.ru_stime + child_use.ru_utime + child_use.ru_stime
    print(json.dumps({"code": code, "peak_mb": self_use.ru_maxrss / 1024,
                      "worker_peak_mb": child_use.ru_maxrss / 1024, "cpu_seconds": cpu,
                      "parent_cpu_seconds": self_use.ru_utime + self_use.ru_stime}))
    return 0


# (module, function, what it is): the stages timed by --stages, in the order printed
STAGES = [
    ("pipeline.hull.plates", "run_part", "the plate: class, strip, shop data (no files)"),
    ("pipeline.hull.plates", "_grid", "  region grid of the plate on the hull (two region_grid)"),
    ("pipeline.stages", "develop_part", "  solve, strip, unroll, check (both families)"),
    ("flatten.solver", "solve", "    solve"),
    ("pipeline.stages", "stage_strip", "    rulings and strip mesh"),
    ("pipeline.hull.platestrip", "butt_family", "  butt-to-butt family (sections, solve, trim)"),
    ("pipeline.hull.platestrip", "section_curves", "    butt sections"),
    ("pipeline.hull.strake", "cut_at_butts", "  cut by the butt planes, hull distance"),
    ("pipeline.hull.strake", "stage_trim", "  the cut strip laid flat"),
    ("pipeline.shop.marks", "frame_polylines", "    frame lines"),
    ("pipeline.shop.plate", "stage_shop", "  shop data"),
    ("pipeline.shop.outline", "exact_outline", "    exact outline"),
    ("pipeline.shop.outline", "_corners", "      plate corners"),
    ("pipeline.shop.bending", "bending_lines", "    bending lines"),
    ("pipeline.export", "export_part", "the plate's files"),
    ("pipeline.shop.layout", "plate_layout", "  text layout"),
    ("pipeline.shop.dxf", "write_steel_dxf", "  DXF"),
    ("pipeline.export", "write_obj", "  OBJ"),
]


def stages(args) -> int:
    """CPU time per plate of each stage, every ``args.every``-th plate, in this process."""
    from pipeline.cli import library_threads

    library_threads()  # as the program runs (before numpy loads)
    import functools
    import importlib

    import pipeline.export
    import pipeline.hull.plates
    from pipeline.hull.plan import load_run

    spent = {name: 0.0 for _, name, _ in STAGES}
    for module, name, _ in STAGES:
        original = getattr(importlib.import_module(module), name)

        def timed(*a, _f=original, _name=name, **k):
            start = time.process_time()
            try:
                return _f(*a, **k)
            finally:
                spent[_name] += time.process_time() - start
        functools.update_wrapper(timed, original)
        for loaded in list(sys.modules.values()):  # every module that imported it by name
            if getattr(loaded, "__name__", "").startswith(("pipeline", "flatten")) and \
                    getattr(loaded, name, None) is original:
                setattr(loaded, name, timed)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "strake.yaml"
        path.write_text(yaml.safe_dump(config(args.seams, args.butts)))
        plan = load_run(path)
        parts = plan.parts[::args.every]
        start = time.process_time()
        for k, part in enumerate(parts):
            folder = Path(tmp) / f"part{k}"
            folder.mkdir()
            pipeline.export.export_part(pipeline.hull.plates.run_part(part, plan), plan, folder)
        total = time.process_time() - start
    print(f"{len(parts)} plates (every {args.every}th of {len(plan.parts)}), {1000 * total / len(parts):.0f} ms CPU "
          f"per plate in all")
    for _, name, label in STAGES:
        print(f"  {label:<58}{1000 * spent[name] / len(parts):8.1f} ms")
    return 0


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value}: give 1 or more rounds")
    return value


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seams", type=int, default=13)
    parser.add_argument("--butts", type=int, default=11)
    parser.add_argument("--stages", action="store_true", help="CPU time per plate of each stage, in this process")
    parser.add_argument("--every", type=int, default=4, help="with --stages: every n-th plate")
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--config", help=argparse.SUPPRESS)
    parser.add_argument("--out", help=argparse.SUPPRESS)
    parser.add_argument("--jobs", type=int, default=1, help=argparse.SUPPRESS)
    parser.add_argument("--root", help=argparse.SUPPRESS)
    parser.add_argument("--repeat", type=_positive, default=3, help="rounds (the median run is printed)")
    parser.add_argument("--before", type=Path, help="an earlier checkout run in the same rounds "
                        "(git worktree add DIR REV)")
    args = parser.parse_args(argv)
    if args.one:
        return one(args)
    if args.stages:
        return stages(args)
    import platform
    import statistics

    from bench_cli import child_env  # the children run as an installed devflat (bytecode cached)
    plates = (args.seams - 1) * (args.butts - 1)
    print(f"machine: {platform.machine()}, python {platform.python_version()}; {plates} plates "
          f"({args.seams - 1} strakes x {args.butts - 1} butt intervals) of the 160 m hull; "
          f"{args.repeat} rounds, interleaved")
    trees = [("this", ROOT)] + ([("before", args.before.resolve())] if args.before is not None else [])
    runs: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "strake.yaml"
        path.write_text(yaml.safe_dump(config(args.seams, args.butts)))
        one_plate = Path(tmp) / "one_plate.yaml"
        one_plate.write_text(yaml.safe_dump(config(2, 2)))
        envs = {label: child_env(Path(tmp) / f"pycache-{label}", root) for label, root in trees}

        def run(label: str, config_path: Path, jobs: int) -> dict:
            out = Path(tmp) / f"out-{label}-{jobs}"
            shutil.rmtree(out, ignore_errors=True)
            start = time.perf_counter()
            done = subprocess.run([sys.executable, __file__, "--one", "--config", str(config_path), "--out", str(out),
                                   "--jobs", str(jobs), "--root", str(dict(trees)[label])],
                                  capture_output=True, text=True, timeout=7200, env=envs[label])
            elapsed = time.perf_counter() - start
            if done.returncode:
                sys.exit(f"bench_strake: the run of {label} failed:\n{done.stderr}")
            measured = json.loads(done.stdout.strip().splitlines()[-1])
            if measured["code"] not in (0, 1):  # 2: that checkout refused the config (no files)
                sys.exit(f"bench_strake: devflat exited {measured['code']} in the run of {label}:\n{done.stderr}")
            summary = json.loads((out / "bench_summary.json").read_text())
            ok = sum(r["status"] == "ok" for r in summary["parts"])
            return dict(measured, seconds=elapsed, ok=ok)

        for label, _ in trees:  # untimed: fills each tree's bytecode cache
            run(label, one_plate, 1)
        for _ in range(args.repeat):
            for label, _ in trees:
                for jobs in (1, 2):
                    runs.setdefault((label, jobs), []).append(run(label, path, jobs))
    header = (f"{'run':<30}{'seconds':>9}{'plates/s':>10}{'ok':>5}{'CPU s':>8}{'parent CPU s':>14}"
              f"{'peak MB':>9}{'worker MB':>11}{'speed-up':>10}")
    median = {key: sorted(rows, key=lambda r: r["seconds"])[(len(rows) - 1) // 2] for key, rows in runs.items()}
    for label, _ in trees:
        print(f"{label}:" if len(trees) > 1 else "")
        print(header)
        print("-" * len(header))
        base = median[(label, 1)]["seconds"]
        for jobs in (1, 2):
            out = median[(label, jobs)]
            name = ("single process" if jobs == 1 else f"--jobs {jobs}") + f" (median of {args.repeat})"
            worker = f"{out['worker_peak_mb']:.0f}" if jobs > 1 else "-"
            print(f"{name:<30}{out['seconds']:>9.2f}{plates / out['seconds']:>10.2f}{out['ok']:>5}"
                  f"{out['cpu_seconds']:>8.1f}{out['parent_cpu_seconds']:>14.1f}{out['peak_mb']:>9.0f}{worker:>11}"
                  f"{base / out['seconds']:>10.2f}")
        for jobs in (1, 2):
            rounds = " ".join(f"{plates / r['seconds']:.1f}" for r in runs[(label, jobs)])
            print(f"  plates/s in each round, {'single process' if jobs == 1 else f'--jobs {jobs}'}: {rounds}")
        # on a shared machine wall time measures the neighbours too: what the CPU time allows
        # on 2 idle cores (the parent's serial part, then the plates spread over the workers)
        out = median[(label, 2)]
        serial = out["parent_cpu_seconds"]
        spread = (out["cpu_seconds"] - serial) / 2
        print(f"  --jobs 2 on 2 idle cores (from CPU time): {plates / (serial + spread):.1f} plates/s "
              f"(parent {serial:.1f} s serial, workers {out['cpu_seconds'] - serial:.1f} CPU s)")
    if len(trees) > 1:
        print("this / before, round by round (wall time ratio < 1: this is faster):")
        for jobs in (1, 2):
            ratios = [a["seconds"] / b["seconds"] for a, b in zip(runs[("this", jobs)], runs[("before", jobs)])]
            cpu = [a["cpu_seconds"] / b["cpu_seconds"] for a, b in zip(runs[("this", jobs)], runs[("before", jobs)])]
            print(f"  {'single process' if jobs == 1 else f'--jobs {jobs}':<16} wall "
                  + " ".join(f"{r:.3f}" for r in ratios) + f"  (median {statistics.median(ratios):.3f});"
                  f" CPU median {statistics.median(cpu):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
