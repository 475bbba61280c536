"""The output folder as a transaction.

A run holds a lock on ``--out`` (a second run on the same folder is refused), writes every
file into a hidden staging folder inside it (same file system: a rename moves a file in
whole), and only when every part is done moves each part's file set in. A part's files
from earlier runs that this run does not rewrite are removed, and so are the files of
parts an earlier run of the same name had and this one has not (a strake re-run with
fewer plates): the summary lists exactly the parts on disk. Within a part the old DXF goes
first and the new DXF comes last, after its JSON report, so that a DXF is never on disk
without the report of the same run, even if the run is killed while committing.

Planned file names are checked before anything runs: two outputs never share a name (a
part called like the summary) and no output would replace an input file.
"""

from __future__ import annotations

import errno
import json
import os
import re
import shutil
import tempfile
from pathlib import Path

from pydantic import BaseModel

from flatten.errors import DevflatError

from .config import NAME_PATTERN, ConfigError, RunConfig

LOCK_NAME = ".devflat.lock"
STAGING_PREFIX = ".devflat-staging-"
RUN_FOLDER = "run"

# every file a part or a run may write, by profile (DXF first: it is removed first)
PART_SUFFIXES = {"steel": (".dxf", "_P.dxf", "_S.dxf", "_templates.dxf", "_pinjig.csv", "_drawing.pdf", "_P_drawing.pdf", "_S_drawing.pdf", ".obj", "_flat.png", "_solutions.png", ".json"),
                 "textile": (".obj", "_flat.png", "_solutions.png", ".json")}
RUN_SUFFIXES = {"steel": ("_plan.dxf", "_expansion.dxf", "_expansion.pdf", "_expansion_tiles.pdf", "_sheet.png",
                          "_classes.png", "_hull.png", "_summary.csv", "_summary.json"),
                "textile": (".dxf", ".plt", "_plan.dxf", "_expansion.dxf", "_expansion.pdf", "_expansion_tiles.pdf",
                            "_print.pdf", "_print.svg", "_roll.pdf", "_sheet.png", "_classes.png", "_hull.png",
                            "_summary.csv", "_summary.json")}


class OutputError(DevflatError, OSError):
    """The output folder cannot be used or written (message names the folder and the file)."""


def run_name(config: RunConfig) -> str:
    """The name of the run's own files (summary, sheet, textile DXF)."""
    return config.spec.name or config.source.stem


def part_files(name: str, profile: str) -> list[str]:
    return [name + suffix for suffix in PART_SUFFIXES[profile]]


def run_files(name: str, profile: str) -> list[str]:
    return [name + suffix for suffix in RUN_SUFFIXES[profile]]


def input_files(config: RunConfig) -> list[Path]:
    """The configuration and every file it reads (IGES, DXF), as given."""
    from .io.sources import source_path

    found = [config.source]

    def walk(value):
        if isinstance(value, (list, tuple)):
            for item in value:
                walk(item)
        elif isinstance(value, BaseModel):
            for key in ("iges", "dxf", "model"):
                name = getattr(value, key, None)
                if isinstance(name, str):
                    found.append(source_path(config.source.parent, name))
            for key in type(value).model_fields:
                walk(getattr(value, key))

    walk(config.spec)
    return found


def _identity(path: Path):
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino


def check_plan(config: RunConfig, out: Path) -> None:
    """Refuse (ConfigError) names that two outputs share and outputs that would replace an
    input file, before anything is computed."""
    profile = config.spec.profile
    owner: dict[str, str] = {}
    planned = [(f"part {p.name}", part_files(p.name, profile)) for p in config.parts]
    planned.append(("the run summary", run_files(run_name(config), profile)))
    for who, names in planned:
        for name in names:
            if name in owner and owner[name] != who:
                raise ConfigError(f"{config.source}: {who} and {owner[name]} would both write {out / name}; "
                                  "rename the part")
            owner[name] = who
    inputs = {_identity(p): p for p in input_files(config)}
    inputs.pop(None, None)
    for name, who in owner.items():
        same = inputs.get(_identity(out / name))
        if same is not None:
            raise ConfigError(f"--out {out}: {who} would overwrite the input file {same}; "
                              "choose another output folder")


def _lock(out: Path) -> int:
    """An exclusive lock on out/.devflat.lock (flock: released by the kernel when the process
    dies, so a killed run never leaves a stale lock). Returns the descriptor."""
    import fcntl

    path = out / LOCK_NAME
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 32).decode("ascii", "replace").strip() or "?"
            os.close(fd)
            raise OutputError(f"--out {out}: another devflat run (pid {holder}) is writing into this folder") \
                from None
        # a finishing run unlinks the lock file while holding it: lock the file on disk
        if _identity(path) == (os.fstat(fd).st_dev, os.fstat(fd).st_ino):
            os.ftruncate(fd, 0)
            os.write(fd, str(os.getpid()).encode())
            return fd
        os.close(fd)


