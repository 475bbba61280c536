"""The hull planner: where the adaptive plan splits (a cylinder joined to a sphere cap),
IGES trims of the real KCS and KVLCC2 hulls against their own model-space boundaries, and
seams traced along the least curvature of a cylinder (its generators)."""

from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.interpolate import make_interp_spline

from flatten.minimax import fits_a_plane
from flatten.surface import nurbs_surface
from pipeline.io.iges import iges_curve, read_iges, iges_surface
from pipeline.hull.planner import honest_class
from pipeline.hull.seamlines import least_curvature_seams
from pipeline.hull.splitting import choose_split, estimate, sample_region
from pipeline.hull.trims import read_trim, trimmed_area
from tests.hull_shapes import cylinder_sphere_iges

ROOT = Path(__file__).resolve().parents[1]
SHIP = ROOT / "tests" / "data" / "ship"
RADIUS, CYLINDER, CAP, JUNCTION = 10000.0, 1500.0, 3000.0, 0.3


def _cs_config(tmp_path, max_splits: int) -> Path:
    iges = cylinder_sphere_iges(tmp_path / "cs.igs", RADIUS, 60.0, CYLINDER, CAP, JUNCTION)
    data = {"name": "cs", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
            "strake": {"surface": {"iges": str(iges)}, "margin": 0.2, "fit_tolerance": 5.0,
                       "plan": {"method": "adaptive", "max_splits": max_splits,
                                "stock": {"max_length": 4000, "max_width": 5000, "min_length": 1000,
                                          "min_width": 1000}}}}
    path = tmp_path / "cs.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_the_split_of_a_cylinder_joined_to_a_sphere_cap_falls_on_the_junction(tmp_path):
    """One strake, three plates along x (butt planes at x = -+1667); the middle plate is half
    cylinder (girth fraction < 0.3), half sphere. Its split is a seam at the junction
    (y = 1500 mm), not at mid girth; the plan then delivers the cylinder half as devflat's
    strip (exact) and the sphere half as not developable by a strip."""
    from pipeline.hull.plan import load_run
    from pipeline.hull.plates import evaluate_plate

    config = load_run(_cs_config(tmp_path, 1), evaluate_plate)
    by_name = {p.name: p for p in config.parts}
    assert "cs_S01_B02" not in by_name  # the mixed plate was split
    low, high = by_name["cs_S01_B02-1"], by_name["cs_S01_B02-2"]
    # the new seam runs at the junction: y within one grid row (1/16 of the girth) of 1500 mm
    seam = low.hull.girths[1]
    g = float(seam(np.array([0.5]))[0])
    y = float(low.hull.surface(np.array([0.5]), np.array([g]))[0, 1])
    assert y <= CYLINDER + 1e-6 and y >= CYLINDER - (CYLINDER + CAP) / 16 - 1.0
    assert honest_class(low.hull.result) == "developable"
    assert low.hull.result.figures["plate_class"]["max_deviation"] < 0.1
    assert honest_class(high.hull.result) == "formed"


