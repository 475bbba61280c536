"""``devflat run A.yaml B.yaml ... --out DIR`` and runs on a Dask scheduler (``--scheduler``).

A batch writes each configuration's files into ``DIR/<config file stem>/``; a single
configuration writes into ``DIR`` itself, as ``devflat run CONFIG`` always did (the program
runs a single configuration without ``--scheduler`` in :mod:`pipeline.cli`, unchanged;
this module runs the others). Every configuration is validated and its files planned
before anything is computed or written: a bad one (or two with the same stem) exits 2
naming it, and nothing is written. Then each output folder is locked and staged as one
transaction (:class:`pipeline.outdir.OutputFolder`), all parts run (with ``--jobs`` one
configuration after the other; on a scheduler all at once), and the folders are committed
one after the other once every part of every configuration is done.
"""

from __future__ import annotations

import sys
from contextlib import ExitStack
from pathlib import Path

from flatten.errors import DevflatError

from .config import ConfigError, RunConfig
from .validate import check_jobs, validate


def batch_folders(configs: list[Path], out: Path) -> list[tuple[Path, Path]]:
    """(config, its output folder) for each configuration: ``out`` itself for one,
    ``out/<stem>`` for several; two configurations of the same stem are refused."""
    if len(configs) == 1:
        return [(configs[0], out)]
    seen: dict[str, Path] = {}
    for path in configs:
        stem = path.stem
        if stem in seen and seen[stem].resolve() == path.resolve():
            raise ConfigError(f"{path}: given twice")
        if stem in seen:
            raise ConfigError(f"{path}: {seen[stem]} and {path} would both write into {out / stem}; "
                              "give configurations of different file names")
        if stem.startswith("."):
            raise ConfigError(f"{path}: a configuration in a batch needs a name that is not hidden ({stem})")
        seen[stem] = path
    return [(path, out / path.stem) for path in configs]


def validate_all(configs: list[Path], out: Path, evaluator=None) -> list[tuple[RunConfig, Path]]:
    """Each configuration validated and its files planned (ConfigError names the file).
    ``evaluator``: the adaptive plans' plate evaluator, one for every configuration
    (:func:`pipeline.runner.plate_evaluator`; None: each plate run in turn, uncached)."""
    from .outdir import check_plan

    if evaluator is None:
        from .hull.plates import evaluate_plate as evaluator

    checked = []
    for path, folder in batch_folders(configs, out):
        config = validate(path, evaluator)
        check_plan(config, folder)
        checked.append((config, folder))
    return checked


def command_batch(args, wrote_line) -> int:
    """Run ``args.configs`` (a list of paths) into ``args.out``; ``wrote_line(n_files, out,
    run)`` is the run's last line (:func:`pipeline.cli.wrote_line`). Exit code: 0 every part
    of every configuration written, 1 a part failed geometrically."""
    from .outdir import OutputError, OutputFolder, run_name
    from .report import summary_table

    check_jobs(args.jobs)
    scheduler = None
    if args.scheduler is not None:
        from .cluster import check_timeout, parse_scheduler

        scheduler = parse_scheduler(args.scheduler)
        check_timeout(args.scheduler_timeout)
        if args.jobs != 1:
            raise ConfigError(f"--jobs {args.jobs} --scheduler {args.scheduler}: the scheduler's workers run the "
                              "parts; give one of the two")
    progress = None
    try:
        with ExitStack() as stack:
            client = None
            if scheduler is not None:  # reached (or started) before anything is planned or written
                from .cluster import connect

                client = stack.enter_context(connect(scheduler, args.scheduler_timeout))
            checked = _plans(args, client)
            n_parts = sum(len(config.parts) for config, _ in checked)
            folders = [stack.enter_context(OutputFolder(out, config)) for config, out in checked]
            if n_parts > 1 and not args.quiet:
                from tqdm import tqdm

                progress = stack.enter_context(tqdm(total=n_parts, unit="part", file=sys.stderr))
            every = _run_parts(checked, folders, args.jobs, client, progress, scheduler)
            if progress is not None:
                progress.close()
            written = []
            for (config, out), folder, results in zip(checked, folders, every):
                written.append((results, _finish(results, config, folder, out)))
            for (config, out), folder, (results, _) in zip(checked, folders, written):
                folder.commit([r.name for r in results])
    except DevflatError:  # an output fault, a cluster that cannot run the parts: named already
        raise
    except OSError as exc:
        raise OutputError(f"--out {args.out}: cannot write the results: {exc.strerror or exc}") from None
    if args.debug:
        for results, _ in written:
            for result in results:
                if "traceback" in result.figures:
                    print(f"part {result.name}:\n{result.figures['traceback']}", file=sys.stderr)
    if not args.quiet:
        for (config, out), (results, n_files) in zip(checked, written):
            if len(checked) > 1:
                print(f"{config.source}:")
            print(summary_table(results))
            print(wrote_line(n_files, out, run_name(config)))
    return 0 if all(r.ok for results, _ in written for r in results) else 1


def _plans(args, client) -> list[tuple[RunConfig, Path]]:
    """Every configuration validated and planned (:func:`validate_all`) with one plate
    evaluator: variants of one hull (other plans, stock, names) share the plates they ask for
    alike, whatever configuration asks first. The adaptive plans' candidates run on the
    cluster's workers (``client``), else on ``--jobs`` processes."""
    if client is not None:
        from .clusterplan import ClusterEvaluator

        evaluator = ClusterEvaluator(client)
    else:
        from .runner import plate_evaluator

        evaluator = plate_evaluator(args.jobs)
    with evaluator:
        checked = validate_all(args.configs, args.out, evaluator)
    if not args.quiet and evaluator.requested:
        print(f"plans: evaluate {evaluator.computed} plates ({evaluator.requested - evaluator.computed} cached) "
              f"{evaluator.seconds:.1f} s ({evaluator.cpu_seconds:.1f} CPU s)", file=sys.stderr)
    return checked


def _keep_geometry(config: RunConfig) -> bool:
    return config.spec.output.png and len(config.parts) > 1  # the summary images need the patterns


def _run_parts(checked, folders, jobs: int, client, progress, scheduler) -> list[list]:
    """Every configuration's results: on the cluster all at once, else one configuration
    after the other with ``--jobs`` processes."""
    textile = [config.spec.profile == "textile" for config, _ in checked]
    if client is not None:
        from .cluster import Batch, run_on_cluster

        batches = [Batch(config, None if tex else folder.staging, out, _keep_geometry(config))
                   for (config, out), folder, tex in zip(checked, folders, textile)]
        return run_on_cluster(client, batches, progress, scheduler.spec)
    from .runner import run_parts

    return [run_parts(config, None if tex else folder.staging, out, jobs, progress, _keep_geometry(config))
            for (config, out), folder, tex in zip(checked, folders, textile)]


def _finish(results, config: RunConfig, folder, out: Path) -> int:
    """A configuration's textile layout and run summary into its staging folder (as
    :mod:`pipeline.cli` does for one); returns the number of files staged."""
    from .export import export_summary, export_textile, textile_pieces
    from .outdir import run_name
    from .runner import guarded_export

    if config.spec.profile == "textile":
        pieces = textile_pieces(results, config)
        results[:] = [guarded_export(r, config, folder.part_folder(k), out) for k, r in enumerate(results)]
        export_textile(pieces, config, folder.run_folder, run_name(config))
    export_summary(results, config, folder.run_folder)
    return sum(1 for path in folder.staging.rglob("*") if path.is_file())
