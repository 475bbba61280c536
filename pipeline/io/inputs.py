"""Input files read within limits: regular files of bounded size, YAML of bounded depth
and expansion with unique keys.

A FIFO would block the reader for ever, /dev/zero would fill the memory, a YAML alias
bomb expands to billions of nodes from a few hundred bytes and deep nesting overflows
the C stack of libyaml's composer: each is refused here with a message naming the file
(and the line), before any parser sees it.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import yaml

from flatten.errors import DevflatError

# bytes per kind of input file; large offsets tables belong in IGES or DXF files
MAX_BYTES = {"configuration": 1 << 20, "IGES": 256 << 20, "DXF": 256 << 20}
MAX_YAML_DEPTH = 64
MAX_YAML_NODES = 1_000_000  # after expanding aliases

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


class InputFileError(DevflatError, ValueError):
    """An input file cannot be read within the limits (message names the file)."""


def _check_stat(st: os.stat_result, path: Path, kind: str) -> None:
    if not stat.S_ISREG(st.st_mode):
        what = next((text for test, text in _KINDS if test(st.st_mode)), "not a regular file")
        raise InputFileError(f"{path}: the {kind} file is {what}, not a regular file")
    limit = MAX_BYTES[kind]
    if st.st_size > limit:
        raise InputFileError(f"{path}: the {kind} file has {st.st_size} bytes, more than the limit of {limit}")


def check_input_file(path: str | Path, kind: str) -> Path:
    """Refuse what is not a regular file of at most ``MAX_BYTES[kind]`` bytes (for readers
    that open the file themselves); returns the path."""
    path = Path(path)
    try:
        st = os.stat(path)  # follows symlinks: a loop is ELOOP here
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read the {kind} file: {exc.strerror or exc}") from None
    _check_stat(st, path, kind)
    return path


def read_input_file(path: str | Path, kind: str) -> bytes:
    """The bytes of a regular file of at most ``MAX_BYTES[kind]`` bytes."""
    path = Path(path)
    try:
        # O_NONBLOCK: opening a FIFO without a writer must not block before the check
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read the {kind} file: {exc.strerror or exc}") from None
    try:
        _check_stat(os.fstat(fd), path, kind)
        chunks, size = [], 0
        while size <= MAX_BYTES[kind]:
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        data = b"".join(chunks)
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read the {kind} file: {exc.strerror or exc}") from None
    finally:
        os.close(fd)
    if len(data) > MAX_BYTES[kind]:  # grew while we read it
        raise InputFileError(f"{path}: the {kind} file is larger than the limit of {MAX_BYTES[kind]} bytes")
    return data


class YamlLimitError(DevflatError, ValueError):
    """A YAML document exceeds a limit or repeats a key; ``line`` is 1-based or None."""

    def __init__(self, message: str, line: int | None = None):
        super().__init__(message)
        self.line = line


_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _check_events(text: str) -> None:
    """Depth and expanded node count from the event stream (libyaml's parser keeps its own
    stack, so this pass is safe on any input; composing is not)."""
    try:
        _check_event_stream(yaml.parse(text, Loader=_Loader))
    except yaml.MarkedYAMLError as exc:
        # libyaml 0.2.6 (PyYAML 6.0.4) scans flow collections ahead and stops itself at 1000 levels, before
        # the events reach the count below: the same limit, met earlier
        if "maximum nesting depth" not in str(exc.problem):
            raise
        line = exc.problem_mark.line + 1 if exc.problem_mark is not None else None
        raise YamlLimitError(f"nesting deeper than {MAX_YAML_DEPTH} levels", line) from None


def _check_event_stream(events) -> None:
    anchors: dict[str, int] = {}  # expanded size of each complete anchored node
    open_nodes: list[list] = []  # [anchor, expanded size so far] per open collection
    for event in events:
        line = event.start_mark.line + 1
        if isinstance(event, yaml.AliasEvent):
            if event.anchor not in anchors:
                raise YamlLimitError(f"alias *{event.anchor} refers to a node that contains it (or to no node)",
                                     line)
            size = anchors[event.anchor]
        elif isinstance(event, yaml.ScalarEvent):
            size = 1
            if event.anchor:
                anchors[event.anchor] = 1
        elif isinstance(event, yaml.CollectionStartEvent):
            if len(open_nodes) >= MAX_YAML_DEPTH:
                raise YamlLimitError(f"nesting deeper than {MAX_YAML_DEPTH} levels", line)
            open_nodes.append([event.anchor, 1])
            continue
        elif isinstance(event, yaml.CollectionEndEvent):
            anchor, size = open_nodes.pop()
            if anchor:
                anchors[anchor] = size
        else:
            continue
        if open_nodes:  # sizes add up into the parent as each node completes
            open_nodes[-1][1] += size
            if open_nodes[-1][1] > MAX_YAML_NODES:
                raise YamlLimitError(f"the document expands to more than {MAX_YAML_NODES} nodes (aliases)", line)


def _check_keys(node, seen: set) -> None:
    """No mapping repeats a key (YAML 1.2 forbids it; PyYAML keeps the last one silently).
    Nodes shared by aliases are checked once."""
    if id(node) in seen:
        return
    seen.add(id(node))
    if isinstance(node, yaml.MappingNode):
        first: dict = {}
        for key, value in node.value:
            if isinstance(key, yaml.ScalarNode) and key.tag != "tag:yaml.org,2002:merge":
                if key.value in first:
                    raise YamlLimitError(f"duplicate key {key.value!r} (first given on line {first[key.value]})",
                                         key.start_mark.line + 1)
                first[key.value] = key.start_mark.line + 1
            _check_keys(value, seen)
    elif isinstance(node, yaml.SequenceNode):
        for value in node.value:
            _check_keys(value, seen)


def load_yaml(text: str):
    """(data, root node) of one YAML document within the limits; the node tree (or None
    for an empty document) gives lines. Raises yaml.YAMLError or YamlLimitError."""
    _check_events(text)
    loader = _Loader(text)
    try:
        root = loader.get_single_node()
        if root is None:
            return None, None
        _check_keys(root, set())
        return loader.construct_document(root), root
    finally:
        loader.dispose()
