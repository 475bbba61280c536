"""Pin-jig table of a curved plate: the assembly plane, the height of every pin and of the
plate's corners (its check points) above the floor (mm).

A pin jig is a bed of vertical screw pins standing on a flat floor (the assembly plane);
set to their heights, the pins' tops carry the formed plate in its shape, so it can be
checked and its stiffeners welded on. The plate rests with its drawn side up: the pins touch
the side its mean normal points away from (for a strip the side opposite to c' x (d - c), the
side the shop drawing is not seen from); heights are to the plate's surface as modelled (a
moulded surface: the plate's thickness is the yard's to add where it models the other side).

The assembly plane is chosen to keep the pins short: its normal minimises the plate's
extent along it (the tallest pin), starting from the least-squares plane of the plate and
refined by Nelder-Mead over the normal's two angles; it is then lowered so the lowest point
of the plate stands ``shortest`` (AVEVA Hull's default: 250 mm) above it, so every pin under
the plate is at least that long. Pins stand on a grid: rows along the frames (hull plates;
elsewhere lines ``spacing`` apart across the plate's length) and every ``spacing`` along each
row, kept where they lie under the plate at least ``margin`` inside its edge.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class PinJig:
    """A plate's pin jig (mm, ship or part coordinates).

    origin : (3,) a point of the assembly plane (the floor); normal : (3,) its unit normal,
        towards the plate; axes : (2, 3) the floor's in-plane axes (along the plate, across)
    pins : (P, 2) pin positions on the floor (along, across); heights : (P,)
    tops : (P, 3) where each pin touches the plate; rows : (P,) the row (frame) name of each
    shortest : the shortest pin asked for; extent : the plate's height range above the floor
    checks : (4, 3) the plate's check points, its corners (the points farthest along the
        floor's diagonals); check_feet : (4, 2) their places on the floor; check_heights (4,)
    """

    origin: np.ndarray
    normal: np.ndarray
    axes: np.ndarray
    pins: np.ndarray
    heights: np.ndarray
    tops: np.ndarray
    rows: tuple
    shortest: float
    extent: float
    checks: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    check_feet: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    check_heights: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def figures(self) -> dict:
        return {"units": "mm", "pins": len(self.heights), "assembly_plane": {"origin": self.origin.tolist(),
                "normal": self.normal.tolist(), "axes": self.axes.tolist()},
                "shortest_pin": self.shortest, "plate_extent_above_floor": self.extent,
                "lowest_pin": float(self.heights.min()) if len(self.heights) else None,
                "tallest_pin": float(self.heights.max()) if len(self.heights) else None,
                "rows": sorted(set(self.rows), key=self.rows.index),
                "check_points": [{"point": p.tolist(), "floor": f.tolist(), "height": float(h)}
                                 for p, f, h in zip(self.checks, self.check_feet, self.check_heights)],
                "side": "pins touch the side the plate's mean normal points away from (the drawn side faces up)",
                "rule": "assembly plane normal minimising the plate's extent along it; floor at the lowest point "
                        "of the plate minus the shortest pin"}

    def csv(self) -> str:
        """The table: one pin a line, positions and heights in mm."""
        lines = ["pin,row,along_mm,across_mm,height_mm,top_x_mm,top_y_mm,top_z_mm"]
        for k, (row, p, h, t) in enumerate(zip(self.rows, self.pins, self.heights, self.tops)):
            lines.append(f"P{k + 1},{row},{p[0]:.1f},{p[1]:.1f},{h:.1f},{t[0]:.1f},{t[1]:.1f},{t[2]:.1f}")
        for k, (p, h, t) in enumerate(zip(self.check_feet, self.check_heights, self.checks)):
            lines.append(f"C{k + 1},CHECK CORNER,{p[0]:.1f},{p[1]:.1f},{h:.1f},{t[0]:.1f},{t[1]:.1f},{t[2]:.1f}")
        return "\n".join(lines) + "\n"


def assembly_normal(points: np.ndarray, side: np.ndarray) -> np.ndarray:
    """The unit normal (3,) minimising the extent of ``points`` (N, 3) along it, on the
    side of ``side`` (3,): least-squares plane first, then Nelder-Mead on two angles."""
    from scipy.optimize import minimize

    centred = points - points.mean(axis=0)
    basis = np.linalg.svd(centred, full_matrices=False)[2]  # rows: principal axes, the last the normal
    n0, e1, e2 = basis[2], basis[0], basis[1]
    def normal(angles):
        a, b = angles
        n = n0 + np.tan(a) * e1 + np.tan(b) * e2
        return n / np.linalg.norm(n)

    def extent(angles):
        h = centred @ normal(angles)
        return float(h.max() - h.min())

    best = minimize(extent, np.zeros(2), method="Nelder-Mead", options={"xatol": 1e-7, "fatol": 1e-6})
    n = normal(best.x) if best.fun <= extent(np.zeros(2)) else n0
    return n if n @ side >= 0 else -n


def height_field(vertices2: np.ndarray, heights: np.ndarray, faces: np.ndarray, shadow, near: int = 48):
    """A function: floor points query (Q, 2) -> heights (Q,) of the mesh above the floor
    there (the triangle holding each point, projected vertices vertices2 (V, 2), their
    heights (V,), linear in it); nan where no triangle holds it. The triangles tried first
    are those whose centres are nearest (a k-d tree); a point inside the mesh's ``shadow``
    (a shapely polygon) that none of them holds is tried against all."""
    import shapely
    from scipy.spatial import cKDTree

    tri = vertices2[faces]  # (F, 3, 2)
    tree = cKDTree(tri.mean(axis=1))

    def solve(q, c):  # q (Q, 2), c (Q, K) face indices -> (found (Q,), value (Q,))
        a, b, d = tri[c, 0], tri[c, 1], tri[c, 2]
        det = (b[..., 0] - a[..., 0]) * (d[..., 1] - a[..., 1]) - (d[..., 0] - a[..., 0]) * (b[..., 1] - a[..., 1])
        qa = q[:, None, :] - a
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (qa[..., 0] * (d[..., 1] - a[..., 1]) - (d[..., 0] - a[..., 0]) * qa[..., 1]) / det
            v = ((b[..., 0] - a[..., 0]) * qa[..., 1] - qa[..., 0] * (b[..., 1] - a[..., 1])) / det
            inside = (det != 0) & (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9)
        first = np.argmax(inside, axis=1)
        rows = np.arange(len(q))
        f = faces[c[rows, first]]
        uu, vv = u[rows, first], v[rows, first]
        with np.errstate(invalid="ignore"):  # a point no triangle holds (nan, degenerate ones inf): masked by found
            value = (1 - uu - vv) * heights[f[:, 0]] + uu * heights[f[:, 1]] + vv * heights[f[:, 2]]
        return inside.any(axis=1), value

    def at(query):
        query = np.asarray(query, float).reshape(-1, 2)
        out = np.full(len(query), np.nan)
        if not len(query):
            return out
        _, cand = tree.query(query, k=min(near, len(faces)))
        found, value = solve(query, cand.reshape(len(query), -1))
        out[found] = value[found]
        missed = np.flatnonzero(~found & shapely.contains_xy(shadow, query[:, 0], query[:, 1]))
        for k in missed:  # rare: a long sliver triangle whose centre is far
            ok, val = solve(query[k:k + 1], np.arange(len(faces))[None, :])
            if ok[0]:
                out[k] = val[0]
        return out

    return at


def _shadow(vertices2: np.ndarray, faces: np.ndarray):
    """The mesh's outline on the floor: its boundary edges (used by one triangle) joined
    into polygons, the largest kept."""
    import shapely

    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1).astype(np.int64)
    # each edge as one integer (np.unique over rows sorts them as opaque records, 40 times slower)
    keys, count = np.unique(edges[:, 0] * len(vertices2) + edges[:, 1], return_counts=True)
    boundary = np.column_stack(np.divmod(keys[count == 1], len(vertices2)))
    polygons = shapely.get_parts(shapely.polygonize(shapely.linestrings(vertices2[boundary])))
    if not len(polygons):
        return shapely.union_all(shapely.polygons(vertices2[faces]))
    return max(polygons, key=lambda p: p.area)


def pin_jig(vertices: np.ndarray, faces: np.ndarray, side: np.ndarray, frames: list, spacing: float,
            shortest: float = 250.0, margin: float = 50.0) -> PinJig:
    """The pin jig of a plate given as a mesh (vertices (V, 3) mm, faces (F, 3)); side (3,)
    the plate's mean normal (the pins stand on the other side); frames: x positions (mm)
    of the pin rows (hull plates), else rows ``spacing`` apart along the plate."""
    import shapely

    normal = assembly_normal(vertices, np.asarray(side, float))
    # the floor's axes: along the plate (x where the plate runs along the ship), across
    centred = vertices - vertices.mean(axis=0)
    along = np.array([1.0, 0.0, 0.0]) if frames else np.linalg.svd(centred, full_matrices=False)[2][0]
    along = along - (along @ normal) * normal
    along /= np.linalg.norm(along)
    across = np.cross(normal, along)
    h = vertices @ normal
    level = float(h.min()) - shortest  # the floor: the lowest point of the plate `shortest` above it
    origin = vertices.mean(axis=0) + (level - vertices.mean(axis=0) @ normal) * normal
    v2 = np.column_stack([(vertices - origin) @ along, (vertices - origin) @ across])
    heights = h - level
    # the plate's shadow on the floor, shrunk by the margin: where pins may stand
    shadow = _shadow(v2, faces)
    inner = shadow.buffer(-margin)
    height_at = height_field(v2, heights, faces, shadow)
    if frames:
        row_names, row_lines = [f"FR {x:g}" for x in frames], list(frames)
    else:
        a0, a1 = v2[:, 0].min(), v2[:, 0].max()
        count = max(1, int(np.ceil((a1 - a0) / spacing)))
        row_names = [f"ROW {k + 1}" for k in range(count)]
        row_lines = list(a0 + (np.arange(count) + 0.5) * (a1 - a0) / count)
    b0, b1 = v2[:, 1].min(), v2[:, 1].max()
    names, pins = [], []
    for name, value in zip(row_names, row_lines):
        bs = np.arange(b0 + 0.5 * ((b1 - b0) % spacing), b1 + 1e-9, spacing)
        if frames:
            # the pin's top on the frame plane x = value (the floor may lean along x, so
            # the pin's foot is off the frame by its height times the lean): a fixed point
            # a = (value - origin.x - b across.x - h(a, b) normal.x) / along.x, h from the mesh
            a = (value - origin[0] - bs * across[0]) / along[0]
            for _ in range(6):
                h_ab = height_at(np.column_stack([a, bs]))
                a = np.where(np.isfinite(h_ab), (value - origin[0] - bs * across[0] - np.nan_to_num(h_ab) * normal[0])
                             / along[0], a)
        else:
            a = np.full(len(bs), value)
        feet = np.column_stack([a, bs])
        for p in feet[shapely.contains_xy(inner, feet[:, 0], feet[:, 1])]:
            names.append(name)
            pins.append(p)
    pins = np.array(pins).reshape(-1, 2)
    pin_h = height_at(pins)
    keep = np.isfinite(pin_h)
    pins, pin_h = pins[keep], pin_h[keep]
    names = tuple(n for n, k in zip(names, keep) if k)
    tops = origin + pins[:, :1] * along + pins[:, 1:] * across + pin_h[:, None] * normal
    # check points: the plate's corners, the vertices farthest along the floor's diagonals
    corner = np.unique([int(np.argmax(v2 @ d)) for d in ((1, 1), (1, -1), (-1, -1), (-1, 1))])
    return PinJig(origin, normal, np.vstack([along, across]), pins, pin_h, tops, names, shortest,
                  float(heights.max()), vertices[corner], v2[corner], heights[corner])
