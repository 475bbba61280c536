"""Numerical tolerances, gathered in one frozen object passed explicitly."""

from dataclasses import dataclass


@dataclass(frozen=True)
class Tolerances:
    """Every threshold the geometry core uses.

    Attributes
    ----------
    residual : float
        Bound on the normalised developability residual
        |g| / (|c'| |d'| |d - c|) a polished ruling must reach.
    zero_relative : float
        A polynomial coefficient (or a determinant) below this fraction of its
        natural scale counts as zero: flat plates, degree drops, fans.
    planarity : float
        Largest distance from a plane, relative to the curve size, for a curve
        to count as planar.
    near_planarity : float
        Largest distance from one plane, relative to the curves' size, for a pair
        whose general solve finds no path, or one that leaves part of a curve
        uncovered beside crossing rulings, to be the planar region between them:
        a CAD model's flat is flat only to its numbers' precision
        (KVLCC2's loft sections across its flat bottom: 1.6e-6 mm off their plane
        over 15.6 m, 1.0e-10 of their size), and f is then that noise, whose
        branches covered 5 and 8 % of the two sections.
    coincidence : float
        Largest distance between the curves, relative to their size, for them to
        count as coincident (bad input).
    grid_lines_per_span : int
        Seed lines per knot span and direction for the branch tracer.
    min_grid_lines : int
        Seed lines over the whole parameter range, whatever the span count.
    trace_step : float
        Spacing of a traced polyline's points in the unit parameter square (at most ~1.25
        of it; the tracer steps up to 16 of them where the zero set is straight and fills in
        between).
    trace_min_step : float
        Smallest tracer step before the tracer tries to jump a singular point.
    trace_max_steps : int
        Steps one trace may take in one direction before it stops with a finding.
    junction : float
        Distance in the unit parameter square below which two branch points are
        the same point (junctions, loop closure, seed matching).
    min_piece_coverage : float
        Pieces covering less than this fraction of both curves are ignored when
        choosing a path (isolated touching points).
    nesting : float
        Slack of the nesting checks (inside the sheet, gaps between parts), relative
        to the sheet size: the nesting engine computes in float32.
    """

    residual: float = 1e-12
    zero_relative: float = 1e-11
    planarity: float = 1e-10
    near_planarity: float = 1e-8
    coincidence: float = 1e-9
    grid_lines_per_span: int = 6
    min_grid_lines: int = 48
    trace_step: float = 4e-3
    trace_min_step: float = 1e-6
    trace_max_steps: int = 20000
    junction: float = 1e-6
    min_piece_coverage: float = 1e-6
    nesting: float = 1e-6


DEFAULT_TOLERANCES = Tolerances()
