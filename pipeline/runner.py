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

import copy
import os
import signal
from dataclasses import dataclass, field, fields, replace
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
    """Compute part ``index``; with a staging folder also write it there (and slim it). The
    wall and CPU seconds of each step go into ``figures["stage_seconds"]`` (no output file
    names it: the console's per-stage line adds them up)."""
    import time

    wall, cpu = time.perf_counter(), time.process_time()
    result = guarded_run(config.parts[index], config)
    seconds = {"plates": time.perf_counter() - wall, "plates_cpu": time.process_time() - cpu}
    if staging is None:
        result.figures["stage_seconds"] = seconds
        return result
    wall, cpu = time.perf_counter(), time.process_time()
    result = guarded_export(result, config, staging / f"part-{index:06d}", out)
    seconds.update(shop=time.perf_counter() - wall, shop_cpu=time.process_time() - cpu)
    result = slim(result, keep_geometry)
    result.figures["stage_seconds"] = seconds
    return result


def stage_line(stages: dict) -> str:
    """The console's line of where the time went: ``stages`` {name: (wall s, CPU s)}."""
    return "time: " + ", ".join(f"{name} {wall:.1f} s" + (f" ({cpu:.1f} CPU s)" if cpu is not None else "")
                                for name, (wall, cpu) in stages.items())


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
    from .cores import usable_cores

    return max(1, min(jobs, n_parts, usable_cores()))


def run_parts(config: RunConfig, staging: Path | None, out: Path | None, jobs: int = 1, progress=None,
              keep_geometry: bool = False, each=None) -> list[PartResult]:
    """Every part's result, in the order of ``config.parts``. With ``staging`` the parts are
    also written there (``staging/part-NNNNNN/``). ``each(result)``: called with each result
    as it comes in (its part attached), in this process, while the workers run the others."""
    n = len(config.parts)
    results: list[PartResult | None] = [None] * n
    workers = worker_count(jobs, n)

    def done(index: int, result: PartResult) -> None:
        result.part = config.parts[index]
        results[index] = result
        if each is not None:
            each(result)
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


# ------------------------------------------------------------ an adaptive plan's candidates
@dataclass
class Wave:
    """One batch an evaluator handed out and waited for: ``kind`` "plates" (candidates
    evaluated) or "tasks" (:meth:`PlateEvaluator.map_each`, :meth:`PlateEvaluator.develop`),
    the CPU seconds of each item in the order handed out, and the wall seconds from handing
    them out to the last answer read. A plan of rounds is as many waves, each waiting for its
    slowest item, whatever the number of workers (``bench/bench_waves.py`` models a run on
    more cores from them)."""

    kind: str
    start: float  # time.perf_counter() when handed out
    cpu: list = field(default_factory=list)
    wall: float = 0.0


