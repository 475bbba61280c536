"""Heating lines of a formed plate: where forming must shrink the developed plate beyond
what rolling gives, lines across the principal shrink direction, spaced by the shrinkage
each line gives, with the side to heat. Arrays in (mm), arrays and figures out.

Strain (convention of :mod:`flatten.patchflat`): each triangle's map J from the hull to the
flat plate has singular values s1 >= s2 (flat length / hull length along its principal
directions); the principal strains are e = s - 1. Positive: the flat plate is longer there
than the hull, forming must shrink it; negative: forming must stretch it.

Workshop method (AVEVA Hull's Contraction / Expansion / NoDeformation), applied as the scale
of the development (:func:`method_scale`; the minimal-strain development's shape is kept, only
its size changes, so every strain moves by the same factor):
  contraction  developed larger by 1 / min(s2): every strain >= 0, forming only shrinks
               (line heating shrinks the plate where it is too long);
  expansion    developed smaller by 1 / max(s1): every strain <= 0, forming only stretches;
               stretching is done by pressing or rolling, not by heating: no heating lines,
               the stretch areas (MARK_STRETCH) and the stretch the report gives are the data;
  none         the minimal-strain development as it is (no deformation compensation): heating
               lines where it must shrink, stretch areas where it must stretch.

Criterion: rolling bends a plate without changing its mid-plane lengths, so every principal
strain is a length change rolling does not give. A plate gets heating lines where its largest
required shrink e1 exceeds ``threshold`` (default 1 mm/m, the figure the strain map marks shrink
areas at; shell expansion programs prompt at 0.3-1 mm/m), unless the caller found the whole plate
rollable (its strain times its size within the fit tolerance).

Model (inherent strain; Ueda, Murakawa, Rashwan, Okumoto & Kamichika, J. Ship Research 38
(1994); Jang, Seo & Ko, J. Ship Production 13 (1997); Jang & Moon, J. Ship Production 14
(1998)): a heating line leaves a transverse shrinkage across it proportional to the heat
input per unit length Q over the plate thickness h. Its upper bound, all the thermal expansion
of the heated cross-section held plastically, is

    delta = alpha Q / (c rho h)      (mm per line)

with alpha = 1.2e-5 1/K and c rho = 4.7e-3 J/(mm^3 K) (mild steel, c = 0.6 J/(g K) averaged to
700 C, rho = 7.85e-3 g/mm^3): alpha / (c rho) = 2.55e-3 mm^3/J. Q is the net heat put into the
plate per mm of line (default 2000 J/mm: delta = 0.51 mm on 10 mm, 0.32 mm on 16 mm plate, the
order of the 0.2-1 mm a line measures on ship plate). A yard that measured its own lines gives
delta directly (``shop.heat_shrinkage``). Lines at spacing s give the strain delta / s, so the
spacing a required shrink e asks is s = delta / e, no closer than ``min_spacing`` (then the
report gives the passes needed).

Lines (evenly spaced streamlines with a separation that varies, Jobard & Lefer 1997): traced
along the direction across the shrink direction, seeded on the plate's outline (inset by the
margin) where lines of that direction enter it, one seed per delta of required shrinkage
crossing the outline, then inside where no line came. A line stops where the required shrink
drops below the threshold, at the inset outline, or where it comes nearer than s / sqrt(2) to
a line of a coarser level (outline seeds are levelled dyadically along each run, so that a
line is dropped where, converging with its neighbours, it would double the density: the
shrinkage given stays within a factor sqrt(2) of the required one).

Side: a heating line also bends the plate about itself, the heated side becoming concave
(the plate bends toward the torch: the heated face shrinks more). Heat the side that is
concave across the lines (along the shrink direction), so the bending adds to the shape: the
inside of the roll curvature on a dome (both curvatures of one sign), its outside on a saddle.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

ALPHA_STEEL = 1.2e-5  # 1/K, thermal expansion of steel
HEAT_CAPACITY = 4.7e-3  # J/(mm^3 K): c rho of steel (0.6 J/(g K) x 7.85e-3 g/mm^3)
METHODS = ("contraction", "expansion", "none")
MAX_TURN = 30.0  # degrees a heating line may turn from its start


@dataclass(frozen=True)
class LineModel:
    """Transverse shrinkage per heating line (mm) on a plate of ``thickness`` mm with net heat
    input ``heat_input`` J/mm, or the yard's measured ``measured`` mm per line."""

    thickness: float
    heat_input: float = 2000.0
    measured: float | None = None

    @property
    def per_line(self) -> float:
        if self.measured is not None:
            return float(self.measured)
        return ALPHA_STEEL * self.heat_input / (HEAT_CAPACITY * self.thickness)

    def figures(self) -> dict:
        return {"shrinkage_per_line_mm": self.per_line, "thickness_mm": self.thickness,
                "heat_input_j_per_mm": self.heat_input, "measured": self.measured is not None,
                "formula": "delta = alpha Q / (c rho h), alpha 1.2e-5 1/K, c rho 4.7e-3 J/(mm^3 K)"
                           if self.measured is None else "shop.heat_shrinkage (the yard's measured shrinkage a line)",
                "source": "inherent strain of a heating line: Ueda et al. 1994 (J. Ship Research 38), Jang, Seo & "
                          "Ko 1997 (J. Ship Production 13), Jang & Moon 1998 (J. Ship Production 14); upper bound "
                          "of the transverse shrinkage (all thermal expansion of the heated section held plastically)"}


