"""Several faces of a hull model expanded as one shell (pipeline/hull/shell.py): a cylinder split
into two trimmed faces gives the plates of the unsplit cylinder across the split; the loft lies on
the faces; a knuckle between faces is refused naming the faces; real hull faces loft within
their stated deviation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from flatten.surface import nurbs_surface
from pipeline.cli import main
from pipeline.hull.shell import chain_pieces, loft, resample
from pipeline.io.hullmodel import ocp_surface, read_hull_model
from tests.hull_shapes import write_step_faces

DATA = Path(__file__).parent / "data" / "ship"
RADIUS, LENGTH = 3000.0, 20000.0


def bilge_cylinder(x0: float = 0.0, x1: float = LENGTH, radius: float = RADIUS):
    """A quarter cylinder of axis x, radius ``radius`` (mm), u along x, v around (rational quadratic)."""
    h = np.radians(45.0)
    arc = np.array([[-radius * np.sin(h), radius * (1 - np.cos(h))], [0.0, radius - radius / np.cos(h)],
                    [radius * np.sin(h), radius * (1 - np.cos(h))]])
    w = np.array([1.0, np.cos(h), 1.0])
    poles = np.array([[[x, y, z] for y, z in arc] for x in (x0, x1)])
    return nurbs_surface(1, 2, poles, [0, 0, 1, 1], [0, 0, 0, 1, 1, 1], np.vstack([w, w]), name="cylinder")


def write_faces_step(path: Path, surface, boxes) -> Path:
    """One STEP file of faces on ``surface``, each bounded by a (u0, u1, v0, v1) box of its
    parameters: a trimmed face of the one underlying surface."""
    return write_step_faces(path, [(surface, box) for box in boxes])


def cylinder_config(folder: Path, source: dict, name: str) -> Path:
    data = {"name": name, "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
            "steel": {"thickness": 12, "material": "S355"},
            "strake": {"surface": source, "fit_tolerance": 5.0,
                       "plan": {"method": "uniform", "stock": {"max_length": 6000, "max_width": 3000,
                                                               "min_length": 1000, "min_width": 1000}}}}
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def plates_of(out: Path, name: str) -> list[tuple]:
    """(region area m2, class, developed area m2) of every plate from the run's summary, sorted."""
    rows = json.loads((out / f"{name}_summary.json").read_text())["parts"]
    return sorted((round(r["region_area_m2"], 3), r["class"], r["area_m2"]) for r in rows)


@pytest.fixture(scope="module")
def cylinder_runs(tmp_path_factory):
    """The unsplit cylinder and the cylinder split into two trimmed faces (along its girth at
    v = 0.4, and at the station u = 0.45), each planned and run."""
    folder = tmp_path_factory.mktemp("shell")
    surface = bilge_cylinder()
    write_faces_step(folder / "whole.step", surface, [(0, 1, 0, 1)])
    write_faces_step(folder / "girth.step", surface, [(0, 1, 0, 0.4), (0, 1, 0.4, 1)])
    write_faces_step(folder / "station.step", surface, [(0, 0.45, 0, 1), (0.45, 1, 0, 1)])
    runs = {}
    for name, source in {"whole": {"model": str(folder / "whole.step")},
                         "girth": {"model": str(folder / "girth.step"), "faces": [0, 1]},
                         "station": {"model": str(folder / "station.step"), "faces": [1, 0]}}.items():
        out = folder / f"out_{name}"
        assert main(["run", str(cylinder_config(folder, source, name)), "--out", str(out), "--quiet"]) == 0
        runs[name] = plates_of(out, name)
    return runs


def test_the_split_faces_are_trimmed_faces_of_one_cylinder(tmp_path):
    model = read_hull_model(write_faces_step(tmp_path / "g.step", bilge_cylinder(), [(0, 1, 0, 0.4), (0, 1, 0.4, 1)]))
    assert len(model.faces) == 2 and all(f.trimmed for f in model.faces)


@pytest.mark.parametrize("split", ["girth", "station"])
def test_a_cylinder_split_into_two_trimmed_faces_gives_the_unsplit_cylinders_plates(cylinder_runs, split):
    """Same plates, butts at the same x, same classes and developed areas within 0.1 %: the
    plan crosses the split, which neither a seam nor a butt follows (girth split at 40 % of the
    girth, between the uniform plan's seams at 0, 50 and 100 %; station split at x = 9 m, not
    on a butt at 5, 10, 15 m)."""
    whole, split_plates = cylinder_runs["whole"], cylinder_runs[split]
    assert len(whole) == 8 and len(split_plates) == len(whole)
    for (region_a, cls_a, area_a), (region_b, cls_b, area_b) in zip(whole, split_plates):
        assert cls_b == cls_a
        assert region_b == pytest.approx(region_a, rel=1e-3)
        assert area_b == pytest.approx(area_a, rel=1e-3)
    expected = RADIUS * np.pi / 2 * LENGTH / 1e6
    assert sum(r[2] for r in split_plates) == pytest.approx(expected, rel=2e-3)


