"""Command line: `devflat run CONFIG --out DIR`, `devflat check CONFIG`.

Exit codes: 0 every part written; 1 a geometric failure for at least one part;
2 bad configuration or input (message names file, field and value; no traceback
without --debug). ``main`` is the only place that decides the exit code.

This module imports nothing heavy at its top: ``entry_point`` pauses the garbage collector
before the first library is imported (see there). Each command imports what it needs.
"""

from __future__ import annotations

import argparse
import gc
import os
import signal
import sys
import traceback
from pathlib import Path
from typing import TYPE_CHECKING

from .validate import check_jobs, validate

if TYPE_CHECKING:
    from .config import RunConfig

EXIT_OK, EXIT_GEOMETRY, EXIT_INPUT = 0, 1, 2  # interrupted: 128 + the signal, as shells report it


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled like Ctrl-C: the same clean-up on the way out."""

    signum = signal.SIGTERM


def _terminated(signum, frame):
    raise Terminated()


class _Version(argparse.Action):
    """``--version``: the installed distribution's version, looked up only when asked for
    (importlib.metadata is not free at start-up)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from importlib.metadata import PackageNotFoundError, version

        try:
            number = version("devflat")
        except PackageNotFoundError:  # run from a source tree that was never installed
            number = "unknown (not installed)"
        parser.exit(message=f"devflat {number}\n")


class _Configs(argparse.Action):
    """``run``'s configurations: ``config`` the first (what a single run reads), ``configs``
    all of them (a batch, :mod:`pipeline.batch`)."""

    def __call__(self, parser, namespace, values, option_string=None):
        namespace.config, namespace.configs = values[0], list(values)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="devflat", description="Developable strips from two NURBS curves, "
                                     "unrolled into DXF cutting patterns.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    parser.add_argument("--version", action=_Version, help="print devflat's version and exit")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run every part of a configuration and write the files")
    run.add_argument("config", type=Path, nargs="+", action=_Configs, help="one configuration, or several: a "
                     "batch, each written into DIR/<its file stem>/ (pipeline.batch)")
    run.add_argument("--out", type=Path, required=True, help="output folder (created if missing)")
    run.add_argument("--quiet", action="store_true", help="no progress bar, no summary table")
    run.add_argument("--jobs", type=int, default=1, help="parts run in parallel processes (default 1)")
    run.add_argument("--scheduler", help="run the parts on Dask distributed: tcp://host:port of a scheduler, "
                     "or local[:N] for a local cluster of N processes (pipeline.cluster)")
    run.add_argument("--scheduler-timeout", type=float, default=10.0,
                     help="seconds to wait for the scheduler and a worker (default 10)")
    check = sub.add_parser("check", help="validate a configuration without running it")
    check.add_argument("config", type=Path)
    nest = sub.add_parser("nest", help="run the parts and nest them (the config's nesting section): a fabric "
                          "marker or steel stock plates")
    nest.add_argument("config", type=Path)
    nest.add_argument("--out", type=Path, required=True, help="output folder (created if missing)")
    nest.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    nest.add_argument("--jobs", type=int, default=1, help="parts run in parallel processes (default 1)")
    nest.add_argument("--time", type=int, help="nesting time budget in seconds (overrides nesting.time)")
    nest.add_argument("--seed", type=int, help="nesting seed (overrides nesting.seed)")
    nest.add_argument("--workers", type=int, help="engine threads (overrides nesting.workers)")
    nest.add_argument("--replay", type=Path, help="reproduce the layout stored in a NAME_nesting.json (checked again)")
    hull = sub.add_parser("hull", help="hull models of many faces (IGES, STEP, Rhino .3dm)")
    hull_sub = hull.add_subparsers(dest="hull_command", required=True)
    inspect = hull_sub.add_parser("inspect", help="sew a hull model's faces and report the shell: faces, areas, "
                                  "free edges, gaps, overlaps")
    inspect.add_argument("model", type=Path, help="IGES (.igs), STEP (.stp) or Rhino (.3dm) file")
    inspect.add_argument("--tolerance", type=float, default=1.0, help="sewing tolerance, mm (default 1)")
    inspect.add_argument("--gap-limit", type=float, default=50.0,
                         help="free edges within this distance of another face are gaps, mm (default 50)")
    inspect.add_argument("--json", action="store_true", help="print the report as JSON")
    for sub_parser in (run, check, nest, inspect):
        sub_parser.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show tracebacks")
    return parser


