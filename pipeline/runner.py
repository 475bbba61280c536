"""Running the parts of a configuration: each in its own guard, in this process or in
worker processes that also write the part's files.

Isolation: an unexpected exception while computing or writing one part makes that part
fail (the reason and the traceback go into its report); the other parts go on. Only an
output fault (disk full, a folder that cannot be written) stops the run, as an
:class:`~pipeline.outdir.OutputError`.

Workers (``jobs > 1``) get the configuration once, through the pool initializer, and are
sent part indices; each computes and writes its part into the staging folder and sends
back the part's summary (no solution, no development; the strip and the pattern only when
the run's summary images need them). Workers ignore SIGINT (the parent decides), die with
the parent (PR_SET_PDEATHSIG on Linux), and are killed when the run is interrupted.
A worker that dies (a signal, the OOM killer) fails only the part it was running.
"""

from __future__ import annotations

import os
import signal
from dataclasses import fields, replace
import sys
import traceback
from pathlib import Path

from .config import RunConfig
from .outdir import OutputError
from .stages import PartResult


def failed_result(part, exc: BaseException, stage: str) -> PartResult:
    """The part's failure for an unexpected exception: reason and traceback in its report."""
    result = PartResult(part.name, part)
    result.reason = f"internal error while {stage}: {type(exc).__name__}: {exc}"
    result.figures["traceback"] = "".join(traceback.format_exception(exc))
    return result


def guarded_run(part, config: RunConfig) -> PartResult:
    from .hull.plates import run_part

    try:
        return run_part(part, config)
    except Exception as exc:  # noqa: BLE001 - one part's bug is that part's failure
        return failed_result(part, exc, "computing the part")


def guarded_export(result: PartResult, config: RunConfig, folder: Path, out: Path) -> PartResult:
    """Write the part's files into ``folder``; an exception other than an output fault
    fails the part, which then writes its report alone."""
    from .export import export_part

    try:
        folder.mkdir(exist_ok=True)
        for path in folder.iterdir():  # left by a worker that died on this part
            path.unlink()
        export_part(result, config, folder)
        return result
    except OSError as exc:
        raise OutputError(f"--out {out}: cannot write the files of part {result.name}: "
                          f"{exc.strerror or exc}") from None
    except Exception as exc:  # noqa: BLE001
        for path in folder.iterdir():
            path.unlink()
        failed = failed_result(result.part, exc, "writing the part's files")
        try:
            export_part(failed, config, folder)
        except OSError as again:
            raise OutputError(f"--out {out}: cannot write the files of part {result.name}: "
                              f"{again.strerror or again}") from None
        return failed


def slim(result: PartResult, keep_geometry: bool) -> PartResult:
    """What the parent needs of a written part: figures and status; the strip and pattern
    only for the summary images. The part itself is re-attached by the parent."""
    keep = {"strip", "pattern", "mesh"} if keep_geometry else set()
    heavy = {f.name: None for f in fields(PartResult) if f.name not in keep | {"name", "status", "reason",
                                                                              "warnings", "figures"}}
    return replace(result, **heavy)


def process_part(index: int, config: RunConfig, staging: Path | None, out: Path | None,
                 keep_geometry: bool) -> PartResult:
    """Compute part ``index``; with a staging folder also write it there (and slim it)."""
    result = guarded_run(config.parts[index], config)
    if staging is None:
        return result
    result = guarded_export(result, config, staging / f"part-{index:06d}", out)
    return slim(result, keep_geometry)


class _Worker:
    """The state of a worker process, set once by the pool initializer (the configuration
    is sent once per worker, not with every part)."""

    config: RunConfig | None = None
    staging: Path | None = None
    out: Path | None = None
    keep_geometry = False


def _die_with_parent(parent: int) -> None:
    if sys.platform.startswith("linux"):
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    if os.getppid() != parent:  # the parent died before the line above
        os._exit(1)