class PlateEvaluator:
    """``evaluate(part, config)`` for the candidate plates of an adaptive plan: each plate
    evaluated once (cached by its geometry, :func:`pipeline.hull.planner.plate_key`, whatever
    plan asks: a second plan of the same hull reuses the first one's plates) and a batch of
    plates spread over ``jobs`` worker processes.

    The workers are forked when the first batch arrives, after the plan loaded its surfaces:
    a plate is sent as a pickle in which the objects every plate shares (the hull surface,
    its distance structure, its trim) are references to the copies the worker inherited, and
    its result comes back without its part (the parent re-attaches it). A lean result (its
    shop data owed) stays lean in the cache: each copy handed out is completed on its own. A worker that dies
    leaves its plates to the parent, which evaluates them itself. Figures (not in any output
    file, so that ``--jobs`` never changes a byte): ``requested`` plates, ``computed`` ones
    (the rest came from the cache), ``seconds`` of wall time in :meth:`many` and the CPU
    seconds of the evaluations (``cpu_seconds``, this process's and the workers' together);
    ``waves``: each batch computed (:class:`Wave`)."""

    def __init__(self, evaluate, jobs: int = 1):
        self.evaluate, self.jobs = evaluate, jobs
        self.cache: dict = {}
        self.waves: list[Wave] = []
        self.requested = self.computed = 0
        self.seconds = self.cpu_seconds = self.local_cpu_seconds = self.mapped_cpu_seconds = 0.0
        self._pool = None
        self._shared: list = []
        self._index: dict = {}

    def __call__(self, part, config):
        return self.many([part], config)[0]

    def many(self, parts: list, config) -> list:
        import time

        from .hull.planner import plate_key

        start = time.perf_counter()
        self.requested += len(parts)
        keys = [plate_key(part, config) for part in parts]
        todo: dict = {}
        for key, part in zip(keys, parts):
            if key not in self.cache and key not in todo:
                todo[key] = part
        for key, result in zip(todo, self._compute(list(todo.values()), config)):
            self.cache[key] = _pristine(result)
        self.computed += len(todo)
        out = [_renamed(self.cache[key], part) for key, part in zip(keys, parts)]
        self.seconds += time.perf_counter() - start
        return out

    def _compute(self, parts: list, config) -> list:
        import time

        if not parts:
            return []
        workers = worker_count(self.jobs, len(parts))
        if workers == 1:
            wave = Wave("plates", time.perf_counter())
            results = []
            for part in parts:
                cpu = time.process_time()
                results.append(self.evaluate(part, config))
                wave.cpu.append(time.process_time() - cpu)
            spent = sum(wave.cpu)
            self.cpu_seconds += spent
            self.local_cpu_seconds += spent
            wave.wall = time.perf_counter() - wave.start
            self.waves.append(wave)
            return results
        return self._in_pool(parts, config, workers)

    def _in_pool(self, parts: list, config, workers: int) -> list:
        import gc
        import multiprocessing
        import time
        from concurrent.futures import ProcessPoolExecutor
        from concurrent.futures.process import BrokenProcessPool

        shared = [obj for part in parts for obj in (part.hull.surface, part.hull.distance, part.hull.trim)
                  if obj is not None]
        if self._pool is not None and any(id(obj) not in self._index for obj in shared):
            self.close()  # a surface the workers never saw: fork them again with it
        if self._pool is None:
            preload_parts()
            self._shared = list({id(obj): obj for obj in shared}.values())
            self._index = {id(obj): k for k, obj in enumerate(self._shared)}
            frozen_before = gc.get_freeze_count()
            gc.freeze()  # the forked workers never walk (and so copy) the parent's pages
            try:
                self._pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"),
                                                 initializer=_init_evaluator,
                                                 initargs=(os.getpid(), config, self.evaluate, self._shared,
                                                           self._index))
                # start the workers now, while the parent's objects are frozen
                list(self._pool.map(_ping, range(workers)))
            finally:
                if not frozen_before:
                    gc.unfreeze()
        wave = Wave("plates", time.perf_counter())
        futures = [self._pool.submit(_evaluate_blob, _dumps(part, self._index)) for part in parts]
        results = []
        for part, future in zip(parts, futures):
            try:
                blob, cpu = future.result()
                result = _loads(blob, self._shared)
                result.part = part
            except BrokenProcessPool:
                self.close()
                cpu = time.process_time()
                result = self.evaluate(part, config)
                cpu = time.process_time() - cpu
                self.local_cpu_seconds += cpu
            self.cpu_seconds += cpu
            wave.cpu.append(cpu)
            results.append(result)
        wave.wall = time.perf_counter() - wave.start
        self.waves.append(wave)
        return results

    @property
    def running(self) -> bool:
        """Are the workers running (forked by a batch of plates, not closed since)?"""
        return self._pool is not None

    def map(self, func, items: list) -> list:
        """``[func(item) for item in items]``, spread over the workers while they run (after
        the first batch of plates; the objects every plate shares travel as references, as
        plates do), else computed here in turn. ``func``: a module-level function. The
        workers' CPU seconds go into ``mapped_cpu_seconds``."""
        return list(self.map_each(func, items))

    def map_each(self, func, items: list):
        """:meth:`map` as an iterator of the answers in order: on the workers the items are
        handed out at once and each answer is given as soon as it and those before it are
        in, so that the caller works on it while the workers compute the rest; here each is
        computed as the iterator is read. Read it to its end before handing the evaluator
        more plates: plates on a surface the workers never saw fork them again, and what
        they had not done is cancelled."""
        if self._pool is None or len(items) < 2:
            return (func(item) for item in items)
        return self._spread_each(_call_blob, [(func, item) for item in items], lambda k: func(items[k]))

    def develop(self, results: list, config) -> list:
        """The results with any development they owe done (:func:`pipeline.hull.plateshop.develop`:
        a plan's kept formed plates, before a fit-up reads them), by the workers while they
        run (as :meth:`map`; under the configuration the workers were started with, the run's),
        else here under ``config``. Use the results handed back (a worker's come back as new
        objects, the parts given re-attached; done here, the given ones are changed)."""
        from .hull.plateshop import develop, owes_development

        out = list(results)
        owing = [k for k, result in enumerate(results) if owes_development(result)]
        if self._pool is None or len(owing) < 2:
            for k in owing:
                out[k] = develop(results[k], config)
            return out
        done = self._spread(_call_blob, [(_developed, replace(results[k], part=None)) for k in owing],
                            lambda j: develop(results[owing[j]], config))
        for k, result in zip(owing, done):
            result.part = results[k].part
            out[k] = result
        return out

    def _spread(self, task, payloads: list, here) -> list:
        """``task(blob)`` of each payload on the workers, their answers in order
        (:meth:`_spread_each`)."""
        return list(self._spread_each(task, payloads, here))

    def _spread_each(self, task, payloads: list, here):
        """``task(blob)`` of each payload handed to the workers now; an iterator of their
        answers in order. The workers' CPU seconds go into ``mapped_cpu_seconds``; once a
        worker dies the pool is closed and payload ``k``'s answer is ``here(k)``, computed
        in this process."""
        import time

        wave = Wave("tasks", time.perf_counter())
        futures = [self._pool.submit(task, _dumps(payload, self._index)) for payload in payloads]
        self.waves.append(wave)
        return self._answers(futures, self._shared, here, wave)

    def _answers(self, futures: list, shared: list, here, wave: Wave):
        """The answers of ``futures`` in order, their shared objects read from ``shared``
        (the workers' list when the work was handed out: a pool forked again for another
        surface before the last answer is read lists other objects); each worker's CPU
        seconds, and the wall seconds until the last is read, go into ``wave``."""
        import time
        from concurrent.futures.process import BrokenProcessPool

        for k, future in enumerate(futures):
            try:
                blob, cpu = future.result()
                answer = _loads(blob, shared)
                self.mapped_cpu_seconds += cpu
                wave.cpu.append(cpu)
            except BrokenProcessPool:
                self.close()
                answer = here(k)
            wave.wall = time.perf_counter() - wave.start
            yield answer

    def close(self) -> None:
        """Stop the workers (the cache stays for the next plan)."""
        if self._pool is not None:
            _shutdown(self._pool)
            self._pool = None

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class _Evaluating:
    """A plan evaluator's worker state, set once by the pool initializer."""

    config = None
    evaluate = None
    shared: list = []
    index: dict = {}


