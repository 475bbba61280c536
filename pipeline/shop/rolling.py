"""Roll set-up: which bending lines a plate of its thickness must be rolled at.

A plate pulled onto its frames at assembly takes a curvature elastically as long as the
bending stress stays well inside the yield stress; rolling it there is wasted work (the rolls
would have to overbend it anyway, the springback being nearly the whole bend). The model is
cylindrical bending of a wide plate (plane strain, Timoshenko & Woinowsky-Krieger, *Theory
of Plates and Shells*, 2nd ed., §1-2): bent to radius R, the outer fibre of a plate of
thickness t carries

    sigma = E' t / (2 R),   E' = E / (1 - nu^2),

so the radius at which it reaches the share k of the yield stress sigma_y is

    R_no_roll = E' t / (2 k sigma_y).

Curvature flatter than that (R > R_no_roll) is pulled in elastically and gets no bending line.
Default k = 0.5: a plate pulled into place keeps at most half its yield stress as a locked-in
assembly stress (the rest is the margin for the service loads it is designed for). Steel:
E = 206 000 MPa, nu = 0.3 (the values IACS class rules use). Yield stress from the material
name: EN 10025 grades S235...S960 by their number; IACS UR W11 hull steels A, B, D, E 235 MPa,
AH/DH/EH/FH32 315, 36 355, 40 390, 47 460 MPa; any other name: 235 MPa (the lowest ship steel,
so the limit is on the safe side: more lines rolled), said so in the report.
Examples: 14 mm AH36 8 927 mm, 12 mm S355 7 652 mm, 16 mm AH36 10 203 mm, 8 mm S235 7 706 mm.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

import numpy as np

E_STEEL = 206_000.0  # MPa
NU_STEEL = 0.3
STRESS_SHARE = 0.5  # k: the share of the yield stress a plate may keep when pulled into place
FALLBACK_YIELD = 235.0  # MPa: the lowest hull steel's yield stress, for a material not known
_HIGH_TENSILE = {"27": 265.0, "32": 315.0, "36": 355.0, "40": 390.0, "47": 460.0}  # IACS UR W11 (AH27S: 265)


@dataclass(frozen=True)
class RollSetup:
    """The radius limit of one plate and what it leaves to roll (mm, MPa).

    limit : the no-roll radius (mm): lines flatter than it get no bending line
    thickness : plate thickness (mm); yield_stress : sigma_y (MPa)
    source : how the limit was found (the model with its numbers, or "shop.no_roll_radius")
    rolled : bending lines kept (radius below the limit); dropped : lines left out
    smallest_radius : the plate's smallest radius across any line (inf on a flat plate)
    """

    limit: float
    thickness: float
    yield_stress: float
    source: str
    rolled: int = 0
    dropped: int = 0
    smallest_radius: float = float("inf")

    @property
    def needs_rolling(self) -> bool:
        return self.rolled > 0

    def text(self) -> str:
        """The shop text: what is rolled, or that nothing is."""
        if not self.needs_rolling:
            return f"NO ROLLING: RADIUS >= {self.limit:.0f} MM EVERYWHERE (PULLED IN ELASTICALLY)"
        return f"ROLL ONLY WHERE MARKED: RADIUS < {self.limit:.0f} MM"

    def figures(self) -> dict:
        """The report's ``bending.rolling`` section."""
        return {"units": "mm", "no_roll_radius": self.limit, "thickness": self.thickness,
                "yield_stress_mpa": self.yield_stress, "source": self.source,
                "needs_rolling": self.needs_rolling, "rolled_lines": self.rolled, "lines_not_rolled": self.dropped,
                "smallest_radius": self.smallest_radius if np.isfinite(self.smallest_radius) else None,
                "text": self.text(),
                "rule": "a bending line only where the radius across it is below no_roll_radius; flatter "
                        "curvature is taken elastically when the plate is pulled into place"}


def yield_stress(material: str) -> tuple[float, bool]:
    """(sigma_y in MPa, known) for a steel grade name such as 'S355', 'AH36', 'A'; unknown
    names give the fallback (235 MPa) and known = False."""
    name = material.strip().upper().replace(" ", "")
    match = re.match(r"^S(\d{3})", name)
    if match:
        return float(match.group(1)), True
    match = re.match(r"^[ADEF]H(\d{2})", name)
    if match and match.group(1) in _HIGH_TENSILE:
        return _HIGH_TENSILE[match.group(1)], True
    if name in ("A", "B", "D", "E", "MILD", "MS"):
        return 235.0, True
    return FALLBACK_YIELD, False


