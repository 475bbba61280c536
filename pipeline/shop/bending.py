"""Bending (roll) lines for the plater, chosen on the solved strip.

The solver's rulings are for computing (trim zones, checks); the shop gets rulings of the
same developable strip at a regular spacing across them (measured between the middles of
the rulings kept on the plate, not along their path: see :func:`across_rulings`), numbered, each
with the local radius across it and the side the plate is rolled to. A ruling is a
straight line of the strip, so rolling along it keeps the plate developable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .outline import PlateTracer

DENSE = 513  # samples of the kept rulings' middles for the length across them (the plate's corners besides)


@dataclass(frozen=True)
class BendLine:
    """One bending line on the placed flat plate (model units unless told).

    number : 1, 2, ... along the plate
    a, b : (2,) ends, on the c side and the d side of the plate
    station : distance across the rulings from the plate's first end (at the rulings' middles)
    radius : radius of curvature across the line at its middle (inf where flat)
    convex_on_drawn_side : the plate bulges towards the viewer of the drawing (the side
        the strip normal c' x (d - c) points to); None where not known (the roll lines of
        a plate developed from its hull patch)
    """

    number: int
    a: np.ndarray
    b: np.ndarray
    station: float
    radius: float
    convex_on_drawn_side: bool


def _centre_line(tracer: PlateTracer, lam: np.ndarray):
    """Developed ends of the kept rulings at lam, their developed and 3D middles, the 3D
    rulings' ends and the developed rulings' directions (c to d, whole)."""
    lo, hi, _, _, pc, pd = tracer.interval(lam)
    ac, ad = tracer.developed_at(lam)
    mid = 0.5 * (lo + hi)
    return ac + lo[:, None] * (ad - ac), ac + hi[:, None] * (ad - ac), ac + mid[:, None] * (ad - ac), \
        pc + mid[:, None] * (pd - pc), pc, pd, ad - ac


def across_rulings(middles: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance (K,) of each of K rulings from the first, measured across them, and the unit
    normals (K-1, 2) it was measured along: each step between neighbouring middles (K, 2) is
    projected on the normal of the two rulings' mean direction (K, 2; any length, c to d).
    Where a butt or seam cuts the rulings obliquely, the kept rulings' middles slide along
    them; the arc length of the middles' path counts that slide, which moves no line, and
    bunched the bending lines spaced along it (1 mm apart on butt-to-butt hull plates)."""
    unit = directions / np.maximum(np.linalg.norm(directions, axis=1), 1e-300)[:, None]
    # a ruling is a line: each taken the way its predecessor points, so that the mean of two
    # never cancels (a ruling cut to nothing, no direction, then takes its neighbour's)
    turn = np.einsum("ij,ij->i", unit[1:], unit[:-1])
    unit[1:] *= np.cumprod(np.where(turn < 0.0, -1.0, 1.0))[:, None]
    mean = unit[:-1] + unit[1:]
    normal = np.column_stack([-mean[:, 1], mean[:, 0]]) / np.maximum(np.linalg.norm(mean, axis=1), 1e-300)[:, None]
    steps = np.abs(np.einsum("ij,ij->i", np.diff(middles, axis=0), normal))
    return np.concatenate([[0.0], np.cumsum(steps)]), normal


def _middle(tracer: PlateTracer, lam: np.ndarray):
    """The 3D middles of the kept rulings at lam and their ends (no development needed)."""
    lo, hi, _, _, pc, pd = tracer.interval(lam)
    mid = 0.5 * (lo + hi)
    return pc + mid[:, None] * (pd - pc), pc, pd