def _init_evaluator(parent: int, config, evaluate, shared: list, index: dict) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent(parent)
    _Evaluating.config, _Evaluating.evaluate, _Evaluating.shared, _Evaluating.index = config, evaluate, shared, index


def _ping(_) -> int:
    return os.getpid()


def _evaluate_blob(blob: bytes) -> tuple[bytes, float]:
    import time

    cpu = time.process_time()
    part = _loads(blob, _Evaluating.shared)
    result = _Evaluating.evaluate(part, _Evaluating.config)
    result.part = None
    return _dumps(result, _Evaluating.index), time.process_time() - cpu


def _developed(result):
    """A result's owed development done in a worker, under the run's configuration."""
    from .hull.plateshop import develop

    return develop(result, _Evaluating.config)


def _call_blob(blob: bytes) -> tuple[bytes, float]:
    import time

    cpu = time.process_time()
    func, item = _loads(blob, _Evaluating.shared)
    return _dumps(func(item), _Evaluating.index), time.process_time() - cpu


def _dumps(obj, index: dict) -> bytes:
    """A pickle in which the objects of ``index`` (id -> number) are sent as their number."""
    import io
    import pickle

    buffer = io.BytesIO()
    pickler = pickle.Pickler(buffer, protocol=pickle.HIGHEST_PROTOCOL)
    pickler.persistent_id = lambda o: index.get(id(o))
    pickler.dump(obj)
    return buffer.getvalue()


