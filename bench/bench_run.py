"""A whole hull run (`devflat run configs/HULL_shell.yaml --jobs 2`), this checkout against a
baseline revision, interleaved round by round so that the machine's drift (these 2-core
machines run the same plan 1.3-1.7 times slower one hour than the next) falls on both alike.

    python bench/bench_run.py [--baseline REV] [--hull hull160] [--rounds 2] [--jobs 2] [--objective weld1.5]
                              [--fit-up follow_pull_hold | --as-shipped]

Each round runs both checkouts in fresh processes (``git archive REV`` for the baseline), in
alternating order, on this checkout's shell config; per checkout it prints the wall time of
each round and each stage's wall (CPU) seconds from the run's own ``time:`` line, the medians
and the ratio this / baseline;
the two runs' plans must agree (plates, classes and shares from the summary JSON; a plan that
differs is printed and the exit code is 1).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
STAGE = re.compile(r"([a-z +-]+?)(?: \d+ plates \(\d+ cached\))? ([\d.]+) s \(([\d.]+) CPU s\)")


def baseline_checkout(rev: str, folder: Path) -> Path:
    """``git archive REV`` of this repository unpacked into ``folder`` / "baseline"."""
    base = folder / "baseline"
    base.mkdir()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev], capture_output=True, check=True)
    subprocess.run(["tar", "x", "-C", str(base)], input=archive.stdout, check=True)
    return base


def interleaved(rounds: int, checkouts: dict, one) -> dict:
    """``one(label, root, k)`` for each checkout (label -> root) and round k, their order
    turned round every other round; {label: [results]}."""
    out = {label: [] for label in checkouts}
    order = list(checkouts.items())
    for k in range(rounds):
        for label, root in order if k % 2 == 0 else order[::-1]:
            out[label].append(one(label, root, k))
    return out


def shell_config(root: Path, hull: str, folder: Path, uniform: bool = False, objective: dict | None = None,
                 strake: dict | None = None, replan: bool = False) -> Path:
    """The hull's shell config of the checkout at ``root`` written into ``folder`` with its
    model files as absolute paths (both checkouts run the same config); ``uniform``: its
    plan made uniform; ``objective``: the plan's objective (bench_hull.py's names);
    ``strake``: strake options set (bench_hull.py's ``fit_up_of``); ``replan``: its
    ``plan.replan_held`` kept (else the plan is made once)."""
    data = yaml.safe_load((root / "configs" / f"{hull}_shell.yaml").read_text())
    if uniform:
        data["strake"]["plan"]["method"] = "uniform"
    if objective is not None:
        data["strake"]["plan"]["objective"] = objective
    data["strake"].update(strake or {})
    if not replan:  # the plan made once: both checkouts run this config, and a baseline's may not know the key
        data["strake"]["plan"].pop("replan_held", None)
    # the expansion's lines and bow: a baseline before them knows no such key
    for key in ("base_line", "waterlines", "decks", "bow"):
        data["strake"].pop(key, None)
    for surface in [data["strake"]["surface"]] + list(data["strake"]["plan"].get("surfaces", [])):
        for key in ("iges", "model"):
            if key in surface:
                surface[key] = str((root / "configs" / surface[key]).resolve())
    path = folder / f"{hull}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def whole_run(root: Path, config: Path, jobs: int, out: Path) -> dict:
    """``devflat run CONFIG --jobs N`` of the checkout at ``root`` in a fresh process: its wall
    seconds, each stage's (wall, CPU) seconds from the run's ``time:`` line, and its plan
    (plates, classes, shares) from the summary JSON."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(root))
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "pipeline", "run", str(config), "--jobs", str(jobs),
                           "--out", str(out)], capture_output=True, text=True, env=env, cwd=root)
    wall = time.perf_counter() - start
    line = next((ln for ln in done.stdout.splitlines() if ln.startswith("time:")), None)
    if done.returncode not in (0, 1) or line is None:
        sys.exit(f"the run at {root} failed (exit {done.returncode}):\n{done.stderr[-2000:]}")
    stages = {name.strip(): (float(w), float(c)) for name, w, c in STAGE.findall(line[len("time:"):])}
    summary = json.loads(next(out.glob("*_summary.json")).read_text())
    plan = {"plates": len(summary["parts"]),
            "classes": {p["id"]: p["class"] for p in summary["parts"]},
            "shares": {k: round(v, 6) for k, v in summary["plan_cost"]["shares"].items()}}
    return {"wall": wall, "stages": stages, "plan": plan}