@dataclass(frozen=True)
class PrincipalStrains:
    """Per triangle: strains (F, 2) [e1 >= e2]; flat (F, 2, 2) unit directions of e1, e2 in
    the flat plate (rows); hull (F, 2, 3) the same directions on the hull; valid (F,)."""

    strain: np.ndarray
    flat: np.ndarray
    hull: np.ndarray
    valid: np.ndarray


def principal_strains(v3: np.ndarray, uv: np.ndarray, faces: np.ndarray) -> PrincipalStrains:
    """Principal strains and directions of the map hull (V, 3) -> flat (V, 2) on each face."""
    from flatten.patchflat import triangle_maps

    v3, uv, faces = np.asarray(v3, float), np.asarray(uv, float), np.asarray(faces)
    maps = triangle_maps(v3, uv, faces)  # (F, 2, 3): zero where the triangle collapses
    u, s, vt = np.linalg.svd(maps, full_matrices=True)
    valid = s[:, 1] > 1e-9 * np.maximum(s[:, 0], 1e-300)
    return PrincipalStrains(np.where(valid[:, None], s - 1.0, np.nan), np.swapaxes(u, 1, 2), vt[:, :2], valid)


def method_scale(strain: np.ndarray, valid: np.ndarray, method: str) -> float:
    """Scale of the development that makes every strain (F, 2) >= 0 (contraction), <= 0
    (expansion) or leaves it (none): the factor the flat plate is multiplied by."""
    if method not in METHODS:
        raise ValueError(f"workshop method {method!r}: expected one of {', '.join(METHODS)}")
    s = strain[valid] + 1.0
    if method == "none" or not len(s):
        return 1.0
    return float(1.0 / s[:, 1].min()) if method == "contraction" else float(1.0 / s[:, 0].max())


