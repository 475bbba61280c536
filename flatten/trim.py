"""A solved strip trimmed by any region: points mapped onto the strip and developed.

A hull plate's region need not be bounded by rulings or planes (its seams are curves on the
hull; a strip whose rulings run butt to butt is trimmed by the seams, an end plate by the
hull's end). Each point of the region (boundary or interior, on the hull) is mapped to its
closest point on the strip, given by the path fraction lam of its ruling and its position v
in [0, 1] along that ruling, and developed exactly there (the development is linear along a
ruling). The cut outline is then the developed image of the region's boundary: it holds the
region's four corners by construction, whatever the family of rulings.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .develop import DevelopedStrip
from .nurbs import NurbsCurve
from .solution import SolutionSet
from .strip import PathSampler

NEWTON_STEPS = 16  # at most; a point stops once its step is below SETTLED ruling spacings
SETTLED = 1e-4
EDGE_V = 0.05  # a point found this near a ruling's end (as a share of it) is finished on exact rulings
EDGE_STEPS = 12
EDGE_SETTLED = 1e-8  # ruling spacings: an edge point's distance is first order in lam
SEED_SPACING = 6.0  # the seed's samples along a ruling, in ruling spacings apart
SEED_STRIDE = 3  # the seed samples every SEED_STRIDE-th ruling of the map
# up to this many (point, seed ruling) pairs the nearest sample is found ruling by ruling;
# beyond it a k-d tree of all samples (its build costs as much as ~5 x 10^4 pairs) is quicker
SEED_SCAN_PAIRS = 20000
SHORT_RULING = 1e4  # a ruling shorter than this many ulps of its coordinates is searched whole


@dataclass(frozen=True)
class Mapped:
    """Points mapped onto a strip (N points; model units).

    lam : (N,) path fraction of each point's ruling; v : (N,) position along it
    on_strip : (N, 3) the closest points of the rulings' lines (v unclipped); distance : (N,)
    |point - on_strip|; flat : (N, 2) their developed positions (the strip's development frame;
    None until :meth:`StripMap.developed`)
    nearest : (N, 3) the closest points of the strip itself (v clipped to its edges: a point
    a hair beyond a seam, as a hull's seam line is beyond a curve fitted to it, is on the seam)
    rulings : (N, 2) each point's ruling (t, T)
    """

    lam: np.ndarray
    v: np.ndarray
    on_strip: np.ndarray
    distance: np.ndarray
    flat: np.ndarray | None
    nearest: np.ndarray
    rulings: np.ndarray


def _nearest_sample_ruling(points: np.ndarray, a: np.ndarray, b: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Index (N,) of the ruling holding each point's nearest sample, the samples being
    a + v_k (b - a) on the rulings a-b (R, 3) at the fractions v (K,) evenly from 0 to 1:
    the squared distance is convex along a ruling, so only the samples around each
    point's projection on it compete (two either side), computed as the k-d tree holds
    them (the same floats; exact ties between rulings go to the first). A ruling within
    SHORT_RULING ulps of its coordinates is no line (its samples' computed distances need
    not be convex along it): all its samples compete."""
    span = b - a  # (R, 3)
    length2 = np.einsum("rk,rk->r", span, span)
    offset = points[:, None, :] - a[None, :, :]  # (N, R, 3)
    along = np.einsum("nrk,rk->nr", offset, span) / np.where(length2 > 0, length2, 1.0)
    last = len(v) - 1
    below = np.floor(np.clip(along, 0.0, 1.0) * last).astype(np.intp)
    best = np.full(along.shape, np.inf)
    for shift in (-1, 0, 1, 2):
        k = np.clip(below + shift, 0, last)
        sample = a[None, :, :] + v[k][..., None] * span[None, :, :]
        gap = points[:, None, :] - sample
        best = np.minimum(best, gap[..., 0] ** 2 + gap[..., 1] ** 2 + gap[..., 2] ** 2)
    # a ruling within round-off of a point (where seams meet) is no line: all its samples compete
    scale = np.maximum(np.abs(a).max(axis=1), np.abs(b).max(axis=1))
    short = np.flatnonzero(length2 <= (SHORT_RULING * np.finfo(np.float64).eps * scale) ** 2)
    if len(short):
        sample = a[short][:, None, :] + v[None, :, None] * span[short][:, None, :]  # (S, K, 3)
        gap = points[:, None, None, :] - sample[None]
        best[:, short] = (gap[..., 0] ** 2 + gap[..., 1] ** 2 + gap[..., 2] ** 2).min(axis=2)
    return np.argmin(best, axis=1)


class StripMap:
    """Closest points on a solved strip and their exact developed positions.

    solution : a truthy SolutionSet of the pair (c, d); n_rulings : rulings of the coarse
    search (evenly spaced in path fraction); the search only seeds a Newton iteration on
    the exact rulings, so its density sets the cost, not the accuracy.
    """

    def __init__(self, solution: SolutionSet, c: NurbsCurve, d: NurbsCurve, n_rulings: int = 801):
        from scipy.interpolate import PchipInterpolator

        self.solution, self.c, self.d = solution, c, d
        self.sampler = PathSampler(solution)
        self.lam = np.linspace(0.0, 1.0, max(int(n_rulings), 3))
        self.rulings = self.sampler(self.lam)
        self.a3, self.b3 = c(self.rulings[:, 0]), d(self.rulings[:, 1])
        # the search's rulings between the exact ones: monotone cubics in lam (t and T only
        # grow along a path, so they stay inside the curves' domains, fans and kinks too)
        self._between = PchipInterpolator(self.lam, self.rulings, axis=0)
        self._developed = self._order = self._tree = self._seeding = None

    def ends(self, lam: np.ndarray):
        """Rulings (N, 2) at path fractions lam and their 3D ends on c and d."""
        r = self.sampler(np.clip(lam, 0.0, 1.0))
        return r, self.c(r[:, 0]), self.d(r[:, 1])

    def _ends_between(self, lam: np.ndarray):
        """3D ends of the rulings at path fractions lam interpolated between the map's exact
        rulings (no polish: what the search needs, a few ulps of lam from the exact ones)."""
        r = self._between(np.clip(lam, 0.0, 1.0))
        return self.c(r[:, 0]), self.d(r[:, 1])

    def _seed(self, points: np.ndarray) -> np.ndarray:
        """Path fraction (N,) of each point's nearest sample of the strip (scanned ruling by
        ruling for a few points, else from a k-d tree; ties to the first ruling either way), the
        samples on every SEED_STRIDE-th of the map's rulings, SEED_SPACING ruling spacings
        apart along them: the nearest sample's lam is then within (SEED_SPACING +
        SEED_STRIDE) / 2 spacings of the closest point's however far the rulings lean over (a
        seam strip extended past its butts: nine samples along its 3.5 m rulings left a seed
        24 spacings off, beyond Newton's reach), and Newton in :meth:`locate` (steps of up to
        four spacings) takes it from there."""
        from scipy.spatial import cKDTree

        if self._seeding is None:
            mid = 0.5 * (self.a3 + self.b3)
            spacing = float(np.median(np.linalg.norm(np.diff(mid, axis=0), axis=1)))
            reach = float(np.linalg.norm(self.b3 - self.a3, axis=1).max())
            per_ruling = int(np.clip(np.ceil(reach / max(SEED_SPACING * spacing, 1e-300)) + 1, 3, 129))
            taken = np.unique(np.append(np.arange(0, len(self.lam), SEED_STRIDE), len(self.lam) - 1))
            self._seeding = (self.a3[taken], self.b3[taken], np.linspace(0.0, 1.0, per_ruling), self.lam[taken])
        a, b, v, lam = self._seeding
        if not np.all(np.isfinite(points)):
            raise ValueError("StripMap: points to locate must be finite")
        if len(points) * len(a) <= SEED_SCAN_PAIRS and self._tree is None:
            return lam[_nearest_sample_ruling(points, a, b, v)]
        if self._tree is None:
            samples = a[:, None, :] + v[None, :, None] * (b - a)[:, None, :]
            # a tree built by the sliding midpoint rule, unbalanced and uncompacted, builds in
            # half the time and answers as quickly; any exact tree finds the same nearest
            # sample, and ties are settled below
            self._tree = cKDTree(samples.reshape(-1, 3), balanced_tree=False, compact_nodes=False)
        # a point's seed must not depend on how it was asked for (the plate's probe is
        # judged as the whole region is): where samples tie for nearest (a fan's rulings
        # share their apex), the first ruling holding one, as the scan picks
        distance, index = self._tree.query(points, k=2)
        ruling = index[:, 0] // len(v)
        tied = np.flatnonzero(distance[:, 1] == distance[:, 0])
        if len(tied):
            ruling[tied] = _nearest_sample_ruling(points[tied], a, b, v)
        return lam[ruling]

    def locate(self, points: np.ndarray, edges: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(lam, v, rulings, on_strip): see :meth:`_locate`; on_strip (N, 3) on the rulings'
        lines (v unclipped). ``edges=False``: points found within EDGE_V of a ruling's end are
        not finished on exact rulings (they are then off by the interpolated ruling's error,
        to first order); the others are located as by default, to the same bits."""
        lam, v, rulings, a, b = self._locate(points, edges)
        return lam, v, rulings, a + v[:, None] * (b - a)

    def _locate(self, points: np.ndarray, edges: bool = True):
        """(lam, v, rulings, a, b) of the closest strip point of each point (N, 3), a and b
        (N, 3) its ruling's ends on c and d: the
        seed (:meth:`_seed`), then Gauss-Newton on the residual to the closest point of the
        ruling segment (central differences in lam) on rulings interpolated between the map's
        exact ones, and the exact ruling at the lam found (an error e in lam moves the
        distance by O(e^2) inside the strip; on its edges by O(e), so points found there are
        finished on exact rulings). v is not clipped: a point beyond the strip's boundary
        curve has v < 0 or > 1."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        lam = self._seed(points)
        spacing = float(self.lam[1] - self.lam[0])
        h = 0.05 * spacing

        def foot(x, where):
            a, b = self._ends_between(x)
            v = np.clip(_along(points[where], a, b), 0.0, 1.0)
            return a + v[:, None] * (b - a)

        def stencil(x, where):
            # kept inside the path: at lam = 0 or 1 a clipped stencil reads no slope
            centre = np.clip(x, h, 1.0 - h)
            return centre, (foot(centre + h, where) - foot(centre - h, where)) / (2 * h)

        def step(residual, tangent, cap):
            speed2 = np.einsum("ij,ij->i", tangent, tangent)
            return np.clip(np.einsum("ij,ij->i", residual, tangent) / np.where(speed2 > 0, speed2, 1.0), -cap, cap)

        active = np.arange(len(points))
        for _ in range(NEWTON_STEPS):
            # Gauss-Newton on the residual point - foot(lam): it needs only the foot's first
            # derivative, which the monotone cubics give well; Newton on the squared distance
            # read their second derivative, which jumps at every exact ruling, and a seed on
            # one (the k-d tree's always are) could see a minimum as a maximum and stay put
            # (a DTMB 5415 corner 2.04 mm off the strip where it is 0.16 mm). A point on the
            # strip's edge (a region's corner on a seam) converges only linearly there, where
            # the foot's speed jumps: each point stops when its step settles.
            x = lam[active]
            centre, tangent = stencil(x, active)
            residual = points[active] - (foot(centre, active) + (x - centre)[:, None] * tangent)
            moved = step(residual, tangent, 4 * spacing)
            lam[active] = np.clip(x + moved, 0.0, 1.0)
            active = active[np.abs(moved) > SETTLED * spacing]
            if not len(active):
                break
        rulings, a, b = self.ends(lam)
        v = _along(points, a, b)
        # a point whose closest strip point lies on the strip's edge (a corner on a seam) is
        # as far off as the interpolated ruling is from the exact one, to first order (0.9 mm
        # on a DTMB 5415 corner, against a corner limit of 1 mm): it is finished on the
        # exact rulings, the interpolated ones giving only the step's direction
        edge = np.flatnonzero((v < EDGE_V) | (v > 1.0 - EDGE_V)) if edges else np.zeros(0, dtype=int)
        for _ in range(EDGE_STEPS):
            if not len(edge):
                break
            x = lam[edge]
            q = a[edge] + np.clip(v[edge], 0.0, 1.0)[:, None] * (b[edge] - a[edge])
            moved = step(points[edge] - q, stencil(x, edge)[1], spacing)
            lam[edge] = np.clip(x + moved, 0.0, 1.0)
            rulings[edge], a[edge], b[edge] = self.ends(lam[edge])
            v[edge] = _along(points[edge], a[edge], b[edge])
            edge = edge[np.abs(moved) > EDGE_SETTLED * spacing]
        return lam, v, rulings, a, b

    def develop(self, rulings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Developed ends (along c, along d), (N, 2) each, of the given rulings (within the
        map's t range), in one frame with this map's own rulings: the map's rulings are
        developed exactly once, the given ones integrated from the break before each on
        that piece's spectral interpolant (:class:`DevelopedStrip`), to round-off."""
        strip = self._development()
        ends = strip.ends(rulings)
        return ends.along_c, ends.along_d

    def own_development(self) -> tuple[np.ndarray, np.ndarray]:
        """Developed ends (along c, along d), (K, 2) each, of this map's own rulings."""
        strip = self._development()
        position = np.empty(len(self.rulings), dtype=int)
        position[self._order] = np.arange(len(self.rulings))
        return strip.development.along_c[position], strip.development.along_d[position]

    def _development(self) -> DevelopedStrip:
        if self._developed is None:
            self._order = np.lexsort((self.rulings[:, 1] * self.solution.path.orientation, self.rulings[:, 0]))
            self._developed = DevelopedStrip(self.c, self.d, self.rulings[self._order], self.solution.field)
        return self._developed

    def map(self, points: np.ndarray) -> tuple[Mapped, np.ndarray, np.ndarray]:
        """Mapped points, and the developed ends (K, 2) x 2 of this map's own rulings in the
        same frame."""
        return self.developed(self.closest(points))

    def closest(self, points: np.ndarray) -> Mapped:
        """Points (N, 3) mapped onto the strip, not yet developed (``flat`` None): what a
        verdict needs, before the development a strip that fails never gets."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        lam, v, rulings, a, b = self._locate(points)
        on_strip, nearest = a + v[:, None] * (b - a), a + np.clip(v, 0.0, 1.0)[:, None] * (b - a)
        return Mapped(lam, v, on_strip, np.linalg.norm(points - on_strip, axis=1), None, nearest, rulings)

    def developed(self, mapped: Mapped) -> tuple[Mapped, np.ndarray, np.ndarray]:
        """The mapped points with their developed positions, and the developed ends (K, 2) x 2
        of this map's own rulings in the same frame."""
        ac, ad = self.develop(mapped.rulings)
        flat = ac + mapped.v[:, None] * (ad - ac)
        own_c, own_d = self.own_development()
        return replace(mapped, flat=flat), own_c, own_d


def ruling_intervals(lam: np.ndarray, boundary_lam: np.ndarray, boundary_v: np.ndarray) -> np.ndarray:
    """Per ruling at path fraction lam (K,), the interval [lo, hi] of v inside the closed
    polygon (boundary_lam, boundary_v) (N,) in the strip's (lam, v) coordinates: the lowest and
    highest crossing of the polygon by the ruling, (K, 2); NaN where the ruling misses it."""
    a_l, a_v = boundary_lam, boundary_v
    b_l, b_v = np.roll(a_l, -1), np.roll(a_v, -1)
    out = np.full((len(lam), 2), np.nan)
    for lo in range(0, len(lam), 512):
        x = lam[lo:lo + 512, None]
        crosses = ((a_l[None] <= x) & (x < b_l[None])) | ((b_l[None] <= x) & (x < a_l[None]))
        with np.errstate(divide="ignore", invalid="ignore"):
            f = (x - a_l[None]) / (b_l - a_l)[None]
        v = np.where(crosses, a_v[None] + f * (b_v - a_v)[None], np.nan)
        some = crosses.any(axis=1)
        out[lo:lo + 512, 0] = np.where(some, np.nanmin(np.where(crosses, v, np.inf), axis=1), np.nan)
        out[lo:lo + 512, 1] = np.where(some, np.nanmax(np.where(crosses, v, -np.inf), axis=1), np.nan)
    return out


def _along(points, a, b):
    r = b - a
    return np.einsum("ij,ij->i", points - a, r) / np.maximum(np.einsum("ij,ij->i", r, r), 1e-300)


def barycentric(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (N, 3) of points p (N, 3) in triangles tri (N, 3, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, p - a
    d00, d01, d11 = (np.einsum("ij,ij->i", x, y) for x, y in ((v0, v0), (v0, v1), (v1, v1)))
    d20, d21 = np.einsum("ij,ij->i", v2, v0), np.einsum("ij,ij->i", v2, v1)
    den = d00 * d11 - d01**2
    den = np.where(den == 0, 1.0, den)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.column_stack([1 - v - w, v, w])
