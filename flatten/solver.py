"""solve(c, d): every branch of the developability equation, judged, and the best strip."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree

from .equation import (COPLANAR, GENERAL, PARALLEL_PLANES, classify_pair, corner_knots, developability_field,
                       normalized_residual, pair_plane)
from .errors import InvalidInputError
from .certify import critical_points, enclose, near_gap
from .judge import (UnitMap, choose_path, coverage, curvature_mismatches, knot_crossings,
                    make_branch, make_turning_point, path_rank, split_pieces)
from .nurbs import NurbsCurve
from .pair import check_pair
from .solution import Branch, Finding, Path, Piece, SolutionSet
from .tolerances import DEFAULT_TOLERANCES, Tolerances
from .tracer import END_STEP_LIMIT, END_UNRESOLVED, SIDE_NAMES, StepCaps, _distance_to_polyline, trace_zero_set


class LocalFrame:
    """A similarity x -> (x - centre) / size putting both curves near the origin at unit size.

    The solution (t, T) does not change under it (f scales by size^-3 for polynomial
    and rational curves alike), but round-off does: a plate 1e8 mm from the origin solves
    like one at the origin. 3D outputs are mapped back with :meth:`to_model`.
    """

    def __init__(self, c: NurbsCurve, d: NurbsCurve):
        points = np.vstack([c.control_points, d.control_points])
        lo, hi = points.min(axis=0), points.max(axis=0)
        self.centre = 0.5 * (lo + hi)
        size = float(np.max(hi - lo))
        self.size = size if np.isfinite(size) and size > 0 else 1.0

    def curve(self, curve: NurbsCurve) -> NurbsCurve:
        local = (curve.control_points - self.centre) / self.size
        local.setflags(write=False)
        return NurbsCurve(curve.degree, local, curve.weights, curve.knots, curve.name)

    def to_model(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points) * self.size + self.centre


def flat_plate_solution(c: NurbsCurve, d: NurbsCurve, normal: np.ndarray, n_rulings: int = 65) -> SolutionSet:
    """Coplanar curves: f vanishes identically; rulings by arc-length correspondence."""
    s = np.linspace(0.0, 1.0, n_rulings)
    points = np.column_stack([c.parameter_at_length(s * c.length), d.parameter_at_length(s * d.length)])
    cov = coverage(c, d, c.domain, d.domain)
    path = Path(points, (), cov, ())
    finding = Finding("FLAT_PLATE", "c and d are coplanar: f(t, T) vanishes identically; the part is "
                      "the planar region between them, rulings by arc-length correspondence",
                      {"normal": np.asarray(normal).tolist()})
    return SolutionSet(True, finding.message, COPLANAR, 0, (), (), (), (), (), path, (finding,), 0.0)


def _intervals(curve: NurbsCurve) -> list[tuple[float, float]]:
    """The domain cut at the curve's corners (the solution jumps there)."""
    ends = [curve.domain[0], *corner_knots(curve).tolist(), curve.domain[1]]
    return list(zip(ends[:-1], ends[1:]))


def _piece_of(curve: NurbsCurve, a: float, b: float) -> NurbsCurve:
    return curve if (a, b) == curve.domain else curve.segment(a, b)


