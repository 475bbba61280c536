"""Parts on Dask distributed workers: ``--scheduler tcp://host:port`` (a running scheduler)
or ``--scheduler local[:N]`` (a LocalCluster of N worker processes on this machine).

Workers compute; only this process (the coordinator) writes into the output folder, through
its transaction (:class:`pipeline.outdir.OutputFolder`). A steel part's worker runs the same
:func:`pipeline.runner.process_part` as a ``--jobs`` worker, into a private temporary folder
of its own, and sends back the part's slimmed result and the bytes of its files; the
coordinator puts those bytes into the staging folder. So the files are those ``--jobs``
writes, byte for byte, and the exports (DXF, drawing, OBJ, report: most of a hull plate's
time) run on the workers too. A textile part's worker sends back the whole result (textile
pieces are laid out side by side before any is written, as with ``--jobs``).

An unexpected exception in a part fails that part (the guard runs on the worker); a part
that kills its worker repeatedly (Dask retries it on another one, then gives up:
``KilledWorker``) fails alone, its report written by the coordinator. A scheduler that
cannot be reached, has no workers, or whose workers cannot run devflat is a
:class:`ClusterError` (exit 2, nothing written).

Results are byte-identical to ``--jobs`` when the workers run the same devflat and
libraries on the same kind of machine (a LocalCluster always does; remote workers should be
installed from the same lock file). ``dask`` and ``distributed`` are imported only here, only
when a run asks for a scheduler.
"""

from __future__ import annotations

import os
import re
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from flatten.errors import DevflatError

from .config import ConfigError, RunConfig
from .outdir import OutputError
from .runner import failed_result, guarded_export, process_part, slim, worker_count
from .stages import PartResult

MAX_LOCAL_WORKERS = 64
_ADDRESS = re.compile(r"^(tcp|tls)://[^\s/:]+:\d{1,5}$")


class ClusterError(DevflatError, ConnectionError):
    """The Dask scheduler or its workers cannot run the parts (the message names the address)."""


@dataclass(frozen=True)
class Scheduler:
    """Where the parts run: ``address`` of a running scheduler, or a local cluster of
    ``workers`` processes (None: one per CPU this process may use)."""

    spec: str
    address: str | None = None
    workers: int | None = None

    @property
    def local(self) -> bool:
        return self.address is None


def parse_scheduler(spec: str) -> Scheduler:
    """``tcp://host:port``, ``tls://host:port``, ``local`` or ``local:N``; ConfigError else."""
    text = spec.strip()
    if text == "local":
        return Scheduler(spec)
    if text.startswith("local:"):
        count = text[len("local:"):]
        if not count.isdigit() or not 1 <= int(count) <= MAX_LOCAL_WORKERS:
            raise ConfigError(f"--scheduler {spec}: give local:N with N worker processes from 1 to "
                              f"{MAX_LOCAL_WORKERS}")
        return Scheduler(spec, workers=int(count))
    if _ADDRESS.match(text) and 0 < int(text.rsplit(":", 1)[1]) < 65536:
        return Scheduler(spec, address=text)
    raise ConfigError(f"--scheduler {spec}: give the address of a Dask scheduler (tcp://host:port) or "
                      "local[:N] for a local cluster of N processes")


def check_timeout(seconds: float) -> None:
    if not 0 < seconds <= 3600:
        raise ConfigError(f"--scheduler-timeout {seconds:g}: give seconds from above 0 to 3600")


