"""Hull models through OpenCascade (IGES, STEP) and rhino3dm (.3dm): the same surfaces as our
IGES reader, STEP and .3dm files written from a hull's surface plan the same plates, and the
sewing report finds DTMB 5415's overlapping bow and main-hull faces."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.cli import main
from pipeline.io.hullmodel import read_hull_model, rhino_surface, ocp_surface
from pipeline.io.iges import iges_surface, read_iges

DATA = Path(__file__).parent / "data" / "ship"
HULLMOD = DATA / "test_1_hull_exported.igs"


def grid_points(surface, n: int = 23) -> np.ndarray:
    return surface.grid(np.linspace(*surface.domain_u, n), np.linspace(*surface.domain_v, n))


@pytest.mark.parametrize("name", ["ship_5415.igs", "ship_kcs.igs", "ship_kvlcc2.igs", "test_1_hull_exported.igs"])
def test_opencascade_and_our_iges_reader_give_the_same_surfaces(name):
    model = read_hull_model(DATA / name)
    iges = read_iges(DATA / name)
    entities = iges.of_type(128)
    assert len(model.faces) == len(entities)
    for face, entity in zip(model.faces, entities):
        ours = iges_surface(iges, entity, iges.unit_mm, "ours")
        a, b = grid_points(face.surface), grid_points(ours)
        size = float(np.ptp(b.reshape(-1, 3), axis=0).max())
        assert np.abs(a - b).max() <= 1e-6 * max(size, 1.0), (name, entity.directory)


def test_kcs_flat_bottom_keeps_its_trim_and_area():
    """KCS's flat bottom (D3) is 2622 m2 untrimmed at ship scale, 1128 m2 inside its trim."""
    model = read_hull_model(DATA / "ship_kcs.igs")
    bottom = model.faces[0]
    assert bottom.trimmed and bottom.outer is not None
    ship_m2 = bottom.area_mm2 * 31.6 ** 2 * 1e-6
    assert ship_m2 == pytest.approx(1128, rel=0.01)
    # the trim loop's area in 3D (the surface is a plane: bilinear, 2 x 2 poles) against OCP's area
    from matplotlib.path import Path as MplPath

    s = bottom.surface
    u = np.linspace(*s.domain_u, 301)
    v = np.linspace(*s.domain_v, 301)
    uu, vv = np.meshgrid(0.5 * (u[1:] + u[:-1]), 0.5 * (v[1:] + v[:-1]), indexing="ij")
    inside = MplPath(bottom.outer).contains_points(np.column_stack([uu.ravel(), vv.ravel()]))
    p = s.grid(u, v)
    cells = np.linalg.norm(np.cross(p[1:, :-1] - p[:-1, :-1], p[:-1, 1:] - p[:-1, :-1]), axis=-1).ravel()
    assert cells[inside].sum() == pytest.approx(bottom.area_mm2, rel=0.01)


def write_step(surface, path: Path) -> None:
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    writer = STEPControl_Writer()
    writer.Transfer(BRepBuilderAPI_MakeFace(ocp_surface(surface), 1e-6).Face(), STEPControl_AsIs)
    assert int(writer.Write(str(path))) == 1  # IFSelect_RetDone


def write_3dm(surface, path: Path, unit: str = "Millimeters") -> None:
    import rhino3dm

    model = rhino3dm.File3dm()
    model.Settings.ModelUnitSystem = getattr(rhino3dm.UnitSystem, unit)
    model.Objects.AddSurface(rhino_surface(surface))
    assert model.Write(str(path), 7)


@pytest.fixture(scope="module")
def hull_files(tmp_path_factory):
    """The 160 m hull's surface (mm) written as STEP and as .3dm (in metres)."""
    folder = tmp_path_factory.mktemp("hullmodel")
    surface = read_hull_model(HULLMOD).faces[0].surface
    write_step(surface, folder / "hull.step")
    metres = type(surface)(surface.degree_u, surface.degree_v, surface.poles / 1000.0, surface.weights,
                           surface.knots_u, surface.knots_v)
    write_3dm(metres, folder / "hull.3dm", "Meters")
    return folder, surface