class _Block:
    """The zero set on one block of the rectangle between corner lines, certified.

    The block's field is built on the exact pieces of c and d, so that a corner line is
    a side of the block and f is evaluated from the block's side of it.
    """

    def __init__(self, c: NurbsCurve, d: NurbsCurve, kind: str, plane: dict | None, tol: Tolerances,
                 field=None):
        self.field = developability_field(c, d, kind, plane) if field is None else field
        self.unit = UnitMap(self.field)
        self.tol = tol
        start = time.perf_counter()
        self.enclosure = enclose(self.field, target=2.0 * tol.trace_step)
        self.critical = critical_points(self.field)
        crit = self.critical
        self.certify_time = time.perf_counter() - start
        unit_crit = self.unit.to_unit(crit.points) if len(crit.points) else np.zeros((0, 2))
        gap = near_gap(crit.value, crit.hessian) if len(crit.points) else np.zeros(0)
        residual = (normalized_residual(c, d, crit.points[:, 0], crit.points[:, 1])
                    if len(crit.points) else np.zeros(0))
        extremum = np.isin(crit.kind, ("min", "max"))
        # f = 0 at an extremum: a point of Z (or a loop too small to trace: 1e-5 of the
        # rectangle): a ruling that exists at one t only
        self.isolated = extremum & ((residual <= tol.residual) | (gap <= 10.0 * tol.junction))
        loops = extremum & np.isfinite(gap) & ~self.isolated
        # a saddle whose f vanishes is a crossing, passed straight through
        saddles = (crit.kind == "saddle") & (residual > tol.residual) & (gap < 0.5)
        capped = loops | saddles
        lam = np.abs(np.linalg.eigvalsh(crit.hessian)) if len(crit.points) else np.zeros((0, 2))
        slope = np.clip(np.sqrt(lam.min(axis=1) / np.maximum(lam.max(axis=1), 1e-300)), 0.05, 1.0) if len(lam) else lam
        self.caps = StepCaps(unit_crit[capped], gap[capped], slope[capped] if len(lam) else np.zeros(0))
        self.extra_u = unit_crit[loops, 0]
        self.extra_U = unit_crit[loops, 1]
        self.iso_unit = unit_crit[self.isolated]
        self.traces, self.seeds, self.visited = trace_zero_set(
            self.field, tol, self.extra_u, self.extra_U, self.caps, self.iso_unit)
        # every box where f provably changes sign must be met by a traced branch; a box
        # no branch meets holds a component the seeds missed: seed lines through it
        start = time.perf_counter()
        self.unmet = self._unmet_boxes()
        self.certify_time += time.perf_counter() - start
        if len(self.unmet):
            extra = self.unit.to_unit(np.column_stack([self.unmet[:, :2].mean(axis=1), self.unmet[:, 2:].mean(axis=1)]))
            self.traces, self.seeds, self.visited = trace_zero_set(
                self.field, tol, np.concatenate([self.extra_u, extra[:, 0]]),
                np.concatenate([self.extra_U, extra[:, 1]]), self.caps, self.iso_unit)
            self.unmet = self._unmet_boxes()
        # a trace that is one point on a side: Z only touches the block there (it belongs
        # to a neighbouring block's branch, or touches the rectangle from outside)
        single = [len(tr.points) < 2 or np.ptp(tr.points, axis=0).max() <= 1e-12 for tr in self.traces]
        self.touches = self.unit.to_params(np.array([tr.points[0] for tr, one in zip(self.traces, single) if one]
                                                    ).reshape(-1, 2))
        self.traces = [tr for tr, one in zip(self.traces, single) if not one]

    def _unmet_boxes(self) -> np.ndarray:
        """Boxes (K, 4) [t0, t1, T0, T1] with a proven zero that no traced branch meets."""
        enc = self.enclosure
        boxes = enc.boxes[enc.sign_change]
        if len(boxes) == 0:
            return boxes
        lo = self.unit.to_unit(boxes[:, [0, 2]])
        hi = self.unit.to_unit(boxes[:, [1, 3]])
        half = 0.5 * (hi - lo)
        step = float(np.clip(half.min(), 1e-6, 1e-3))
        centre = 0.5 * (lo + hi)
        met = np.zeros(len(boxes), dtype=bool)
        for p in self.iso_unit:  # an isolated point (or a loop too small to trace) explains its box
            met |= np.all(np.abs(centre - p) <= half + step, axis=1)
        if not self.traces:
            return boxes[~met]
        # a box is met by a polyline segment that crosses it grown by ``step`` (slab test);
        # segments longer than the largest box are cut, so that candidate pairs (from the
        # segments' and boxes' centres) stay within a fixed reach
        reach = float(half.max()) + step
        pieces = [_densify(tr.points, 2.0 * reach) for tr in self.traces]
        # (a trace of one point, Z touching a side, is a segment of length 0)
        start = np.vstack([x[:-1] if len(x) > 1 else x for x in pieces])
        seg = np.vstack([np.diff(x, axis=0) if len(x) > 1 else np.zeros_like(x) for x in pieces])
        if len(seg) == 0:
            return boxes[~met]
        pairs = cKDTree(centre).sparse_distance_matrix(
            cKDTree(start + 0.5 * seg), reach + 0.5 * float(np.abs(seg).max()) + 1e-12, p=np.inf,
            output_type="ndarray")
        box, idx = pairs["i"].astype(np.intp), pairs["j"].astype(np.intp)
        p0, d = start[idx], seg[idx]
        lo_g, hi_g = lo[box] - step, hi[box] + step
        with np.errstate(divide="ignore", invalid="ignore"):
            t1, t2 = (lo_g - p0) / d, (hi_g - p0) / d
        flat = d == 0.0  # parallel to an axis: inside that slab or not at all
        inside_slab = (p0 >= lo_g) & (p0 <= hi_g)
        enter = np.where(flat, np.where(inside_slab, -np.inf, np.inf), np.minimum(t1, t2))
        leave = np.where(flat, np.where(inside_slab, np.inf, -np.inf), np.maximum(t1, t2))
        hit = np.maximum(enter.max(axis=1), 0.0) <= np.minimum(leave.min(axis=1), 1.0)
        met[box[hit]] = True
        return boxes[~met]


