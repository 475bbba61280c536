"""An adaptive plan's candidates are evaluated lean (pipeline/hull/plateshop.py): class, fit
and area, no shop data. A plate evaluated lean, sent through the plan evaluator's cache and
a worker's pickle and then completed writes the same files, byte for byte, as the full
plate run (real plates of the 160 m hull: flat, a seam-to-seam strip, a strip trimmed by
its region, formed); the plates a plan drops never get shop data computed."""

import pickle
from pathlib import Path

import numpy as np
import pytest
import yaml

from flatten.meshcheck import naive_reference
from pipeline.export import export_part
from pipeline.hull.fitup import plate_edges
from pipeline.hull.hullplots import shell_area
from pipeline.hull.plan import load_run
from pipeline.hull.planner import honest_class
from pipeline.hull.plateshop import develop
from pipeline.hull.plates import evaluate_plate, run_part
from pipeline.runner import PlateEvaluator
from tests.hull_shapes import cylinder_sphere_iges
from tests.shipped_configs import plain_uniform, with_files_from

ROOT = Path(__file__).resolve().parents[1]

# plates of the 160 m hull's uniform layout and the way the full run delivers them
PLATES = {
    "hull160_S01_B06": ("flat", None),
    "hull160_S07_B07": ("developable", "seam"),
    "hull160_S05_B01": ("developable", "trimmed"),
    "hull160_S03_B09": ("formed", None),  # heating lines, templates, pin jig
}
SHOP_FIGURES = ("bending", "outline", "templates", "pinjig", "heating", "forming")


@pytest.fixture(scope="module")
def hull160(tmp_path_factory):
    """The 160 m hull's uniform layout (no plan evaluation: every plate is run in full by
    ``run_part``), without previews."""
    data = plain_uniform(yaml.safe_load((ROOT / "configs" / "hull160_shell.yaml").read_text()))
    data = with_files_from(data, ROOT / "configs")
    data["output"] = {"png": False}
    path = tmp_path_factory.mktemp("hull160") / "hull160.yaml"
    path.write_text(yaml.safe_dump(data))
    config = load_run(path)
    return config, {p.name: p for p in config.parts}


def _files(result, config, folder: Path) -> dict:
    import ezdxf

    folder.mkdir()
    ezdxf.options.write_fixed_meta_data_for_testing = True  # no time stamps, no random GUIDs
    try:
        export_part(result, config, folder)
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = False
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def evaluated(hull160):
    """The plates evaluated lean by two worker processes, as a plan's evaluator does: the
    results come back to this process, whose own parts never ran (their curves are cold)."""
    config, parts = hull160
    evaluator = PlateEvaluator(evaluate_plate, 2)
    try:
        results = evaluator.many([parts[name] for name in PLATES], config)
    finally:
        evaluator.close()
    assert evaluator.computed == len(PLATES)
    return evaluator, dict(zip(PLATES, results))


