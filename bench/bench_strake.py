"""A whole strake of >= 100 hull plates in one run: plates per second and peak memory,
single process and with --jobs 2, side by side.

    python bench/bench_strake.py [--seams 13] [--butts 11]

The 160 m hull of tests/data/ship (hullmod): seams are iso-curves v = 4.0, 4.05, ... of its
surface, butts every 8 m from x = 56 m; (seams - 1) x (butts - 1) plates, each solved,
trimmed, checked, unrolled, fitted to the hull and written (DXF, OBJ, JSON; no PNGs).
"""

from __future__ import annotations

import argparse
import json
import resource
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
    from pipeline.cli import main as devflat

    start = time.perf_counter()
    code = devflat(["run", args.config, "--out", args.out, "--quiet", "--jobs", str(args.jobs)])
    elapsed = time.perf_counter() - start
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(json.dumps({"code": code, "seconds": elapsed, "peak_mb": own, "worker_peak_mb": children}))
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seams", type=int, default=13)
    parser.add_argument("--butts", type=int, default=11)
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--config", help=argparse.SUPPRESS)
    parser.add_argument("--out", help=argparse.SUPPRESS)
    parser.add_argument("--jobs", type=int, default=1, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        return one(args)
    import platform
    plates = (args.seams - 1) * (args.butts - 1)
    print(f"machine: {platform.machine()}, python {platform.python_version()}; {plates} plates "
          f"({args.seams - 1} strakes x {args.butts - 1} butt intervals) of the 160 m hull")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "strake.yaml"
        path.write_text(yaml.safe_dump(config(args.seams, args.butts)))
        for jobs in (1, 2):
            done = subprocess.run([sys.executable, __file__, "--one", "--config", str(path), "--out",
                                   str(Path(tmp) / f"out{jobs}"), "--jobs", str(jobs)],
                                  capture_output=True, text=True, timeout=7200)
            out = json.loads(done.stdout.strip().splitlines()[-1])
            summary = json.loads((Path(tmp) / f"out{jobs}" / "bench_summary.json").read_text())
            ok = sum(r["status"] == "ok" for r in summary["parts"])
            rows.append((jobs, out, ok))
    header = f"{'run':<22}{'seconds':>10}{'plates/s':>10}{'ok':>6}{'peak MB':>10}{'worker peak MB':>16}{'speed-up':>10}"
    print(header)
    print("-" * len(header))
    base = rows[0][1]["seconds"]
    for jobs, out, ok in rows:
        label = "single process" if jobs == 1 else f"--jobs {jobs}"
        worker = f"{out['worker_peak_mb']:.0f}" if jobs > 1 else "-"
        print(f"{label:<22}{out['seconds']:>10.2f}{plates / out['seconds']:>10.2f}{ok:>6}{out['peak_mb']:>10.0f}"
              f"{worker:>16}{base / out['seconds']:>10.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
