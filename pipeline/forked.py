"""A piece of a run's work done beside it, by a forked copy of its process.

A hull run's summary drawings (the plan DXF, the shell expansion DXF and PDF, the sheet and
hull PNGs) need nothing that the fit-up computes, and the fit-up nothing they draw; both ran
one after the other in the run's process, on one core, after the parts' workers were done
(a quarter of a minute on the 160 m hull, most of a minute on KCS). :func:`beside` forks the
process at that point: the copy has the results in memory already (nothing is pickled to
it), does the work and sends back only its small return value or its exception, while the
run goes on with the fit-up on the other core. Several drawings are shared out one at a
time (:func:`beside_all`): the run itself draws those no copy has started when its fit-up
is done.

It forks only when that is safe and useful: on Linux (fork without exec is unsafe on macOS,
absent on Windows), with a single thread in the process (a Dask client's threads, say, would
be copied mid-flight), and with no render process active (a one-shot run's images already go
to one, and a copy would write into its pipes). Otherwise the work is done at once, in place,
as before. The copy ignores Ctrl-C (the run decides), dies with the run (PR_SET_PDEATHSIG),
and is killed and reaped when the run leaves the ``with`` block without waiting for it (an
error, an interrupt), before the staging folder is removed. A copy that dies (a signal, the
OOM killer) is a ``RuntimeError`` in the run.
"""

from __future__ import annotations

import functools
import os
import pickle
import signal
import struct
import sys
import threading
from typing import Self

from .renderproc import ACTIVE, _read, _write, sendable, start_child


def can_fork() -> bool:
    """Is forking this process now safe (Linux, one thread, no render process active)?"""
    return sys.platform.startswith("linux") and threading.active_count() == 1 and ACTIVE.get() is None


