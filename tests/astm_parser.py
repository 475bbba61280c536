"""The open ASTM/AAMA parser (ksons/astm-parser, TypeScript) run with node, for tests.

Its source is not in this repository (ISC licence, copied unchanged in
../shared/realdata/textile/astm-parser-src, see tests/data/SOURCES.md); DEVFLAT_ASTM_PARSER_SRC
may point elsewhere. The parser's npm dependencies are pinned by tests/astm/package-lock.json
and installed with `npm ci` into the pytest cache, so every run uses the same versions.
``parser_or_reason`` returns a callable, or the reason why the parser cannot run here
(the tests skip with that reason).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SOURCE_PARTS = ("shared", "realdata", "textile", "astm-parser-src")


def parser_source() -> Path | None:
    given = os.environ.get("DEVFLAT_ASTM_PARSER_SRC")
    candidates = [Path(given)] if given else [parent.joinpath(*SOURCE_PARTS) for parent in ROOT.parents]
    for path in candidates:
        if (path / "src" / "index.ts").is_file():
            return path
    return None


def parser_or_reason(cache_dir: Path):
    """(run, None) with run(paths) -> list of per-file dicts, or (None, reason)."""
    source = parser_source()
    if source is None:
        return None, ("ASTM parser source not found (../shared/realdata/textile/astm-parser-src; "
                      "set DEVFLAT_ASTM_PARSER_SRC)")
    node, npm = shutil.which("node"), shutil.which("npm")
    if node is None or npm is None:
        return None, "node and npm are needed to run the ASTM parser"
    work = Path(cache_dir)
    lock = (HERE / "astm" / "package-lock.json").read_bytes()
    stamp = work / "installed.lock"
    if not (stamp.is_file() and stamp.read_bytes() == lock and (work / "node_modules").is_dir()):
        if work.exists():
            shutil.rmtree(work)
        work.mkdir(parents=True)
        for name in ("package.json", "package-lock.json"):
            shutil.copy(HERE / "astm" / name, work / name)
        done = subprocess.run([npm, "ci", "--silent", "--no-audit", "--no-fund"], cwd=work,
                              capture_output=True, text=True, timeout=600)
        if done.returncode != 0:
            return None, f"npm ci for the ASTM parser failed (offline?): {done.stderr.strip()[-300:]}"
        stamp.write_bytes(lock)
    # file by file: the shared copy is read-only and copytree would copy that mode too
    for path in (source / "src").rglob("*.ts"):
        target = work / "src" / path.relative_to(source / "src")
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(path.read_bytes())
    shutil.copy(HERE / "astm" / "astm_json.mts", work / "astm_json.mts")

    def run(paths: list[Path]) -> list[dict]:
        done = subprocess.run([node, str(work / "node_modules" / "tsx" / "dist" / "cli.mjs"), "astm_json.mts",
                               *map(str, paths)], cwd=work, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        # dxf-parser logs its own warnings to stdout; the JSON is the last line
        return json.loads(done.stdout.strip().splitlines()[-1])

    return run, None


@pytest.fixture(scope="module")
def astm_or_none(request):
    """The open ASTM parser (node), installed once per worker into the pytest cache; None
    where it cannot be run (for tests whose other readers still have their say)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    run, _ = parser_or_reason(request.config.cache.mkdir(f"astm-parser-{worker}"))
    return run


@pytest.fixture(scope="module")
def astm(request, astm_or_none):
    """The parser, or the test skips saying why."""
    if astm_or_none is None:
        worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
        pytest.skip(parser_or_reason(request.config.cache.mkdir(f"astm-parser-{worker}"))[1])
    return astm_or_none
