"""Seam and butt planning for a whole hull (``strake.plan``).

uniform : girth seams (iso-parameter curves along the hull) at equal girth spacing at the
          widest section, so that every strake is at most ``stock.max_width`` wide; butt
          planes x = const equally spaced, so that every plate is at most ``max_length`` long;
          the plates at either end are closed by the hull's end (stem, stern).
adaptive : the uniform layout, then every plate that is neither flat nor devflat's strip
          (fitting the hull within the tolerance and covering its region) is split in two
          where and across the way the misfit is (pipeline/hull/splitting.py: a butt plane x = X
          or a new seam at a girth fraction, chosen so that the largest share of the plate is
          expected to fit), as long as both halves stay above ``stock.min_length`` x
          ``stock.min_width``, up to ``max_splits`` times; a plate stops splitting as soon as
          it fits. Splits are local (staggered butts, drop strakes): a plate's neighbours keep
          their seams. A patch development within the tolerance does not stop the splitting:
          only flat and strip plates count as fitting here.

The evaluator (``evaluate(part) -> result``) is given by the caller, so the plan knows no stage.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from flatten.closest import SurfaceDistance
from flatten.patch import region_grid

from flatten.plane import Plane

from .region import Girth, load_plan_surfaces, long_axis_of, plate_part, seam_curve
from .seamlines import least_curvature_seams
from .sewing import overlap_cuts
from .splitting import choose_split, sample_region


def girth_lengths(surface, axis: int, s_values: np.ndarray, n: int = 201) -> tuple[np.ndarray, np.ndarray]:
    """Cumulative girth arc length (len(s_values), n) along iso-s curves and the g samples (n,)."""
    gdom = surface.domain_v if axis == 0 else surface.domain_u
    g = np.linspace(*gdom, n)
    pts = surface.grid(s_values, g) if axis == 0 else surface.grid(g, s_values).transpose(1, 0, 2)
    seg = np.linalg.norm(np.diff(pts, axis=1), axis=2)
    return np.concatenate([np.zeros((len(s_values), 1)), np.cumsum(seg, axis=1)], axis=1), g


def uniform_layout(surface, axis: int, stock, x_limits: tuple = (None, None)) -> tuple[list[float], list[float], float]:
    """Girth seam values (iso-g), interior butt positions x, and the widest section's s;
    ``x_limits``: (lo, hi) where the face is cut (None: its own end), butts lie between."""
    sdom = surface.domain_u if axis == 0 else surface.domain_v
    s = np.linspace(*sdom, 41)
    cum, g = girth_lengths(surface, axis, s)
    widest = int(np.argmax(cum[:, -1]))
    total = cum[widest, -1]
    s_widest = float(s[widest])
    n_strakes = max(1, int(np.ceil(total / stock.max_width - 1e-9)))
    seams = list(np.interp(np.linspace(0, total, n_strakes + 1), cum[widest], g))
    seams[0], seams[-1] = float(g[0]), float(g[-1])
    gdom = surface.domain_v if axis == 0 else surface.domain_u
    pts = surface.grid(np.linspace(*surface.domain_u, 65), np.linspace(*surface.domain_v, 65))
    x0, x1 = float(pts[..., 0].min()), float(pts[..., 0].max())
    x0 = x0 if x_limits[0] is None else max(x0, x_limits[0])
    x1 = x1 if x_limits[1] is None else min(x1, x_limits[1])
    n_butts = max(1, int(np.ceil((x1 - x0) / stock.max_length - 1e-9)))
    butts = list(np.linspace(x0, x1, n_butts + 1)[1:-1])
    del gdom
    return [float(v) for v in seams], [float(x) for x in butts], s_widest


def region_size(surface, axis: int, girths, planes) -> tuple[float, float, float, float]:
    """(length, width, x_min, x_max) of a plate's region from a coarse grid of it; zeros when empty."""
    grid = region_grid(surface, axis, girths[0], girths[1], [None if p is None else p.as_tuple() for p in planes],
                       7, 17, probe=160)
    if grid is None:
        return 0.0, 0.0, 0.0, 0.0
    p = grid.points
    length = float(np.linalg.norm(np.diff(p, axis=1), axis=2).sum(axis=1).max())
    width = float(np.linalg.norm(np.diff(p, axis=0), axis=2).sum(axis=0).max())
    return length, width, float(p[..., 0].min()), float(p[..., 0].max())


