"""`devflat nest` remnants (issue 25): each stock plate's offcut kept in a CSV inventory, the
next nest cutting from it first and never from the same remnant twice; and one time
budget for the whole command (it was one per engine run: a 10 s budget took 36 s on 11
plates of 3 stock widths, every one of 32 engine runs taking at least a second)."""

import csv
import types
from pathlib import Path

import ezdxf
import numpy as np
import pytest
import yaml
from shapely.geometry import Polygon, box

from pipeline.cli import main
from pipeline.nest import command, engine
from pipeline.nest.engine import NestItem
from pipeline.nest.remnants import offcut

ROOT = Path(__file__).resolve().parents[1]
PLATE = ROOT / "configs" / "plate.yaml"
SEED = 5


def rect(w: float, h: float) -> np.ndarray:
    return np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])


# ------------------------------------------------------------------ the budget
@pytest.fixture
def fake_clock(monkeypatch):
    """The engine's clock advanced only by engine runs, each by the seconds it was given
    (0.1 s for a first-layout run): what the nesting would take if every run used its
    whole budget. Records each run's seconds and the time left when it was asked for."""
    now = [0.0]
    runs = []
    clock = types.SimpleNamespace(perf_counter=lambda: now[0])
    real = engine.strip_pack

    def strip_pack(items, counts, height, spacing, budget, seed, workers, progress=None):
        runs.append((budget, now[0]))
        placements, eng = real(items, counts, height, spacing, 0, seed, workers)
        now[0] += max(budget, 0.1)
        return placements, eng

    monkeypatch.setattr(engine, "time", clock)
    monkeypatch.setattr(command, "time", clock)
    monkeypatch.setattr(engine, "strip_pack", strip_pack)
    return now, runs


def test_the_stock_budget_holds_for_every_engine_run_together(fake_clock):
    now, runs = fake_clock
    items = [NestItem("big", rect(2900, 2600), 12, (0.0, 90.0, 180.0, 270.0)),
             NestItem("mid", rect(1900, 1300), 3, (0.0, 90.0))]
    stock = [("S", 3000.0, 6000.0), ("T", 2500.0, 8000.0), ("U", 2800.0, 7000.0)]
    budget = 4.0
    result = engine.nest_stock(items, stock, 10.0, 10.0, budget, SEED, 1)
    assert result.success, result.message
    assert len(runs) > budget  # more engine runs than seconds: at one second each it overran
    assert sum(seconds for seconds, _ in runs) <= budget
    for seconds, at in runs:  # no run was given more than was left
        assert seconds <= max(0.0, budget - at)


def test_groups_share_one_budget(fake_clock):
    """Two thicknesses, one budget: the groups' engine runs add up to it (each group had
    at least a second of its own, and its runs a second each, before)."""
    now, runs = fake_clock
    items = {"S355-12": [NestItem("a", rect(2900, 2600), 5, (0.0, 90.0))],
             "S355-15": [NestItem("b", rect(1400, 1300), 9, (0.0, 90.0))]}
    job = command.NestJob("stock", groups=items,
                          group_info={k: {"thickness_mm": float(k[-2:]), "material": "S355"} for k in items})
    spec = types.SimpleNamespace(spacing=10.0, edge_margin=10.0, time=3, seed=SEED, workers=1,
                                 stock_sizes=lambda: [types.SimpleNamespace(name="S", width=3000.0, length=6000.0)])
    config = types.SimpleNamespace(spec=types.SimpleNamespace(nesting=spec), source=Path("x.yaml"))
    results = command.run_job(job, config)
    assert all(r.success for r in results.values())
    assert sum(seconds for seconds, _ in runs) <= 3
    assert now[0] <= 3 + 0.1 * sum(1 for seconds, _ in runs if seconds == 0)


# ------------------------------------------------------------------ offcuts
def test_the_offcut_is_the_plate_beyond_its_last_part():
    row = {"used_length": 5363.28, "length": 9000.0, "width": 3000.0}
    assert offcut(row, 2000.0, 500.0) == (5363.28, 3000.0, pytest.approx(3636.72, abs=1e-9))
    assert offcut(row, 3700.0, 500.0) is None  # too short
    assert offcut(row, 500.0, 3001.0) is None  # too narrow
    # the cut keeps the kerf (spacing) from the last part when it exceeds the edge margin
    assert offcut(row, 2000.0, 500.0, 10.0, 25.0)[:2] == (pytest.approx(5378.28), 3000.0)


# ------------------------------------------------------------------ the inventory round trip
def nest(tmp_path: Path, name: str, inventory: str | None, quantity: int, length: float = 9000.0) -> Path:
    data = yaml.safe_load(PLATE.read_text())
    data["output"] = {"png": False}
    remnants = {"min_length": 2000, "min_width": 1000}
    if inventory is not None:
        remnants["inventory"] = inventory
    data["nesting"] = {"stock": {"width": 3000, "length": length, "name": "STOCK"}, "spacing": 10, "edge_margin": 10,
                       "time": 2, "seed": SEED, "pairs": True, "quantities": {"bilge_plate": quantity},
                       "remnants": remnants}
    config = tmp_path / f"{name}.yaml"
    config.write_text(yaml.safe_dump(data))
    out = tmp_path / name
    assert main(["nest", str(config), "--out", str(out), "--quiet"]) == 0
    return out


