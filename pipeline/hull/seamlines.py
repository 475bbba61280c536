"""Seams that follow the hull's direction of least curvature (``plan.seams: least_curvature``).

A strake whose seams run along the direction of least normal curvature has its long edges
along the rulings a developable strip wants there (on a cylindrical midbody, the
generators). Each interior seam starts where the iso-parameter seam of the uniform layout
crosses the widest section and is traced forward and aft in the surface's parameters
(s along the hull, g round the girth) on dg/ds of the least-curvature direction:

- where that direction is more than ``MAX_ANGLE`` from the hull's length (the bow, the stern
  where lines turn up) or undefined (nearly umbilic, nearly flat: a flat bottom's
  directions are noise), the seam keeps its girth parameter (runs as an iso line);
- a seam stays within ``MAX_SHIFT`` of its iso-line spacing of its iso line, so strakes
  neither cross nor narrow below half their width.

The first and last seams are the surface's edges (keel, deck) and stay iso. Which layout is
better is measured (bench_hull.py --seams), not assumed.
"""

from __future__ import annotations

import numpy as np

from flatten.patch import principal_frame

from .region import Girth

MAX_ANGLE = np.radians(30.0)  # largest angle of a seam to the hull's length
MAX_SHIFT = 0.25  # largest departure from the iso seam, as a share of the iso seams' spacing
ANISOTROPY = 0.3  # (|k2| - |k1|) / |k2| below this: no preferred direction
STEPS = 160


def least_curvature_slope(surface, axis: int, s: np.ndarray, g: np.ndarray) -> np.ndarray:
    """dg/ds (N,) of the direction of least normal curvature at (s, g) (N,), 0 where that
    direction is undefined or more than MAX_ANGLE from the s-direction."""
    u, v = (s, g) if axis == 0 else (g, s)
    k, d, su, sv = principal_frame(surface, u, v)  # d: (du, dv) of least curvature
    dot = lambda a, b: np.einsum("ij,ij->i", a, b)  # noqa: E731
    ds_, dg_ = (d[:, 0], d[:, 1]) if axis == 0 else (d[:, 1], d[:, 0])
    t_s, t_g = (su, sv) if axis == 0 else (sv, su)
    d3 = ds_[:, None] * t_s + dg_[:, None] * t_g
    cos = np.abs(dot(d3, t_s)) / np.maximum(np.linalg.norm(d3, axis=1) * np.linalg.norm(t_s, axis=1), 1e-300)
    defined = np.abs(k[:, 1]) > 0
    defined &= (np.abs(k[:, 1]) - np.abs(k[:, 0])) >= ANISOTROPY * np.abs(k[:, 1])
    usable = defined & (cos >= np.cos(MAX_ANGLE)) & (np.abs(ds_) > 0)
    return np.where(usable, dg_ / np.where(np.abs(ds_) > 0, ds_, 1.0), 0.0)


def least_curvature_seams(surface, axis: int, iso_values: list[float], s_start: float) -> list[Girth]:
    """Seams (Girth, s -> g) from the iso values at s_start, traced both ways (RK2 steps)."""
    sdom = surface.domain_u if axis == 0 else surface.domain_v
    gdom = surface.domain_v if axis == 0 else surface.domain_u
    iso = np.asarray(iso_values, dtype=float)
    seams = [Girth.iso(iso[0])]
    s_fwd = np.linspace(s_start, sdom[1], STEPS)
    s_bwd = np.linspace(s_start, sdom[0], STEPS)
    inner = iso[1:-1]
    if not len(inner):
        return [Girth.iso(v) for v in iso]
    spacing = np.minimum(np.diff(iso)[:-1], np.diff(iso)[1:])
    lo, hi = inner - MAX_SHIFT * spacing, inner + MAX_SHIFT * spacing
    tracks = []
    for path in (s_fwd, s_bwd):
        g = inner.copy()
        out = [g.copy()]
        for a, b in zip(path[:-1], path[1:]):
            h = b - a
            k1 = least_curvature_slope(surface, axis, np.full(len(g), a), g)
            mid = np.clip(g + 0.5 * h * k1, lo, hi)
            k2 = least_curvature_slope(surface, axis, np.full(len(g), a + 0.5 * h), mid)
            g = np.clip(g + h * k2, max(gdom[0], -np.inf), gdom[1])
            g = np.clip(g, lo, hi)
            out.append(g.copy())
        tracks.append((path, np.array(out)))
    (sf, gf), (sb, gb) = tracks
    s_all = np.concatenate([sb[::-1], sf[1:]])
    g_all = np.concatenate([gb[::-1], gf[1:]], axis=0)
    seams += [Girth(tuple(float(x) for x in s_all), tuple(float(x) for x in g_all[:, k])) for k in range(len(inner))]
    seams.append(Girth.iso(iso[-1]))
    return seams