def command_run(args, early=None) -> int:
    """``devflat run``; ``early``: the render process :func:`early_renderer` started."""
    try:
        return _run(args, early)
    except BaseException:
        if early is not None:
            early.discard()  # no-op once the run took it over
        raise


def _run(args, early) -> int:
    from .export import export_summary, export_textile, printout_line, textile_pieces
    from .outdir import OutputError, OutputFolder, check_plan, run_name
    from .report import summary_table
    import time

    from .runner import guarded_export, plate_evaluator, run_parts, stage_line

    check_jobs(args.jobs)
    clock = (time.perf_counter(), time.process_time())
    evaluator = plate_evaluator(args.jobs)  # an adaptive plan's candidates: over the workers, cached
    config = validate(args.config, evaluator)
    planned = (time.perf_counter(), time.process_time())
    check_plan(config, args.out)
    parts = config.parts
    textile = config.spec.profile == "textile"
    progress = None
    try:
        # the render process (if any) is forked before any thread starts (tqdm's) and is
        # gone before the staging folder is removed
        with OutputFolder(args.out, config) as folder, render_process(args, config, early) as renderer:
            if args.one_shot:
                # with a render process, ezdxf too is imported when the first DXF is written:
                # after the part's previews are sent, while the render process draws them
                preload(config, images=renderer is None, dxf=renderer is None)
                imports_done()
            if len(parts) > 1 and not args.quiet:
                from tqdm import tqdm

                class Progress(tqdm):
                    monitor_interval = 0  # no monitor thread: the export forks a process of one thread

                progress = Progress(total=len(parts), unit="part", file=sys.stderr)
            # steel parts are written by whoever computes them; textile pieces are laid out
            # side by side first (their options are checked against every piece)
            keep_geometry = config.spec.output.png and len(parts) > 1
            # this process samples each hull plate's region for the summary as the plate comes
            # in, while its workers run the others (the summary's edges, else a serial second)
            sampled: dict = {}
            sample = None
            if not textile and any(p.hull is not None for p in parts):
                # imported before the parts run: a Ctrl-C that lands inside an import's
                # dataclass (built by exec) makes CPython end the process by SIGINT at its
                # exit, whatever the run returns (130 became -2, one run in ten)
                from .hull.expansion import shell_edges

                def sample(result):
                    sampled.update(shell_edges([result]))
            results = run_parts(config, None if textile else folder.staging, args.out, args.jobs, progress,
                                keep_geometry, sample)
            # the export's CPU counts the drawings' forked copy too (reaped within the stage)
            ran = (time.perf_counter(), time.process_time() + _children_cpu())
            if progress is not None:
                progress.close()
            printed: dict = {}  # the printouts' page counts, for the console
            if textile:
                pieces = textile_pieces(results, config)
                results = [guarded_export(r, config, folder.part_folder(k), args.out) for k, r in enumerate(results)]
                export_textile(pieces, config, folder.run_folder, run_name(config), printed)
            shell = None
            if textile:
                export_summary(results, config, folder.run_folder)  # waits for every image
            else:
                from .export import summary_drawing_jobs
                from .forked import beside_all
                from .hull.fitup import shell_fitup

                # the drawings are drawn by copies of this process (when it may fork), one per
                # free core, while this one computes the fit-up (none needs another); this one
                # draws those no copy has started once its summary waits for them
                edges = {r.name: sampled[r.name] for r in results if r.name in sampled}
                with beside_all(summary_drawing_jobs(results, config, folder.run_folder, edges)) as drawn:
                    shell = shell_fitup(results, config)  # None unless the run has hull plates
                    export_summary(results, config, folder.run_folder, shell, edges, drawn)  # waits for every image
            # what the commit moves in: every staged file (it refuses a name the plan lacks)
            n_files = sum(1 for path in folder.staging.rglob("*") if path.is_file())
            folder.commit([r.name for r in results])
            exported = (time.perf_counter(), time.process_time() + _children_cpu())
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(f"--out {args.out}: cannot write the results: {exc.strerror or exc}") from None
    if args.debug:
        for result in results:
            if "traceback" in result.figures:
                print(f"part {result.name}:\n{result.figures['traceback']}", file=sys.stderr)
    if not args.quiet:
        print(summary_table(results))
        if textile and printout_line(printed, run_name(config)):
            print(printout_line(printed, run_name(config)))
        if config.plan_cost is not None:
            from .hull.cost import plan_line, stock_min_width

            print(plan_line(config.plan_cost, stock_min_width(config.spec), config.mm_per_unit))
        if shell is not None:
            print(shell.one_line())
        for done in (config.fitup_repair, config.fitup_follow, getattr(config, "replan", None)):
            if done is not None:
                print(done.one_line())
        print(stage_line(_stages(evaluator, clock, planned, ran, exported, results, config)))
        print(wrote_line(n_files, args.out, run_name(config)))
    return EXIT_OK if all(r.ok for r in results) else EXIT_GEOMETRY