def test_the_split_chooser_prefers_the_junction_over_mid_girth():
    """The estimate itself: the cylinder part of the region scores 0 (it is ruled along y),
    the sphere part a sagitta of order l^2 / (8 R) (>> 5 mm), so the best split leaves the
    whole cylinder in one half."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = cylinder_sphere_iges(Path(tmp) / "cs.igs", RADIUS, 60.0, CYLINDER, CAP, JUNCTION)
        iges = read_iges(path)
        surface = iges_surface(iges, iges.of_type(128)[0], 1.0, "cs")
    from flatten.plane import Plane
    from pipeline.hull.region import Girth

    pair = (Plane((1.0, 0.0, 0.0), -1667.0), Plane((1.0, 0.0, 0.0), 1667.0))
    cyl = sample_region(surface, 0, (Girth.iso(0.0), Girth.iso(0.25)), pair)
    cap = sample_region(surface, 0, (Girth.iso(0.35), Girth.iso(1.0)), pair)
    assert estimate(cyl, 5.0) < 1e-3
    # a spherical cap's chord of 3 m at least bends away by (3000)^2 / (8 R) = 112 mm
    assert estimate(cap, 5.0) > 3000.0**2 / (8 * RADIUS)
    whole = sample_region(surface, 0, (Girth.iso(0.0), Girth.iso(1.0)), pair)
    split = choose_split(whole, 5.0, 1000.0, 1000.0)
    assert split.kind == "girth" and JUNCTION - 1 / 16 <= split.at <= JUNCTION
    assert split.estimates[0] < 5.0 < split.estimates[1]


@pytest.mark.parametrize("name, scale, directory", [("ship_kcs.igs", 31.6, 3), ("ship_kvlcc2.igs", 58.0, 253)])
def test_the_flat_bottom_trims_of_kcs_and_kvlcc2_match_their_model_space_boundaries(name, scale, directory):
    """The flat-bottom surfaces are planes z = 0 trimmed by a loop (entity 143 / 141); the
    area inside the loop read from its parameter-space curves equals the area the loop's
    own model-space curves enclose (shoelace in x, y), and is well below the untrimmed
    rectangle's (so an untrimmed plan double counts or invents shell there)."""
    iges = read_iges(SHIP / name)
    entity = next(e for e in iges.of_type(128) if e.directory == directory)
    surface = iges_surface(iges, entity, scale, name)
    trim = read_trim(iges, directory)
    assert trim is not None and not trim.covers_rectangle(surface.domain_u, surface.domain_v)
    full, inside = trimmed_area(surface, trim, 401)
    pts = surface.grid(np.linspace(*surface.domain_u, 9), np.linspace(*surface.domain_v, 9))
    assert np.ptp(pts[..., 2]) < 1e-6 * np.ptp(pts[..., 0])  # a plane z = const
    # the boundary's model-space curves (141: CRVPT, SENSE, K, PSCPT...), each turned by its
    # SENSE (2: reversed), in the boundary's order
    boundary = next(e for e in iges.of_type(141) if e.parameters[3] == str(directory)).parameters
    n, k, loop = int(boundary[4]), 5, []
    for _ in range(n):
        curve = iges_curve(iges, next(e for e in iges.entities if e.directory == int(boundary[k])), scale, "b")
        pts = curve(np.linspace(*curve.domain, 400))[:, :2]
        loop.append(pts[::-1] if boundary[k + 1] == "2" else pts)
        k += 3 + int(boundary[k + 2])
    gaps = [np.linalg.norm(a[-1] - b[0]) for a, b in zip(loop, loop[1:] + loop[:1])]
    assert max(gaps) < 1e-6 * np.ptp(np.vstack(loop))  # a closed loop as the file orders it
    xy = np.vstack(loop)
    shoelace = 0.5 * abs(np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]))
    assert inside == pytest.approx(shoelace, rel=5e-3)
    assert inside < 0.7 * full


@pytest.mark.parametrize("name, directories", [("ship_kcs.igs", (347, 369)), ("ship_kvlcc2.igs", (223,))])
def test_the_main_hull_trims_are_their_whole_parameter_rectangles(name, directories):
    iges = read_iges(SHIP / name)
    for d in directories:
        entity = next(e for e in iges.of_type(128) if e.directory == d)
        surface = iges_surface(iges, entity, 1.0, name)
        trim = read_trim(iges, d)
        assert trim is not None and trim.covers_rectangle(surface.domain_u, surface.domain_v)