@contextmanager
def connect(scheduler: Scheduler, timeout: float, n_parts: int | None = None):
    """A ``distributed.Client`` to the scheduler (a LocalCluster started for the run: at most
    one worker per part, when ``n_parts`` is known), closed on the way out whatever happened (a local cluster's
    workers are stopped with it). Raises :class:`ClusterError` when no worker is there
    within ``timeout`` seconds."""
    import logging

    import distributed

    quiet = logging.getLogger("distributed")
    level = quiet.level
    quiet.setLevel(logging.CRITICAL)  # its connection retries are ours to report, in one line
    cluster = client = None
    try:
        try:
            if scheduler.local:
                workers = scheduler.workers or worker_count(MAX_LOCAL_WORKERS, MAX_LOCAL_WORKERS)
                cluster = local_cluster(max(1, workers if n_parts is None else min(workers, n_parts)))
                client = distributed.Client(cluster, timeout=timeout, set_as_default=False)
            else:
                client = distributed.Client(scheduler.address, timeout=timeout, set_as_default=False)
            client.wait_for_workers(1, timeout=timeout)
            _check_workers(client, scheduler)
        except ClusterError:
            raise
        except (OSError, TimeoutError, RuntimeError) as exc:  # RuntimeError: a nanny that failed to start
            what = ("cannot start a local cluster" if scheduler.local else
                    f"no Dask scheduler with a worker answered within {timeout:g} s")
            raise ClusterError(f"--scheduler {scheduler.spec}: {what} ({type(exc).__name__}: {exc})") from None
        yield client
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
        quiet.setLevel(level)


def local_cluster(workers: int):
    """A ``distributed.LocalCluster`` of ``workers`` processes of one thread each, as devflat
    runs the parts: they ignore SIGINT (:func:`dask_setup`), and they run without the
    ``MALLOC_TRIM_THRESHOLD_`` that Dask's nanny sets for its workers by default: glibc then
    no longer adapts its mmap threshold, every large array is mapped and unmapped afresh,
    and a hull plate took 5-15 % more CPU (bench/README.md). Its dashboard on a free port."""
    import logging

    import dask
    import distributed

    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", default={}) or {})
    environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
        return distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                        dashboard_address=":0", silence_logs=logging.CRITICAL, preload=[__name__])


def dask_setup(worker) -> None:
    """Run by each process of a local cluster as it starts (``preload``; again when its
    nanny restarts it): it ignores SIGINT, like a ``--jobs`` worker (Ctrl-C reaches the whole
    process group; this process decides and stops the cluster)."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _worker_versions() -> str:
    """Run on each worker: the devflat it imports (a worker without devflat cannot even
    unpickle this function)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("devflat")
    except PackageNotFoundError:
        return "unknown"


def _check_workers(client, scheduler: Scheduler) -> None:
    try:
        found = client.run(_worker_versions)
    except Exception as exc:  # noqa: BLE001 - whatever a worker raises here, it cannot run the parts
        raise ClusterError(f"--scheduler {scheduler.spec}: the workers cannot run devflat ({type(exc).__name__}: "
                           f"{exc}); install the same devflat on every worker") from None
    mine = _worker_versions()
    other = sorted({v for v in found.values() if v != mine})
    if other:
        raise ClusterError(f"--scheduler {scheduler.spec}: workers run devflat {', '.join(other)}, this process "
                           f"{mine}; install the same devflat on every worker")


@dataclass
class Batch:
    """One configuration's run on the cluster: its parts are written into ``staging``
    (``staging/part-NNNNNN/``; None: the whole results come back, textile) and named in
    messages by ``out``."""

    config: RunConfig
    staging: Path | None
    out: Path
    keep_geometry: bool = False


def cluster_part(config: RunConfig, index: int, out: Path, keep_geometry: bool, files: bool):
    """On a worker: part ``index`` of ``config``. ``files``: written into a temporary folder
    of this worker and returned as (slimmed result, {file name: bytes}); else (whole
    result, None)."""
    os.environ.setdefault("IGL_NUM_THREADS", "1")  # as the devflat program runs libigl (pipeline.cli)
    if not files:
        return process_part(index, config, None, out, keep_geometry), None
    # in the worker's own folder: Dask removes it with the worker, and a worker killed on
    # this part leaves it to the next worker's start, which purges dead workers' folders
    with tempfile.TemporaryDirectory(prefix="devflat-part-", dir=_worker_directory()) as tmp:
        result = process_part(index, config, Path(tmp), out, keep_geometry)
        folder = Path(tmp) / f"part-{index:06d}"
        return result, {path.name: path.read_bytes() for path in sorted(folder.iterdir())}


