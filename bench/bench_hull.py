"""Whole hulls: the share of shell area delivered flat / devflat's strip / rolled patch /
formed, per hull, with the plain seam layout (``plan.method: uniform``) and with the adaptive
plan, iso-parameter or least-curvature seams.

    python bench/bench_hull.py [--hulls hull160 dtmb5415 kvlcc2 kcs] [--methods uniform adaptive]
                               [--seams iso least_curvature] [--objectives none weld1.5 ...]
                               [--fit-up report follow follow_pull follow_pull_hold follow_hold repair]
                               [--jobs N] [--out DIR]

Per hull, method and seams: plates, shares of the shell area (plate regions inside the IGES
trims) per class, delivered complete: flat, strip (devflat's strip between the plate's seams
or butt sections fits the hull within the tolerance and covers the region), patch (no strip
fits; the hull patch's minimal-strain development is within the tolerance: rolled), formed,
failed; flat + strip is the honest share. The plan's cost (pipeline/hull/cost.py): metres of
weld between plates (seams + butts), per m^2 of shell, the narrowest plate's width and the
cross joints (four plates at a point off the block joints), the plates no stock sheet holds
(their developments, pipeline/hull/sheets.py). The
worst deviation from the hull (flat and strip plates), the worst in-plane strain (patch and
formed plates), crashes, time; the hull picture coloured by class, the plan (plate outlines
in 3D, one DXF layer per class) and the shell expansion (DXF and PDF) go to --out.
Fit-up (pipeline/hull/fitup.py): shell covered and covered twice (% of the shell), developed
length mismatch of flat/strip neighbours' shared edges (p95 / max mm), step between
neighbours' 3D edges (p95 / max mm) and the number of shared edges stepping over 3 mm, per
``strake.fit_up`` of ``--fit-up`` (report: as planned; follow: the formed plates formed to meet
their flat and strip neighbours; follow_pull: follow with strake.pull_steps, the flat or strip
pairs it leaves stepping pulled together at erection; follow_hold: follow with
strake.hold_steps, those pairs held on the hull; follow_pull_hold: both, the pulls first;
repair: misfit plates developed on the hull), each
after the same plan (its plates come from the cache).

Objectives (``plan.objective``, adaptive plans only): ``none`` (split every misfit plate),
``weldF`` ({maximise: flat_strip, weld_factor: F}, e.g. weld1.5), ``cost`` (weights: 1 per weld
metre, 5 per plate, 5 per m^2 not flat or strip). One plate evaluator per hull serves every
method and objective (``--jobs`` workers; a plate is evaluated once, whatever plan asks): a
second objective on a hull costs only the plates the first did not ask for. Per row: the
plan's time (wall and CPU seconds, the workers' included) and the plates it evaluated and
found in the cache; after each adaptive row its Pareto front (the candidate plans the planner
evaluated that no other beats in both flat + strip share and weld length).

    python bench/bench_hull.py --lean-every 4 [--hulls hull160]

prints instead, per hull, the CPU per plate of a candidate's lean evaluation (what an
adaptive plan runs: class, fit, area; pipeline/hull/plateshop.py) beside the full plate
run (the baseline: what every candidate cost before), on every 4th plate of its uniform
layout, in this process, interleaved plate by plate, per class and in all; and the
completion a kept plate gets (its shop data), so that lean + completion / full shows that
a kept plate pays nothing twice.
"""

from __future__ import annotations

import argparse
import copy
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import yaml

from tests.shipped_configs import with_files_from

HULLS = {"hull160": "hull160_shell.yaml", "dtmb5415": "dtmb5415_shell.yaml", "kvlcc2": "kvlcc2_shell.yaml",
         "kcs": "kcs_shell.yaml"}


OBJECTIVES = {"cost": {"weights": {"weld_m": 1.0, "plate": 5.0, "formed_m2": 5.0}}}


def objective_of(name: str) -> dict | None:
    if name == "none":
        return None
    if name.startswith("weld"):
        return {"maximise": "flat_strip", "weld_factor": float(name[4:])}
    return OBJECTIVES[name]


FIT_UPS = ("report", "repair", "follow", "follow_pull", "follow_pull_hold", "follow_hold")


