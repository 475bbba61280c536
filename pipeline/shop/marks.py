"""Marks on a hull plate: frame lines and the names of its seams and butts.

Computed on the developed (flat) plate; knows nothing of file formats.
"""

from __future__ import annotations

import numpy as np


def frame_polylines(result, frames, lo, hi, keep, n_v: int = 41):
    """Each frame plane x = X on the plate, as developed points (unplaced): along lines of
    constant v the crossing between two rulings is solved exactly (secant on t with T(t)
    from f = 0), and the crossing points are developed exactly (the strip developed once,
    every frame's crossing rulings developed from it: :class:`flatten.develop.DevelopedStrip`).

    The frames are solved side by side, each as if alone: a frame's points stop moving
    once they all meet the tolerance, as they would in a loop over the frames."""
    from flatten.develop import DevelopedStrip

    part, solution, strip = result.part, result.solution, result.strip
    field_ = solution.field
    rulings = strip.rulings
    m = len(strip.samples)
    k = np.arange(strip.n_rulings) * m
    a3, b3 = strip.vertices[k], strip.vertices[k + m - 1]
    v = np.linspace(0.0, 1.0, n_v)
    xs = a3[:, None, 0] + v[None, :] * (b3 - a3)[:, None, 0]  # (K, n_v)
    found = []  # per frame with >= 2 crossings: (x, v (n,), t, t_lo, t_hi (n,) each)
    for x in frames:
        change = np.diff(np.sign(xs - x), axis=0) != 0  # (K - 1, n_v)
        cols = np.flatnonzero(change.any(axis=0))  # lines of constant v crossing the frame
        if len(cols) < 2:
            continue
        i = np.argmax(change[:, cols], axis=0)  # the first crossing along each
        frac = (x - xs[i, cols]) / (xs[i + 1, cols] - xs[i, cols])
        found.append((float(x), v[cols], rulings[i, 0] + frac * (rulings[i + 1, 0] - rulings[i, 0]),
                      rulings[i, 0], rulings[i + 1, 0]))
    if not found:
        return []
    owner = np.concatenate([np.full(len(f[1]), n) for n, f in enumerate(found)])
    target = np.array([f[0] for f in found])
    vv, t, t_lo, t_hi = (np.concatenate([f[k] for f in found]) for k in range(1, 5))
    x_of = target[owner]

    def x_at(tt, sel):
        guess = np.interp(tt, rulings[:, 0], rulings[:, 1])
        TT = guess if field_ is None else field_.refine_T(tt, guess, 8)
        pc, pd = part.c(tt), part.d(TT)
        return pc[:, 0] + vv[sel] * (pd[:, 0] - pc[:, 0]) - x_of[sel], TT

    everything = np.arange(len(t))
    g0, _ = x_at(t_lo, everything)
    g1, _ = x_at(t_hi, everything)
    moving = np.ones(len(found), dtype=bool)
    for _ in range(40):  # regula falsi (Illinois) inside the bracket
        sel = np.flatnonzero(moving[owner])
        if not len(sel):
            break
        g, _ = x_at(t[sel], sel)
        left = np.sign(g) == np.sign(g0[sel])
        t_lo[sel], g0[sel] = np.where(left, t[sel], t_lo[sel]), np.where(left, g, g0[sel])
        t_hi[sel], g1[sel] = np.where(left, t_hi[sel], t[sel]), np.where(left, g1[sel], g)
        t[sel] = np.where(g1[sel] != g0[sel], t_hi[sel] - g1[sel] * (t_hi[sel] - t_lo[sel]) / (g1[sel] - g0[sel]),
                          t[sel])
        worst = np.zeros(len(found))
        np.maximum.at(worst, owner[sel], np.abs(g))
        moving &= ~(worst <= 1e-9 * (1 + np.abs(target)))
    _, T = x_at(t, everything)
    strip_dev = result.developed  # the strip's development (stage_unroll), if of these rulings
    if strip_dev is None or not np.array_equal(strip_dev.rulings, rulings):
        strip_dev = DevelopedStrip(part.c, part.d, rulings[np.lexsort((rulings[:, 1] * solution.path.orientation,
                                                                        rulings[:, 0]))], field_)
    dev = strip_dev.ends(np.column_stack([t, T]))
    pts = dev.along_c + vv[:, None] * (dev.along_d - dev.along_c)
    return [(x, pts[owner == n]) for n, (x, *_) in enumerate(found)]