@pytest.mark.parametrize("name", list(PLATES))
def test_a_lean_plate_completed_writes_the_full_runs_files(hull160, evaluated, name, tmp_path, monkeypatch):
    config, parts = hull160
    evaluator, lean_results = evaluated
    part, lean = parts[name], lean_results[name]
    klass, how = PLATES[name]
    # what the plan reads is there; the shop data are not
    assert lean.ok and lean.shop_work is not None and lean.figures["plate_class"]["class"] == klass
    assert lean.shop is None and lean.templates == () and lean.pinjig is None
    assert not [k for k in SHOP_FIGURES if lean.figures.get(k)]
    if klass == "formed":  # the plan reads its class and wholeness: its development itself is owed
        assert lean.shop_work.develops and lean.pattern is None and lean.mesh is None
        assert "strain" not in lean.figures and "completeness" not in lean.figures
    elif how != "seam":  # no marks yet (a seam strip's pattern is its solver's rulings until shop.plate)
        assert not len(lean.pattern.bend_lines) and lean.pattern.frame_lines == () and lean.pattern.labels == ()
    # a second plan asks again: the cache's copy, sent to a worker (pickled) and completed
    # there, before this process runs the plate itself
    requested = evaluator.requested
    again = evaluator.many([part], config)[0]
    assert evaluator.computed == len(PLATES) and evaluator.requested == requested + 1
    sent = pickle.loads(pickle.dumps(again))
    monkeypatch.setattr(sent.part.hull, "result", sent)
    completed = run_part(sent.part, config)
    assert completed.shop_work is None and evaluator.cache[next(k for k in evaluator.cache if evaluator.cache[k].name
                                                                == name)].shop_work is not None  # the cache stays lean
    assert completed.figures["fitup_edges"] is not None
    monkeypatch.setattr(part.hull, "result", None)
    full = run_part(part, config)  # the full plate run
    assert full.ok and full.figures["plate_class"]["class"] == klass
    # the delivery this plate stands for: a seam-to-seam strip keeps its strip (its shop data
    # from shop.plate.stage_shop), a trimmed strip and a patch their region mesh
    assert (full.strip is not None) == (how == "seam")
    assert ("mapped onto the strip" in full.figures["plate_class"]["method"]) == (how == "trimmed")
    if klass == "developable":  # the naive surface T = t beside it: computed for the delivered strip alone
        check = full.figures["developability"]
        assert check["naive_max_abs_K_times_size_squared"] > 0 and check["naive_T_equals_t"]["max_abs_gaussian_curvature"] > 0
        if how == "seam":
            naive = naive_reference(part.c, part.d, check["check_rulings"], len(full.strip.samples))
            assert check["naive_T_equals_t"] == naive.as_dict()
            # scaled by the size of the strip checked, which reached past the butts, as the
            # strip's own figure is (not by the delivered strip's, trimmed at the butts)
            trimmed_size = float(np.ptp(full.strip.vertices, axis=0).max())
            assert check["naive_max_abs_K_times_size_squared"] / naive.max_abs_K > 1.01 * trimmed_size ** 2
    # the plan judged the lean result as it would have judged the full one
    assert honest_class(lean) == honest_class(full)
    assert shell_area(lean) == shell_area(full)
    assert lean.figures["region"] == full.figures["region"]
    # what a fit-up reads before the shop data: the development, as the full run has it
    developed = develop(pickle.loads(pickle.dumps(lean)), config)
    assert developed.shop_work is not None and not developed.shop_work.develops
    assert developed.figures["plate_class"] == full.figures["plate_class"]
    assert developed.status == full.status and developed.reason == full.reason
    if klass == "formed":
        assert np.array_equal(developed.pattern.vertices, full.pattern.vertices)
        assert developed.figures["strain"] == full.figures["strain"]
        with pytest.raises(ValueError, match="development is owed"):  # a fit-up reads no owed plate
            plate_edges(lean)
        # failed after its evaluation (by something else): developed, and still failed
        failed = pickle.loads(pickle.dumps(lean))
        failed.status, failed.reason = "failed", "failed later (test)"
        failed = develop(failed, config)
        assert (failed.status, failed.reason) == ("failed", "failed later (test)")
        assert failed.figures["plate_class"] == full.figures["plate_class"]
        assert failed.figures["strain"] == full.figures["strain"]
    assert develop(developed, config) is developed  # nothing more owed there
    if klass != "flat":  # a flat plate gets frame lines and names only
        assert [k for k in SHOP_FIGURES if full.figures.get(k)]
    if how == "seam":  # the exact outline replaced the ruling polygon at completion
        assert not np.array_equal(completed.pattern.outline, lean.pattern.outline)
    full_files = _files(full, config, tmp_path / "full")
    lean_files = _files(completed, config, tmp_path / "lean")
    assert {n.rsplit(".", 1)[-1] for n in full_files} >= {"json", "obj", "dxf"}
    assert list(lean_files) == list(full_files)
    for file in full_files:
        assert lean_files[file] == full_files[file], file


