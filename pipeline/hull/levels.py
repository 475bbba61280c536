"""Waterlines and decks on the shell expansion: where the hull's sections reach a height.

A waterline is the plane z = base line + h (z up); a deck meets the shell along its
deck-at-side line, whose height may change along the hull (the sheer) and which may run
over part of it only (a forecastle deck). Both are a level z = Z(x) crossed by the sections
x = const that the expansion unrolls (:class:`.expansion.Sections`, which keep each
section point's z beside its girth). On the table's grid (stations along x by girth
samples), z - Z(x) is contoured at 0 by contourpy (matplotlib's contouring engine): where
a section crosses the level more than once (a bulb, a tumblehome) each crossing is its own
line, and a line ends where the level or the section ends. A level that the shell reaches
only at its edge (a deck at the top of the side shell) is met within ``snap``: points within
it of the level count as on it, so the line runs along the edge instead of flickering with
the edge's round-off.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CURVE_SAMPLES = 2001  # points of a deck-at-side curve read as height against x


@dataclass(frozen=True)
class DeckProfile:
    """A deck at side as heights along the hull: ``x`` (K,) ascending and ``z`` (K,) (config
    units), linear between them and absent beyond their ends; a single value (K = 1) holds
    all along the hull. ``above_base``: z counts from the base line (else it is the model's z)."""

    name: str
    x: np.ndarray
    z: np.ndarray
    above_base: bool

    def at(self, x: np.ndarray, base: float) -> np.ndarray:
        """The deck's model z (N,) at x (N,); NaN where the deck does not run."""
        x = np.asarray(x, dtype=float)
        shift = base if self.above_base else 0.0
        if len(self.x) == 1:
            return np.full(x.shape, float(self.z[0]) + shift)
        z = np.interp(x, self.x, self.z) + shift
        return np.where((x >= self.x[0]) & (x <= self.x[-1]), z, np.nan)


def deck_profile(deck, curve=None) -> DeckProfile:
    """The profile of a ``strake.decks`` entry (:class:`pipeline.config.DeckSpec`); ``curve``
    the built NURBS curve of a deck given by one. Raises ValueError when the curve does not run
    along the hull (it doubles back in x, or stands across it)."""
    if deck.height is not None:
        return DeckProfile(deck.name, np.zeros(1), np.array([float(deck.height)]), True)
    if deck.at_side is not None:
        points = np.asarray(deck.at_side, dtype=float)
        return DeckProfile(deck.name, points[:, 0].copy(), points[:, 1].copy(), True)
    points = curve(np.linspace(*curve.domain, CURVE_SAMPLES))
    step = np.diff(points[:, 0])
    if not (np.all(step > 0) or np.all(step < 0)):
        k = int(np.argmax(step <= 0)) if step[0] > 0 else int(np.argmax(step >= 0))
        raise ValueError(f"deck {deck.name!r}: its curve does not run one way along x (it turns at x = "
                         f"{points[k + 1, 0]:g}, point {k + 1} of {CURVE_SAMPLES} along it): a deck at side runs "
                         "along the hull")
    order = np.argsort(points[:, 0])
    return DeckProfile(deck.name, points[order, 0], points[order, 2], False)


def crossings(stations: np.ndarray, girth: np.ndarray, z: np.ndarray, level: np.ndarray, snap: float) -> list:
    """Polylines (M, 2) of (x, girth) where the sections cross the level.

    stations (K,) x of the sections; girth, z (K, n) of each section's points (NaN where the
    section has none); level (K,) the level's z at each station (NaN: none there); snap: a
    point within it of the level lies on it (model units)."""
    import contourpy

    f = z - level[:, None]
    bad = ~(np.isfinite(f) & np.isfinite(girth))
    if bad.all():
        return []
    # a section's end point within snap of the level: counted just above it, so that a level
    # met only along the shell's edge crosses between the edge and the point next to it, at
    # the edge itself (inside, the crossing is interpolated as it is)
    first = np.argmax(~bad, axis=1)
    last = f.shape[1] - 1 - np.argmax(~bad[:, ::-1], axis=1)
    rows = np.arange(len(f))
    for end in (first, last):
        near = ~bad[rows, end] & (np.abs(f[rows, end]) <= snap)
        f[rows[near], end[near]] = 1e-9 * snap
    x = np.broadcast_to(stations[:, None], f.shape)
    y = np.where(bad, 0.0, girth)  # never read: every cell at a masked point is left out
    generator = contourpy.contour_generator(x, y, np.ma.array(np.where(bad, 0.0, f), mask=bad),
                                            line_type=contourpy.LineType.Separate)
    return [np.asarray(line, dtype=float) for line in generator.lines(0.0) if len(line) >= 2]


@dataclass(frozen=True)
class Level:
    """A waterline or deck on the expansion: ``kind`` 'waterline', 'design' (the design
    waterline) or 'deck'; ``lines`` (M, 2) polylines (x, girth + the band's offset), model
    units; ``band`` the surface's band."""

    name: str
    kind: str
    lines: tuple
    band: int


def waterline_heights(spacing: float, design: float | None, top: float) -> list[tuple[str, str, float]]:
    """(name, kind, height above the base line) of the waterlines up to ``top``: every
    ``spacing`` from the base line (the base line itself left out) and the design waterline."""
    count = int(np.floor(top / spacing + 1e-9))
    out = [(f"WL {k * spacing:g}", "waterline", k * spacing) for k in range(1, min(count, 1000) + 1)
           if design is None or abs(k * spacing - design) > 1e-9 * spacing]
    if design is not None and design <= top:
        out.append((f"DWL {design:g}", "design", float(design)))
    return sorted(out, key=lambda item: item[2])
