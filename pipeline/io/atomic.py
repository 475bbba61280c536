"""Files written whole or not at all: a temp file in the target folder, then a rename.

The temp file is created as an ordinary ``open()`` creates a file (mode 0666, which the
kernel reduces by the umask or the folder's default ACL), so that the rename gives the
target the mode a plain write would have (``mkstemp`` creates it 0600).
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

_TRIES = 100  # names tried before giving up (each a fresh 48-bit random name)


def _new_temp(target: Path) -> Path:
    """A new empty file ``.NAME.XXXXXXXXXXXX.tmp`` beside target (O_EXCL: never one that exists)."""
    for _ in range(_TRIES):
        tmp = target.parent / f".{target.name}.{os.urandom(6).hex()}.tmp"
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return tmp
    raise FileExistsError(f"{target.parent}: no free temporary name for {target.name} in {_TRIES} tries")


@contextmanager
def atomic_path(target: str | Path):
    """Yield a temporary path next to ``target``; on success rename it onto ``target``,
    on any exception remove it and leave ``target`` untouched."""
    target = Path(target)
    tmp = _new_temp(target)
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_text(target: str | Path, text: str) -> None:
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")
