"""Erection pulls: flat and strip plates that step from each other pulled together elastically.

A flat or strip plate is delivered within the fit tolerance of the hull; two neighbours off it
in opposite directions step at their shared edge. At erection a yard pulls such edges
together (strongbacks, wedges, dogs) and the plate onto its frames before welding: the plate
is cut and rolled as developed and bent a little more, elastically, into place. That is what
the fit tolerance already assumes of every flat plate on a curved hull, and what
:mod:`pipeline.shop.rolling` assumes of a curvature flatter than the no-roll radius. The steps
over the limit that the joint programme (:mod:`.joint`) leaves between flat and strip plates
are nearly all misalignments through the plates (at 60 of the 67 worst points over 3 mm on
the 160 m hull's shell the gap to the other plate lies along its normal to within 10 %,
bench/README.md), so a pull through the plate takes them.

A plate's pull is a displacement field, each component a polynomial of degree three in each of
the plate's two in-plane coordinates (its principal axes): enough to twist a corner, bow an
edge or follow the frames, never a wrinkle. The pulls of all the plates that step are chosen
together by least squares, in model units:
 - along every shared edge with a flat or strip neighbour (pulled or not) each edge point
   and its closest point on the neighbour's edge meet along their mean normal, each plate
   moving along its own normal (a slide in its own surface would close a step where two
   plates meet at an angle, at the cost of moving every other edge; weight 1 per point);
 - the plate keeps its lengths to first order (a sample of its mesh edges, ISOMETRY_MM: the
   pull of a curved plate comes with the slide along it that keeps it developed);
 - its points are drawn onto the hull along its normal (TOWARD_HULL: two neighbours off the
   hull on either side meet on it, and a flat plate is pulled toward its frames);
 - the pull bends the plate little and moves it little (LEAST_BENDING, KEEP_SHORT).
PULL_ROUNDS rounds, the plates measured again after each. Formed neighbours are formed
afterwards to meet the pulled edges (:mod:`.follow`).

A pull is elastic or it is not taken. Each plate's pull is scaled down (PULL_SHARES) until
 - no point moves further than PULL_SLIDE fit tolerances and the plate, as pulled, lies
   within the tolerance of its own surface (a flat plate's plane, not its region on the hull);
 - its bending stress ``E' t kappa / 2`` (``kappa`` the largest change of curvature across an
   edge of its mesh, :func:`bending`; plane strain as in :mod:`pipeline.shop.rolling`) stays
   within PULL_STRESS_SHARE of the yield stress: half the share a plate pulled into place
   may keep (the other half is left for the curvature it is already pulled into unrolled);
 - it stretches no edge of the plate's mesh by more than PULL_STRAIN (membrane stress about
   21 MPa; a curved plate pulled along its normals without sliding would stretch by w / R).
The plate keeps its class, development, outline, bending lines, marks and templates; its 3D
edges, hull fit and OBJ are those of the plate as pulled (``erection_pull`` in its JSON).
"""

from __future__ import annotations

import copy
import dataclasses
import functools
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from pipeline.shop.rolling import E_STEEL, NU_STEEL, yield_stress

from .fitup import EdgeMeasures, _common, _dense, closest_on
from .ownsurface import hull_distance, hull_points
from .rigid import moved_edges, pending_transform, place_when_done