def test_the_loft_lies_on_the_cylinder_and_its_u_is_x(tmp_path):
    """The two faces lofted: every point of a fine grid of the lofted surface lies on the
    cylinder (radius 3000 mm about the axis y = 0, z = 3000) within 0.1 mm (the sections are
    polylines ~30 mm apart along the girth: their chords miss the arc by 0.04 mm), and S(u, v).x = u."""
    from pipeline.hull.region import load_surface_trimmed

    path = write_faces_step(tmp_path / "g.step", bilge_cylinder(), [(0, 1, 0, 0.4), (0, 1, 0.4, 1)])
    spec = type("Spec", (), {"model": str(path), "faces": [0, 1]})()
    surface, trim, note = load_surface_trimmed(spec, tmp_path, 1.0)
    assert trim is None and "lofted as one shell" in note and "meet smoothly" in note
    u = np.linspace(*surface.domain_u, 41)
    points = surface.grid(u, np.linspace(0, 1, 57))
    radius = np.hypot(points[..., 1], points[..., 2] - RADIUS)
    assert np.abs(radius - RADIUS).max() <= 0.1
    assert np.abs(points[..., 0] - u[:, None]).max() <= 1e-6 * LENGTH


def test_faces_meeting_at_a_knuckle_are_refused_naming_them(tmp_path, capsys):
    """A flat face meeting the cylinder's edge at 45 degrees: a knuckle, which a plate cannot
    cross; the run stops (exit 2) naming both faces and the angle."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from OCP.TopoDS import TopoDS_Compound

    cylinder = bilge_cylinder()
    edge = cylinder.grid([0.0, 1.0], [1.0])[:, 0]  # the cylinder's upper edge, (2, 3)
    up = np.array([0.0, 0.0, 1.0])  # 45 degrees off the cylinder's tangent there, (0, 1, 1) / sqrt(2)
    poles = np.array([[edge[0], edge[0] + 1000 * up], [edge[1], edge[1] + 1000 * up]])
    flat = nurbs_surface(1, 1, poles, [0, 0, 1, 1], [0, 0, 1, 1], name="flat")
    builder, compound = BRep_Builder(), TopoDS_Compound()
    builder.MakeCompound(compound)
    for s in (cylinder, flat):
        builder.Add(compound, BRepBuilderAPI_MakeFace(ocp_surface(s), 1e-6).Face())
    writer = STEPControl_Writer()
    writer.Transfer(compound, STEPControl_AsIs)
    writer.Write(str(tmp_path / "k.step"))
    config = cylinder_config(tmp_path, {"model": str(tmp_path / "k.step"), "faces": [0, 1]}, "k")
    assert main(["run", str(config), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "knuckle" in err and "faces 0 and 1" in err and "k.step" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("bad, needle", [({"faces": [0]}, "faces"), ({"faces": [0, 0]}, "distinct"),
                                         ({"faces": [0, 7]}, "faces [7] asked for"),
                                         ({"faces": [0, 1], "face": 1}, "not both")])
def test_bad_shell_face_lists_exit_2_naming_them(tmp_path, capsys, bad, needle):
    path = write_faces_step(tmp_path / "g.step", bilge_cylinder(), [(0, 1, 0, 0.4), (0, 1, 0.4, 1)])
    config = cylinder_config(tmp_path, {"model": str(path), **bad}, "bad")
    assert main(["run", str(config), "--out", str(tmp_path / "out")]) == 2
    assert needle in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_chain_joins_pieces_in_girth_order_and_refuses_a_gap():
    """Three pieces of a section given out of order and reversed chain into one polyline from
    the centreline up; a gap wider than the join distance breaks the chain."""
    a = np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0.0]])
    b = np.array([[0, 2, 0], [0, 3, 1], [0, 3, 2.0]])
    c = np.array([[0, 3, 2], [0, 3, 3.0]])
    chain, starts, gap = chain_pieces([(2, c[::-1]), (0, a), (1, b[::-1])])
    assert np.allclose(chain[0], [0, 0, 0]) and np.allclose(chain[-1], [0, 3, 3])
    assert [f for _, f in starts] == [0, 1, 2] and gap == 0.0
    assert chain_pieces([(0, a), (1, b + [0, 0, 10.0])]) is None
    # a gap within the join distance is bridged and reported: 1.5 across, or none where one
    # face's end lies on the other (faces overlapping by 0.5 along the section)
    assert chain_pieces([(0, a), (1, b + [0, 0, 1.5])])[2] == pytest.approx(1.5)
    assert chain_pieces([(0, a), (1, np.vstack([[0, 1.5, 0], b]))])[2] == pytest.approx(0.0, abs=1e-12)
    # a flat of bottom ending in a 0.6 mm sliver beside the side face's lowest point (KVLCC2 at
    # its stern): both sliver ends lie near the side's end; the chain still starts at the centreline
    side = np.array([[0, 305.8, 448.3], [0, 100, 50], [0, 0.5, 0.0]])
    sliver = np.array([[0, 0.0, 0], [0, 0.6, 0.0]])
    chain, starts, _ = chain_pieces([(0, side), (1, sliver)])
    assert np.allclose(chain[0], [0, 0, 0]) and np.allclose(chain[-1], [0, 305.8, 448.3])
    assert [f for _, f in starts] == [1, 0]


def test_loft_reproduces_a_bicubic_surface_and_keeps_a_junction_knot():
    """Points of a flat strip meeting a circular arc (curvature 0 then 1/R: a flat of bottom
    meeting the bilge) lofted with a break at the junction fit within 1e-3 of R; without the
    break the same poles miss by more (the change of curvature smoothed over)."""
    r, flat = 100.0, 150.0
    quarter = np.pi / 2 * r
    total = flat + quarter
    s = np.linspace(0, 1, 121) * total
    y = np.where(s <= flat, s, flat + r * np.sin((s - flat) / r))
    z = np.where(s <= flat, 0.0, r * (1 - np.cos((s - flat) / r)))
    stations = np.linspace(0, 1000, 30)
    chain = np.column_stack([np.zeros_like(s), y, z])
    at = np.array([flat / total])
    v = np.union1d(np.linspace(0, 1, 121), at)
    grid = np.stack([resample(chain + [x, 0, 0], v, at, at) for x in stations])
    _, with_break = loft(stations, v, grid, 1e-9, "b", at)
    grid_plain = np.stack([resample(chain + [x, 0, 0], v) for x in stations])
    _, plain = loft(stations, v, grid_plain, 1e-9, "p")
    assert with_break.max() <= 1e-3 * r
    assert plain.max() > 3 * with_break.max()


def test_kvlcc2_flat_bottom_and_side_loft_into_one_shell():
    """KVLCC2's main-hull face and its trimmed flat of bottom (faces 10 and 11, meeting smoothly
    along 5.1 m of the model) loft at ship scale (1:58) into one surface over x 15-300 m (the
    faces' 14-312 m, less the ends where they leave gaps of up to 5.5 mm in the model): on a
    61 x 61 grid of it, the distance to the faces is at most 2.5 mm, p95 at most 0.25 mm (2.1 and
    0.17 measured; 3.4 and 0.60 when the stations' sections were the contour's chords), and the
    note reports the loft's own misfit."""
    from flatten.closest import SurfaceDistance
    from pipeline.hull.region import load_surface_trimmed

    scale = 58.0
    spec = type("Spec", (), {"model": str(DATA / "ship_kvlcc2.igs"), "faces": [10, 11]})()
    surface, _, note = load_surface_trimmed(spec, DATA, 1.0, scale)
    assert "faces 10+11 lofted" in note and "faces 10 and 11 meet smoothly" in note
    assert surface.domain_u[0] < 16000 and surface.domain_u[1] > 295000
    grid = surface.grid(np.linspace(*surface.domain_u, 61), np.linspace(0, 1, 61)) / scale
    model = read_hull_model(DATA / "ship_kvlcc2.igs")
    faces = SurfaceDistance([model.faces[10].surface, model.faces[11].surface])
    distance = faces(grid.reshape(-1, 3)) * scale
    assert distance.max() <= 2.5 and np.percentile(distance, 95) <= 0.25


def area_inside_trim(part, rows: int = 41, columns: int = 161) -> float:
    """Area (mm2) of a plate's planned region inside its face's trim: cells of a fine grid of
    the region counted where their centre lies inside."""
    from flatten.patch import region_grid

    h = part.hull
    grid = region_grid(h.surface, h.long_axis, h.girths[0], h.girths[1],
                       [None if p is None else p.as_tuple() for p in h.butts], rows, columns)
    p, uv = grid.points, grid.params
    a = 0.5 * np.linalg.norm(np.cross(p[1:, :-1] - p[:-1, :-1], p[:-1, 1:] - p[:-1, :-1]), axis=2)
    b = 0.5 * np.linalg.norm(np.cross(p[1:, 1:] - p[1:, :-1], p[1:, 1:] - p[:-1, 1:]), axis=2)
    if h.trim is None:
        return float(a.sum() + b.sum())
    centre = 0.25 * (uv[1:, 1:] + uv[:-1, 1:] + uv[1:, :-1] + uv[:-1, :-1])
    return float(((a + b) * h.trim.inside(centre[..., 0], centre[..., 1])).sum())


def test_faces_beyond_the_loft_are_planned_on_their_own_and_the_shell_is_covered_once(tmp_path):
    """A cylinder as two trimmed faces: below v = 0.4 over its whole 20 m, above it over
    x 0-14 m only. Most stations cross both faces, so the loft runs over x 0-14
    m; beyond it the lower face is planned on its own (its plates end at the loft's end plane).
    Every plate region added up is the two faces' area (no overlap, no gap), and the lower
    face's plates all lie beyond x = 14 m."""
    from pipeline.hull.plan import load_run

    surface = bilge_cylinder()
    path = write_faces_step(tmp_path / "part.step", surface, [(0, 1, 0, 0.4), (0, 0.7, 0.4, 1)])
    parts = load_run(cylinder_config(tmp_path, {"model": str(path), "faces": [0, 1]}, "part")).parts
    shell = sum(f.area_mm2 for f in read_hull_model(path).faces)  # OpenCascade's, inside the trims
    # a plate partly outside its face's trim is cut at it when delivered: its part inside counts
    assert sum(area_inside_trim(p) for p in parts) == pytest.approx(shell, rel=2e-3)
    beyond = [p for p in parts if "beyond the shell's loft" in p.hull.surface_note]
    assert beyond and all(p.hull.butts[0] is not None and abs(p.hull.butts[0].offset - 14000.0) < 100.0
                          for p in beyond if p.hull.butts[0] is not None and p.hull.butts[0].offset < 14500.0)
    lofted = [p for p in parts if "lofted as one shell" in p.hull.surface_note]
    assert lofted and len(lofted) + len(beyond) == len(parts)
    # the loft's plates end at x = 14 m on a butt plane (not the hull's end), so fit-up pairs
    # them with the lower face's plates there: the same cylinder on both sides, no step
    assert any(p.hull.butts[1] is not None and abs(p.hull.butts[1].offset - 14000.0) < 100.0 for p in lofted)
    out = tmp_path / "out"
    assert main(["run", str(cylinder_config(tmp_path, {"model": str(path), "faces": [0, 1]}, "part")), "--out",
                 str(out), "--quiet"]) == 0
    shell = json.loads((out / "part_summary.json").read_text())["shell"]
    across = [p for p in shell["pairs"] if p["kind"] == "butt"
              and sum("_P1_" in name for name in p["plates"]) == 1]
    assert across and max(p["step_max_mm"] for p in across) < 1.0
    assert shell["coverage"]["covered"] == pytest.approx(1.0, abs=2e-3)
    assert shell["coverage"]["overlap"] <= 1e-3


# ------------------------------------------------ the loft's end planes (issue 26: KVLCC2's 178 mm step)
FLAT_Y, PLANE_Y, BILGE_R = 2000.0, 5000.0, 3000.0


def flat_and_bilge(lift: float = 0.0, length: float = 20000.0, lift_from: float = 0.7, factor: float = 1.0):
    """A flat of bottom (the plane z = 0, x 0..length, y 0..PLANE_Y, u along x, v across) and a
    bilge meeting it tangentially at y = FLAT_Y (a quarter circle of radius BILGE_R centred at
    y = FLAT_Y, z = BILGE_R, up to y = FLAT_Y + BILGE_R), both times ``factor`` (a model at
    1 : 1/factor). With ``lift`` the bilge rises off the flat by up to ``lift`` (z, times factor)
    from u = ``lift_from`` to its end, linearly: the faces part there."""
    corners = np.array([[[0, 0, 0], [0, PLANE_Y, 0]], [[length, 0, 0], [length, PLANE_Y, 0]]])
    flat = nurbs_surface(1, 1, factor * corners, [0, 0, 1, 1], [0, 0, 1, 1], name="flat")
    arc = np.array([[FLAT_Y, 0.0], [FLAT_Y + BILGE_R, 0.0], [FLAT_Y + BILGE_R, BILGE_R]])
    xs, dz = [0.0, lift_from * length, length], [0.0, 0.0, lift]
    poles = factor * np.array([[[x, y, z + d] for y, z in arc] for x, d in zip(xs, dz)])
    w = np.tile([1.0, np.sqrt(0.5), 1.0], (3, 1))
    bilge = nurbs_surface(1, 2, poles, [0, 0, lift_from, 1, 1], [0, 0, 0, 1, 1, 1], w, name="bilge")
    return flat, bilge


def test_sub_surface_is_the_surface_over_its_box():
    """The exact piece of a rational surface over a box of its parameters: the same points
    (to round-off) at 500 random parameters inside the box, and the box as its domain."""
    from pipeline.hull.trims import sub_surface

    _, bilge = flat_and_bilge(lift=300.0)
    part = sub_surface(bilge, (0.13, 0.91), (0.2, 0.65))
    assert part.domain_u == pytest.approx((0.13, 0.91)) and part.domain_v == pytest.approx((0.2, 0.65))
    rng = np.random.default_rng(7)
    u, v = rng.uniform(0.13, 0.91, 500), rng.uniform(0.2, 0.65, 500)
    assert np.abs(part(u, v) - bilge(u, v)).max() <= 1e-9 * 20000


def end_plane_config(folder: Path, model: Path, name: str, scale: float = 1.0) -> Path:
    data = {"name": name, "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
            "steel": {"thickness": 20, "material": "S355"},
            "strake": {"surface": {"model": str(model), "faces": [0, 1]}, "scale": scale, "fit_tolerance": 5.0,
                       "plan": {"method": "uniform", "stock": {"max_length": 6000, "max_width": 3000,
                                                               "min_length": 1000, "min_width": 1000}}}}
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def flat_beyond_loft(tmp_path_factory):
    """The flat of bottom trimmed to y <= FLAT_Y over x 0..20 m, the bilge over x 0..14 m only:
    the loft runs over x 0..14 m and the flat is planned on its own beyond it (KVLCC2's stern,
    where the flat of bottom keeps 33 mm of its face's 26.6 m girth). Planned and run."""
    folder = tmp_path_factory.mktemp("endplane")
    flat, bilge = flat_and_bilge()
    model = write_step_faces(folder / "fb.step", [(flat, (0, 1, 0, FLAT_Y / PLANE_Y)), (bilge, (0, 0.7, 0, 1))])
    config = end_plane_config(folder, model, "fb")
    out = folder / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    from pipeline.hull.plan import load_run

    fits = {f.stem: json.loads(f.read_text())["hull_fit"]["max_distance"] for f in out.glob("fb_P*.json")}
    return load_run(config).parts, json.loads((out / "fb_summary.json").read_text())["shell"], fits


def test_a_trimmed_face_beyond_the_loft_is_planned_inside_its_trim(flat_beyond_loft):
    """The flat's plates beyond the loft cover its trimmed part (y <= 2000 mm, x 14..20 m), not
    the untrimmed plane around it (y up to 5000 mm, where the bilge is): every point of their
    regions lies within 1 mm of the trim, and they add up to its 6 m x 2 m."""
    parts, _, _ = flat_beyond_loft
    beyond = [p for p in parts if "beyond the shell's loft" in p.hull.surface_note]
    assert beyond and all("trimmed region's parameter box" in p.hull.surface_note for p in beyond)
    from flatten.patch import region_grid

    area = 0.0
    for p in beyond:
        h = p.hull
        grid = region_grid(h.surface, h.long_axis, h.girths[0], h.girths[1],
                           [None if b is None else b.as_tuple() for b in h.butts], 21, 41)
        assert grid.points[..., 1].max() <= FLAT_Y + 1.0 and grid.points[..., 0].min() >= 14000.0 - 100.0
        area += area_inside_trim(p)
    loft_end = max(b.offset for p in parts if "lofted as one shell" in p.hull.surface_note for b in p.hull.butts
                   if b is not None)
    assert area == pytest.approx((20000.0 - loft_end) * FLAT_Y, rel=2e-3)


def test_plates_on_both_sides_of_the_loft_end_plane_meet(flat_beyond_loft):
    """Across the loft's end plane (x = 14 m) the flat's plates and the loft's share their butt
    edge: every pair there steps by no more than the two plates' own departures from the hull
    added (a flat plate on the plane it is cut on, a strip within the fit tolerance; 10 % and
    0.05 mm for the departure between the grid points it is measured on, and the edges'
    samples), so within the fit tolerance; none is reported apart; the shell (flat 20 m x 2 m,
    bilge 14 m x pi R / 2) is covered once. Planned on the untrimmed plane, the flat's plate
    reached y = 2500 mm at z = 0 under the bilge: 41.4 mm below the loft's second strake there,
    5.4 mm off its first (KVLCC2: 178.5 mm). The loft's first strake is one flat plate across
    the flat's edge, 4.1 mm off the hull on its minimax plane: its step with the flat's plate
    (4.4 mm) exceeds what a butt may step (3 mm), as any plate's own fit may; fit_up: repair
    holds such plates (tests/test_fitup_repair.py)."""
    parts, shell, fits = flat_beyond_loft
    across = [p for p in shell["pairs"] if p["kind"] == "butt" and sum("_P1_" in n for n in p["plates"]) == 1]
    assert across and any("_P2_" in n for p in across for n in p["plates"])
    for p in across:
        own = sum(fits[n] for n in p["plates"])
        assert p["step_max_mm"] <= 1.1 * own + 0.05 and p["step_max_mm"] < 5.0
    assert not shell["apart"]
    area = 20000.0 * FLAT_Y + 14000.0 * np.pi / 2 * BILGE_R
    assert shell["coverage"]["shell_m2"] == pytest.approx(area / 1e6, rel=2e-3)
    assert shell["coverage"]["covered"] == pytest.approx(1.0, abs=2e-3)
    assert shell["coverage"]["overlap"] <= 1e-3


def test_the_loft_ends_where_the_faces_part(tmp_path):
    """A 1:10 model whose bilge rises off the flat from x = 14 m (ship) to 15 mm (ship) at
    x = 20 m: every station's sections still chain (the join is 2 mm of the model, 20 mm of
    the ship), but the loft ends where the gap passes 6 mm (ship), x = 14 + 6 * 6 / 15 =
    16.4 m: its end section is the faces' own within 3 mm (half the gap) plus the loft's
    tolerance, not a chord across 15 mm; the note says where the faces part and by how much;
    beyond it both faces are planned on their own."""
    from flatten.closest import SurfaceDistance
    from pipeline.hull.region import load_plan_surfaces

    factor = 0.1
    flat, bilge = flat_and_bilge(lift=15.0, factor=factor)
    model = write_step_faces(tmp_path / "p.step", [(flat, (0, 1, 0, FLAT_Y / PLANE_Y)), (bilge, (0, 1, 0, 1))])
    spec = type("Spec", (), {"model": str(model), "faces": [0, 1]})()
    surfaces = load_plan_surfaces([spec], tmp_path, 1.0, 1 / factor)
    loft = surfaces[0]
    x0, x1 = loft.surface.domain_u
    assert x0 == pytest.approx(0.0, abs=100.0)
    assert 16400.0 - 100.0 <= x1 <= 16400.0
    assert "the faces part beyond x = " in loft.note and "a gap in the model" in loft.note
    gap = float(loft.note.split("a gap in the model: ")[1].split(" mm")[0])
    assert 14.0 <= gap <= 15.0  # the widest the sections chained across, near x = 20 m
    beyond = surfaces[1:]
    assert len(beyond) == 2 and all(s.x_limits == (x1, None) for s in beyond)
    # the loft's end section against the two faces (ship scale)
    section = loft.surface(np.full(401, x1), np.linspace(0, 1, 401))
    faces = SurfaceDistance([flat, bilge])
    assert (faces(section * factor) / factor).max() <= 3.0 + 1.0


def test_a_face_beyond_both_ends_of_the_loft_is_covered_at_both(tmp_path):
    """The lower face of a cylinder over its whole 20 m, the upper over x 3-14 m: the loft runs
    over 3-14 m and the lower face is planned beyond both of its ends, on one surface. The
    shell's reference is both faces' area (OpenCascade's), covered once: the plates beyond the
    fore end are shell, not steel outside it."""
    path = write_faces_step(tmp_path / "both.step", bilge_cylinder(), [(0, 1, 0, 0.4), (0.15, 0.7, 0.4, 1)])
    out = tmp_path / "out"
    assert main(["run", str(cylinder_config(tmp_path, {"model": str(path), "faces": [0, 1]}, "both")), "--out",
                 str(out), "--quiet"]) == 0
    shell = json.loads((out / "both_summary.json").read_text())["shell"]
    area = sum(f.area_mm2 for f in read_hull_model(path).faces) / 1e6
    assert shell["coverage"]["shell_m2"] == pytest.approx(area, rel=2e-3)
    assert shell["coverage"]["covered"] == pytest.approx(1.0, abs=2e-3)
    assert shell["coverage"]["outside_m2"] <= 1e-3 * area


def test_coverage_areas_split_cells_at_a_surfaces_c0_knots():
    """A surface that turns at a C0 girth knot (v = 0.3, not a cell edge of the 64 x 64 grid:
    a 100 mm flat then 7000 mm of side, as a loft's girth knot at a narrow flat of bottom):
    its area is L (a + b) to round-off, whole (Gauss cells) or as a polygon a hair inside
    (cut cells); Gauss points straddling the knot counted the side's area element over the
    flat's part of its cell (0.4 % too much)."""
    import shapely

    from pipeline.hull.coverage import surface_area

    length, a, b = 10000.0, 100.0, 7000.0
    poles = np.array([[[0, 0, 0], [0, a, 0], [0, a, b]], [[length, 0, 0], [length, a, 0], [length, a, b]]])
    surface = nurbs_surface(1, 1, poles, [0, 0, 1, 1], [0, 0, 0.3, 1, 1], name="kinked")
    whole = surface_area(surface, shapely.box(0, 0, 1, 1))
    inside = surface_area(surface, shapely.box(1e-9, 1e-9, 1 - 1e-9, 1 - 1e-9))
    assert whole == pytest.approx(length * (a + b), rel=1e-9)
    assert inside == pytest.approx(length * (a + b), rel=1e-6)


def test_a_lone_broken_section_is_found_and_the_ends_are_left_to_the_loft():
    """broken_stations on misfits in closed form: a lone station missed by 1000 with its
    neighbours ringing at a third of that, inside the loft, is broken; the same spike at an
    end, a run of like misfits (a hull changing faster than the stations) and a spike
    barely above its neighbours are not."""
    from pipeline.hull.shell import OUTLIER, SPIKE, broken_stations

    limit = 5.0
    quiet = np.full(101, 0.1)
    ringing = quiet.copy()
    ringing[40:61] = 300.0 * np.exp(-np.abs(np.arange(-10, 11)) / 4.0)
    ringing[50] = 1000.0
    assert broken_stations(ringing, limit).tolist() == [50]
    assert broken_stations(np.roll(ringing, -50), limit).tolist() == []  # the spike at the loft's first station
    run = quiet.copy()
    run[40:61] = 100.0
    assert broken_stations(run, limit).tolist() == []
    low = ringing.copy()
    low[50] = 0.99 * SPIKE * ringing[49]  # the worst of the rest, beside it
    assert broken_stations(low, limit).tolist() == []
    modest = quiet.copy()
    modest[50] = 0.99 * OUTLIER * limit
    assert broken_stations(modest, limit).tolist() == []


def test_two_blocks_of_faces_loft_across_the_station_where_they_meet(monkeypatch):
    """ship_part3.igs (NAPA): a bottom and a side face in two blocks, 46 and 47 aft of x =
    43476 mm, 60 and 61 fore of it, all four meeting smoothly. The station on the line where
    the blocks meet has a broken section (its contour there missed half the bottom face:
    girth 3.7 m among 5.1 m); the loft through it was 1007 mm off it and rang up to 0.3 m
    over the stations around it, and the loft kept the 233 stations before it (x 28984 to
    42491 mm), the rest of the faces planned face by face into 58 mm slivers. Left out alone,
    the loft runs over the faces' whole length within 0.5 mm of their sections."""
    from pipeline.hull import shell
    from pipeline.hull.region import _model_shell

    path = DATA / "ship_part3.igs"
    model = read_hull_model(path)
    surface, note, _ = _model_shell(model, path, [46, 47, 60, 61], 1.0, 1.0)
    assert "x 28984.0..57968.0 mm" in note
    assert surface.domain_u[0] == pytest.approx(28984.0, abs=1.0) and surface.domain_u[1] == pytest.approx(57968.0, abs=1.0)
    deviation = float(note.split("it lies within ")[1].split(" mm")[0])
    assert deviation <= 0.5
    monkeypatch.setattr(shell, "broken_stations", lambda worst, limit: np.zeros(0, dtype=int))
    _, before, _ = _model_shell(model, path, [46, 47, 60, 61], 1.0, 1.0)
    assert "x 28984.0..42490.5 mm" in before


def test_the_longest_run_of_stations_bridges_a_lone_station_that_did_not_chain():
    """Stations 0..20; 10 did not chain (ship_part3's station on the line where two blocks
    of 15 faces meet, in its 30-face shell: the loft took the 250 stations on one side of it
    and the other block was planned face by face). One or two missing in a row are left out
    alone; three end the run."""
    from pipeline.hull.shell import JOINED, longest_run

    x = np.arange(21.0)
    one = np.delete(x, [10])
    assert longest_run(x, one) == (0, 10)  # without a bridge: the first half
    assert longest_run(x, one, JOINED) == (0, 20)
    two = np.delete(x, [9, 10])
    assert longest_run(x, two, JOINED) == (0, 19)
    three = np.delete(x, [8, 9, 10])
    assert longest_run(x, three, JOINED) == (8, 18)  # the longer side: stations 11..20



def vanishing_flat_and_bilge(start: float = 40.0, length: float = 20000.0, width: float = FLAT_Y):
    """KVLCC2's stern in closed form: a flat of bottom (z = 0) that is a triangle, its width
    0 at x = ``start`` growing to ``width`` at x = ``length`` (u along x, v across), and a
    bilge of radius BILGE_R from x = 0 meeting it tangentially along its slanted edge y =
    width (x - start) / (length - start), continued aft of ``start`` where the flat has none."""
    corners = np.array([[[start, 0, 0], [start, 0, 0]], [[length, 0, 0], [length, width, 0]]])
    flat = nurbs_surface(1, 1, corners, [0, 0, 1, 1], [0, 0, 1, 1], name="flat")
    rows = []
    for x in (0.0, length):
        y0 = width * (x - start) / (length - start)
        rows.append([[x, y0, 0.0], [x, y0 + BILGE_R, 0.0], [x, y0 + BILGE_R, BILGE_R]])
    w = np.tile([1.0, np.sqrt(0.5), 1.0], (2, 1))
    bilge = nurbs_surface(1, 2, np.array(rows), [0, 0, 1, 1], [0, 0, 0, 1, 1, 1], w, name="bilge")
    return flat, bilge


def test_faces_beyond_the_loft_that_chain_are_lofted_together_not_planned_into_a_sliver(tmp_path, monkeypatch):
    """The flat of bottom vanishes at x = 40 mm, the bilge runs on to x = 0; stations every 80
    mm from x = 0. The first crosses the bilge alone, the rest both faces, so the loft (its
    girth knot at their junction) starts at x = 80 mm. Beyond it the two faces chain: they are
    lofted over x 0..80 mm as one surface of arc-length girth, and planned on it. Planned each
    alone (the control), the flat's part beyond is a plate 8 mm wide at most, as KVLCC2's
    stern left its flat of bottom's 33 mm x 1.19 m. The shell (the flat's triangle 19.96 m x
    2 m / 2, the sheared bilge's 20 m of quarter circles) is covered once."""
    from pipeline.hull import region
    from pipeline.hull.plan import load_run
    from pipeline.hull.region import load_plan_surfaces

    flat, bilge = vanishing_flat_and_bilge()
    model = write_step_faces(tmp_path / "stern.step", [(flat, (0, 1, 0, 1)), (bilge, (0, 1, 0, 1))])
    spec = type("Spec", (), {"model": str(model), "faces": [0, 1]})()
    surfaces = load_plan_surfaces([spec], tmp_path, 1.0)
    assert len(surfaces) == 2
    loft, stern = surfaces
    assert loft.surface.domain_u[0] == pytest.approx(80.0, abs=1.0)
    assert "faces 0+1 beyond the shell's loft (x < 80)" in stern.note and stern.x_limits == (None, loft.surface.domain_u[0])
    assert stern.surface.domain_u[0] == pytest.approx(0.0, abs=1.0)
    assert stern.surface.domain_u[1] == pytest.approx(loft.surface.domain_u[0], abs=0.01)
    # the stern's loft lies on the faces: their sections x = const are the flat's segment
    # 0 <= y <= y0(x) and the bilge's quarter circle centred at (y0(x), R)
    x, y, z = stern.surface.grid(np.linspace(*stern.surface.domain_u, 9), np.linspace(0, 1, 41)).reshape(-1, 3).T
    y0 = FLAT_Y * (x - 40.0) / (20000.0 - 40.0)
    on_flat = np.where((y <= y0) & (x >= 40.0), np.abs(z), np.inf)
    on_bilge = np.where(y >= y0 - 0.5, np.abs(np.hypot(y - y0, z - BILGE_R) - BILGE_R), np.inf)
    assert np.minimum(on_flat, on_bilge).max() <= 0.5
    config = end_plane_config(tmp_path, model, "stern")
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "stern_summary.json").read_text())
    coverage = summary["shell"]["coverage"]
    # the bilge's sections are quarter circles sheared along x by the slope s = y0'(x):
    # its area element is R sqrt(1 + s^2 sin^2 t) per unit x and angle t
    theta = np.linspace(0.0, np.pi / 2, 20001)
    slope = FLAT_Y / (20000.0 - 40.0)
    element = np.sqrt(1.0 + (slope * np.sin(theta)) ** 2)
    arc = BILGE_R * float(np.sum(0.5 * (element[1:] + element[:-1]) * np.diff(theta)))
    area = (20000.0 - 40.0) * FLAT_Y / 2 + 20000.0 * arc
    assert coverage["shell_m2"] == pytest.approx(area / 1e6, rel=2e-3)
    assert coverage["covered"] >= 0.999 and coverage["overlap"] <= 1e-3
    widths = [p.hull for p in load_run(config).parts if "_P2_" in p.name]
    assert widths and all("beyond the shell's loft" in h.surface_note for h in widths)
    # the control: each face planned alone beyond the loft, the flat's part a sliver
    monkeypatch.setattr(region, "_beyond_shell", lambda *args, **kwargs: None)
    alone = load_plan_surfaces([spec], tmp_path, 1.0)
    assert len(alone) == 3
    flat_part = next(s for s in alone[1:] if "face 0 beyond" in s.note)
    pts = flat_part.surface.grid(np.linspace(*flat_part.surface.domain_u, 21), np.linspace(0, 1, 5))
    assert pts[..., 1][pts[..., 0] <= 80.0].max() <= FLAT_Y * 80.0 / 19960.0 + 1e-6


