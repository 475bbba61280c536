"""Frozen result types of the developability solver."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Finding:
    """A coded observation: ``code`` is stable (for reports), ``message`` is for people."""

    code: str
    message: str
    data: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Branch:
    """A connected piece of the zero set Z.

    points : (N, 2) [t, T] in the curves' own parameters, polished
    closed : True for a closed loop
    ends : where each end lies: 't_start', 't_end', 'T_start', 'T_end' (a side of the
        rectangle), 'loop' or 'unresolved'
    kind : 'graph' (T a function of t), 'curve' (turns back), 'loop', 'fan_c'
        (t constant: a cone with apex on c) or 'fan_d' (T constant: apex on d)
    """

    index: int
    points: np.ndarray
    closed: bool
    ends: tuple[str, str]
    kind: str


@dataclass(frozen=True)
class Piece:
    """A maximal part of a branch on which T' = -f_t / f_T keeps its class.

    acceptable : T moves monotonically with t in the orientation of the solution
        (T' >= 0, or T' <= 0 when d runs against c; fans included); otherwise the
        rulings cross (regression).
    corner : a corner fan: the piece lies on a C0 knot line of c (or d) and joins the
        one-sided roots there by a cone with its apex at the corner point (branch -1)
    """

    index: int
    branch: int
    points: np.ndarray
    acceptable: bool
    corner: bool = False

    @property
    def t_range(self) -> tuple[float, float]:
        return float(self.points[:, 0].min()), float(self.points[:, 0].max())

    @property
    def T_range(self) -> tuple[float, float]:
        return float(self.points[:, 1].min()), float(self.points[:, 1].max())


@dataclass(frozen=True)
class TurningPoint:
    """Where a branch changes between acceptable and regression.

    kind : 'dT/dt=0' (f_t = 0) or 'dt/dT=0' (f_T = 0)
    point_c, point_d : c(t) and d(T) in model space
    """

    branch: int
    t: float
    T: float
    kind: str
    point_c: np.ndarray
    point_d: np.ndarray


@dataclass(frozen=True)
class CurvatureMismatch:
    """A stretch of a branch where the normal curvatures of c and d have opposite
    signs: the part of the curves a designer has to change. (Theorem 2 stated
    correctly: neighbouring rulings do not cross iff k_c k_d > 0; T' > 0 additionally
    needs c' and d' on the same side of the ruling, see the README.)

    t_range, T_range : parameter intervals; points_c, points_d : (2, 3) the stretch's
    ends on c and d in model space; worst : (t, T) where kc * kd is most negative.
    """

    branch: int
    t_range: tuple[float, float]
    T_range: tuple[float, float]
    points_c: np.ndarray
    points_d: np.ndarray
    worst: tuple[float, float]


@dataclass(frozen=True)
class KnotCrossing:
    """A branch crossing a knot of c or d, with the one-sided jumps of T' and T''.

    expected_class : k - 1 for a C^k curve at that knot (the solution is C^(k-1))
    jump_first, jump_second : |T'(+) - T'(-)| and |T''(+) - T''(-)|, relative to
        1 + |T'| and 1 + |T''|
    """

    branch: int
    curve: str
    knot: float
    t: float
    T: float
    expected_class: int
    jump_first: float
    jump_second: float


@dataclass(frozen=True)
class Coverage:
    """Parameter intervals of c and d a path covers, their lengths and fractions.

    ``area`` is the area of the strip along the path (model units squared, 0 when
    not computed): the path chooser ranks paths by min(c_fraction, d_fraction) first,
    then by this area.
    """

    t_interval: tuple[float, float]
    T_interval: tuple[float, float]
    c_length: float
    d_length: float
    c_fraction: float
    d_fraction: float
    area: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        return {"t_interval": list(self.t_interval), "T_interval": list(self.T_interval),
                "c_length": self.c_length, "d_length": self.d_length,
                "c_fraction": self.c_fraction, "d_fraction": self.d_fraction, "area": self.area}


@dataclass(frozen=True)
class Path:
    """The chosen developable strip: a monotone path through acceptable pieces.

    points : (N, 2) [t, T], t and T non-decreasing
    pieces : indices of the pieces used, in order
    fans : fan stretches along the path, as dicts
    orientation : +1 when T increases with t, -1 when d runs against c
    """

    points: np.ndarray
    pieces: tuple[int, ...]
    coverage: Coverage
    fans: tuple[dict, ...] = ()
    orientation: int = 1


@dataclass(frozen=True, eq=False)
class SolutionSet:
    """Everything the solver found for a pair of curves.

    ``bool(result)`` is ``success``: an acceptable path exists. When it does not,
    ``message`` says why and ``findings`` carry the evidence.
    """

    success: bool
    message: str
    kind: str
    degree_in_T: int
    branches: tuple[Branch, ...]
    pieces: tuple[Piece, ...]
    turning_points: tuple[TurningPoint, ...]
    mismatches: tuple[CurvatureMismatch, ...]
    knot_crossings: tuple[KnotCrossing, ...]
    path: Path | None
    findings: tuple[Finding, ...]
    max_residual: float
    field: Any = None

    def __bool__(self) -> bool:
        return self.success
