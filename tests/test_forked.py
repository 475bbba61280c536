"""pipeline.forked: work done beside the run by a forked copy of its process (a hull run's
summary drawings while it computes the fit-up): the copy's return value and exceptions come
back, a copy that dies is an error, one not waited for is killed, and the work is done in
place where forking is unsafe."""

from __future__ import annotations

import functools
import os
import re
import signal
import sys
import threading
import time

import pytest

from pipeline.forked import BesideAll, beside, beside_all, can_fork

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forks only on Linux")


def alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(") ")[1][0] != "Z"
    except FileNotFoundError:
        return False


def test_the_work_runs_in_a_copy_and_its_value_comes_back():
    big = list(range(100_000))  # in the copy's memory already: nothing is sent to it
    with beside(lambda: (os.getpid(), sum(big)), fork=True) as drawn:
        assert drawn.forked
        pid, total = drawn.result()
    assert pid != os.getpid()
    assert total == sum(big)
    assert not alive(pid)


def test_the_copys_exceptions_are_raised_in_the_run_an_output_fault_stays_one():
    def full_disk():
        raise OSError(28, "No space left on device")

    with beside(full_disk, fork=True) as drawn, pytest.raises(OSError, match="No space left") as caught:
        drawn.result()
    assert caught.value.errno == 28
    assert "in the process drawing beside the run" in "".join(caught.value.__notes__)

    class NeedsTwo(Exception):
        def __init__(self, a, b):
            super().__init__(f"{a} and {b}")

    def unpicklable():
        raise NeedsTwo(1, 2)  # pickles, but does not unpickle

    with beside(unpicklable, fork=True) as drawn, pytest.raises(RuntimeError, match="NeedsTwo: 1 and 2"):
        drawn.result()


def _logged(log, k: int) -> list:
    """Work ``k``: its number and process appended to ``log`` (O_APPEND: whole lines, from any
    process), so that a work done twice is seen even where one answer overwrites another."""
    fd = os.open(log, os.O_WRONLY | os.O_APPEND | os.O_CREAT)
    try:
        os.write(fd, f"{k} {os.getpid()}\n".encode())
    finally:
        os.close(fd)
    return [(k, os.getpid())]


def _done_once(log, n: int) -> None:
    done = sorted(int(line.split()[0]) for line in log.read_text().splitlines())
    assert done == list(range(n))  # each work exactly once, whoever took it
    log.unlink()


def test_works_beside_share_as_many_copies_as_asked_their_lists_joined_in_order(tmp_path):
    log = tmp_path / "done"

    def slow(k):
        time.sleep(0.05)
        return _logged(log, k)

    works = [functools.partial(slow, k) for k in range(5)]
    for copies, expected in ((1, 1), (2, 2), (3, 3), (9, 5)):
        with BesideAll(works, copies, fork=True) as drawn:
            assert len(drawn.parts) == expected and all(part.forked for part in drawn.parts)
            got = drawn.result()
            assert drawn.result() == got  # asked again: the same answer
        assert [k for k, _ in got] == list(range(5))  # in the works' order
        copy_pids = {part.pid for part in drawn.parts}
        assert {pid for _, pid in got} <= copy_pids | {os.getpid()}
        _done_once(log, 5)


def test_the_run_takes_the_works_no_copy_has_started(tmp_path):
    def first():
        # the copy's first work waits until the run has done the two others
        deadline = time.monotonic() + 60.0
        while not all((tmp_path / f"took{k}").exists() for k in (1, 2)) and time.monotonic() < deadline:
            time.sleep(0.01)
        return [(0, os.getpid())]

    def other(k):
        (tmp_path / f"took{k}").touch()
        return [(k, os.getpid())]

    works = [first] + [functools.partial(other, k) for k in (1, 2)]
    with BesideAll(works, 1, fork=True) as drawn:
        deadline = time.monotonic() + 60.0
        while _pieces_left(drawn) == 3 and time.monotonic() < deadline:
            time.sleep(0.01)  # until the copy has taken its first work
        got = drawn.result()
    assert [k for k, _ in got] == [0, 1, 2]
    assert got[0][1] == drawn.parts[0].pid  # the copy drew the first work
    assert [pid for _, pid in got[1:]] == [os.getpid()] * 2  # the run the two it had not started


def _pieces_left(drawn) -> int:
    import fcntl
    import struct
    import termios

    return struct.unpack("i", fcntl.ioctl(drawn._pieces.fd, termios.FIONREAD, b"\0" * 4))[0] // 2


def test_every_work_is_taken_once_however_the_copies_race(tmp_path):
    log = tmp_path / "done"
    works = [functools.partial(_logged, log, k) for k in range(300)]  # past a byte's 256 numbers
    for _ in range(3):
        with BesideAll(works, 3, fork=True) as drawn:
            got = drawn.result()
        assert [k for k, _ in got] == list(range(300))
        _done_once(log, 300)