@pytest.mark.parametrize("name", ["hull.step", "hull.3dm"])
def test_step_and_3dm_round_trips_give_the_surface_back(hull_files, name):
    folder, surface = hull_files
    back = read_hull_model(folder / name).faces[0].surface
    assert np.abs(grid_points(back) - grid_points(surface)).max() <= 1e-6 * 160000


def strake_config(folder: Path, surface_source: dict) -> Path:
    config = {"name": "hm", "units": "mm",
              "strake": {"surface": surface_source, "seams": [{"iso": {"v": 4.0}}, {"iso": {"v": 4.3}}],
                         "butts": [72000, 88000, 104000], "frames": {"spacing": 2500}, "margin": 0.2,
                         "fit_tolerance": 5.0},
              "resolution": {"chord_tolerance": 1.0}, "steel": {"thickness": 14, "material": "AH36"},
              "output": {"png": False}}
    path = folder / f"{abs(hash(json.dumps(surface_source, sort_keys=True)))}.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def plate_figures(out: Path) -> dict:
    reports = {}
    for path in sorted(out.glob("hm_S*.json")):
        report = json.loads(path.read_text())
        reports[path.stem] = (report["status"], report.get("hull_plate", {}).get("class"),
                              report["outline"]["area_m2"], report["rulings"])
    return reports


def test_plans_from_iges_step_and_3dm_agree(hull_files, tmp_path):
    """The same two plates from our IGES reader, OpenCascade's STEP and rhino3dm's .3dm (the
    .3dm in metres): same classes, outline areas to 1e-9 relative, rulings to 1e-7."""
    folder, _ = hull_files
    sources = {"iges": {"iges": str(HULLMOD), "entity": 0}, "step": {"model": str(folder / "hull.step")},
               "3dm": {"model": str(folder / "hull.3dm"), "face": 0}}
    figures = {}
    for kind, source in sources.items():
        out = tmp_path / kind
        assert main(["run", str(strake_config(tmp_path, source)), "--out", str(out), "--quiet"]) == 0
        figures[kind] = plate_figures(out)
    assert len(figures["iges"]) == 2
    for kind in ("step", "3dm"):
        assert figures[kind].keys() == figures["iges"].keys()
        for name, (status, cls, area, rulings) in figures["iges"].items():
            other = figures[kind][name]
            assert other[:2] == (status, cls)
            assert other[2] == pytest.approx(area, rel=1e-9)
            assert np.allclose(np.asarray(other[3]), np.asarray(rulings), atol=1e-7)