CS = dict(radius=10000.0, angle_deg=60.0, cylinder=1500.0, cap=3000.0, junction=0.3)


def _cs_config(tmp_path: Path) -> Path:
    """The cylinder joined to a sphere cap (tests/test_planner.py), planned adaptively: its
    mixed plate is split, its halves replace it."""
    iges = cylinder_sphere_iges(tmp_path / "cs.igs", **CS)
    data = {"name": "cs", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
            "strake": {"surface": {"iges": str(iges)}, "margin": 0.2, "fit_tolerance": 5.0,
                       "plan": {"method": "adaptive", "max_splits": 1,
                                "stock": {"max_length": 4000, "max_width": 5000, "min_length": 1000,
                                          "min_width": 1000}}}}
    path = tmp_path / "cs.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_plates_the_plan_drops_never_get_shop_data(tmp_path, monkeypatch):
    """Every call that computes shop data (a strip plate's exact outline and marks, a patch or
    trimmed plate's marks, templates, heating lines) is counted per plate: none while the
    plan evaluates its candidates, one per kept plate when the plates are run, none for the
    candidates it split."""
    import pipeline.hull.plateshop as plateshop
    import pipeline.shop.plate as shop_plate

    calls: list = []

    def counting(module, name, plate_of):
        real = getattr(module, name)

        def wrapper(*args, **kwargs):
            calls.append((name, plate_of(*args)))
            return real(*args, **kwargs)
        monkeypatch.setattr(module, name, wrapper)

    counting(shop_plate, "stage_shop", lambda result, config: result.name)
    counting(shop_plate, "hull_templates", lambda result, *a: result.name)
    for name in ("trimmed_shop", "patch_shop"):
        counting(plateshop, name, lambda result, *a: result.name)
    import pipeline.hull.plates as plates  # it holds the shop functions it owes by name

    monkeypatch.setattr(plates, "trimmed_shop", plateshop.trimmed_shop)
    monkeypatch.setattr(plates, "patch_shop", plateshop.patch_shop)

    evaluated: list = []

    def evaluate(part, config):
        evaluated.append(part.name)
        return evaluate_plate(part, config)

    config = load_run(_cs_config(tmp_path), PlateEvaluator(evaluate, 1))
    kept = [p.name for p in config.parts]
    dropped = set(evaluated) - set(kept)
    assert "cs_S01_B02" in dropped and {"cs_S01_B02-1", "cs_S01_B02-2"} <= set(kept)
    assert calls == []  # the plan evaluated its candidates without any shop data
    results = [run_part(part, config) for part in config.parts]
    assert all(r.ok for r in results)
    done = [plate for _, plate in calls]
    assert not dropped & set(done)
    # every kept plate once through its delivery's shop function; templates only for the
    # strip and formed plates (their shape needs checking)
    delivered = [plate for name, plate in calls if name in ("stage_shop", "trimmed_shop", "patch_shop")]
    assert sorted(delivered) == sorted(kept)
    curved = {r.name for r in results if r.figures["plate_class"]["class"] != "flat"}
    templated = [plate for name, plate in calls if name == "hull_templates"] + \
                [plate for name, plate in calls if name == "stage_shop"]
    assert sorted(templated) == sorted(curved)
    # run again: a completed plate owes nothing
    before = len(calls)
    for part in config.parts:
        run_part(part, config)
    assert len(calls) == before


