"""The stages of one part: solve -> strip -> check -> unroll -> pattern.

Each stage is a function of typed inputs; a geometric failure is a result with a reason,
never an exception. No file is written here (see :mod:`pipeline.export`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flatten import DEFAULT_TOLERANCES, SolutionSet, solve
from flatten.develop import DevelopedStrip, Development, unfold_triangles
from flatten.meshcheck import naive_reference, ruling_residuals, strip_angle_defects
from flatten.metrics import distortion, polyline_length, triangle_areas
from flatten.strip import Strip, build_strip, choose_rulings

from .config import Part, RunConfig

CHECK_RULINGS = 256


@dataclass(frozen=True)
class Pattern:
    """The flat part in the plane (model units), placed with its bounding box at the origin.

    outline : (N, 2) closed cut contour (c side, then d side backwards), not repeated
    bend_lines : (K, 2, 2) ruling segments
    vertices : (V, 2) flat strip vertices (same order as the 3D mesh)
    placement : (rotation (2, 2), translation (2,)) taking the development to these coordinates
    """

    outline: np.ndarray
    bend_lines: np.ndarray
    vertices: np.ndarray
    placement: tuple
    frame_lines: tuple = ()  # ((x, (N, 2) polyline), ...) for hull plates
    labels: tuple = ()  # ((text, (2,) position, angle in degrees), ...) seam and butt names


@dataclass
class PartResult:
    """Everything known about one part after the run, success or not."""

    name: str
    part: Part
    status: str = "failed"
    reason: str = ""
    warnings: list[str] = field(default_factory=list)
    solution: SolutionSet | None = None
    strip: Strip | None = None
    development: Development | None = None
    # the exact development of the strip's rulings (stage_unroll), kept so that later stages
    # (frame lines, the exact outline, bending lines) develop further rulings from it
    developed: DevelopedStrip | None = None
    pattern: Pattern | None = None
    figures: dict = field(default_factory=dict)
    mesh: tuple | None = None  # (vertices (V, 3), faces (F, 3)) of a plate that is no strip (flat, formed)
    shop: object = None  # a pipeline.shop.ShopPlate for steel plates
    templates: tuple = ()  # pipeline.shop.templates.Template: what checks a curved steel plate's shape
    pinjig: object = None  # a pipeline.shop.pinjig.PinJig of a rolled or formed hull plate
    # a lean-evaluated hull plate's shop data still to compute (pipeline.hull.plateshop.ShopWork)
    shop_work: object = None
    # the checked strip's size (model units) while its naive surface's figures are owed (naive_check)
    naive_size: float | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def place_flat(points: np.ndarray, along_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rigid motion putting the developed c chord along +x and the bounding box at the origin.
    Returns (rotation (2, 2), translation (2,)) for p -> R p + t."""
    chord = along_c[-1] - along_c[0]
    angle = -np.arctan2(chord[1], chord[0]) if np.hypot(*chord) > 0 else 0.0
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    moved = points @ rot.T
    return rot, -moved.min(axis=0)


def stage_strip(result: PartResult, config: RunConfig, extra_rulings=None, given: np.ndarray | None = None) -> None:
    """Rulings (by chord tolerance or count) and the strip mesh; ``extra_rulings(solution)
    -> (K, 2)`` adds rulings a later stage needs (e.g. through the corners of a hull plate);
    ``given`` (K, 2) [t, T] in path order replaces them all (textile seams trim a strip so)."""
    res = config.spec.resolution
    part, solution = result.part, result.solution
    # chord_tolerance is in the config's units, like the curves; its default is 0.5 mm
    rulings = given if given is not None else choose_rulings(
        solution, part.c, part.d, chord_tolerance=res.tolerance(config.mm_per_unit), n_rulings=res.rulings)
    if extra_rulings is not None and given is None:
        corners = extra_rulings(solution)
        rulings = np.vstack([rulings, corners])
        rulings = rulings[np.lexsort((rulings[:, 1] * solution.path.orientation, rulings[:, 0]))]
        distinct = np.ones(len(rulings), dtype=bool)
        distinct[1:] = np.any(np.abs(np.diff(rulings, axis=0)) > 1e-12, axis=1)
        rulings = rulings[distinct]
    result.strip = build_strip(part.c, part.d, rulings, res.samples_per_ruling)
    from trimesh.grouping import group_rows  # trimesh costs ~0.1 s to import: only where the mesh is made

    mesh = result.strip.mesh()
    boundary_edges = len(group_rows(mesh.edges_sorted, require_count=1))
    result.figures["mesh"] = {"vertices": len(mesh.vertices), "faces": len(mesh.faces), "area_3d": float(mesh.area),
                              "euler_number": int(mesh.euler_number), "boundary_edges": boundary_edges}
    result.figures["rulings"] = {"count": len(rulings), "samples_per_ruling": res.samples_per_ruling,
                                 "chord_tolerance": res.tolerance(config.mm_per_unit),
                                 "max_chord_error_c": float(result.strip.max_chord_error[0]),
                                 "max_chord_error_d": float(result.strip.max_chord_error[1])}


