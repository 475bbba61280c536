"""solve(c, d): every branch of the developability equation, judged, and the best strip."""

from __future__ import annotations

import numpy as np

from .equation import (COPLANAR, PARALLEL_PLANES, classify_pair, developability_field,
                       normalized_residual)
from .errors import InvalidInputError
from .judge import (UnitMap, choose_path, coverage, curvature_mismatches, knot_crossings,
                    make_branch, make_turning_point, split_pieces)
from .nurbs import NurbsCurve
from .solution import Finding, Path, Piece, SolutionSet
from .tolerances import DEFAULT_TOLERANCES, Tolerances
from .tracer import END_UNRESOLVED, trace_zero_set


def check_pair(c: NurbsCurve, d: NurbsCurve, tol: Tolerances) -> None:
    """Reject a pair that cannot bound a part: the same curve twice (either direction)."""
    for name, curve in (("c", c), ("d", d)):
        if not isinstance(curve, NurbsCurve):
            raise InvalidInputError(f"{name} must be a NurbsCurve, got {type(curve).__name__}")
    samples = np.linspace(0.0, 1.0, 257)
    pc = c(c.parameter_at_length(samples * c.length))
    pd = d(d.parameter_at_length(samples * d.length))
    size = max(float(np.ptp(np.vstack([pc, pd]), axis=0).max()), 1e-300)
    for other in (pd, pd[::-1]):
        gap = float(np.linalg.norm(pc - other, axis=1).max())
        if gap <= tol.coincidence * size:
            raise InvalidInputError(
                f"curves {c.name} and {d.name} coincide (largest distance {gap:.3g} for a part "
                f"of size {size:.3g}): they bound no surface")


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


def solve(c: NurbsCurve, d: NurbsCurve, tolerances: Tolerances = DEFAULT_TOLERANCES) -> SolutionSet:
    """Find and judge every branch of f(t, T) = det[C, C', D, D'] = 0.

    Parameters
    ----------
    c, d : boundary curves (t on c's knot domain, T on d's)
    tolerances : thresholds (see :class:`Tolerances`)

    Returns
    -------
    SolutionSet
        Truthy when an acceptable path exists. Always carries the branches, their
        acceptable and regression pieces, turning points, Theorem 2 mismatches,
        knot crossings and findings.

    Raises
    ------
    InvalidInputError
        For a pair that bounds nothing (coincident curves).
    """
    tol = tolerances
    check_pair(c, d, tol)
    kind, plane = classify_pair(c, d, tol.planarity)
    if kind == COPLANAR:
        return flat_plate_solution(c, d, plane["normal"])
    field = developability_field(c, d, kind, plane)
    if field.identically_zero:
        return flat_plate_solution(c, d, np.zeros(3))
    unit = UnitMap(field)
    traces, seeds, visited = trace_zero_set(field, tol)
    findings: list[Finding] = []
    if kind == PARALLEL_PLANES:
        findings.append(Finding(
            "PARALLEL_PLANES", f"polynomial curves on parallel planes {plane['height']:.6g} apart: "
            f"f reduces to h (x'Y' - y'X'), degree {field.degree_in_T} in T",
            {"height": plane["height"], "normal": np.asarray(plane["normal"]).tolist()}))
    if not visited.all():
        missed = seeds.points[~visited]
        findings.append(Finding("UNTRACED_SEEDS", f"{len(missed)} grid roots lie on no traced branch",
                                {"points": unit.to_params(missed).tolist()}))
    for trace in traces:
        if END_UNRESOLVED in trace.ends:
            findings.append(Finding("BRANCH_UNRESOLVED", "a branch could not be followed to its end",
                                    {"end": unit.to_params(trace.points[-1]).tolist()}))

    polished = [trace.points if len(trace.points) < 2 else unit.polish(trace.points) for trace in traces]
    traces = [type(tr)(p, tr.closed, tr.ends) for tr, p in zip(traces, polished)]
    branches = tuple(make_branch(k, unit.to_params(tr.points), tr, tr.points)
                     for k, tr in enumerate(traces))
    # judge both orientations of d against c; keep the one with the better strip
    raw_pieces, raw_turning = split_pieces(unit, traces, tol.junction)
    piece_points = [unit.to_params(unit.polish(x)) for x, _, _ in raw_pieces]
    best = None
    for column, orientation in ((0, 1), (1, -1)):
        pieces = tuple(Piece(k, n, points, acc[column])
                       for k, ((_, acc, n), points) in enumerate(zip(raw_pieces, piece_points)))
        path = choose_path(c, d, list(pieces), tol.junction, tol.min_piece_coverage, orientation)
        score = -1.0 if path is None else path.coverage.c_fraction + path.coverage.d_fraction
        if best is None or score > best[0] + 1e-12:
            best = (score, pieces, orientation, path)
    _, pieces, orientation, path = best
    turning = tuple(make_turning_point(c, d, unit.to_params(unit.polish(x[None])[0]), kind_, n)
                    for x, kind_, n, o in raw_turning if o == orientation)
    mismatches = []
    crossings = []
    for branch in branches:
        mismatches += curvature_mismatches(c, d, branch.index, branch.points)
        crossings += knot_crossings(field, branch.index, branch.points)

    all_points = np.vstack([b.points for b in branches]) if branches else np.zeros((0, 2))
    residual = float(normalized_residual(c, d, all_points[:, 0], all_points[:, 1]).max(initial=0.0))

    if not branches:
        f_values = field(*np.meshgrid(np.linspace(*c.domain, 33), np.linspace(*d.domain, 33)))
        message = ("no developable strip: f(t, T) has no zero in the parameter rectangle "
                   f"(it keeps one sign, |f| >= {np.abs(f_values).min():.3g}); only fans "
                   "(cones with the apex on one curve, meeting at a crease) join these curves")
        findings.append(Finding("NO_SOLUTION_CURVE", message,
                                {"f_min": float(f_values.min()), "f_max": float(f_values.max())}))
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
    return SolutionSet(success, message, kind, field.degree_in_T, branches, pieces, turning,
                       tuple(mismatches), tuple(crossings), path, tuple(findings), residual, field)


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
