"""The README's two commands stay true."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def commands():
    return [line.strip() for line in README.splitlines() if line.startswith("    python3 -m venv .venv")]


def test_readme_has_the_install_and_run_and_the_test_commands():
    cmds = commands()
    assert any("pip install -e . && devflat run configs/plate.yaml --out out" in c for c in cmds)
    assert any("pip install -e '.[test]' && pytest -q" in c for c in cmds)
    ci = (ROOT / ".ci" / "run").read_text()
    assert "pip install --quiet -e '.[test]' && pytest -q" in ci


def test_readme_main_job_runs_as_written(tmp_path):
    main_job = next(c for c in commands() if "devflat run" in c)
    run_part = main_job.split("&& devflat ")[1]
    args = run_part.split()
    assert args[:2] == ["run", "configs/plate.yaml"]
    out = tmp_path / "out"
    exe = shutil.which("devflat")
    cmd = ([exe] if exe else [sys.executable, "-m", "pipeline"]) + args[:-1] + [str(out)]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert re.search(r"bilge_plate\s+ok", done.stdout)
    written = {p.name for p in out.iterdir()}
    assert {"bilge_plate.dxf", "bilge_plate.obj", "bilge_plate.json"} <= written
    # the files the README lists after the command, and the last line it shows, are the run's
    assert readme_listed_files() == written
    shown = re.search(r"`(wrote \d+ files to out/ \(summary: out/bilge_plate_summary.json\))`", README)
    assert shown and done.stdout.splitlines()[-1] == shown[1].replace("out/", f"{out}/")


def readme_listed_files() -> set[str]:
    """The file names of the README's list after the main job: each entry's backticked names
    before its colon (``a.csv` / `.json``: a second suffix of the same name)."""
    names = set()
    for line in README.splitlines():
        if not line.startswith("- `bilge_plate"):
            continue
        previous = None
        for token in re.findall(r"`([^`]+)`", line.split(":", 1)[0]):
            name = previous.rsplit(".", 1)[0] + token if token.startswith(".") else token
            names.add(name)
            previous = name
    return names


def test_python_dash_m_pipeline_is_the_same_program(tmp_path):
    done = subprocess.run([sys.executable, "-m", "pipeline", "check", "configs/frustum.yaml"], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and "valid, 1 part(s): frustum" in done.stdout
