"""The 3D strip as Wavefront OBJ with the developed positions as texture coordinates."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .atomic import write_text


def obj_text(vertices: np.ndarray, flat: np.ndarray, faces: np.ndarray, name: str) -> str:
    """One `vt` per `v` (same index), faces as v/vt pairs; 1-based indices. Coordinates in
    Python's shortest repr, which reads back to the same double (half the time of %.17g)."""
    lines = [f"# devflat strip {name}: vt are the developed coordinates, model units", f"o {name}"]
    lines += ["v %r %r %r" % tuple(row) for row in np.asarray(vertices, dtype=float).tolist()]
    lines += ["vt %r %r" % tuple(row) for row in np.asarray(flat, dtype=float).tolist()]
    lines += ["f %d/%d %d/%d %d/%d" % (a, a, b, b, c, c) for a, b, c in (np.asarray(faces) + 1).tolist()]
    return "\n".join(lines) + "\n"


def write_obj(target: str | Path, vertices: np.ndarray, flat: np.ndarray, faces: np.ndarray, name: str) -> None:
    write_text(target, obj_text(vertices, flat, faces, name))


def read_obj(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices (V, 3), texture coordinates (V, 2), faces (F, 3)) of a file written above."""
    v, vt, f = [], [], []
    for line in Path(path).read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            v.append([float(x) for x in parts[1:4]])
        elif parts[0] == "vt":
            vt.append([float(x) for x in parts[1:3]])
        elif parts[0] == "f":
            f.append([int(p.split("/")[0]) - 1 for p in parts[1:4]])
    return np.array(v), np.array(vt), np.array(f, dtype=int)
