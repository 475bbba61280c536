"""Marks on a hull plate: frame lines and the names of its seams and butts.

Computed on the developed (flat) plate; knows nothing of file formats.
"""

from __future__ import annotations

import numpy as np


def frame_polylines(result, frames, lo, hi, keep, n_v: int = 41):
    """Each frame plane x = X on the plate, as developed points (unplaced): along lines of
    constant v the crossing between two rulings is solved exactly (secant on t with T(t)
    from f = 0), and the crossing points are developed exactly (one development with those
    rulings added)."""
    from flatten.develop import develop

    part, solution, strip = result.part, result.solution, result.strip
    field_ = solution.field
    rulings = strip.rulings
    m = len(strip.samples)
    k = np.arange(strip.n_rulings) * m
    a3, b3 = strip.vertices[k], strip.vertices[k + m - 1]
    v = np.linspace(0.0, 1.0, n_v)
    lines = []
    for x in frames:
        xs = a3[:, None, 0] + v[None, :] * (b3 - a3)[:, None, 0]  # (K, n_v)
        crossings = []
        for j in range(n_v):
            idx = np.flatnonzero(np.diff(np.sign(xs[:, j] - x)) != 0)
            for i in idx[:1]:
                frac = (x - xs[i, j]) / (xs[i + 1, j] - xs[i, j])
                crossings.append((v[j], rulings[i, 0] + frac * (rulings[i + 1, 0] - rulings[i, 0]),
                                  rulings[i, 0], rulings[i + 1, 0]))
        if len(crossings) < 2:
            continue
        vv = np.array([cr[0] for cr in crossings])
        t = np.array([cr[1] for cr in crossings])
        t_lo = np.array([cr[2] for cr in crossings])
        t_hi = np.array([cr[3] for cr in crossings])

        def x_at(tt):
            TT = field_.refine_T(tt, np.interp(tt, rulings[:, 0], rulings[:, 1]), 8)
            pc, pd = part.c(tt), part.d(TT)
            return pc[:, 0] + vv * (pd[:, 0] - pc[:, 0]) - x, TT

        g0, _ = x_at(t_lo)
        g1, _ = x_at(t_hi)
        for _ in range(40):  # regula falsi (Illinois) inside the bracket
            g, _ = x_at(t)
            left = np.sign(g) == np.sign(g0)
            t_lo, g0 = np.where(left, t, t_lo), np.where(left, g, g0)
            t_hi, g1 = np.where(left, t_hi, t), np.where(left, g1, g)
            t = np.where(g1 != g0, t_hi - g1 * (t_hi - t_lo) / (g1 - g0), t)
            if np.abs(g).max() <= 1e-9 * (1 + abs(x)):
                break
        _, T = x_at(t)
        merged = np.vstack([rulings, np.column_stack([t, T])])
        order = np.lexsort((merged[:, 1] * solution.path.orientation, merged[:, 0]))
        dev = develop(part.c, part.d, merged[order], field_)
        position = np.empty(len(merged), dtype=int)
        position[order] = np.arange(len(merged))
        new = position[len(rulings):]
        pts = dev.along_c[new] + vv[:, None] * (dev.along_d[new] - dev.along_c[new])
        lines.append((float(x), pts))
    return lines


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
