"""The layout's rule (docs/architecture.md): a room imports only rooms on lower floors, no
circles, every module in a room of the table; and the render process's function names point
at functions that exist. Imports are read with ``ast``, lazy ones inside functions included."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("flatten", "pipeline")
WINGS = ("io", "hull", "shop", "textile", "nest")
FUNCTION_NAME = re.compile(r"^pipeline(\.[a-z_]+)+:[a-z_][a-z_0-9]*$")


def read_floors(doc: Path) -> dict[str, int]:
    """The table 'floor | rooms' of the architecture page: room -> floor."""
    floors = {}
    for line in doc.read_text(encoding="utf-8").splitlines():
        match = re.match(r"^\|\s*(\d+)\s*\|(.*)\|\s*$", line)
        if match:
            for name in match.group(2).split(","):
                floors[name.strip().replace("\\_", "_")] = int(match.group(1))
    return floors


def module_of(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path: Path, root: Path) -> set[str]:
    """Every module of ours that ``path`` imports, anywhere in it."""
    module = module_of(path, root)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package.split(".")[: len(package.split(".")) - node.level + 1]
            if node.module:
                found.add(".".join(base + [node.module]))
            else:  # from . import a, b: each is a module
                found.update(".".join(base + [alias.name]) for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return {name for name in found if name.split(".")[0] in PACKAGES}


def room_of(module: str) -> str:
    parts = module.split(".")
    if parts[0] == "flatten":
        return "flatten"
    if len(parts) == 1:
        return "pipeline"  # the package's own __init__: a docstring only
    return parts[1]  # a wing or a top-level module


def graph(root: Path) -> dict[str, set[str]]:
    """module -> the modules of ours it imports (a module imported as a package counts as
    its __init__)."""
    return {module_of(path, root): imported_modules(path, root)
            for package in PACKAGES for path in sorted((root / package).rglob("*.py"))}


def violations(root: Path, floors: dict[str, int]) -> list[str]:
    """Every import that runs up or sideways between rooms, every module without a room,
    and every circle of imports; empty when the layout holds."""
    modules = graph(root)
    found = []
    for module, targets in sorted(modules.items()):
        room = room_of(module)
        if room != "pipeline" and room not in floors:
            found.append(f"{module}: room {room} is not on a floor of docs/architecture.md")
            continue
        for target in sorted(targets):
            other = room_of(target)
            if other == room or other == "pipeline":
                continue
            if other not in floors:
                found.append(f"{module} imports {target}: room {other} is not on a floor")
            elif floors[other] >= floors[room]:
                found.append(f"{module} (floor {floors[room]}) imports {target} (floor {floors[other]}): "
                             f"{'sideways' if floors[other] == floors[room] else 'upward'}")
    found.extend(f"circle: {' -> '.join(circle)}" for circle in circles(modules))
    return found


def circles(modules: dict[str, set[str]]) -> list[list[str]]:
    """One circle through each module that is on one (depth-first search, iterative)."""
    state, found = {}, []
    for start in sorted(modules):
        if start in state:
            continue
        stack = [(start, iter(sorted(modules.get(start, ()))))]
        path = [start]
        state[start] = "open"
        while stack:
            node, children = stack[-1]
            child = next(children, None)
            if child is None:
                state[node] = "done"
                stack.pop()
                path.pop()
            elif child not in modules:
                continue
            elif state.get(child) == "open":
                found.append(path[path.index(child):] + [child])
            elif child not in state:
                state[child] = "open"
                stack.append((child, iter(sorted(modules.get(child, ())))))
                path.append(child)
    return found


def test_every_import_runs_downward_and_no_circle():
    floors = read_floors(ROOT / "docs" / "architecture.md")
    assert {"flatten", "io", "cli"} <= set(floors), floors
    assert violations(ROOT, floors) == []


def test_io_and_flatten_know_nothing_of_a_run():
    floors = read_floors(ROOT / "docs" / "architecture.md")
    bottom = max(floors["io"], floors["flatten"])
    # the ground floor's other rooms are the process's own plumbing (imports, the render
    # process, the cores it may use): they know nothing of a run either
    assert all(floor >= bottom for room, floor in floors.items() if room not in ("flatten", "io", "lazymodules",
                                                                                    "renderproc", "cores"))


def test_every_wing_says_what_it_takes_and_gives():
    for wing in WINGS:
        doc = ast.get_docstring(ast.parse((ROOT / "pipeline" / wing / "__init__.py").read_text(encoding="utf-8")))
        assert doc and len(doc.split()) >= 30, wing


def test_render_function_names_exist():
    """``"pipeline.plots:flat_pattern_png"``: strings that a move of a file would not update."""
    names = set()
    for path in (ROOT / "pipeline").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and FUNCTION_NAME.match(node.value):
                names.add(node.value)
    assert len(names) >= 6, names
    for name in sorted(names):
        module, _, function = name.partition(":")
        source = ROOT / Path(*module.split(".")).with_suffix(".py")
        assert source.is_file(), name
        defined = {n.name for n in ast.parse(source.read_text(encoding="utf-8")).body if isinstance(n, ast.FunctionDef)}
        assert function in defined, name


def write_tree(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


FLOORS = {"flatten": 0, "io": 1, "config": 2, "shop": 2, "hull": 3, "cli": 4}


@pytest.mark.parametrize("files, expected", [
    ({"pipeline/io/reader.py": "from ..config import RunConfig\n"}, "upward"),
    ({"pipeline/shop/plate.py": "def f():\n    from ..hull.plan import plane_crossings\n"}, "upward"),
    ({"pipeline/shop/plate.py": "from ..config import Part\n"}, "sideways"),
    ({"flatten/curve.py": "from pipeline.io import reader\n"}, "upward"),
    ({"pipeline/hull/plan.py": "from .planner import plan_hull\n",
      "pipeline/hull/planner.py": "def f():\n    from .plan import Girth\n"}, "circle"),
    ({"pipeline/stages.py": "import numpy\n"}, "not on a floor"),
])
def test_the_check_finds_what_breaks_the_rule(tmp_path, files, expected):
    base = {"flatten/__init__.py": "", "flatten/curve.py": "import numpy\n", "pipeline/__init__.py": "",
            "pipeline/io/__init__.py": "", "pipeline/io/reader.py": "from flatten.curve import x\n",
            "pipeline/config.py": "from .io.reader import read\n", "pipeline/cli.py": "from .hull import plan\n",
            "pipeline/hull/__init__.py": "", "pipeline/hull/plan.py": "from ..shop.plate import f\n",
            "pipeline/shop/__init__.py": "", "pipeline/shop/plate.py": "from ..io import reader\n"}
    write_tree(tmp_path, base)
    assert violations(tmp_path, FLOORS) == []
    write_tree(tmp_path, files)
    found = violations(tmp_path, FLOORS)
    assert found and expected in found[0], found