def _twisted_cylinder(radius=5000.0, length=20000.0, twist_deg=20.0):
    """A cylinder of axis x, radius R, parametrised so that its iso-v lines are helices:
    P(u, v) = (L u, R cos t, R sin t), t = pi/4 (1 + v) + twist u; bicubic interpolation of
    a 41 x 41 grid (within 0.01 mm of the cylinder)."""
    u = np.linspace(0.0, 1.0, 41)
    v = np.linspace(0.0, 1.0, 41)
    t = np.pi / 4 * (1 + v[None, :]) + np.radians(twist_deg) * u[:, None]
    pts = np.stack([length * np.broadcast_to(u[:, None], t.shape), radius * np.cos(t), radius * np.sin(t)], axis=-1)
    su = make_interp_spline(u, pts, k=3, axis=0)
    sv = make_interp_spline(v, su.c, k=3, axis=1)
    # BSpline keeps the interpolated axis first: sv.c is (v, u, 3)
    return nurbs_surface(3, 3, np.transpose(sv.c, (1, 0, 2)), su.t, sv.t, None, "twisted cylinder")


def test_least_curvature_seams_on_a_cylinder_run_along_its_generators():
    """Twist 3 degrees: each iso seam turns 260 mm round the axis, within the quarter spacing
    a traced seam may depart from its iso line; the traced seams are generators."""
    surface = _twisted_cylinder(twist_deg=3.0)
    s = np.linspace(0.0, 1.0, 41)
    iso = [0.0, 0.33, 0.5, 0.67, 1.0]
    seams = least_curvature_seams(surface, 0, iso, 0.5)
    assert seams[0].is_iso() and seams[-1].is_iso()
    for seam, g0 in zip(seams[1:-1], iso[1:-1]):
        pts = surface(s, seam(s))
        iso_pts = surface(s, np.full_like(s, g0))
        # a generator: y and z constant along the seam (to the 0.01 mm of the fitted surface and
        # the tracer's steps), while the iso line turns round the axis
        assert np.ptp(pts[:, 1]) < 2.0 and np.ptp(pts[:, 2]) < 2.0
        assert np.hypot(np.ptp(iso_pts[:, 1]), np.ptp(iso_pts[:, 2])) > 200.0


def test_least_curvature_seams_stay_ordered_when_the_hull_turns_them_hard():
    """Twist 20 degrees: the generators leave the iso lines by more than the seams may move;
    the seams follow them as far as allowed and never cross or close up."""
    surface = _twisted_cylinder(twist_deg=20.0)
    s = np.linspace(0.0, 1.0, 81)
    iso = [0.0, 0.33, 0.5, 0.67, 1.0]
    g = np.array([seam(s) for seam in least_curvature_seams(surface, 0, iso, 0.5)])
    assert np.all(np.diff(g, axis=0) >= 0.5 * np.diff(iso).min() - 1e-12)
    assert np.ptp(g[1]) > 0.5 * 0.25 * 0.17  # it did turn


def test_a_plan_of_kcs_flat_bottom_covers_its_trimmed_area_not_its_rectangle(tmp_path):
    """The uniform plan of KCS's flat-bottom surface DE3 alone: plates wholly outside the
    trim are not planned, and the plates' regions weighted by their share inside the trim
    add up to the trimmed area (1128 m2, against 2622 m2 for the rectangle)."""
    from flatten.patch import region_grid
    from pipeline.hull.plan import load_run

    data = {"name": "de3", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
            "strake": {"surface": {"iges": str(SHIP / "ship_kcs.igs"), "directory": 3}, "scale": 31.6,
                       "fit_tolerance": 5.0,
                       "plan": {"method": "uniform", "stock": {"max_length": 16000, "max_width": 4000,
                                                               "min_length": 3000, "min_width": 1000}}}}
    path = tmp_path / "de3.yaml"
    path.write_text(yaml.safe_dump(data))
    parts = load_run(path).parts
    iges = read_iges(SHIP / "ship_kcs.igs")
    surface = iges_surface(iges, next(e for e in iges.of_type(128) if e.directory == 3), 31.6, "de3")
    full, inside = trimmed_area(surface, read_trim(iges, 3), 401)
    total = 0.0
    for part in parts:
        h = part.hull
        assert 0.0 < h.inside_trim <= 1.0 and "honoured by area" in h.surface_note
        grid = region_grid(h.surface, h.long_axis, h.girths[0], h.girths[1],
                           [None if p is None else p.as_tuple() for p in h.butts], 41, 161)
        p = grid.points
        a = np.cross(p[1:, :-1] - p[:-1, :-1], p[:-1, 1:] - p[:-1, :-1])
        b = np.cross(p[1:, 1:] - p[1:, :-1], p[1:, 1:] - p[:-1, 1:])
        total += h.inside_trim * 0.5 * (np.linalg.norm(a, axis=2).sum() + np.linalg.norm(b, axis=2).sum())
    assert total == pytest.approx(inside, rel=0.02)
    assert total < 0.5 * full