def _children_cpu() -> float:
    """CPU seconds of this process's reaped children."""
    times = os.times()
    return times.children_user + times.children_system


def _stages(evaluator, clock, planned, ran, exported, results, config: RunConfig) -> dict:
    """{stage: (wall s, CPU s)}: the plan's own geometry, the fit-up that moves its plates to
    meet (``strake.fit_up`` follow or repair; the plates it has evaluated again count under
    the evaluation), its candidates' evaluation (workers' CPU included), the final plates
    (their run and, in the same workers, their shop files) and the run's export (the shell's
    fit-up measures, plan cost, expansion drawing, summary, commit)."""
    per_part = [r.figures.get("stage_seconds") or {} for r in results]
    cpu_plates = sum(p.get("plates_cpu", 0.0) + p.get("shop_cpu", 0.0) for p in per_part)
    wall_plan = planned[0] - clock[0] - evaluator.seconds
    cpu_plan = planned[1] - clock[1] - evaluator.local_cpu_seconds + evaluator.mapped_cpu_seconds
    fitup = config.fitup_seconds
    stages = {"plan": (wall_plan - fitup[0], cpu_plan - fitup[1]) if fitup else (wall_plan, cpu_plan)}
    if fitup:
        stages["fit-up"] = fitup
    if evaluator.requested:
        stages[f"evaluate {evaluator.computed} plates ({evaluator.requested - evaluator.computed} cached)"] = \
            (evaluator.seconds, evaluator.cpu_seconds)
    stages["plates + shop files"] = (ran[0] - planned[0], cpu_plates)
    stages["export"] = (exported[0] - ran[0], exported[1] - ran[1])
    return stages


def image_modules(config: RunConfig, warm: bool = False) -> tuple[str, ...]:
    """What the run's images need ("module" or "module:function" to call): matplotlib's
    Agg canvas for PNG previews, its PDF backend for shop drawings; () for none. ``warm``:
    a first drawing of each kind too (a render process makes it while it waits)."""
    out = config.spec.output
    return _image_modules(config.spec.profile, out.png, out.dxf, out.drawing, warm)


def _image_modules(profile: str, png: bool, dxf: bool, drawing: bool | None, warm: bool) -> tuple[str, ...]:
    """:func:`image_modules` from the output settings (the validated ones, or a raw file's)."""
    drawings = profile == "steel" and dxf and (png if drawing is None else drawing)
    previews_need = "pipeline.plots:warm_up" if warm else "pipeline.plots"
    drawings_need = "pipeline.shop.drawing:warm_up" if warm else "pipeline.lazymodules:pdf_backend"
    return ((previews_need,) if png else ()) + ((drawings_need,) if drawings else ())


def render_process(args, config: RunConfig, early=None):
    """A :class:`pipeline.renderproc.Renderer` for a one-shot run whose parts run in this
    process and that writes images (a second core draws them; :mod:`pipeline.renderproc`),
    else a context that does nothing. Textile runs draw in place (their pieces are laid
    out after all parts ran); so do systems other than Linux (fork without exec is unsafe
    on macOS, absent on Windows). ``early``: the process :func:`early_renderer` started,
    taken over when the run wants one (its preloads are a hint: a module it lacks is
    imported by its first job), else ended."""
    import contextlib

    from .runner import worker_count

    modules = image_modules(config, warm=True)
    if (args.one_shot and modules and sys.platform.startswith("linux") and config.spec.profile == "steel"
            and worker_count(args.jobs, len(config.parts)) == 1 and (early is not None or spare_core())):
        from .renderproc import Renderer

        return early if early is not None else Renderer(modules)
    if early is not None:
        early.discard()
    return contextlib.nullcontext()


