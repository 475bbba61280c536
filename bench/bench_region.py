"""A plate's region sampled on the hull (``flatten.patch.region_grid``, as the shell expansion
and the plan's cost sample every plate: 33 x 129 points, a probe of 400 columns), this
checkout's against a baseline commit's ``flatten/patch.py``, interleaved, on the uniform
layouts of the 160 m hull (one IGES surface) and KVLCC2 (its faces' loft).

    python bench/bench_region.py [--baseline 671077e] [--rounds 3]

Prints ms per plate for each and their ratio, and how many grids are identical bit for bit
(the sparse probe must give the whole probe's grid).
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import ROOT, machine_line

import numpy as np  # noqa: E402
import yaml  # noqa: E402

from flatten import patch as this_patch  # noqa: E402
from tests.shipped_configs import with_files_from

HULLS = {"hull160": "hull160_shell.yaml", "kvlcc2": "kvlcc2_shell.yaml"}


def baseline_module(revision: str):
    """``flatten/patch.py`` of ``revision`` imported as a module of its own."""
    source = subprocess.run(["git", "-C", str(ROOT), "show", f"{revision}:flatten/patch.py"], check=True,
                            capture_output=True, text=True).stdout
    source = source.replace("from .surface import", "from flatten.surface import")
    path = Path(tempfile.mkdtemp()) / "baseline_patch.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("baseline_patch", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["baseline_patch"] = module
    spec.loader.exec_module(module)
    return module


def uniform_plates(hull: str) -> list:
    """The hull's shell config planned uniformly (no plate evaluated): its hull plates."""
    from pipeline.hull.plan import load_run

    data = yaml.safe_load((ROOT / "configs" / HULLS[hull]).read_text())
    data["strake"]["plan"]["method"] = "uniform"
    data["strake"]["plan"].pop("replan_held", None)  # (nothing is planned again in a uniform plan)
    with_files_from(data, ROOT / "configs")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{hull}.yaml"
        path.write_text(yaml.safe_dump(data))
        return [p for p in load_run(path).parts if p.hull is not None and p.hull.girths is not None]


def sample_all(module, plates: list) -> tuple[float, list]:
    start = time.perf_counter()
    grids = []
    for part in plates:
        hull = part.hull
        planes = [None if p is None else p.as_tuple() for p in hull.butts]
        grids.append(module.region_grid(hull.surface, hull.long_axis, hull.girths[0], hull.girths[1], planes, 33, 129,
                                        probe=400))
    return time.perf_counter() - start, grids


def same(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in ("params", "points", "rows", "ends"))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--baseline", default="671077e")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    print(machine_line())
    baseline = baseline_module(args.baseline)
    for hull in HULLS:
        plates = uniform_plates(hull)
        times = {"this": [], args.baseline: []}
        for k in range(args.rounds):
            order = [("this", this_patch), (args.baseline, baseline)]
            for label, module in order if k % 2 == 0 else order[::-1]:
                seconds, grids = sample_all(module, plates)
                times[label].append(1e3 * seconds / len(plates))
                if label == "this":
                    ours = grids
                else:
                    theirs = grids
        identical = sum(same(a, b) for a, b in zip(ours, theirs))
        mine, base = np.median(times["this"]), np.median(times[args.baseline])
        print(f"{hull}: {len(plates)} plates, ms per plate (median of {args.rounds}): this {mine:.2f}, "
              f"{args.baseline} {base:.2f}, this / {args.baseline}: {mine / base:.2f}; grids identical: "
              f"{identical} of {len(plates)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
