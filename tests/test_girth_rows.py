"""Region grid rows even in the girth's 3D length (flatten.patch.region_grid, spacing
"length"), on surfaces whose girth parameter runs very unevenly: KVLCC2's loft of its main and
flat-of-bottom faces keeps 42 % of its girth parameter on the 29 mm wide flat at its aft end."""

import numpy as np
import pytest

from flatten.patch import region_grid
from flatten.surface import nurbs_surface

K = 0.5522847498  # cubic Bezier quarter circle


def flat_and_bilge(flat=0.03, share=0.42):
    """u: x from 0 to 10 (degree 2, the section 1.5 times as deep at x = 5 as at the ends),
    v: a flat ``flat`` wide on v in [0, share] (a knot of full multiplicity), then a bilge of
    radius 1 on [share, 1]: the girth parameter runs share / flat : (1 - share) / (pi / 2)
    = 38 times slower on the flat than on the bilge."""
    section = np.array([(0.0, 0.0), (flat / 3, 0.0), (2 * flat / 3, 0.0), (flat, 0.0),
                        (flat + K, 0.0), (flat + 1.0, 1.0 - K), (flat + 1.0, 1.0)])
    poles = np.array([[(x, y, depth * z) for y, z in section] for x, depth in ((0.0, 1.0), (5.0, 1.5), (10.0, 1.2))])
    return nurbs_surface(2, 3, poles, [0, 0, 0, 1, 1, 1], [0, 0, 0, 0, share, share, share, 1, 1, 1, 1], name="fb")


def crowded_bezier():
    """One cubic Bezier across the girth with its first three poles within 0.02 of each other
    (no knot inside: the parameter's speed changes smoothly, about 100-fold), straight along x."""
    section = np.array([(0.0, 0.0), (0.01, 0.0), (0.02, 0.0), (1.0, 1.0)])
    poles = np.array([[(x, y, z) for y, z in section] for x in (0.0, 10.0)])
    return nurbs_surface(1, 3, poles, [0, 0, 1, 1], [0, 0, 0, 0, 1, 1, 1, 1], name="crowded")


def const(value):
    return lambda s: np.full(np.shape(s), float(value))


def arcs_between_rows(surface, grid, dense=400):
    """3D length (R - 1, C) of the girth curve between consecutive rows of every column (the
    grid's columns share their s here: planes x = const on surfaces whose x is u's alone)."""
    s, g = grid.params[..., 0], grid.params[..., 1]
    t = np.linspace(0.0, 1.0, dense)
    gg = g[:-1, :, None] + t * (g[1:, :, None] - g[:-1, :, None])
    ss = np.broadcast_to(s[:-1, :, None], gg.shape)
    p = surface(ss.ravel(), gg.ravel()).reshape(*gg.shape, 3)
    return np.linalg.norm(np.diff(p, axis=2), axis=3).sum(axis=2)


X_PLANES = [(np.array([1.0, 0.0, 0.0]), 1.0), (np.array([1.0, 0.0, 0.0]), 9.0)]


# the crowded Bezier within 4e-3: its girth fractions are linear in length between samples
# 1/24 of the girth apart where the parameter's speed grows 100-fold from the seam
@pytest.mark.parametrize("make, seams, tol", [(flat_and_bilge, (0.0, 1.0), 2e-3), (flat_and_bilge, (0.2, 0.9), 2e-3),
                                              (crowded_bezier, (0.0, 1.0), 5e-3)])
def test_rows_are_even_in_3d_length_along_every_column(make, seams, tol):
    """Consecutive rows lie the same girth length apart in every column, within ``tol`` of it
    (rows even in the girth parameter: 38 or more times apart on the bilge than on the flat)."""
    surface = make()
    grid = region_grid(surface, 0, const(seams[0]), const(seams[1]), X_PLANES, rows=13, cols=17, probe=200,
                       spacing="length")
    assert grid is not None and grid.shape == (13, 17)
    np.testing.assert_allclose(grid.params[:, 0, 0], grid.params[0, 0, 0], rtol=0, atol=1e-12)
    arcs = arcs_between_rows(surface, grid)
    spread = (arcs.max(axis=0) - arcs.min(axis=0)) / arcs.mean(axis=0)
    assert spread.max() < tol
    # the chords too (the bilge turns 7.5 degrees between rows at most: chords within 0.1 % of arcs)
    chords = np.linalg.norm(np.diff(grid.points, axis=0), axis=2)
    assert ((chords.max(axis=0) - chords.min(axis=0)) / chords.mean(axis=0)).max() < tol + 3e-3


