"""The region of a hull surface between two seams and two butt planes, as a fine grid mesh.

A plate's region in the surface's parameters: along the longitudinal parameter s, between
two girth curves g_lo(s) and g_hi(s) (seams), and between two planes (butts) or the
surface's own end (the hull's stem or stern). Each grid row follows a fraction in [0, 1]
of the girth between the seams (of its 3D length, or of its parameter); its ends are where
the row meets the butt planes, found by bisection on the exact surface, so the grid's
boundary lies on the seams and the butts.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .surface import NurbsSurface


@dataclass(frozen=True)
class PatchGrid:
    """params (R, C, 2) surface parameters (u, v); points (R, C, 3); rows: fractions (R,)
    of the girth between the seams of the rows kept (rows that miss the region are dropped),
    of its 3D length or of its parameter as :func:`region_grid`'s ``spacing`` says; ends:
    per kept row whether its two ends lie on a butt plane (True) or on the surface's end
    (False), (R, 2)."""

    params: np.ndarray
    points: np.ndarray
    rows: np.ndarray
    ends: np.ndarray
    # what callers derive from this grid and ask for again (a plate's boundary and butt
    # sections, once per strip family tried): kept with the grid, dropped with it
    derived: dict = field(default_factory=dict, compare=False, repr=False)

    def __getstate__(self) -> dict:
        # a grid sent to another process goes without what was derived from it (a plate's
        # boundary: tens of kB that the receiver computes again if it asks)
        return dict(self.__dict__, derived={})

    @property
    def shape(self) -> tuple[int, int]:
        return self.points.shape[:2]

    def faces(self) -> np.ndarray:
        """Triangles (2 (R-1) (C-1), 3) of the grid, vertices numbered row-major."""
        return grid_triangles(*self.shape)

    def corners(self) -> np.ndarray:
        """The four corners (4, 3): seam lo at butt lo, seam lo at butt hi, seam hi at butt hi,
        seam hi at butt lo."""
        p = self.points
        return np.array([p[0, 0], p[0, -1], p[-1, -1], p[-1, 0]])

    def boundary(self) -> np.ndarray:
        """Closed boundary polyline (N, 3) around the grid (not repeated)."""
        return grid_ring(self.points)


def grid_triangles(rows: int, cols: int) -> np.ndarray:
    """Triangles (2 (R-1) (C-1), 3) of a grid of R x C points numbered row-major: every
    cell's (top left, top right, bottom right) first, then every cell's (top left, bottom
    right, bottom left)."""
    idx = np.arange(rows * cols).reshape(rows, cols)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    d, e = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    return np.concatenate([np.column_stack([a, b, e]), np.column_stack([a, e, d])]).astype(np.int64)


def grid_ring(values: np.ndarray) -> np.ndarray:
    """The boundary of a grid (R, C, k) as one closed ring (2 (R + C) - 4, k), not repeated:
    first row, last column, last row back, first column back."""
    return np.vstack([values[0, :], values[1:, -1], values[-1, -2::-1], values[-2:0:-1, 0]])


def _uv(long_axis: int, s: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return (s, g) if long_axis == 0 else (g, s)


def region_grid(surface: NurbsSurface, long_axis: int, g_lo, g_hi, planes, rows, cols,
                probe: int = 400, s_range=None, spacing: str = "parameter") -> PatchGrid | None:
    """Grid of the region between girth curves and planes; None when it is empty.

    long_axis : 0 when u runs along the hull (s = u, g = v), 1 when v does
    g_lo, g_hi : callables s (N,) -> girth parameter (N,), the two seams
    planes : (lower, upper), each (normal (3,), offset) or None for the surface's end; the
             region is where normal . p - offset >= 0 for lower and <= 0 for upper
    rows, cols : grid size (rows across the girth, columns along the length), each a count
                 (even fractions) or the fractions themselves, increasing within [0, 1]
                 (the columns' from 0 to 1; :func:`turn_refined`'s)
    s_range : optional (lo, hi) sub-range of the longitudinal parameter to search
    spacing : "length": row k of every column lies k / (rows - 1) of the girth curve's 3D
              length from seam lo (:func:`girth_fractions`); "parameter": at that fraction of
              the girth parameter between the seams

    The rows are even in length because a surface's girth parameter need not be: KVLCC2's
    loft of its main and flat-of-bottom faces keeps 42 % of its girth parameter on the 29 mm
    wide flat at its aft end, where rows even in the parameter crowded on the flat and left
    one 470 mm chord across the bilge; the plate's butt edge along that chord stepped 44 mm
    from its neighbour's beyond the loft's end plane. A row keeps its length fraction a along
    the plate; its girth fraction W(s, a) follows the column. Where the row meets a butt
    plane it is narrowed down with W linear in s between the two probe columns around the
    crossing (cheap: W is known at the probe columns), then once more with W fixed at its
    exact value at that first crossing, which the end keeps: the end lies on the plane, off
    the exact W only by W's change between the two crossings, which lie as close as the
    first W's error moves a point across the plane. Inside, W is exact at 4 cols columns
    across the rows and linear in s between them (KVLCC2's aft plates: rows even within
    0.1 %, 1.2 % at a column next to a kink of W along s; 3 to 4 times the old grid's time).
    """
    if spacing not in ("length", "parameter"):
        raise ValueError(f"region_grid: spacing is 'length' or 'parameter', not {spacing!r}")
    even = spacing == "length"
    dom = surface.domain_u if long_axis == 0 else surface.domain_v
    s_lo, s_hi = s_range if s_range is not None else dom
    s = np.linspace(s_lo, s_hi, probe)
    a = _fractions(rows, "rows", ends=False)  # a grid of kept rows may be asked for again
    t = _fractions(cols, "cols", ends=True)
    rows, cols = len(a), len(t)
    glo, ghi = np.asarray(g_lo(s), dtype=float), np.asarray(g_hi(s), dtype=float)

    def seams(ss):
        return np.asarray(g_lo(ss), dtype=float), np.asarray(g_hi(ss), dtype=float)

    def fractions(ss, lo, hi, aa):
        """Girth fractions (N, M) of length fractions aa (N, M) at columns ss (N,)."""
        if not even:
            return np.array(aa, dtype=float)
        return girth_fractions(surface, long_axis, ss, lo, hi, aa)

    def point(ss, ww):
        lo, hi = seams(ss)
        uu, vv = _uv(long_axis, ss, lo + ww * (hi - lo))
        return surface(uu, vv)

    def margin(pts):
        """How far inside both planes (the smaller signed distance), >= 0 inside."""
        out = np.full(pts.shape[:-1], np.inf)
        for plane, sign in zip(planes, (1.0, -1.0)):
            if plane is not None:
                out = np.minimum(out, sign * (pts @ np.asarray(plane[0], dtype=float) - plane[1]))
        return out

    if even and probe > PROBE_FRACTIONS:
        # W at PROBE_FRACTIONS columns, linear in s between them: the probe only finds each
        # row's run inside the planes, whose ends are then found with W exact
        ref = np.linspace(s_lo, s_hi, PROBE_FRACTIONS)
        w_ref = fractions(ref, *seams(ref), np.broadcast_to(a, (PROBE_FRACTIONS, rows)))
        w_probe = np.stack([np.interp(s, ref, w_ref[:, k]) for k in range(rows)])  # (rows, probe)
    else:
        w_probe = fractions(s, glo, ghi, np.broadcast_to(a, (probe, rows))).T  # (rows, probe)
    gg = glo[None, :] + w_probe * (ghi - glo)[None, :]
    probed = _probe_margins(surface, long_axis, s, gg, margin)
    rows_in, run = _longest_runs(probed >= 0)  # (R, 2) first and last inside
    bounds = s[run]
    ends_w = w_probe[rows_in[:, None], run]  # the girth fraction at each end (R, 2)
    flags = np.zeros(bounds.shape, dtype=bool)
    # the run's ends that lie on a plane (a sample outside beyond them) are narrowed down
    # between the last sample inside and the first outside, all rows at once
    beyond = run + np.array([-1, 1])
    task_row, task_end = np.nonzero((beyond >= 0) & (beyond < probe))
    if len(task_row):
        i_in, i_out = run[task_row, task_end], beyond[task_row, task_end]
        r_probe = rows_in[task_row]
        s_in, s_out = s[i_in], s[i_out]
        w_in, w_out = w_probe[r_probe, i_in], w_probe[r_probe, i_out]

        def along(ss_, k):
            """W linear in s between the bracket's probe columns."""
            return w_in[k] + (ss_ - s_in[k]) / (s_out[k] - s_in[k]) * (w_out[k] - w_in[k])

        task = np.arange(len(task_row))
        hit = narrow_crossings(lambda ss_, k: margin(point(ss_, along(ss_, k))), s_out, s_in,
                               probed[r_probe, i_out], probed[r_probe, i_in], task)
        w_hit = along(hit, task)
        if even:
            # W at the crossing is exact there, the crossing again with W fixed at it
            lo, hi = seams(hit)
            w_fix = fractions(hit, lo, hi, a[r_probe][:, None])[:, 0]
            f_in, f_out = margin(point(s_in, w_fix)), margin(point(s_out, w_fix))
            ok = (f_in >= 0) & (f_out < 0)  # else (rare) the first crossing stands
            if ok.any():
                hit[ok] = narrow_crossings(lambda ss_, k: margin(point(ss_, w_fix[k])), s_out[ok], s_in[ok],
                                           f_out[ok], f_in[ok], task[ok])
                w_hit[ok] = w_fix[ok]
        bounds[task_row, task_end] = hit
        ends_w[task_row, task_end] = w_hit
        flags[task_row, task_end] = True
    keep = bounds[:, 1] > bounds[:, 0]
    kept = rows_in[keep]
    ends_s = bounds[keep]
    on_plane = flags[keep]
    if len(kept) < 2:
        return None
    S = ends_s[:, :1] + t[None, :] * (ends_s[:, 1:] - ends_s[:, :1])
    W = np.empty(S.shape)
    W[:, -1], W[:, 0] = ends_w[keep, 1], ends_w[keep, 0]
    inner = S[:, 1:-1]
    n_ref = 4 * cols
    if inner.size and (not even or inner.size <= n_ref or np.ptp(inner) <= 0.0):
        lo, hi = seams(inner.ravel())
        W[:, 1:-1] = fractions(inner.ravel(), lo, hi, np.repeat(a[kept], cols - 2)[:, None]).reshape(inner.shape)
    elif inner.size:
        # the rows' columns differ in s only as their ends do: W exact at 4 cols columns
        # across them all (not at every point: R / 4 times fewer surface evaluations), linear
        # in s between them
        ref = np.linspace(inner.min(), inner.max(), n_ref)
        lo, hi = seams(ref)
        w_ref = fractions(ref, lo, hi, np.broadcast_to(a[kept], (n_ref, len(kept))))  # (n_ref, R)
        pos = (inner - ref[0]) / (ref[1] - ref[0])
        i = np.clip(pos.astype(np.int64), 0, n_ref - 2)
        f = np.clip(pos - i, 0.0, 1.0)
        r = np.arange(len(kept))[:, None]
        W[:, 1:-1] = w_ref[i, r] + f * (w_ref[i + 1, r] - w_ref[i, r])
    lo, hi = seams(S.ravel())
    G = (lo + W.ravel() * (hi - lo)).reshape(S.shape)
    u, v = _uv(long_axis, S, G)
    params = np.stack([u, v], axis=-1)
    points = surface(u.ravel(), v.ravel()).reshape(len(kept), cols, 3)
    return PatchGrid(params, points, a[kept], on_plane)


COARSE_PROBE = 40  # a long probe's columns sampled first; the others only around the region they find


def _probe_margins(surface: NurbsSurface, long_axis: int, s: np.ndarray, gg: np.ndarray, margin) -> np.ndarray:
    """How far inside the planes (R, P) the probe's points are: rows of girth parameters gg
    (R, P) at the columns s (P,). A probe of at least 4 COARSE_PROBE columns is first sampled
    at every (P // COARSE_PROBE)-th column; when some row lies inside there, only the columns
    from one such step before the first inside sample to one after the last are evaluated (the
    others read as outside), provided that no row is inside at their first or last column (it
    may reach beyond) and that every row's longest run inside them is at least a step long
    (a run elsewhere lies between two sparse columns, shorter: the grid keeps each row's
    longest). Else, and for a region too short for the coarse columns to meet (a 33 mm
    leftover on a 281 m loft), every column is. The
    columns evaluated are the same points as the whole probe's: the margins, and so the
    grid, are the same. A plate's region is one band across the rows: the sparse columns
    skip the hull's length away from it (half a plate boundary sample's time on the 160 m
    hull)."""
    rows, probe = gg.shape

    def at(columns: np.ndarray) -> np.ndarray:
        ss = np.broadcast_to(s[columns], (rows, len(columns)))
        u, v = _uv(long_axis, ss.ravel(), gg[:, columns].ravel())
        return margin(surface(u, v).reshape(rows, len(columns), 3))

    step = probe // COARSE_PROBE
    if step >= 4:
        coarse = np.arange(0, probe, step)
        hit = coarse[(at(coarse) >= 0).any(axis=0)]
        if hit.size:
            first, last = max(0, int(hit[0]) - step), min(probe - 1, int(hit[-1]) + step)
            columns = np.arange(first, last + 1)
            near = at(columns)
            inside = near >= 0
            bounded = (first == 0 or not inside[:, 0].any()) and (last == probe - 1 or not inside[:, -1].any())
            # a row's run beyond these columns lies between two sparse ones (under a step long):
            # it cannot be the row's longest, which the region's grid keeps, when the one here is longer
            rows_in, run = _longest_runs(inside)
            if bounded and len(rows_in) == rows and (run[:, 1] - run[:, 0] + 1 >= step).all():
                out = np.full((rows, probe), -np.inf)
                out[:, first:last + 1] = near
                return out
    return at(np.arange(probe))


def _longest_runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each row's longest run of True in ``mask`` (R, P), the first of equal ones, all rows at
    once (run starts and ends in row-major order pair up): the rows that have one (R',) and
    its first and last index (R', 2)."""
    padded = np.zeros((mask.shape[0], mask.shape[1] + 2), dtype=np.int8)
    padded[:, 1:-1] = mask
    step = np.diff(padded, axis=1)
    start_row, start = np.nonzero(step == 1)
    _, stop = np.nonzero(step == -1)
    order = np.lexsort((start, start - stop, start_row))
    rows_in, first = np.unique(start_row[order], return_index=True)
    return rows_in, np.column_stack([start[order][first], stop[order][first] - 1])


def _fractions(count_or_fractions, name: str, ends: bool) -> np.ndarray:
    """Grid fractions (N,): even ones for a count, else the given ones, checked to increase
    within [0, 1] (from 0 to 1 when ``ends``); ``name`` names them in the error."""
    if np.ndim(count_or_fractions) == 0:
        return np.linspace(0.0, 1.0, int(count_or_fractions))
    f = np.asarray(count_or_fractions, dtype=np.float64)
    if len(f) < 2 or np.any(np.diff(f) <= 0.0) or f[0] < 0.0 or f[-1] > 1.0 or (ends and (f[0], f[-1]) != (0.0, 1.0)):
        raise ValueError(f"region_grid: {name} fractions must increase within [0, 1]"
                         f"{' from 0 to 1' if ends else ''}, not {f.tolist()}")
    return f


def chord_sagittas(polyline: np.ndarray) -> np.ndarray:
    """How far (N - 1,) each chord of a polyline (N, 3) sampling a smooth curve stands off
    the curve, estimated from the turn at its ends: L^2 kappa / 8, kappa the larger of the
    two ends' turning angle over their mean chord length. Not seen: a turn within a
    polyline's end chords (they have one inner end) and within a single chord. A vertex
    beside a chord under 1e-9 of the polyline's length (points that coincide, such as a seam
    collapsing to a point at a strake's end) turns by nothing: its direction is round-off."""
    d = np.diff(np.asarray(polyline, dtype=np.float64), axis=0)
    length = np.linalg.norm(d, axis=1)
    kappa = np.zeros(len(length))
    if len(length) >= 2:
        unit = d / np.maximum(length, 1e-300)[:, None]
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", unit[:-1], unit[1:]), -1.0, 1.0))
        real = np.minimum(length[:-1], length[1:]) > 1e-9 * length.sum()
        at_vertex = np.where(real, turn, 0.0) / np.maximum(0.5 * (length[:-1] + length[1:]), 1e-300)
        kappa[:-1] = at_vertex
        kappa[1:] = np.maximum(kappa[1:], at_vertex)
    return length ** 2 * kappa / 8.0


def turn_refined(fractions: np.ndarray, polylines, trigger, target: float, max_pieces: int = 8) -> np.ndarray:
    """Fractions (M,) holding the given ones (N,), with every interval where one of the
    polylines (each (N, 3), sampled at these fractions) has a chord standing off its curve by
    more than ``trigger`` (a number, or one per interval (N - 1,); :func:`chord_sagittas`)
    cut into even pieces, as many as bring it within ``target`` (a sagitta falls with the
    square of the chord), at most ``max_pieces``; M = N when none is."""
    fractions = np.asarray(fractions, dtype=np.float64)
    worst = np.max([chord_sagittas(p) for p in polylines], axis=0)
    pieces = np.where(worst > trigger, np.clip(np.ceil(np.sqrt(worst / target)), 1, max_pieces), 1).astype(np.int64)
    if np.all(pieces == 1):
        return fractions
    return subdivided(fractions, pieces)


def subdivided(values: np.ndarray, pieces) -> np.ndarray:
    """Values (N, ...) (fractions, or the points of a polyline) with each interval between
    consecutive ones cut into ``pieces`` even parts (a count, or one per interval (N - 1,)):
    shape (sum of the pieces + 1, ...). The j-th of k parts starts at lo + j (hi - lo) / k,
    as ``np.linspace`` places it."""
    values = np.asarray(values, dtype=np.float64)
    if len(values) < 2:
        return values
    counts = np.broadcast_to(np.asarray(pieces, dtype=np.int64), (len(values) - 1,))
    trailing = (1,) * (values.ndim - 1)
    step = np.repeat(np.diff(values, axis=0) / counts.reshape(-1, *trailing), counts, axis=0)
    j = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)).reshape(-1, *trailing)
    return np.concatenate([j * step + np.repeat(values[:-1], counts, axis=0), values[-1:]])


def _near_cuts(old: np.ndarray, new: np.ndarray) -> np.ndarray:
    """(len(new) - 1,) whether each interval of ``new`` is no interval of ``old`` (a piece of
    a cut one, or one that spans a dropped fraction) or lies next to such an interval (a
    turn spreads over the chords either side of it)."""
    kept = np.isin(new, old)
    position = np.searchsorted(old, new)
    cut = ~(kept[:-1] & kept[1:] & (np.diff(position) == 1))
    near = cut.copy()
    near[1:] |= cut[:-1]
    near[:-1] |= cut[1:]
    return near


# a grid cut where its edges turn grows at most this many times along each direction
# (the most on the four real hulls: 9 times, the rows of DTMB 5415's plate at the stem)
TURN_GROWTH = 12


def turn_refined_grid(surface: NurbsSurface, long_axis: int, g_lo, g_hi, planes, rows: int, cols: int,
                      trigger: float, target: float, passes: int = 3, **kwargs) -> PatchGrid | None:
    """:func:`region_grid` (``kwargs`` passed on), with its columns cut where a seam row's
    chords (its first and last rows) stand off the seam by more than ``trigger`` and its
    rows where a butt column's do (:func:`turn_refined`). The pieces and the chords next to
    them are cut again while over ``target``: the estimate from the turn at a chord's ends
    spreads a turn concentrated in a short arc over the chord, and a chord next to a cut
    one, estimated under ``trigger``, stood off by 0.8 of ``trigger``. At most ``passes``
    rounds and TURN_GROWTH times the plain grid's size each way, so the chords aim at the
    target and may stay above it. A grid whose edges turn gently is the plain grid itself."""
    along = np.linspace(0.0, 1.0, cols)
    grid = region_grid(surface, long_axis, g_lo, g_hi, planes, rows, along, **kwargs)
    if grid is None:
        return None
    most_along, most_across = TURN_GROWTH * len(along), TURN_GROWTH * len(grid.rows)
    near_along, near_across = np.zeros(len(along) - 1, dtype=bool), np.zeros(len(grid.rows) - 1, dtype=bool)
    for _ in range(passes):
        seams, butts = (grid.points[0], grid.points[-1]), (grid.points[:, 0], grid.points[:, -1])
        new_along = turn_refined(along, seams, np.where(near_along, target, trigger), target)
        new_across = turn_refined(grid.rows, butts, np.where(near_across, target, trigger), target)
        new_along = new_along if len(new_along) <= most_along else along
        new_across = new_across if len(new_across) <= most_across else grid.rows
        if len(new_along) == len(along) and len(new_across) == len(grid.rows):
            break
        refined = region_grid(surface, long_axis, g_lo, g_hi, planes, new_across, new_along, **kwargs)
        if refined is None:
            return grid
        near_along, near_across = _near_cuts(along, new_along), _near_cuts(grid.rows, refined.rows)
        along, grid = new_along, refined
    return grid


# samples of a girth curve whose chords measure its length, per pass (see girth_fractions)
GIRTH_SAMPLES = 25
# probe columns at which a length-even grid measures its rows' girth fractions (linear between)
PROBE_FRACTIONS = 48


def girth_fractions(surface: NurbsSurface, long_axis: int, s: np.ndarray, g_lo: np.ndarray, g_hi: np.ndarray,
                    length: np.ndarray, samples: int = GIRTH_SAMPLES) -> np.ndarray:
    """Girth fractions w (N, M) where the girth curve w -> S(s, g_lo + w (g_hi - g_lo)) of
    each column s (N,) (seams g_lo, g_hi (N,)) has ``length`` (N, M) of its 3D length (as
    fractions) behind it; w = length at a column whose curve has no length.

    Cumulative chords of ``samples`` points even in w, then of as many even in the first
    estimate of length, each pass with the surface's girth knots of full multiplicity among
    them (where a loft joins two faces it may turn or change speed: KVLCC2's girth parameter
    runs 50 times slower on its flat than on its bilge), inverted linearly: on KVLCC2's
    plates 5 m across within 0.2 mm of the length (1e-3 of it without the second pass).
    """
    s = np.asarray(s, dtype=float)
    g_lo, g_hi = np.asarray(g_lo, dtype=float), np.asarray(g_hi, dtype=float)
    length = np.asarray(length, dtype=float)
    if not len(s):
        return length.copy()
    knots = surface.knots_v if long_axis == 0 else surface.knots_u
    degree = surface.degree_v if long_axis == 0 else surface.degree_u
    values, counts = np.unique(knots, return_counts=True)
    breaks = values[(counts >= degree) & (values > min(g_lo.min(), g_hi.min())) & (values < max(g_lo.max(), g_hi.max()))]
    span = g_hi - g_lo
    with np.errstate(divide="ignore", invalid="ignore"):
        w_breaks = np.clip((breaks[None, :] - g_lo[:, None]) / span[:, None], 0.0, 1.0)
    w_breaks = np.where(np.isfinite(w_breaks), w_breaks, 0.0)
    even = np.broadcast_to(np.linspace(0.0, 1.0, samples), (len(s), samples))
    w = np.sort(np.hstack([even, w_breaks]), axis=1)
    for again in (True, False):
        uu, vv = _uv(long_axis, np.repeat(s, w.shape[1]), (g_lo[:, None] + w * span[:, None]).ravel())
        p = surface(uu, vv).reshape(*w.shape, 3)
        cum = np.hstack([np.zeros((len(s), 1)), np.cumsum(np.linalg.norm(np.diff(p, axis=1), axis=2), axis=1)])
        total = cum[:, -1:]
        good = total[:, 0] > 0.0
        c = np.where(good[:, None], cum / np.where(good, total[:, 0], 1.0)[:, None], np.linspace(0.0, 1.0, w.shape[1]))
        if again:
            w = np.sort(np.hstack([_invert(c, w, even), w_breaks]), axis=1)
    out = _invert(c, w, length)
    # the seams exactly, and the parameter where the curve has no length
    out = np.where(length <= 0.0, 0.0, np.where(length >= 1.0, 1.0, out))
    return np.where(good[:, None], out, length)


def _invert(c: np.ndarray, w: np.ndarray, target: np.ndarray) -> np.ndarray:
    """w (N, M) at ``target`` (N, M) of the piecewise linear c -> w of each row, c and w (N, K)
    non-decreasing, c from 0 to 1 (a segment of no length gives its start)."""
    k = c.shape[1]
    seg = np.clip(np.sum(c[:, None, :] <= target[:, :, None], axis=2) - 1, 0, k - 2)
    c0, c1 = np.take_along_axis(c, seg, 1), np.take_along_axis(c, seg + 1, 1)
    w0, w1 = np.take_along_axis(w, seg, 1), np.take_along_axis(w, seg + 1, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(c1 > c0, (target - c0) / (c1 - c0), 0.0)
    return w0 + np.clip(f, 0.0, 1.0) * (w1 - w0)


# where each step tries points around the secant estimate of a crossing, in fractions of
# the bracket (the estimate's error falls as the square of the bracket, so a good one is
# caught by a near point and a poor one by a far one)
_NEAR = np.array([-1e-2, -1e-4, -1e-6, -1e-9, 0.0, 1e-9, 1e-6, 1e-4, 1e-2])


def narrow_crossings(f, lo: np.ndarray, hi: np.ndarray, f_lo: np.ndarray, f_hi: np.ndarray, data: np.ndarray,
                     bits: int = 48) -> np.ndarray:
    """Where f(x, data) (vectorised over brackets) turns >= 0, each bracketed by lo (f < 0)
    and hi (f >= 0), (N,) each: the hi end of every bracket once it is 2^-bits of its first
    width (what as many bisection steps leave) or two neighbouring floats.

    Each step evaluates, per bracket, the secant estimate, points 1e-2 to 1e-9 of the
    bracket and two ulps either side of it, and the middle, and keeps the first crossing
    from the lo end, as bisection would: a smooth crossing takes two to four evaluations of
    f (of 12 points per bracket) where bisection takes ``bits`` (of one point); where f is
    round-off noise or kinked at the crossing the middle keeps it within ``bits`` steps.
    """
    lo, hi = np.array(lo, dtype=np.float64), np.array(hi, dtype=np.float64)
    f_lo, f_hi = np.array(f_lo, dtype=np.float64), np.array(f_hi, dtype=np.float64)
    data = np.asarray(data)
    goal = np.abs(hi - lo) * 2.0 ** -bits
    active = np.arange(len(lo))
    for _ in range(bits):
        width = np.abs(hi[active] - lo[active])
        tiny = 2.0 * np.spacing(np.maximum(np.abs(lo[active]), np.abs(hi[active])))
        active = active[(width > goal[active]) & (width > tiny)]
        if not len(active):
            break
        a, b, fa, fb = lo[active], hi[active], f_lo[active], f_hi[active]
        # in fractions tau of the bracket from its lo end (the bracket may run either way)
        with np.errstate(divide="ignore", invalid="ignore"):
            guess = fa / (fa - fb)
        guess = np.where(np.isfinite(guess) & (guess > 0.0) & (guess < 1.0), guess, 0.5)
        # and two ulps of x either side: once the estimate is good to them the bracket
        # closes, where offsets in fractions of a bracket a few ulps wide fall on the estimate
        ulps = 2.0 * np.spacing(np.maximum(np.abs(a), np.abs(b))) / np.abs(b - a)
        tau = np.hstack([np.clip(guess[:, None] + _NEAR[None, :], 0.0, 1.0),
                         np.clip(guess[:, None] + ulps[:, None] * np.array([-1.0, 1.0]), 0.0, 1.0),
                         np.full((len(active), 1), 0.5)])
        tau.sort(axis=1)
        x = a[:, None] + tau * (b - a)[:, None]
        fx = f(x.ravel(), np.repeat(data[active], tau.shape[1])).reshape(x.shape)
        inside = fx >= 0
        first = np.where(inside.any(axis=1), np.argmax(inside, axis=1), tau.shape[1])  # first point inside
        rows = np.arange(len(active))
        has_in, has_out = first < tau.shape[1], first > 0
        j_in, j_out = np.minimum(first, tau.shape[1] - 1), np.maximum(first - 1, 0)
        hi[active[has_in]], f_hi[active[has_in]] = x[rows, j_in][has_in], fx[rows, j_in][has_in]
        lo[active[has_out]], f_lo[active[has_out]] = x[rows, j_out][has_out], fx[rows, j_out][has_out]
    return hi


def weld(vertices: np.ndarray, faces: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge vertices closer than ``tolerance`` (a collapsed seam end gives a whole row of
    one point) and drop the triangles that become degenerate. Returns (vertices, faces,
    index) with index[old vertex] = new vertex."""
    from scipy.spatial import cKDTree

    pairs = cKDTree(vertices).query_pairs(tolerance, output_type="ndarray")
    parent = np.arange(len(vertices))
    for i, j in pairs[np.argsort(pairs[:, 1])] if len(pairs) else []:
        ri, rj = i, j
        while parent[ri] != ri:
            ri = parent[ri]
        while parent[rj] != rj:
            rj = parent[rj]
        if ri != rj:
            parent[max(ri, rj)] = min(ri, rj)
    for k in range(len(parent)):
        r = k
        while parent[r] != r:
            r = parent[r]
        parent[k] = r
    used, new_index = np.unique(parent, return_inverse=True)
    f = new_index[faces]
    good = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    v = vertices[used]
    f = f[good]
    e1, e2 = v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]
    area = np.linalg.norm(np.cross(e1, e2), axis=1)
    f = f[area > 1e-12 * max(float(np.ptp(v, axis=0).max()), 1.0) ** 2]
    return v, f.astype(np.int64), new_index


def grid_frame(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents (R, C, 3) of a grid of points (R, C, 3): along its rows (central
    differences along axis 1), and across them (along axis 0) made orthogonal to the first."""
    along = np.gradient(points, axis=1)
    across = np.gradient(points, axis=0)
    along /= np.maximum(np.linalg.norm(along, axis=2, keepdims=True), 1e-300)
    across = across - np.sum(across * along, axis=2, keepdims=True) * along
    across /= np.maximum(np.linalg.norm(across, axis=2, keepdims=True), 1e-300)
    return along, across


def principal_frame(surface: NurbsSurface, u: np.ndarray, v: np.ndarray) -> tuple:
    """Principal curvatures (N, 2) [kappa_1, kappa_2] with |kappa_1| <= |kappa_2|, the
    direction (N, 2) of kappa_1 in (du, dv), and the tangents S_u, S_v (N, 3) at parameters
    u, v (N,), from central differences on the surface."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    hu = 1e-4 * np.ptp(surface.domain_u)
    hv = 1e-4 * np.ptp(surface.domain_v)
    # keep the stencil inside the domain
    u = np.clip(u, surface.domain_u[0] + hu, surface.domain_u[1] - hu)
    v = np.clip(v, surface.domain_v[0] + hv, surface.domain_v[1] - hv)
    s = {(i, j): surface(u + i * hu, v + j * hv) for i in (-1, 0, 1) for j in (-1, 0, 1)}
    su = (s[1, 0] - s[-1, 0]) / (2 * hu)
    sv = (s[0, 1] - s[0, -1]) / (2 * hv)
    suu = (s[1, 0] - 2 * s[0, 0] + s[-1, 0]) / hu**2
    svv = (s[0, 1] - 2 * s[0, 0] + s[0, -1]) / hv**2
    suv = (s[1, 1] - s[1, -1] - s[-1, 1] + s[-1, -1]) / (4 * hu * hv)
    n = np.cross(su, sv)
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    dot = lambda a, b: np.einsum("ij,ij->i", a, b)  # noqa: E731
    first = np.stack([np.stack([dot(su, su), dot(su, sv)], -1), np.stack([dot(su, sv), dot(sv, sv)], -1)], -2)
    second = np.stack([np.stack([dot(suu, n), dot(suv, n)], -1), np.stack([dot(suv, n), dot(svv, n)], -1)], -2)
    shape = np.linalg.solve(first, second)  # Weingarten map in (u, v) coordinates
    kappa, vecs = np.linalg.eig(shape)
    kappa, vecs = kappa.real, vecs.real
    order = np.argsort(np.abs(kappa), axis=1)
    k_sorted = np.take_along_axis(kappa, order, axis=1)
    least = np.take_along_axis(vecs, order[:, None, :1], axis=2)[..., 0]  # (N, 2) in (du, dv)
    return k_sorted, least, su, sv


def principal_curvatures(surface: NurbsSurface, u: np.ndarray, v: np.ndarray) -> tuple:
    """Principal curvatures (N, 2) [kappa_1, kappa_2] with |kappa_1| <= |kappa_2| and the 3D
    unit direction (N, 3) of kappa_1 (the direction of least bending: the rulings of a
    developable surface) at parameters u, v (N,), from central differences on the surface."""
    k_sorted, least, su, sv = principal_frame(surface, u, v)
    d3 = least[:, :1] * su + least[:, 1:] * sv
    d3 /= np.maximum(np.linalg.norm(d3, axis=1), 1e-300)[:, None]
    return k_sorted, d3
