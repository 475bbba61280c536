"""The plane that keeps a plate's edges nearest its points, among the planes within a
tolerance of all of them.

A flat plate is cut planar and fits the hull when some plane lies within the fit tolerance of
its region. Which one is free; the minimax plane (:mod:`.minimax`) halves the region's slab,
so a plate that bulges by 2 s has its edges up to s off the hull, and two such neighbours can
step by 2 s at their shared edge. Among the planes within the tolerance of every point, the
one whose largest distance from the *edge* points is least keeps the edges on the hull where
the region allows: a plate that bulges between plane edges (a dome over a planar rim) gets
the rim's plane when the bulge is within the tolerance, and the plane moved toward the bulge
by just what the tolerance demands when it is not.

Method: in the frame of a trial normal, the planes z = a x + b y + h are a linear programme
in (a, b, h, t): minimise t subject to |z_i - a x_i - b y_i - h| <= t on the edge points and
<= tolerance on every point (HiGHS, ``scipy.optimize.linprog``). A vertical distance is never
less than the perpendicular one, so the plane found is within the tolerance of every point
in truth; the frame is turned to the normal found and the programme solved again until the
edge distance stands still (plate-like sets: two or three rounds). The perpendicular
distances are then measured exactly.

Units: those of the points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .minimax import _frame
from .patchflat import PlaneFit, fit_plane

ROUNDS = 6


@dataclass(frozen=True)
class EdgePlaneFit(PlaneFit):
    """A plane within the tolerance of every point: ``centroid`` (3,) a point of it, ``axes``
    (2, 3), ``normal`` (3,), ``distances`` (N,) signed perpendicular distances of all points;
    ``edge_max_distance`` the largest distance of the edge points."""

    edge_max_distance: float = 0.0


def edge_held_plane(points: np.ndarray, edge: np.ndarray, tolerance: float,
                    start: PlaneFit | None = None) -> EdgePlaneFit | None:
    """The plane within ``tolerance`` of every point (N, 3) whose largest distance from the
    points flagged by ``edge`` (N,) bool is least; None when no plane found lies within the
    tolerance of every point. ``start``: a plane to begin from (the minimax plane when the
    caller has it; else the least-squares plane)."""
    points = np.asarray(points, dtype=np.float64)
    edge = np.asarray(edge, dtype=bool)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 3:
        raise ValueError(f"points must be (N >= 3, 3), got shape {points.shape}")
    if edge.shape != (len(points),) or not edge.any():
        raise ValueError(f"edge must flag some of the {len(points)} points, got shape {edge.shape}")
    if not tolerance > 0:
        raise ValueError(f"tolerance must be > 0, got {tolerance!r}")
    start = fit_plane(points) if start is None else start
    centre = np.asarray(start.centroid, dtype=np.float64)
    rel = points - centre
    frame = np.vstack([start.axes, start.normal])
    best = None
    for _ in range(ROUNDS):
        local = rel @ frame.T
        solved = _edge_lp(local, edge, tolerance)
        if solved is None:
            break
        a, b, h = solved
        normal = frame[2] - a * frame[0] - b * frame[1]
        norm = float(np.linalg.norm(normal))
        point = centre + h * frame[2]
        distances = (points - point) @ (normal / norm)
        fit = EdgePlaneFit(point, _frame(normal / norm, frame[:2])[:2], normal / norm, distances,
                           edge_max_distance=float(np.abs(distances[edge]).max()))
        if best is not None and fit.edge_max_distance >= best.edge_max_distance * (1.0 - 1e-9):
            break
        best = fit
        frame = _frame(normal / norm, frame[:2])
    if best is None or best.max_distance > tolerance * (1.0 + 1e-9):
        return None
    return best


def _edge_lp(local: np.ndarray, edge: np.ndarray, tolerance: float):
    """(a, b, h) of the plane z = a x + b y + h in the local frame (points (N, 3)) that
    minimises the largest vertical distance of the edge points with every point within
    ``tolerance`` vertically; None when the programme has no solution."""
    from scipy.optimize import linprog

    L = max(float(np.abs(local[:, :2]).max()), 1e-300)
    Z = max(float(np.abs(local[:, 2]).max()), tolerance)
    x, y, w = local[:, 0] / L, local[:, 1] / L, local[:, 2] / Z
    tol = tolerance / Z
    n, m = len(w), int(edge.sum())
    xe, ye, we = x[edge], y[edge], w[edge]
    # variables (a, b, h, t): +-(w - a x - b y - h) <= t on edges, <= tol everywhere
    A = np.vstack([np.column_stack([-xe, -ye, -np.ones(m), -np.ones(m)]),
                   np.column_stack([xe, ye, np.ones(m), -np.ones(m)]),
                   np.column_stack([-x, -y, -np.ones(n), np.zeros(n)]),
                   np.column_stack([x, y, np.ones(n), np.zeros(n)])])
    rhs = np.concatenate([-we, we, tol - w, tol + w])
    res = linprog(np.array([0.0, 0.0, 0.0, 1.0]), A_ub=A, b_ub=rhs,
                  bounds=[(None, None)] * 3 + [(0, None)], method="highs")
    if res.status != 0:
        return None
    a, b, h, _ = res.x
    return a * Z / L, b * Z / L, h * Z