def rows(path: Path) -> list[dict]:
    return list(csv.DictReader(path.open()))


def test_a_remnant_from_one_nest_is_used_by_the_next_and_never_twice(tmp_path):
    first = nest(tmp_path, "first", None, 1)
    plates = rows(first / "bilge_plate_cutting_list.csv")
    inventory = rows(first / "bilge_plate_remnants.csv")
    # every plate's offcut beyond its last part, full width, listed in mm (rounded down)
    expected = [(p["plate"], 9000.0 - float(p["used_length_mm"])) for p in plates
                if 9000.0 - float(p["used_length_mm"]) >= 2000]
    assert expected and len(inventory) == len(expected)
    for r, (plate, length) in zip(inventory, expected):
        assert r["remnant"].startswith("R") and f" {plate} " in r["origin"]
        assert float(r["width_mm"]) == 3000.0 and float(r["length_mm"]) == pytest.approx(length, abs=0.1)
        assert float(r["length_mm"]) <= length and (r["thickness_mm"], r["material"]) == ("12", "S355")
    kept = {r["remnant"]: r for r in inventory}

    second = nest(tmp_path, "second", "first/bilge_plate_remnants.csv", 1)
    plates2 = rows(second / "bilge_plate_cutting_list.csv")
    used = [p for p in plates2 if p["stock"] in kept]
    assert len(used) == 1  # a 3 m x 3.6 m remnant takes one 2.9 m x 2.7 m plate, first
    [p] = used
    remnant = kept[p["stock"]]
    assert (float(p["width_mm"]), float(p["length_mm"])) == (float(remnant["width_mm"]), float(remnant["length_mm"]))
    assert p["plate"] == "P01" and int(p["parts_count"]) >= 1
    # its parts lie on the remnant (the DXF read back), inside the edge margin
    doc = ezdxf.readfile(second / f"bilge_plate_{p['plate']}.dxf")
    cuts = [Polygon(list(e.vertices_in_wcs())) for e in doc.modelspace().query("LWPOLYLINE[layer=='CUT_OUTER']")]
    inside = box(10, 10, float(remnant["length_mm"]) - 10, float(remnant["width_mm"]) - 10).buffer(1e-2)
    assert len(cuts) == int(p["parts_count"]) and all(inside.contains(c) for c in cuts)
    inventory2 = rows(second / "bilge_plate_remnants.csv")
    ids2 = [r["remnant"] for r in inventory2]
    assert p["stock"] not in ids2  # used up
    assert set(kept) - {p["stock"]} <= set(ids2)  # the others are still there
    new = [i for i in ids2 if i not in kept]
    assert new and min(int(i[1:]) for i in new) > max(int(i[1:]) for i in kept)  # fresh ids

    third = nest(tmp_path, "third", "second/bilge_plate_remnants.csv", 1)
    stocks = [p["stock"] for nest_out in (second, third) for p in rows(nest_out / "bilge_plate_cutting_list.csv")
              if p["stock"] != "STOCK"]
    assert len(stocks) == len(set(stocks))  # no remnant cut twice
    assert p["stock"] not in [q["stock"] for q in rows(third / "bilge_plate_cutting_list.csv")]


BAD_ROWS = [("R0001,12,S355,-5,3000,x\n", ["row 2", "width_mm", "'-5'"]),
            ("R0001,12,S355,3000,3000,x\nR0001,12,S355,3000,3000,y\n", ["row 3", "R0001", "twice"]),
            ("X1,12,S355,3000,3000,x\n", ["row 2", "remnant", "'X1'"])]


@pytest.mark.parametrize("body, expected", BAD_ROWS, ids=["negative", "twice", "id"])
def test_a_bad_inventory_exits_2_naming_file_row_field_and_value(tmp_path, capsys, body, expected):
    (tmp_path / "inv.csv").write_text("remnant,thickness_mm,material,width_mm,length_mm,origin\n" + body)
    data = yaml.safe_load(PLATE.read_text())
    data["nesting"] = {"stock": {"width": 3000, "length": 6000}, "time": 1, "remnants": {"inventory": "inv.csv"}}
    config = tmp_path / "plate.yaml"
    config.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["nest", str(config), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    for piece in ["inv.csv"] + expected:
        assert piece in err, (piece, err)
    assert not out.exists()


def test_a_missing_inventory_or_remnants_on_a_marker_is_bad_input(tmp_path, capsys):
    data = yaml.safe_load(PLATE.read_text())
    data["nesting"] = {"stock": {"width": 3000, "length": 6000}, "time": 1, "remnants": {"inventory": "none.csv"}}
    config = tmp_path / "plate.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["nest", str(config), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    assert "none.csv" in capsys.readouterr().err
    lamp = yaml.safe_load((ROOT / "configs" / "lampshade.yaml").read_text())
    lamp["nesting"] = {"fabric_width": 900, "remnants": {"min_length": 100}}
    config = tmp_path / "lamp.yaml"
    config.write_text(yaml.safe_dump(lamp))
    assert main(["nest", str(config), "--out", str(tmp_path / "out2"), "--quiet"]) == 2
    assert "remnants" in capsys.readouterr().err