def inside_share(surface, axis: int, girths, planes, trim) -> float:
    """Share of a plate region's area inside the surface's trim (a 17 x 49 grid of it)."""
    grid = region_grid(surface, axis, girths[0], girths[1], [None if p is None else p.as_tuple() for p in planes],
                       17, 49, probe=160)
    if grid is None:
        return 0.0
    p = grid.points
    # area per grid point: the product of its half-neighbour spacings along and across
    ds = np.gradient(np.concatenate([np.zeros((p.shape[0], 1)), np.cumsum(
        np.linalg.norm(np.diff(p, axis=1), axis=2), axis=1)], axis=1), axis=1)
    dg = np.gradient(np.concatenate([np.zeros((1, p.shape[1])), np.cumsum(
        np.linalg.norm(np.diff(p, axis=0), axis=2), axis=0)], axis=0), axis=0)
    weight = ds * dg
    inside = trim.inside(grid.params[..., 0], grid.params[..., 1])
    total = float(weight.sum())
    return float(weight[inside].sum()) / total if total > 0 else 0.0


def plate_class(result) -> str:
    figures = getattr(result, "figures", {}) or {}
    return (figures.get("plate_class") or {}).get("class", "failed")


def honest_class(result) -> str:
    """flat, developable (devflat's strip between the seams fits and covers the region),
    formed (anything else: a patch development counts as formed here, whatever its misfit)
    or failed. The adaptive plan splits every plate that is not flat or developable."""
    if not getattr(result, "ok", False):
        return "failed"
    klass = (getattr(result, "figures", {}) or {}).get("plate_class") or {}
    name = klass.get("class", "failed")
    if name == "developable" and not is_strip(klass):
        return "formed"
    return name


def is_strip(klass: dict) -> bool:
    """The class record says the plate is devflat's strip (not a patch development)."""
    method = str(klass.get("method", ""))
    return "strip" in method and not method.startswith("isometric") and "patch" not in method


def _keep(parts: list, part, result, record: dict) -> None:
    """A plate the adaptive plan keeps, with why it stopped splitting (``figures['plan']``)."""
    if getattr(result, "figures", None) is not None:
        result.figures["plan"] = record
    parts.append(part)


