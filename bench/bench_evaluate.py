"""CPU of a hull plate's lean evaluation (what the adaptive plan pays per candidate), this
checkout against a baseline revision, interleaved round by round so that the machine's drift
(these 2-core machines run a whole-hull plan 1.5 times slower one hour than the next) falls
on both alike.

    python bench/bench_evaluate.py [--baseline REV] [--hull hull160] [--every 4] [--rounds 3]

The hull's shell config (this checkout's, for both) is planned uniform (the adaptive plan's
first candidates); every ``--every``-th plate is evaluated by ``pipeline.hull.plates.evaluate_plate`` in a fresh
process per round and checkout (``git archive REV`` for the baseline), and the per-round CPU
seconds, their medians and the ratio this / baseline are printed; the plates' classes must
agree (a class that differs is printed, and the exit code is 1).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_run import ROOT, baseline_checkout, comparison_parser, interleaved, shell_config

# what each round's process runs (ROOT and the arguments come from argv)
WORKER = r"""
import json, sys, time
from pathlib import Path
root, config_path, every = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3])
sys.path.insert(0, str(root))
from pipeline.hull.plan import load_run
from pipeline.hull.plates import evaluate_plate
config = load_run(config_path)
parts = config.parts[::every]
evaluate_plate(parts[0], config)  # untimed: the lazy imports and the surface's caches
cpu = time.process_time()
classes = [(evaluate_plate(p, config).figures.get("plate_class") or {}).get("class") for p in parts]
print(json.dumps({"cpu": time.process_time() - cpu, "classes": classes, "names": [p.name for p in parts]}))
"""


def one_round(root: Path, config: Path, every: int) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(root))
    out = subprocess.run([sys.executable, "-c", WORKER, str(root), str(config), str(every)], capture_output=True,
                         text=True, env=env, cwd=root)
    if out.returncode:
        sys.exit(f"bench_evaluate: the round at {root} failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = comparison_parser(__doc__, "bd359ea", rounds=3)
    parser.add_argument("--every", type=int, default=4)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        config = shell_config(ROOT, args.hull, tmp, uniform=True)
        runs = interleaved(args.rounds, {"this": ROOT, args.baseline: baseline_checkout(args.baseline, tmp)},
                           lambda label, root, k: one_round(root, config, args.every))
    rows = {label: [r["cpu"] for r in results] for label, results in runs.items()}
    last = {label: results[-1] for label, results in runs.items()}
    n = len(last["this"]["classes"])
    print(f"{args.hull}: lean evaluation of {n} plates (every {args.every}th of the uniform plan), CPU s per round, "
          f"interleaved")
    for label, values in rows.items():
        print(f"  {label:<10}" + "".join(f"{v:8.2f}" for v in values) + f"   median {statistics.median(values):7.2f}"
              f"   {1000 * statistics.median(values) / n:6.0f} ms a plate")
    print(f"  this / {args.baseline}: {statistics.median(rows['this']) / statistics.median(rows[args.baseline]):.2f}")
    differ = [(name, a, b) for name, a, b in zip(last["this"]["names"], last["this"]["classes"],
                                                   last[args.baseline]["classes"]) if a != b]
    for name, a, b in differ:
        print(f"  class differs: {name}: {a} here, {b} at {args.baseline}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
