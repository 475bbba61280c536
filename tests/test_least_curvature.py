"""The strip whose rulings follow the hull's least curvature (pipeline/hull/leaststrip.py):
closed forms for its direction and its misfit estimate, and a plate that neither its seams
nor its butt sections can carry as a strip."""

import json

import numpy as np
import pytest

from pipeline.hull.leaststrip import CurvatureSample, mean_direction, ruling_misfit
from tests.hull_shapes import helical_cylinder_iges
from tests.test_best_fit import run_strake


def _rectangle_sample(kappa1: float, kappa2: float, angle: float, length=10.0, width=2.0) -> CurvatureSample:
    x, y = np.meshgrid(np.linspace(0.0, length, 11), np.linspace(0.0, width, 5))
    xy = np.column_stack([x.ravel(), y.ravel()])
    n = len(xy)
    return CurvatureSample(xy, (length, width), np.tile([kappa1, kappa2], (n, 1)), np.full(n, angle))


def test_the_misfit_of_straight_rulings_is_the_sagitta_of_the_longest_chord_halved():
    """A 10 x 2 chart bending by kappa_1 = 1e-3 along x and kappa_2 = 2e-3 along y: rulings
    along x span 10 (misfit kappa_1 100 / 16), across span 2 (kappa_2 4 / 16); at 45 degrees
    the normal curvature is the mean (Euler) and the longest chord the rectangle's 2 sqrt 2."""
    sample = _rectangle_sample(1e-3, 2e-3, 0.0)
    assert ruling_misfit(sample, 0.0) == pytest.approx(1e-3 * 100 / 16)
    assert ruling_misfit(sample, np.pi / 2) == pytest.approx(2e-3 * 4 / 16)
    assert ruling_misfit(sample, np.pi / 4) == pytest.approx(1.5e-3 * 8 / 16)


def test_the_mean_direction_has_no_sign_and_ignores_points_that_bend_alike_every_way():
    """Directions of +80 and -80 degrees are one direction near +-90 (doubled angles), not 0;
    points of a sphere (kappa_1 = kappa_2) weigh nothing; a sphere alone has no direction."""
    a = _rectangle_sample(0.0, 1e-3, np.radians(80.0))
    b = _rectangle_sample(0.0, 1e-3, np.radians(-80.0))
    sphere = _rectangle_sample(1e-3, 1e-3, 0.3)
    both = CurvatureSample(np.vstack([a.xy, b.xy, sphere.xy]), a.extent, np.vstack([a.kappa, b.kappa, sphere.kappa]),
                           np.concatenate([a.angle, b.angle, sphere.angle]))
    angle, coherence = mean_direction(both)
    assert abs(abs(angle) - np.pi / 2) < 1e-12
    assert coherence == pytest.approx(np.cos(np.radians(20.0)))  # the two directions 20 degrees apart
    assert mean_direction(sphere) == (0.0, 0.0)


@pytest.fixture(scope="module")
def helical(tmp_path_factory):
    return helical_cylinder_iges(tmp_path_factory.mktemp("helical") / "helical.igs")


HELICAL_PLATE = {"butts": [4000.0, 16000.0], "fit_tolerance": 5.0, "seams": [{"iso": {"v": 0.4}}, {"iso": {"v": 0.6}}]}


def test_a_plate_whose_rulings_cross_its_seams_obliquely_is_the_strip_along_them(tmp_path, helical):
    """A 12 m x 1.8 m plate of a 3 m cylinder whose seams cross the generators at
    atan(0.2) = 11.31 degrees: a generator runs 9 m along the plate from seam to seam
    (further than the seams reach past the butts) and drifts 2.4 m across the girth from
    butt to butt (further than the butt sections reach past the seams), so neither pair of
    edges carries the cylinder. The strip between two hull curves across the generators is
    the cylinder: found at the generators' angle, within the surface's own interpolation
    error of the hull, its developed area the region's."""
    code, out = run_strake(tmp_path, {"surface": {"iges": str(helical)}, **HELICAL_PLATE})
    assert code == 0
    rep = json.loads((out / "t_S1_B1.json").read_text())
    klass = rep["plate_class"]
    assert klass["class"] == "developable" and klass["family"] == "rulings along the least curvature"
    assert abs(klass["least_curvature"]["angle_deg"]) == pytest.approx(np.degrees(np.arctan(0.2)), abs=0.05)
    assert klass["least_curvature"]["coherence"] > 0.999
    assert klass["max_deviation"] < 0.05 and rep["completeness"]["passed"]
    assert rep["outline"]["area_m2"] == pytest.approx(rep["region"]["area_m2"], rel=1e-3)
    assert klass["other_family"]["family"] in ("rulings seam to seam", "rulings butt to butt")
    assert klass["other_family"]["rejected_because"]


def test_without_the_least_curvature_strip_the_oblique_plate_is_formed(tmp_path, helical, monkeypatch):
    """The control: with the family's gate shut, the same plate has no strip (the seam and
    butt families fail, best fits included) and is developed on the hull as a patch."""
    from pipeline.hull import leaststrip

    monkeypatch.setattr(leaststrip, "GATE", -1.0)
    code, out = run_strake(tmp_path, {"surface": {"iges": str(helical)}, **HELICAL_PLATE})
    assert code == 0
    klass = json.loads((out / "t_S1_B1.json").read_text())["plate_class"]
    assert klass["class"] == "formed"
    reasons = {f["family"]: f["rejected_because"] for f in klass["families"]}
    assert reasons["rulings along the least curvature"].startswith("not tried: straight rulings at -11 deg")
    assert set(reasons) == {"rulings seam to seam", "rulings butt to butt", "rulings along the least curvature"}


def test_a_best_fit_of_the_least_curvature_strip_keeps_its_direction(tmp_path, helical, monkeypatch):
    """The best fit solves its moved strip again: the strip it hands back still says the
    direction it was laid along (plate_class.least_curvature), as the plain one does."""
    import yaml

    from pipeline.hull import bestfit
    from pipeline.hull.leaststrip import least_curvature_family
    from pipeline.hull.plan import load_run
    from pipeline.hull.plates import _grid

    path = tmp_path / "t.yaml"
    path.write_text(yaml.safe_dump({"name": "t", "units": "mm", "strake": {"surface": {"iges": str(helical)},
                                                                           **HELICAL_PLATE}}))
    config = load_run(path)
    part = config.parts[0]
    grid = _grid(part, config)
    plain = least_curvature_family(part, config, grid, 0.5)
    assert plain.ok and "least_curvature" in plain.figures
    solved = []
    real = bestfit._solved_and_trimmed

    def kept(*args, **kwargs):
        solved.append(real(*args, **kwargs))
        return solved[-1]

    monkeypatch.setattr(bestfit, "_solved_and_trimmed", kept)
    bestfit.best_fit(plain, part, config, grid, 1)
    assert len(solved) == 1 and solved[0].figures["least_curvature"] == plain.figures["least_curvature"]