def _densify(points: np.ndarray, step: float) -> np.ndarray:
    """Points along a polyline (N, 2) at most ``step`` apart."""
    if len(points) < 2:
        return points
    seg = np.diff(points, axis=0)
    n = np.maximum(np.ceil(np.hypot(*seg.T) / step).astype(int), 1)
    base = np.repeat(np.arange(len(seg)), n)
    frac = (np.arange(len(base)) - np.repeat(np.cumsum(n) - n, n)) / n[base]  # k / n_i, k < n_i
    return np.vstack([points[base] + frac[:, None] * seg[base], points[-1:]])


def _end_names(ends: tuple[str, str], t_walls: tuple[bool, bool], T_walls: tuple[bool, bool]) -> tuple[str, str]:
    """Rename the ends of a block's branch that lie on a corner line (not a side)."""
    rename = {"t_start": "c_corner" if t_walls[0] else "t_start", "t_end": "c_corner" if t_walls[1] else "t_end",
              "T_start": "d_corner" if T_walls[0] else "T_start", "T_end": "d_corner" if T_walls[1] else "T_end"}
    return tuple(rename.get(e, e) for e in ends)


def _side_ends(ends: tuple[str, str], points: np.ndarray) -> tuple[str, str]:
    """A trace's end kinds after its ends were located on the sides (unit points (N, 2)):
    an end the tracer put at a corner of the square that the polish moved along one side
    (a branch passing the corner within round-off of the trace) is named by that side."""
    out = list(ends)
    for k, (name, point) in enumerate(zip(ends, points[[0, -1]])):
        if name in SIDE_NAMES:
            axis, value = (0 if name.startswith("t_") else 1), (0.0 if name.endswith("start") else 1.0)
            if point[axis] != value:
                on = [SIDE_NAMES[2 * a + int(point[a] == 1.0)] for a in (0, 1) if point[a] in (0.0, 1.0)]
                out[k] = on[0] if on else name
    return tuple(out)


