"""A plate cut at its face's trim line: the part of its region inside the trim, developed.

A plate planned on a trimmed face (KCS's flat bottom keeps 1128 of its 2622 m2) may reach
past the trim, where another face carries the shell. Its hull patch is developed whole
(the grid of its region); the cut is made in the surface's parameters, where region and
trim are both polygons: their intersection, mapped to the development through the grid
(piecewise linear over its cells: exact where the development is affine in (u, v), as on a
plane, within the grid's second-order error elsewhere), is the plate the shop cuts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TrimCut:
    """outline: (N, 2) the cut plate's flat outline (placed coordinates, model units);
    outline_uv: (N, 2) the same in the surface's parameters; inside_faces: (F,) which grid
    triangles have their centroid inside the trim."""

    outline: np.ndarray
    outline_uv: np.ndarray
    inside_faces: np.ndarray


def cut_at_trim(trim, params: np.ndarray, placed: np.ndarray, faces: np.ndarray) -> TrimCut | None:
    """The region of a plate's grid (params (R, C, 2), its developed points ``placed``
    (R C, 2), triangles ``faces`` (F, 3)) cut by ``trim`` (outer loop, holes; (u, v)).
    None when the region lies inside the trim; a TrimCut with an empty outline when outside."""
    region, kept = region_in_trim(trim, params)
    if kept.area >= region.area * (1.0 - 1e-9):
        return None
    flat_params = params.reshape(-1, 2)
    centroids = flat_params[faces].mean(axis=1)
    inside = trim.inside(centroids[:, 0], centroids[:, 1])
    if kept.is_empty:
        return TrimCut(np.zeros((0, 2)), np.zeros((0, 2)), inside)
    if kept.geom_type != "Polygon":  # the trim leaves pieces: the plate is the largest
        kept = max(getattr(kept, "geoms", [kept]), key=lambda g: g.area)
    kept = _with_region_points(kept, region, params)
    uv = np.asarray(kept.exterior.coords)[:-1]
    flat = grid_map(flat_params, faces, placed, uv)
    return TrimCut(flat, uv, inside)


SNAP = 1e-9  # of the region's smaller extent in (u, v): a grid point this near the cut outline lies on it


def _with_region_points(kept, region, params: np.ndarray):
    """The cut outline with the region's boundary grid points that lie on it put back: where
    a trim loop runs along the region's side (a face's own edge: KVLCC2's centreline) the
    intersection keeps the loop's vertices, and the outline mapped to a curved development
    (a formed plate) would cut straight across its side between them."""
    import shapely

    from flatten.patch import grid_ring

    u0, v0, u1, v1 = region.bounds
    return shapely.snap(kept, shapely.MultiPoint(grid_ring(params)), SNAP * min(u1 - u0, v1 - v0))


def outside_trim(trim, params: np.ndarray) -> bool:
    """Whether a plate's region (grid params (R, C, 2)) lies wholly outside ``trim``: what
    :func:`cut_at_trim` finds before any development."""
    return region_in_trim(trim, params)[1].is_empty


def region_in_trim(trim, params: np.ndarray):
    """The region's polygon in (u, v) and its part inside the trim."""
    from shapely.geometry import Polygon

    from flatten.patch import grid_ring

    region = Polygon(grid_ring(params)).buffer(0)
    u0, v0, u1, v1 = region.bounds
    pad = max(u1 - u0, v1 - v0)  # a box around the region: the trim's loops are what cuts it
    return region, region.intersection(trim.polygon(u0 - pad, v0 - pad, u1 + pad, v1 + pad))


ROUND_OFF = 1e-6  # barycentric: a query this far outside a grid triangle lies on its edge


def grid_map(params: np.ndarray, faces: np.ndarray, values: np.ndarray, query: np.ndarray) -> np.ndarray:
    """``values`` (N, k) given at the grid's points ``params`` (N, 2), interpolated linearly
    over the grid's own triangles ``faces`` at ``query`` (M, 2); a query just outside the
    grid (round-off on its edge: a corner where a trim meets the region's boundary) takes
    the value on the triangle it misses least (:func:`_nearest_triangle`), one further out its
    nearest grid point's."""
    from matplotlib.tri import LinearTriInterpolator, Triangulation

    a, b, c = (params[faces[:, k]] for k in range(3))
    doubled = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    mesh = Triangulation(params[:, 0], params[:, 1], faces, mask=np.abs(doubled) <= 1e-300)
    out = np.column_stack([np.ma.filled(LinearTriInterpolator(mesh, values[:, k])(query[:, 0], query[:, 1]), np.nan)
                           for k in range(values.shape[1])])
    missing = ~np.all(np.isfinite(out), axis=1)
    if missing.any():
        good = np.abs(doubled) > 1e-300
        out[missing] = _nearest_triangle(params, faces[good], values, query[missing])
    return out


def _nearest_triangle(params: np.ndarray, faces: np.ndarray, values: np.ndarray, query: np.ndarray,
                      candidates: int = 8) -> np.ndarray:
    """``values`` (N, k) interpolated at queries (M, 2) outside the triangles ``faces`` (F, 3)
    of the points ``params`` (N, 2): on the triangle, of the ``candidates`` whose centroids lie
    nearest, whose barycentric coordinates go least negative, with those coordinates clipped
    to zero and scaled to sum to one (a query a round-off outside an edge takes the edge's
    value there; a grid point's value instead would be up to half a cell away). A query that
    misses every candidate by more than ROUND_OFF in barycentric terms takes its nearest
    grid point's value."""
    from scipy.spatial import cKDTree

    from flatten.trim import barycentric

    k = min(candidates, len(faces))
    _, near = cKDTree(params[faces].mean(axis=1)).query(query, k=k)
    tri = faces[np.asarray(near).reshape(len(query), k)]  # (M, k, 3)
    bary = barycentric(np.repeat(query, k, axis=0), params[tri].reshape(-1, 3, 2)).reshape(len(query), k, 3)
    pick = np.argmax(bary.min(axis=-1), axis=1)
    rows = np.arange(len(query))
    weights = np.clip(bary[rows, pick], 0.0, None)
    weights /= weights.sum(axis=1, keepdims=True)
    out = np.einsum("mj,mjk->mk", weights, values[tri[rows, pick]])
    far = bary[rows, pick].min(axis=1) < -ROUND_OFF
    if far.any():
        out[far] = values[cKDTree(params).query(query[far])[1]]
    return out
