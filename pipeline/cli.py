"""Command line: `devflat run CONFIG --out DIR`, `devflat check CONFIG`.

Exit codes: 0 every part written; 1 a geometric failure for at least one part;
2 bad configuration or input (message names file, field and value; no traceback
without --debug). ``main`` is the only place that decides the exit code.
"""

from __future__ import annotations

import argparse
import sys
import traceback
from pathlib import Path

from flatten.errors import DevflatError
from flatten.solver import check_pair
from flatten.tolerances import DEFAULT_TOLERANCES

from .config import ConfigError, RunConfig

EXIT_OK, EXIT_GEOMETRY, EXIT_INPUT = 0, 1, 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report it


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="devflat", description="Developable strips from two NURBS curves, "
                                     "unrolled into DXF cutting patterns.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run every part of a configuration and write the files")
    run.add_argument("config", type=Path)
    run.add_argument("--out", type=Path, required=True, help="output folder (created if missing)")
    run.add_argument("--quiet", action="store_true", help="no progress bar, no summary table")
    run.add_argument("--jobs", type=int, default=1, help="parts run in parallel processes (default 1)")
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
    for sub_parser in (run, check, nest):
        sub_parser.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show tracebacks")
    return parser


def validate(path: Path, evaluate=None) -> RunConfig:
    """Load the config, plan its plates and check each part's curve pair (coincident curves
    are bad input)."""
    from .plan import load_run

    config = load_run(path, evaluate)
    for part in config.parts:
        if part.hull is not None and not part.hull.developable:
            continue  # no strip is tried between these seams (e.g. an end plate)
        try:
            check_pair(part.c, part.d, DEFAULT_TOLERANCES)
        except DevflatError as exc:
            raise ConfigError(f"{path}: part {part.name}: {exc}") from None
    return config


MAX_JOBS = 64


def check_jobs(jobs: int) -> None:
    if not 1 <= jobs <= MAX_JOBS:
        raise ConfigError(f"--jobs {jobs}: give a number of processes from 1 to {MAX_JOBS}")


def command_run(args) -> int:
    from .export import export_part, export_summary, export_textile, textile_pieces
    from .plates import evaluate_plate, run_part
    from .report import summary_table

    check_jobs(args.jobs)
    config = validate(args.config, evaluate_plate)
    parts = config.parts
    progress = None
    if len(parts) > 1 and not args.quiet:
        from tqdm import tqdm
        progress = tqdm(total=len(parts), unit="part", file=sys.stderr)
    results = []
    if args.jobs > 1 and len(parts) > 1:
        from concurrent.futures import ProcessPoolExecutor
        from functools import partial

        with ProcessPoolExecutor(max_workers=args.jobs) as pool:
            for result in pool.map(partial(run_part, config=config), parts):
                results.append(result)
                if progress is not None:
                    progress.set_postfix_str(result.name)
                    progress.update()
    else:
        for part in parts:
            results.append(run_part(part, config))
            if progress is not None:
                progress.set_postfix_str(part.name)
                progress.update()
    # textile options are checked against the pieces before anything is written
    pieces = textile_pieces(results, config) if config.spec.profile == "textile" else []
    try:
        args.out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"--out {args.out}: cannot create the output folder: {exc}") from None
    for result in results:
        export_part(result, config, args.out)
    if pieces:
        export_textile(pieces, config, args.out, config.spec.name or config.source.stem)
    export_summary(results, config, args.out)
    if not args.quiet:
        print(summary_table(results))
    return EXIT_OK if all(r.ok for r in results) else EXIT_GEOMETRY


def command_check(args) -> int:
    config = validate(args.config)
    print(f"{args.config}: valid, {len(config.parts)} part(s): " + ", ".join(p.name for p in config.parts))
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse already printed its message
        return EXIT_INPUT if exc.code else EXIT_OK
    try:
        if args.command == "run":
            return command_run(args)
        if args.command == "nest":
            from .nesting_io import command_nest

            return command_nest(args, validate)
        return command_check(args)
    except (ConfigError, DevflatError) as exc:
        if args.debug:
            traceback.print_exc()
        print(f"devflat: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        print("devflat: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (MemoryError, RecursionError) as exc:
        # reading or checking the input exhausted a resource: the input is out of range
        if args.debug:
            traceback.print_exc()
        print(f"devflat: error: {args.config}: the input is too large to process ({type(exc).__name__})",
              file=sys.stderr)
        return EXIT_INPUT


def entry_point() -> None:
    sys.exit(main())
