"""Checks on a pair of boundary curves before anything is solved between them.

Light on purpose: ``devflat check`` runs it without importing the solver.
"""

from __future__ import annotations

import numpy as np

from .errors import InvalidInputError
from .nurbs import NurbsCurve
from .tolerances import Tolerances


def check_pair(c: NurbsCurve, d: NurbsCurve, tol: Tolerances) -> None:
    """Reject a pair that cannot bound a part: the same curve twice (either direction)."""
    for name, curve in (("c", c), ("d", d)):
        if not isinstance(curve, NurbsCurve):
            raise InvalidInputError(f"{name} must be a NurbsCurve, got {type(curve).__name__}")
    # the sampled gap below is at least the gap between the end points, and the sampled
    # size at most the control polygon's (convex hull): ends far apart in both
    # directions settle it without the arc-length sampling (the usual case)
    ends_c, ends_d = c(np.array(c.domain)), d(np.array(d.domain))
    hull = max(float(np.ptp(np.vstack([c.control_points, d.control_points]), axis=0).max()), 1e-300)
    end_gaps = [float(np.linalg.norm(ends_c - other, axis=1).max()) for other in (ends_d, ends_d[::-1])]
    if min(end_gaps) > 2.0 * tol.coincidence * hull:
        return
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
