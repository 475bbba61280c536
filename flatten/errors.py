"""Exception types of devflat.

Every error subclasses both :class:`DevflatError` and the builtin it matches, so
callers may catch either (the ezdxf convention).
"""


class DevflatError(Exception):
    """Base class of every error raised on purpose by devflat."""


class InvalidCurveError(DevflatError, ValueError):
    """A curve definition is malformed: wrong knots, bad weights, NaN, too few points."""


class InvalidInputError(DevflatError, ValueError):
    """Two curves cannot form a part (coincident curves, incompatible arguments)."""