def butt_order(butts, first_3d: np.ndarray, last_3d: np.ndarray) -> tuple[int, int]:
    """Which butt plane each end of the plate lies on, decided in 3D: (index of the butt
    at the first ruling, index at the last). first_3d, last_3d: (m, 3) points of the end
    rulings. The assignment with the smaller total distance to the planes wins, so a seam
    running towards -x gets its butts the other way round."""
    straight = sum(float(np.abs(b.signed(p)).max()) for b, p in zip(butts, (first_3d, last_3d)))
    swapped = sum(float(np.abs(b.signed(p)).max()) for b, p in zip(butts, (last_3d, first_3d)))
    return (0, 1) if straight <= swapped else (1, 0)


def edge_labels(hull, lower: np.ndarray, upper: np.ndarray, grid_3d: np.ndarray) -> list:
    """Seam names along the c and d sides (lower, upper: (K, 2) placed flat points), butt
    names along the end lines, each butt named by the plane its end ruling lies on in 3D
    (grid_3d: (K, m, 3) trimmed strip vertices); ((text, (2,) position, angle in degrees), ...)."""
    first, last = butt_order(hull.butts, grid_3d[0], grid_3d[-1])
    labels = []
    for text, line in ((hull.seam_names[0], lower), (hull.seam_names[1], upper),
                       (hull.butt_names[first], np.vstack([lower[0], upper[0]])),
                       (hull.butt_names[last], np.vstack([lower[-1], upper[-1]]))):
        mid = line[len(line) // 2] if len(line) > 2 else line.mean(axis=0)
        direction = line[-1] - line[0]
        labels.append((text, mid, float(np.degrees(np.arctan2(direction[1], direction[0])))))
    return labels


def strain_areas(strain: dict, grid_shape, placed: np.ndarray) -> list:
    """The shrink and stretch areas of a formed plate as closed rings on the flat plate:
    [(kind, (K, 2) ring, first point repeated, region entry)], kind 'shrink' or 'stretch'.

    strain : the plate's strain map (pipeline.plates.strain_map: regions of grid cells,
        about 1 m square, each with its kind)
    grid_shape : (rows, cols) of the plate's patch grid; placed : (rows * cols, 2) its flat
        vertices (model units). A region is a block of grid cells (as the strain map cuts
        them), so its boundary runs along grid lines: exact, no polygon union."""
    regions = [r for r in strain.get("regions", []) if r.get("kind") in ("shrink", "stretch")]
    if not regions:
        return []
    rows, cols = grid_shape
    # the strain map's region counts: every region with a valid triangle is listed
    nr = 1 + max(r["region"][0] for r in strain["regions"])
    nc = 1 + max(r["region"][1] for r in strain["regions"])
    cell_row = np.arange(rows - 1) * nr // (rows - 1)
    cell_col = np.arange(cols - 1) * nc // (cols - 1)
    pg = np.asarray(placed).reshape(rows, cols, 2)
    out = []
    for region in regions:
        i, j = region["region"]
        ci, cj = np.flatnonzero(cell_row == i), np.flatnonzero(cell_col == j)
        if ci.size == 0 or cj.size == 0:
            continue
        i0, i1, j0, j1 = ci[0], ci[-1] + 1, cj[0], cj[-1] + 1
        ring = np.vstack([pg[i0, j0:j1 + 1], pg[i0 + 1:i1 + 1, j1], pg[i1, j1 - 1:j0 - 1 if j0 else None:-1],
                          pg[i1 - 1:i0:-1, j0], pg[i0, j0][None]])
        out.append((region["kind"], ring, region))
    return out
