"""Wall time of a hull run's export stage (fit-up, plan cost, summary, and the drawings: plan
and expansion DXF, expansion PDF, sheet and hull PNGs), this checkout against a baseline
revision, interleaved round by round so that the machine's drift falls on both alike.

    python bench/bench_export.py [--baseline REV] [--hull kcs] [--rounds 2] [--adaptive]

The hull's shell config is run as ``devflat run CONFIG --jobs 2`` (planned uniform unless
``--adaptive``: the export's work grows with the plates, not with how they were planned) in
a fresh process per round and checkout (``git archive REV`` for the baseline); the stage
line's export wall and CPU seconds of each round, their medians and the ratio this /
baseline are printed, with the whole run's wall. The runs' summary JSON must agree on the
plates and their classes (a difference is printed, and the exit code is 1).
"""

from __future__ import annotations

import statistics
import sys
import tempfile
from pathlib import Path

from bench_run import ROOT, baseline_checkout, comparison_parser, interleaved, shell_config, whole_run


def one_round(root: Path, config: Path, out: Path) -> dict:
    run = whole_run(root, config, 2, out)
    wall, cpu = run["stages"]["export"]
    return {"wall": wall, "cpu": cpu, "run": run["wall"], "classes": run["plan"]["classes"]}


def main(argv=None) -> int:
    parser = comparison_parser(__doc__, "29f5478", hull="kcs")
    parser.add_argument("--adaptive", action="store_true", help="the shell config's own (adaptive) plan")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        config = shell_config(ROOT, args.hull, tmp, uniform=not args.adaptive)
        rows = interleaved(args.rounds, {"this": ROOT, args.baseline: baseline_checkout(args.baseline, tmp)},
                           lambda label, root, k: one_round(root, config, tmp / f"out-{label}-{k}"))
    plan = "adaptive" if args.adaptive else "uniform"
    print(f"{args.hull} ({plan} plan, --jobs 2): export stage wall s per round, interleaved")
    medians = {}
    for label, runs in rows.items():
        walls = [r["wall"] for r in runs]
        medians[label] = statistics.median(walls)
        print(f"  {label:10s} " + " ".join(f"{w:7.2f}" for w in walls) + f"   median {medians[label]:7.2f}"
              f"   (CPU {statistics.median(r['cpu'] for r in runs):.2f} s, the run's process and its drawing copy;"
              f" whole run {statistics.median(r['run'] for r in runs):.1f} s)")
    print(f"  this / {args.baseline}: {medians['this'] / medians[args.baseline]:.2f}")
    differ = [name for name, klass in rows["this"][0]["classes"].items()
              if rows[args.baseline][0]["classes"].get(name) != klass]
    if differ or set(rows["this"][0]["classes"]) != set(rows[args.baseline][0]["classes"]):
        print(f"  the plans differ: {differ[:10]}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