def test_one_copy_per_free_core_draws_beside_the_run(monkeypatch):
    import pipeline.cores as cores

    works = [lambda k=k: [k] for k in range(3)]
    # (cores usable, tasks of other processes runnable) -> copies
    for (usable, busy), copies in (((1, 0), 1), ((2, 0), 1), ((3, 0), 2), ((16, 0), 3), ((16, 14), 1),
                                   ((16, 13), 2), ((4, None), 3)):
        monkeypatch.setattr(cores, "usable_cores", lambda usable=usable: usable)
        monkeypatch.setattr(cores, "others_runnable", lambda *_, busy=busy: busy)
        with beside_all(works, fork=False) as drawn:  # in place: the count alone is tested
            assert len(drawn.parts) == copies and drawn.result() == [0, 1, 2]
    with beside_all([], fork=False) as drawn:
        assert drawn.parts == [] and drawn.result() == []  # no drawing, no copy
    # in place, the first part does every work at once (as the run did before it forked)
    with BesideAll(works, 2, fork=False) as drawn:
        assert [len(part.result()) for part in drawn.parts] == [3, 0]


def test_an_error_in_one_copy_is_raised_and_the_others_are_reaped():
    def broken():
        raise ValueError("no plan DXF")

    with BesideAll([lambda: [1], broken, lambda: time.sleep(60) or [3]], 3, fork=True) as drawn:
        pids = [part.pid for part in drawn.parts]
        with pytest.raises(ValueError, match="no plan DXF"):
            drawn.result()
    assert not any(alive(pid) for pid in pids)  # the sleeper killed when the run left


def test_a_copy_that_dies_is_an_error_naming_the_signal():
    with beside(lambda: os.kill(os.getpid(), signal.SIGKILL), fork=True) as drawn:
        with pytest.raises(RuntimeError, match="ended unexpectedly \\(signal 9\\)"):
            drawn.result()


def test_a_copy_not_waited_for_is_killed_when_the_run_leaves_the_block():
    with pytest.raises(KeyError):
        with beside(lambda: time.sleep(60), fork=True) as drawn:
            pid = drawn.pid
            assert alive(pid)
            raise KeyError("the run failed while the copy drew")
    assert not alive(pid)  # killed and reaped at once, not after its 60 s


def test_the_work_is_done_in_place_when_forking_is_unsafe():
    assert can_fork() == (threading.active_count() == 1)
    stop = threading.Event()
    thread = threading.Thread(target=stop.wait)
    thread.start()
    try:
        assert not can_fork()  # another thread would be copied mid-flight
        with beside(os.getpid) as drawn:
            assert not drawn.forked
            assert drawn.result() == os.getpid()
    finally:
        stop.set()
        thread.join()
    with beside(lambda: 1 / 0, fork=False) as drawn, pytest.raises(ZeroDivisionError):
        drawn.result()



def test_a_fork_the_system_refuses_leaves_the_work_to_the_run(monkeypatch):
    def refused():
        raise BlockingIOError(11, "Resource temporarily unavailable")  # fork(2): EAGAIN, no process left

    monkeypatch.setattr(os, "fork", refused)
    with beside(os.getpid, fork=True) as drawn:
        assert not drawn.forked
        assert drawn.result() == os.getpid()


RUN = r"""
import json, sys
import pipeline.forked as forked
flags = []
start = forked.Beside.__init__
def spied(self, work, fork=None):
    start(self, work, fork if sys.argv[1] == "fork" else False)
    flags.append(self.forked)
forked.Beside.__init__ = spied
from pipeline.cli import main
code = main(["run", sys.argv[2], "--jobs", "2", "--out", sys.argv[3]])  # with its progress bar
print(json.dumps({"code": code, "forked": flags}))
"""


def _run(how: str, config, out) -> dict:
    import json
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=str(root), SOURCE_DATE_EPOCH="1700000000")
    done = subprocess.run([sys.executable, "-c", RUN, how, str(config), str(out)], capture_output=True, text=True,
                          env=env, cwd=root, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_strake_runs_drawings_beside_its_fit_up_and_writes_what_it_wrote_in_place(tmp_path):
    """`devflat run --jobs 2` of a strake with images forks its summary drawings (the
    process has one thread by then: the progress bar runs no monitor thread) and writes the
    same files as when they are drawn in place: JSON, CSV, OBJ, PNG and PDF byte for byte
    (SOURCE_DATE_EPOCH), DXF apart from its header (creation time, GUIDs)."""
    import yaml

    from tests.test_run_faults import strake_config

    config = strake_config(tmp_path, butts=(56000, 64000, 72000))
    data = yaml.safe_load(config.read_text())
    data["output"] = {"png": True, "obj": True}
    config.write_text(yaml.safe_dump(data))
    forked, in_place = _run("fork", config, tmp_path / "forked"), _run("in place", config, tmp_path / "in_place")
    assert forked == {"code": 0, "forked": [True]}
    assert in_place == {"code": 0, "forked": [False]}
    a = {p.name: p for p in (tmp_path / "forked").iterdir()}
    b = {p.name: p for p in (tmp_path / "in_place").iterdir()}
    assert sorted(a) == sorted(b)
    drawings = {name for name in a if name.startswith("h_") and not name.startswith("h_summary")}
    assert {"h_expansion.dxf", "h_expansion.pdf", "h_sheet.png", "h_hull.png"} <= drawings, sorted(a)
    for name in a:
        if name.endswith(".dxf"):  # the time it was written is in a part's data too
            same = [re.sub(r"\d{4}-\d\d-\d\dT[\d:.]+\+00:00", "T", p.read_text().split("ENTITIES", 1)[1])
                    for p in (a[name], b[name])]
            assert same[0] == same[1], name
        else:
            assert a[name].read_bytes() == b[name].read_bytes(), name
