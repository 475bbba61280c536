"""Closest points on a NURBS surface, with the search structure built once per surface.

A grid of surface samples in a KD-tree gives the starting parameters; Gauss-Newton on
(u, v) with central-difference derivatives polishes them. Building the grid and the tree
is the expensive part, so one :class:`SurfaceDistance` serves every plate of a surface.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from scipy.spatial import cKDTree

from .surface import NurbsSurface


# a Gauss-Newton move below this fraction of the domain: the next one is round-off (the
# distance is then exact to round-off; the closest parameters keep all 12 steps)
CONVERGED = 1e-9


class SurfaceDistance:
    """Distances and closest parameters of points to one surface (or the nearest of several).

    surfaces : one NurbsSurface or a sequence of them (a hull split into patches)
    grid : samples per parameter direction of the seed grid
    """

    def __init__(self, surfaces, grid: int = 120):
        self.surfaces = (surfaces,) if isinstance(surfaces, NurbsSurface) else tuple(surfaces)
        self.grid = int(grid)

    @cached_property
    def _seeds(self) -> list[tuple[np.ndarray, np.ndarray, cKDTree]]:
        out = []
        for surface in self.surfaces:
            u = np.linspace(*surface.domain_u, self.grid)
            v = np.linspace(*surface.domain_v, self.grid)
            uu, vv = np.meshgrid(u, v, indexing="ij")
            samples = surface.grid(u, v).reshape(-1, 3)
            out.append((uu.ravel(), vv.ravel(), cKDTree(samples)))
        return out

    def closest(self, points: np.ndarray, index: int = 0, iterations: int = 12,
                converged: float | None = None, nearest: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Closest parameters (N, 2) on surface ``index`` of each point (N, 3) and the
        distances (N,). With ``converged`` (a fraction of the domain), a point whose move
        falls below it takes one more step and stops (the others go on): the many points
        that settle in a few steps no longer wait for the slowest one. ``nearest``: each
        point's nearest seed sample (N,) on that surface, when already looked up."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        surface = self.surfaces[index]
        uu, vv, tree = self._seeds[index]
        idx = tree.query(points)[1] if nearest is None else nearest
        pu, pv = uu[idx], vv[idx]
        hu = 1e-7 * np.ptp(surface.domain_u)
        hv = 1e-7 * np.ptp(surface.domain_v)
        limit_u = np.inf if converged is None else converged * np.ptp(surface.domain_u)
        limit_v = np.inf if converged is None else converged * np.ptp(surface.domain_v)
        active = np.arange(len(points))
        last_step = np.zeros(len(points), dtype=bool)  # the point's move was below the limit
        for _ in range(iterations):
            if not len(active):
                break
            u, v, n = pu[active], pv[active], len(active)
            # the point and its four neighbours in one evaluation (the surface is evaluated
            # point by point: the batch changes nothing but the number of calls)
            at = surface(np.concatenate([u, u + hu, u - hu, u, u]), np.concatenate([v, v, v, v + hv, v - hv]))
            s = at[:n]
            su = (at[n:2 * n] - at[2 * n:3 * n]) / (2 * hu)
            sv = (at[3 * n:4 * n] - at[4 * n:]) / (2 * hv)
            r = s - points[active]
            a11, a12, a22 = (np.einsum("ij,ij->i", x, y) for x, y in ((su, su), (su, sv), (sv, sv)))
            b1, b2 = np.einsum("ij,ij->i", su, r), np.einsum("ij,ij->i", sv, r)
            det = a11 * a22 - a12**2
            # a degenerate point of the surface (a collapsed edge) has det = 0: keep the seed there
            ok = np.abs(det) > 1e-300
            du = np.where(ok, (a22 * b1 - a12 * b2) / np.where(ok, det, 1), 0)
            dv = np.where(ok, (a11 * b2 - a12 * b1) / np.where(ok, det, 1), 0)
            pu[active] = np.clip(u - du, *surface.domain_u)
            pv[active] = np.clip(v - dv, *surface.domain_v)
            if converged is not None:
                # the difference Jacobian is good to ~1e-9: the step after a small one is round-off
                done = last_step[active]
                last_step[active] = (np.abs(du) <= limit_u) & (np.abs(dv) <= limit_v)
                active = active[~done]
        return np.column_stack([pu, pv]), np.linalg.norm(surface(pu, pv) - points, axis=1)

    @cached_property
    def _reach(self) -> np.ndarray:
        """(S,) per surface, a bound on the distance of any of its points from its nearest
        seed sample: the longest diagonal of the sample grid's cells."""
        out = []
        for surface in self.surfaces:
            u = np.linspace(*surface.domain_u, self.grid)
            v = np.linspace(*surface.domain_v, self.grid)
            p = surface.grid(u, v)
            diagonals = (np.linalg.norm(p[1:, 1:] - p[:-1, :-1], axis=-1), np.linalg.norm(p[1:, :-1] - p[:-1, 1:], axis=-1))
            out.append(max(float(d.max(initial=0.0)) for d in diagonals))
        return np.array(out)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Distance (N,) of each point (N, 3) to the nearest of the surfaces. Each point is
        searched first on the surface of its nearest seed sample, then only on the surfaces
        whose nearest sample, less their grid's reach, lies within the distance found: no
        point of the others is nearer (a hull of several faces: each point is near one or
        two), and the least is what searching them all would give."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if len(self.surfaces) == 1:
            return self.closest(points, 0, converged=CONVERGED)[1]
        seeds = _SeedDistances(self, points)
        first = np.argmin(seeds.distance, axis=0)
        best = np.full(len(points), np.inf)
        for k in range(len(self.surfaces)):
            mine = np.flatnonzero(first == k)
            if len(mine):
                best[mine] = self.closest(points[mine], k, converged=CONVERGED, nearest=seeds.nearest[k, mine])[1]
        for k in range(len(self.surfaces)):
            seeds.look_up(k, np.flatnonzero((first != k) & (seeds.lower[k] - self._reach[k] <= best)))
            need = np.flatnonzero((first != k) & (seeds.distance[k] - self._reach[k] <= best))
            if len(need):
                found = self.closest(points[need], k, converged=CONVERGED, nearest=seeds.nearest[k, need])[1]
                best[need] = np.minimum(best[need], found)
        return best

    @cached_property
    def _boxes(self) -> np.ndarray:
        """(S, 2, 3) the bounding box of each surface's seed samples."""
        return np.array([(tree.data.min(axis=0), tree.data.max(axis=0)) for _, _, tree in self._seeds])