def comparison_parser(doc: str, baseline: str, hull: str = "hull160", rounds: int = 2) -> argparse.ArgumentParser:
    """The options every bench against a baseline revision takes: --baseline, --hull, --rounds."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--baseline", default=baseline, help=f"git revision to compare with (default: {baseline})")
    parser.add_argument("--hull", default=hull, choices=["hull160", "dtmb5415", "kvlcc2", "kcs"])
    parser.add_argument("--rounds", type=int, default=rounds)
    return parser


def main(argv=None) -> int:
    from bench_hull import FIT_UPS, fit_up_of, objective_of

    parser = comparison_parser(__doc__, "9d0000e")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--objective", default="none",
                        help="the plan's objective: weldF (e.g. weld1.5), cost, or none (the config's own)")
    parser.add_argument("--fit-up", default="report", choices=FIT_UPS,
                        help="strake.fit_up and its options, as bench_hull.py names them")
    parser.add_argument("--as-shipped", action="store_true",
                        help="the config's own fit-up and plan.replan_held (the baseline must know the key)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        config = shell_config(ROOT, args.hull, tmp, objective=objective_of(args.objective),
                              strake=None if args.as_shipped else fit_up_of(args.fit_up), replan=args.as_shipped)
        runs = interleaved(args.rounds, {"this": ROOT, args.baseline: baseline_checkout(args.baseline, tmp)},
                           lambda label, root, k: whole_run(root, config, args.jobs, tmp / f"{label}-{k}"))
    fit_up = "as shipped" if args.as_shipped else args.fit_up
    objective = "the config's" if objective_of(args.objective) is None else args.objective
    print(f"{args.hull} (objective {objective}, fit-up {fit_up}): whole run, --jobs {args.jobs}, wall s per round (interleaved); stages: median wall (CPU) s")
    for label, rounds in runs.items():
        walls = [r["wall"] for r in rounds]
        names = list(rounds[0]["stages"])
        stages = "  ".join(f"{n} {statistics.median(r['stages'][n][0] for r in rounds):.1f} "
                           f"({statistics.median(r['stages'][n][1] for r in rounds):.1f})" for n in names)
        print(f"  {label:<10}" + "".join(f"{w:8.1f}" for w in walls) + f"   median {statistics.median(walls):7.1f}")
        for k, r in enumerate(rounds):
            per_stage = "  ".join(f"{n} {w:.1f} ({c:.1f})" for n, (w, c) in r["stages"].items())
            print(f"  {'':<10}round {k + 1}: {per_stage}")
        print(f"  {'':<10}median:  {stages}")
    ratio = statistics.median(r["wall"] for r in runs["this"]) / statistics.median(r["wall"] for r in
                                                                                   runs[args.baseline])
    print(f"  this / {args.baseline}: {ratio:.2f}")
    this, other = runs["this"][-1]["plan"], runs[args.baseline][-1]["plan"]
    if this != other:
        differ = [n for n in set(this["classes"]) | set(other["classes"])
                  if this["classes"].get(n) != other["classes"].get(n)]
        print(f"  plans differ: {this['plates']} plates here, {other['plates']} at {args.baseline}; shares "
              f"{this['shares']} against {other['shares']}; {len(differ)} plates differ, e.g. {sorted(differ)[:5]}")
        return 1
    print(f"  the same plan: {this['plates']} plates, shares {this['shares']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