def test_parameter_spacing_keeps_the_rows_even_in_the_parameter():
    """spacing="parameter": the old rows, g = g_lo + w (g_hi - g_lo) with w = PatchGrid.rows,
    crowded on the flat (8 of 13 rows within its 0.03)."""
    surface = flat_and_bilge()
    grid = region_grid(surface, 0, const(0.0), const(1.0), X_PLANES, rows=13, cols=17, probe=200,
                       spacing="parameter")
    np.testing.assert_allclose(grid.params[..., 1], grid.rows[:, None] * np.ones(17), rtol=0, atol=1e-15)
    assert (grid.params[:, 0, 1] <= 0.42).sum() == 6
    with pytest.raises(ValueError):
        region_grid(surface, 0, const(0.0), const(1.0), X_PLANES, rows=13, cols=17, spacing="chord")


def test_the_grid_lies_on_the_surface_between_its_seams_and_butts():
    """Every point is the surface's at its parameters; the first and last rows are the seams
    (to the bit), the rows' fractions of the girth length are PatchGrid.rows, and the rows end
    on two slanted planes (to 1e-12) with their spacing as even there as inside."""
    surface = flat_and_bilge()
    normal = np.array([1.0, 0.3, 0.2]) / np.linalg.norm([1.0, 0.3, 0.2])
    planes = [(normal, 1.5), (normal, 8.0)]
    lo, hi = (lambda s: 0.1 + 0.01 * s), (lambda s: 0.95 - 0.02 * s)
    grid = region_grid(surface, 0, lo, hi, planes, rows=11, cols=15, probe=300, spacing="length")
    assert grid is not None and grid.shape == (11, 15) and grid.ends.all()
    s, g = grid.params[..., 0], grid.params[..., 1]
    np.testing.assert_array_equal(grid.points.reshape(-1, 3), surface(s.ravel(), g.ravel()))
    np.testing.assert_array_equal(g[0], lo(s[0]))
    np.testing.assert_array_equal(g[-1], lo(s[-1]) + 1.0 * (hi(s[-1]) - lo(s[-1])))
    np.testing.assert_allclose(grid.points[:, 0] @ normal, 1.5, rtol=0, atol=1e-12)
    np.testing.assert_allclose(grid.points[:, -1] @ normal, 8.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(grid.rows, np.linspace(0.0, 1.0, 11), rtol=0, atol=0)
    # each point's share of its column's girth curve, measured densely
    t = np.linspace(0.0, 1.0, 4001)
    for j in range(15):
        sj = s[:, j]  # the rows' ends differ in s: each point on its own girth curve
        gg = lo(sj)[:, None] + t * (hi(sj) - lo(sj))[:, None]
        p = surface(np.repeat(sj, len(t)), gg.ravel()).reshape(len(sj), len(t), 3)
        cum = np.concatenate([np.zeros((len(sj), 1)), np.cumsum(np.linalg.norm(np.diff(p, axis=1), axis=2), axis=1)],
                             axis=1)
        w = (g[:, j] - lo(sj)) / (hi(sj) - lo(sj))
        share = np.array([np.interp(wk, t, ck) / ck[-1] for wk, ck in zip(w, cum)])
        np.testing.assert_allclose(share, grid.rows, rtol=0, atol=1e-3)


def test_a_girth_curve_without_length_keeps_the_parameter():
    """A column whose seams meet (a collapsed seam end) has no length to share: its fractions
    are the parameter's, and finite."""
    from flatten.patch import girth_fractions

    surface = flat_and_bilge()
    s = np.array([0.2, 0.5])
    w = girth_fractions(surface, 0, s, np.array([0.3, 0.0]), np.array([0.3, 1.0]),
                        np.array([[0.0, 0.25, 1.0], [0.0, 0.25, 1.0]]))
    np.testing.assert_array_equal(w[0], [0.0, 0.25, 1.0])
    assert w[1, 0] == 0.0 and w[1, 2] == 1.0 and 0.42 < w[1, 1] < 1.0
