"""Curve sources beside inline NURBS: IGES curves and surface iso-curves, DXF splines and
polylines, and point lists fitted to a cubic B-spline within a stated tolerance.

Every reader rejects a bad file with a message naming the file and the entity.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import make_splprep

from flatten import InvalidCurveError, NurbsCurve, nurbs_curve
from flatten.errors import DevflatError

from .iges import IgesError, iges_curve, iges_surface, read_iges


class SourceError(DevflatError, ValueError):
    """A curve source cannot be read or does not hold the entity asked for."""


MAX_FIT_POINTS = 100_000


def source_path(base: Path, name: str) -> Path:
    """A source file's absolute path, relative to the config's folder; symlinks are not
    resolved here (a loop is reported when the file is read, not raised as RuntimeError)."""
    return Path(os.path.abspath(base / name))


@dataclass(frozen=True)
class FitReport:
    """How well a fitted curve follows its points (model units)."""

    points: int
    control_points: int
    max_error: float
    rms_error: float
    tolerance: float


def fit_points(points: np.ndarray, tolerance: float, name: str,
               where: str | None = None) -> tuple[NurbsCurve, FitReport]:
    """Cubic B-spline through (N, 3) points, smoothed as much as the tolerance allows:
    the smoothing factor is lowered until the largest distance of a point from the
    curve (at its own parameter) is within ``tolerance``. Messages start with ``where``
    (the file and entity the points come from), by default with the curve's ``name``."""
    from flatten.nurbs import MAX_COORDINATE

    where = name if where is None else where

    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < 4:
        raise SourceError(f"{where}: need at least 4 points of 3 coordinates, got shape {pts.shape}")
    if len(pts) > MAX_FIT_POINTS:
        raise SourceError(f"{where}: {len(pts)} points, more than the {MAX_FIT_POINTS} a fit takes")
    bad = np.argwhere(~(np.abs(pts) <= MAX_COORDINATE))
    if len(bad):
        i, j = bad[0]
        raise SourceError(f"{where}: point {i} coordinate {j} = {pts[i, j]:g} is not finite or beyond "
                          f"+-{MAX_COORDINATE:g}")
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(pts, axis=0), axis=1) > 0
    pts = pts[keep]
    distinct = len(np.unique(pts, axis=0))
    if distinct < 4:
        raise SourceError(f"{where}: a cubic fit needs at least 4 distinct points, got {distinct}")
    try:
        with warnings.catch_warnings():
            # FITPACK warns when its smoothing iteration stops short of s (too small for the
            # knots, or out of iterations) and returns its best spline: the distance of every
            # point from it, checked below, judges that spline, so the warning says nothing
            # a user can act on (the 160 m hull's run printed one)
            warnings.simplefilter("ignore", RuntimeWarning)
            smoothing = len(pts) * tolerance**2
            for _ in range(60):
                spline, u = make_splprep(pts.T, k=3, s=smoothing)
                error = np.linalg.norm(spline(u).T - pts, axis=1)
                if error.max() <= tolerance:
                    break
                smoothing *= 0.25
            else:
                spline, u = make_splprep(pts.T, k=3, s=0)
                error = np.linalg.norm(spline(u).T - pts, axis=1)
    except ValueError as exc:  # scipy's own checks of the data (e.g. a point list that doubles back)
        raise SourceError(f"{where}: the points cannot be fitted by a cubic B-spline: {exc}") from None
    n = len(spline.t) - 4
    curve = nurbs_curve(np.asarray(spline.c).reshape(3, -1).T[:n] if np.asarray(spline.c).shape[0] == 3
                        else np.asarray(spline.c)[:n], 3, None, spline.t, name=name)
    return curve, FitReport(len(pts), n, float(error.max()), float(np.sqrt(np.mean(error**2))), tolerance)


def pick_entity(entities, spec, where: str, kind: str):
    """The entity a source names by index among its type, directory number or label."""
    if spec.directory is not None:
        found = [e for e in entities if e.directory == spec.directory]
        what = f"directory entry D{spec.directory}"
    elif spec.label is not None:
        found = [e for e in entities if e.label == spec.label]
        what = f"label {spec.label!r}"
    else:
        found = entities[spec.entity: spec.entity + 1] if 0 <= spec.entity < len(entities) else []
        what = f"index {spec.entity}"
    if not found:
        raise SourceError(f"{where}: no {kind} with {what} ({len(entities)} {kind} entities in the file)")
    return found[0]


