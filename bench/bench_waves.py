"""A hull run on more cores than this machine has, modelled from the waves it waited for.

    python bench/bench_waves.py [--hull hull160] [--jobs 2] [--workers 2,16,64]

Runs the hull's shell config (``fit_up: report``) in a fresh process twice, one after the
other: its own plan (the config's objective: the yard's plan, made in rounds) and, as the
baseline, the plain adaptive plan (no objective: every plate that does not fit split, depth
by depth). Each run records every batch its plan evaluator handed to the workers and waited
for (``pipeline.runner.Wave``: each item's CPU seconds in the order handed out, and the
wall seconds until the last answer) and each final plate's CPU in the plates + shop files
stage. A run on W workers is then modelled stage by stage:

- plan: its wall here less its waves' walls (what the run's own process does between
  them), plus each wave's makespan on W workers (items handed out in order, each to the
  first worker free, as ``ProcessPoolExecutor`` does);
- evaluate: the same with the batches of candidate plates;
- plates + shop files: its wall here less the makespan of its plates on the ``--jobs``
  workers, plus their makespan on W;
- export: as here (the shell's fit-up in the run's own process, the drawings beside it).

The CPU of an item is what it took here, on a busy 2-core machine (two workers sharing its
caches); the model at ``--jobs`` is printed beside the measured wall as its check. No wave
can take less than its slowest item: the sum of those is what a plan of many rounds costs
on any number of workers. Nor can a run on W cores take less than its CPU seconds (every
stage's, its own process's and the workers') over W, however its work is scheduled: on
``--jobs`` cores the gap between that and the measured wall is all that better scheduling
could win.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))


def makespan(cpu: list, workers: int) -> float:
    """Wall seconds of items (CPU seconds, in the order handed out) on ``workers`` workers,
    each item going to the first worker free."""
    free = [0.0] * max(1, workers)
    for seconds in cpu:
        k = free.index(min(free))
        free[k] += seconds
    return max(free)


def model(run: dict, workers: int) -> dict:
    """{stage: wall s} of ``run`` (:func:`child`'s record) on ``workers`` workers."""
    ran = run["ran_start"]
    plan_tasks = [w for w in run["waves"] if w["kind"] == "tasks" and w["start"] < ran]
    late_tasks = [w for w in run["waves"] if w["kind"] == "tasks" and w["start"] >= ran]
    plates = [w for w in run["waves"] if w["kind"] == "plates"]
    stages = run["stages"]

    def on(waves):
        return sum(makespan(w["cpu"], workers) for w in waves)

    shop_here = makespan(run["shop_cpu"], run["jobs"])
    return {"plan": stages["plan"][0] - sum(w["wall"] for w in plan_tasks) + on(plan_tasks),
            "evaluate": stages["evaluate"][0] - sum(w["wall"] for w in plates) + on(plates),
            "plates + shop files": max(0.0, stages["plates + shop files"][0] - shop_here)
            + makespan(run["shop_cpu"], workers),
            "export": stages["export"][0] - sum(w["wall"] for w in late_tasks) + on(late_tasks)}


def child(config: str, out: str, jobs: int) -> dict:
    """``devflat run CONFIG --jobs N`` in this process, its evaluator's waves and its final
    plates' CPU captured (the run itself unchanged)."""
    import io
    from contextlib import redirect_stdout

    from bench_run import STAGE

    from pipeline import runner
    from pipeline.cli import main

    made, marks, shop = [], {}, []
    make_evaluator, run_parts = runner.plate_evaluator, runner.run_parts

    def plate_evaluator(n=1):
        made.append(make_evaluator(n))
        return made[-1]

    def marked_run_parts(*args, **kwargs):
        marks["ran_start"] = time.perf_counter()
        results = run_parts(*args, **kwargs)
        for result in results:
            seconds = result.figures.get("stage_seconds") or {}
            shop.append(seconds.get("plates_cpu", 0.0) + seconds.get("shop_cpu", 0.0))
        return results

    runner.plate_evaluator, runner.run_parts = plate_evaluator, marked_run_parts
    printed = io.StringIO()
    start = time.perf_counter()
    with redirect_stdout(printed):
        code = main(["run", config, "--jobs", str(jobs), "--out", out])
    wall = time.perf_counter() - start
    line = next(ln for ln in printed.getvalue().splitlines() if ln.startswith("time:"))
    stages = {name.strip(): (float(w), float(c)) for name, w, c in STAGE.findall(line[len("time:"):])}
    plan = next((ln for ln in printed.getvalue().splitlines() if ln.startswith("plan:")), "")
    waves = [{"kind": w.kind, "start": w.start, "cpu": w.cpu, "wall": w.wall} for e in made for w in e.waves]
    return {"code": code, "wall": wall, "stages": stages, "waves": waves, "ran_start": marks["ran_start"],
            "shop_cpu": shop, "jobs": jobs, "plan": plan}


def measured(config: Path, jobs: int, out: Path) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, __file__, "--child", str(config), str(out), str(jobs)],
                          capture_output=True, text=True, env=env, cwd=ROOT, check=False)
    if done.returncode != 0:
        sys.exit(f"the run of {config} failed (exit {done.returncode}):\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.splitlines()[-1])


def report(label: str, run: dict, workers: list) -> list[str]:
    plates = [w for w in run["waves"] if w["kind"] == "plates"]
    tasks = [w for w in run["waves"] if w["kind"] == "tasks"]
    models = {n: model(run, n) for n in workers}
    names = list(models[workers[0]])
    lines = [f"  {label:<28}{run['wall']:9.1f}" + "".join(f"{sum(m.values()):12.1f}" for m in models.values())]
    for name in names:
        lines.append(f"    {name:<26}{run['stages'][name][0]:9.1f}"
                     + "".join(f"{models[n][name]:12.1f}" for n in workers))
    slowest = sum(max(w["cpu"], default=0.0) for w in plates)
    lines.append(f"    {len(plates)} waves of {sum(len(w['cpu']) for w in plates)} candidate plates "
                 f"({sum(sum(w['cpu']) for w in plates):.1f} CPU s; their slowest plates {slowest:.1f} s), "
                 f"{len(tasks)} of {sum(len(w['cpu']) for w in tasks)} tasks "
                 f"({sum(sum(w['cpu']) for w in tasks):.1f} CPU s), {len(run['shop_cpu'])} final plates "
                 f"({sum(run['shop_cpu']):.1f} CPU s)")
    cpu = sum(seconds for _, seconds in run["stages"].values())
    lines.append(f"    {cpu:.1f} CPU s in all stages: on W cores no schedule takes less than CPU / W ("
                 + ", ".join(f"W = {n}: {cpu / n:.1f} s" for n in workers) + ")")
    lines.append(f"    {run['plan']}")
    return lines


def main(argv=None) -> int:
    import yaml
    from bench_hull import fit_up_of
    from bench_run import shell_config

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--hull", default="hull160", choices=["hull160", "dtmb5415", "kvlcc2", "kcs"])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--workers", default="2,16,64", help="worker counts to model, comma-separated")
    args = parser.parse_args(argv)
    workers = sorted({int(n) for n in args.workers.split(",")} | {args.jobs})
    when = time.strftime("%Y-%m-%d %H:%M")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        runs = {}
        for label in ("yard", "plain"):
            (tmp / label).mkdir()
            config = shell_config(ROOT, args.hull, tmp / label, strake=fit_up_of("report"))
            if label == "plain":  # the baseline: no objective, whatever the config ships
                data = yaml.safe_load(config.read_text())
                data["strake"]["plan"].pop("objective", None)
                config.write_text(yaml.safe_dump(data))
            runs[label] = measured(config, args.jobs, tmp / f"{label}-out")
    print(f"{args.hull}, fit_up report, measured with --jobs {args.jobs} ({when}); wall s, and modelled on W workers")
    print(f"  {'':<28}{'measured':>9}" + "".join(f"{f'W = {n}':>12}" for n in workers))
    for line in report("the config's plan (yard)", runs["yard"], workers) + report("plain adaptive plan", runs["plain"],
                                                                                  workers):
        print(line)
    return 0


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "--child":
        print(json.dumps(child(sys.argv[2], sys.argv[3], int(sys.argv[4]))))
        sys.exit(0)
    sys.exit(main())