def replan_where_it_applies(data: dict) -> dict:
    """The config ``data`` without ``plan.replan_held`` where it does not apply (a uniform plan,
    or a fit-up without ``hold_steps``: nothing is held to plan again), as the shipped 160 m
    hull's config sets it and a bench's variant may not."""
    plan = data["strake"].get("plan") or {}
    if plan.get("method") == "uniform" or not data["strake"].get("hold_steps"):
        plan.pop("replan_held", None)
    return data


def fit_up_of(name: str) -> dict:
    """The strake options of a ``--fit-up`` name (one of FIT_UPS)."""
    return {"fit_up": "follow" if name.startswith("follow") else name,
            "hold_steps": name.endswith("_hold"), "pull_steps": "_pull" in name}


def run(hull: str, method: str, out: Path, seams: str = "iso", objective: str = "none", evaluator=None,
        fit_up: str = "report") -> dict:
    from pipeline.hull.hullplots import class_hull_png, display_class, shell_area
    from pipeline.hull.plan import load_run
    from pipeline.hull.planout import write_plan_dxf
    from pipeline.hull.plates import run_part
    from pipeline.runner import plate_evaluator

    evaluator = evaluator or plate_evaluator(1)
    data = yaml.safe_load((ROOT / "configs" / HULLS[hull]).read_text())
    data = copy.deepcopy(data)
    data["strake"]["plan"]["method"] = method
    data["strake"]["plan"]["seams"] = seams
    # "none" plans without one, whatever the config ships
    data["strake"]["plan"].pop("objective", None)
    if objective_of(objective) is not None:
        data["strake"]["plan"]["objective"] = objective_of(objective)
    data["strake"].update(fit_up_of(fit_up))
    replan_where_it_applies(data)
    with_files_from(data, ROOT / "configs")  # the files, relative to the config (a hull model's too: KCS, KVLCC2)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{hull}.yaml"
        path.write_text(yaml.safe_dump(data))
        start, cpu = time.perf_counter(), time.process_time()
        before = (evaluator.requested, evaluator.computed, evaluator.cpu_seconds - evaluator.local_cpu_seconds)
        config = load_run(path, evaluator)
        results = [run_part(part, config) for part in config.parts]
        seconds = time.perf_counter() - start
        # this process's CPU and the evaluator's workers' (they report theirs with each plate)
        cpu = time.process_time() - cpu + (evaluator.cpu_seconds - evaluator.local_cpu_seconds - before[2])
        asked, computed = evaluator.requested - before[0], evaluator.computed - before[1]
        from pipeline.hull.fitup import shell_fitup

        fit = shell_fitup(results, config).as_dict()  # not timed: the run's report, not the plan
    areas = {"flat": 0.0, "strip": 0.0, "patch": 0.0, "formed": 0.0, "failed": 0.0}
    worst_dev, worst_strain, crashes = 0.0, 0.0, 0
    for r in results:
        klass = (r.figures.get("plate_class") or {})
        area = shell_area(r)
        name = {"developable": "strip", "patch": "patch"}.get(display_class(r), display_class(r))
        areas[name if name in areas else "failed"] += area
        crashes += "internal error" in r.reason
        if r.ok and name in ("flat", "strip"):
            worst_dev = max(worst_dev, klass.get("max_deviation") or 0.0)
        if r.ok and name in ("patch", "formed"):
            worst_strain = max(worst_strain, klass.get("max_strain") or 0.0)
    total = sum(areas.values())
    from pipeline.hull.cost import block_joints, plan_cost, stock_min_width
    from pipeline.hull.expansion import shell_edges, write_expansion
    from pipeline.hull.sheets import Sheets

    edges = shell_edges(results)
    cost = plan_cost(results, edges, config.mm_per_unit, stock_min_width(config.spec), block_joints(config.spec),
                     Sheets.of_shop(config.spec.shop))
    out.mkdir(parents=True, exist_ok=True)
    tag = (f"{hull}_{method}" + ("" if seams == "iso" else f"_{seams}") + ("" if objective == "none" else
                                                                          f"_{objective}")
           + ("" if fit_up == "report" else f"_{fit_up}"))
    class_hull_png(out / f"{tag}_classes.png", results, config.spec.units, config.mm_per_unit,
                   f"{hull}, {method} plan, {seams} seams: {len(results)} plates")
    write_plan_dxf(out / f"{tag}_plan.dxf", results, config.mm_per_unit)
    write_expansion(results, edges, config, out, tag, True, True)
    return {"hull": hull, "method": method, "plates": len(results), "area_m2": total,
            "shares": {k: v / total for k, v in areas.items()},
            "worst_deviation": worst_dev, "worst_strain": worst_strain, "crashes": crashes, "seconds": seconds,
            "cpu_seconds": cpu, "evaluated": computed, "cached": asked - computed,
            "weld_per_m2": cost.weld_per_m2, "weld_m": cost.weld_m, "narrowest_m": (cost.narrowest or {}).get("width_m"),
            "cross_joints": len(cost.cross_joints), "off_sheets": len(cost.off_sheets),
            "fitup": fit, "record": config.plan_record, "objective": objective, "fit_up": fit_up}