def stage_check(result: PartResult, config: RunConfig, naive: bool = True) -> bool:
    """Analytic residual and libigl angle defects, beside the naive surface T = t (a
    reference figure that judges nothing: ``naive=False`` leaves it None, owed to
    :func:`naive_check` where the strip is delivered)."""
    strip, part, check = result.strip, result.part, config.spec.check
    size = float(np.ptp(strip.vertices, axis=0).max())
    residual = ruling_residuals(part.c, part.d, strip.rulings)
    # the surface is checked, not the export mesh: angle defects of a coarse mesh of a
    # developable strip with skew rulings are discretisation error, so check at least
    # CHECK_RULINGS rulings (the naive surface T = t gets the same mesh density)
    n_check = max(strip.n_rulings, CHECK_RULINGS)
    dense = strip if n_check == strip.n_rulings else build_strip(
        part.c, part.d, choose_rulings(result.solution, part.c, part.d, n_rulings=n_check), len(strip.samples),
        chords=False)
    mesh = strip_angle_defects(dense)
    flat_plate = result.solution.kind == "coplanar"
    curvature = mesh.max_abs_K * size**2
    passed_residual = flat_plate or float(residual.max()) <= check.max_residual
    passed_curvature = curvature <= check.max_curvature
    result.figures["developability"] = {
        "max_residual": 0.0 if flat_plate else float(residual.max()),
        "residual_limit": check.max_residual,
        "mesh": mesh.as_dict(),
        "naive_T_equals_t": None,
        "check_rulings": n_check,
        "max_abs_K_times_size_squared": curvature,
        "naive_max_abs_K_times_size_squared": None,
        "curvature_limit": check.max_curvature,
        "passed": bool(passed_residual and passed_curvature),
    }
    result.naive_size = size
    if naive:
        naive_check(result)
    if not passed_residual:
        result.reason = (f"strip not developable: residual {residual.max():.3g} above the limit "
                         f"{check.max_residual:.3g} at t = {strip.rulings[np.argmax(residual), 0]:.6g}")
        return False
    if not passed_curvature:
        result.reason = (f"strip not developable: max |K| size^2 = {curvature:.3g} above the limit "
                         f"{check.max_curvature:.3g}")
        return False
    return True


def naive_check(result: PartResult) -> None:
    """The naive surface T = t's angle defects beside a checked strip's (the mesh density and
    size :func:`stage_check` used: a seam strip is trimmed by its butts in between), when
    they are still owed."""
    figures = result.figures.get("developability")
    if figures is None or result.naive_size is None:
        return
    part, size = result.part, result.naive_size
    result.naive_size = None
    try:
        naive = naive_reference(part.c, part.d, figures["check_rulings"], len(result.strip.samples))
    except Exception as exc:  # noqa: BLE001 - a reference that judges nothing never fails a delivered strip
        figures["naive_T_equals_t"] = {"error": f"{type(exc).__name__}: {exc}"}
        return
    figures["naive_T_equals_t"] = naive.as_dict()
    figures["naive_max_abs_K_times_size_squared"] = naive.max_abs_K * size**2