def _loads(blob: bytes, shared: list):
    import io
    import pickle

    unpickler = pickle.Unpickler(io.BytesIO(blob))
    unpickler.persistent_load = lambda number: shared[number]
    return unpickler.load()


def _pristine(result):
    """The cache's copy: its own figures and warnings (the plan, the fit-up and the shop write
    into a result's afterwards), and its owed work's own part as evaluated. Evaluated in this
    process, that part is the plan's, which a fit-up later moves (``hull.follow``, ``held``,
    ``plane``, ``result``): a plan made again (:mod:`pipeline.hull.replan`) that asks for the
    same plate would have its work done on the moved one. A shallow copy of the part and its
    hull keeps the seam curves (and what the evaluation cached on them)."""
    work = result.shop_work
    if work is not None and work.part is not None and getattr(work.part, "hull", None) is not None:
        part = copy.copy(work.part)
        part.hull = copy.copy(part.hull)
        work = replace(work, part=part)
    return replace(result, figures=_copied(result.figures), warnings=list(result.warnings), shop_work=work)


def _copied(figures: dict) -> dict:
    """A deep copy of a result's figures (plain data: nested dicts, lists, numbers, strings,
    arrays) through pickle, several times faster than copy.deepcopy on them (KCS's plan:
    3.9 s of the parent's serial time for 2000 copies)."""
    import pickle

    return pickle.loads(pickle.dumps(figures, protocol=pickle.HIGHEST_PROTOCOL))


def _renamed(result, part):
    """A cached result for ``part`` (the same geometry, maybe another name)."""
    old = result.name
    out = replace(result, name=part.name, part=part, figures=_copied(result.figures),
                  warnings=[w.replace(old, part.name) for w in result.warnings],
                  reason=result.reason.replace(old, part.name))
    return out


def preload_parts() -> None:
    """Import now the libraries every part's stages import on first use (trimesh, for the
    mesh figures; scipy.ndimage, which trimesh imports and no run uses, deferred): before
    workers are forked, each inherits them instead of importing them again (0.26 CPU s in
    each of the 160 m hull's plan workers, which were forked before :func:`pipeline.cli.preload`)."""
    from .lazymodules import defer

    defer("scipy.ndimage")  # imported by trimesh's voxels, which devflat does not use
    import trimesh.grouping  # noqa: F401 - every part's mesh figures (pipeline.stages)


def plate_evaluator(jobs: int = 1) -> PlateEvaluator:
    """The evaluator ``devflat run`` hands an adaptive plan: the lean plate run (class, fit,
    area; no shop data: the plates the plan keeps get theirs when they are run, from the
    geometry cached here, :mod:`pipeline.hull.plateshop`)."""
    from .hull.plates import evaluate_plate

    return PlateEvaluator(evaluate_plate, jobs)
