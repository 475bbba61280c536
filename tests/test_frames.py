"""Frame marks on hull plates: end plates and butt edges named in two places."""

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import yaml

from tests.shipped_configs import plain_uniform, with_files_from

ROOT = Path(__file__).resolve().parents[1]


def test_end_plates_get_their_frames_marked(tmp_path):
    """The 160 m hull's shell (configs/hull160_shell.yaml, planned uniformly: no plate is
    run to plan it): an end plate, bounded by a butt and the hull's end, knows the frames
    between its butt and the farthest x of its region on the hull (sampled here from the
    hull surface over the plate's girth band), and its delivered layout marks every one
    (the keel plate at the bow spans x 146.7-158.2 m: frames 147.5 to 157.5 m)."""
    from pipeline.export import export_part
    from pipeline.hull.plan import load_run
    from pipeline.hull.plates import run_part

    data = plain_uniform(yaml.safe_load((ROOT / "configs" / "hull160_shell.yaml").read_text()))
    data = with_files_from(data, ROOT / "configs")
    (tmp_path / "hull160.yaml").write_text(yaml.safe_dump(data))
    plan = load_run(tmp_path / "hull160.yaml")
    ends = [p for p in plan.parts if None in p.hull.butts]
    assert len(ends) == 18
    for part in ends:
        hull = part.hull
        g0, g1 = (float(g.g[0]) for g in hull.girths)
        u = np.linspace(*hull.surface.domain_u, 1201)
        x = np.concatenate([hull.surface(u, np.full_like(u, g))[:, 0] for g in np.linspace(g0, g1, 17)])
        butt = next(b for b in hull.butts if b is not None).offset
        lo, hi = (x.min(), butt) if hull.butts[0] is None else (butt, x.max())
        expected = [k * 2500.0 for k in range(int(np.ceil(lo / 2500.0)), int(np.floor(hi / 2500.0)) + 1)
                    if lo < k * 2500.0 < hi]
        assert hull.frames == expected and expected, part.name
    bow_keel = next(p for p in ends if p.name == "hull160_S01_B12")
    assert bow_keel.hull.frames == [147500.0, 150000.0, 152500.0, 155000.0, 157500.0]
    result = run_part(bow_keel, plan)
    assert result.ok
    export_part(result, plan, tmp_path)
    layout = json.loads((tmp_path / "hull160_S01_B12.json").read_text())["layout"]
    assert sorted(layout["frames_marked"]) == sorted(f"FR {x:g}" for x in bow_keel.hull.frames)
    assert layout["findings"] == []


def test_a_butt_edge_named_in_two_places_is_not_one_line_across_the_plate():
    """A 10 m x 2 m plate whose 'end' butt name sits on two stretches of its outline (as an
    end ruling named by the way the seams run, not by where it lies, made it: the last
    ruling of a seam running towards -x is at the first butt). Frames 1.07 m and more from
    either butt are marked; joined into one polyline the two stretches crossed the plate
    and every frame was '0.0 mm from a butt' and not marked."""
    from pipeline.shop.outline import Outline
    from pipeline.shop.plate import ShopPlate, shop_layout

    # corners (0, 0) -> (10000, 0) -> (10000, 2000) -> (0, 2000), a corner piece on each butt
    points = np.array([[0, 0], [5000, 0], [10000, 0], [10000, 1000], [10000, 2000], [5000, 2000], [0, 2000],
                       [0, 1000]], dtype=float)
    edges = ("c", "c", "end", "end", "d", "d", "end", "start")
    outline = Outline(points, edges, 0.0, 0.05, 0.0)
    assert len(outline.edge_runs("end")) == 2 and len(outline.edge_runs("start")) == 1
    frames = [(x, np.array([[x, -100.0], [x, 2100.0]])) for x in (1070.0, 2500.0, 5000.0, 7500.0, 8930.0)]
    hull = SimpleNamespace(seam_names=("SEAM 1", "SEAM 2"), butt_names=("BUTT A", "BUTT B"))
    result = SimpleNamespace(name="P", shop=ShopPlate(outline), part=SimpleNamespace(hull=hull),
                             pattern=SimpleNamespace(frame_lines=frames, labels=()), figures={}, warnings=[])
    shop = SimpleNamespace(text_height=(5.0, 40.0), frame_clearance=50.0, stock=[(3000.0, 16000.0)],
                           stock_margin=10.0, bevel=SimpleNamespace(c="", d="", start="", end=""),
                           allowance=lambda: {"c": 0, "d": 0, "start": 0, "end": 0})
    config = SimpleNamespace(mm_per_unit=1.0, spec=SimpleNamespace(shop=shop))
    shop_layout(result, config, ["PART P"])
    layout = result.figures["layout"]
    assert not [f for f in layout["findings"] if "from a butt" in f], layout["findings"]
    assert sorted(layout["frames_marked"]) == sorted(f"FR {x:g}" for x, _ in frames)
