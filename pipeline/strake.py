"""Hull plates of a strake: seams on the hull surface, butts as planes x = const.

Each plate's strip is computed on its two seams extended past the butts and trimmed by
the butt planes: a ruling meets a plane in one point, so the trim line is exact at every
ruling and lies on the strip; plates on either side of a butt share its end points on the
seams. Also the fit of each plate to the design surface and its frame lines.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import BSpline
from scipy.spatial import cKDTree

from flatten import NurbsCurve
from flatten.nurbs import ppoly_from_spline
from flatten.surface import NurbsSurface

from .iges import IgesError, iges_surface, read_iges
from .sources import SourceError, pick_entity, source_path


MAX_FRAMES_PER_PLATE = 1000


@dataclass(frozen=True)
class Plane:
    """The plane n . p = offset, n a unit normal pointing towards the plate's far butt."""

    normal: tuple[float, float, float]
    offset: float

    def signed(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points) @ np.asarray(self.normal) - self.offset

    def shifted(self, distance: float) -> "Plane":
        return Plane(self.normal, self.offset + distance)

    def describe(self) -> str:
        n = self.normal
        if abs(n[0] - 1.0) < 1e-12:
            return f"x = {self.offset:g}"
        return f"{n[0]:.4g} x + {n[1]:.4g} y + {n[2]:.4g} z = {self.offset:g}"


