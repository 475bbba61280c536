"""The preview PNG of a textile piece, in the sewing room's terms: cut line, sew line, the
seam allowance between them, notches, grain line, and the piece's name, size, quantity
and fabric, at true aspect (equal axes, model units). Rulings appear only when the run
writes them as internal lines, and are called that."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as PolygonPatch

from ..plots import _fitted_axes, _save
from .pieces import TextilePiece, label_anchor

LEGEND = ("cut line", "sew line", "seam allowance", "notches", "grain line")


def textile_preview_figure(piece: TextilePiece, units: str) -> Figure:
    s = piece.settings
    cut = np.vstack([piece.cut, piece.cut[:1]])
    sew = np.vstack([piece.sew, piece.sew[:1]])
    fig, ax = _fitted_axes(cut, 9.0, (0.8, 0.3, 0.6, 0.75), 6.0)
    # the allowance is the band between the cut and the sew line
    ax.add_patch(PolygonPatch(piece.cut, closed=True, facecolor="#f2dfb8", edgecolor="none", label=LEGEND[2]))
    ax.add_patch(PolygonPatch(piece.sew, closed=True, facecolor="white", edgecolor="none"))
    if len(piece.internal_lines):
        ax.add_collection(LineCollection(piece.internal_lines, colors="0.75", linewidths=0.4,
                                         label="internal lines (rulings)"))
    ax.plot(cut[:, 0], cut[:, 1], color="black", lw=1.3, label=LEGEND[0])
    ax.plot(sew[:, 0], sew[:, 1], color="tab:blue", lw=0.9, ls=(0, (5, 3)), label=LEGEND[1])
    if piece.notches:
        ax.add_collection(LineCollection([n.line for n in piece.notches], colors="crimson", linewidths=2.0,
                                         label=LEGEND[3]))
    else:
        ax.plot([], [], color="crimson", lw=2.0, label=LEGEND[3] + " (none)")
    g = piece.grain
    ax.annotate("", xy=tuple(g[1]), xytext=tuple(g[0]), arrowprops={"arrowstyle": "<|-|>", "lw": 1.0,
                                                                     "color": "darkgreen"})
    ax.plot([], [], color="darkgreen", lw=1.0, label=LEGEND[4])
    lines = [piece.name, f"size {s.size}, cut {s.quantity}", s.fabric]
    # model units per point of text: equal axes fit the larger of the two spans
    pos = ax.get_position()
    span = np.ptp(cut, axis=0)
    per_pt = max(span[0] / (pos.width * fig.get_figwidth()), span[1] / (pos.height * fig.get_figheight())) / 72.0
    # the text inside the sew line, clear of the grain line and the notches, as large as fits
    for size in (8.0, 6.5, 5.0):
        w, h = 0.7 * size * max(map(len, lines)) * per_pt, 1.3 * size * len(lines) * per_pt
        at = label_anchor(piece, h, w, 0.3 * size * per_pt)
        if at is not None:
            ax.text(at[0], at[1], "\n".join(lines), ha="center", va="center", fontsize=size, linespacing=1.2)
            break
    widths = sorted(set(piece.allowances))
    ax.set_title(f"{piece.name}: size {s.size}, cut {s.quantity} in {s.fabric}; seam allowance "
                 f"{' / '.join(f'{w:g}' for w in widths)} {units}; {len(piece.notches)} notch(es)",
                 fontsize=9, loc="left", y=1.01)
    ax.set_xlabel(units)
    ax.autoscale_view()
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.06), ncols=3, fontsize=7, frameon=False)
    return fig


def textile_preview_png(target: str | Path, piece: TextilePiece, units: str) -> None:
    _save(textile_preview_figure(piece, units), target)