def stage_unroll(result: PartResult) -> None:
    strip, part = result.strip, result.part
    developed = DevelopedStrip(part.c, part.d, strip.rulings, result.solution.field)
    development = developed.development
    m = len(strip.samples)
    k = np.arange(strip.n_rulings) * m
    flat = development.vertices(strip.samples)
    figures = distortion(strip.vertices, flat, m, part.c, part.d, strip.rulings)
    unfolded = unfold_triangles(strip.vertices[k], strip.vertices[k + m - 1], development)
    size = float(np.ptp(flat, axis=0).max())
    drift = max(np.abs(unfolded.along_c - development.along_c).max(),
                np.abs(unfolded.along_d - development.along_d).max())
    figures["triangle_unfold_drift"] = float(drift)
    figures["triangle_unfold_drift_relative"] = float(drift / size) if size > 0 else 0.0
    result.development, result.developed = development, developed
    result.figures["unroll"] = figures
    rot, shift = place_flat(flat, development.along_c)
    placed = flat @ rot.T + shift
    c_side = placed[k]
    d_side = placed[k + m - 1]
    outline = np.vstack([c_side, d_side[::-1]])
    keep = np.ones(len(outline), dtype=bool)
    keep[1:] = np.hypot(*np.diff(outline, axis=0).T) > 1e-12 * max(size, 1.0)
    outline = outline[keep]
    result.pattern = Pattern(outline, np.stack([c_side, d_side], axis=1), placed, (rot, shift))


def partial_percent(fraction: float) -> str:
    """A coverage fraction as a percentage with two decimals; a strip that misses less than
    5e-5 of a curve reads ">99.99%", never "100.00%" beside the word "partial"."""
    text = f"{100 * fraction:.2f}%"
    return ">99.99%" if text == "100.00%" and fraction < 1.0 else text


def develop_part(result: PartResult, config: RunConfig, extra_rulings=None, min_coverage=None, screen=None,
                 naive: bool = True, unroll: bool = True) -> bool:
    """Solve, strip, check and unroll; False (with the reason in the result) on a geometric
    failure. ``screen(result) -> bool``: a cheaper verdict on the checked strip, run before it is
    developed (False: rejected, the reason set by the screen). ``naive=False``: the naive
    surface's figures are left to :func:`naive_check` (a hull plate's strips are many
    attempts, one delivered); ``unroll=False``: so is the development, to :func:`stage_unroll`
    (a hull plate's strip families judge their strips on the region first)."""
    part = result.part
    solution = solve(part.c, part.d, DEFAULT_TOLERANCES)
    result.solution = solution
    if not solution:
        result.reason = solution.message
        return False
    cov = solution.path.coverage
    result.figures["coverage"] = cov.as_dict()
    min_coverage = config.spec.check.min_coverage if min_coverage is None else min_coverage
    if min(cov.c_fraction, cov.d_fraction) < min_coverage:
        result.reason = (f"coverage too low: the acceptable strip covers {100 * cov.c_fraction:.1f}% of c and "
                         f"{100 * cov.d_fraction:.1f}% of d (min_coverage {min_coverage:g})")
        return False
    if min(cov.c_fraction, cov.d_fraction) < 1.0 - 1e-9:
        result.warnings.append(f"partial coverage: {partial_percent(cov.c_fraction)} of c, "
                               f"{partial_percent(cov.d_fraction)} of d")
    stage_strip(result, config, extra_rulings)
    if not stage_check(result, config, naive):
        return False
    if screen is not None and not screen(result):
        return False
    if unroll:
        stage_unroll(result)
    return True


def run_part(part: Part, config: RunConfig) -> PartResult:
    """All geometric stages of one part; never raises for a geometric failure."""
    result = PartResult(part.name, part)
    if develop_part(result, config):
        finish_part(result, config)
    return result


def finish_part(result: PartResult, config: RunConfig) -> None:
    """Area and steel figures of a developed part; marks it ok."""
    part = result.part
    if config.spec.profile == "steel" and result.strip is not None and result.solution is not None:
        from .shop.plate import stage_shop

        stage_shop(result, config)
        area_m2 = result.figures["outline"]["area_m2"]  # the exact outline, not the ruling polygon
    else:
        faces = result.strip.faces if result.strip is not None else result.mesh[1]
        area_model = float(triangle_areas(result.pattern.vertices, faces).sum())
        area_m2 = area_model * (config.mm_per_unit / 1000.0) ** 2
    result.figures["area_m2"] = area_m2
    if config.spec.profile == "steel":
        steel = part.steel
        outline = np.vstack([result.pattern.outline, result.pattern.outline[:1]])
        result.figures["steel"] = {"thickness_mm": steel.thickness, "material": steel.material,
                                   "density_kg_m3": steel.density, "marked_side": steel.marked_side,
                                   "area_m2": area_m2,
                                   "weight_kg": area_m2 * steel.thickness / 1000.0 * steel.density,
                                   "outline_length": polyline_length(outline)}
    result.status = "ok"
