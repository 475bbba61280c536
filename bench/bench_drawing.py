"""The shop drawings' cost: configs/hullmod_strake.yaml (10 plates) with --jobs 2, with its
drawings (PDF: plate page, table, templates page) and without (output.drawing: false, the
baseline), interleaved in rounds; plates per second of each and the ratio.

    python bench/bench_drawing.py [--repeat 3] [--jobs 2]

On a shared machine the absolute figures move with the load: the ratio is the figure.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _config(folder: Path, drawing: bool) -> Path:
    text = (ROOT / "configs" / "hullmod_strake.yaml").read_text()
    text = text.replace("../tests/data", str(ROOT / "tests" / "data"))
    path = folder / f"hullmod_{'drawing' if drawing else 'plain'}.yaml"
    path.write_text(text + f"output: {{drawing: {'true' if drawing else 'false'}}}\n")
    return path


def _run(config: Path, out: Path, jobs: int) -> float:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "pipeline", "run", str(config), "--out", str(out), "--quiet",
                           "--jobs", str(jobs)], check=False, cwd=ROOT, capture_output=True, text=True)
    if done.returncode not in (0, 1):
        raise SystemExit(f"{config.name}: exit {done.returncode}\n{done.stderr[-2000:]}")
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        configs = {"with drawings": _config(folder, True), "without (baseline)": _config(folder, False)}
        times = {k: [] for k in configs}
        for r in range(args.repeat):
            for label, config in configs.items():
                times[label].append(_run(config, folder / f"out{r}_{len(times[label])}_{label.split()[0]}", args.jobs))
        pdfs = len(list(folder.glob("out0_*_with/*_drawing.pdf")))
    plates = 10
    print(f"configs/hullmod_strake.yaml, {plates} plates, --jobs {args.jobs}, median of {args.repeat} rounds "
          f"({pdfs} PDFs a run with drawings)")
    med = {k: statistics.median(v) for k, v in times.items()}
    for label, t in med.items():
        print(f"  {label:<20} {t:7.2f} s  {plates / t:6.2f} plates/s   rounds: "
              + " ".join(f"{plates / x:.2f}" for x in times[label]))
    print(f"  ratio with / without: {med['without (baseline)'] / med['with drawings']:.3f} of the baseline's plates/s")


if __name__ == "__main__":
    main()
