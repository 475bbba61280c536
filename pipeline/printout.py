"""A 1:1 printable sheet (PDF and SVG) of textile pieces with a 10 cm check square.

The figure is exactly as large as the pieces plus a margin, and the axes fill it, so one
millimetre of pattern is one millimetre of paper; the check square proves the scale.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .atomic import atomic_path  # noqa: E402
from .textile import TextilePiece  # noqa: E402

MARGIN_MM = 20.0
CHECK_MM = 100.0


def sheet_extent(pieces: list[TextilePiece], scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Lower-left corner and size (mm) of the sheet, with room for the check square."""
    pts = np.vstack([p.cut for p in pieces]) * scale
    lo = pts.min(axis=0) - MARGIN_MM
    hi = pts.max(axis=0) + MARGIN_MM
    lo[1] -= CHECK_MM + MARGIN_MM  # the check square sits below the pieces
    hi[0] = max(hi[0], lo[0] + CHECK_MM + 2 * MARGIN_MM)
    return lo, hi - lo


def write_printout(targets: list[Path], pieces: list[TextilePiece], scale: float, title: str) -> tuple[float, float]:
    """Write the sheet to each target (format from the suffix); returns its size in mm."""
    lo, size = sheet_extent(pieces, scale)
    plt.rcParams["svg.fonttype"] = "none"
    fig = plt.figure(figsize=(size[0] / 25.4, size[1] / 25.4))
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(lo[0], lo[0] + size[0])
    ax.set_ylim(lo[1], lo[1] + size[1])
    ax.set_axis_off()
    for piece in pieces:
        cut = np.vstack([piece.cut, piece.cut[:1]]) * scale
        sew = np.vstack([piece.sew, piece.sew[:1]]) * scale
        ax.plot(cut[:, 0], cut[:, 1], color="black", lw=0.8)
        ax.plot(sew[:, 0], sew[:, 1], color="black", lw=0.5, ls="--")
        for notch in piece.notches:
            ax.plot(*(notch.line * scale).T, color="black", lw=0.8)
        g = piece.grain * scale
        ax.annotate("", xy=g[1], xytext=g[0], arrowprops={"arrowstyle": "<->", "lw": 0.6})
        centre = piece.sew.mean(axis=0) * scale
        s = piece.settings
        ax.text(centre[0], centre[1], f"{piece.name}\nsize {s.size}  x{s.quantity}\n{s.fabric}",
                ha="center", va="center", fontsize=8)
    corner = lo + MARGIN_MM
    square = corner + np.array([[0, 0], [CHECK_MM, 0], [CHECK_MM, CHECK_MM], [0, CHECK_MM], [0, 0]])
    ax.plot(square[:, 0], square[:, 1], color="black", lw=0.6)
    ax.text(corner[0] + CHECK_MM / 2, corner[1] + CHECK_MM / 2, "10 cm check square\nprint at 100 %",
            ha="center", va="center", fontsize=7)
    ax.text(lo[0] + MARGIN_MM, lo[1] + size[1] - MARGIN_MM / 2, title, fontsize=8, va="center")
    for target in targets:
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format=Path(target).suffix.lstrip("."))
    plt.close(fig)
    return float(size[0]), float(size[1])