def no_roll_radius(thickness, sigma_y, share: float = STRESS_SHARE, modulus: float = E_STEEL,
                   poisson: float = NU_STEEL):
    """R = E' t / (2 k sigma_y) (mm) with E' = E / (1 - nu^2): the radius at which the outer
    fibre of a wide plate of ``thickness`` (mm) bent to it carries the share k of its yield
    stress ``sigma_y`` (MPa). Broadcasts over arrays."""
    thickness = np.asarray(thickness, dtype=float)
    if np.any(thickness <= 0):
        raise ValueError(f"thickness must be > 0 mm, got {thickness}")
    if not 0 < share <= 1:
        raise ValueError(f"share must be in (0, 1], got {share}")
    if np.any(np.asarray(sigma_y) <= 0):
        raise ValueError(f"sigma_y must be > 0 MPa, got {sigma_y}")
    return modulus / (1.0 - poisson ** 2) * thickness / (2.0 * share * np.asarray(sigma_y, dtype=float))


def plate_limit(thickness: float, material: str, configured: float | None) -> RollSetup:
    """The no-roll radius of a plate: ``configured`` (shop.no_roll_radius, mm) when given,
    else the elastic model above for its thickness and material."""
    sigma, known = yield_stress(material)
    if configured is not None:
        return RollSetup(float(configured), thickness, sigma, "shop.no_roll_radius")
    limit = float(no_roll_radius(thickness, sigma))
    source = (f"E' t / (2 k sigma_y): E = {E_STEEL:g} MPa, nu = {NU_STEEL:g}, t = {thickness:g} mm, "
              f"k = {STRESS_SHARE:g}, sigma_y = {sigma:g} MPa ("
              + (f"grade {material}" if known else f"material {material!r} not known: the lowest hull steel's")
              + "); cylindrical bending of a wide plate")
    return RollSetup(limit, thickness, sigma, source)


def line_radii(surface, params: np.ndarray, flat: np.ndarray, faces: np.ndarray, outline: np.ndarray,
               lines: np.ndarray, samples: int = 5) -> np.ndarray:
    """The smallest radius across each roll line of a plate developed from its hull patch
    (model units): at ``samples`` points along each flat line (lines (L, 2, 2)), the patch
    grid's surface parameters there (params (V, 2) of the flat grid points flat (V, 2),
    triangles faces, linear in each) and the hull's largest principal curvature at them:
    a roll line follows the least curvature, so the curvature across it is the largest.
    inf where a line leaves the plate everywhere."""
    import shapely

    from flatten.patch import principal_curvatures

    from .pinjig import height_field

    if not len(lines):
        return np.zeros(0)
    shadow = shapely.Polygon(outline)
    u_at = height_field(flat, params[:, 0], faces, shadow)
    v_at = height_field(flat, params[:, 1], faces, shadow)
    f = np.linspace(0.1, 0.9, samples)
    pts = (lines[:, :1, :] + f[None, :, None] * (lines[:, 1:, :] - lines[:, :1, :])).reshape(-1, 2)
    u, v = u_at(pts), v_at(pts)
    kappa = np.zeros(len(pts))
    ok = np.isfinite(u) & np.isfinite(v)
    if ok.any():
        kappa[ok] = np.abs(principal_curvatures(surface, u[ok], v[ok])[0][:, 1])
    largest = kappa.reshape(len(lines), samples).max(axis=1)
    with np.errstate(divide="ignore"):
        return np.where(largest > 0, 1.0 / largest, np.inf)


def rolled_lines(lines, setup: RollSetup):
    """The bending lines a plate is rolled at: those whose radius (BendLine.radius, mm) is
    below the limit, numbered again from 1 in their order; returns (lines, the setup with
    its counts). Lines without a radius (nan: roll lines of a formed plate, whose radius is
    not computed) are kept."""
    radius = np.array([b.radius for b in lines], dtype=float)
    keep = ~(radius >= setup.limit)  # nan and inf compare False / True as wanted: nan kept, inf dropped
    kept = [dataclasses.replace(b, number=k + 1) for k, b in enumerate(b for b, y in zip(lines, keep) if y)]
    finite = radius[np.isfinite(radius)]
    smallest = float(finite.min()) if finite.size else float("inf")
    return kept, dataclasses.replace(setup, rolled=len(kept), dropped=int((~keep).sum()), smallest_radius=smallest)