def _worker_directory() -> str | None:
    """The Dask worker's local directory, or None (the system's temporary folder) outside one."""
    from distributed import get_worker

    try:
        return get_worker().local_directory
    except ValueError:  # not on a worker
        return None


def put_files(folder: Path, files: dict[str, bytes], out: Path, name: str) -> None:
    """Write a part's files, as a worker sent them, into its staging folder."""
    try:
        folder.mkdir(exist_ok=True)
        for file, data in files.items():
            if Path(file).name != file or file.startswith("."):
                raise OSError(f"a worker sent the file name {file!r}")
            (folder / file).write_bytes(data)
    except OSError as exc:
        raise OutputError(f"--out {out}: cannot write the files of part {name}: {exc.strerror or exc}") from None


def _given(value):
    return value


def run_on_cluster(client, batches: list[Batch], progress=None, spec: str = "") -> list[list[PartResult]]:
    """Every part of every batch on the cluster, all submitted at once (the cluster is kept
    busy across configurations); each part's files go into its batch's staging folder as
    soon as they arrive. Returns the results per batch, in the order of its parts.

    When a worker dies, Dask runs its parts again elsewhere and gives up on a part whose
    workers died too often (``KilledWorker``); the parts that were merely beside it on a
    dying worker get the blame too. Those parts are run again one at a time once the
    others are done, so that the part a worker dies on fails alone (as ``--jobs`` does)."""
    from distributed import as_completed
    from distributed.scheduler import KilledWorker

    results: list[list[PartResult | None]] = [[None] * len(b.config.parts) for b in batches]
    # each configuration sent once, as a task that returns it (not scattered: a scattered
    # value is lost with the workers that held it; a task's result is computed again)
    configs = [client.submit(_given, batch.config, pure=False) for batch in batches]

    def submit(k: int, index: int):
        batch = batches[k]
        return client.submit(cluster_part, configs[k], index, batch.out, batch.keep_geometry,
                             batch.staging is not None, pure=False)

    def receive(k: int, index: int, future, alone: bool) -> bool:
        """Stage the part's files and record its result; False: its worker died and it
        was not run alone (it is run again)."""
        batch = batches[k]
        part = batch.config.parts[index]
        folder = None if batch.staging is None else batch.staging / f"part-{index:06d}"
        try:
            result, files = future.result()
        except KilledWorker as exc:
            if not alone:
                return False
            result, files = failed_result(part, exc, "computing the part (its worker process died)"), None
            if folder is not None:
                result = slim(guarded_export(result, batch.config, folder, batch.out), batch.keep_geometry)
        except OutputError as exc:
            raise ClusterError(f"--scheduler {spec}: a worker cannot write part {part.name}'s files into its "
                               f"temporary folder: {exc}") from None
        except Exception as exc:  # noqa: BLE001 - not a part's failure: the guard runs on the worker
            raise ClusterError(f"--scheduler {spec}: part {part.name} did not come back from the cluster "
                               f"({type(exc).__name__}: {exc})") from None
        if files is not None:
            put_files(folder, files, batch.out, part.name)
        result.part = part
        results[k][index] = result
        if progress is not None:
            progress.set_postfix_str(result.name)
            progress.update()
        return True

    # a future dropped (popped, out of scope) lets the cluster forget the part's result
    futures = {submit(k, index): (k, index) for k, batch in enumerate(batches)
               for index in range(len(batch.config.parts))}
    again = []
    try:
        for future in as_completed(list(futures), loop=client.loop):
            k, index = futures.pop(future)
            if not receive(k, index, future, alone=False):
                again.append((k, index))
        for k, index in sorted(again):
            future = submit(k, index)
            futures[future] = (k, index)
            receive(k, index, future, alone=True)
            futures.pop(future)
    finally:
        if futures:  # interrupted: what is still queued or running
            client.cancel(list(futures))
    return results