def normal_curvatures(v3: np.ndarray, faces: np.ndarray, normals: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Normal curvature (F, K) of the mesh (V, 3), (F, 3) along unit hull directions (F, K, 3),
    1/mm, positive where the surface is convex seen from the side of ``normals`` (F, 3) (the
    face normals oriented to the drawn side). From the vertex normals' change along the
    face's edges (least squares shape operator per face)."""
    p = v3[faces]  # (F, 3, 3)
    area_n = normals * (0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1))[:, None]
    vn = np.zeros_like(v3)
    for k in range(3):
        np.add.at(vn, faces[:, k], area_n)
    vn /= np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]
    n = vn[faces]
    edges = p[:, [1, 2, 0]] - p  # (F, 3, 3)
    dn = n[:, [1, 2, 0]] - n
    e1 = edges[:, 0] / np.maximum(np.linalg.norm(edges[:, 0], axis=1), 1e-300)[:, None]
    e2 = np.cross(normals, e1)
    frame = np.stack([e1, e2], axis=2)  # (F, 3, 2)
    a = edges @ frame  # (F, 3, 2): edges in the face frame
    b = dn @ frame
    gram = np.swapaxes(a, 1, 2) @ a
    det = gram[:, 0, 0] * gram[:, 1, 1] - gram[:, 0, 1] ** 2
    inv = np.zeros_like(gram)
    ok = det > 1e-24 * np.maximum(gram[:, 0, 0] * gram[:, 1, 1], 1e-300)
    inv[ok] = np.linalg.inv(gram[ok])
    shape = inv @ np.swapaxes(a, 1, 2) @ b  # (F, 2, 2): dN coords = edge coords @ shape
    shape = 0.5 * (shape + np.swapaxes(shape, 1, 2))
    t = directions @ frame  # (F, K, 2)
    return np.einsum("fki,fij,fkj->fk", t, shape, t)


@dataclass(frozen=True)
class Heating:
    """The heating lines of one plate (mm, the placed flat plate's coordinates).

    lines : polylines (K_i, 2); group : (L,) the group of each line; groups : per group a dict
    (side, required shrink, lines); figures : the report's ``heating`` section."""

    lines: tuple = ()
    group: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    groups: tuple = ()
    figures: dict = field(default_factory=dict)


def _field(centres: np.ndarray, need: np.ndarray, along: np.ndarray, k: int = 6):
    """Sampler of the face field at points (N, 2): required shrink (inverse distance mean of
    the k nearest faces) and the line direction (principal axis of their sign-free
    directions)."""
    from scipy.spatial import cKDTree

    tree = cKDTree(centres)
    k = min(k, len(centres))

    def at(points):
        d, i = tree.query(points, k=k)
        d, i = d.reshape(len(points), k), i.reshape(len(points), k)
        w = 1.0 / np.maximum(d, 1e-9)
        w /= w.sum(axis=1, keepdims=True)
        e = np.sum(w * need[i], axis=1)
        t = along[i]  # (N, k, 2)
        txx, tyy, txy = (np.sum(w * t[..., 0] ** 2, 1), np.sum(w * t[..., 1] ** 2, 1), np.sum(w * t[..., 0] * t[..., 1], 1))
        angle = 0.5 * np.arctan2(2 * txy, txx - tyy)
        return e, np.column_stack([np.cos(angle), np.sin(angle)]), i[:, 0]

    return at


def _levels(n: int) -> np.ndarray:
    """Dyadic level of seeds 0..n-1 along a run: trailing zeros of k + 1 (coarsest first)."""
    k = np.arange(1, n + 1)
    return np.array([(int(x) & -int(x)).bit_length() - 1 for x in k])


