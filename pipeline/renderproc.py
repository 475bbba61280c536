"""Images and drawings written by a second process while the run goes on.

matplotlib is the run's largest import (~0.3 s of a one-shot plate, more than its solve)
and its PNG previews and PDF shop drawings are the largest part of a plate's files; none
of it feeds back into the computation. In a one-shot ``devflat run`` (one process for the
parts, 2 cores on this machine) the command forks a render process as soon as it has read
the configuration file, when a core is free (:func:`pipeline.cli.early_renderer`): it
imports matplotlib while the run validates the configuration, imports its other libraries
and solves; the validated configuration then keeps it or ends it unused. It writes each
image it is sent (a part's previews are sent first) while the run lays out and writes the
DXF and OBJ. The functions it runs are named (``"pipeline.plots:flat_pattern_png"``) and their
arguments pickled, so the run itself never imports matplotlib; the files are the same
bytes as when written in the run's process (same function, same arguments).

Outside such a run (tests, the library, ``--jobs`` workers) :func:`render` calls the
function in place. Errors are the function's own: :meth:`Renderer.wait` raises, in the
run's process, the first exception a job raised (an ``OSError`` stays one: a full disk is
an output fault as before), so a part whose image fails fails as it did before, at the
end of its export. At most ``IN_FLIGHT`` jobs are sent ahead of their answers (bounded
pipes, no deadlock). The process ignores Ctrl-C (the run decides), dies with the run
(PR_SET_PDEATHSIG on Linux) and is killed and reaped when the run leaves its ``with``
block for whatever reason, before the staging folder is removed.
"""

from __future__ import annotations

import contextvars
import importlib
import os
import pickle
import signal
import struct
import sys
import traceback

IN_FLIGHT = 4
MAX_TRACEBACK = 4000  # characters of a job's traceback sent back (an answer stays small)
_HEADER = struct.Struct("<Q")

# the render process of the running command, if any (a context value, not a global: it
# is set by the command for the duration of its run and seen by the code it calls)
ACTIVE: contextvars.ContextVar[Renderer | None] = contextvars.ContextVar("devflat_renderer", default=None)


def _call(target: str, args: tuple, kwargs: dict):
    module, name = target.split(":")
    return getattr(importlib.import_module(module), name)(*args, **kwargs)


def render(target: str, *args, **kwargs) -> None:
    """Run ``target`` ("module:function", which writes a file and returns nothing) in the
    render process when one is active, else here and now."""
    renderer = ACTIVE.get()
    if renderer is None:
        _call(target, args, kwargs)
    else:
        renderer.submit(target, args, kwargs)


def wait() -> None:
    """Wait until every image sent so far is written; raise the first job's exception."""
    renderer = ACTIVE.get()
    if renderer is not None:
        renderer.wait()


def _write(fd: int, payload: bytes) -> None:
    view = memoryview(_HEADER.pack(len(payload)) + payload)
    while view:
        view = view[os.write(fd, view):]


def _read(fd: int) -> bytes | None:
    """One message, or None at end of file."""
    def exactly(n: int) -> bytes | None:
        chunks, got = [], 0
        while got < n:
            chunk = os.read(fd, n - got)
            if not chunk:
                return None
            chunks.append(chunk)
            got += len(chunk)
        return b"".join(chunks)

    header = exactly(_HEADER.size)
    if header is None:
        return None
    return exactly(_HEADER.unpack(header)[0])


