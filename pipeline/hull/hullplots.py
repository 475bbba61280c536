"""The hull picture of a shell expansion: every plate's region coloured by its class.

matplotlib is imported by :func:`class_hull_png` only (the plan DXF uses
:func:`plate_ring` without it), and as in :mod:`pipeline.plots` without pyplot: a bare
``Figure`` on the Agg canvas (no figure registry, no backend selection).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flatten.patch import grid_ring

from ..io.atomic import atomic_path

# "developable" is devflat's strip; "patch" a hull patch developed within the tolerance
# (rolled, no strip between those seams): the shares keep them apart
CLASS_COLOURS = {"flat": "#8fa8c8", "developable": "#4caf50", "patch": "#c5e1a5", "formed": "#ff9800",
                 "failed": "#d32f2f"}

LABELS = {"developable": "developable (strip)", "patch": "rolled (patch within tol.)"}


def display_class(result) -> str:
    """flat, developable (devflat's strip), patch (no strip fits, but the hull patch's
    development is within the tolerance: rolled, reported developable-by-patch or formed
    with rolling_only), formed or failed."""
    if not result.ok:
        return "failed"
    klass = result.figures.get("plate_class") or {}
    name = klass.get("class", "failed")
    if name == "developable":
        method = str(klass.get("method", ""))
        return "developable" if "strip" in method and not method.startswith("isometric") and "patch" not in method \
            else "patch"
    if name == "formed" and klass.get("rolling_only"):
        return "patch"
    return name if name in CLASS_COLOURS else "failed"


def plate_ring(result) -> np.ndarray | None:
    """The 3D boundary (N, 3) of a delivered plate, from its strip or its patch grid."""
    if result.strip is not None:
        m = len(result.strip.samples)
        grid = result.strip.vertices.reshape(-1, m, 3)
        return np.vstack([grid[:, 0], grid[::-1, -1]])
    if result.mesh is not None:
        shape = (result.figures.get("region") or {}).get("grid")
        if shape:
            g = result.mesh[0].reshape(shape[0], shape[1], 3)
            return grid_ring(g)
    corners = (result.figures.get("region") or {}).get("corners")
    return None if corners is None else np.asarray(corners)


def shell_area(result) -> float:
    """The plate's area on the hull (m^2) that is shell: its region inside the surface's
    IGES trim (the whole region for an untrimmed surface)."""
    area = float((result.figures.get("region") or {}).get("area_m2") or 0.0)
    hull = getattr(getattr(result, "part", None), "hull", None)
    return area * (1.0 if hull is None else float(getattr(hull, "inside_trim", 1.0)))


def class_hull_png(target: str | Path, results, units: str, mm_per_unit: float, title: str | None = None) -> dict:
    """Side and bottom views of the plates coloured flat / developable (strip) / patch /
    formed / failed; returns the shell area of each (m^2, regions on the hull inside trims).
    The picture is drawn by :func:`draw_class_hull` through :func:`pipeline.renderproc.render`
    (in the render process of a one-shot run: only the rings and colours are sent)."""
    from ..renderproc import render

    rings, colours = [], []
    for r in results:
        ring = plate_ring(r)
        if ring is not None:
            rings.append(ring)
            colours.append(CLASS_COLOURS.get(display_class(r), CLASS_COLOURS["failed"]))
    areas = {k: 0.0 for k in CLASS_COLOURS}
    for r in results:
        areas[display_class(r)] += shell_area(r)
    render("pipeline.hull.hullplots:draw_class_hull", target, rings, colours, areas, units, title)
    return areas


def draw_class_hull(target: str | Path, rings: list, colours: list, areas: dict, units: str,
                    title: str | None) -> None:
    """The picture of :func:`class_hull_png`: rings (N, 3) in model units, their colours,
    the shell area of each class (m^2)."""
    fig = class_figure(rings, colours, areas, units, title)
    with atomic_path(target) as tmp:
        fig.savefig(tmp, format="png")


def class_figure(rings: list, colours: list, areas: dict, units: str, title: str | None):
    """The side and bottom views as a matplotlib ``Figure`` on the Agg canvas: each view as
    tall as the hull's true aspect asks (a long hull is a thin band: a fixed page height left
    it two strips in a white page), the legend below both, clear of the plates (drawn inside
    the side view, it covered the sheer strakes)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    points = np.vstack(rings) if rings else np.zeros((1, 3))
    extent = np.maximum(np.ptp(points, axis=0), 1e-9 * max(float(np.ptp(points)), 1.0))
    width = 12.0
    heights = [float(np.clip(0.9 * width * extent[k] / extent[0], 0.6, 4.0)) for k in (2, 1)]
    fig = Figure(figsize=(width, sum(heights) + 1.8), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 1, sharex=True, height_ratios=heights)
    for ax, (a, b), label in zip(axes, ((0, 2), (0, 1)), ("side view (x, z)", "bottom view (x, y)")):
        polygons = [ring[:, [a, b]] for ring in rings]
        ax.add_collection(PolyCollection(polygons, facecolors=colours, edgecolor="black", linewidth=0.3, alpha=0.85))
        ax.autoscale_view()
        ax.set_aspect("equal")
        ax.set_ylabel(f"{'zy'[b == 1]} ({units})")
        ax.set_title(label, fontsize=9)
    axes[-1].set_xlabel(f"x ({units})")
    total = sum(areas.values()) or 1.0
    handles = [Line2D([], [], marker="s", linestyle="none", color=colour) for colour in CLASS_COLOURS.values()]
    labels = [f"{LABELS.get(k, k)}: {areas[k]:.1f} m2 ({100 * areas[k] / total:.1f}%)" for k in CLASS_COLOURS]
    fig.legend(handles, labels, loc="outside lower center", fontsize=7, ncols=len(CLASS_COLOURS), frameon=False)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig
