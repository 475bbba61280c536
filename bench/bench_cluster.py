"""Scaling of a strake's plates on Dask distributed against --jobs, and the model that
extrapolates it to a 16-core machine and a 4 x 16-core cluster.

    python bench/bench_cluster.py [--seams 13] [--butts 11] [--repeat 3]

The workload is bench_strake.py's: (seams - 1) x (butts - 1) plates of the 160 m hull, each
solved, trimmed, checked, unrolled, fitted to the hull and written (DXF, OBJ, JSON, shop
no PNG previews, no PDF drawing: output.png is off). Every run is a fresh ``devflat`` process (its time includes
the interpreter's start, the imports and the planning), repeated ``--repeat`` times in
interleaved rounds; the median run of each kind is printed:

- ``--jobs 1`` and ``--jobs 2`` (the baseline: forked workers that write their own files);
- ``--scheduler local:1`` / ``local:2``: the run starts its own LocalCluster (cold: the
  cluster's start and the workers' imports are in the figure);
- ``--scheduler tcp://...`` on a warm LocalCluster of 1 and 2 worker processes that this
  bench keeps running (what a standing cluster gives: workers already started).

Then the model's terms, each measured separately (CPU seconds, so that the neighbours on a
shared machine do not enter them):

- S0 + P S1, the coordinator's serial part (its CPU outside the phase where the parts run:
  start, imports, distributed's included, planning, summary, commit), a line through two
  plate counts on the warm cluster; b, the coordinator's CPU per plate while the parts run
  (receiving a plate's files and writing them into the staging folder);
- c, the workers' CPU per plate (compute and export; measured in the worker processes);
- d, the client's and scheduler's CPU per task, from 2000 no-op tasks on the warm cluster
  (the scheduler runs in this bench's process); beside it the scheduler process's CPU
  during the real runs per plate, which adds its time-proportional background (heartbeats,
  monitors: about 5 % of a core) and is not a per-plate cost;
- the file bytes per plate that cross the network.

    T(W) = S0 + P * S1 + P * max(c / W, b + d + bytes / bandwidth)

W workers compute while the coordinator and scheduler take each plate in turn; whichever
is slower sets the pace. ``--jobs`` on one machine is the same model with its own S0, b
(the parent receiving each plate's summary) and c, no scheduler and no network.
bench/README.md has the figures and the extrapolation.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_strake import config  # noqa: E402  the same strake


def one(args) -> int:
    """One run in this fresh process, as the ``devflat`` program runs it; besides its CPU
    time, the CPU time this process spent while the parts ran (``run_parts`` with --jobs,
    ``run_on_cluster`` on a scheduler: receiving and staging the parts' files)."""
    import pipeline.cluster
    import pipeline.runner
    from pipeline.cli import run_program

    phase = {"cpu": 0.0}

    def timed(function):
        def run(*a, **k):
            start = time.process_time()
            try:
                return function(*a, **k)
            finally:
                phase["cpu"] += time.process_time() - start
        return run

    # both are imported by name when a run starts: the wrapped ones are what it calls
    pipeline.runner.run_parts = timed(pipeline.runner.run_parts)
    pipeline.cluster.run_on_cluster = timed(pipeline.cluster.run_on_cluster)
    code = run_program(["run", args.config, "--out", args.out, "--quiet", *args.extra.split()])
    self_use, child_use = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    print(json.dumps({"code": code, "parent_cpu": self_use.ru_utime + self_use.ru_stime,
                      "children_cpu": child_use.ru_utime + child_use.ru_stime, "parts_phase_cpu": phase["cpu"]}))
    return 0


def _process_cpu() -> float:
    import psutil

    times = psutil.Process().cpu_times()
    return times.user + times.system


def _noop(x):
    return x


class WarmCluster:
    """A LocalCluster of ``n`` worker processes kept by this bench, as devflat starts one."""

    def __init__(self, n: int):
        import logging

        import distributed

        logging.getLogger("distributed").setLevel(logging.ERROR)  # its INFO lines on every connection

        from pipeline.cluster import local_cluster

        self.cluster = local_cluster(n)  # as devflat starts one for --scheduler local:N
        self.client = distributed.Client(self.cluster, set_as_default=False)
        self.address = self.cluster.scheduler_address

    def workers_cpu(self) -> float:
        return sum(self.client.run(_process_cpu).values())

    def round_trip(self, tasks: int = 2000) -> tuple[float, float]:
        """(wall seconds, CPU seconds of this process: client and scheduler) per no-op task,
        submitted together and gathered."""
        self.client.gather(self.client.map(_noop, range(50), pure=False))
        start, cpu = time.perf_counter(), _process_cpu()
        self.client.gather(self.client.map(_noop, range(tasks), pure=False))
        return (time.perf_counter() - start) / tasks, (_process_cpu() - cpu) / tasks

    def close(self) -> None:
        self.client.close()
        self.cluster.close()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seams", type=int, default=13)
    parser.add_argument("--butts", type=int, default=11)
    parser.add_argument("--repeat", type=int, default=3, help="rounds (the median run is printed)")
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--config", help=argparse.SUPPRESS)
    parser.add_argument("--out", help=argparse.SUPPRESS)
    parser.add_argument("--extra", default="", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        return one(args)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("IGL_NUM_THREADS", "1")
    import platform

    from bench_cli import child_env

    plates = (args.seams - 1) * (args.butts - 1)
    small_plates = 2 * (args.butts - 1)
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}; "
          f"{plates} plates of the 160 m hull (DXF, OBJ, JSON; no images); {args.repeat} rounds, interleaved; "
          f"load average at the start {os.getloadavg()[0]:.1f}")
    runs: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        path, small = tmp / "bench.yaml", tmp / "small.yaml"
        path.write_text(yaml.safe_dump(config(args.seams, args.butts)))
        small.write_text(yaml.safe_dump(config(3, args.butts)))
        env = child_env(tmp / "pycache")
        warm = {n: WarmCluster(n) for n in (1, 2)}

        def run(label: str, extra: str, config_path: Path = path, cluster: WarmCluster | None = None) -> dict:
            out = tmp / "out"
            shutil.rmtree(out, ignore_errors=True)
            workers = cluster.workers_cpu() if cluster else 0.0
            scheduler = _process_cpu()
            start = time.perf_counter()
            done = subprocess.run([sys.executable, __file__, "--one", "--config", str(config_path), "--out", str(out),
                                   "--extra", extra], capture_output=True, text=True, timeout=7200, env=env)
            elapsed = time.perf_counter() - start
            scheduler = _process_cpu() - scheduler
            if done.returncode:
                sys.exit(f"bench_cluster: {label} failed:\n{done.stderr}")
            measured = json.loads(done.stdout.strip().splitlines()[-1])
            if measured["code"] != 0:
                sys.exit(f"bench_cluster: devflat exited {measured['code']} in {label}:\n{done.stderr[-2000:]}")
            files = [p for p in out.iterdir() if p.suffix in (".dxf", ".obj", ".json", ".pdf")]
            return dict(measured, seconds=elapsed, label=label,
                        workers_cpu=(cluster.workers_cpu() - workers) if cluster else measured["children_cpu"],
                        scheduler_cpu=scheduler if cluster else 0.0,
                        bytes=sum(p.stat().st_size for p in files))

        kinds = [("--jobs 1", "--jobs 1", None), ("--jobs 2", "--jobs 2", None),
                 ("local:1 (cold)", "--scheduler local:1", None), ("local:2 (cold)", "--scheduler local:2", None),
                 ("warm cluster, 1 worker", f"--scheduler {warm[1].address}", warm[1]),
                 ("warm cluster, 2 workers", f"--scheduler {warm[2].address}", warm[2])]
        for _, extra, cluster in kinds:  # untimed: bytecode cache, the warm workers' imports
            run("warm-up", extra, small, cluster)
        small_runs = []
        for _ in range(args.repeat):
            for label, extra, cluster in kinds:
                runs.setdefault(label, []).append(run(label, extra, path, cluster))
            small_runs.append(run("small", f"--scheduler {warm[2].address}", small, warm[2]))
        trip = {n: warm[n].round_trip() for n in (1, 2)}
        for cluster in warm.values():
            cluster.close()
    median = {label: sorted(rows, key=lambda r: r["seconds"])[(len(rows) - 1) // 2] for label, rows in runs.items()}
    base, baseline = median["--jobs 1"]["seconds"], median["--jobs 2"]
    header = (f"{'run':<26}{'seconds':>9}{'plates/s':>10}{'CPU s':>8}{'coord. CPU s':>14}{'workers CPU s':>15}"
              f"{'sched. CPU s':>14}{'x --jobs 1':>12}{'x --jobs 2':>12}")
    print(header)
    print("-" * len(header))
    for label, _, _ in kinds:
        r = median[label]
        cpu = r["parent_cpu"] + r["workers_cpu"] + r["scheduler_cpu"]
        print(f"{label:<26}{r['seconds']:>9.2f}{plates / r['seconds']:>10.2f}{cpu:>8.1f}{r['parent_cpu']:>14.2f}"
              f"{r['workers_cpu']:>15.2f}{r['scheduler_cpu']:>14.2f}{base / r['seconds']:>12.2f}"
              f"{baseline['seconds'] / r['seconds']:>12.2f}")
    for label, _, _ in kinds:
        print(f"  plates/s in each round, {label}: " + " ".join(f"{plates / r['seconds']:.1f}" for r in runs[label]))
    # Dask's overhead per plate against the baseline --jobs 2 (same 2 processes computing)
    for label in ("local:2 (cold)", "warm cluster, 2 workers"):
        r = median[label]
        wall = (r["seconds"] - baseline["seconds"]) / plates
        cpu = ((r["parent_cpu"] + r["workers_cpu"] + r["scheduler_cpu"])
               - (baseline["parent_cpu"] + baseline["workers_cpu"])) / plates
        print(f"  Dask's overhead against --jobs 2, {label}: {1000 * wall:+.1f} ms wall and {1000 * cpu:+.1f} ms CPU "
              f"per plate")
    # the model's terms
    big = median["warm cluster, 2 workers"]
    small_run = sorted(small_runs, key=lambda r: r["seconds"])[(len(small_runs) - 1) // 2]
    if plates <= small_plates:
        sys.exit("bench_cluster: give more than 3 seams (the model's line needs two plate counts)")

    def outside(r):  # the coordinator's CPU before and after the parts ran
        return r["parent_cpu"] - r["parts_phase_cpu"]

    s1 = max((outside(big) - outside(small_run)) / (plates - small_plates), 0.0)
    s0 = outside(big) - s1 * plates
    b = big["parts_phase_cpu"] / plates
    c = statistics.median([r["workers_cpu"] / plates for label in ("warm cluster, 1 worker", "warm cluster, 2 workers")
                           for r in runs[label]])
    background = statistics.median([r["scheduler_cpu"] / plates for label in ("warm cluster, 1 worker",
                                                                            "warm cluster, 2 workers")
                                    for r in runs[label]])
    d = max(trip[1][1], trip[2][1])
    jobs = median["--jobs 2"]
    c_jobs = jobs["workers_cpu"] / plates
    b_jobs = jobs["parts_phase_cpu"] / plates
    s0_jobs = outside(jobs) - s1 * plates
    per_plate_bytes = big["bytes"] / plates
    print("model terms (CPU; medians of the runs above):")
    print(f"  S0  coordinator's fixed serial part (start, imports, connecting)    {s0:.2f} s Dask, {s0_jobs:.2f} s --jobs")
    print(f"  S1  serial part per plate, before and after the parts run         {1000 * s1:.1f} ms "
          f"(planning, summary, commit; {small_plates} and {plates} plates)")
    print(f"  b   coordinator per plate while they run (receive, stage)          {1000 * b:.1f} ms Dask, "
          f"{1000 * b_jobs:.1f} ms --jobs")
    print(f"  c   workers per plate (compute and export)                         {1000 * c:.1f} ms Dask, "
          f"{1000 * c_jobs:.1f} ms --jobs")
    print(f"  d   client + scheduler per task (no-op tasks, 1 / 2 workers)        {1000 * trip[1][1]:.2f} / "
          f"{1000 * trip[2][1]:.2f} ms (wall per task {1000 * trip[1][0]:.2f} / {1000 * trip[2][0]:.2f} ms)")
    print(f"      scheduler process's CPU during the runs / plates (with its background) {1000 * background:.1f} ms")
    print(f"      file bytes per plate                                           {per_plate_bytes / 1024:.0f} KiB")
    print("predicted on idle cores, T = S0 + P S1 + P max(c / W, b + d + bytes / bandwidth) (--jobs: d = 0, "
          f"no network; the cluster already running), for these {plates} plates and for 10 x as many:")
    for label, workers, bandwidth, dask in (("--jobs 16, one 16-core machine", 16, None, False),
                                            ("local cluster, 16 cores (15 workers)", 15, None, True),
                                            ("4 x 16-core cluster, 64 workers, 1 Gbit/s", 64, 125e6, True),
                                            ("4 x 16-core cluster, 64 workers, 10 Gbit/s", 64, 1250e6, True)):
        row = []
        for n in (plates, 10 * plates):
            if dask:
                pace = b + d + (per_plate_bytes / bandwidth if bandwidth else 0.0)
                seconds = s0 + n * s1 + n * max(c / workers, pace)
            else:
                seconds = s0_jobs + n * s1 + n * max(c_jobs / workers, b_jobs)
            row.append(f"{n} plates {seconds:6.1f} s, {n / seconds:6.1f} plates/s")
        print(f"  {label:<45}" + "; ".join(row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