def test_formed_plates_the_plan_drops_are_never_developed(tmp_path, monkeypatch):
    """A formed candidate's development (its hull patch's ARAP) is owed while the plan
    evaluates (the plan reads its class and wholeness): the formed plates it splits for their
    fit are never developed, each kept formed plate once, when the plan checks the kept
    plates against the stock sheets (:func:`pipeline.hull.planner._onto_sheets`: a plate it
    splits for the sheets is developed first; none here), not again when it is run."""
    import pipeline.hull.plates as plates

    developed: list = []
    real = plates._developed_patch

    def counted(result, *args, **kwargs):
        developed.append(result.name)
        return real(result, *args, **kwargs)

    monkeypatch.setattr(plates, "_developed_patch", counted)
    evaluator = PlateEvaluator(evaluate_plate, 1)
    config = load_run(_cs_config(tmp_path), evaluator)
    kept = {p.name for p in config.parts}
    assert sorted(developed) == sorted(p.name for p in config.parts if honest_class(p.hull.result) == "formed")
    candidates = {r.name: r for r in evaluator.cache.values()}
    dropped = [n for n, r in candidates.items() if n not in kept and r.figures["plate_class"]["class"] == "formed"]
    assert "cs_S01_B02" in dropped and all(candidates[n].shop_work.develops for n in dropped)
    assert all(honest_class(candidates[n]) == "formed" for n in dropped)  # as the plan judged them
    results = [run_part(part, config) for part in config.parts]
    formed = sorted(r.name for r in results if r.figures["plate_class"]["class"] == "formed")
    assert formed and sorted(developed) == formed
    assert all("development" not in r.figures["plate_class"] and r.figures.get("strain") for r in results
               if r.name in formed)


def test_a_formed_plate_cut_at_its_faces_trim_owes_and_gets_the_full_runs_development(tmp_path):
    """A formed plate of the sphere cap whose face is trimmed through its middle (the trim's
    outer loop ends half way along the plate): evaluated lean its development is owed, and
    developed and completed it writes the full run's files byte for byte, cut at the trim."""
    from flatten.patch import region_grid
    from pipeline.hull.trims import Trim

    config = load_run(_cs_config(tmp_path))  # no evaluator: the uniform layout
    part = next(p for p in config.parts if p.name == "cs_S01_B02")
    h = part.hull
    grid = region_grid(h.surface, h.long_axis, h.girths[0], h.girths[1],
                       [None if p is None else p.as_tuple() for p in h.butts], 9, 17)
    along = grid.params[..., h.long_axis]
    cut = 0.5 * (along.min() + along.max())
    (u0, u1), (v0, v1) = h.surface.domain_u, h.surface.domain_v
    box = [[u0, v0], [u1, v0], [u1, v1], [u0, v1]]
    for corner in (1, 2) if h.long_axis == 0 else (2, 3):  # the loop's far side moved to the cut
        box[corner][h.long_axis] = cut
    trim = Trim(1, np.array(box + box[:1], dtype=np.float64), (), 144)
    h.trim, h.face_trim, h.inside_trim = trim, trim, 0.5  # this test's own plan
    full = run_part(part, config)
    assert full.ok and full.figures["plate_class"]["class"] == "formed"
    assert 0.3 < full.figures["trim_cut"]["share"] < 0.7
    lean = evaluate_plate(part, config)
    assert lean.shop_work.develops and lean.pattern is None and "trim_cut" not in lean.figures
    developed = develop(pickle.loads(pickle.dumps(lean)), config)
    assert developed.figures["plate_class"] == full.figures["plate_class"]
    assert developed.figures["trim_cut"] == full.figures["trim_cut"]
    assert np.array_equal(developed.pattern.vertices, full.pattern.vertices)
    assert np.array_equal(developed.pattern.outline, full.pattern.outline)
    sent = pickle.loads(pickle.dumps(lean))
    sent.part.hull.result = sent
    completed = run_part(sent.part, config)
    full_files = _files(full, config, tmp_path / "full")
    lean_files = _files(completed, config, tmp_path / "lean")
    assert list(lean_files) == list(full_files) and {n.rsplit(".", 1)[-1] for n in full_files} >= {"json", "dxf"}
    for file in full_files:
        assert lean_files[file] == full_files[file], file