def test_a_butt_split_keeps_each_half_as_wide_as_the_stock_by_its_own_columns():
    """A flat plate 8 m long widening from 0.8 m to 1.2 m (columns every metre, 50 mm
    wider each): with the yard's strict width (each half at least 1 m wide somewhere) the
    butt at the middle (x = 4 m) leaves the narrow half 1.0 m wide only at the cut itself,
    where the sample's column is not the butt plane's section; the split goes to x = 5 m,
    whose narrow half is 1.0 m wide a column inside it. Without the strict width, the middle."""
    from pipeline.hull.splitting import RegionSample

    x = np.arange(9) * 1000.0
    widths = 800.0 + 50.0 * np.arange(9)
    rows = np.linspace(0.0, 1.0, 5)
    points = np.stack(np.broadcast_arrays(x[None, :], rows[:, None] * widths[None, :], 0.0 * x[None, :]), axis=-1)
    ones = np.ones(points.shape[:2])
    sample = RegionSample(points, rows, 0.0 * ones, ones, 0.0 * ones, np.broadcast_to(x, ones.shape).copy(),
                          rows[:, None] * widths[None, :], ones)
    strict = choose_split(sample, 5.0, 3000.0, 1000.0, strict_width=True, kinds=("length",))
    loose = choose_split(sample, 5.0, 3000.0, 1000.0, strict_width=False, kinds=("length",))
    assert loose.at == pytest.approx(4000.0) and strict.at == pytest.approx(5000.0)


def test_a_girth_split_for_the_sheets_may_taper_where_the_plate_does():
    """A flat plate 8 m long tapering from a point to 2.8 m of girth (0.35 m wider each
    metre): every girth split leaves halves narrower than the 1 m stock near the point, so
    none is allowed by the stock's width over every column. For a plate no sheet holds
    (``tapering``) the halves keep 1 m only where the plate is wide enough for two cut at a
    row (2 m and the rows' spacing, x >= 7 m): the middle row splits it, each half 1.4 m wide
    at the wide end and tapering with the plate. A row off the middle leaves one half 0.92 m
    wide where the plate is 2.45 m wide."""
    from pipeline.hull.splitting import RegionSample

    x = np.arange(9) * 1000.0
    widths = 350.0 * np.arange(9)
    rows = np.linspace(0.0, 1.0, 9)
    points = np.stack(np.broadcast_arrays(x[None, :], rows[:, None] * widths[None, :], 0.0 * x[None, :]), axis=-1)
    ones = np.ones(points.shape[:2])
    sample = RegionSample(points, rows, 0.0 * ones, ones, 0.0 * ones, np.broadcast_to(x, ones.shape).copy(),
                          rows[:, None] * widths[None, :], ones)
    assert choose_split(sample, 5.0, 3000.0, 1000.0, kinds=("girth",)) is None
    split = choose_split(sample, 5.0, 3000.0, 1000.0, kinds=("girth",), tapering=True)
    assert split.kind == "girth" and split.at == pytest.approx(0.5)
    # where the plate is narrower than two widths everywhere, no girth split at all
    narrow = RegionSample(points * [1.0, 0.5, 1.0], rows, 0.0 * ones, ones, 0.0 * ones,
                          np.broadcast_to(x, ones.shape).copy(), 0.5 * rows[:, None] * widths[None, :], ones)
    assert choose_split(narrow, 5.0, 3000.0, 1000.0, kinds=("girth",), tapering=True) is None


