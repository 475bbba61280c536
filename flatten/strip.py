"""The developable strip as rulings and a triangle mesh with its ruling structure kept."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .judge import UnitMap
from .nurbs import NurbsCurve
from .solution import SolutionSet

# Rulings (or points) per batch of temporaries: big strips are processed in batches of this
# many so that peak memory stays a few hundred bytes per ruling above the results (the
# temporaries of one batch are a few MB) while every batch is still one vectorised call.
CHUNK_RULINGS = 8192

# A path point's polish stops after a Newton step this short (unit square): its error is
# then about K * 1e-20 (K the zero set's curvature against the gradient's length), round-off,
# and the step that would confirm it is saved (a third of the polish on the strake's plates;
# the points agree with the polish to a step of round-off to 2e-15).
SETTLED_STEP = 1e-10


def batches(n: int, size: int = CHUNK_RULINGS):
    """Consecutive (start, stop) ranges covering range(n), each at most ``size`` long."""
    size = max(int(size), 1)
    return ((lo, min(lo + size, n)) for lo in range(0, n, size))


@dataclass(frozen=True)
class Strip:
    """Rulings of a strip and its triangle mesh.

    rulings : (K, 2) [t, T] on c and d
    samples : (m,) ruling parameters v in [0, 1] of the vertices on each ruling (m >= 3)
    vertices : (K * m, 3) model units; vertex k * m + j lies at v = samples[j] on ruling k
    faces : (2 (K-1) (m-1), 3) int, counter-clockwise seen from c' x (d - c)
    max_chord_error : (2,) largest distance between the boundary chords and c, d (NaN
        where not measured: :func:`build_strip`'s ``chords``)
    trim : (K, 2) or None, the interval of v each ruling keeps when the strip is trimmed
        (by butt planes); vertex k * m + j then lies at v = trim[k, 0] + (trim[k, 1] -
        trim[k, 0]) samples[j]
    """

    rulings: np.ndarray
    samples: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray
    max_chord_error: np.ndarray
    trim: np.ndarray | None = None

    @property
    def n_rulings(self) -> int:
        return len(self.rulings)

    def mesh(self):
        """The strip as a :class:`trimesh.Trimesh` with the vertex order kept (process=False)."""
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, process=False)

    def ruling_edges(self) -> np.ndarray:
        """(K (m-1), 2) vertex pairs along rulings."""
        m = len(self.samples)
        start = (np.arange(self.n_rulings)[:, None] * m + np.arange(m - 1)[None, :]).ravel()
        return np.column_stack([start, start + 1])


def grid_faces(n_rulings: int, m: int) -> np.ndarray:
    """Two triangles per quad of a K x m vertex grid, shape (2 (K-1) (m-1), 3): first
    every (a, c, b), then every (b, c, d) for the quad a = k m + j, b = a + 1, c = a + m,
    d = a + m + 1. Filled in place (no stacked temporaries)."""
    quads = max(n_rulings - 1, 0)
    n = quads * (m - 1)
    faces = np.empty((2 * n, 3), dtype=np.int64)
    for lo, hi in batches(quads):  # in batches: no index temporaries of the full size
        a = (np.arange(lo, hi)[:, None] * m + np.arange(m - 1)[None, :]).ravel()
        first = faces[lo * (m - 1):hi * (m - 1)]
        second = faces[n + lo * (m - 1):n + hi * (m - 1)]
        first[:, 0] = a
        first[:, 1] = a + m
        first[:, 2] = a + 1
        second[:, 0] = first[:, 2]
        second[:, 1] = first[:, 1]
        second[:, 2] = a + (m + 1)
    return faces


class PathSampler:
    """:func:`sample_path` of one solution, its set-up (the unit map with its knot lines,
    the path's fractions of length) done once for the many calls of a stage: the same
    values as :func:`sample_path`, call by call."""

    def __init__(self, solution: SolutionSet):
        self.solution = solution
        path = solution.path.points
        if solution.field is None:  # flat plate: the path is an arc-length correspondence
            self.unit, self.x = None, path
            self.lam = np.linspace(0.0, 1.0, len(path))
            return
        self.unit = UnitMap(solution.field)
        self.x = self.unit.to_unit(path)
        steps = np.hypot(*np.diff(self.x, axis=0).T)
        lam = np.concatenate([[0.0], np.cumsum(steps)])
        lam /= lam[-1]
        self.lam = lam

    def vertices(self) -> tuple[np.ndarray, np.ndarray]:
        """The path's own vertices: their fractions (M,) and [t, T] (M, 2), as they are
        (no polish: the path's points lie on the solution already, and the polish of one
        would move it by round-off only)."""
        return self.lam, (self.x if self.unit is None else self.unit.to_params(self.x))

    def unpolished(self, fractions: np.ndarray) -> np.ndarray:
        """Points [t, T] (N, 2) of the path at fractions of its length, interpolated between
        its vertices without the polish: where only the rulings' density is estimated from
        them (curvature and speed of c at t, of d at T) a point a trace tolerance off the
        solution changes nothing that matters."""
        return _interpolated(fractions, *self.vertices())

    def __call__(self, fractions: np.ndarray) -> np.ndarray:
        """Points [t, T] (N, 2) of the path at fractions (N,) of its length, polished."""
        if self.unit is None:
            return _interpolated(fractions, self.lam, self.x)
        fractions = np.asarray(fractions, dtype=np.float64)
        out = np.empty((len(fractions), 2))
        for lo, hi in batches(len(fractions)):  # the polish is pointwise: batches change nothing
            pts = _interpolated(fractions[lo:hi], self.lam, self.x)
            out[lo:hi] = self.unit.to_params(self.unit.polish(pts, iterations=6, settled=SETTLED_STEP))
        return out


def _interpolated(fractions: np.ndarray, lam: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The polyline x (M, 2) at fractions lam (M,), linearly between its points, (N, 2)."""
    return np.column_stack([np.interp(fractions, lam, x[:, 0]), np.interp(fractions, lam, x[:, 1])])


def sample_path(solution: SolutionSet, fractions: np.ndarray) -> np.ndarray:
    """Points of the chosen path at fractions of its length in the unit square, polished, (N, 2)."""
    return PathSampler(solution)(fractions)


def chord_errors(curve: NurbsCurve, params: np.ndarray) -> float:
    """Largest distance of the curve from its chords between consecutive parameters."""
    if len(params) < 2:
        return 0.0
    return max(_chord_errors(curve, params[lo:hi + 1]) for lo, hi in batches(len(params) - 1))


def _chord_errors(curve: NurbsCurve, params: np.ndarray) -> float:
    s = np.linspace(0.0, 1.0, 9)[1:-1]
    a, b = params[:-1], params[1:]
    mids = a[:, None] + s[None, :] * (b - a)[:, None]
    # one evaluation of the curve (pointwise): the chords' ends and the points between
    points = curve(np.concatenate([params, mids.ravel()]))
    pa, pb = points[:len(a)], points[1:len(params)]
    on_curve = points[len(params):].reshape(len(a), len(s), 3)
    # distance to the chord, measured perpendicular to it
    seg = pb - pa
    length2 = np.maximum(np.einsum("ij,ij->i", seg, seg), 1e-300)
    rel = on_curve - pa[:, None, :]
    along = np.einsum("nsj,nj->ns", rel, seg) / length2[:, None]
    perp = rel - along[..., None] * seg[:, None, :]
    return float(np.sqrt(np.einsum("nsj,nsj->ns", perp, perp)).max())


def choose_rulings(solution: SolutionSet, c: NurbsCurve, d: NurbsCurve,
                   chord_tolerance: float | None = None, n_rulings: int | None = None,
                   max_rulings: int = 20000) -> np.ndarray:
    """Rulings along the chosen path, (K, 2) [t, T].

    With ``n_rulings``: evenly spaced along the path. With ``chord_tolerance`` (model
    units): spaced so that both boundaries' chord errors stay below it, using the
    sagitta κ Δs² / 8 and doubling where a check finds it exceeded.
    """
    sample = PathSampler(solution)
    if n_rulings is not None:
        return sample(np.linspace(0.0, 1.0, max(int(n_rulings), 2)))
    dense = np.linspace(0.0, 1.0, 2049)
    pts = sample.unpolished(dense)  # the rulings themselves are polished, their chord errors checked
    curves = (c, d)
    density = np.zeros(len(dense))
    for axis, curve in enumerate(curves):
        # |ds/dlam| = |c'(t)| |dt/dlam|, from the same derivatives as the curvature; a seam
        # end with zero speed (a doubled end pole) has no curvature (0/0): it moves nowhere
        # there (ds = 0), so it asks for no rulings
        with np.errstate(divide="ignore", invalid="ignore"):
            speed, kappa = curve.speed_and_curvature(pts[:, axis])
        kappa = np.nan_to_num(kappa, nan=0.0, posinf=0.0)
        ds = speed * np.abs(np.gradient(pts[:, axis], dense))
        density = np.maximum(density, np.sqrt(np.maximum(kappa, 0.0) / (8.0 * chord_tolerance)) * ds)
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(dense))])
    count = int(np.clip(np.ceil(cumulative[-1] * 1.2) + 1, 2, max_rulings))
    for _ in range(6):
        if cumulative[-1] > 0:
            fractions = np.interp(np.linspace(0, cumulative[-1], count), cumulative, dense)
        else:
            fractions = np.linspace(0.0, 1.0, count)
        rulings = sample(fractions)
        worst = max(chord_errors(curve, rulings[:, axis]) for axis, curve in enumerate(curves))
        if worst <= chord_tolerance or count >= max_rulings:
            return rulings
        count = min(2 * count, max_rulings)
    return rulings


def build_strip(c: NurbsCurve, d: NurbsCurve, rulings: np.ndarray, samples_per_ruling: int = 5,
                chords: bool = True) -> Strip:
    """Mesh of the ruled surface along the given rulings, vertices on each ruling at
    evenly spaced v (>= 3 per ruling so that interior vertices exist). ``chords`` False:
    the boundary chord errors are not measured (NaN), for meshes only the curvature check
    reads."""
    m = max(int(samples_per_ruling), 3)
    v = np.linspace(0.0, 1.0, m)
    vertices = np.empty((len(rulings), m, 3))
    for lo, hi in batches(len(rulings)):
        pc = c(rulings[lo:hi, 0])
        pd = d(rulings[lo:hi, 1])
        vertices[lo:hi] = pc[:, None, :] * (1 - v)[None, :, None] + pd[:, None, :] * v[None, :, None]
    vertices = vertices.reshape(-1, 3)
    faces = grid_faces(len(rulings), m)
    errors = (np.array([chord_errors(c, rulings[:, 0]), chord_errors(d, rulings[:, 1])]) if chords
              else np.full(2, np.nan))
    return Strip(rulings, v, vertices, faces, errors)