def _curvature(tracer: PlateTracer, lam: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Signed curvature across the rulings at lam (the normal's turn over the distance
    between neighbouring rulings at their middles), > 0 where the plate is convex on the
    side its normal points to."""
    lo_lam, hi_lam = np.clip(lam - step, 0, 1), np.clip(lam + step, 0, 1)
    n0, n1 = np.split(tracer.normals(np.concatenate([lo_lam, hi_lam])), 2)  # both sides in one evaluation
    m0, pc0, pd0 = _middle(tracer, lo_lam)
    m1, pc1, pd1 = _middle(tracer, hi_lam)
    move = m1 - m0
    ruling = pd0 + pd1 - pc0 - pc1
    ruling /= np.maximum(np.linalg.norm(ruling, axis=1), 1e-300)[:, None]
    across = move - np.einsum("ij,ij->i", move, ruling)[:, None] * ruling
    width = np.linalg.norm(across, axis=1)
    turn = n1 - n0
    kappa = np.linalg.norm(turn, axis=1) / np.maximum(width, 1e-300)
    sign = np.sign(np.einsum("ij,ij->i", turn, across))
    return kappa, sign


def bending_lines(tracer: PlateTracer, spacing: float, min_length: float = 0.1) -> tuple[list[BendLine], float]:
    """Lines every ``spacing`` (model units) across the rulings, measured between the
    middles of the rulings kept between the butts (:func:`across_rulings`), centred so the
    margins at both ends are equal; lines shorter than ``min_length`` times the longest
    (corner slivers) are left out. Returns (lines, the plate's length across its rulings)."""
    first, last, corners = tracer.plate_range()
    # the kept middles turn sharply where a corner cuts the rulings (they then follow the
    # butt plane): a sample at each corner keeps the steps' error second order on the smooth
    # pieces between (without them a strake plate's centre line came out up to 2.2 mm short
    # at 2001 samples; with them 2e-5 mm at 513)
    lam = np.union1d(np.linspace(first, last, DENSE), corners)
    _, _, mid2, _, _, _, directions = _centre_line(tracer, lam)
    s, normal = across_rulings(mid2, directions)
    length = float(s[-1])
    stations = _stations(length, spacing)
    if not len(stations):
        return [], length
    at = np.interp(stations, s, lam)
    # one secant step on the exact middles removes the interpolation error
    _, _, m_at, *_ = _centre_line(tracer, at)
    index = np.clip(np.searchsorted(s, stations) - 1, 0, len(s) - 2)
    exact_s = s[index] + np.abs(np.einsum("ij,ij->i", m_at - mid2[index], normal[index]))
    slope = (s[index + 1] - s[index]) / np.maximum(lam[index + 1] - lam[index], 1e-300)
    at = np.clip(at - (exact_s - stations) / slope, first, last)
    step = 1e-5 * (last - first)
    # the lines and their neighbours for the curvature in one evaluation of the path
    tracer.rulings(np.concatenate([at, np.clip(at - step, 0, 1), np.clip(at + step, 0, 1)]))
    a, b, *_ = _centre_line(tracer, at)
    kappa, sign = _curvature(tracer, at, step)
    return _numbered(a, b, stations, kappa, sign, min_length), length


def _stations(length: float, spacing: float) -> np.ndarray:
    """Positions (K,) every ``spacing`` along a ``length``, centred so the margins at both
    ends are equal; empty when it is shorter than one spacing."""
    count = int(np.floor(length / spacing))
    return 0.5 * (length - (count - 1) * spacing) + spacing * np.arange(count) if count >= 1 else np.zeros(0)


def _numbered(a, b, stations, kappa, sign, min_length: float) -> list[BendLine]:
    """Bending lines numbered from 1, from flat ends a, b (K, 2), their stations, curvature
    and roll side; lines shorter than ``min_length`` times the longest (corner slivers) are
    left out."""
    lengths = np.linalg.norm(b - a, axis=1)
    lines = []
    for k in range(len(stations)):
        if lengths[k] < min_length * lengths.max():
            continue
        radius = float(1.0 / kappa[k]) if kappa[k] > 0 else float("inf")
        lines.append(BendLine(len(lines) + 1, a[k], b[k], float(stations[k]), radius, bool(sign[k] > 0)))
    return lines


def lines_on_rulings(a2: np.ndarray, b2: np.ndarray, a3: np.ndarray, b3: np.ndarray, normals: np.ndarray,
                     spacing: float, min_length: float = 0.1) -> tuple[list[BendLine], float]:
    """Bending lines of a strip given as K dense rulings already cut to the plate (a strip
    trimmed by its region, whichever family its rulings belong to): flat ends a2, b2 (K, 2)
    placed, 3D ends a3, b3 (K, 3), unit normals (K, 3) seen from the drawn side, in order
    along the plate. Lines every ``spacing`` across the rulings, measured between their
    middles (:func:`across_rulings`), each interpolated between its two neighbouring rulings
    (nearly a ruling: the rulings are dense), with the radius across it from the turn of the
    normals. Returns (lines, the plate's length across its rulings)."""
    if len(a2) < 3:
        return [], 0.0
    s, _ = across_rulings(0.5 * (a2 + b2), b2 - a2)
    length = float(s[-1])
    stations = _stations(length, spacing)
    if not len(stations):
        return [], length
    k = np.clip(np.searchsorted(s, stations) - 1, 0, len(s) - 2)
    f = ((stations - s[k]) / np.maximum(s[k + 1] - s[k], 1e-300))[:, None]
    a = a2[k] + f * (a2[k + 1] - a2[k])
    b = b2[k] + f * (b2[k + 1] - b2[k])
    lo, hi = np.clip(k - 1, 0, len(s) - 1), np.clip(k + 2, 0, len(s) - 1)
    mid3 = 0.5 * (a3 + b3)
    move = mid3[hi] - mid3[lo]
    ruling = b3[k] - a3[k]
    ruling /= np.maximum(np.linalg.norm(ruling, axis=1), 1e-300)[:, None]
    across = move - np.einsum("ij,ij->i", move, ruling)[:, None] * ruling
    turn = normals[hi] - normals[lo]
    kappa = np.linalg.norm(turn, axis=1) / np.maximum(np.linalg.norm(across, axis=1), 1e-300)
    sign = np.sign(np.einsum("ij,ij->i", turn, across))
    return _numbered(a, b, stations, kappa, sign, min_length), length