def iges_source(spec, base: Path, mm_per_unit: float, name: str) -> tuple[NurbsCurve, FitReport | None]:
    """A curve from an IGES file: entity 126, or an iso-curve or a plane section (fitted)
    of entity 128; scaled from the file's unit to the config's."""
    path = source_path(base, spec.iges)
    report = None
    try:
        iges = read_iges(path)
        scale = iges.unit_mm / mm_per_unit
        if spec.iso is None and spec.section is None:
            entity = pick_entity(iges.of_type(126), spec, str(path), "entity-126 curve")
            curve = iges_curve(iges, entity, scale, name)
        else:
            entity = pick_entity(iges.of_type(128), spec, str(path), "entity-128 surface")
            surface = iges_surface(iges, entity, scale, name)
            where = f"{path}: entity 128 at D{entity.directory}"
            if spec.iso is not None:
                curve = _iso(surface, spec.iso, where, name)
            else:
                try:
                    points = surface.plane_section_points(spec.section.point, spec.section.normal)
                except ValueError as exc:
                    raise SourceError(f"{where}: section {spec.section.point} / {spec.section.normal}: {exc}") from None
                curve, report = fit_points(points, spec.tolerance, name)
        if spec.segment is not None:
            curve = curve.segment(*spec.segment)
        return curve, report
    except (IgesError, InvalidCurveError) as exc:
        raise SourceError(str(exc)) from None


def _iso(surface, iso, where: str, name: str) -> NurbsCurve:
    if iso.u is not None:
        lo, hi = surface.domain_u
        value, direction = iso.u, "u"
    else:
        lo, hi = surface.domain_v
        value, direction = iso.v, "v"
    if not lo <= value <= hi:
        raise SourceError(f"{where}: iso.{direction} = {value} lies outside the surface's domain [{lo}, {hi}]")
    return surface.iso_u(value, name) if direction == "u" else surface.iso_v(value, name)


def dxf_source(spec, base: Path, name: str) -> tuple[NurbsCurve, FitReport | None]:
    """A SPLINE (exact NURBS) or a polyline (fitted) from a DXF file, by layer or handle."""
    import ezdxf

    from .inputs import InputFileError, check_input_file

    path = source_path(base, spec.dxf)
    try:
        check_input_file(path, "DXF")
        doc = ezdxf.readfile(path)
    except InputFileError as exc:
        raise SourceError(str(exc)) from None
    except Exception as exc:  # noqa: BLE001 - ezdxf's parser raises many types on hostile files
        raise SourceError(f"{path}: cannot read the DXF file: {type(exc).__name__}: {exc}") from None
    msp = doc.modelspace()
    if spec.handle is not None:
        entity = doc.entitydb.get(spec.handle)
        what = f"handle {spec.handle}"
        candidates = [entity] if entity is not None else []
    else:
        candidates = [e for e in msp.query("SPLINE LWPOLYLINE POLYLINE") if e.dxf.layer == spec.layer]
        what = f"layer {spec.layer!r}"
    if not candidates:
        raise SourceError(f"{path}: no SPLINE or polyline with {what}")
    entity = candidates[0]
    where = f"{path}: {entity.dxftype()} {entity.dxf.handle} on layer {entity.dxf.layer!r}"
    try:
        if entity.dxftype() == "SPLINE":
            points = np.array(entity.control_points, dtype=np.float64)
            weights = list(entity.weights) or None
            return nurbs_curve(points, int(entity.dxf.degree), weights, list(entity.knots), name=name), None
        if entity.dxftype() == "LWPOLYLINE":
            pts = np.array([(x, y, entity.dxf.elevation) for x, y in entity.get_points("xy")], dtype=np.float64)
        elif entity.dxftype() == "POLYLINE":
            pts = np.array([tuple(v.dxf.location) for v in entity.vertices], dtype=np.float64)
        else:
            raise SourceError(f"{where}: not a SPLINE or polyline")
    except InvalidCurveError as exc:
        raise SourceError(f"{where}: {exc}") from None
    return fit_points(pts, spec.tolerance, name, where=where)