PULL_STRESS_SHARE = 0.25  # of the yield stress: the pull's own bending stress at most
PULL_STRAIN = 1e-4  # the largest stretch of a mesh edge a pull may put in (membrane stress about 21 MPa)
PULL_SHARES = (1.0, 0.75, 0.5, 0.25)  # of a plate's pull, tried in turn until it passes
PULL_SLIDE = 2.0  # a pull moves no point further than this many fit tolerances (it ends within one of the hull)
PULL_ROUNDS = 3  # solve, check, measure again
ROW_MM = 100.0  # spacing of the edge points that must meet
KEEP_SHORT = 0.05  # weight of the term that keeps the pulls short through the plate (against 1 an edge point)
KEEP_STILL = 1.0  # ... and along it
LEAST_BENDING = 1.0  # weight of the pull's bending (its sagittas over the plate), as of an edge point
ISOMETRY_MM = 20000.0  # weight of a mesh edge's first-order stretch: 1e-4 weighs as 2 mm of an edge point's miss
ISOMETRY_EDGES = 400  # mesh edges a plate's stretch is held at
TOWARD_HULL = 0.3  # weight of a point's pull onto the hull (against 1 for an edge point meeting its neighbour)
DEGREE = 3  # of the pull's polynomial in each in-plane coordinate: a corner twisted, an edge bowed twice
PULLABLE = ("flat", "developable")
FORMED = "formed"
FORMED_HOLDS = 0.5  # weight of a formed neighbour's edge point (against 1 for a flat or strip neighbour's)
RULE = ("pulled at erection (strake.pull_steps): the flat and strip plates that step from a flat or strip "
        "neighbour by more than the limit after the joint programme are pulled, each by a displacement of degree 3 "
        "in each of its in-plane coordinates, all chosen together by least squares so that every shared edge with a "
        "flat or strip neighbour meets along the normal, each plate keeps its lengths and is drawn toward the hull; "
        "a pull is scaled down until it moves no point further than twice the fit tolerance, leaves the plate "
        f"within it of the hull, bends it at most {PULL_STRESS_SHARE:g} of the yield stress and stretches it at "
        f"most {PULL_STRAIN:g}; the plate keeps its class, development, outline, lines and templates (cut and rolled "
        "as developed, pulled elastically at erection)")


@dataclass(frozen=True)
class PullField:
    """A plate's pull: the displacement ``basis(p) @ coefficients`` (3,) of each point p,
    ``coefficients`` (K, 3). ``origin`` (3,), ``axes`` (2, 3) the plate's principal in-plane
    directions, ``centre`` and ``half`` (2,) its extent along them (model units); anchors
    (M, 3) and their unit normals (M, 3): the plate's mesh as it lies when pulled."""

    origin: np.ndarray
    axes: np.ndarray
    centre: np.ndarray
    half: np.ndarray
    anchors: np.ndarray
    normals: np.ndarray
    coefficients: np.ndarray

    def uv(self, points: np.ndarray) -> np.ndarray:
        """(N, 2) normalised in-plane coordinates of points (N, 3), about [-1, 1] on the plate."""
        return ((np.asarray(points, dtype=np.float64) - self.origin) @ self.axes.T - self.centre) / self.half

    def basis(self, points: np.ndarray) -> np.ndarray:
        """(N, K) the polynomial basis at points (N, 3), K = (DEGREE + 1)^2."""
        uv = self.uv(points)
        powers = np.arange(DEGREE + 1)
        return (uv[:, :1, None] ** powers[None, :, None] * uv[:, None, 1:] ** powers[None, None, :]).reshape(len(uv), -1)

    def sagittas(self, points: np.ndarray) -> tuple[np.ndarray, ...]:
        """The basis's second derivatives at points (N, 3) in the normalised coordinates, (N, K)
        each: d2/du2, sqrt(2) d2/dudv, d2/dv2 (the pull's bending over the plate's half
        extents, as a length: a sagitta)."""
        uv = self.uv(points)
        powers = np.arange(DEGREE + 1)

        def derivative(values, order):
            factor = powers * (powers - 1) if order == 2 else (powers if order == 1 else np.ones_like(powers))
            return factor * values[:, None] ** np.maximum(powers - order, 0)

        out = []
        for du, dv, weight in ((2, 0, 1.0), (1, 1, np.sqrt(2.0)), (0, 2, 1.0)):
            out.append(weight * (derivative(uv[:, 0], du)[:, :, None] * derivative(uv[:, 1], dv)[:, None, :])
                       .reshape(len(uv), -1))
        return tuple(out)

    @cached_property
    def _tree(self):
        from scipy.spatial import cKDTree

        return cKDTree(self.anchors)

    def normal(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) the unit normal of the plate's anchor nearest each point (N, 3)."""
        _, nearest = self._tree.query(np.asarray(points, dtype=np.float64))
        return self.normals[nearest]

    def scaled(self, share: float) -> PullField:
        return dataclasses.replace(self, coefficients=share * self.coefficients)

    def move(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) the pull's displacement of points (N, 3), model units."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return self.basis(points) @ self.coefficients

    def apply(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64)
        return points + self.move(points).reshape(points.shape)


