"""Planning layer: a strake or hull configuration becomes plates (seams, butts, region).

Data flows one way: config (validated YAML) -> plan (this module: plates with their seams,
butts and region on the hull) -> stages (develop each plate) -> export. This module knows
nothing of the stages: an adaptive plan receives its plate evaluator from the caller.

A plate's region (:mod:`.region`) is bounded along the girth by two seams (iso-parameter curves of the hull
surface, or given curves projected onto it) and along the length by two butt planes or the
hull's end (stem, stern). Its two seams, extended past the butts, are the curve pair the
developable strip is computed on.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from flatten.closest import SurfaceDistance

from ..config import ConfigError, Part, RunConfig, _curve, _line_of, load_config
from ..io.sources import SourceError
from .region import Girth, butt_plane, load_surface_noted, long_axis_of, plate_part, seam_curve


def plan_strake(spec, config_path: Path, mm_per_unit: float, lines: dict) -> list[Part]:
    """The plates of a hand-laid strake: between consecutive seams and consecutive butts."""
    strake = spec.strake
    surface, trim_note = load_surface_noted(strake.surface, config_path.parent, mm_per_unit, strake.scale)
    axis = long_axis_of(surface)
    distance = SurfaceDistance(surface)
    curves, girths = [], []
    for k, seam in enumerate(strake.seams):
        if seam.curve is not None:
            curve = _curve(seam.curve, ("strake", "seams", k, "curve"), config_path, lines, mm_per_unit, {})
            params, _ = distance.closest(curve(np.linspace(*curve.domain, 200)))
            s, g = params[:, axis], params[:, 1 - axis]
            order = np.argsort(s)
            curves.append(curve)
            girths.append(Girth(tuple(s[order]), tuple(g[order])))
            continue
        iso = seam.iso
        if (iso.u is not None) == (axis == 0):
            raise SourceError(f"seams[{k}].iso: the seam runs across the hull ({'u' if iso.u is not None else 'v'} "
                              f"is the girth parameter here): give iso {'v' if axis == 0 else 'u'}")
        value = iso.u if iso.u is not None else iso.v
        dom = surface.domain_u if iso.u is not None else surface.domain_v
        if not dom[0] <= value <= dom[1]:
            raise SourceError(f"seams[{k}].iso.{'u' if iso.u is not None else 'v'} = {value} lies outside the "
                              f"surface's domain {dom}")
        girths.append(Girth.iso(value))
        curves.append(seam_curve(surface, axis, girths[-1], f"seam{k + 1}"))
    planes = [butt_plane(b) for b in strake.butts]
    resolution = float(getattr(strake, "patch_spacing", None) or 200.0 / mm_per_unit)
    parts = []
    crossings = {}  # (seam, plane) -> parameters: asked for by up to four plates
    for i in range(len(curves) - 1):
        for j in range(len(planes) - 1):
            name = f"{spec.name}_S{i + 1}_B{j + 1}"
            parts.append(plate_part(name, surface, axis, girths[i:i + 2], curves[i:i + 2], planes[j:j + 2], spec.steel,
                                strake, distance, (f"SEAM {i + 1}", f"SEAM {i + 2}"),
                                (f"BUTT {j + 1}", f"BUTT {j + 2}"), resolution, trim_note, crossings))
            if not parts[-1].hull.developable and all(p is not None for p in planes[j:j + 2]):
                # a hand-laid seam that misses a butt plane is a layout error, as before
                raise SourceError(parts[-1].hull.note)
    return parts


def load_run(path: str | Path, evaluate=None) -> RunConfig:
    """Load a configuration and plan its plates. ``evaluate(part) -> result`` lets an
    adaptive plan judge candidate plates (given by the caller: the plan does not import
    the stages)."""
    config = load_config(path)
    spec = config.spec
    if spec.strake is None:
        return config
    path = Path(path)
    record = repair = follow = fairings = fit_seconds = replanned = None
    decks = deck_profiles(spec.strake, path, config.mm_per_unit, config.lines)  # bad input fails before the plan
    try:
        plan = spec.strake.plan
        judge = None if evaluate is None else _Judge(evaluate, config)
        if plan is not None:
            from .objective import PlanRecord
            from .planner import plan_hull

            record = PlanRecord() if judge is not None and plan.method == "adaptive" else None
            fairings = []
            parts = plan_hull(spec, path, config.mm_per_unit, config.lines, judge, record, fairings)
        else:
            parts = plan_strake(spec, path, config.mm_per_unit, config.lines)
        if spec.strake.fit_up in ("repair", "follow") and evaluate is not None:
            fit_seconds = (0.0, 0.0)
            repair, follow, fit_seconds = _fit_up(parts, spec, config, evaluate, fit_seconds)
            if plan is not None and plan.replan_held and follow is not None:
                from .objective import PlanRecord
                from .planner import plan_hull
                from .replan import plan_again

                def replan(lost: frozenset) -> tuple:
                    again, again_fairings = PlanRecord(), []
                    return (plan_hull(spec, path, config.mm_per_unit, config.lines, judge, again, again_fairings,
                                      lost), again, again_fairings)

                def fit_up(planned: list):
                    nonlocal fit_seconds
                    _, done, fit_seconds = _fit_up(planned, spec, config, evaluate, fit_seconds)
                    return done

                (parts, record, fairings, follow), replanned = plan_again(
                    plan.replan_held, (parts, record, fairings, follow), replan, fit_up)
    except SourceError as exc:
        line = _line_of(config.lines, ("strake",))
        raise ConfigError(f"{path}{':' + str(line) if line else ''}: strake: {exc}") from None
    finally:
        close = getattr(evaluate, "close", None)
        if close is not None:
            close()  # an evaluator's workers end with the plan (its cache stays)
    run = RunConfig(spec, parts, path, config.lines)
    run.plan_record = record
    run.plan_fairings = fairings
    run.fitup_repair = repair
    run.fitup_follow = follow
    run.fitup_seconds = fit_seconds
    run.replan = replanned
    run.decks = decks
    return run


def deck_profiles(strake, config_path: Path, mm_per_unit: float, lines: dict) -> list:
    """Each of ``strake.decks`` as heights along the hull (:class:`.levels.DeckProfile`); a
    deck curve that cannot be read, or that does not run along the hull, is a ConfigError
    naming the file, its line and the deck."""
    from .levels import deck_profile

    out = []
    for k, deck in enumerate(strake.decks):
        curve = None
        if deck.curve is not None:
            curve = _curve(deck.curve, ("strake", "decks", k, "curve"), config_path, lines, mm_per_unit, {})
        try:
            out.append(deck_profile(deck, curve))
        except ValueError as exc:
            line = _line_of(lines, ("strake", "decks", k))
            raise ConfigError(f"{config_path}{':' + str(line) if line else ''}: strake.decks[{k}]: {exc}") from None
    return out


def _fit_up(parts: list, spec, config, evaluate, seconds: tuple) -> tuple:
    """The fit-up ``strake.fit_up`` asks for of the planned ``parts`` (their results' owed
    developments done first): (repair report, follow report, ``seconds`` (wall, CPU) plus its
    own)."""
    started = _own_clock(evaluate)
    # the fit-up reads the plates' developments, which a plan's evaluation may owe
    fitting = _Judge(evaluate, config)
    fitting.develop_plates(parts)
    repair = follow = None
    if spec.strake.fit_up == "repair":
        from .repair import repair_fitup

        repair = repair_fitup(parts, fitting.many_developed, config.mm_per_unit, float(spec.steel.thickness),
                              workers=fitting)
    else:
        from .follow import follow_fitup

        follow = follow_fitup(parts, fitting.many_developed, config.mm_per_unit, float(spec.steel.thickness),
                              as_strips=spec.strake.flats_as_strips, hold=spec.strake.hold_steps,
                              pull=spec.strake.pull_steps, workers=fitting)
    return repair, follow, tuple(total + now - then for total, now, then in zip(seconds, _own_clock(evaluate),
                                                                                started))


def _own_clock(evaluator) -> tuple[float, float]:
    """(wall, CPU) seconds so far of this process's own work: less the time in the
    evaluator's batches of plates (a stage of their own), plus the CPU its workers spent on
    what was mapped over them (as the plan's stage counts it, ``pipeline.cli``)."""
    return (time.perf_counter() - getattr(evaluator, "seconds", 0.0),
            time.process_time() - getattr(evaluator, "local_cpu_seconds", 0.0)
            + getattr(evaluator, "mapped_cpu_seconds", 0.0))


class _Judge:
    """The plan's evaluator: ``evaluate(part, config)`` bound to the configuration; ``many``
    hands a batch to an evaluator that has one (workers, cache), else runs it in turn."""

    def __init__(self, evaluate, config):
        self.evaluate, self.config = evaluate, config
        # the plan's split jobs' answers, kept for the plans made again after a fit-up
        # (:func:`.planner._spread_remembered`)
        self.remembered = {}

    def __call__(self, part):
        return self.evaluate(part, self.config)

    def many(self, parts: list) -> list:
        batch = getattr(self.evaluate, "many", None)
        if batch is not None:
            return batch(parts, self.config)
        return [self.evaluate(part, self.config) for part in parts]

    def many_developed(self, parts: list) -> list:
        """:meth:`many`, each result's owed development done (:func:`.plateshop.develop`)."""
        return self.developed(self.many(parts))

    def developed(self, results: list) -> list:
        """The results with any development they owe done, their shop data still owed (by
        the evaluator's workers when it has them)."""
        from .plateshop import develop

        spread = getattr(self.evaluate, "develop", None)
        if spread is not None:
            return spread(results, self.config)
        return [develop(result, self.config) for result in results]

    def develop_plates(self, parts: list) -> None:
        """Each hull plate's evaluated result (``part.hull.result``) with its owed development done."""
        held = [p for p in parts if getattr(p, "hull", None) is not None and p.hull.result is not None]
        for part, result in zip(held, self.developed([p.hull.result for p in held])):
            part.hull.result = result

    @property
    def running(self) -> bool:
        """Does the evaluator have workers running now (:meth:`map` spreads over them)?"""
        return bool(getattr(self.evaluate, "running", False))

    def map(self, func, items: list) -> list:
        """``func`` over items, on the evaluator's workers when it has them."""
        spread = getattr(self.evaluate, "map", None)
        return spread(func, items) if spread is not None else [func(item) for item in items]

    def map_each(self, func, items: list):
        """:meth:`map` as an iterator of the answers in order, the items handed to the
        evaluator's workers at once when it has them (else each computed as it is read)."""
        spread = getattr(self.evaluate, "map_each", None) or getattr(self.evaluate, "map", None)
        return spread(func, items) if spread is not None else (func(item) for item in items)
