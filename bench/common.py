"""Shared benchmark inputs: the plate configs of configs/ and a real hull plate."""

from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from flatten import NurbsCurve, SolutionSet, solve  # noqa: E402
from flatten.strip import Strip, build_strip, choose_rulings  # noqa: E402
from flatten.surface import expand_knots, nurbs_surface  # noqa: E402
from pipeline.config import load_config  # noqa: E402


@dataclass
class Plate:
    name: str
    c: NurbsCurve
    d: NurbsCurve
    solution: SolutionSet
    strip: Strip


def s60_curves(u1=0.4, u2=0.5, v0=0.3, v1=0.5):
    """A Series 60 shell plate between two iso-parameter seams (tests/data/ship, mm)."""
    s = json.loads((ROOT / "tests" / "data" / "ship" / "s60_bsplines.json").read_text())["surfaces"][0]
    surface = nurbs_surface(s["degree_u"], s["degree_v"], s["poles"], expand_knots(s["knots_u"], s["mults_u"]),
                            expand_knots(s["knots_v"], s["mults_v"]), name="s60")
    return surface.iso_u(u1).segment(v0, v1), surface.iso_u(u2).segment(v0, v1)


def plates(n_rulings: int = 100, samples: int = 5) -> list[Plate]:
    pairs = []
    for name in ("plate", "frustum"):
        part = load_config(ROOT / "configs" / f"{name}.yaml").parts[0]
        pairs.append((part.name, part.c, part.d))
    lamp = load_config(ROOT / "configs" / "lampshade.yaml").parts[1]
    pairs.append((lamp.name, lamp.c, lamp.d))
    pairs.append(("s60_hull_plate", *s60_curves()))
    out = []
    for name, c, d in pairs:
        solution = solve(c, d)
        rulings = choose_rulings(solution, c, d, n_rulings=n_rulings)
        out.append(Plate(name, c, d, solution, build_strip(c, d, rulings, samples)))
    return out


def timed(fn, *args, repeat: int = 1):
    best, out = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn(*args)
        best = min(best, time.perf_counter() - start)
    return best, out


def machine_line() -> str:
    import platform
    return (f"machine: {platform.machine()} {os.cpu_count()} cores, python {platform.python_version()}, "
            f"numpy {np.__version__}, one BLAS thread")
