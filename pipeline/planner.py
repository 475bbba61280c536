"""Seam and butt planning for a whole hull (``strake.plan``).

uniform : girth seams (iso-parameter curves along the hull) at equal girth spacing at the
          widest section, so that every strake is at most ``stock.max_width`` wide; butt
          planes x = const equally spaced, so that every plate is at most ``max_length`` long;
          the plates at either end are closed by the hull's end (stem, stern).
adaptive : the uniform layout, then every plate the evaluator classes as *formed* (neither
          flat nor developable within the fit tolerance) is split in two (a butt at mid
          length when the plate is long, else a seam at mid girth), as long as both halves stay
          above ``stock.min_length`` x ``stock.min_width``, up to ``max_splits`` times. Splits
          are local (staggered butts, drop strakes): a plate's neighbours keep their seams.

The evaluator (``evaluate(part) -> result``) is given by the caller, so the plan knows no stage.
"""

from __future__ import annotations

import numpy as np

from flatten.closest import SurfaceDistance
from flatten.patch import region_grid

from .plan import Girth, Plane, _plate, load_surface_noted, long_axis_of, seam_curve


def girth_lengths(surface, axis: int, s_values: np.ndarray, n: int = 201) -> tuple[np.ndarray, np.ndarray]:
    """Cumulative girth arc length (len(s_values), n) along iso-s curves and the g samples (n,)."""
    gdom = surface.domain_v if axis == 0 else surface.domain_u
    g = np.linspace(*gdom, n)
    pts = surface.grid(s_values, g) if axis == 0 else surface.grid(g, s_values).transpose(1, 0, 2)
    seg = np.linalg.norm(np.diff(pts, axis=1), axis=2)
    return np.concatenate([np.zeros((len(s_values), 1)), np.cumsum(seg, axis=1)], axis=1), g


def uniform_layout(surface, axis: int, stock) -> tuple[list[float], list[float]]:
    """Girth seam values (iso-g) and interior butt positions x for one surface."""
    sdom = surface.domain_u if axis == 0 else surface.domain_v
    s = np.linspace(*sdom, 41)
    cum, g = girth_lengths(surface, axis, s)
    widest = int(np.argmax(cum[:, -1]))
    total = cum[widest, -1]
    n_strakes = max(1, int(np.ceil(total / stock.max_width - 1e-9)))
    seams = list(np.interp(np.linspace(0, total, n_strakes + 1), cum[widest], g))
    seams[0], seams[-1] = float(g[0]), float(g[-1])
    gdom = surface.domain_v if axis == 0 else surface.domain_u
    pts = surface.grid(np.linspace(*surface.domain_u, 65), np.linspace(*surface.domain_v, 65))
    x0, x1 = float(pts[..., 0].min()), float(pts[..., 0].max())
    n_butts = max(1, int(np.ceil((x1 - x0) / stock.max_length - 1e-9)))
    butts = list(np.linspace(x0, x1, n_butts + 1)[1:-1])
    del gdom
    return [float(v) for v in seams], [float(x) for x in butts]


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


def plate_class(result) -> str:
    figures = getattr(result, "figures", {}) or {}
    return (figures.get("plate_class") or {}).get("class", "failed")


def plan_hull(spec, path, mm_per_unit: float, lines: dict, evaluate=None) -> list:
    strake = spec.strake
    plan = strake.plan
    sources = [strake.surface] + list(plan.surfaces)
    loaded = [load_surface_noted(s, path.parent, mm_per_unit, strake.scale) for s in sources]
    surfaces = [s for s, _ in loaded]
    distance = SurfaceDistance(surfaces)
    resolution = float(strake.patch_spacing or 200.0 / mm_per_unit)
    stock = plan.stock
    multi = len(surfaces) > 1
    parts = []
    for k, surface in enumerate(surfaces):
        axis = long_axis_of(surface)
        seams, butts = uniform_layout(surface, axis, stock)
        planes = [None] + [Plane((1.0, 0.0, 0.0), x) for x in butts] + [None]
        prefix = f"{spec.name}_P{k + 1}" if multi else spec.name
        queue = []
        for i in range(len(seams) - 1):
            for j in range(len(planes) - 1):
                queue.append((f"{prefix}_S{i + 1:02d}_B{j + 1:02d}", (Girth.iso(seams[i]), Girth.iso(seams[i + 1])),
                              (f"SEAM {i + 1}", f"SEAM {i + 2}"), tuple(planes[j:j + 2]), 0))
        while queue:
            name, girths, seam_names, pair, depth = queue.pop(0)
            length, width, xa, xb = region_size(surface, axis, girths, pair)
            if length <= 0:
                continue  # the region misses this surface (e.g. a butt beyond a short strake)
            butt_names = tuple("HULL END" if p is None else f"BUTT X{p.offset:.0f}" for p in pair)
            curves = [seam_curve(surface, axis, g, f"{name}.{n}") for g, n in zip(girths, seam_names)]
            part = _plate(name, surface, axis, girths, curves, pair, spec.steel, strake, distance, seam_names,
                          butt_names, resolution, loaded[k][1])
            if plan.method == "uniform" or evaluate is None:
                parts.append(part)
                continue
            result = evaluate(part)
            part.hull.result = result
            if plate_class(result) in ("flat", "developable") or depth >= plan.max_splits:
                parts.append(part)
                continue
            can_length = length >= 2 * stock.min_length
            can_width = width >= 2 * stock.min_width
            if not (can_length or can_width):
                parts.append(part)
                continue
            if can_length and (length >= 2.0 * width or not can_width):
                mid = Plane((1.0, 0.0, 0.0), 0.5 * (xa + xb))
                queue += [(f"{name}-1", girths, seam_names, (pair[0], mid), depth + 1),
                          (f"{name}-2", girths, seam_names, (mid, pair[1]), depth + 1)]
            else:
                middle = girths[0].between(girths[1], 0.5)
                label = f"{seam_names[0]}.5" if seam_names[0][-2:] != ".5" else f"{seam_names[0]}5"
                queue += [(f"{name}-1", (girths[0], middle), (seam_names[0], label), pair, depth + 1),
                          (f"{name}-2", (middle, girths[1]), (label, seam_names[1]), pair, depth + 1)]
    return parts