def early_renderer(args):
    """A render process started before the configuration is validated, so that it imports
    matplotlib while the run validates (about a third of a one-shot run's time); None when
    the run will not want one: not one-shot, not Linux, ``--jobs`` above 1, no core free,
    or the file's raw YAML (read without validation; unreadable: None) asks for no PNG
    previews or is a textile run. The validated configuration has the last word
    (:func:`render_process`). numpy is imported first: both processes use it."""
    if not (args.one_shot and sys.platform.startswith("linux") and args.jobs == 1 and spare_core()):
        return None
    import yaml

    try:
        with open(args.config, encoding="utf-8") as stream:
            raw = yaml.safe_load(stream)
        output = raw.get("output") or {}
        profile = raw.get("profile", "steel")
        previews = output.get("png", True) is not False  # the defaults of pipeline.config.Output
        drawing = output.get("drawing")
        modules = _image_modules(profile, previews, output.get("dxf", True) is not False,
                                 None if drawing is None else drawing is not False, warm=True)
    except Exception:  # noqa: BLE001 - anything unexpected is for validation to name
        return None
    if profile != "steel" or not previews:
        return None
    import numpy  # noqa: F401

    from .renderproc import Renderer

    return Renderer(modules).start()


def spare_core(loadavg: str = "/proc/loadavg") -> bool:
    """Whether a core is free for the render process now: fewer tasks of other processes are
    runnable than there are cores less one. On Linux the count is the kernel's number of
    tasks runnable at this instant (``loadavg``'s fourth field) less this process's own
    running threads (a library's worker threads spin at its start: OpenBLAS's unless told
    one thread), the least of three readings a millisecond apart: a CPU-bound task is
    runnable at each, one passing by is not counted. Elsewhere the last minute's load
    average decides; it is not used on Linux because it remembers the minute: a run started
    within a minute of another on a 2-core machine found the average above 1 and drew its
    images in place (bench/bench_cli.py's own rounds: 1.3-1.5 s against 0.9 s). The second
    process pays for itself only on a free core: it costs 0.1-0.2 s CPU (pages the fork
    shares and either process then writes are copied; the images' arguments are pickled),
    and on a machine whose cores are all busy it measured slower in wall time too."""
    from .cores import free_cores, usable_cores

    free = free_cores(loadavg)
    if free is None:
        return os.getloadavg()[0] <= usable_cores() - 1
    return free >= 1


def preload(config: RunConfig, images: bool = True, dxf: bool = True) -> None:
    """Import now the libraries the run's outputs need, which their stages would import
    on first use anyway: in a one-shot process this is still its start (see
    :func:`entry_point`), and worker processes forked later inherit them. Nothing that
    the configuration does not ask for: ezdxf only for steel DXFs, matplotlib only for
    images (``images``: drawn in this process); ezdxf not before it is needed when not
    ``dxf``."""
    import importlib

    from .runner import preload_parts

    preload_parts()

    out = config.spec.output
    if config.spec.profile == "steel" and out.dxf and dxf:
        from .shop import dxf, plate  # noqa: F401
    for name in image_modules(config) if images else ():
        module, _, function = name.partition(":")
        loaded = importlib.import_module(module)
        if function:
            getattr(loaded, function)()


def wrote_line(n_files: int, out: Path, run: str) -> str:
    """The run's last line: where the files went and where the summary is."""
    folder = str(out).rstrip("/\\") + "/"
    return f"wrote {n_files} file{'s' if n_files != 1 else ''} to {folder} (summary: {folder}{run}_summary.json)"


def command_check(args) -> int:
    config = validate(args.config)
    print(f"{args.config}: valid, {len(config.parts)} part(s): " + ", ".join(p.name for p in config.parts))
    return EXIT_OK


def command_hull_inspect(args) -> int:
    """``devflat hull inspect MODEL``: the shell the model's faces make when sewn."""
    import json

    from .config import ConfigError
    from .hull.sewing import sew_report
    from .io.hullmodel import read_hull_model

    for name, value, least in (("--tolerance", args.tolerance, 0.0), ("--gap-limit", args.gap_limit, args.tolerance)):
        if not value > least:
            raise ConfigError(f"{name} {value}: must be > {least:g} mm")
    report = sew_report(read_hull_model(args.model), args.tolerance, args.gap_limit)
    print(json.dumps(report.as_dict(), indent=1) if args.json else "\n".join(report.lines()))
    return EXIT_OK


