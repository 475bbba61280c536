"""The shell's class picture (``NAME_classes.png``): every plate visible, the legend clear of them."""

from itertools import pairwise

import numpy as np
import pytest

from pipeline.hull.hullplots import CLASS_COLOURS, class_figure, draw_class_hull


def long_hull_rings(length=160000.0, depth=9000.0, beam=12000.0, strakes=8, butts=20):
    """Plates of a box-like hull as long and as slender as the 160 m hull, rings (5, 3) in mm:
    strakes up the side (y = beam, z rising) and across the bottom (z = 0, y rising)."""
    rings = []
    xs = np.linspace(0.0, length, butts + 1)
    for x0, x1 in pairwise(xs):
        for z0, z1 in pairwise(np.linspace(0.0, depth, strakes + 1)):
            rings.append(np.array([[x0, beam, z0], [x1, beam, z0], [x1, beam, z1], [x0, beam, z1], [x0, beam, z0]]))
        for y0, y1 in pairwise(np.linspace(0.0, beam, strakes + 1)):
            rings.append(np.array([[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0], [x0, y0, 0.0]]))
    return rings


@pytest.mark.parametrize("length", [160000.0, 40000.0])
def test_the_legend_covers_no_plate_and_the_views_fill_the_page(length):
    rings = long_hull_rings(length)
    colours = [list(CLASS_COLOURS.values())[k % len(CLASS_COLOURS)] for k in range(len(rings))]
    areas = {k: 10.0 * (n + 1) for n, k in enumerate(CLASS_COLOURS)}
    fig = class_figure(rings, colours, areas, "mm", "a hull")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legend = fig.legends[0].get_window_extent(renderer)
    views = [ax.get_window_extent(renderer) for ax in fig.axes]
    assert not any(view.overlaps(legend) for view in views)
    # every class is named with its share, in the order of the colours
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert [t.split(":")[0] for t in texts] == ["flat", "developable (strip)", "rolled (patch within tol.)", "formed",
                                                "failed"]
    assert texts[0].endswith("(6.7%)") and texts[-1].endswith("(33.3%)")
    # true aspect, and the two views take most of the page's height (a fixed 7-inch page left
    # the 160 m hull two thin strips in white)
    for ax in fig.axes:
        x0, x1 = ax.get_xlim()
        y0, y1 = ax.get_ylim()
        box = ax.get_window_extent(renderer)
        assert box.height / box.width == pytest.approx((y1 - y0) / (x1 - x0), rel=0.02)
    assert sum(v.height for v in views) >= 0.4 * fig.bbox.height


def test_the_picture_is_written_whole(tmp_path):
    rings = long_hull_rings()
    target = tmp_path / "hull_classes.png"
    draw_class_hull(target, rings, ["#4caf50"] * len(rings), {k: 1.0 for k in CLASS_COLOURS}, "mm", None)
    assert target.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["hull_classes.png"]
