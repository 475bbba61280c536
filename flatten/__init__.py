"""devflat geometry core: NURBS curves, the developability equation and its solver.

numpy in, numpy out: no files, no YAML, no printing.

The error and tolerance names load with the package; the curves, the equation, the
solver and its result types load on first use (PEP 562): checking a config (``devflat
check``) does not pay for the tracer, the judge and the certification, and a process that
only reads results (the render process unpickling a solution) not for scipy.
"""

from importlib import import_module

from .errors import DevflatError, InvalidCurveError, InvalidInputError
from .tolerances import DEFAULT_TOLERANCES, Tolerances

# name -> the submodule that defines it, imported when the name is first asked for
_ON_FIRST_USE = {
    **dict.fromkeys(("NurbsCurve", "clamped_uniform_knots", "nurbs_curve"), "nurbs"),
    **dict.fromkeys(("DevelopabilityField", "developability_field", "normalized_residual"), "equation"),
    **dict.fromkeys(("Branch", "Coverage", "CurvatureMismatch", "Finding", "KnotCrossing", "Path", "Piece",
                     "SolutionSet", "TurningPoint"), "solution"),
    **dict.fromkeys(("rulings_on_path", "solve"), "solver"),
}

__all__ = [
    "Branch", "Coverage", "CurvatureMismatch", "DEFAULT_TOLERANCES", "DevelopabilityField",
    "DevflatError", "Finding", "InvalidCurveError", "InvalidInputError", "KnotCrossing",
    "NurbsCurve", "Path", "Piece", "SolutionSet", "Tolerances", "TurningPoint",
    "clamped_uniform_knots", "developability_field", "normalized_residual", "nurbs_curve",
    "rulings_on_path", "solve",
]


def __getattr__(name: str):
    module = _ON_FIRST_USE.get(name)
    if module is None:
        raise AttributeError(f"module 'flatten' has no attribute {name!r}")
    value = getattr(import_module(f".{module}", __name__), name)
    globals()[name] = value  # later lookups skip this hook
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