def main(argv: list[str] | None = None, *, one_shot: bool = False) -> int:
    """Run one command; returns the exit code. ``one_shot``: this process runs nothing else
    and :func:`entry_point` paused the garbage collector for the imports; the commands
    that make garbage resume it (:func:`imports_done`)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse already printed its message
        return EXIT_INPUT if exc.code else EXIT_OK
    args.one_shot = one_shot
    if args.command == "run" and (len(args.configs) > 1 or args.scheduler is not None):
        args.command = "batch"  # several configurations or a Dask scheduler: pipeline.batch
    from .lazymodules import defer_unused

    defer_unused()
    # before anything heavy is imported: the render process imports matplotlib meanwhile
    early = early_renderer(args) if args.command == "run" else None
    from flatten.errors import DevflatError

    from .config import ConfigError

    previous_term = signal.signal(signal.SIGTERM, _terminated)
    try:
        if args.command == "run":
            return command_run(args, early)
        if args.command == "batch":
            from .batch import command_batch

            if one_shot:
                imports_done()
            return command_batch(args, wrote_line)
        if args.command == "nest":
            from .nest.command import command_nest

            if one_shot:
                imports_done()
            return command_nest(args)
        if args.command == "hull":
            return command_hull_inspect(args)
        return command_check(args)
    except (ConfigError, DevflatError) as exc:
        if args.debug:
            traceback.print_exc()
        print(f"devflat: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt as exc:
        print(f"devflat: interrupted ({signal.Signals(getattr(exc, 'signum', signal.SIGINT)).name})",
              file=sys.stderr)
        return 128 + getattr(exc, "signum", signal.SIGINT)
    except Exception as exc:  # noqa: BLE001 - a bug outside any part: one line, not a traceback
        if args.debug:
            traceback.print_exc()
        print(f"devflat: internal error: {type(exc).__name__}: {exc} (--debug shows the traceback)", file=sys.stderr)
        return EXIT_GEOMETRY
    finally:
        signal.signal(signal.SIGTERM, previous_term)


def imports_done() -> None:
    """End of a one-shot process's start: what the imports made (hundreds of thousands of
    objects: pydantic's models, matplotlib, ezdxf, trimesh, scipy; they live until the
    exit) is moved out of the collector's sight (``gc.freeze``), and the collector resumes
    for the work, which makes garbage (matplotlib's figures are reference cycles). Every
    later full collection is then a walk over the run's objects only."""
    gc.freeze()
    gc.enable()


def entry_point() -> None:
    """The ``devflat`` program (``python -m pipeline`` too): :func:`main`, in a process of
    its own.

    The cyclic garbage collector is paused from the start: imports create long-lived
    objects by the hundred thousand and hardly any garbage, and each collection during
    them would walk all of them again (a tenth of ``check``'s time beyond the bare
    numpy/scipy import). At the exit everything is frozen (``gc.freeze``): the
    interpreter's last collections would walk every object of the process to free memory
    the operating system takes back anyway (about 0.1 s for ``check``, 0.3 s for a ``run``
    with previews, measured by bench/bench_cli.py). Files are closed and the atexit
    handlers run as usual."""
    sys.exit(run_program())


def run_program(argv: list[str] | None = None) -> int:
    """:func:`entry_point` without the exit: the program's process settings
    (:func:`library_threads`), then :func:`main` as a one-shot process."""
    library_threads()
    gc.disable()
    code = main(argv, one_shot=True)
    gc.freeze()
    return code


def library_threads() -> None:
    """Set before numpy and libigl load: BLAS and libigl run on one thread unless the
    environment says otherwise (``OPENBLAS_NUM_THREADS`` / ``OMP_NUM_THREADS``, read when numpy loads, and
    ``IGL_NUM_THREADS``, read at libigl's first parallel loop; both later): devflat's
    matrices and meshes are small, and parallelism comes from ``--jobs``. On a machine
    whose cores are all busy (``--jobs``, the render process) OpenBLAS's threads spin
    beside the work (they busy-wait after each call), and libigl's loops wait for threads
    that wait for a core: a strake worker spent 15 % of its plates' time off the CPU."""
    if "OPENBLAS_NUM_THREADS" not in os.environ and "OMP_NUM_THREADS" not in os.environ:
        os.environ["OPENBLAS_NUM_THREADS"] = "1"
    os.environ.setdefault("IGL_NUM_THREADS", "1")