def _init_worker(parent: int, config: RunConfig, staging: Path | None, out: Path | None,
                 keep_geometry: bool) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the parent decides
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent(parent)
    _Worker.config, _Worker.staging, _Worker.out, _Worker.keep_geometry = config, staging, out, keep_geometry


def _work(index: int) -> PartResult:
    return process_part(index, _Worker.config, _Worker.staging, _Worker.out, _Worker.keep_geometry)


def worker_count(jobs: int, n_parts: int) -> int:
    """Workers worth starting: not more than parts, nor than CPUs this process may use."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:
        cpus = os.cpu_count() or 1
    return max(1, min(jobs, n_parts, cpus))


def run_parts(config: RunConfig, staging: Path | None, out: Path | None, jobs: int = 1, progress=None,
              keep_geometry: bool = False) -> list[PartResult]:
    """Every part's result, in the order of ``config.parts``. With ``staging`` the parts are
    also written there (``staging/part-NNNNNN/``)."""
    n = len(config.parts)
    results: list[PartResult | None] = [None] * n
    workers = worker_count(jobs, n)

    def done(index: int, result: PartResult) -> None:
        result.part = config.parts[index]
        results[index] = result
        if progress is not None:
            progress.set_postfix_str(result.name)
            progress.update()

    if workers == 1:
        for index in range(n):
            done(index, process_part(index, config, staging, out, keep_geometry))
        return results
    pending = list(range(n))
    while pending:
        pending = _pool_pass(pending, config, staging, out, workers, keep_geometry, done)
    return results


def _pool_pass(indices: list[int], config, staging, out, workers: int, keep_geometry: bool, done) -> list[int]:
    """Run ``indices`` in a fresh pool, at most two parts per worker in flight. The parts in
    flight when a worker dies are run again one at a time, so that the part a worker dies
    on fails alone. Returns the parts not yet started."""
    import gc
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    # the workers are forked with this process's objects: frozen, the collector in a
    # worker never walks them (each walk would touch, and so copy, every page they are on)
    frozen_before = gc.get_freeze_count()
    gc.freeze()
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_init_worker,
                               initargs=(os.getpid(), config, staging, out, keep_geometry))
    queue = list(indices)
    flight: dict = {}
    try:
        while queue or flight:
            while queue and len(flight) < 2 * workers:  # a second part queued: no idle worker between
                index = queue.pop(0)
                flight[pool.submit(_work, index)] = index
            finished, _ = wait(flight, return_when=FIRST_COMPLETED)
            for future in finished:
                index = flight.pop(future)
                try:
                    done(index, future.result())
                except BrokenProcessPool as exc:
                    lost = [index] + list(flight.values())
                    if len(lost) == 1 and workers == 1:
                        part = config.parts[index]
                        result = failed_result(part, exc, "computing the part (the worker process died)")
                        if staging is not None:
                            result = slim(guarded_export(result, config, staging / f"part-{index:06d}", out),
                                          keep_geometry)
                        done(index, result)
                        return queue
                    _shutdown(pool)
                    # again, one at a time, so that the part that kills a worker is found
                    for again in sorted(lost):
                        _one_at_a_time(again, config, staging, out, keep_geometry, done)
                    return queue
        pool.shutdown(wait=True)
        return []
    except BaseException:
        _shutdown(pool)
        raise
    finally:
        if not frozen_before:  # a long-lived caller's objects are collectable again
            gc.unfreeze()


def _one_at_a_time(index: int, config, staging, out, keep_geometry: bool, done) -> None:
    remaining = _pool_pass([index], config, staging, out, 1, keep_geometry, done)
    assert not remaining


def _shutdown(pool) -> None:
    """Stop the pool now: cancel what has not started and kill the workers (their staged
    files are removed with the staging folder after they are gone)."""
    processes = list(getattr(pool, "_processes", {}).values())  # no public API to kill workers
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.kill()
    for process in processes:
        process.join(timeout=5)