def lean_vs_full(hull: str, every: int) -> None:
    """CPU per plate, full plate run vs lean evaluation (and its completion), every
    ``every``-th plate of the hull's uniform layout. A formed plate's lean evaluation leaves
    its development owed too (``plateshop.owe_development``): its completion column holds it."""
    from pipeline.hull.plan import load_run
    from pipeline.hull.planner import honest_class
    from pipeline.hull.plates import evaluate_plate, run_plate
    from pipeline.hull.plateshop import complete

    data = yaml.safe_load((ROOT / "configs" / HULLS[hull]).read_text())
    data["strake"]["plan"]["method"] = "uniform"
    replan_where_it_applies(data)
    with_files_from(data, ROOT / "configs")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{hull}.yaml"
        path.write_text(yaml.safe_dump(data))
        config = load_run(path)
    parts = config.parts[::every]
    evaluate_plate(parts[0], config)  # untimed: the lazy imports
    rows: dict = {}
    for part in parts:
        cpu = time.process_time()
        full = run_plate(part, config)
        t_full = time.process_time() - cpu
        cpu = time.process_time()
        lean = evaluate_plate(part, config)
        t_lean = time.process_time() - cpu
        cpu = time.process_time()
        complete(lean, config)
        t_done = time.process_time() - cpu
        if honest_class(lean) != honest_class(full):
            sys.exit(f"bench_hull: {part.name}: lean class {honest_class(lean)}, full {honest_class(full)}")
        klass = honest_class(full)
        for key in (klass, "all"):
            row = rows.setdefault(key, [0, 0.0, 0.0, 0.0])
            row[0] += 1
            row[1] += t_full
            row[2] += t_lean
            row[3] += t_done
    print(f"{hull}: {len(parts)} plates (every {every}th of {len(config.parts)} of the uniform layout), CPU ms per "
          f"plate, load average {os.getloadavg()[0]:.1f}")
    print(f"  {'class':<12}{'plates':>7}{'full':>9}{'lean':>9}{'lean/full':>10}{'shop (completion)':>19}"
          f"{'(lean+shop)/full':>18}")
    for key in sorted(rows, key=lambda k: (k == "all", k)):
        n, full, lean, done = rows[key]
        print(f"  {key:<12}{n:>7}{1000 * full / n:>9.0f}{1000 * lean / n:>9.0f}{lean / full:>10.2f}"
              f"{1000 * done / n:>19.0f}{(lean + done) / full:>18.2f}")


def front_lines(record, area_m2: float) -> list[str]:
    """The Pareto front of the candidate plans (weld m, weld m/m^2, plates, flat + strip %)."""
    if record is None or not record.points:
        return []
    lines = [f"  pareto ({len(record.points)} candidate plans; uniform weld {record.uniform_weld_m:.0f} m"
             + ("" if record.weld_budget_m is None else f", budget {record.weld_budget_m:.0f} m")
             + f"; splits taken {record.splits_taken}, rejected {record.splits_rejected}):"]
    for p in record.pareto():
        lines.append(f"    round {p.round:>2}  plates {p.plates:>4}  weld {p.weld_m:>7.0f} m  "
                     f"{p.weld_m / area_m2 if area_m2 else float('nan'):.3f} m/m2  flat+strip {100 * p.flat_strip:5.1f} %"
                     + ("  <- plan" if p.kept else ""))
    plan = next((p for p in record.points if p.kept), None)
    if plan is not None and plan not in record.pareto():
        lines.append(f"    the plan: plates {plan.plates}, weld {plan.weld_m:.0f} m, flat+strip {100 * plan.flat_strip:.1f} % "
                     "(dominated: a plan it evaluated earlier had as much share for less weld)")
    return lines


