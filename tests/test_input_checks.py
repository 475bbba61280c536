"""Input checks a user meets with real models (issue 26, item 5): knot vectors that break a
curve, DXF polylines with too few points, numbers in the wrong unit. Each exits 2 with a
message naming the file, the field and the value, and creates no output folder."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings, strategies as st
from scipy.interpolate import BSpline

from flatten import InvalidCurveError, nurbs_curve
from pipeline.cli import main
from pipeline.config import MAX_PART_MM, ConfigError, load_config
from tests.test_hostile_inputs import iges_126

C = [[0, 0, 0], [100, 20, 0], [200, 20, 5], [300, 0, 0]]
D = [[0, 0, 500], [100, 30, 500], [200, 30, 510], [300, 0, 500]]
# six control points of degree 3 whose knots put 4 copies of 0.5 in the middle: the user
# means a curve with a break at 0.5; the domain [0, 0.5] would end there (0/0 at t = 0.5)
BROKEN_POINTS = [[0, 0, 0], [100, 20, 0], [150, 20, 0], [200, 20, 5], [250, 10, 0], [300, 0, 0]]
BROKEN_KNOTS = [0, 0, 0, 0, 0.5, 0.5, 0.5, 0.5, 1, 1]
BROKEN_TEXT = "[0, 0, 0, 0, 0.5, 0.5, 0.5, 0.5, 1, 1]"


def config(c, d=None, units="mm") -> dict:
    return {"name": "p", "units": units, "resolution": {"rulings": 12}, "output": {"png": False, "obj": False},
            "curves": {"c": c, "d": d if d is not None else {"degree": 3, "control_points": D}}}


def refused(tmp_path, capsys, data) -> str:
    """Run the config; assert exit 2, the config named, no traceback, no output folder; the message."""
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "Traceback" not in err, err
    assert not out.exists()
    return err


# ------------------------------------------------------------------------------ knots
def test_inline_curve_with_a_break_in_its_knots_is_bad_input(tmp_path, capsys):
    err = refused(tmp_path, capsys, config({"degree": 3, "control_points": BROKEN_POINTS, "knots": BROKEN_KNOTS}))
    for piece in ("curves.c.knots", "interior knot 0.5 has multiplicity 4 > degree 3", BROKEN_TEXT):
        assert piece in err, (piece, err)


def test_iges_curve_with_a_break_in_its_knots_names_file_entity_and_knots(tmp_path, capsys):
    igs = tmp_path / "broken.igs"
    igs.write_text(iges_126(BROKEN_POINTS, 3, [float(k) for k in BROKEN_KNOTS]))
    err = refused(tmp_path, capsys, config({"iges": str(igs)}))
    for piece in (str(igs), "entity 126 at D1", "knots", "multiplicity 4 > degree 3", BROKEN_TEXT):
        assert piece in err, (piece, err)


def test_dxf_spline_with_a_break_in_its_knots_names_file_layer_and_knots(tmp_path, capsys):
    import ezdxf

    doc = ezdxf.new("R2000")
    doc.modelspace().add_open_spline(BROKEN_POINTS, degree=3, knots=BROKEN_KNOTS, dxfattribs={"layer": "SEAM_C"})
    dxf = tmp_path / "seams.dxf"
    doc.saveas(dxf)
    err = refused(tmp_path, capsys, config({"dxf": str(dxf), "layer": "SEAM_C"}))
    for piece in (str(dxf), "SPLINE", "layer 'SEAM_C'", "curves.c.knots", "multiplicity 4 > degree 3", BROKEN_TEXT):
        assert piece in err, (piece, err)


def test_knots_that_leave_the_last_control_point_without_influence_are_bad_input(tmp_path, capsys):
    # knots[4] = knots[5] = 1 ends the domain [0, 1] with N_4 supported on [1, 4] only
    err = refused(tmp_path, capsys, config({"degree": 3, "control_points": C + [[400, 0, 0]],
                                            "knots": [0, 0, 0, 0, 1, 1, 2, 3, 4]}))
    for piece in ("curves.c.knots", "control point 4 would act nowhere", "[0, 0, 0, 0, 1, 1, 2, 3, 4]"):
        assert piece in err, (piece, err)


def dead_or_broken(knots: np.ndarray, degree: int) -> bool:
    """Independent oracle: a control point whose B-spline basis function vanishes on the whole
    domain, or a knot inside the domain repeated more than ``degree`` times. A basis function
    is positive inside every non-empty span of its support, so the span midpoints decide."""
    n_points = len(knots) - degree - 1
    lo, hi = knots[degree], knots[n_points]
    edges = np.unique(knots[(knots >= lo) & (knots <= hi)])
    mids = 0.5 * (edges[:-1] + edges[1:])
    for i in range(n_points):
        coef = np.zeros(n_points)
        coef[i] = 1.0
        if np.max(np.abs(BSpline(knots, coef, degree)(mids))) == 0.0:
            return True
    inner, counts = np.unique(knots[(knots > lo) & (knots < hi)], return_counts=True)
    return bool(np.any(counts > degree))


@settings(max_examples=300, derandomize=True, deadline=None)
@given(degree=st.integers(1, 5), extra=st.integers(0, 4), data=st.data())
def test_knot_vectors_are_refused_exactly_when_a_control_point_is_dead_or_the_curve_breaks(degree, extra, data):
    n_points = degree + 1 + extra
    # few distinct values, so that repeated knots (and every multiplicity) come up often
    values = data.draw(st.lists(st.sampled_from([0.0, 0.25, 0.5, 0.75, 1.0]),
                                min_size=n_points + degree + 1, max_size=n_points + degree + 1))
    knots = np.sort(np.array(values))
    points = np.random.default_rng(n_points).normal(size=(n_points, 3)) * 100.0
    if not knots[n_points] > knots[degree]:
        with pytest.raises(InvalidCurveError, match="empty domain"):
            nurbs_curve(points, degree, knots=knots, name="curves.c")
        return
    bad = dead_or_broken(knots, degree)
    try:
        curve = nurbs_curve(points, degree, knots=knots, name="curves.c")
    except InvalidCurveError as err:
        assert bad, str(err)
        assert str(err).startswith("curves.c.knots: ")
        assert "[" + ", ".join(f"{k:.10g}" for k in knots) + "]" in str(err)  # the whole knot vector
        return
    assert not bad
    lo, hi = curve.domain
    t = np.linspace(lo, hi, 41)  # both ends included: no 0/0 there
    assert np.all(np.isfinite(curve.derivatives(t, 2)))


@settings(max_examples=25, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # capsys is read out per example
@given(data=st.data())
def test_knot_vectors_in_a_config_exit_2_exactly_when_the_curve_is_broken(tmp_path_factory, capsys, data):
    # a cubic of 7 control points: 11 knots drawn from a few values, in the YAML as given
    knots = np.sort(np.array(data.draw(st.lists(st.sampled_from([0.0, 0.2, 0.5, 0.8, 1.0]), min_size=11,
                                                max_size=11))))
    if not knots[7] > knots[3]:
        return  # an empty domain (its own message, tested in test_nurbs)
    points = (np.random.default_rng(3).normal(size=(7, 3)) * 100.0).round(3)
    path = tmp_path_factory.mktemp("knots") / "k.yaml"
    path.write_text(yaml.safe_dump(config({"degree": 3, "control_points": points.tolist(),
                                           "knots": knots.tolist()})))
    bad = dead_or_broken(knots, 3)
    assert main(["check", str(path)]) == (2 if bad else 0)
    err = capsys.readouterr().err
    if bad:
        assert str(path) in err and "curves.c.knots" in err and ", ".join(f"{k:.10g}" for k in knots) in err, err


# --------------------------------------------------------------------- DXF polylines
@pytest.mark.parametrize("points, distinct", [
    ([[0, 0, 0], [100, 0, 0], [200, 50, 0], [100, 0, 0], [0, 0, 0]], 3),
    ([[0, 0, 0], [300, 0, 0]], 2),
])
def test_dxf_polyline_with_too_few_distinct_points_names_the_file_and_layer(tmp_path, capsys, points, distinct):
    import ezdxf

    doc = ezdxf.new("R2000")
    doc.modelspace().add_polyline3d(points, dxfattribs={"layer": "SEAM_C"})
    dxf = tmp_path / "seam.dxf"
    doc.saveas(dxf)
    err = refused(tmp_path, capsys, config({"dxf": str(dxf), "layer": "SEAM_C", "tolerance": 0.1}))
    assert str(dxf) in err and "POLYLINE" in err and "layer 'SEAM_C'" in err, err
    if distinct >= 2 and len(points) >= 4:
        assert f"at least 4 distinct points, got {distinct}" in err, err
    else:
        assert f"shape ({len(points)}, 3)" in err, err


# ----------------------------------------------------------------------------- units
def lines_apart(length: float, gap: float) -> dict:
    """Two straight parallel lines of ``length``, ``gap`` apart: the part's extent is
    exactly hypot(length, gap)."""
    return {"c": {"degree": 1, "control_points": [[0, 0, 0], [length, 0, 0]]},
            "d": {"degree": 1, "control_points": [[0, 0, gap], [length, 0, gap]]}}


def test_mm_numbers_under_units_m_are_stopped_saying_what_was_expected(tmp_path, capsys):
    # a 2.9 m plate drawn in mm but declared in metres: 2.9 km
    data = config({"degree": 3, "control_points": [[0, 0, 0], [1000, 200, 0], [2000, 200, 50], [2900, 0, 0]]},
                  {"degree": 3, "control_points": [[0, 0, 500], [1000, 300, 500], [2000, 300, 510], [2900, 0, 500]]},
                  units="m")
    err = refused(tmp_path, capsys, data)
    extent = load_extent(data, tmp_path)
    assert 2900.0 < extent <= np.linalg.norm([2900.0, 300.0, 510.0])  # within the control points' box
    for piece in ("curves.c and curves.d", "units: m", f"{extent * 1e-3:.4g} km",
                  "expected a part between 1 mm and 1 km", f"as mm: {extent * 1e-3:.4g} m"):
        assert piece in err, (piece, err)


def load_extent(data, tmp_path) -> float:
    """The extent of the same part read in mm (where it passes), by sampling both curves densely."""
    path = tmp_path / "in_mm.yaml"
    path.write_text(yaml.safe_dump(dict(data, units="mm")))
    part = load_config(path).parts[0]
    points = np.vstack([curve(np.linspace(*curve.domain, 20001)) for curve in (part.c, part.d)])
    return float(np.linalg.norm(np.ptp(points, axis=0)))


def test_a_part_smaller_than_a_millimetre_is_stopped(tmp_path, capsys):
    data = config(**lines_apart(0.6, 0.8))  # extent 1.0 in the config's numbers
    data["units"] = "in"  # 25.4 mm: passes
    path = tmp_path / "ok.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["check", str(path)]) == 0
    capsys.readouterr()
    data["units"] = "mm"
    data["curves"] = lines_apart(0.3, 0.4)  # 0.5 mm
    err = refused(tmp_path, capsys, data)
    for piece in ("part p", "span 0.5 under units: mm", "a part of 0.5 mm", "between 1 mm and 1 km",
                  "as cm: 5 mm", "as m: 500 mm", "as in: 12.7 mm"):
        assert piece in err, (piece, err)


@pytest.mark.parametrize("units, scale", [("mm", 1.0), ("m", 1000.0), ("cm", 10.0), ("in", 25.4)])
def test_the_size_limit_is_one_kilometre_in_mm_after_units(tmp_path, units, scale):
    limit = MAX_PART_MM / scale  # in the config's units
    for extent, passes in ((0.999 * limit, True), (1.001 * limit, False)):
        data = config(**lines_apart(0.6 * extent, 0.8 * extent), units=units)
        path = tmp_path / f"{units}.yaml"
        path.write_text(yaml.safe_dump(data))
        if passes:
            assert len(load_config(path).parts) == 1
        else:
            with pytest.raises(ConfigError, match=r"a part of 1\.001 km"):
                load_config(path)


def test_a_sequence_names_the_two_curves_of_the_oversized_part(tmp_path, capsys):
    line = lambda y, z: {"degree": 1, "control_points": [[0, y, z], [300, y, z]]}  # noqa: E731
    data = {"name": "s", "units": "mm", "sequence": [line(0, 0), line(0, 500), line(0, 2e6)]}
    err = refused(tmp_path, capsys, data)
    assert "part s_2: sequence[1] and sequence[2]" in err, err
