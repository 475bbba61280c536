"""devflat geometry core: NURBS curves, the developability equation and its solver.

numpy in, numpy out: no files, no YAML, no printing.
"""

from .equation import DevelopabilityField, developability_field, normalized_residual
from .errors import DevflatError, InvalidCurveError, InvalidInputError
from .nurbs import NurbsCurve, clamped_uniform_knots, nurbs_curve
from .solution import (Branch, Coverage, CurvatureMismatch, Finding, KnotCrossing, Path, Piece,
                       SolutionSet, TurningPoint)
from .solver import rulings_on_path, solve
from .tolerances import DEFAULT_TOLERANCES, Tolerances

__all__ = [
    "Branch", "Coverage", "CurvatureMismatch", "DEFAULT_TOLERANCES", "DevelopabilityField",
    "DevflatError", "Finding", "InvalidCurveError", "InvalidInputError", "KnotCrossing",
    "NurbsCurve", "Path", "Piece", "SolutionSet", "Tolerances", "TurningPoint",
    "clamped_uniform_knots", "developability_field", "normalized_residual", "nurbs_curve",
    "rulings_on_path", "solve",
]