class _SeedDistances:
    """The distance (S, N) of each point to each surface's nearest seed sample and that
    sample (S, N), looked up only where they can matter: a point far from a surface's box of
    samples (a transom's flat samples seen from the hull's length, where a KD-tree search
    visits most of them) is looked up there only when the surface may be its nearest or
    lie within reach of its distance; elsewhere the distance reads inf. ``lower`` (S, N)
    bounds the distances from below (the distance to the box, less round-off)."""

    def __init__(self, distance: SurfaceDistance, points: np.ndarray):
        self.seeds, self.points = distance._seeds, points
        lo, hi = distance._boxes[:, 0], distance._boxes[:, 1]
        outside = np.maximum(np.maximum(lo[:, None, :] - points[None], points[None] - hi[:, None, :]), 0.0)
        self.lower = np.linalg.norm(outside, axis=2) * (1.0 - 1e-9)
        self.distance = np.full(self.lower.shape, np.inf)
        self.nearest = np.zeros(self.lower.shape, dtype=np.int64)
        nearest_box = np.argmin(self.lower, axis=0)
        for k in np.unique(nearest_box):  # the nearest box's surface: an upper bound on the least
            self.look_up(int(k), np.flatnonzero(nearest_box == k))
        least = self.distance.min(axis=0)
        for k in range(len(self.seeds)):  # every surface that may be nearer (or as near)
            self.look_up(k, np.flatnonzero(self.lower[k] <= least))

    def look_up(self, k: int, rows: np.ndarray) -> None:
        """Surface k's nearest samples of the points ``rows`` not looked up there yet (a
        looked-up distance is finite)."""
        rows = rows[np.isinf(self.distance[k, rows])]
        if len(rows):
            self.distance[k, rows], self.nearest[k, rows] = self.seeds[k][2].query(self.points[rows])


def closest_with_sides(distance: SurfaceDistance, points: np.ndarray, index: int = 0,
                       samples: int = 2001) -> tuple[np.ndarray, np.ndarray]:
    """Closest parameters (N, 2) on surface ``index`` of ``distance`` of each point (N, 3)
    and the distances (N,): the better of :meth:`SurfaceDistance.closest` and a search along
    the surface's four sides (``samples`` points on each, then finer around the nearest,
    twice). A search that reaches a collapsed side (a pole row, where the surface has no
    tangent plane) stays there: on DTMB 5415's stern face up to 76 mm from a foot on its side."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    surface = distance.surfaces[index]
    params, dist = distance.closest(points, index)
    rows = np.arange(len(points))
    for param, end in ((0, 0), (0, 1), (1, 0), (1, 1)):
        fixed = (surface.domain_u, surface.domain_v)[param][end]
        lo, hi = (surface.domain_u, surface.domain_v)[1 - param]
        along = np.linspace(lo, hi, samples)
        step = along[1] - along[0]

        def at(s, param=param, fixed=fixed):
            uv = (np.full(s.shape, fixed), s) if param == 0 else (s, np.full(s.shape, fixed))
            return surface(uv[0].ravel(), uv[1].ravel()).reshape(*s.shape, 3)

        gap, nearest = cKDTree(at(along)).query(points)
        best = along[nearest]
        for _ in range(2):  # finer samples around the nearest
            candidates = np.clip(best[:, None] + step * np.linspace(-1.0, 1.0, 41)[None, :], lo, hi)
            d = np.linalg.norm(at(candidates) - points[:, None, :], axis=-1)
            k = np.argmin(d, axis=1)
            best, gap = candidates[rows, k], d[rows, k]
            step /= 20.0
        better = gap < dist
        side = np.column_stack([np.full(len(points), fixed), best] if param == 0 else [best, np.full(len(points), fixed)])
        params[better], dist[better] = side[better], gap[better]
    return params, dist
