"""PNG previews: the flat pattern and the solution diagram in the (t, T) rectangle.

The one module that talks to matplotlib. Previews are drawn on a bare ``Figure`` with the
Agg canvas (no pyplot: no global figure registry, no GUI backend probing) with few
artists: line sets as one collection each, fixed margins instead of ``tight_layout``
(which measures every tick label twice) and fast PNG compression. A preview costs
about a tenth of what the pyplot version did (bench/bench_cli.py).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from .io.atomic import atomic_path

if TYPE_CHECKING:  # a type only: the render process draws without importing scipy (flatten's curves)
    from flatten import SolutionSet

# zlib level 1: a preview of lines on white compresses nearly as well as at level 6
# (PIL's default) in a fraction of the time
PNG_OPTIONS = {"compress_level": 1}


def _figure(figsize: tuple[float, float], dpi: int) -> Figure:
    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def _fitted_axes(points: np.ndarray, width: float, margins: tuple[float, float, float, float],
                 max_height: float, dpi: int = 100):
    """A figure ``width`` inches wide whose data area (equal axes) has the aspect of the
    points' bounding box (N, 2), its height clipped to [1, max_height] inches; margins
    (left, right, bottom, top) in inches. Long thin plates get a short image, not a
    square one of white space."""
    left, right, bottom, top = margins
    span = np.ptp(points, axis=0)
    ax_w = width - left - right
    ax_h = float(np.clip(ax_w * span[1] / span[0], 1.0, max_height)) if span[0] > 0 else max_height
    height = ax_h + bottom + top
    fig = _figure((width, height), dpi)
    ax = fig.add_axes((left / width, bottom / height, ax_w / width, ax_h / height))
    ax.set_aspect("equal", adjustable="datalim")
    return fig, ax


def _save(fig: Figure, target: str | Path) -> None:
    with atomic_path(target) as tmp:
        fig.savefig(tmp, format="png", pil_kwargs=PNG_OPTIONS)


def flat_pattern_png(target: str | Path, outline: np.ndarray, bend_lines: np.ndarray, title: str, units: str) -> None:
    """The cut contour (N, 2) and the bending lines (K, 2, 2), model units."""
    _save(flat_pattern_figure(outline, bend_lines, title, units), target)


def flat_pattern_figure(outline: np.ndarray, bend_lines: np.ndarray, title: str, units: str) -> Figure:
    """The preview's figure: equal axes (true aspect), the legend above the axes, clear of
    the part."""
    closed = np.vstack([outline, outline[:1]])
    fig, ax = _fitted_axes(closed, 9.0, (0.8, 0.3, 0.6, 0.6), 5.0)
    ax.add_collection(LineCollection(np.asarray(bend_lines)[:, :, :2], colors="steelblue", linewidths=0.5,
                                     label="bending lines"))
    ax.plot(closed[:, 0], closed[:, 1], color="crimson", lw=1.4, label="cut")
    ax.locator_params(nbins=6)
    # title and legend above the plate, at fixed positions (no tick-label extents measured)
    ax.set_title(title, fontsize=9, loc="left", y=1.01)
    ax.set_xlabel(units)
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=2, fontsize=7, frameon=False)
    return fig


def solution_diagram_png(target: str | Path, solution: SolutionSet, c_domain, d_domain, title: str) -> None:
    """Every branch in the parameter rectangle: acceptable pieces green, regression red,
    the chosen path thick, turning points marked."""
    fig = _figure((6, 6), 100)
    ax = fig.add_axes((0.11, 0.08, 0.85, 0.85))
    ax.add_patch(Rectangle((c_domain[0], d_domain[0]), np.ptp(c_domain), np.ptp(d_domain),
                           fill=False, color="black", lw=0.8))
    for acceptable, colour, label in ((True, "seagreen", "acceptable"),
                                      (False, "firebrick", "regression (rulings cross)")):
        lines = [piece.points[:, :2] for piece in solution.pieces if piece.acceptable == acceptable]
        ax.add_collection(LineCollection(lines, colors=colour, linewidths=1.0, label=label))
    if solution.path is not None:
        ax.plot(solution.path.points[:, 0], solution.path.points[:, 1], color="navy", lw=3.0, alpha=0.6,
                label="chosen strip")
    if solution.turning_points:
        ax.plot([tp.t for tp in solution.turning_points], [tp.T for tp in solution.turning_points], "o",
                color="orange", ms=4, label="turning points")
    ax.set_xlabel("t (curve c)")
    ax.set_ylabel("T (curve d)")
    ax.set_title(title, fontsize=9, y=1.01)
    ax.legend(loc="lower right", fontsize=7)
    ax.set_xlim(c_domain[0] - 0.02 * np.ptp(c_domain), c_domain[1] + 0.02 * np.ptp(c_domain))
    ax.set_ylim(d_domain[0] - 0.02 * np.ptp(d_domain), d_domain[1] + 0.02 * np.ptp(d_domain))
    _save(fig, target)


SHEET_CELL = (2.6, 1.3, 0.4)  # inches: cell width, height (long thin plates), title band


def sheet_layout(patterns, cols: int) -> tuple[float, list, list]:
    """All patterns at one scale (sheet inches per model unit: the largest at which every
    plate fits its cell), each centred in its cell of a ``cols``-wide grid. Returns
    (scale, outlines (closed, inches), bending lines (K, 2, 2) inches)."""
    cell_w, cell_h, _ = SHEET_CELL
    box = np.array([cell_w - 0.2, cell_h - 0.35])  # drawing box in a cell, the name above it
    spans = np.array([np.ptp(outline, axis=0) for _, outline, _ in patterns])
    with np.errstate(divide="ignore"):
        fits = np.where(spans > 0, box / np.where(spans > 0, spans, 1.0), np.inf)
    scale = float(fits.min()) if np.isfinite(fits).any() else 1.0
    outlines, bends = [], []
    for i, (_, outline, bend_lines) in enumerate(patterns):
        row, col = divmod(i, cols)
        corner = np.array([col * cell_w, -(row + 1) * cell_h])
        lo, span = outline.min(axis=0), np.ptp(outline, axis=0)
        shift = corner + 0.1 + 0.5 * (box - span * scale)
        outlines.append((np.vstack([outline, outline[:1]]) - lo) * scale + shift)
        bends.append((np.asarray(bend_lines)[:, :, :2].reshape(-1, 2, 2) - lo) * scale + shift)
    return scale, outlines, bends


def sheet_png(target: str | Path, patterns, units: str, mm_per_unit: float = 1.0) -> float:
    """All flat patterns of a run on one sheet, in a grid, at one common scale (the
    largest plate fills its cell), each named, with a scale bar. Returns the scale
    (sheet inches per model unit).

    One axes for the whole sheet whose data units are inches of the figure, the patterns
    moved into their cells, every line set one collection: a strake of 120 plates draws
    in about the time of one preview (one axes per plate took seconds)."""
    n = len(patterns)
    cols = int(np.ceil(np.sqrt(n)))
    rows = int(np.ceil(n / cols))
    cell_w, cell_h, head = SHEET_CELL
    fig = _figure((cell_w * cols, cell_h * rows + head), 80)
    ax = fig.add_axes((0.0, 0.0, 1.0, cell_h * rows / (cell_h * rows + head)))
    ax.set_axis_off()
    ax.set_xlim(0.0, cell_w * cols)
    ax.set_ylim(-cell_h * rows, 0.0)
    scale, outlines, bends = sheet_layout(patterns, cols)
    for i, (name, _, _) in enumerate(patterns):
        row, col = divmod(i, cols)
        ax.text((col + 0.5) * cell_w, -row * cell_h - 0.06, name, fontsize=7, ha="center", va="top")
    if bends:
        ax.add_collection(LineCollection(np.concatenate(bends), colors="steelblue", linewidths=0.3))
    ax.add_collection(LineCollection(outlines, colors="crimson", linewidths=0.8))
    # a scale bar of a round length (mm) about a cell wide, in the title band
    bar_mm = _round_length(0.8 * cell_w / scale * mm_per_unit)
    bar = bar_mm / mm_per_unit * scale / (cell_w * cols)  # figure fraction
    y = 1.0 - 0.6 * head / (cell_h * rows + head)
    fig.add_artist(Line2D([0.01, 0.01 + bar], [y, y], color="black", lw=2.0))
    fig.text(0.015 + bar, y, f"{bar_mm / 1000:g} m" if bar_mm >= 1000 else f"{bar_mm:g} mm", fontsize=8,
             va="center")
    fig.suptitle(f"flat patterns ({units}), all at one scale", fontsize=9)
    _save(fig, target)
    return scale


def _round_length(length: float) -> float:
    """The largest 1, 2 or 5 times a power of ten not above ``length``."""
    power = 10.0 ** np.floor(np.log10(length))
    return float(max(m for m in (1.0, 2.0, 5.0) if m * power <= length) * power)


def hull_png(target: str | Path, plates, tolerance: float, units: str) -> None:
    """Side view (x, z) of the plates on the hull, coloured by their largest deviation.
    plates: [(name, boundary on the hull (N, 3), deviation or NaN (grey: no figure)), ...]."""
    from matplotlib import colormaps
    from matplotlib.collections import PolyCollection

    polygons, values, names = [], [], []
    for name, ring, deviation in plates:
        polygons.append(np.asarray(ring)[:, [0, 2]])
        values.append(deviation)
        names.append(name.split("_", 1)[-1])
    fig, ax = _fitted_axes(np.vstack(polygons), 10.0, (0.9, 1.5, 0.6, 0.3), 4.0)
    for name, ring in zip(names, polygons):
        centre = ring.mean(axis=0)
        ax.text(centre[0], centre[1], name, fontsize=6, ha="center", va="center")
    values = np.ma.masked_invalid(np.array(values, dtype=float))
    collection = PolyCollection(polygons, array=values, cmap=colormaps["viridis"].with_extremes(bad="lightgrey"),
                                edgecolor="black", linewidth=0.4, clim=(0.0, tolerance))
    ax.add_collection(collection)
    ax.autoscale_view()
    ax.set_xlabel(f"x ({units})")
    ax.set_ylabel(f"z ({units})")
    box = ax.get_position()
    grey = ",\ngrey: no figure" if values.mask.any() else ""
    fig.colorbar(collection, cax=fig.add_axes((box.x1 + 0.02, box.y0, 0.015, box.height)),
                 label=f"max deviation ({units}),\ntolerance {tolerance:g}{grey}")
    _save(fig, target)


def layout_png(target: str | Path, width: float, length: float, parts, title: str, units: str,
               margin: float = 0.0) -> None:
    """A nesting layout: the roll or stock plate [0, length] x [0, width] (its edge margin
    dashed) and each placed part, filled, with its label. parts: [(label, (N, 2) ring), ...]."""
    from matplotlib.collections import PolyCollection

    corners = np.array([[0.0, 0.0], [length, width]])
    fig, ax = _fitted_axes(corners, 12.0, (0.8, 0.3, 0.6, 0.4), 9.0)
    ax.add_patch(Rectangle((0, 0), length, width, fill=False, color="black", lw=1.0))
    if margin > 0:
        ax.add_patch(Rectangle((margin, margin), length - 2 * margin, width - 2 * margin, fill=False,
                               color="grey", lw=0.5, ls="--"))
    ax.add_collection(PolyCollection([ring for _, ring in parts], facecolor="lightsteelblue", edgecolor="crimson",
                                     linewidth=0.6))
    size = max(2.0, min(7.0, 600.0 / max(len(parts), 1)))
    for label, ring in parts:
        centre = ring.mean(axis=0)
        ax.text(centre[0], centre[1], label, fontsize=size, ha="center", va="center")
    ax.autoscale_view()
    ax.set_xlabel(units)
    ax.set_title(title, fontsize=9, loc="left", y=1.01)
    _save(fig, target)


def warm_up() -> None:
    """Draw a small flat pattern into memory. A process's first drawing loads the fonts and
    fills matplotlib's caches (several times a later drawing's cost); a render process
    (:mod:`pipeline.renderproc`) does it while it waits for its first image."""
    import io

    square = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])
    bends = np.array([[[50.0, 0.0], [50.0, 100.0]]])
    flat_pattern_figure(square, bends, "warm-up: flat pattern (1 bending line)", "mm").savefig(
        io.BytesIO(), format="png", pil_kwargs=PNG_OPTIONS)