def fitup_columns(fit: dict) -> str:
    """Shell covered and covered twice, the developed length mismatch of flat/strip neighbours
    (p95 / max) and the step between neighbours' 3D edges (p95 / max, count over 3 mm)."""
    def pct(x):
        return "-" if x is None else f"{100 * x:.2f}"

    def pair(d):
        return "-" if d["max"] is None else f"{d['p95']:.2f}/{d['max']:.2f}"

    cov = fit.get("coverage") or {}
    return (f"{pct(cov.get('covered')):>10}{pct(cov.get('overlap')):>10}{pair(fit['length_mismatch_mm']):>18}"
            f"{pair(fit['step_mm']):>16}{fit['steps_over_3mm']:>6}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--hulls", nargs="+", default=list(HULLS), choices=list(HULLS))
    parser.add_argument("--methods", nargs="+", default=["uniform", "adaptive"], choices=["uniform", "adaptive"])
    parser.add_argument("--seams", nargs="+", default=["iso"], choices=["iso", "least_curvature"],
                        help="seam layouts to compare (iso-parameter lines, lines of least curvature)")
    parser.add_argument("--objectives", nargs="+", default=["none"],
                        help="adaptive plans' objectives: none, weldF (e.g. weld1.5), cost")
    parser.add_argument("--fit-up", nargs="+", default=["report"], choices=list(FIT_UPS),
                        help="strake.fit_up of each run (the adaptive plan is evaluated once: its plates are cached)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes for the plans' plate evaluations")
    parser.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "bench_hull")
    parser.add_argument("--lean-every", type=int, default=0,
                        help="instead: lean vs full evaluation CPU per plate on every n-th uniform plate")
    args = parser.parse_args(argv)
    if args.lean_every > 0:
        for hull in args.hulls:
            lean_vs_full(hull, args.lean_every)
        return 0
    from pipeline.runner import plate_evaluator

    print(f"{'hull':<9}{'plan':<10}{'seams':<6}{'plates':>7}{'area m2':>9}{'flat %':>8}{'strip %':>8}{'patch %':>8}"
          f"{'formed %':>9}{'failed %':>9}{'flat+strip %':>13}{'weld m':>8}{'weld m/m2':>10}{'narrowest m':>12}{'cross':>6}"
          f"{'no sheet':>9}{'worst dev mm':>13}{'worst strain':>13}{'crashes':>8}{'time s':>8}{'CPU s':>7}{'eval/cached':>12}"
          f"{'covered %':>10}{'overlap %':>10}{'fit-up p95/max mm':>18}{'step p95/max mm':>16}{'>3mm':>6}"
          f"  objective, fit-up")
    for hull in args.hulls:
        evaluator = plate_evaluator(args.jobs)  # one cache per hull: every plan of it shares the plates
        runs = [(m, s, o, f) for m in args.methods for s in args.seams for o in (args.objectives if m == "adaptive"
                                                                                  else ["none"]) for f in args.fit_up]
        for method, seams, objective, fit_up in runs:
            r = run(hull, method, args.out, seams, objective, evaluator, fit_up)
            s = r["shares"]
            print(f"{hull:<9}{method:<10}{'iso' if seams == 'iso' else 'least':<6}{r['plates']:>7}"
                  f"{r['area_m2']:>9.0f}{100 * s['flat']:>8.1f}"
                  f"{100 * s['strip']:>8.1f}{100 * s['patch']:>8.1f}{100 * s['formed']:>9.1f}{100 * s['failed']:>9.1f}"
                  f"{100 * (s['flat'] + s['strip']):>13.1f}{r['weld_m']:>8.0f}{r['weld_per_m2']:>10.3f}"
                  f"{r['narrowest_m'] or float('nan'):>12.2f}{r['cross_joints']:>6}"
                  f"{r['off_sheets']:>9}{r['worst_deviation']:>13.2f}{r['worst_strain']:>13.2e}{r['crashes']:>8}{r['seconds']:>8.0f}"
                  f"{r['cpu_seconds']:>7.0f}{r['evaluated']:>6}/{r['cached']:<5}"
                  f"{fitup_columns(r['fitup'])}  {objective}, {fit_up}", flush=True)
            for line in front_lines(r["record"], r["area_m2"]):
                print(line, flush=True)
    print(f"pictures, plan DXFs and shell expansions in {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