def test_a_tapering_girth_split_leaves_no_sliver_where_the_rows_bunch():
    """A plate 1.9 m wide over its first 7 m and 2.8 m at its end, its grid rows bunched
    towards one seam there (girth fraction r^3 of row fraction r). The middle row halves the
    wide end (1.4 m each) but leaves a 0.24 m sliver over the first 7 m, where the plate is
    too narrow for two 1 m halves; a tapering split keeps each half a third of the plate's
    width there, and no row does both: no split. Rows spread evenly, the middle row is taken."""
    from pipeline.hull.splitting import RegionSample

    x = np.arange(9) * 1000.0
    widths = np.where(x < 7000.0, 1900.0, 2800.0)
    rows = np.linspace(0.0, 1.0, 9)
    ones = np.ones((9, 9))

    def sample(fractions):
        across = fractions * widths[None, :]
        points = np.stack(np.broadcast_arrays(x[None, :], across, 0.0 * ones), axis=-1)
        return RegionSample(points, rows, 0.0 * ones, ones, 0.0 * ones, np.broadcast_to(x, ones.shape).copy(),
                            across, ones)

    bunched = np.where(x[None, :] < 7000.0, rows[:, None] ** 3, rows[:, None] * ones)
    assert 1900.0 * 0.5 ** 3 == pytest.approx(237.5)
    assert choose_split(sample(bunched), 5.0, 3000.0, 1000.0, kinds=("girth",), tapering=True) is None
    even = choose_split(sample(rows[:, None] * ones), 5.0, 3000.0, 1000.0, kinds=("girth",), tapering=True)
    assert even.at == pytest.approx(0.5)


def test_the_split_chooser_asks_fewer_plane_fits_for_the_same_split(monkeypatch):
    """On the 160 m hull's surface (real data), 40 regions drawn with a fixed seed: the
    splits chosen with each answer of flatness reused for the halves it settles (a plane
    fitting a half fits every smaller half; none fits a half holding one it does not) are the
    splits of the control that fits a plane to every half, in fewer plane fits."""
    from flatten.plane import Plane
    from pipeline.config import load_config
    from pipeline.hull import splitting
    from pipeline.hull.region import Girth, load_plan_surfaces

    config_path = Path(__file__).parents[1] / "configs" / "hull160_shell.yaml"
    config = load_config(config_path)
    surface = load_plan_surfaces([config.spec.strake.surface], config_path.parent, config.mm_per_unit)[0].surface
    rng = np.random.default_rng(3)
    samples = []
    while len(samples) < 40:
        g0, g1 = sorted(rng.uniform(*surface.domain_v, 2))
        x0 = rng.uniform(-5000.0, 150000.0)
        if g1 - g0 < 0.05 * np.ptp(surface.domain_v):
            continue
        sample = sample_region(surface, 0, (Girth.iso(g0), Girth.iso(g1)),
                               (Plane((1.0, 0.0, 0.0), x0), Plane((1.0, 0.0, 0.0), x0 + rng.uniform(3000.0, 14000.0))))
        if sample is not None:
            samples.append(sample)
    fits = []
    monkeypatch.setattr(splitting, "fits_a_plane", lambda points, tol: fits.append(1) or fits_a_plane(points, tol))

    def splits():
        fits.clear()
        return [choose_split(s, 5.0, 1000.0, 800.0, kinds=kinds) for s in samples
                for kinds in (("length", "girth"), ("girth",))], len(fits)

    reused, reused_fits = splits()

    class EveryHalf(splitting._Flatness):
        def __call__(self, mask):
            return splitting._flat(self.s, mask, self.tol)

    monkeypatch.setattr(splitting, "_Flatness", EveryHalf)
    control, control_fits = splits()
    assert reused == control
    assert sum(s is not None and 0.0 < s.fitting_share < 1.0 for s in control) >= 10  # halves both flat and not
    assert reused_fits < control_fits / 2
