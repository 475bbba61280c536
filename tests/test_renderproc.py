"""The render process of a one-shot run (pipeline.renderproc): the same files as drawn in
place, the jobs' errors raised in the run with their type, no hang when it dies."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import pipeline.cores as run_cores
from pipeline.cli import main
from pipeline.renderproc import ACTIVE, Renderer, render, wait

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the render process is forked (Linux)")

# a trapezoid plate (mm) and three bending lines across it
OUTLINE = np.array([[0.0, 0.0], [3000.0, 0.0], [2600.0, 1200.0], [400.0, 1200.0]])
BENDS = np.array([[[750.0 * k, 0.0], [750.0 * k, 1200.0]] for k in (1, 2, 3)])
FLAT = "pipeline.plots:flat_pattern_png"


def test_images_drawn_by_the_render_process_are_the_bytes_drawn_in_place(tmp_path):
    render(FLAT, tmp_path / "here.png", OUTLINE, BENDS, "plate: flat pattern", "mm")
    assert ACTIVE.get() is None
    with Renderer(("pipeline.plots",)) as renderer:
        assert ACTIVE.get() is renderer
        for k in range(6):  # more than IN_FLIGHT: the run waits for answers as it sends
            render(FLAT, tmp_path / f"there{k}.png", OUTLINE, BENDS, "plate: flat pattern", "mm")
        wait()
        assert renderer.pending == 0
    assert ACTIVE.get() is None
    here = (tmp_path / "here.png").read_bytes()
    assert here[:8] == b"\x89PNG\r\n\x1a\n"
    for k in range(6):
        assert (tmp_path / f"there{k}.png").read_bytes() == here


def test_a_job_error_is_raised_in_the_run_with_its_type(tmp_path):
    with Renderer(("pipeline.plots",)):
        render(FLAT, tmp_path / "no such folder" / "flat.png", OUTLINE, BENDS, "t", "mm")
        render(FLAT, tmp_path / "fine.png", OUTLINE, BENDS, "t", "mm")
        with pytest.raises(FileNotFoundError) as raised:  # an OSError stays one: an output fault
            wait()
        assert "in the render process" in "".join(raised.value.__notes__)
        render(FLAT, tmp_path / "bad.png", OUTLINE[:, :1], BENDS, "t", "mm")  # (N, 1): not a plane outline
        with pytest.raises(IndexError):
            wait()
    assert (tmp_path / "fine.png").exists()  # the jobs after a failed one still ran


def test_a_killed_render_process_fails_the_wait_and_leaves_no_child(tmp_path):
    with pytest.raises(RuntimeError, match="render process ended"):
        with Renderer(("pipeline.plots",)) as renderer:
            os.kill(renderer.pid, signal.SIGKILL)
            render(FLAT, tmp_path / "flat.png", OUTLINE, BENDS, "t", "mm")
            wait()
    with pytest.raises(ChildProcessError):
        os.waitpid(renderer.pid, os.WNOHANG)  # reaped by the with block


# devflat's start (pipeline.cli.entry_point) with the render process whatever the load
ONE_SHOT = ("import gc, sys; gc.disable(); import pipeline.cli as cli; cli.spare_core = lambda: True; "
            "code = cli.main(sys.argv[1:], one_shot=True); gc.freeze(); sys.exit(code)")


def test_a_one_shot_run_writes_what_an_in_process_run_writes(tmp_path):
    """A one-shot run (render process, frozen collector) against main() here."""
    config = ROOT / "configs" / "plate.yaml"
    assert main(["run", str(config), "--out", str(tmp_path / "here"), "--quiet"]) == 0
    env = dict(os.environ, PYTHONPATH=str(ROOT), SOURCE_DATE_EPOCH="0")
    done = subprocess.run([sys.executable, "-c", ONE_SHOT, "run", str(config), "--out", str(tmp_path / "there")],
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1].startswith("wrote 9 files")  # with its templates DXF
    here, there = sorted(p.name for p in (tmp_path / "here").iterdir()), sorted(
        p.name for p in (tmp_path / "there").iterdir())
    assert here == there and "bilge_plate_drawing.pdf" in there
    for name in ("bilge_plate_flat.png", "bilge_plate_solutions.png", "bilge_plate.obj"):
        assert (tmp_path / "here" / name).read_bytes() == (tmp_path / "there" / name).read_bytes(), name
    report = json.loads((tmp_path / "there" / "bilge_plate.json").read_text())
    assert report == json.loads((tmp_path / "here" / "bilge_plate.json").read_text())
    assert report["layout"]["drawings"][0]["file"] == "bilge_plate_drawing.pdf"
    pdf = (tmp_path / "there" / "bilge_plate_drawing.pdf").read_bytes()
    assert pdf.startswith(b"%PDF") and b"/CreationDate (D:19700101000000Z)" in pdf


def test_arguments_that_do_not_pickle_are_drawn_in_the_run(tmp_path):
    class Title(str):  # a local class: pickle cannot name it
        pass

    with Renderer(("pipeline.plots",)) as renderer:
        render(FLAT, tmp_path / "here.png", OUTLINE, BENDS, Title("plate: flat pattern"), "mm")
        assert renderer.pending == 0  # not sent: written already
        assert (tmp_path / "here.png").exists()


def test_a_render_process_started_before_validation_is_ended_by_a_bad_config(tmp_path, monkeypatch):
    """The run forks its render process before it validates (pipeline.cli.early_renderer):
    a config that fails validation ends it, writes nothing and leaves no child."""
    import pipeline.cli as cli

    monkeypatch.setattr(cli, "spare_core", lambda: True)
    started = []
    start = Renderer.start
    monkeypatch.setattr(Renderer, "start", lambda self: started.append(self) or start(self))
    text = (ROOT / "configs" / "plate.yaml").read_text().replace("degree: 3", "degree: 0", 1)
    bad = tmp_path / "bad.yaml"
    bad.write_text(text)
    assert main(["run", str(bad), "--out", str(tmp_path / "out"), "--quiet"], one_shot=True) == 2
    assert len(started) == 1 and started[0].pid is not None and not started[0].running  # forked, ended
    assert not (tmp_path / "out").exists()
    with pytest.raises(ChildProcessError):
        os.waitpid(-1, os.WNOHANG)


@pytest.mark.parametrize("output, forked", [({}, True), ({"png": False}, False)])
def test_the_early_render_process_follows_the_raw_previews_setting(tmp_path, monkeypatch, output, forked):
    import yaml

    import pipeline.cli as cli

    monkeypatch.setattr(cli, "spare_core", lambda: True)
    raw = yaml.safe_load((ROOT / "configs" / "plate.yaml").read_text())
    raw["output"] = output
    config = tmp_path / "plate.yaml"
    config.write_text(yaml.safe_dump(raw))
    args = cli.build_parser().parse_args(["run", str(config), "--out", str(tmp_path / "out")])
    args.one_shot = True
    early = cli.early_renderer(args)
    try:
        assert (early is not None) == forked
    finally:
        if early is not None:
            early.discard()


def test_the_render_process_draws_a_solution_without_importing_scipy(tmp_path):
    """What a one-shot run sends for its solution diagram (the solution without its field)
    unpickles, with the plotting module, in a process that never imports scipy: the render
    process is ready while the run still imports and solves."""
    import dataclasses
    import pickle

    from pipeline.hull.plan import load_run
    from pipeline.hull.plates import evaluate_plate
    from pipeline.runner import run_parts

    config = load_run(ROOT / "configs" / "plate.yaml", evaluate_plate)
    result = run_parts(config, None, None)[0]
    job = pickle.dumps(("pipeline.plots:solution_diagram_png",
                        (tmp_path / "solutions.png", dataclasses.replace(result.solution, field=None),
                         result.part.c.domain, result.part.d.domain, "t"), {}))
    (tmp_path / "job.pickle").write_bytes(job)
    code = ("import pickle, sys; import pipeline.plots; from pipeline.renderproc import _call; "
            f"target, args, kwargs = pickle.loads(open({str(tmp_path / 'job.pickle')!r}, 'rb').read()); "
            "_call(target, args, kwargs); print(sorted(m for m in sys.modules if m.split('.')[0] == 'scipy'))")
    done = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, PYTHONPATH=str(ROOT)),
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
    assert (tmp_path / "solutions.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("line, average, spare", [
    ("3.50 2.10 1.00 1/78 4242", 3.5, True),  # a busy last minute, nothing else runnable now
    ("0.10 0.10 0.10 2/78 4242", 0.1, False),  # a quiet minute, a task running beside us now
    ("0.10 0.10 0.10 3/78 4242", 0.1, False),
    ("not a loadavg", 0.5, True),  # unreadable: the last minute's average decides
    ("not a loadavg", 1.5, False),
])
def test_spare_core_counts_the_tasks_runnable_now(tmp_path, monkeypatch, line, average, spare):
    import pipeline.cli as cli

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    monkeypatch.setattr(os, "getloadavg", lambda: (average, average, average))
    monkeypatch.setattr(run_cores, "_own_running_threads", lambda: 1)  # the counts are of a process running alone
    loadavg = tmp_path / "loadavg"
    loadavg.write_text(line + "\n")
    assert cli.spare_core(str(loadavg)) is spare


def test_spare_core_sees_a_cpu_bound_task_on_every_other_core():
    import pipeline.cli as cli

    cores = len(os.sched_getaffinity(0))
    if cores > 8:
        pytest.skip(f"{cores} cores: too many busy loops to start")
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(cores - 1)]
    try:
        time.sleep(0.3)  # each has started its loop
        assert run_cores.others_runnable() >= cores - 1
        assert not cli.spare_core()
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()


def test_spare_core_does_not_count_this_processs_own_threads(tmp_path, monkeypatch):
    """A thread of ours busy outside the GIL (zlib; OpenBLAS's threads spin so after numpy's
    import when not told one thread) is runnable, and is ours: the core it takes is the run's."""
    import threading
    import zlib

    import pipeline.cli as cli

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    loadavg = tmp_path / "loadavg"
    stop = threading.Event()
    data = os.urandom(1 << 22)

    def busy():
        while not stop.is_set():
            zlib.compress(data, 9)  # releases the GIL: runnable while the test reads

    worker = threading.Thread(target=busy, daemon=True)
    worker.start()
    try:
        time.sleep(0.05)
        # the busy thread waits for the GIL between two calls (a few ms in ~100): read a few times
        own = max(run_cores._own_running_threads() for _ in range(5))
        assert own >= 2  # this thread and the busy one at least
        loadavg.write_text(f"0.10 0.10 0.10 {own}/78 4242\n")  # only our threads runnable
        assert run_cores.others_runnable(str(loadavg)) == 0 and cli.spare_core(str(loadavg))
        loadavg.write_text(f"0.10 0.10 0.10 {own + 1}/78 4242\n")  # and one task of another process
        assert run_cores.others_runnable(str(loadavg)) >= 1 and not cli.spare_core(str(loadavg))
    finally:
        stop.set()
        worker.join()
