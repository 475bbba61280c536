"""Shop marks on steel plates: labels checked against the 3D geometry."""

from pathlib import Path

import ezdxf
import numpy as np
import pytest
import yaml
from scipy.spatial import cKDTree

from pipeline.cli import main
from pipeline.meshio import read_obj

ROOT = Path(__file__).resolve().parents[1]
SHIP = ROOT / "tests" / "data" / "ship"


def _strake_config(tmp_path, name, surface, seams, butts, **extra):
    data = {"name": name, "units": "mm", "resolution": {"chord_tolerance": 1.0},
            "strake": {"surface": surface, "seams": seams, "butts": butts, "margin": 0.2, "fit_tolerance": 5.0,
                       **extra}}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def strakes(tmp_path_factory):
    """Two real strakes whose seams run opposite ways: hullmod's iso-curves run towards -x,
    DTMB 5415's towards +x."""
    tmp = tmp_path_factory.mktemp("shop")
    runs = {}
    aft = _strake_config(tmp, "aft", {"iges": str(SHIP / "test_1_hull_exported.igs")},
                         [{"iso": {"v": 4.0}}, {"iso": {"v": 4.3}}], [72000, 88000, 104000],
                         frames={"spacing": 2500})
    fore = _strake_config(tmp, "fore", {"iges": str(SHIP / "ship_5415.igs"), "directory": 5},
                          [{"iso": {"v": 3.0}}, {"iso": {"v": 3.2}}], [1000, 2000, 3000],
                          frames={"spacing": 250})
    for key, config in (("aft", aft), ("fore", fore)):
        out = tmp / key
        assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
        runs[key] = (out, yaml.safe_load(config.read_text())["strake"])
    return runs


@pytest.mark.parametrize("key", ["aft", "fore"])
def test_butt_labels_sit_on_the_butt_they_name_in_3d(strakes, key):
    out, spec = strakes[key]
    butts = spec["butts"]
    directions = set()
    for j in range(len(butts) - 1):
        name = f"{key}_S1_B{j + 1}"
        v, vt, _ = read_obj(out / f"{name}.obj")
        directions.add(np.sign(v[-1, 0] - v[0, 0]))
        tree = cKDTree(vt)
        msp = ezdxf.readfile(out / f"{name}.dxf").modelspace()
        seen = []
        for text in msp.query("TEXT"):
            if not text.dxf.text.startswith("BUTT "):
                continue
            k = int(text.dxf.text.split()[1])
            _, nearest = tree.query(np.array(text.dxf.insert)[:2])
            x = v[nearest, 0]
            # the label's place on the flat plate maps to the butt it names, not the other one
            other = butts[j + 1] if k == j + 1 else butts[j]
            assert abs(x - butts[k - 1]) < abs(x - other), (name, k, x)
            seen.append(k)
        assert sorted(seen) == [j + 1, j + 2]
    # the two strakes do run in opposite directions along their seams
    assert directions == ({-1.0} if key == "aft" else {1.0})