class Beside:
    """Work running in a forked copy of this process, or done already (``forked`` False).
    Use as a context manager; :meth:`result` waits for the work and returns what it
    returned (raising what it raised)."""

    def __init__(self, work, fork: bool | None = None):
        self.pid: int | None = None
        self._value = self._error = None
        self._done = False
        if fork is None:
            fork = can_fork()
        pid = self._fork(work) if fork else None
        if pid is None:  # not asked to, or the system could not (no memory, no process left)
            try:
                self._value = work()
            except BaseException as exc:  # noqa: BLE001 - raised by result(), as the copy's would be
                self._error = exc
            self._done = True

    def _fork(self, work) -> int | None:
        try:
            read, write = os.pipe()
        except OSError:
            return None
        sys.stdout.flush()
        sys.stderr.flush()
        parent = os.getpid()
        try:
            pid = os.fork()
        except OSError:
            os.close(read)
            os.close(write)
            return None
        if pid == 0:  # the copy: never returns
            code = 1
            try:
                os.close(read)
                code = _run_copy(parent, work, write)
            finally:
                os._exit(code)  # no atexit handlers or buffers of the run's process
        os.close(write)
        self.pid, self._answers = pid, read
        return pid

    @property
    def forked(self) -> bool:
        return self.pid is not None

    def result(self):
        if not self._done:
            message = _read(self._answers)
            os.close(self._answers)
            _, status = os.waitpid(self.pid, 0)
            self._done = True
            if message is None:
                how = f"signal {os.WTERMSIG(status)}" if os.WIFSIGNALED(status) else f"exit {os.WEXITSTATUS(status)}"
                self._error = RuntimeError(f"the process drawing beside the run ended unexpectedly ({how})")
            elif message[:1] == b"V":  # the value, else the exception (_run_copy)
                self._value = pickle.loads(message[1:])
            else:
                self._error = pickle.loads(message[1:])
        if self._error is not None:
            error, self._error = self._error, None
            raise error
        return self._value

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        if self._done:
            return
        try:
            os.kill(self.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        os.waitpid(self.pid, 0)
        os.close(self._answers)
        self._done = True


class BesideAll:
    """Pieces of work, each returning a list, shared by ``copies`` forked copies (:class:`Beside`),
    all started at once: each copy takes the next piece no one has taken until none is left,
    and so does the run when it asks for the result, rather than wait idle while a copy has
    pieces still to start. :meth:`result` returns their lists joined in the pieces' order
    (raising the first error it meets: the run's own, then each copy's in turn; a copy stops
    at its first). At most :data:`MAX_PIECES` pieces. A context manager, as :class:`Beside`."""

    def __init__(self, works: list, copies: int, fork: bool | None = None):
        self.works = list(works)
        self.parts: list[Beside] = []
        self._pieces = None
        self._mine: dict | None = None  # {piece: its list} of those the run took
        n = min(max(copies, 1), len(self.works))
        if not n:
            return
        self._pieces = _Pieces(len(self.works))
        try:
            for _ in range(n):
                self.parts.append(Beside(functools.partial(_take_all, self.works, self._pieces), fork))
        except BaseException:
            self.__exit__()
            raise

    def result(self) -> list:
        if self._mine is None:
            try:
                self._mine = {} if self._pieces is None else _take_all(self.works, self._pieces)
            finally:
                if self._pieces is not None:  # none left to take: the copies hold their own ends
                    self._pieces.close()
        done = dict(self._mine)
        for part in self.parts:
            done.update(part.result())
        return [item for k in range(len(self.works)) for item in done[k]]

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        for part in self.parts:
            part.__exit__()
        if self._pieces is not None:
            self._pieces.close()


MAX_PIECES = 4096  # two bytes each: all of them fit in an empty pipe (64 KiB on Linux, 4 KiB at least)


class _Pieces:
    """The numbers of ``n`` pieces of work in a pipe, each read by whichever process takes
    it first (a two-byte read from a pipe is atomic). Every number is written before anyone
    reads and the pipe is read without blocking, so an empty pipe means every piece is taken."""

    def __init__(self, n: int):
        if not 0 < n <= MAX_PIECES:
            raise ValueError(f"pieces of work beside the run: 1 to {MAX_PIECES}, not {n}")
        self.fd, write = os.pipe()
        try:
            os.write(write, struct.pack(f"<{n}H", *range(n)))
            os.set_blocking(self.fd, False)
        except BaseException:
            os.close(self.fd)
            raise
        finally:
            os.close(write)

    def take(self) -> int | None:
        """The next piece no one has taken, None when none is left."""
        if self.fd is None:
            return None
        try:
            got = os.read(self.fd, 2)
        except BlockingIOError:
            return None
        return struct.unpack("<H", got)[0] if got else None

    def close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def _take_all(works: list, pieces: _Pieces) -> dict:
    """{piece: its list} of the pieces this process takes, until none is left."""
    done = {}
    while (k := pieces.take()) is not None:
        done[k] = works[k]()
    return done


def beside_all(works: list, fork: bool | None = None) -> BesideAll:
    """The ``works`` (each ``work() -> list``) in forked copies when :func:`can_fork`, else
    now: one copy per free core beside the run's own (:func:`spare_cores`), at most one per
    work, none for no work (:class:`BesideAll`; the run takes the works left when it asks
    for their result).
    A hull run's summary drawings (expansion, plan DXF, images: 2.3, 1.5 and 1.2 s on the 160
    m hull) are independent: with cores to spare they take the longest one's time, not the
    sum; on 2 cores one copy draws them beside the fit-up (three copies made KCS's export
    stage 1.25 times as long: the fit-up, which the summary waits for, lost its core) and the
    run draws those the copy has not started once its fit-up and summary are done (the 160 m
    hull's images: the copy had drawn the expansion and the plan DXF by then)."""
    return BesideAll(works, spare_cores(), fork)


def spare_cores() -> int:
    """Cores free beside this process now: those it may run on, less its own and those the
    tasks of other processes keep busy (at least 1)."""
    from .cores import free_cores, usable_cores

    free = free_cores()
    return max(1, usable_cores() - 1 if free is None else free)


def beside(work, fork: bool | None = None) -> Beside:
    """``work()`` in a forked copy of this process when :func:`can_fork` (or ``fork``
    says so), else now; see :class:`Beside`."""
    return Beside(work, fork)


def _run_copy(parent: int, work, answers: int) -> int:
    if not start_child(parent):
        return 1
    try:
        answer = b"V" + pickle.dumps(work())
    except BaseException as exc:  # noqa: BLE001 - sent back, raised in the run
        answer = b"E" + sendable(exc, "in the process drawing beside the run")
    _write(answers, answer)
    return 0