def _corner_fans(branches: list[Branch], c: NurbsCurve, d: NurbsCurve, first_index: int):
    """Corner fan pieces: on each corner line, join consecutive branch points lying on it.

    At a C0 knot t = k of c every ruling from the corner c(k) lies on the cone with apex
    c(k), so the one-sided roots T- and T+ there are joined by that fan (the solution
    of a C^0 curve jumps: seed, C^k -> C^(k-1)).
    """
    out = []
    for axis, curve in ((0, c), (1, d)):
        for knot in corner_knots(curve):
            on = [b.points[[0, -1]][b.points[[0, -1], axis] == knot] for b in branches if not b.closed]
            on = np.vstack(on) if on else np.zeros((0, 2))
            other = np.unique(on[:, 1 - axis])
            for a, b in zip(other[:-1], other[1:]):
                along = np.linspace(a, b, 17)
                pts = np.column_stack([np.full_like(along, knot), along] if axis == 0 else [along, np.full_like(along, knot)])
                out.append(Piece(first_index + len(out), -1, pts, True, corner=True))
    return out


def solve(c: NurbsCurve, d: NurbsCurve, tolerances: Tolerances = DEFAULT_TOLERANCES) -> SolutionSet:
    """Find, certify and judge every branch of f(t, T) = det[C, C', D, D'] = 0.

    Parameters
    ----------
    c, d : boundary curves (t on c's knot domain, T on d's)
    tolerances : thresholds (see :class:`Tolerances`)

    Returns
    -------
    SolutionSet
        Truthy when an acceptable path exists. Always carries the branches, their
        acceptable and regression pieces (corner fans included), turning points,
        Theorem 2 mismatches, knot crossings and findings (isolated points, proofs,
        residual checks).

    Raises
    ------
    InvalidInputError
        For a pair that bounds nothing (coincident curves).
    """
    check_pair(c, d, tolerances)
    solution = _solve(c, d, tolerances, parallel=True)
    if solution.kind == PARALLEL_PLANES and solution.max_residual > tolerances.residual:
        # planes parallel to the planarity tolerance but not to the residual bound: the
        # reduced equation h (x'Y' - y'X') is not accurate enough, solve the full one
        solution = _solve(c, d, tolerances, parallel=False)
    return _flat_beyond_noise(c, d, solution, tolerances)


def _flat_beyond_noise(c: NurbsCurve, d: NurbsCurve, solution: SolutionSet, tolerances: Tolerances) -> SolutionSet:
    """The flat plate between c and d when they lie within ``near_planarity`` of one plane
    and their general solve finds no path, or one that leaves part of a curve uncovered
    beside pieces whose rulings cross: f is then the curves' departure from the plane, a
    CAD model's round-off, and its zero set says nothing of the part. A pair turned against
    its plane by a smooth angle, however small, has a clean zero set and keeps it (a cubic
    turned 1e-9 rad: one graph branch over 10 % of c)."""
    if solution.kind == COPLANAR:
        return solution
    if solution and not {"PARTIAL_COVERAGE", "REGRESSION"} <= {f.code for f in solution.findings}:
        return solution
    plane, size = pair_plane(c, d, tolerances.near_planarity)
    if plane.max_distance > tolerances.near_planarity * size:
        return solution
    cover = ("found no path" if solution.path is None else
             f"covered {100 * solution.path.coverage.c_fraction:.3g}% of c and "
             f"{100 * solution.path.coverage.d_fraction:.3g}% of d")
    note = Finding("NEARLY_COPLANAR", f"c and d lie within {plane.max_distance:.3g} of one plane "
                   f"({plane.max_distance / size:.2g} of their size): their general solve {cover}, f being that "
                   "departure; solved as the planar region between them",
                   {"max_distance": plane.max_distance, "relative": plane.max_distance / size,
                    "general_kind": solution.kind})
    flat = flat_plate_solution(c, d, plane.normal)
    return replace(flat, findings=flat.findings + (note,))