def test_the_loft_reaches_where_the_faces_start_and_a_trimmed_face_is_read_along_its_trim(tmp_path):
    """The flat of bottom trimmed to x >= 40 mm, the bilge to x >= 30 mm; stations every 80 mm
    from x = 0. The first crosses neither face, the second both, and the loft started there,
    80 mm: the faces' parts aft of it reach more than the remainder a face is planned for (20
    mm), but the flat's x range was read from a 65 x 65 grid of the face, whose first column
    inside the trim is at x = 312 mm, so its 40 mm x 2 m there was neither lofted nor planned,
    and no figure said so. Read along the trim too, the flat starts at 40 mm; and the loft now
    reaches where the two faces start to chain (bisection: 40 mm, both faces keeping their
    girth), leaving the bilge's 10 mm, under the remainder."""
    from pipeline.hull.region import _x_extent, load_plan_surfaces
    from pipeline.hull.trims import Trim

    flat, bilge = flat_and_bilge()
    model = write_step_faces(tmp_path / "end.step", [(flat, (0.002, 1, 0, FLAT_Y / PLANE_Y)),
                                                      (bilge, (0.0015, 1, 0, 1))])
    face = read_hull_model(model).faces[0]
    trim = Trim(face.index, face.outer, face.inner, 0)
    assert _x_extent(face.surface, trim)[0] == pytest.approx(40.0, abs=0.5)
    spec = type("Spec", (), {"model": str(model), "faces": [0, 1]})()
    surfaces = load_plan_surfaces([spec], tmp_path, 1.0)
    assert len(surfaces) == 1
    assert surfaces[0].surface.domain_u[0] == pytest.approx(40.0, abs=80.0 / 4096 + 1e-6)
