"""The cut line of an allowance (pipeline.shop.allowance.cut_outline) on developed plates whose
edges are arcs: the same outline whatever the round-off of the net outline, which a plate's
rulings change from one solver version or machine to the next."""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import given, seed, settings
from hypothesis import strategies as st

from pipeline.shop.allowance import cut_outline, edge_runs


def sector(r_c: float, r_d: float, a0: float, a1: float, n: int, shift) -> tuple[np.ndarray, tuple]:
    """An annular sector's outline (mm), as a cone's plate develops: the c arc, the end
    radius, the d arc back, the start radius; one edge name per segment."""
    a = np.linspace(a0, a1, n)
    c = np.column_stack([r_c * np.cos(a), r_c * np.sin(a)])
    d = np.column_stack([r_d * np.cos(a), r_d * np.sin(a)])[::-1]
    edges = ("c",) * (n - 1) + ("end",) + ("d",) * (n - 1) + ("start",)
    return np.vstack([c, d]) + np.asarray(shift), edges


@seed(20261123)
@settings(max_examples=150, deadline=None)
@given(r_c=st.floats(1000.0, 4000.0), r_d=st.floats(4500.0, 8000.0), a0=st.floats(0.0, 0.5),
       a1=st.floats(0.7, 1.5), n=st.integers(5, 60), shift=st.tuples(st.floats(-1e4, 1e4), st.floats(-1e4, 1e4)),
       widths=st.fixed_dictionaries({"c": st.sampled_from([0.0, 5.0]), "d": st.sampled_from([0.0, 25.0]),
                                     "start": st.sampled_from([0.0, 40.0]), "end": st.sampled_from([0.0, 15.0])}).filter(
           lambda w: any(w.values())),
       exponents=st.lists(st.floats(-14.0, -11.0), min_size=5, max_size=5))
def test_cut_line_does_not_move_with_the_round_off_of_the_net_outline(r_c, r_d, a0, a1, n, shift, widths,
                                                                       exponents):
    """Scaled by 1 +- 1e-14 .. 1e-11 (what another ruling round-off gives), the cut line
    keeps its area, stays one valid ring around the net and keeps every edge's vertices
    away from the corners at that edge's allowance. Before the corner wedges overlapped
    their neighbours, 4 of 400 such plates lost a corner wedge or pinched the cut line onto
    a net corner."""
    points, edges = sector(r_c, r_d, a0, a1, n, shift)
    reference = shapely.Polygon(cut_outline(points, edges, widths))
    assert reference.is_valid
    for k, exponent in enumerate(exponents):
        scaled = points * (1.0 + (-1.0) ** k * 10.0 ** exponent)
        cut = cut_outline(scaled, edges, widths)
        polygon = shapely.Polygon(cut)
        assert polygon.is_valid
        assert abs(polygon.area - reference.area) <= 1e-9 * reference.area
        assert polygon.buffer(1e-6).contains(shapely.Polygon(scaled))
        ring = shapely.LinearRing(cut)
        for name, segments in edge_runs(edges):
            if len(segments) < 3:
                continue
            inner = scaled[segments[1:-1]]
            far = np.min([np.linalg.norm(inner - scaled[segments[0]], axis=1),
                          np.linalg.norm(inner - scaled[(segments[-1] + 1) % len(scaled)], axis=1)], axis=0)
            keep = far > 4.0 * max(widths.values())
            if not keep.any():
                continue
            # a convex arc's vertex lies its allowance from the cut line; a concave one's
            # (the c arc, inner) at least that, the neighbouring offsets crossing inside
            distance = shapely.distance(shapely.points(inner[keep]), ring)
            if name == "d":
                np.testing.assert_allclose(distance, widths[name], atol=1e-3 * max(widths[name], 1.0))
            else:
                assert np.all(distance >= widths[name] - 1e-6)