def butt_plane(spec) -> Plane:
    """A butt given as x (a float) or as {point, normal}; the normal is turned towards +x."""
    if isinstance(spec, (int, float)):
        return Plane((1.0, 0.0, 0.0), float(spec))
    n = np.asarray(spec.normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    if n[0] < 0:
        n = -n
    return Plane(tuple(float(v) for v in n), float(n @ np.asarray(spec.point, dtype=np.float64)))


@dataclass
class HullPlate:
    """What a strake plate knows beyond its two seams: the hull, its two butt planes."""

    surface: NurbsSurface
    butts: tuple[Plane, Plane]
    frames: list[float] = field(default_factory=list)
    seam_names: tuple[str, str] = ("", "")
    butt_names: tuple[str, str] = ("", "")
    fit_tolerance: float = 5.0


def plane_crossings(curve: NurbsCurve, plane: Plane) -> np.ndarray:
    """Parameters where the curve meets the plane (exact roots of the homogeneous B-spline
    n . A - offset w), sorted."""
    spline = curve.homogeneous
    coef = spline.c[:, :3] @ np.asarray(plane.normal) - plane.offset * spline.c[:, 3]
    roots = ppoly_from_spline(BSpline(spline.t, coef, spline.k)).roots(extrapolate=False)
    lo, hi = curve.domain
    return np.unique(roots[(roots >= lo) & (roots <= hi)])


def load_surface(spec, base: Path, mm_per_unit: float) -> NurbsSurface:
    path = source_path(base, spec.iges)
    try:
        iges = read_iges(path)
        entity = pick_entity(iges.of_type(128), spec, str(path), "entity-128 surface")
        return iges_surface(iges, entity, iges.unit_mm / mm_per_unit, "hull")
    except IgesError as exc:
        raise SourceError(str(exc)) from None


def _extended_segment(seam: NurbsCurve, planes: tuple[Plane, Plane], margin: float, name: str) -> NurbsCurve:
    """The seam between the butts, extended past each by ``margin`` times the plate length
    (or to the seam's end where it ends first)."""
    lo, hi = seam.domain
    cross_lo, cross_hi = plane_crossings(seam, planes[0]), plane_crossings(seam, planes[1])
    if len(cross_lo) != 1 or len(cross_hi) != 1:
        raise SourceError(f"seam {name} crosses the butt planes {planes[0].describe()} and {planes[1].describe()} "
                          f"{len(cross_lo)} and {len(cross_hi)} times (once each expected)")
    t1, t2 = cross_lo[0], cross_hi[0]
    extra = margin * float(np.linalg.norm(seam([t2])[0] - seam([t1])[0]))
    ext1 = plane_crossings(seam, planes[0].shifted(-extra))
    ext2 = plane_crossings(seam, planes[1].shifted(extra))
    e1 = ext1[0] if len(ext1) == 1 else (lo if t1 < t2 else hi)
    e2 = ext2[0] if len(ext2) == 1 else (hi if t2 > t1 else lo)
    a, b = sorted((e1, e2))
    seg = seam.segment(a, b)
    return NurbsCurve(seg.degree, seg.control_points, seg.weights, seg.knots, name)


def strake_parts(spec, config_path: Path, mm_per_unit: float) -> list:
    from .config import Part

    strake = spec.strake
    surface = load_surface(strake.surface, config_path.parent, mm_per_unit)
    seams = []
    for k, seam in enumerate(strake.seams):
        if seam.curve is not None:
            from .config import _curve

            seams.append(_curve(seam.curve, ("strake", "seams", k, "curve"), config_path, {}, mm_per_unit, {}))
            continue
        iso = seam.iso
        if iso.u is not None:
            if not surface.domain_u[0] <= iso.u <= surface.domain_u[1]:
                raise SourceError(f"seams[{k}].iso.u = {iso.u} lies outside the surface's u domain {surface.domain_u}")
            seams.append(surface.iso_u(iso.u, f"seam{k + 1}"))
        else:
            if not surface.domain_v[0] <= iso.v <= surface.domain_v[1]:
                raise SourceError(f"seams[{k}].iso.v = {iso.v} lies outside the surface's v domain {surface.domain_v}")
            seams.append(surface.iso_v(iso.v, f"seam{k + 1}"))
    planes = [butt_plane(b) for b in strake.butts]
    parts = []
    for i in range(len(seams) - 1):
        for j in range(len(planes) - 1):
            pair = (planes[j], planes[j + 1])
            name = f"{spec.name}_S{i + 1}_B{j + 1}"
            c = _extended_segment(seams[i], pair, strake.margin, f"{name}.seam{i + 1}")
            d = _extended_segment(seams[i + 1], pair, strake.margin, f"{name}.seam{i + 2}")
            corners = np.array([curve([plane_crossings(curve, p)[0]])[0] for curve in (c, d) for p in pair])
            frames = []
            if strake.frames is not None:
                lo, hi = corners[:, 0].min(), corners[:, 0].max()
                if not hi - lo <= MAX_FRAMES_PER_PLATE * strake.frames.spacing:
                    raise SourceError(f"frames.spacing = {strake.frames.spacing:g} puts more than "
                                      f"{MAX_FRAMES_PER_PLATE} frames on plate {name}")
                first = int(np.ceil((lo - strake.frames.start) / strake.frames.spacing))
                last = int(np.floor((hi - strake.frames.start) / strake.frames.spacing))
                frames = [strake.frames.start + k * strake.frames.spacing for k in range(first, last + 1)
                          if lo < strake.frames.start + k * strake.frames.spacing < hi]
            hull = HullPlate(surface, pair, frames, (f"SEAM {i + 1}", f"SEAM {i + 2}"),
                             (f"BUTT {j + 1}", f"BUTT {j + 2}"), strake.fit_tolerance)
            parts.append(Part(name, c, d, spec.steel, ("c", "d"), {}, hull))
    return parts


# ------------------------------------------------------------ trimming
def corner_rulings(solution, c: NurbsCurve, d: NurbsCurve, planes, per_zone: int = 32) -> np.ndarray:
    """Rulings through the four plate corners (where the butt planes cross the seams), and
    ``per_zone`` more between the two corners of each butt, where the butt line crosses
    the rulings: the trim is then sampled finely whatever the ruling spacing elsewhere."""
    path = solution.path.points
    field_ = solution.field
    order = np.argsort(path[:, 1])

    def T_of(t):
        guess = np.interp(t, path[:, 0], path[:, 1])
        return field_.refine_T(np.atleast_1d(t), np.atleast_1d(guess), 8)

    extra = []
    for plane in planes:
        corners_t = []
        for t in plane_crossings(c, plane):
            if path[0, 0] <= t <= path[-1, 0]:
                corners_t.append(t)
        for T in plane_crossings(d, plane):
            if path[order[0], 1] <= T <= path[order[-1], 1]:
                t = float(np.interp(T, path[order, 1], path[order, 0]))
                for _ in range(8):  # Newton on f(., T) = 0
                    ft = field_(t, T, 1, 0)[0]
                    if ft == 0:
                        break
                    t -= field_(t, T)[0] / ft
                extra.append((t, T))
                corners_t.append(t)
        for t in corners_t[:1] if len(corners_t) < 2 else np.linspace(min(corners_t), max(corners_t), per_zone):
            extra.append((float(t), float(T_of(t)[0])))
    return np.array(extra).reshape(-1, 2)


def trim_intervals(ends_c: np.ndarray, ends_d: np.ndarray, planes: tuple[Plane, Plane]) -> np.ndarray:
    """Per ruling, the interval of v in [0, 1] between the two butt planes (on the positive
    side of the first, the negative side of the second), (K, 2); NaN rows for rulings
    wholly outside."""
    lo = np.zeros(len(ends_c))
    hi = np.ones(len(ends_c))
    for plane, sign in zip(planes, (1.0, -1.0)):
        sa, sb = sign * plane.signed(ends_c), sign * plane.signed(ends_d)
        ds = sb - sa
        with np.errstate(divide="ignore", invalid="ignore"):
            cut = -sa / ds  # where sign * s(v) = 0
        rising = ds > 0
        lo = np.where(rising, np.maximum(lo, cut), lo)
        hi = np.where(ds < 0, np.minimum(hi, cut), hi)
        outside = (ds == 0) & (sa < 0)
        hi = np.where(outside, -1.0, hi)
    lo, hi = np.clip(lo, 0.0, 1.0), np.clip(hi, 0.0, 1.0)
    out = np.column_stack([lo, hi])
    out[~(hi > lo + 1e-12)] = np.nan
    return out


def surface_distance(surface: NurbsSurface, points: np.ndarray, grid: int = 120) -> np.ndarray:
    """Distance of each point (N, 3) to the surface: closest grid sample, then Gauss-Newton
    on the parameters with central-difference derivatives."""
    u = np.linspace(*surface.domain_u, grid)
    v = np.linspace(*surface.domain_v, grid)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    samples = surface(uu.ravel(), vv.ravel())
    _, idx = cKDTree(samples).query(points)
    pu, pv = uu.ravel()[idx], vv.ravel()[idx]
    hu = 1e-7 * np.ptp(surface.domain_u)
    hv = 1e-7 * np.ptp(surface.domain_v)
    for _ in range(12):
        s = surface(pu, pv)
        su = (surface(pu + hu, pv) - surface(pu - hu, pv)) / (2 * hu)
        sv = (surface(pu, pv + hv) - surface(pu, pv - hv)) / (2 * hv)
        r = s - points
        a11, a12, a22 = (np.einsum("ij,ij->i", x, y) for x, y in ((su, su), (su, sv), (sv, sv)))
        b1, b2 = np.einsum("ij,ij->i", su, r), np.einsum("ij,ij->i", sv, r)
        det = a11 * a22 - a12**2
        ok = np.abs(det) > 0
        du = np.where(ok, (a22 * b1 - a12 * b2) / np.where(ok, det, 1), 0)
        dv = np.where(ok, (a11 * b2 - a12 * b1) / np.where(ok, det, 1), 0)
        pu = np.clip(pu - du, *surface.domain_u)
        pv = np.clip(pv - dv, *surface.domain_v)
    return np.linalg.norm(surface(pu, pv) - points, axis=1)


def stage_trim(result, min_coverage: float = 0.0) -> bool:
    """Cut the plate out of its extended strip with the butt planes, measure its fit to the
    hull and map the frame lines; False (with the reason) when the plate misses the hull."""
    from flatten.strip import Strip, grid_faces

    from .marks import edge_labels, frame_polylines
    from .stages import Pattern, place_flat

    hull: HullPlate = result.part.hull
    strip, dev = result.strip, result.development
    m = len(strip.samples)
    k = np.arange(strip.n_rulings) * m
    a3, b3 = strip.vertices[k], strip.vertices[k + m - 1]
    intervals = trim_intervals(a3, b3, hull.butts)
    keep = ~np.isnan(intervals[:, 0])
    if keep.sum() < 2:
        result.reason = (f"the strip does not reach across the butts {hull.butts[0].describe()} and "
                         f"{hull.butts[1].describe()}")
        return False
    lo, hi = intervals[keep, 0], intervals[keep, 1]
    v = lo[:, None] + (hi - lo)[:, None] * strip.samples[None, :]
    a3, b3 = a3[keep], b3[keep]
    a2, b2 = dev.along_c[keep], dev.along_d[keep]
    vertices = (a3[:, None] + v[..., None] * (b3 - a3)[:, None]).reshape(-1, 3)
    flat = (a2[:, None] + v[..., None] * (b2 - a2)[:, None]).reshape(-1, 2)
    faces = grid_faces(int(keep.sum()), m)
    trimmed = Strip(strip.rulings[keep], strip.samples, vertices, faces, strip.max_chord_error,
                    np.column_stack([lo, hi]))
    rot, shift = place_flat(flat, flat.reshape(-1, m, 2)[:, 0])
    placed = flat @ rot.T + shift
    grid = placed.reshape(-1, m, 2)
    lower, upper = grid[:, 0], grid[:, -1]
    outline = np.vstack([lower, upper[::-1]])
    frame_lines = [(x, pts @ rot.T + shift) for x, pts in frame_polylines(result, hull.frames, lo, hi, keep)]
    labels = edge_labels(hull, lower, upper, vertices.reshape(-1, m, 3))
    # how much of each seam between the butts the plate covers (the extended seams' own
    # coverage is partial by design)
    path = result.solution.path.points
    covered = {}
    for key, curve, column in (("c", result.part.c, 0), ("d", result.part.d, 1)):
        ends = np.sort([plane_crossings(curve, plane)[0] for plane in hull.butts])
        lo_t, hi_t = np.sort(path[[0, -1], column])
        span = curve.arc_length_at(ends)
        inside = curve.arc_length_at(np.clip(ends, lo_t, hi_t))
        covered[key] = float((inside[1] - inside[0]) / (span[1] - span[0]))
    result.figures["plate_coverage"] = covered
    result.warnings = [w for w in result.warnings if not w.startswith("partial coverage")]
    if min(covered.values()) < min_coverage:
        result.reason = (f"plate incomplete: the strip covers {100 * covered['c']:.1f}% and {100 * covered['d']:.1f}% "
                         f"of its seams between the butts (min_coverage {min_coverage:g}); increase strake.margin")
        return False
    if min(covered.values()) < 1.0 - 1e-9:
        result.warnings.append(f"plate incomplete: the strip covers {100 * covered['c']:.2f}% of seam "
                               f"{hull.seam_names[0]} and {100 * covered['d']:.2f}% of {hull.seam_names[1]} "
                               "between the butts; increase strake.margin")
    result.strip = trimmed
    result.pattern = Pattern(outline, np.stack([lower, upper], axis=1), placed, (rot, shift),
                             tuple(frame_lines), tuple(labels))
    distance = surface_distance(hull.surface, vertices)
    worst = int(np.argmax(distance))
    result.figures["hull_fit"] = {"max_distance": float(distance.max()),
                                  "rms_distance": float(np.sqrt(np.mean(distance**2))),
                                  "worst_point": vertices[worst].tolist(),
                                  "tolerance": hull.fit_tolerance,
                                  "passed": bool(distance.max() <= hull.fit_tolerance)}
    result.figures["trim"] = {"butt_planes": [{"normal": list(p.normal), "offset": p.offset} for p in hull.butts],
                              "rulings_kept": int(keep.sum()),
                              "frames": [x for x, _ in frame_lines]}
    if distance.max() > hull.fit_tolerance:
        result.reason = (f"plate deviates from the hull by {distance.max():.4g} (tolerance "
                         f"{hull.fit_tolerance:g}) at {np.round(vertices[worst], 3).tolist()}")
        return False
    return True
