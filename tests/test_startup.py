"""What a devflat process imports at its start (issue 15: a one-shot run or check costs
about one numpy + scipy import): modules the libraries import without using are loaded on
first use, and still work when something does use them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHECK_THEN_USE = """
import json, sys, types
from pipeline.cli import main
code = main(["check", sys.argv[1]])
names = ("numpy.testing", "numpy.f2py")
executed = {n: type(sys.modules[n]) is types.ModuleType for n in names if n in sys.modules}
import scipy.interpolate  # the star import that used to load them has run
import numpy
numpy.testing.assert_allclose(1.0, 1.0)  # first use loads the real module
print(json.dumps({"code": code, "executed": executed, "scipy": "scipy.interpolate" in sys.modules,
                  "works": type(sys.modules["numpy.testing"]) is types.ModuleType}))
"""


def test_check_loads_scipy_without_numpys_test_helpers_which_load_on_first_use():
    done = subprocess.run([sys.executable, "-c", CHECK_THEN_USE, str(ROOT / "configs" / "plate.yaml")],
                          env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["code"] == 0 and out["scipy"]
    assert out["executed"] == {"numpy.testing": False, "numpy.f2py": False}
    assert out["works"]


PROGRAM_START = """
import os, sys
import pipeline.cli as cli
cli.main = lambda argv, one_shot: print(os.environ.get("OPENBLAS_NUM_THREADS"), os.environ.get("OMP_NUM_THREADS"),
                                        os.environ.get("IGL_NUM_THREADS"), "numpy" in sys.modules or "igl" in sys.modules,
                                        one_shot) or 0
sys.exit(cli.run_program(["check", "x.yaml"]))
"""


def test_the_program_runs_blas_and_libigl_on_one_thread_unless_the_environment_says_otherwise():
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "IGL_NUM_THREADS")}
    env["PYTHONPATH"] = str(ROOT)
    done = subprocess.run([sys.executable, "-c", PROGRAM_START], env=env, capture_output=True, text=True, timeout=60)
    # set before numpy and libigl are loaded (they read it then or later)
    assert done.returncode == 0 and done.stdout.split() == ["1", "None", "1", "False", "True"], done.stderr
    done = subprocess.run([sys.executable, "-c", PROGRAM_START], env=dict(env, OMP_NUM_THREADS="3", IGL_NUM_THREADS="2"),
                          capture_output=True, text=True, timeout=60)
    assert done.stdout.split() == ["None", "3", "2", "False", "True"], done.stderr
