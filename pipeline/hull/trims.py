"""IGES trims of a hull surface (entities 143/141 and 144/142) as loops in its parameters.

A trimmed surface keeps only the part of its entity-128 rectangle inside its outer boundary
loop (and outside any inner loop). The loops are read from their parameter-space curves
(entity 126 with z = 0: (u, v) of the surface), each sampled finely and joined in the order
and sense the boundary gives. A boundary without parameter-space curves is reported as
unread (the plan then states that the trim is ignored).

The plan honours a trim by area: a plate whose region lies wholly outside the trimmed surface
is dropped (another surface of the hull covers that shell: KCS's and KVLCC2's flat-bottom
surfaces run on under the main hull), a plate partly outside it keeps its untrimmed region
and reports the share inside (``HullPlate.inside_trim``), and the shell area counts only
the part inside.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..io.iges import IgesError, IgesFile, iges_curve

SAMPLES_PER_CURVE = 200


@dataclass(frozen=True)
class Trim:
    """Outer loop (N, 2) and inner loops of a surface's trimmed region, in (u, v)."""

    surface_directory: int
    outer: np.ndarray | None  # None: the outer boundary is the whole parameter rectangle
    inner: tuple
    entity: int  # 143 or 144

    def inside(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        from matplotlib.path import Path as MplPath

        pts = np.column_stack([np.ravel(u), np.ravel(v)])
        keep = np.ones(len(pts), dtype=bool)
        if self.outer is not None:
            keep &= MplPath(self.outer).contains_points(pts, radius=_radius(self.outer))
        for loop in self.inner:
            keep &= ~MplPath(loop).contains_points(pts)
        return keep.reshape(np.shape(u))

    def polygon(self, u0: float, v0: float, u1: float, v1: float):
        """The trimmed region within the box [u0, u1] x [v0, v1] of (u, v) as a shapely
        geometry: the box with the outer loop, less the holes."""
        import shapely

        region = shapely.box(u0, v0, u1, v1)
        if self.outer is not None:
            region = valid_polygon(self.outer).intersection(region)
        for loop in self.inner:
            region = region.difference(valid_polygon(loop))
        return region

    def face_region(self, surface):
        """The trimmed region of ``surface`` within its parameter rectangle (:meth:`polygon`)."""
        (u0, u1), (v0, v1) = surface.domain_u, surface.domain_v
        return self.polygon(u0, v0, u1, v1)

    def covers_rectangle(self, domain_u, domain_v, tol: float = 1e-6) -> bool:
        """The outer loop is the parameter rectangle itself and there is no hole."""
        if self.inner:
            return False
        if self.outer is None:
            return True
        su, sv = np.ptp(domain_u), np.ptp(domain_v)
        u, v = self.outer[:, 0], self.outer[:, 1]
        on_edge = ((np.abs(u - domain_u[0]) <= tol * su) | (np.abs(u - domain_u[1]) <= tol * su)
                   | (np.abs(v - domain_v[0]) <= tol * sv) | (np.abs(v - domain_v[1]) <= tol * sv))
        return bool(on_edge.all())


def sub_surface(surface, u_range, v_range, name: str | None = None):
    """The exact piece of a NURBS surface over [u0, u1] x [v0, v1] of its parameters (knot
    insertion to full multiplicity at the cuts), with the same parameters: a trim's loops in
    (u, v) hold on it unchanged."""
    from scipy.interpolate import BSpline

    from flatten.nurbs import spline_piece
    from flatten.surface import nurbs_surface

    hom = np.concatenate([surface.poles * surface.weights[..., None], surface.weights[..., None]], axis=-1)
    knots = []
    for axis, (lo, hi), t, p in ((0, u_range, surface.knots_u, surface.degree_u),
                                 (1, v_range, surface.knots_v, surface.degree_v)):
        rows = np.moveaxis(hom, axis, 0)
        shape = rows.shape
        coefficients, piece_knots = spline_piece(BSpline(t, rows.reshape(shape[0], -1), p), lo, hi)
        hom = np.moveaxis(coefficients.reshape(-1, *shape[1:]), 0, axis)
        knots.append(piece_knots)
    return nurbs_surface(surface.degree_u, surface.degree_v, hom[..., :3] / hom[..., 3:], knots[0], knots[1],
                         hom[..., 3], name=name or surface.name)


def valid_polygon(points: np.ndarray):
    """A closed loop (N, 2) as a valid shapely polygon (a self-touching loop made valid,
    its slivers of no area dropped)."""
    import shapely

    poly = shapely.Polygon(points)
    if not poly.is_valid:
        poly = shapely.make_valid(poly)
        poly = shapely.union_all([g for g in getattr(poly, "geoms", [poly]) if g.area > 0]) \
            if poly.geom_type == "GeometryCollection" else poly
    return poly


def _radius(loop: np.ndarray) -> float:
    # matplotlib's sign convention for a tolerant containment test depends on orientation
    area = 0.5 * float(np.sum(loop[:-1, 0] * loop[1:, 1] - loop[1:, 0] * loop[:-1, 1]))
    return 1e-9 if area > 0 else -1e-9


def _param_curve_points(iges: IgesFile, directory: int, reverse: bool = False) -> np.ndarray:
    entity = _by_directory(iges, directory)
    if entity.type != 126:
        raise IgesError(f"{iges.path}: trim curve D{directory} is entity {entity.type}; only 126 is read")
    curve = iges_curve(iges, entity, 1.0, f"trim D{directory}")
    pts = curve(np.linspace(*curve.domain, SAMPLES_PER_CURVE))[:, :2]
    return pts[::-1] if reverse else pts


def _by_directory(iges: IgesFile, directory: int):
    for e in iges.entities:
        if e.directory == directory:
            return e
    raise IgesError(f"{iges.path}: no entity at D{directory}")


def _loop_141(iges: IgesFile, directory: int) -> np.ndarray:
    """A boundary entity 141: TYPE, PREF, SPTR, N, then per curve CRVPT, SENSE, K, PSCPT(K)."""
    p = _by_directory(iges, directory).parameters
    n, k, pieces = int(p[4]), 5, []
    for _ in range(n):
        sense, count = int(p[k + 1]), int(p[k + 2])
        params = [int(x) for x in p[k + 3:k + 3 + count]]
        k += 3 + count
        if not params:
            raise IgesError(f"{iges.path}: boundary D{directory} has a curve without a parameter-space curve")
        pieces += [_param_curve_points(iges, q, False) for q in params]
    return _chain(pieces)


def _chain(pieces: list) -> np.ndarray:
    """Join curve pieces into one loop, each turned to start where the previous one ends
    (exporters disagree on what a boundary's SENSE flag says of its parameter curves)."""
    loop = [pieces[0]]
    if len(pieces) > 1:
        nxt = pieces[1]
        ends = [np.linalg.norm(pieces[0][e] - nxt[f]) for e in (0, -1) for f in (0, -1)]
        if int(np.argmin(ends)) < 2:  # the first piece runs backwards
            loop = [pieces[0][::-1]]
    for piece in pieces[1:]:
        end = loop[-1][-1]
        loop.append(piece if np.linalg.norm(piece[0] - end) <= np.linalg.norm(piece[-1] - end) else piece[::-1])
    return np.vstack(loop)


def _loop_142(iges: IgesFile, directory: int) -> np.ndarray:
    """A curve on a parametric surface 142: CRTN, SPTR, BPTR (parameter curve), CPTR, PREF."""
    p = _by_directory(iges, directory).parameters
    bptr = int(p[3])
    if bptr == 0:
        raise IgesError(f"{iges.path}: curve on surface D{directory} has no parameter-space curve")
    return _param_curve_points(iges, bptr, False)


def read_trim(iges: IgesFile, surface_directory: int) -> Trim | None:
    """The trim of the entity-128 surface at ``surface_directory``; None when untrimmed.
    Raises IgesError when the trim is there but cannot be read."""
    for e in iges.entities:
        p = e.parameters
        if e.type == 143 and len(p) > 3 and p[2].strip() == str(surface_directory):
            count = int(p[3])
            loops = [_loop_141(iges, int(d)) for d in p[4:4 + count]]
            return Trim(surface_directory, loops[0], tuple(loops[1:]), 143)
        if e.type == 144 and len(p) > 4 and p[1].strip() == str(surface_directory):
            n1, n2 = int(p[2]), int(p[3])
            outer = _loop_142(iges, int(p[4])) if n1 == 1 else None
            inner = tuple(_loop_142(iges, int(d)) for d in p[5:5 + n2])
            return Trim(surface_directory, outer, inner, 144)
    return None


def trimmed_area(surface, trim: Trim | None, n: int = 201) -> tuple[float, float]:
    """(untrimmed area, area inside the trim) of the surface, model units^2, on an n x n
    grid of its parameters (midpoint rule on the grid's quads)."""
    u = np.linspace(*surface.domain_u, n)
    v = np.linspace(*surface.domain_v, n)
    p = surface.grid(u, v)
    a = p[1:, :-1] - p[:-1, :-1]
    b = p[:-1, 1:] - p[:-1, :-1]
    c = p[1:, 1:] - p[1:, :-1]
    d = p[1:, 1:] - p[:-1, 1:]
    quad = 0.5 * (np.linalg.norm(np.cross(a, b), axis=2) + np.linalg.norm(np.cross(c, d), axis=2))
    if trim is None:
        return float(quad.sum()), float(quad.sum())
    um, vm = np.meshgrid(0.5 * (u[1:] + u[:-1]), 0.5 * (v[1:] + v[:-1]), indexing="ij")
    return float(quad.sum()), float(quad[trim.inside(um, vm)].sum())