def plate_frame(points: np.ndarray, faces: np.ndarray) -> PullField:
    """A zero pull on the plate whose mesh is ``points`` (M, 3), ``faces`` (F, 3): its
    principal in-plane axes, extent and per-vertex normals (oriented as its faces)."""
    points = np.asarray(points, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    origin = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - origin, full_matrices=False)
    axes = vt[:2]
    flat = (points - origin) @ axes.T
    lo, hi = flat.min(axis=0), flat.max(axis=0)
    corners = points[faces]
    face_normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])  # area-weighted
    normals = np.zeros_like(points)
    for k in range(3):
        np.add.at(normals, faces[:, k], face_normals)
    length = np.linalg.norm(normals, axis=1)
    normals = np.where(length[:, None] > 0, normals / np.where(length > 0, length, 1.0)[:, None], vt[2])
    return PullField(origin, axes, 0.5 * (lo + hi), np.maximum(0.5 * (hi - lo), 1e-12), points, normals,
                     np.zeros(((DEGREE + 1) ** 2, 3)))


class _Rows:
    """A sparse least-squares system over the pulls of several plates, a row block at a time."""

    def __init__(self, names: list):
        self.size = 3 * (DEGREE + 1) ** 2
        self.column = {name: k * self.size for k, name in enumerate(sorted(names))}
        self.rows, self.cols, self.values, self.rhs = [], [], [], []

    def add(self, blocks: list, target: np.ndarray) -> None:
        """Rows ``sum(block @ coefficients of its plate) = target`` (n,); ``blocks``: [(plate,
        basis (n, K), direction (n, 3))]: the pull's component along the direction."""
        start = len(self.rhs)
        self.rhs.extend(np.asarray(target, dtype=np.float64).tolist())
        for name, basis, direction in blocks:
            block = (basis[:, :, None] * direction[:, None, :]).reshape(len(basis), -1)
            self.rows.append(np.repeat(np.arange(start, start + len(block)), block.shape[1]))
            self.cols.append(np.tile(self.column[name] + np.arange(block.shape[1]), len(block)))
            self.values.append(block.ravel())

    def solve(self) -> dict:
        """The least-squares coefficients of every plate, {name: (K, 3)}: the normal equations
        (a few thousand unknowns, every plate's rows keep its own pull short: positive
        definite), sparse as the plates are (a plate's unknowns meet only its neighbours'):
        SuperLU, not a dense Cholesky factor of every plate against every other."""
        import warnings

        from scipy.linalg import lstsq
        from scipy.sparse import coo_matrix
        from scipy.sparse.linalg import MatrixRankWarning, spsolve

        if not self.rows:
            return {name: np.zeros((self.size // 3, 3)) for name in self.column}
        matrix = coo_matrix((np.concatenate(self.values), (np.concatenate(self.rows), np.concatenate(self.cols))),
                            shape=(len(self.rhs), self.size * len(self.column))).tocsr()
        normal = (matrix.T @ matrix).tocsc()
        right = matrix.T @ np.asarray(self.rhs)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MatrixRankWarning)  # singular: NaN, solved below instead
            solution = spsolve(normal, right)
        if not np.all(np.isfinite(solution)):  # (no row keeps some plate's pull short)
            solution = lstsq(normal.toarray(), right)[0]
        return {name: solution[at:at + self.size].reshape(-1, 3) for name, at in self.column.items()}


def solve_pulls(frames: dict, names: list, records: dict, pairs: list, mm_per_unit: float,
                faces: dict) -> dict:
    """{plate: PullField} the pulls of the plates ``names`` chosen together (least squares):
    every shared edge in ``pairs`` between a plate pulled and a flat or strip plate
    (``records``: {name: (PlateEdges, part)}) meets along the mean normal, each plate moving
    along its own (a formed neighbour's edge holding at FORMED_HOLDS); each plate's mesh
    (``faces``) keeps its lengths to first order (ISOMETRY_MM), its points are drawn onto
    the hull along its normal (TOWARD_HULL) and its pull bends it little (LEAST_BENDING) and
    moves it little, through it (KEEP_SHORT) and less along it (KEEP_STILL). ``frames``: a
    zero pull (:func:`plate_frame`) of every plate pulled and of its flat and strip
    neighbours (their normals)."""
    system = _Rows(names)
    column = system.column
    spacing = ROW_MM / mm_per_unit
    for q in pairs:
        kinds = [records[n][0].klass for n in (q.a, q.b)]
        if (q.a not in column and q.b not in column) or any(k not in (*PULLABLE, FORMED) for k in kinds):
            continue
        # a formed neighbour is formed afterwards to meet the pulled edge, but only within its
        # own tolerance of the hull: its edge (on the hull as developed) holds the pulled one
        # more weakly than a flat or strip neighbour's does
        weight = FORMED_HOLDS if FORMED in kinds else 1.0
        ea, eb = records[q.a][0].edge(q.side_a), records[q.b][0].edge(q.side_b)
        if ea is None or eb is None:
            continue
        da, db = _dense(ea, spacing), _dense(eb, spacing)
        for (na, dense_a), (nb, dense_b) in (((q.a, da), (q.b, db)), ((q.b, db), (q.a, da))):
            lo, hi = _common(dense_a, dense_b)
            inside = (dense_a.s3 >= lo) & (dense_a.s3 <= hi)
            if inside.sum() < 2:
                continue
            p = dense_a.p3[inside]
            feet, _ = closest_on(p, dense_b)
            known = na if na in frames else nb
            n_a = frames[na].normal(p) if na in frames else frames[known].normal(feet)
            n_b = frames[nb].normal(feet) if nb in frames else n_a
            n_b = np.where(np.sum(n_a * n_b, axis=1)[:, None] < 0, -n_b, n_b)
            # they meet along the mean normal, each by its pull along its own normal: the steps
            # are misalignments through the plates, and where two plates meet at an angle a
            # slide in its own surface would close one at the cost of moving all its other edges
            d = n_a + n_b
            d /= np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
            blocks = [(name, weight * sign * frames[name].basis(at), np.sum(d * n, axis=1)[:, None] * n)
                      for name, sign, at, n in ((na, -1.0, p, n_a), (nb, 1.0, feet, n_b)) if name in column]
            system.add(blocks, -weight * np.sum(d * (feet - p), axis=1))
    for name in column:
        frame = frames[name]
        edges = records[name][0]
        pick = frame.anchors[np.linspace(0, len(frame.anchors) - 1, min(len(frame.anchors), 50)).astype(int)]
        ring = np.vstack([pick, *(_dense(e, spacing).p3 for e in edges.edges)])
        # the plate, its edges and a sample of the rest, drawn onto the hull along its normal,
        # more weakly than its edges meet: two neighbours off the hull on either side meet on
        # it, and a flat plate pulled is pulled toward its frames
        normal = frame.normal(ring)
        on_hull = hull_points(records[name][1].hull, ring)
        system.add([(name, TOWARD_HULL * frame.basis(ring), normal)], TOWARD_HULL * np.sum(normal * (on_hull - ring), axis=1))
        start, end = _sample_edges(faces[name], ISOMETRY_EDGES)
        chord = frame.anchors[end] - frame.anchors[start]
        stiff = (ISOMETRY_MM / mm_per_unit) / np.maximum(np.sum(chord * chord, axis=1), 1e-300)[:, None]
        system.add([(name, frame.basis(frame.anchors[end]), stiff * chord),
                    (name, -frame.basis(frame.anchors[start]), stiff * chord)], np.zeros(len(chord)))
        normal = frame.normal(pick)
        along_u = np.cross(normal, frame.axes[1])
        along_u /= np.maximum(np.linalg.norm(along_u, axis=1), 1e-300)[:, None]
        for along, weight in ((normal, KEEP_SHORT), (along_u, KEEP_STILL), (np.cross(normal, along_u), KEEP_STILL)):
            # short through the plate, shorter along it: a slide along the plate moves all its edges
            system.add([(name, np.sqrt(weight / len(pick)) * frame.basis(pick), along)], np.zeros(len(pick)))
            for sagitta in frame.sagittas(pick):
                system.add([(name, np.sqrt(LEAST_BENDING / len(pick)) * sagitta, along)], np.zeros(len(pick)))
    solution = system.solve()
    return {name: dataclasses.replace(frames[name], coefficients=solution[name]) for name in column}


def mesh_edges(faces: np.ndarray) -> np.ndarray:
    """(E, 2) the mesh's edges, each once, by their two vertex indices (sorted)."""
    faces = np.asarray(faces, dtype=np.int64)
    return np.unique(np.sort(np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1), axis=0)


def _sample_edges(faces: np.ndarray, most: int) -> tuple[np.ndarray, np.ndarray]:
    """Up to ``most`` of the mesh's edges (their two vertex indices), spread over the mesh."""
    pairs = mesh_edges(faces)
    pick = np.unique(np.linspace(0, len(pairs) - 1, min(len(pairs), most)).astype(int))
    return pairs[pick, 0], pairs[pick, 1]


def bending(before: np.ndarray, after: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(E,) the change of curvature (1 / model unit) across each interior edge of a mesh
    moved from ``before`` to ``after`` (M, 3), ``faces`` (F, 3): the change of the signed
    dihedral angle times the edge's length over its two faces' area (1 / R for a grid
    rolled to radius R across its edges; discrete shells, Grinspun et al. 2003)."""
    faces = np.asarray(faces, dtype=np.int64)
    start, end = faces.ravel(), faces[:, [1, 2, 0]].ravel()
    face_of = np.repeat(np.arange(len(faces)), 3)
    key = np.minimum(start, end) * (int(faces.max()) + 1) + np.maximum(start, end)
    order = np.argsort(key, kind="stable")
    twin = key[order][1:] == key[order][:-1]
    a, b = order[:-1][twin], order[1:][twin]
    if not len(a):
        return np.zeros(0)

    def angles(points):
        corners = points[faces]
        normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        area = 0.5 * np.linalg.norm(normal, axis=1)
        unit = normal / np.maximum(2.0 * area, 1e-300)[:, None]
        na, nb = unit[face_of[a]], unit[face_of[b]]
        edge = points[end[a]] - points[start[a]]
        length = np.linalg.norm(edge, axis=1)
        sine = np.sum(np.cross(na, nb) * edge, axis=1) / np.maximum(length, 1e-300)
        return np.arctan2(sine, np.sum(na * nb, axis=1)), length, area[face_of[a]] + area[face_of[b]]

    angle_before, length, area = angles(np.asarray(before, dtype=np.float64))
    angle_after, _, _ = angles(np.asarray(after, dtype=np.float64))
    return np.abs(angle_after - angle_before) * length / np.maximum(area, 1e-300)


@dataclass(frozen=True)
class PullCheck:
    """What a pull does to its plate: the share of it taken (0: none), its largest move
    (mm), the plate's largest distance from its surface as pulled (mm), the bending stress
    and the stretch it puts in, why a larger share was refused ("" when the whole was
    taken) and the root mean square of its points' distances as pulled."""

    share: float
    largest_pull_mm: float
    distance: float  # model units
    distance_mm: float
    stress_mpa: float
    strain: float
    refused: str = ""
    rms_distance: float = 0.0  # model units


def check_pull(base: np.ndarray, faces: np.ndarray, steps: tuple, distance, tolerance: float, thickness_mm: float,
               material: str, mm_per_unit: float) -> PullCheck:
    """The largest share of the last of ``steps`` (PullFields applied in turn, the others
    whole; PULL_SHARES) that keeps the plate (its mesh ``base`` (M, 3), ``faces`` (F, 3),
    before any step) within ``tolerance`` (model units) of its surface (``distance(points) ->
    (N,)``), moves no point further than PULL_SLIDE of it, bends the plate at most
    PULL_STRESS_SHARE of its steel's yield stress and stretches it at most PULL_STRAIN."""
    sigma_y, _ = yield_stress(material)
    modulus = E_STEEL / (1.0 - NU_STEEL ** 2)
    faces = np.asarray(faces, dtype=np.int64)
    edges = mesh_edges(faces)
    length = np.linalg.norm(base[edges[:, 0]] - base[edges[:, 1]], axis=1)
    keep = length > 0
    edges, length = edges[keep], length[keep]
    why = ""
    for share in (*PULL_SHARES, 0.0):
        moved = apply_steps((*steps[:-1], steps[-1].scaled(share)), base)
        largest = float(np.linalg.norm(moved - base, axis=1).max()) if len(base) else 0.0
        gaps = np.asarray(distance(moved), dtype=np.float64) if len(moved) else np.zeros(1)
        off = float(np.max(gaps))
        kappa = bending(base, moved, faces)
        stress = float(modulus * thickness_mm * (kappa.max() if len(kappa) else 0.0) / mm_per_unit / 2.0)
        strain = float(np.max(np.abs(np.linalg.norm(moved[edges[:, 0]] - moved[edges[:, 1]], axis=1) / length - 1.0)))
        reasons = [text for bad, text in (
            (largest > PULL_SLIDE * tolerance, f"moves {largest * mm_per_unit:.2f} mm, over {PULL_SLIDE:g} tolerances"),
            (off > tolerance, f"leaves the plate {off * mm_per_unit:.2f} mm off the hull"),
            (stress > PULL_STRESS_SHARE * sigma_y,
             f"bends it to {stress:.0f} MPa, over {PULL_STRESS_SHARE:g} of the yield stress {sigma_y:.0f} MPa"),
            (strain > PULL_STRAIN, f"stretches it by {strain:.2g}, over {PULL_STRAIN:g}")) if bad]
        if not reasons or share == 0.0:
            return PullCheck(share, largest * mm_per_unit, off, off * mm_per_unit, stress, strain, why,
                             float(np.sqrt(np.mean(gaps ** 2))))
        if not why:
            why = "the whole pull " + ", ".join(reasons)
    raise AssertionError("unreachable: a zero share always passes")


def apply_steps(steps: tuple, points: np.ndarray) -> np.ndarray:
    """Points (N, 3) moved by each PullField of ``steps`` in turn."""
    points = np.asarray(points, dtype=np.float64)
    for step in steps:
        points = step.apply(points)
    return points


def pulled(result, steps: tuple, check: PullCheck):
    """A copy of a flat or strip plate's result (the input is not changed) pulled by
    ``steps`` (PullFields in turn): its fit-up edges pulled and its ``hull_fit`` that of the
    plate as pulled; its 3D geometry pulled once its owed shop data are done (at once when it
    owes none)."""
    from .fitup import kept_edges

    transform = functools.partial(apply_steps, steps)
    out = copy.copy(result)
    out.figures = dict(result.figures)
    out.figures["fitup_edges"] = moved_edges(kept_edges(result), transform)
    before = dict(result.figures.get("hull_fit") or {})
    out.figures["hull_fit"] = dict(before, max_distance=check.distance, rms_distance=check.rms_distance, passed=True,
                                   measured_on="the pulled plate's points, their distance from the hull",
                                   before_pull_max_distance=before.get("max_distance"),
                                   before_pull_rms_distance=before.get("rms_distance"))
    if "plate_class" in out.figures:
        out.figures["plate_class"] = dict(out.figures["plate_class"],
                                          max_deviation=out.figures["hull_fit"]["max_distance"])
    out.figures["erection_pull"] = {"rule": RULE, "rounds": len(steps), "last_share": check.share,
                                    "largest_pull_mm": check.largest_pull_mm, "distance_mm": check.distance_mm,
                                    "bending_stress_mpa": check.stress_mpa, "stretch": check.strain,
                                    "refused_more_because": check.refused or None, "placed": False}
    place_when_done(out, result, transform, "erection_pull")
    return out


def pull_stepping(records: dict, pairs: list, mm_per_unit: float, thickness_mm: float,
                  measures: EdgeMeasures | None = None) -> tuple[dict, dict, dict]:
    """({plate: its result pulled}, {plate: its pull's figures}, {plate: why it was not
    pulled}) for the flat and strip plates of the ``pairs`` that step by more than their
    limit, their pulls chosen together (:func:`solve_pulls`) and each checked
    (:func:`check_pull`), PULL_ROUNDS rounds measured again after each. ``records``: {name:
    (PlateEdges, part)} as the pairs were measured; ``measures``: the fit-up's edges measured
    before (:class:`.fitup.EdgeMeasures`)."""
    from .fitup import kept_edges, shared_edges

    records = dict(records)
    steps: dict = {}  # plate -> the PullFields taken, in turn
    results, refused, base = {}, {}, {}
    for _ in range(PULL_ROUNDS):
        stepping = [q for q in pairs if q.step_max > q.limit
                    and all(records[n][0].klass in PULLABLE for n in (q.a, q.b))]
        names = sorted({n for q in stepping for n in (q.a, q.b)})
        around = {n for q in pairs if q.a in names or q.b in names for n in (q.a, q.b)
                  if records[n][0].klass in PULLABLE}
        frames = {}
        for name in sorted(around):
            if name not in base:
                base[name] = delivered_mesh(records[name][1].hull.result)
            if base[name] is not None:
                frames[name] = plate_frame(apply_steps(steps.get(name, ()), base[name][0]), base[name][1])
        names = [n for n in names if n in frames]
        if not names:
            break
        pulls = solve_pulls(frames, names, records, [q for q in pairs if q.a in frames or q.b in frames],
                            mm_per_unit, {n: base[n][1] for n in frames})
        changed = set()
        for name in names:
            part = records[name][1]
            steel = getattr(part, "steel", None)
            trial = (*steps.get(name, ()), pulls[name])
            check = check_pull(base[name][0], base[name][1], trial, hull_distance(part.hull),
                               part.hull.fit_tolerance, float(getattr(steel, "thickness", None) or thickness_mm),
                               str(getattr(steel, "material", "") or ""), mm_per_unit)
            if check.share == 0.0:
                if name not in steps:
                    refused[name] = check.refused
                continue
            refused.pop(name, None)
            steps[name] = (*trial[:-1], trial[-1].scaled(check.share))
            results[name] = pulled(part.hull.result, steps[name], check)
            records[name] = (kept_edges(results[name]), part)
            changed.add(name)
        if not changed:
            break
        pairs, _ = shared_edges(records, mm_per_unit, thickness_mm, measures)
    return results, {name: {k: v for k, v in r.figures["erection_pull"].items() if k not in ("rule", "placed")}
                     for name, r in results.items()}, refused


def delivered_mesh(result) -> tuple[np.ndarray, np.ndarray] | None:
    """The plate's mesh (vertices (M, 3), faces (F, 3)) where it lies now: a flat plate's
    region on its plane (its OBJ is the region on the hull), a strip moved by the joint
    programme whose geometry waits for its shop data moved here as it will be."""
    mesh = getattr(result, "mesh", None)
    if mesh is None or len(mesh[1]) == 0:
        return None
    vertices = np.asarray(mesh[0], dtype=np.float64)
    klass = result.figures.get("plate_class") or {}
    if klass.get("class") == "flat":  # the cut plate is planar: its mesh is the region, on the plane
        from .fitup import _on_plane

        vertices = _on_plane(vertices, klass)
    move = pending_transform(result)
    return (vertices if move is None else move(vertices)), np.asarray(mesh[1], dtype=np.int64)