def _solve(c: NurbsCurve, d: NurbsCurve, tolerances: Tolerances, parallel: bool) -> SolutionSet:
    tol = tolerances
    # solve in a local frame (numerics independent of where the part is); lengths,
    # areas and 3D points are reported in the model's frame
    model_c, model_d = c, d
    frame = LocalFrame(c, d)
    c, d = frame.curve(c), frame.curve(d)
    kind, plane = classify_pair(c, d, tol.planarity)
    if kind == PARALLEL_PLANES and not parallel:
        kind, plane = GENERAL, {}
    if kind == COPLANAR:
        return flat_plate_solution(model_c, model_d, plane["normal"])
    field = developability_field(c, d, kind, plane)
    if field.identically_zero:
        return flat_plate_solution(model_c, model_d, np.zeros(3))
    findings: list[Finding] = []
    if kind == PARALLEL_PLANES:
        height = plane["height"] * frame.size
        findings.append(Finding(
            "PARALLEL_PLANES", f"polynomial curves on parallel planes {height:.6g} apart: "
            f"f reduces to h (x'Y' - y'X'), degree {field.degree_in_T} in T",
            {"height": height, "normal": np.asarray(plane["normal"]).tolist()}))
    start = time.perf_counter()
    blocks = []
    c_parts, d_parts = _intervals(c), _intervals(d)
    for a, b in c_parts:
        for A, B in d_parts:
            whole = (a, b) == c.domain and (A, B) == d.domain  # no corners: the block is the rectangle
            block = _Block(_piece_of(c, a, b), _piece_of(d, A, B), kind, plane, tol, field if whole else None)
            walls = ((a > c.domain[0], b < c.domain[1]), (A > d.domain[0], B < d.domain[1]))
            blocks.append((block, walls))

    branches: list[Branch] = []
    branch_derivs: list = []  # (c, d derivatives to order 2) at each branch's points
    raw_pieces, raw_turning, knot_hits = [], [], []

    def point_evidence(p):  # where a single-point finding is, in parameters and in 3D
        return {"t": float(p[0]), "T": float(p[1]), "point_c": model_c(p[:1])[0].tolist(),
                "point_d": model_d(p[1:])[0].tolist()}

    for block, (t_walls, T_walls) in blocks:
        unit = block.unit
        seeds, visited = block.seeds, block.visited
        if not visited.all():
            missed = seeds.points[~visited]
            findings.append(Finding("UNTRACED_SEEDS", f"{len(missed)} grid roots lie on no traced branch",
                                    {"points": unit.to_params(missed).tolist()}))
        if len(block.unmet):
            findings.append(Finding(
                "UNTRACED_REGION", f"{len(block.unmet)} boxes where f provably changes sign are met by no "
                "traced branch: a component of the solution curve may be missing",
                {"boxes": block.unmet.tolist()}))
        traces = block.traces
        for trace in traces:
            if END_UNRESOLVED in trace.ends or END_STEP_LIMIT in trace.ends:
                why = ("the trace reached its step limit" if END_STEP_LIMIT in trace.ends
                       else "a branch could not be followed to its end")
                findings.append(Finding("BRANCH_UNRESOLVED", why,
                                        {"end": unit.to_params(trace.points[-1]).tolist()}))
        several = [k for k, tr in enumerate(traces) if len(tr.points) >= 2]
        polished = [tr.points for tr in traces]
        for k, points in zip(several, unit.polish_each([traces[k].points for k in several])):
            polished[k] = points
        traces = [type(tr)(p, tr.closed, _side_ends(tr.ends, p)) for tr, p in zip(traces, polished)]
        # the curves' derivatives at the branch points, once: the judge's classes and
        # Theorem 2's curvature signs both need them
        params = [unit.to_params(tr.points) for tr in traces]
        derivs = [(block.field.c.derivatives(p[:, 0], 2), block.field.d.derivatives(p[:, 1], 2)) for p in params]
        offset = len(branches)
        for k, tr in enumerate(traces):
            branch = make_branch(offset + k, params[k], tr, tr.points)
            # (a block between corner lines has its own one-sided derivatives on them;
            # Theorem 2's signs take the whole curves')
            branch_derivs.append(derivs[k] if block.field.c is c and block.field.d is d else None)
            branches.append(Branch(branch.index, branch.points, branch.closed,
                                   _end_names(branch.ends, t_walls, T_walls), branch.kind))
            knot_hits += knot_crossings(block.field, offset + k, branches[-1].points)
        pieces_b, turning_b, unchecked = split_pieces(unit, traces, tol.junction, derivs)
        for i, j, pairs, budget in unchecked:
            # a trace piled up on itself (circling until its step limit): the judge
            # stays within its memory budget and says what it did not check
            which = f"branch {offset + i}" + ("" if i == j else f" and branch {offset + j}")
            findings.append(Finding(
                "CROSSINGS_UNCHECKED", f"crossings of {which} ({len(traces[i].points)}"
                + ("" if i == j else f" and {len(traces[j].points)}") + f" points) were not searched: "
                f"{pairs} candidate segment pairs exceed the judge's budget of {budget} (the trace piles up "
                "on itself); junctions there are missing and its pieces are unverified",
                {"branches": sorted({offset + i, offset + j}), "candidate_pairs": int(pairs), "budget": int(budget)}))
        # a piece is a run of polished trace points between two cut points (turning
        # points, junctions, class boundaries): only the ends are new, and are polished
        # here with the turning points, in one batch
        ends = [x[[0, -1]] for x, _, _ in pieces_b] + [x[None] for x, _, _, _ in turning_b]
        polished_ends = unit.polish_each(ends) if ends else []
        for (x, acc, n), e in zip(pieces_b, polished_ends):
            x = x.copy()
            x[[0, -1]] = e
            raw_pieces.append((unit.to_params(x), acc, offset + n))
        for (_, kind_, n, o), e in zip(turning_b, polished_ends[len(pieces_b):]):
            raw_turning.append((unit.to_params(e[0]), kind_, offset + n, o))
        for p in block.critical.points[block.isolated]:
            # a degenerate critical point on a traced branch (e.g. the apex of a pointed
            # plate, where c and d meet) is a singular point of that branch, not isolated
            if any(len(b.points) > 1 and _distance_to_polyline(((p - unit.lo) / unit.width)[None],
                                                               unit.to_unit(b.points))[0] <= 1e-6
                   for b in branches[offset:]):
                continue
            findings.append(Finding(
                "ISOLATED_POINT", f"f vanishes at an isolated point (t, T) = ({p[0]:.9g}, {p[1]:.9g}) (an "
                "extremum of f with f = 0): a developable ruling that exists for this t only",
                point_evidence(p)))
    scale = np.array([np.ptp(c.domain), np.ptp(d.domain)])
    for block, _ in blocks:
        for p in block.touches:
            if any(np.min(np.hypot(*((b.points - p) / scale).T)) <= tol.junction for b in branches):
                continue
            findings.append(Finding(
                "ISOLATED_POINT", f"f vanishes at a single point (t, T) = ({p[0]:.9g}, {p[1]:.9g}) on a side of "
                "the rectangle (the solution curve touches it from outside): a ruling for this t only",
                point_evidence(p)))
    fans = _corner_fans(branches, c, d, len(raw_pieces))
    for fan in fans:
        apex = model_c(fan.points[:1, 0])[0] if np.ptp(fan.points[:, 0]) == 0 else model_d(fan.points[:1, 1])[0]
        findings.append(Finding(
            "CORNER_FAN", f"a corner fan with its apex at {np.round(apex, 6).tolist()} joins the one-sided "
            f"roots at a C0 knot: t in [{fan.points[0, 0]:.9g}, {fan.points[-1, 0]:.9g}], "
            f"T in [{fan.points[0, 1]:.9g}, {fan.points[-1, 1]:.9g}]",
            {"points": fan.points[[0, -1]].tolist(), "apex": apex.tolist()}))
    certify_time = sum(block.certify_time for block, _ in blocks)
    # judge both orientations of d against c; keep the one with the better strip
    best = None
    for column, orientation in ((0, 1), (1, -1)):
        pieces = tuple(Piece(k, n, points, acc[column])
                       for k, (points, acc, n) in enumerate(raw_pieces)) + tuple(fans)
        path = choose_path(model_c, model_d, list(pieces), tol.junction, tol.min_piece_coverage, orientation)
        score = (-1, -1.0) if path is None else path_rank(path.coverage)
        if best is None or score > best[0]:
            best = (score, pieces, orientation, path)
    _, pieces, orientation, path = best
    turning = tuple(make_turning_point(model_c, model_d, x, kind_, n) for x, kind_, n, o in raw_turning
                    if o == orientation)
    mismatches = []
    for branch, derivs in zip(branches, branch_derivs):
        mismatches += [replace(m, points_c=frame.to_model(m.points_c), points_d=frame.to_model(m.points_d))
                       for m in curvature_mismatches(c, d, branch.index, branch.points, derivs=derivs)]

    # every reported point is checked against the residual bound after tracing
    checked = [b.points for b in branches] + [p.points for p in pieces]
    checked += [np.array([[tp.t, tp.T]]) for tp in turning]
    if path is not None:
        checked.append(path.points)
    all_points = np.vstack(checked) if checked else np.zeros((0, 2))
    # branch, piece and path points are mostly the same points: each is checked once
    # (by a lexsort of the two columns: np.unique along an axis sorts a structured view,
    # several times slower)
    order = np.lexsort((all_points[:, 1], all_points[:, 0]))
    ordered = all_points[order]
    first = np.ones(len(ordered), dtype=bool)
    first[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    inverse = np.empty(len(ordered), dtype=np.intp)
    inverse[order] = np.cumsum(first) - 1
    unique = ordered[first]
    point_residual = normalized_residual(c, d, unique[:, 0], unique[:, 1])[inverse]
    residual = float(point_residual.max(initial=0.0))
    if residual > tol.residual:
        bad = all_points[point_residual > tol.residual]
        on_path = path is not None and bool(np.any(normalized_residual(c, d, *path.points.T) > tol.residual))
        findings.append(Finding(
            "RESIDUAL_EXCEEDED", f"{len(bad)} reported point(s) miss the residual bound {tol.residual:.0e} "
            f"(worst {residual:.3g})" + (", some on the chosen path" if on_path else ""),
            {"points": bad[:50].tolist(), "worst": residual, "on_path": on_path}))

    proved = all(block.enclosure.proved_empty for block, _ in blocks)
    if not branches:
        f_values = field(*np.meshgrid(np.linspace(*c.domain, 33), np.linspace(*d.domain, 33)))
        bounds = [min(b.enclosure.f_min for b, _ in blocks), max(b.enclosure.f_max for b, _ in blocks)]
        n_boxes = sum(b.enclosure.n_excluded for b, _ in blocks)
        iso = [f for f in findings if f.code == "ISOLATED_POINT"]
        if proved:
            message = ("no developable strip: f(t, T) has no zero in the parameter rectangle, proved (the "
                       f"Bernstein coefficients of f keep one sign on all {n_boxes} boxes); only fans "
                       "(cones with the apex on one curve, meeting at a crease) join these curves")
            code = "NO_SOLUTION_CURVE"
        else:
            left = sum(len(b.enclosure.boxes) for b, _ in blocks)
            message = ("no developable strip: no branch of the solution curve was found, but its absence is "
                       f"not proved: {left} boxes of the rectangle where f may vanish remain after subdivision"
                       + (f"; f vanishes at {len(iso)} isolated point(s) (a ruling at one t only)" if iso else "")
                       + "; only fans (cones with the apex on one curve) join these curves elsewhere")
            code = "NO_BRANCH_FOUND"
        findings.append(Finding(code, message, {"f_min": float(f_values.min()), "f_max": float(f_values.max()),
                                                "bernstein_bounds": bounds, "excluded_boxes": n_boxes,
                                                "proved": proved}))
        success = False
    elif path is None:
        worst = [m.worst for m in mismatches]
        message = (f"no acceptable strip: all {len(branches)} branch(es) of the solution curve have "
                   "neighbouring rulings crossing inside the strip (regression); the normal "
                   "curvatures of c and d have opposite signs"
                   + (f", e.g. at (t, T) = ({worst[0][0]:.6g}, {worst[0][1]:.6g})" if worst else ""))
        findings.append(Finding("NO_ACCEPTABLE_BRANCH", message,
                                {"mismatches": [{"t_range": list(m.t_range), "T_range": list(m.T_range),
                                                 "worst": list(m.worst)} for m in mismatches]}))
        success = False
    else:
        cov = path.coverage
        success = True
        message = (f"acceptable strip found: covers {100 * cov.c_fraction:.4g}% of c and "
                   f"{100 * cov.d_fraction:.4g}% of d"
                   + ("" if path.orientation > 0 else " (d runs against c: T decreases)"))
        if min(cov.c_fraction, cov.d_fraction) < 1.0 - 1e-9:
            findings.append(Finding("PARTIAL_COVERAGE", message, cov.as_dict()))
        if any(not p.acceptable for p in pieces):
            findings.append(Finding("REGRESSION", "parts of the solution curve have rulings "
                                    "crossing inside the strip; they are shown, never cut",
                                    {"pieces": [p.index for p in pieces if not p.acceptable]}))
    total = time.perf_counter() - start
    findings.append(Finding("CERTIFICATE", _certificate_message(blocks, branches, proved),
                            {"proved_empty": proved,
                             "complete": all(b.enclosure.complete and b.critical.complete for b, _ in blocks),
                             "critical_points": int(sum(len(b.critical.points) for b, _ in blocks)),
                             "excluded_boxes": int(sum(b.enclosure.n_excluded for b, _ in blocks)),
                             "certify_seconds": certify_time, "solve_seconds": total}))
    return SolutionSet(success, message, kind, field.degree_in_T, tuple(branches), pieces, turning,
                       tuple(mismatches), tuple(knot_hits), path, tuple(findings), residual, field)


def _certificate_message(blocks, branches, proved: bool) -> str:
    n_crit = sum(len(b.critical.points) for b, _ in blocks)
    complete = all(b.enclosure.complete and b.critical.complete for b, _ in blocks)
    unmet = sum(len(b.unmet) for b, _ in blocks)
    if proved:
        return "f has no zero in the rectangle (proved by Bernstein bounds on every box)"
    if complete and unmet == 0:
        return (f"{len(branches)} branch(es); every box where f changes sign is met by a traced branch and a "
                f"seed line passes through each of the {n_crit} critical point(s) that may hold a loop")
    what = []
    if not complete:
        what.append("the subdivision ran out of its box budget (f nearly vanishes on a large set)")
    if unmet:
        what.append(f"{unmet} box(es) with a sign change of f are met by no branch")
    return "completeness not proved: " + "; ".join(what)


def rulings_on_path(solution: SolutionSet, t: np.ndarray, iterations: int = 4) -> np.ndarray:
    """T on the chosen path for a batch of t (graph part of the path), shape (N,).

    Starts from the traced path and runs batched Newton on f(t, ·): one polynomial
    evaluation per iteration for the whole batch.
    """
    path = solution.path
    field = solution.field
    t = np.asarray(t, dtype=np.float64)
    pts = path.points
    T = np.interp(t, pts[:, 0], pts[:, 1])  # t is non-decreasing along every path
    if field is None:  # flat plate: arc-length correspondence
        return T
    return field.refine_T(t, T, iterations)
