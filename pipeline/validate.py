"""Checks a run and ``devflat nest`` share before any work: the configuration loaded and
planned, every part's curve pair usable, the number of processes in range.

Below the commands (cli, nest) that call it; above the plan it loads. Imports nothing heavy
at its top: the one-shot run imports it before its libraries.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .config import RunConfig


def validate(path: Path, evaluate=None) -> RunConfig:
    """Load the config, plan its plates and check each part's curve pair (coincident curves
    are bad input)."""
    from flatten.errors import DevflatError
    from flatten.pair import check_pair
    from flatten.tolerances import DEFAULT_TOLERANCES

    from .config import ConfigError
    from .hull.plan import load_run

    try:
        config = load_run(path, evaluate)
        for part in config.parts:
            if part.hull is not None and not part.hull.developable:
                continue  # no strip is tried between these seams (e.g. an end plate)
            try:
                check_pair(part.c, part.d, DEFAULT_TOLERANCES)
            except DevflatError as exc:
                raise ConfigError(f"{path}: part {part.name}: {exc}") from None
    except (DevflatError, KeyboardInterrupt):
        raise
    except (MemoryError, RecursionError) as exc:  # the input exhausted a resource: out of range
        raise ConfigError(f"{path}: the input is too large to process ({type(exc).__name__})") from exc
    except Exception as exc:  # noqa: BLE001 - an input no check foresaw is still bad input, named
        raise ConfigError(f"{path}: cannot process the configuration: {type(exc).__name__}: {exc}") from exc
    return config


MAX_JOBS = 64


def check_jobs(jobs: int) -> None:
    from .config import ConfigError

    if not 1 <= jobs <= MAX_JOBS:
        raise ConfigError(f"--jobs {jobs}: give a number of processes from 1 to {MAX_JOBS}")