def _remove(path: Path, inputs: set) -> None:
    if _identity(path) in inputs:
        return  # never an input, whatever its name
    try:
        path.unlink()
    except FileNotFoundError:
        pass


class OutputFolder:
    """``with OutputFolder(out, config) as folder:`` locks ``out``, gives ``folder.staging``
    and removes the staging folder and the lock on the way out, whatever happened.
    ``commit`` moves the staged files in."""

    def __init__(self, out: Path, config: RunConfig):
        self.out = Path(out)
        self.config = config
        self.staging: Path | None = None
        self._fd: int | None = None
        self._created: list[Path] = []  # folders this run made, removed again if it commits nothing
        self._committed = False

    def __enter__(self) -> "OutputFolder":
        out = self.out
        missing = out
        while not missing.exists() and missing != missing.parent:
            self._created.append(missing)
            missing = missing.parent
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"--out {out}: cannot create the output folder: {exc.strerror or exc}") from None
        if not out.is_dir():
            self._created = []
            raise OutputError(f"--out {out}: not a folder")
        try:
            self._fd = _lock(out)
            for old in out.glob(STAGING_PREFIX + "*"):  # left by a run that was killed
                shutil.rmtree(old, ignore_errors=True)
            self.staging = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=out))
            (self.staging / RUN_FOLDER).mkdir()
        except OutputError:
            raise
        except OSError as exc:
            self.__exit__()
            raise OutputError(f"--out {out}: cannot write into the output folder: {exc.strerror or exc}") from None
        return self

    def part_folder(self, index: int) -> Path:
        return self.staging / f"part-{index:06d}"

    @property
    def run_folder(self) -> Path:
        return self.staging / RUN_FOLDER

    def _release(self) -> None:
        if self._fd is not None:
            try:
                (self.out / LOCK_NAME).unlink()
            except OSError:
                pass
            os.close(self._fd)
            self._fd = None

    def __exit__(self, *exc) -> None:
        if self.staging is not None:
            shutil.rmtree(self.staging, ignore_errors=True)
            self.staging = None
        self._release()
        if not self._committed:  # a refused or interrupted run leaves no folder it made
            for folder in self._created:
                try:
                    folder.rmdir()
                except OSError:
                    break

    def _previous_parts(self, name: str) -> list[str]:
        """Part ids listed by the summary an earlier run of this name left (names checked:
        the file is input we did not write in this run)."""
        try:
            data = json.loads((self.out / f"{name}_summary.json").read_text(encoding="utf-8"))
            ids = [row["id"] for row in data["parts"]]
        except (OSError, ValueError, KeyError, TypeError):
            return []
        return [i for i in ids if isinstance(i, str) and re.match(NAME_PATTERN, i)]

    def commit(self, names: list[str]) -> None:
        """Move the staged files of the parts (``names[k]`` staged in ``part_folder(k)``)
        and of the run into ``out``; remove stale files. Raises OutputError."""
        profile = self.config.spec.profile
        run = run_name(self.config)
        inputs = {_identity(p) for p in input_files(self.config)} - {None}
        previous = self._previous_parts(run)
        self._committed = True
        try:
            for k, name in enumerate(names):
                self._commit_set(self.part_folder(k), part_files(name, profile), inputs)
            for name in set(previous) - set(names):
                for file in part_files(name, profile):
                    _remove(self.out / file, inputs)
            self._commit_set(self.run_folder, run_files(run, profile), inputs)
        except OSError as exc:
            raise OutputError(f"--out {self.out}: cannot move the results in: {exc}") from None

    def commit_files(self, folder: Path, names: list[str], stale: list[str]) -> None:
        """Move the files ``names`` staged in ``folder`` into ``out``; first remove the files
        ``stale`` (what an earlier run of the same command listed) that this run does not
        rewrite. For commands whose file names are known only after they ran (nesting).
        Raises OutputError."""
        inputs = {_identity(p) for p in input_files(self.config)} - {None}
        self._committed = True
        try:
            for name in stale:
                if name not in names and re.fullmatch(r"[A-Za-z0-9_.+-]+", name):
                    _remove(self.out / name, inputs)
            self._commit_set(folder, list(names), inputs)
        except OSError as exc:
            raise OutputError(f"--out {self.out}: cannot move the results in: {exc}") from None

    def _commit_set(self, folder: Path, candidates: list[str], inputs: set) -> None:
        """Stale files out (the old DXF first, whether or not a new one comes), then the new
        files in, the DXF after the JSON report."""
        new = {p.name for p in folder.iterdir()} if folder.is_dir() else set()
        for name in candidates:  # DXF first
            if name not in new or name.endswith(".dxf"):
                _remove(self.out / name, inputs)
        order = [n for n in candidates if not n.endswith(".dxf")] + [n for n in candidates if n.endswith(".dxf")]
        for name in order:
            if name in new:
                os.replace(folder / name, self.out / name)
        extra = new - set(candidates)
        if extra:  # an exporter wrote a name the plan does not know: a bug, never silently dropped
            raise OSError(errno.EINVAL, f"unplanned output files {sorted(extra)}")