def test_inspect_finds_dtmb5415s_overlapping_bow_and_main_hull(capsys):
    """The bow (face 0) and main-hull (face 1) surfaces lie on each other over x 16.2-20.5 m at
    ship scale (DESIGN §8), i.e. 654-824 mm at the file's model scale: sewing alone finds no
    shared edge there; the report finds the overlap and where cutting it leaves the least step."""
    assert main(["hull", "inspect", str(DATA / "ship_5415.igs"), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["schema"] == "hull-model/1" and len(report["faces"]) == 3
    assert [o["faces"] for o in report["overlaps"]] == [[0, 1]]
    overlap = report["overlaps"][0]
    lo, hi = overlap["x_range_mm"]
    assert 640 <= lo <= 670 and 800 <= hi <= 830
    # they are not the same surface twice: 0.2-0.6 mm apart over most of it, up to ~2 mm
    assert overlap["median_distance_mm"] < 1.0 < overlap["max_distance_mm"] < 2.5
    assert lo <= overlap["cut_x_mm"] <= hi and overlap["step_at_cut_mm"] <= overlap["max_distance_mm"]
    # an independent check of the overlap: points of the bow inside that x range lie on the main hull
    from flatten.closest import SurfaceDistance

    model = read_hull_model(DATA / "ship_5415.igs")
    bow, main_hull = model.faces[0].surface, model.faces[1].surface
    pts = grid_points(bow, 41).reshape(-1, 3)
    inside = pts[(pts[:, 0] > lo + 20) & (pts[:, 0] < hi - 20)]
    _, dist = SurfaceDistance(main_hull).closest(inside)
    assert len(inside) > 20 and np.median(dist) < 1.0
    assert report["free_edges"] >= 9 and report["contiguous_edges"] <= 1


def test_a_single_untrimmed_face_is_one_open_sheet(capsys):
    assert main(["hull", "inspect", str(HULLMOD)]) == 0
    out = capsys.readouterr().out
    assert "1 face," in out and "4 free" in out and "overlaps: none" in out and "gaps: none" in out


@pytest.mark.parametrize("args, needle", [
    (["hull", "inspect", "missing.step"], "missing.step: no such file"),
    (["hull", "inspect", "README.md"], "got the suffix '.md'"),
    (["hull", "inspect", str(HULLMOD), "--tolerance", "0"], "--tolerance 0.0: must be > 0"),
])
def test_bad_hull_model_input_exits_2_naming_it(args, needle, capsys):
    assert main(args) == 2
    assert needle in capsys.readouterr().err


def test_a_face_the_model_does_not_have_is_bad_input(hull_files, tmp_path, capsys):
    folder, _ = hull_files
    config = strake_config(tmp_path, {"model": str(folder / "hull.step"), "face": 3})
    assert main(["run", str(config), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    assert "face 3 asked for; the model has 1 faces" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_a_rational_surface_written_to_3dm_is_the_surface_rhino_evaluates():
    """OpenNURBS keeps homogeneous control points: rhino3dm's own evaluation of the written
    surface must be ours (a weight handled as a Euclidean point moves it by ~0.6 here)."""
    import rhino3dm  # noqa: F401

    from flatten.surface import nurbs_surface
    from pipeline.io.hullmodel import surface_from_rhino

    rng = np.random.default_rng(7)
    surface = nurbs_surface(2, 3, rng.normal(size=(4, 5, 3)), [0, 0, 0, 0.4, 1, 1, 1],
                            [0, 0, 0, 0, 0.5, 1, 1, 1, 1], rng.uniform(0.5, 2.0, size=(4, 5)))
    rhino = rhino_surface(surface)
    for u, v in ((0.3, 0.7), (0.05, 0.5), (0.9, 0.2)):
        p = rhino.PointAt(u, v)
        assert np.allclose([p.X, p.Y, p.Z], surface(np.array([u]), np.array([v]))[0], atol=1e-12)
    back = surface_from_rhino(rhino, 1.0, "back")
    assert np.abs(grid_points(back) - grid_points(surface)).max() <= 1e-12


def test_the_run_summary_carries_the_hull_models_sewing_report(hull_files, tmp_path):
    folder, _ = hull_files
    config = strake_config(tmp_path, {"model": str(folder / "hull.step")})
    assert main(["run", str(config), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    summary = json.loads((tmp_path / "out" / "hm_summary.json").read_text())
    (model,) = summary["hull_models"]
    assert model["file"].endswith("hull.step") and len(model["faces"]) == 1
    assert model["faces"][0]["area_m2"] == pytest.approx(3816.4, rel=1e-3)  # OpenCascade's area of the hull side
    assert model["free_edges"] == 4 and model["overlaps"] == []


def cylinder_piece(path: Path, x0: float, x1: float, radius: float = 3000.0) -> Path:
    """The bilge cylinder of axis x (tests/hull_shapes.cylinder_along_iges) over x in [x0, x1]."""
    from tests.hull_shapes import write_iges_surface

    h = np.radians(45.0)
    arc = np.array([[-radius * np.sin(h), radius * (1 - np.cos(h))], [0.0, radius - radius / np.cos(h)],
                    [radius * np.sin(h), radius * (1 - np.cos(h))]])
    w = np.array([1.0, np.cos(h), 1.0])
    poles = np.array([[[x, y, z] for y, z in arc] for x in (x0, x1)])
    return write_iges_surface(path, 1, 2, poles, np.vstack([w, w]), [0, 0, 1, 1], [0, 0, 0, 1, 1, 1])


def two_faces_config(tmp_path: Path) -> Path:
    """One bilge cylinder given as two faces lying on each other over x 8-12 m, planned uniformly."""
    aft, fore = cylinder_piece(tmp_path / "aft.igs", 0.0, 12000.0), cylinder_piece(tmp_path / "fore.igs", 8000.0, 20000.0)
    data = {"name": "two", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
            "steel": {"thickness": 12, "material": "S355"},
            "strake": {"surface": {"iges": str(aft)}, "fit_tolerance": 5.0,
                       "plan": {"method": "uniform", "surfaces": [{"iges": str(fore)}],
                                "stock": {"max_length": 6000, "max_width": 3000, "min_length": 1000,
                                          "min_width": 1000}}}}
    path = tmp_path / "two.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def region_area(part) -> float:
    from flatten.patch import region_grid

    h = part.hull
    grid = region_grid(h.surface, h.long_axis, h.girths[0], h.girths[1],
                       [None if p is None else p.as_tuple() for p in h.butts], 21, 81)
    p = grid.points
    a = np.cross(p[1:, :-1] - p[:-1, :-1], p[:-1, 1:] - p[:-1, :-1])
    b = np.cross(p[1:, 1:] - p[1:, :-1], p[1:, 1:] - p[:-1, 1:])
    return 0.5 * float(np.linalg.norm(a, axis=2).sum() + np.linalg.norm(b, axis=2).sum())


def test_a_plan_of_two_overlapping_faces_covers_the_shell_once(tmp_path):
    """One cylinder given as two faces that lie on each other over x 8-12 m (as DTMB 5415's bow
    and main hull do): the plan cuts them at one transverse plane inside the overlap, so the
    plates add up to the cylinder's area (not the 4 m more of both faces) and the plates of
    the two faces meet at that plane."""
    from pipeline.hull.plan import load_run

    parts = load_run(two_faces_config(tmp_path)).parts
    total = sum(region_area(p) for p in parts)
    shell = 3000.0 * np.pi / 2 * 20000.0
    assert total == pytest.approx(shell, rel=2e-3)
    cuts = {p.hull.butts[1].offset for p in parts if "_P1_" in p.name and p.hull.butts[1] is not None} & \
        {p.hull.butts[0].offset for p in parts if "_P2_" in p.name and p.hull.butts[0] is not None}
    assert len(cuts) == 1 and 8000.0 <= cuts.pop() <= 12000.0
    assert all("overlap" in p.hull.surface_note for p in parts)


def kcs_bottom_config(tmp_path: Path, **output) -> Path:
    """KCS's flat bottom (DE3, trimmed) alone at ship scale, planned uniformly."""
    data = {"name": "de3", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False, **output},
            "steel": {"thickness": 16, "material": "AH36"},
            "strake": {"surface": {"iges": str(DATA / "ship_kcs.igs"), "directory": 3}, "scale": 31.6,
                       "fit_tolerance": 5.0,
                       "plan": {"method": "uniform", "stock": {"max_length": 16000, "max_width": 4000,
                                                               "min_length": 3000, "min_width": 1000}}}}
    path = tmp_path / "de3.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def kcs_bottom_plan(tmp_path):
    from pipeline.hull.plan import load_run

    return load_run(kcs_bottom_config(tmp_path))


def test_kcs_flat_bottom_plates_are_cut_at_its_trim_and_cover_it_once(tmp_path):
    """KCS's flat bottom (a horizontal plane, 2622 m2 untrimmed, 1128 m2 inside its trim, at
    ship scale): the plates' regions cut at the trim, measured in the plane itself (x, y), add
    up to the trimmed area (our own trim reader's, on a 401 x 401 grid); the plates that reach
    past the trim are cut, the others are whole."""
    from flatten.patch import region_grid
    from flatten.metrics import polygon_area
    from pipeline.hull.trimcut import cut_at_trim
    from pipeline.hull.trims import read_trim, trimmed_area

    config = kcs_bottom_plan(tmp_path)
    iges = read_iges(DATA / "ship_kcs.igs")
    surface = iges_surface(iges, next(e for e in iges.of_type(128) if e.directory == 3), 31.6, "de3")
    full, inside = trimmed_area(surface, read_trim(iges, 3), 401)
    total, cut_plates = 0.0, 0
    for part in config.parts:
        h = part.hull
        grid = region_grid(h.surface, h.long_axis, h.girths[0], h.girths[1],
                           [None if p is None else p.as_tuple() for p in h.butts], 41, 161)
        assert np.ptp(grid.points[..., 2]) < 1e-6  # the plane is horizontal: (x, y) is its development
        xy = grid.points[..., :2].reshape(-1, 2)
        cut = None if h.trim is None else cut_at_trim(h.trim, grid.params, xy, grid.faces())
        if cut is None:
            ring = np.vstack([grid.points[0, :, :2], grid.points[1:, -1, :2], grid.points[-1, -2::-1, :2],
                              grid.points[-2:0:-1, 0, :2]])
            total += polygon_area(ring)
        else:
            cut_plates += 1
            total += polygon_area(cut.outline)
    assert cut_plates >= 10
    assert total == pytest.approx(inside, rel=3e-3) and total < 0.5 * full


def test_a_plate_cut_at_the_trim_reports_and_cuts_the_part_inside(tmp_path):
    """One KCS bottom plate that reaches past the trim: its area, steel weight and DXF cut
    outline are the part inside the trim, not its rectangle."""
    import ezdxf

    from pipeline.export import export_part
    from pipeline.hull.plates import run_part

    config = kcs_bottom_plan(tmp_path)
    part = next(p for p in config.parts if p.hull.trim is not None and 0.2 < p.hull.inside_trim < 0.8)
    result = run_part(part, config)
    assert result.ok and result.figures["plate_class"]["class"] == "flat"
    cut = result.figures["trim_cut"]
    assert cut["area_m2"] == pytest.approx(result.figures["area_m2"]) == pytest.approx(result.figures["steel"]["area_m2"])
    assert cut["area_m2"] < 0.9 * cut["region_area_m2"]
    assert cut["share"] == pytest.approx(part.hull.inside_trim, abs=0.05)  # the planner's 17 x 49 estimate
    export_part(result, config, tmp_path)
    doc = ezdxf.readfile(tmp_path / f"{part.name}.dxf")
    (outline,) = [e for e in doc.modelspace().query("LWPOLYLINE") if e.dxf.layer == "CUT_OUTER"]
    from flatten.metrics import polygon_area

    assert polygon_area(np.array(outline.get_points("xy"))) / 1e6 == pytest.approx(cut["area_m2"], rel=1e-6)


def test_the_coverage_of_two_overlapping_faces_is_measured_against_the_sides_they_keep(tmp_path):
    """The two-face cylinder planned and run: the fit-up report measures each face against the
    side of the cut it keeps, so the shell is covered once (no overlap, nothing missing)."""
    assert main(["run", str(two_faces_config(tmp_path)), "--out", str(tmp_path / "out"), "--quiet", "--jobs", "2"]) == 0
    coverage = json.loads((tmp_path / "out" / "two_summary.json").read_text())["shell"]["coverage"]
    assert coverage["covered"] == pytest.approx(1.0, abs=1e-3)
    assert coverage["overlap"] == pytest.approx(0.0, abs=1e-6)
    assert coverage["shell_m2"] == pytest.approx(3.0 * np.pi / 2 * 20.0, rel=2e-3)


def test_cut_plates_leave_no_steel_outside_the_trim_in_the_fitup_report(tmp_path):
    """KCS's flat bottom alone, planned and run: plates cut at the trim cover it once and no
    plate area lies outside it (the report measures the delivered plates)."""
    path = kcs_bottom_config(tmp_path, dxf=False)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet", "--jobs", "2"]) == 0
    summary = json.loads((tmp_path / "out" / "de3_summary.json").read_text())
    coverage = summary["shell"]["coverage"]
    assert coverage["covered"] == pytest.approx(1.0, abs=2e-3)
    assert coverage["overlap"] == pytest.approx(0.0, abs=1e-6)
    assert coverage["outside_m2"] < 1e-3 * coverage["shell_m2"]
    steel = sum(p["area_m2"] for p in summary["parts"])
    assert steel == pytest.approx(1128.0, rel=5e-3)


def test_junctions_tell_a_knuckle_from_a_smooth_join():
    """A bilge quarter-cylinder of radius 3 m (axis x) meets, tangentially, a flat bottom, and
    the bottom meets a transverse end plate at 90 degrees: one smooth junction (0 deg), one
    knuckle (90 deg).
    KCS's two main-hull faces (DE347 | DE369 at x = 3457 mm) join smoothly; its transom face
    meets its stern face at a knuckle."""
    from flatten.surface import nurbs_surface
    from flatten.closest import SurfaceDistance
    from pipeline.hull.sewing import junctions_of
    from pipeline.io.hullmodel import HullFace, HullModel

    r, length = 3000.0, 10000.0
    w = np.array([1.0, np.sqrt(0.5), 1.0])
    arc = np.array([[0.0, -r], [r, -r], [r, 0.0]])  # (y, z): from the bottom (z = -r) up the side
    bilge = nurbs_surface(1, 2, [[[x, y, z] for y, z in arc] for x in (0.0, length)], [0, 0, 1, 1],
                          [0, 0, 0, 1, 1, 1], np.vstack([w, w]))
    bottom = nurbs_surface(1, 1, [[[0.0, -4000.0, -r], [0.0, 0.0, -r]], [[length, -4000.0, -r], [length, 0.0, -r]]],
                           [0, 0, 1, 1], [0, 0, 1, 1])
    end = nurbs_surface(1, 1, [[[length, -4000.0, -r], [length, -4000.0, 0.0]], [[length, 0.0, -r], [length, 0.0, 0.0]]],
                        [0, 0, 1, 1], [0, 0, 1, 1])
    faces = tuple(HullFace(k, s, None, (), float("nan")) for k, s in enumerate((bilge, bottom, end)))
    model = HullModel(Path("box"), "test", faces)
    found = {tuple(j["faces"]): j for j in junctions_of(model, [SurfaceDistance(f.surface) for f in faces], 1.0)}
    assert found[(0, 1)]["max_angle_deg"] < 0.01 and found[(0, 1)]["kind"].startswith("smooth")
    assert found[(0, 1)]["length_mm"] == pytest.approx(length, rel=0.03)
    assert found[(1, 2)]["p95_angle_deg"] == pytest.approx(90.0, abs=0.01) and found[(1, 2)]["kind"].startswith("knuckle")

    from pipeline.hull.sewing import sew_report

    kcs = {tuple(j["faces"]): j for j in sew_report(read_hull_model(DATA / "ship_kcs.igs"), 1.0).junctions}
    assert kcs[(16, 17)]["kind"].startswith("smooth") and kcs[(16, 17)]["p95_angle_deg"] < 0.5
    assert kcs[(14, 15)]["kind"].startswith("knuckle") and kcs[(14, 15)]["p95_angle_deg"] > 60


def test_plates_of_two_faces_meet_at_the_cut_and_are_paired_there(tmp_path):
    """The two-face cylinder: the plates on either side of the cut plane are neighbours in the
    fit-up report (pairs across the two faces), and they meet there (the faces are one
    cylinder: steps at round-off of the plates' own fit)."""
    assert main(["run", str(two_faces_config(tmp_path)), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    shell = json.loads((tmp_path / "out" / "two_summary.json").read_text())["shell"]
    across = [p for p in shell["pairs"] if ("_P1_" in p["plates"][0]) != ("_P1_" in p["plates"][1])]
    assert len(across) >= 2  # every strake meets its continuation on the other face
    assert all(p["kind"] == "butt" and p["step_max_mm"] < 1.0 for p in across), across


def test_a_transom_given_twice_is_reported_and_a_run_sews_only_its_own_faces(tmp_path, capsys):
    """A STEP file of the 160 m hull's side and a transom square given twice in the plane
    x = -5 m (as a modeller's export may hold a face twice): the plane that would cut the
    two transoms apart holds them both, and the overlap's cut search raised ("internal
    error", exit 1), in ``hull inspect`` and in every run that read any face of the file
    (its summary sewed the whole file). Now the inspection reports the two as lying on each
    other in that plane, and a run of the hull's side sews only the faces it uses."""
    from flatten.surface import nurbs_surface
    from tests.hull_shapes import write_step_faces

    side = read_hull_model(HULLMOD).faces[0].surface
    square = nurbs_surface(1, 1, [[[-5000.0, 0.0, 0.0], [-5000.0, 0.0, 3000.0]],
                                  [[-5000.0, 4000.0, 0.0], [-5000.0, 4000.0, 3000.0]]], [0, 0, 1, 1], [0, 0, 1, 1])
    whole = (*side.domain_u, *side.domain_v)
    model = write_step_faces(tmp_path / "twice.step", [(side, whole), (square, (0, 1, 0, 1)), (square, (0, 1, 0, 1))])
    assert main(["hull", "inspect", str(model)]) == 0
    printed = capsys.readouterr().out
    assert "overlap: faces 1 and 2 lie on each other in the plane x = -5000.0 mm over 12 m2" in printed
    assert "a plan should use one of them" in printed
    assert "face 1: 12 m2, 2x2 poles degree 1x1, x -5000.0..-5000.0, y 0.0..4000.0, z 0.0..3000.0" in printed

    config = strake_config(tmp_path, {"model": str(model), "face": 0})
    assert main(["run", str(config), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    (report,) = json.loads((tmp_path / "out" / "hm_summary.json").read_text())["hull_models"]
    assert [f["index"] for f in report["faces"]] == [0] and report["file_faces"] == 3
    assert report["overlaps"] == [] and report["free_edges"] == 4
    assert report["faces"][0]["area_m2"] == pytest.approx(3816.4, rel=1e-3)


def test_a_sewing_report_that_fails_is_reported_and_the_plates_are_written(hull_files, tmp_path, monkeypatch):
    """The summary's sewing report is a finding about the model, not a stage the plates
    depend on: when it raises, the run writes its plates and says why the report is missing."""
    from pipeline.hull import sewing

    def broken(*args, **kwargs):
        raise ValueError("a plane misses the surface")

    monkeypatch.setattr(sewing, "sew_report", broken)
    folder, _ = hull_files
    config = strake_config(tmp_path, {"model": str(folder / "hull.step")})
    assert main(["run", str(config), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    summary = json.loads((tmp_path / "out" / "hm_summary.json").read_text())
    (report,) = summary["hull_models"]
    assert report["error"] == "the sewing report failed: ValueError: a plane misses the surface"
    assert report["faces_used"] == [0] and len(summary["parts"]) == 2
    assert len(list((tmp_path / "out").glob("hm_S1_B*.json"))) == 2


def _plane_face(k: int, origin, along, up):
    from flatten.surface import nurbs_surface
    from pipeline.io.hullmodel import HullFace

    o, a, b = (np.asarray(x, dtype=float) for x in (origin, along, up))
    surface = nurbs_surface(1, 1, [[o, o + b], [o + a, o + a + b]], [0, 0, 1, 1], [0, 0, 1, 1], name=f"face {k}")
    return HullFace(k, surface, None, (), float("nan"))


@pytest.mark.parametrize("angle_deg", [10.0, 20.0, 40.0])
def test_the_two_sides_of_a_sharp_end_meet_and_do_not_overlap(angle_deg):
    """Two plane faces 3 m x 2 m meeting along a stem line at a fine angle (a Wigley hull's
    bows meet at 22 deg): the points of one within reach (50 mm: 10 tolerances of 5 mm) of
    the other form a band reach / sin(angle) wide along the stem, 288 mm at 10 deg, wider
    than a sliver, and the overlap search took it for two faces lying on each other: a plan
    cut both at a transverse plane and dropped the stem's strip from each. Their tangent
    planes part by the angle: they meet. A face lying 0.5 mm off the first, turned by 1 deg,
    still overlaps it."""
    from pipeline.hull.sewing import overlaps_of
    from pipeline.io.hullmodel import HullModel

    t = np.radians(angle_deg)
    side = _plane_face(0, (0, 0, 0), (3000, 0, 0), (0, 0, 2000))
    other = _plane_face(1, (0, 0, 0), (3000 * np.cos(t), 3000 * np.sin(t), 0), (0, 0, 2000))
    assert overlaps_of(HullModel(Path("sharp"), "test", (side, other)), 5.0) == []
    t = np.radians(1.0)
    lying = _plane_face(1, (1000, 0.5, 0), (2000 * np.cos(t), 2000 * np.sin(t), 0), (0, 0, 2000))
    (found,) = overlaps_of(HullModel(Path("lying"), "test", (side, lying)), 5.0)
    assert found.faces == (0, 1) and found.area_m2 == pytest.approx(2.0 * 2.0, rel=0.1)