def plan_hull(spec, path, mm_per_unit: float, lines: dict, evaluate=None) -> list:
    strake = spec.strake
    plan = strake.plan
    sources = [strake.surface] + list(plan.surfaces)
    planned = load_plan_surfaces(sources, path.parent, mm_per_unit, strake.scale)
    loaded = [(p.surface, p.trim, p.note) for p in planned]
    surfaces = [s for s, _, _ in loaded]
    distance = SurfaceDistance(surfaces)
    resolution = float(strake.patch_spacing or 200.0 / mm_per_unit)
    stock = plan.stock
    multi = len(surfaces) > 1
    tolerance = float(strake.fit_tolerance or 5.0 / mm_per_unit)
    # faces that lie on each other are cut at a transverse plane, each keeping one side (a
    # shell's faces beyond its loft keep the side its end plane gives them)
    free = [k for k, p in enumerate(planned) if not p.fixed]
    cut, overlaps = overlap_cuts([surfaces[k] for k in free], [loaded[k][1] for k in free], tolerance) \
        if len(free) > 1 else ([(None, None)] * len(free), [])
    overlaps = [replace(o, faces=tuple(free[i] for i in o.faces)) for o in overlaps]
    limits = [p.x_limits for p in planned]
    for k, lim in zip(free, cut):  # the tighter of a loft's own ends and an overlap's cut
        limits[k] = tuple(a if b is None else b if a is None else pick(a, b)
                          for a, b, pick in zip(limits[k], lim, (max, min)))
    parts = []
    for k, surface in enumerate(surfaces):
        axis = long_axis_of(surface)
        seams, butts, s_widest = uniform_layout(surface, axis, stock, limits[k])
        if plan.seams == "least_curvature":
            seam_lines = least_curvature_seams(surface, axis, seams, s_widest)
        else:
            seam_lines = [Girth.iso(g) for g in seams]
        ends = [None if x is None else Plane((1.0, 0.0, 0.0), x) for x in limits[k]]
        planes = [ends[0]] + [Plane((1.0, 0.0, 0.0), x) for x in butts] + [ends[1]]
        cut_note = "; ".join(f"faces {o.faces[0] + 1} and {o.faces[1] + 1} overlap over x {o.x_range_mm[0]:.0f}.."
                             f"{o.x_range_mm[1]:.0f} ({o.median_distance_mm:.3g} apart, median): cut at x = "
                             f"{o.cut_x_mm:.0f}, step {o.step_at_cut_mm:.3g} there" for o in overlaps if k in o.faces)
        prefix = f"{spec.name}_P{k + 1}" if multi else spec.name
        queue = []
        for i in range(len(seams) - 1):
            for j in range(len(planes) - 1):
                queue.append((f"{prefix}_S{i + 1:02d}_B{j + 1:02d}", (seam_lines[i], seam_lines[i + 1]),
                              (f"SEAM {i + 1}", f"SEAM {i + 2}"), tuple(planes[j:j + 2]), 0))
        while queue:
            name, girths, seam_names, pair, depth = queue.pop(0)
            length, width, xa, xb = region_size(surface, axis, girths, pair)
            if length <= 0:
                continue  # the region misses this surface (e.g. a butt beyond a short strake)
            butt_names = tuple("HULL END" if p is None else f"BUTT X{p.offset:.0f}" for p in pair)
            curves = [seam_curve(surface, axis, g, f"{name}.{n}") for g, n in zip(girths, seam_names)]
            inside = 1.0 if loaded[k][1] is None else inside_share(surface, axis, girths, pair, loaded[k][1])
            if inside <= 0.0:
                continue  # wholly outside the surface's trim: not shell (another surface covers it)
            part = plate_part(name, surface, axis, girths, curves, pair, spec.steel, strake, distance, seam_names,
                          butt_names, resolution, "; ".join(n for n in (loaded[k][2], cut_note) if n))
            part.hull.inside_trim = inside
            part.hull.trim = loaded[k][1] if inside < 1.0 else None
            part.hull.x_limits = limits[k]
            part.hull.face_trim = loaded[k][1]
            if plan.method == "uniform" or evaluate is None:
                parts.append(part)
                continue
            result = evaluate(part)
            part.hull.result = result
            klass = honest_class(result)
            record = {"depth": depth, "class_for_plan": klass, "method": plan.method}
            if klass in ("flat", "developable") or depth >= plan.max_splits:
                record["stopped"] = "fits" if klass in ("flat", "developable") else f"max_splits = {plan.max_splits}"
                _keep(parts, part, result, record)
                continue
            sample = sample_region(surface, axis, girths, pair)
            split = None if sample is None else choose_split(sample, strake.fit_tolerance, stock.min_length,
                                                             stock.min_width)
            if split is None:
                record["stopped"] = "no split keeps both halves within the minimum stock sizes"
                _keep(parts, part, result, record)
                continue
            if split.kind == "length":
                cut = Plane((1.0, 0.0, 0.0), split.at)
                queue += [(f"{name}-1", girths, seam_names, (pair[0], cut), depth + 1),
                          (f"{name}-2", girths, seam_names, (cut, pair[1]), depth + 1)]
            else:
                middle = girths[0].between(girths[1], split.at)
                label = f"{seam_names[0]}+{round(100 * split.at)}%"
                queue += [(f"{name}-1", (girths[0], middle), (seam_names[0], label), pair, depth + 1),
                          (f"{name}-2", (middle, girths[1]), (label, seam_names[1]), pair, depth + 1)]
    return parts