def _ring_seeds(ring: np.ndarray, sample, spacing_of, threshold: float, step: float):
    """Seeds on the closed inset outline (M, 2): where the required shrink exceeds the
    threshold, one per unit of line demand |d1 . tangent| / s crossing it, evenly in each
    run. Returns (points (N, 2), inward line directions (N, 2), levels (N,))."""
    closed = np.vstack([ring, ring[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    total = seg.sum()
    m = max(int(np.ceil(total / step)), 8)
    s = np.linspace(0.0, total, m, endpoint=False)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    j = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
    tangent = np.diff(closed, axis=0)[j] / np.maximum(seg[j], 1e-300)[:, None]
    pts = closed[j] + (s - cum[j])[:, None] * tangent
    e, t, _ = sample(pts)
    area = 0.5 * np.sum(ring[:, 0] * np.roll(ring[:, 1], -1) - np.roll(ring[:, 0], -1) * ring[:, 1])
    inward = np.column_stack([-tangent[:, 1], tangent[:, 0]]) * np.sign(area)
    cross = np.abs(np.einsum("ij,ij->i", t, inward))  # |t . nu| = |d1 . tangent|
    demand = np.where(e > threshold, cross / spacing_of(e), 0.0) * (total / m)  # lines per sample
    on = demand > 0
    if not on.any():
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, int)
    # runs of consecutive samples in need (cyclic): start after an off sample
    start = 0 if on.all() else int(np.flatnonzero(~on)[0])
    order = np.roll(np.arange(m), -start)
    runs, current = [], []
    for idx in order:
        if on[idx]:
            current.append(idx)
        elif current:
            runs.append(current)
            current = []
    if current:
        runs.append(current)
    points, dirs, levels = [], [], []
    for run in runs:
        run = np.array(run)
        phi = np.concatenate([[0.0], np.cumsum(demand[run])])
        n = int(np.round(phi[-1]))
        if n < 1:
            continue
        want = (np.arange(n) + 0.5) * phi[-1] / n
        # each sample carries its demand over [i - 1/2, i + 1/2]: place seeds between samples
        pos = np.interp(want, phi, np.arange(len(run) + 1) - 0.5).clip(0, len(run) - 1)
        lo = np.floor(pos).astype(int)
        hi = np.minimum(lo + 1, len(run) - 1)
        frac = (pos - lo)[:, None]
        pick = run[np.round(pos).astype(int)]
        d = t[pick] * np.sign(np.einsum("ij,ij->i", t[pick], inward[pick]))[:, None]
        points.append(pts[run[lo]] + frac * (pts[run[hi]] - pts[run[lo]]))
        dirs.append(d)
        levels.append(_levels(n))
    if not points:
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, int)
    return np.vstack(points), np.vstack(dirs), np.concatenate(levels)


def _trace(seeds, dirs, sample, inside, near, spacing_of, threshold, step, max_steps):
    """Streamlines of the line direction from seeds (N, 2) along dirs (N, 2), all at once
    (midpoint steps of ``step`` mm); each stops leaving ``inside``, where the required shrink
    drops below the threshold, nearer than s / sqrt(2) to the lines ``near`` measures, or
    where it has turned more than MAX_TURN from its start (a line is one torch pass, marked
    nearly straight; where the field turns on, the rest is seeded again)."""
    p = np.array(seeds, float)
    prev = np.array(dirs, float)
    first = prev.copy()
    paths = [[q.copy()] for q in p]
    alive = np.ones(len(p), bool)
    for _ in range(max_steps):
        idx = np.flatnonzero(alive)
        if not idx.size:
            break
        _, t, _ = sample(p[idx])
        t *= np.sign(np.einsum("ij,ij->i", t, prev[idx]) + 1e-300)[:, None]
        _, tm, _ = sample(p[idx] + 0.5 * step * t)
        tm *= np.sign(np.einsum("ij,ij->i", tm, t) + 1e-300)[:, None]
        q = p[idx] + step * tm
        e, _, _ = sample(q)
        stop = ~inside(q) | (e <= threshold) | (near(q) < spacing_of(np.maximum(e, threshold)) / np.sqrt(2.0))
        stop |= np.einsum("ij,ij->i", tm, first[idx]) < np.cos(np.radians(MAX_TURN))
        go = idx[~stop]
        alive[idx[stop]] = False
        p[go], prev[go] = q[~stop], tm[~stop]
        for i, pt in zip(go, q[~stop]):
            paths[i].append(pt)
    return [np.array(path) for path in paths]


def heating_lines(v3: np.ndarray, uv: np.ndarray, faces: np.ndarray, outline: np.ndarray, model: LineModel,
                  method: str = "none", threshold: float = 1e-3, min_spacing: float = 100.0, margin: float = 50.0,
                  scale: float = 1.0, rollable: bool = False) -> Heating:
    """Heating lines of a formed plate (every length in mm).

    v3 : (V, 3) the hull patch; uv : (V, 2) its development as drawn (already scaled by the
    workshop method's ``scale``, which is only reported here); faces : (F, 3); outline : (M, 2)
    the plate's net outline; rollable: the caller found the whole plate formed by rolling
    alone (its strain times its size within the fit tolerance): figures, no lines. Returns a
    :class:`Heating`."""
    import shapely
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    v3, uv, faces = np.asarray(v3, float), np.asarray(uv, float), np.asarray(faces)
    ps = principal_strains(v3, uv, faces)
    delta = model.per_line
    valid = ps.valid
    e1 = np.where(valid, ps.strain[:, 0], 0.0)
    e2 = np.where(valid, ps.strain[:, 1], 0.0)
    need = np.where(e1 > threshold, e1, 0.0)
    figures = {"method": method, "development_scale": scale, "model": model.figures(), "threshold": threshold,
               "criterion": "heat where the largest principal strain (flat longer than the hull) exceeds the threshold: "
                            "rolling bends without changing mid-plane lengths",
               "min_spacing_mm": min_spacing, "margin_mm": margin,
               "max_required_strain": float(need.max(initial=0.0)),
               "max_cross_shrink": float(np.where(e1 > threshold, e2, 0.0).max(initial=0.0)),
               "max_stretch": float(max(-e2.min(initial=0.0), 0.0)),
               "lines": 0, "total_length_mm": 0.0, "groups": [], "polylines": []}
    if method == "expansion":
        figures["note"] = ("expansion: every strain <= 0, the plate is stretched by pressing or rolling; no heating "
                           "lines (the stretch areas are marked)")
        return Heating(figures=figures)
    if not (need > 0).any():
        figures["note"] = "no shrink beyond the threshold: no heating lines"
        return Heating(figures=figures)
    if rollable:
        figures["note"] = ("rolling only: the plate's strain times its size is within the fit tolerance, no heating "
                           "lines")
        return Heating(figures=figures)
    p = uv[faces]
    signed = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                    - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    q = v3[faces]
    n3 = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
    n3 = n3 / np.maximum(np.linalg.norm(n3, axis=1), 1e-300)[:, None] * np.sign(signed)[:, None]
    kappa = normal_curvatures(v3, faces, n3, ps.hull)  # (F, 2): across the lines (d1), along them (d2)
    heat_drawn = kappa[:, 0] <= 0  # concave across the lines on the drawn side: heat this side
    dome = kappa[:, 0] * kappa[:, 1] > 0
    centres = p.mean(axis=1)
    good = valid
    along = ps.flat[:, 1]  # line direction: the e2 direction, across the shrink direction
    sample = _field(centres[good], need[good], along[good])

    def spacing_of(e):
        return np.maximum(delta / np.maximum(e, 1e-300), min_spacing)

    plate = shapely.make_valid(shapely.Polygon(outline))
    room = plate.buffer(-margin)
    if room.is_empty:
        figures["note"] = f"the plate is narrower than twice the margin ({margin:g} mm): no heating lines"
        return Heating(figures=figures)
    if room.geom_type != "Polygon":
        room = max(getattr(room, "geoms", [room]), key=lambda g: g.area)
    shapely.prepare(room)

    def inside(points):
        return shapely.contains_xy(room, points[:, 0], points[:, 1])

    step = min_spacing / 4.0
    extent = float(np.ptp(np.asarray(room.exterior.coords), axis=0).max())
    max_steps = int(4 * extent / step) + 1
    ring = np.asarray(room.exterior.coords)[:-1]
    seeds, dirs, levels = _ring_seeds(ring, sample, spacing_of, threshold, step / 2)
    traced: list[np.ndarray] = []

    def near_of(lines):
        if not lines:
            return lambda pts: np.full(len(pts), np.inf)
        tree = cKDTree(np.vstack(lines))
        return lambda pts: tree.query(pts)[0]

    for level in sorted(set(levels.tolist()), reverse=True):  # coarse levels first, a level at once
        sel = levels == level
        traced += _trace(seeds[sel], dirs[sel], sample, inside, near_of(traced), spacing_of, threshold, step,
                         max_steps)
    # inside: where no outline line came, candidates on a grid, the most needed first
    lo, hi = np.asarray(room.bounds[:2]), np.asarray(room.bounds[2:])
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0], min_spacing / 2), np.arange(lo[1], hi[1], min_spacing / 2))
    cand = np.column_stack([gx.ravel(), gy.ravel()])
    cand = cand[inside(cand)]
    ce, _, _ = sample(cand) if len(cand) else (np.zeros(0), None, None)
    keep = ce > threshold
    cand, ce = cand[keep][np.argsort(-ce[keep], kind="stable")], ce[keep][np.argsort(-ce[keep], kind="stable")]
    while len(cand):
        d = near_of([line for line in traced if len(line) >= 2])(cand)
        free = d >= spacing_of(ce)
        if not free.any():
            break
        i = int(np.argmax(free))
        _, t, _ = sample(cand[i:i + 1])
        near = near_of(traced)
        halves = _trace(np.repeat(cand[i:i + 1], 2, axis=0), np.vstack([t, -t]), sample, inside, near,
                        spacing_of, threshold, step, max_steps)
        traced.append(np.vstack([halves[1][::-1], halves[0][1:]]))
        cand, ce = cand[i + 1:][free[i + 1:]], ce[i + 1:][free[i + 1:]]
    # a stroke shorter than half the closest spacing is no line a plater runs
    lines = [line for line in traced if len(line) >= 2 and np.linalg.norm(np.diff(line, axis=0), axis=1).sum()
             >= 0.5 * min_spacing]
    lines = [np.asarray(shapely.simplify(shapely.LineString(line), 1.0).coords) for line in lines]
    if not lines:
        figures["note"] = "the shrink areas are too small or too near the edges for a line"
        return Heating(figures=figures)
    # groups: connected areas in need heated from one side (faces sharing an edge)
    heat = need > 0
    ef = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    owner = np.tile(np.arange(len(faces)), 3)
    key = np.sort(ef, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    same = np.all(key[order][1:] == key[order][:-1], axis=1)
    a, b = owner[order][:-1][same], owner[order][1:][same]
    link = heat[a] & heat[b] & (heat_drawn[a] == heat_drawn[b])
    graph = coo_matrix((np.ones(link.sum()), (a[link], b[link])), shape=(len(faces), len(faces)))
    _, label = connected_components(graph, directed=False)
    seed_face = np.flatnonzero(good)[sample(np.array([line[0] for line in lines]))[2]]
    # a seed's nearest face may miss the area by a cell: take the nearest face in need
    needy = np.flatnonzero(heat)
    tree = cKDTree(centres[needy])
    seed_face = np.where(heat[seed_face], seed_face,
                         needy[tree.query(np.array([line[0] for line in lines]))[1]])
    names, group = {}, []
    for f in seed_face:
        group.append(names.setdefault(int(label[f]), len(names)))
    group = np.array(group)
    groups = []
    for g, comp in enumerate(names):
        faces_g = label == comp
        g_lines = [line for line, k in zip(lines, group) if k == g]
        length = float(sum(np.linalg.norm(np.diff(line, axis=0), axis=1).sum() for line in g_lines))
        emax = float(need[faces_g].max())
        passes = int(np.ceil(emax * min_spacing / delta - 1e-9)) if emax * min_spacing > delta else 1
        groups.append({"group": g + 1, "lines": len(g_lines), "length_mm": length,
                       "side": "drawn" if bool(heat_drawn[faces_g].mean() >= 0.5) else "other",
                       "shape": "dome" if bool(dome[faces_g].mean() >= 0.5) else "saddle",
                       "max_required_strain": emax, "passes": passes,
                       "spacing_mm": [float(spacing_of(np.array([emax]))[0]),
                                      float(spacing_of(np.array([max(threshold, need[faces_g & heat].min())]))[0])]})
    for g in groups:
        g["text"] = group_text(g, delta)
    figures.update(lines=len(lines), total_length_mm=float(sum(gr["length_mm"] for gr in groups)), groups=groups,
                   polylines=[line.tolist() for line in lines], line_group=[int(k) + 1 for k in group],
                   side_rule="heat the side concave across the lines (the heated side becomes concave): the inside "
                             "of the roll curvature on a dome, its outside on a saddle",
                   drawn_side="the side the plate is drawn from (the DXF seen from +z)")
    return Heating(tuple(lines), group, tuple(groups), figures)


def group_text(group: dict, delta: float) -> str:
    """The shop text of a group of heating lines: side, required shrink, shrink a line."""
    side = "THIS SIDE" if group["side"] == "drawn" else "OTHER SIDE"
    where = "INSIDE OF ROLL" if group["shape"] == "dome" else "OUTSIDE OF ROLL"
    passes = f", {group['passes']} PASSES" if group["passes"] > 1 else ""
    lines = f"{group['lines']} LINE" + ("" if group["lines"] == 1 else "S")
    return (f"HEAT G{group['group']} ({lines}): {side} ({where}), SHRINK "
            f"{1000 * group['max_required_strain']:.1f} MM/M, {delta:.2f} MM A LINE{passes}")


def layout_marks(figures: dict | None) -> tuple[list, list[str]]:
    """The heating lines of a plate's report section as layout marks [('heat', (K, 2))] and
    the texts of their groups (mm)."""
    if not figures or not figures.get("polylines"):
        return [], []
    return ([("heat", np.asarray(line, float)) for line in figures["polylines"]],
            [g["text"] for g in figures.get("groups", [])])


def label_groups(layout, figures: dict | None, net: np.ndarray, smallest: float) -> list[str]:
    """Name each group of heating lines on the plate ('G1' on the heat layer, as its part-data
    text calls it): beside one of its lines, along it, inside the net outline (N, 2) and
    clear of every line and text already laid out (mm). Adds the texts to ``layout``; returns
    findings for a group with no room."""
    import shapely
    from shapely.geometry import LineString, Polygon

    from .layout import Text, readable

    if not figures or not figures.get("polylines"):
        return []
    lines = [np.asarray(line, float) for line in figures["polylines"]]
    which = np.asarray(figures.get("line_group", [1] * len(lines)))
    plate = Polygon(net).buffer(-0.2 * smallest)
    obstacles = [LineString(line) for _, line in layout.lines if len(line) >= 2] + [t.box() for t in layout.texts]
    tree = shapely.STRtree(obstacles)
    findings = []
    for g in sorted(set(which.tolist())):
        text, placed = f"G{g}", False
        for h in (layout.text_height, smallest) if layout.text_height > smallest else (smallest,):
            for k in np.flatnonzero(which == g)[np.argsort([-len(lines[i]) for i in np.flatnonzero(which == g)],
                                                             kind="stable")]:
                line = lines[k]
                d = line[-1] - line[0]
                d = d / max(np.linalg.norm(d), 1e-300)
                normal = np.array([-d[1], d[0]])
                angle = readable(float(np.degrees(np.arctan2(d[1], d[0]))))
                path = LineString(line)
                for f in (0.5, 0.3, 0.7):
                    at = line[0] + f * (line[-1] - line[0])
                    on = np.asarray(path.interpolate(path.project(shapely.Point(at))).coords[0])
                    for side in (1.0, -1.0):
                        label = Text("heat", text, tuple(at + side * 0.9 * h * normal), h, angle, tuple(on))
                        box = label.box()
                        if plate.contains(box) and not len(tree.query(box, predicate="intersects")):
                            layout.texts.append(label)
                            obstacles.append(box)
                            tree = shapely.STRtree(obstacles)
                            placed = True
                            break
                    if placed:
                        break
                if placed:
                    break
            if placed:
                break
        if not placed:
            findings.append(f"heating group label {text!r}: no room beside its lines")
    return findings
