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