class Renderer:
    """A forked render process and the two pipes to it. Use as a context manager."""

    def __init__(self, preload: tuple[str, ...]):
        self.preload = preload
        self.pid: int | None = None
        self.running = False  # forked and not yet reaped
        self.pending = 0
        self.error: BaseException | None = None

    def start(self) -> Renderer:
        """Fork the process now (it imports ``preload`` at once), before the run decides to
        use it: ``with`` then takes it over, or :meth:`discard` ends it unused."""
        if self.pid is None:
            self._fork()
        return self

    def discard(self) -> None:
        """End a started process that the run does not use (nothing once it is reaped)."""
        if self.running:
            os.close(self._jobs_w)
            os.close(self._answers_r)
            self._kill_and_reap()

    def _kill_and_reap(self) -> None:
        try:
            os.kill(self.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self._reap()

    def _reap(self) -> None:
        os.waitpid(self.pid, 0)
        self.running = False

    def __enter__(self) -> Renderer:
        self.start()
        self._token = ACTIVE.set(self)
        return self

    def _fork(self) -> None:
        jobs_r, self._jobs_w = os.pipe()
        self._answers_r, answers_w = os.pipe()
        sys.stdout.flush()
        sys.stderr.flush()
        parent = os.getpid()
        pid = os.fork()
        if pid == 0:  # the render process: never returns
            code = 1
            try:
                os.close(self._jobs_w)
                os.close(self._answers_r)
                code = _serve(parent, jobs_r, answers_w, self.preload)
            finally:
                os._exit(code)  # no atexit handlers or buffers of the run's process
        self.pid, self.running = pid, True
        os.close(jobs_r)
        os.close(answers_w)

    def submit(self, target: str, args: tuple, kwargs: dict) -> None:
        try:
            job = pickle.dumps((target, args, kwargs), protocol=pickle.HIGHEST_PROTOCOL)
        except Exception:  # noqa: BLE001 - arguments that do not pickle: drawn here, as without the process
            _call(target, args, kwargs)
            return
        if self.pending >= IN_FLIGHT:
            self._answer()
        try:
            _write(self._jobs_w, job)
        except BrokenPipeError:
            raise RuntimeError("the render process ended unexpectedly (killed?); its images were not written") \
                from None
        self.pending += 1

    def _answer(self) -> None:
        message = _read(self._answers_r)
        if message is None:
            raise RuntimeError("the render process ended unexpectedly (killed?); its images were not written")
        self.pending -= 1
        error = pickle.loads(message)
        if error is not None and self.error is None:
            self.error = error

    def wait(self) -> None:
        while self.pending:
            self._answer()
        error, self.error = self.error, None
        if error is not None:
            raise error

    def __exit__(self, *exc) -> None:
        ACTIVE.reset(self._token)
        try:
            if exc[0] is None:
                self.wait()
        finally:
            os.close(self._jobs_w)  # end of file: the process exits after its last job
            os.close(self._answers_r)
            if exc[0] is not None or self.pending:  # interrupted or failed: its files are not wanted
                self._kill_and_reap()
            else:
                self._reap()


def start_child(parent: int) -> bool:
    """In a process forked from the run: ignore Ctrl-C (it reaches the whole group; the run
    decides), die with the run (PR_SET_PDEATHSIG on Linux); False when the run is gone already."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    return os.getppid() == parent  # the run may have died before the line above


def sendable(error: BaseException, where: str) -> bytes:
    """``error`` pickled to be raised in the run, its traceback (the last MAX_TRACEBACK
    characters) added as a note saying ``where``; its text in a RuntimeError when it pickles
    but does not unpickle (an exception class with required arguments)."""
    error.add_note(f"({where})\n" + "".join(traceback.format_exception(error))[-MAX_TRACEBACK:])
    try:
        answer = pickle.dumps(error)
        pickle.loads(answer)
    except Exception:  # noqa: BLE001 - then its text
        answer = pickle.dumps(RuntimeError(f"{type(error).__name__}: {error}\n{getattr(error, '__notes__', '')}"))
    return answer


def _serve(parent: int, jobs: int, answers: int, preload: tuple[str, ...]) -> int:
    import gc

    if not start_child(parent):
        return 1
    for name in preload:  # "module" or "module:function" (called without arguments)
        if ":" in name:
            _call(name, (), {})
        else:
            importlib.import_module(name)
    gc.freeze()  # as the run does after its imports (pipeline.cli.imports_done)
    gc.enable()
    while (message := _read(jobs)) is not None:
        target, args, kwargs = pickle.loads(message)
        answer = pickle.dumps(None)
        try:
            _call(target, args, kwargs)
        except BaseException as exc:  # noqa: BLE001 - sent back, raised in the run
            answer = sendable(exc, "in the render process")
        _write(answers, answer)
    return 0
