"""PNG previews: the flat pattern and the solution diagram in the (t, T) rectangle.

The one module that talks to matplotlib (Agg backend, no screen needed).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from flatten import SolutionSet  # noqa: E402

from .atomic import atomic_path  # noqa: E402


def flat_pattern_png(target: str | Path, outline: np.ndarray, bend_lines: np.ndarray, title: str, units: str) -> None:
    fig, ax = plt.subplots(figsize=(9, 5), dpi=110)
    closed = np.vstack([outline, outline[:1]])
    ax.plot(closed[:, 0], closed[:, 1], color="crimson", lw=1.4, label="cut")
    for a, b in bend_lines:
        ax.plot([a[0], b[0]], [a[1], b[1]], color="steelblue", lw=0.5)
    ax.plot([], [], color="steelblue", lw=0.5, label="bending lines (rulings)")
    ax.set_aspect("equal")
    ax.set_title(title)
    ax.set_xlabel(units)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    with atomic_path(target) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def solution_diagram_png(target: str | Path, solution: SolutionSet, c_domain, d_domain, title: str) -> None:
    """Every branch in the parameter rectangle: acceptable pieces green, regression red,
    the chosen path thick, turning points marked."""
    fig, ax = plt.subplots(figsize=(6, 6), dpi=110)
    ax.add_patch(plt.Rectangle((c_domain[0], d_domain[0]), np.ptp(c_domain), np.ptp(d_domain),
                               fill=False, color="black", lw=0.8))
    for piece in solution.pieces:
        colour = "seagreen" if piece.acceptable else "firebrick"
        ax.plot(piece.points[:, 0], piece.points[:, 1], color=colour, lw=1.0)
    if solution.path is not None:
        ax.plot(solution.path.points[:, 0], solution.path.points[:, 1], color="navy", lw=3.0, alpha=0.6)
    for tp in solution.turning_points:
        ax.plot(tp.t, tp.T, "o", color="orange", ms=4)
    ax.plot([], [], color="seagreen", label="acceptable")
    ax.plot([], [], color="firebrick", label="regression (rulings cross)")
    ax.plot([], [], color="navy", lw=3, alpha=0.6, label="chosen strip")
    ax.set_xlabel("t (curve c)")
    ax.set_ylabel("T (curve d)")
    ax.set_title(title, fontsize=9)
    ax.legend(loc="lower right", fontsize=7)
    ax.set_xlim(c_domain[0] - 0.02 * np.ptp(c_domain), c_domain[1] + 0.02 * np.ptp(c_domain))
    ax.set_ylim(d_domain[0] - 0.02 * np.ptp(d_domain), d_domain[1] + 0.02 * np.ptp(d_domain))
    fig.tight_layout()
    with atomic_path(target) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def sheet_png(target: str | Path, patterns, units: str) -> None:
    """All flat patterns of a run on one sheet, in a grid, each with its name."""
    n = len(patterns)
    cols = int(np.ceil(np.sqrt(n)))
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.4 * rows), dpi=100, squeeze=False)
    for ax in axes.ravel():
        ax.set_axis_off()
    for ax, (name, outline, bend_lines) in zip(axes.ravel(), patterns):
        closed = np.vstack([outline, outline[:1]])
        ax.plot(closed[:, 0], closed[:, 1], color="crimson", lw=0.8)
        for a, b in bend_lines:
            ax.plot([a[0], b[0]], [a[1], b[1]], color="steelblue", lw=0.3)
        ax.set_aspect("equal")
        ax.set_title(name, fontsize=7)
    fig.suptitle(f"flat patterns ({units})", fontsize=9)
    fig.tight_layout()
    with atomic_path(target) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def hull_png(target: str | Path, plates, tolerance: float, units: str) -> None:
    """Side view (x, z) of the plates on the hull, coloured by their largest deviation."""
    from matplotlib.collections import PolyCollection

    fig, ax = plt.subplots(figsize=(10, 4), dpi=110)
    polygons, values = [], []
    for name, vertices, m, deviation in plates:
        grid = vertices.reshape(-1, m, 3)
        ring = np.vstack([grid[:, 0], grid[::-1, -1]])
        polygons.append(ring[:, [0, 2]])
        values.append(deviation)
        centre = ring[:, [0, 2]].mean(axis=0)
        ax.text(centre[0], centre[1], name.split("_", 1)[-1], fontsize=6, ha="center", va="center")
    collection = PolyCollection(polygons, array=np.array(values), cmap="viridis", edgecolor="black",
                                linewidth=0.4, clim=(0.0, tolerance))
    ax.add_collection(collection)
    ax.autoscale_view()
    ax.set_aspect("equal")
    ax.set_xlabel(f"x ({units})")
    ax.set_ylabel(f"z ({units})")
    fig.colorbar(collection, ax=ax, label=f"max distance from the hull ({units}), tolerance {tolerance:g}")
    fig.tight_layout()
    with atomic_path(target) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
