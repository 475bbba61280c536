"""Faces that lie on each other, faired into one another (``plan.overlaps: fair``): on two
coaxial cylinders the faired face's radius follows the C2 ramp in closed form and the rest of
the face is untouched; on DTMB 5415 the bow face meets the main hull at the plan's cut, where
the files leave 27 mm."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from flatten.surface import nurbs_surface
from pipeline.hull import fairing
from pipeline.hull.fairing import (
    RAMP_PER_GAP,
    fair_into,
    fair_junctions,
    fair_overlaps,
    ramp,
)
from pipeline.hull.sewing import overlap_cuts

SHIP = Path(__file__).parent / "data" / "ship"


def cylinder(radius: float, x0: float, x1: float, spans: int = 4):
    """The quarter cylinder y^2 + z^2 = radius^2, y >= 0, z <= 0, x0 <= x <= x1 (mm): cubic
    along x on ``spans`` spans, the exact rational quadratic arc around."""
    xs = np.linspace(x0, x1, spans + 3)
    arc = np.array([[0.0, -radius], [radius, -radius], [radius, 0.0]])
    poles = np.array([[[x, y, z] for y, z in arc] for x in xs])
    weights = np.tile([1.0, np.sqrt(0.5), 1.0], (len(xs), 1))
    knots_u = np.concatenate([[0.0] * 4, np.arange(1, spans) / spans, [1.0] * 4])
    return nurbs_surface(3, 2, poles, knots_u, [0.0, 0.0, 0.0, 1.0, 1.0, 1.0], weights, name=f"R{radius:g}")


def radius_on_grid(surface, n: int = 61):
    p = surface.grid(np.linspace(*surface.domain_u, n), np.linspace(*surface.domain_v, n))
    return p[..., 0], np.hypot(p[..., 1], p[..., 2])


def test_ramp_is_c2_and_runs_either_way():
    x = np.linspace(-1.0, 2.0, 3001)
    r = ramp(x, 0.0, 1.0)
    assert r[x <= 0].max() == 0.0 and r[x >= 1].min() == 1.0
    assert np.all(np.diff(r) >= 0)
    # zero slope and curvature at both ends: the second difference vanishes there
    h = x[1] - x[0]
    second = np.diff(r, 2) / h**2
    assert abs(second[999]) < 0.1 and abs(second[1999]) < 0.1 and np.abs(second).max() == pytest.approx(10 / np.sqrt(3), rel=0.01)
    assert np.allclose(ramp(x, 1.0, 0.0), 1.0 - r)


@pytest.mark.parametrize("delta", [20.0, -35.0])
def test_a_cylinder_faired_into_a_coaxial_one_follows_the_ramp_in_closed_form(delta):
    """Face B (radius R + delta, x 0..10000) faired into face A (radius R, x 5000..20000)
    from x = 5000 to the cut at 10000: B's radius is R + delta (1 - ramp(x)) to within the
    refit error it reports (a fiftieth of a millimetre), the faces meet at the cut, and B before the ramp is untouched."""
    radius = 5000.0
    a, b = cylinder(radius, 5000.0, 20000.0), cylinder(radius + delta, 0.0, 10000.0)
    faired, done = fair_into(b, a, 5000.0, 10000.0, face=1, other=0)
    x, r = radius_on_grid(faired, 81)
    expected = radius + delta * (1.0 - ramp(x, 5000.0, 10000.0))
    # the reported refit error is measured between the fit's samples; a finer grid finds the
    # same within half again
    assert np.abs(r - expected).max() <= 1.5 * done.refit_error + 1e-6
    assert np.abs(r - expected).max() < 0.002 * abs(delta)
    assert done.moved_max == pytest.approx(abs(delta), rel=1e-3)
    assert done.step_at_cut_before == pytest.approx(abs(delta), rel=1e-6)
    assert done.step_at_cut_after < 0.01 * abs(delta)
    original = b.grid(np.linspace(*b.domain_u, 81), np.linspace(*b.domain_v, 81))
    moved = faired.grid(np.linspace(*b.domain_u, 81), np.linspace(*b.domain_v, 81))
    # beyond the poles that act on the ramp (B's knot span before it) the face is B to round-off;
    # within that span the fit of the move leaks micrometres
    assert np.abs(moved - original)[x <= 2500.0].max() < 1e-9 * radius
    assert np.abs(moved - original)[x < 5000.0 - 1e-6].max() < 1e-4 * abs(delta)
    assert np.ptp(faired.weights) > 0  # still the exact arc's rational form


def test_the_plan_fairs_the_face_that_keeps_the_overlap():
    """overlap_cuts finds the coaxial cylinders' overlap (x 5000..10000, 20 mm apart) and
    cuts it; the face whose kept side holds the overlap is faired into the other and the two
    then meet at the cut, the other face unchanged."""
    radius, delta, tolerance = 5000.0, 20.0, 5.0
    faces = [cylinder(radius + delta, 0.0, 10000.0), cylinder(radius, 5000.0, 20000.0)]
    limits, overlaps = overlap_cuts(faces, [None, None], tolerance)
    assert len(overlaps) == 1 and overlaps[0].step_at_cut_mm == pytest.approx(delta, rel=1e-3)
    out, done = fair_overlaps(faces, overlaps, limits, tolerance)
    (made,) = done
    assert made.taken and made.step_at_cut_after < 0.2
    kept_side = {k for k, (lo, hi) in enumerate(limits)
                 if (hi is not None and hi > 5000.0 + 1.0) or (lo is not None and lo < 10000.0 - 1.0)}
    assert made.face in kept_side and out[made.onto] is faces[made.onto] and out[made.face] is not faces[made.face]


def test_a_fairing_whose_refit_strays_is_not_taken(monkeypatch):
    monkeypatch.setattr(fairing, "REFIT_SHARE", 0.0)
    faces = [cylinder(5020.0, 0.0, 10000.0), cylinder(5000.0, 5000.0, 20000.0)]
    limits, overlaps = overlap_cuts(faces, [None, None], 5.0)
    out, (made,) = fair_overlaps(faces, overlaps, limits, 5.0)
    assert not made.taken and "refit strays" in made.reason and all(o is f for o, f in zip(out, faces))
    assert "not faired" in made.note()


def _dtmb_config(tmp_path: Path, overlaps: str) -> Path:
    config = {"name": "d5415", "units": "mm",
              "strake": {"surface": {"iges": str(SHIP / "ship_5415.igs"), "directory": 5}, "scale": 24.824,
                         "plan": {"method": "uniform", "overlaps": overlaps,
                                  "stock": {"max_length": 14000, "max_width": 3500, "min_length": 3000,
                                            "min_width": 1000},
                                  "surfaces": [{"iges": str(SHIP / "ship_5415.igs"), "directory": 1}]},
                         "fit_tolerance": 5.0},
              "steel": {"thickness": 12, "material": "AH36"}}
    path = tmp_path / f"d5415_{overlaps}.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def test_dtmb5415s_bow_meets_the_main_hull_at_the_cut_when_faired(tmp_path):
    """The bow face's plates at the cut (x = 20198 mm) lie on the main hull there within the
    refit's error once faired (27 mm apart in the files); plates elsewhere keep the file's
    surfaces, and both faces' plates say what was done."""
    from flatten.closest import SurfaceDistance
    from pipeline.hull.plan import load_run

    runs = {how: load_run(_dtmb_config(tmp_path, how)) for how in ("cut", "fair")}
    fairings = runs["fair"].plan_fairings
    assert runs["cut"].plan_fairings == [] and len(fairings) == 1 and fairings[0]["taken"]
    assert (fairings[0]["face"], fairings[0]["onto"]) == (2, 1)  # the bow (the plan's second surface) moved
    cut = fairings[0]["ramp_x_mm"][1]
    assert cut == pytest.approx(20198.0, abs=1.0)

    def steps(run):
        main = next(p.hull.surface for p in run.parts if "_P1_" in p.name)
        bow = next(p.hull.surface for p in run.parts if "_P2_" in p.name)
        section = bow.plane_section_points((cut, 0.0, 0.0), (1.0, 0.0, 0.0), 200)
        params, dist = SurfaceDistance(main, grid=60).closest(section)
        (u0, u1), (v0, v1) = main.domain_u, main.domain_v
        inside = (params[:, 0] > u0 + 1e-6) & (params[:, 0] < u1 - 1e-6) & (params[:, 1] > v0 + 1e-6) & (
            params[:, 1] < v1 - 1e-6)
        return dist[inside]

    before, after = steps(runs["cut"]), steps(runs["fair"])
    assert before.max() > 20.0
    assert after.max() < 2.0 and after.max() <= fairings[0]["step_at_cut_after_mm"] + 0.1
    assert [p.name for p in runs["cut"].parts] == [p.name for p in runs["fair"].parts]
    assert all("faired into face 1" in p.hull.surface_note for p in runs["fair"].parts)
    # the main hull's own plates keep the file's surface
    main_cut = next(p.hull.surface for p in runs["cut"].parts if "_P1_" in p.name)
    main_fair = next(p.hull.surface for p in runs["fair"].parts if "_P1_" in p.name)
    assert np.array_equal(main_cut.poles, main_fair.poles)


def test_an_unknown_overlaps_choice_is_refused_naming_the_field(tmp_path, capsys):
    from pipeline.cli import main

    path = _dtmb_config(tmp_path, "cut")
    path.write_text(path.read_text().replace("overlaps: cut", "overlaps: blend"))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "overlaps" in err and "blend" in err and not out.exists()


def test_inspect_points_to_fairing_where_faces_overlap(capsys):
    from pipeline.cli import main

    assert main(["hull", "inspect", str(SHIP / "ship_5415.igs")]) == 0
    out = capsys.readouterr().out
    overlap = next(line for line in out.splitlines() if line.startswith("overlap:"))
    assert "faces 0 and 1" in overlap and "overlaps: fair" in overlap


def plane_face(x0: float, x1: float, z: float, width: float = 3000.0, spans: int = 4):
    """The plane z = ``z`` over x0..x1, y 0..``width`` (mm), cubic along x on ``spans`` spans."""
    xs, ys = np.linspace(x0, x1, spans + 3), np.linspace(0.0, width, 4)
    poles = np.array([[[x, y, z] for y in ys] for x in xs])
    knots_u = np.concatenate([[0.0] * 4, np.arange(1, spans) / spans, [1.0] * 4])
    return nurbs_surface(3, 3, poles, knots_u, [0.0] * 4 + [1.0] * 4, name=f"z{z:g}")


def oriented(face, side: tuple):
    """The plane face re-parametrised so that its end x = x1 is the side ``side`` ((parameter,
    end)): u reversed for end 0, u and v swapped for parameter 1."""
    poles, knots_u, knots_v = face.poles, face.knots_u, face.knots_v
    if side[1] == 0:
        poles, knots_u = poles[::-1], 1.0 - knots_u[::-1]
    if side[0] == 1:
        poles, knots_u, knots_v = poles.transpose(1, 0, 2), knots_v, knots_u
    return nurbs_surface(3, 3, poles, knots_u, knots_v, name=face.name)


@pytest.mark.parametrize("side", [(0, 1), (0, 0), (1, 1), (1, 0)])
def test_a_face_whose_end_stands_off_the_next_face_is_faired_onto_it_in_closed_form(side):
    """A bottom plane (x 0..10000 at z = 0) ends 12 mm below the next face (x 10000..12000 at
    z = 12), its end any of its four parameter sides: the longer face's end moves onto the
    other face, behind it z = 12 ramp(x) over RAMP_PER_GAP x 12 mm, and the rest of it stays
    where it was."""
    gap, tolerance = 12.0, 5.0
    faces = [oriented(plane_face(0.0, 10000.0, 0.0), side), plane_face(10000.0, 12000.0, gap)]
    out, (made,) = fair_junctions(faces, [None, None], [(None, None)] * 2, tolerance)
    assert made.taken and made.kind == "junction" and (made.face, made.onto) == (0, 1) and out[1] is faces[1]
    start = 10000.0 - RAMP_PER_GAP * gap
    assert made.ramp_x == pytest.approx((start, 10000.0), abs=1.0)
    assert made.step_at_cut_before == pytest.approx(gap, rel=1e-6) and made.step_at_cut_after < 0.01 * gap
    u, v = np.linspace(0.0, 1.0, 201), np.linspace(0.0, 1.0, 31)
    before, after = faces[0].grid(u, v), out[0].grid(u, v)
    expected = gap * ramp(before[..., 0], start, 10000.0)
    assert np.abs(after[..., 2] - expected).max() <= 1.5 * made.refit_error + 1e-6 < 0.02 * gap
    assert np.abs(after[..., :2] - before[..., :2]).max() < 1e-6  # the move runs along z only
    assert np.abs(after - before)[before[..., 0] < 5000.0].max() < 1e-9 * 10000.0  # two spans off: untouched
    assert "faired onto the junction with face 2" in made.note() and made.as_dict()["gap_after_mm"] < 0.12


def test_the_side_that_stands_off_moves_where_the_other_face_ends_on_the_first():
    """The bottom (z = 0, x 0..10000) ends on a transverse face (x = 10000, z -12..3000) whose
    own lower side hangs 12 mm below the bottom: that side, not the bottom's end (which lies on
    the transverse face), is faired up onto the bottom."""
    bottom = plane_face(0.0, 10000.0, 0.0)
    ys, zs = np.linspace(0.0, 3000.0, 4), np.linspace(-12.0, 3000.0, 7)
    poles = np.array([[[10000.0, y, z] for y in ys] for z in zs])
    knots = np.concatenate([[0.0] * 4, [0.25, 0.5, 0.75], [1.0] * 4])
    transverse = nurbs_surface(3, 3, poles, knots, [0.0] * 4 + [1.0] * 4, name="transverse")
    out, (made,) = fair_junctions([bottom, transverse], [None, None], [(None, None)] * 2, 5.0)
    assert made.taken and (made.face, made.onto) == (1, 0) and out[0] is bottom
    lowest = out[1](np.zeros(31), np.linspace(0.0, 1.0, 31))
    assert np.abs(lowest[:, 2]).max() < 0.01 * 12.0 and made.step_at_cut_before == pytest.approx(12.0, rel=1e-6)


def test_a_ramp_that_would_reach_the_faces_far_side_is_not_taken():
    """Two 2 m faces 12 mm apart: the ramp (2.4 m) would move the whole face."""
    faces = [plane_face(0.0, 2000.0, 0.0), plane_face(2000.0, 4000.0, 12.0)]
    out, (made,) = fair_junctions(faces, [None, None], [(None, None)] * 2, 5.0)
    assert not made.taken and "far side" in made.reason and all(o is f for o, f in zip(out, faces))


def test_a_side_only_partly_along_the_other_face_is_not_faired():
    """The bottom's end runs 150 mm past the next face's side: of the two, only the next face's
    end lies wholly along the other, and it is the one faired."""
    faces = [plane_face(0.0, 10000.0, 0.0), plane_face(10000.0, 14000.0, 12.0, width=2850.0)]
    out, (made,) = fair_junctions(faces, [None, None], [(None, None)] * 2, 5.0)
    assert made.taken and (made.face, made.onto) == (1, 0) and out[0] is faces[0]


def test_faces_that_meet_within_half_the_tolerance_are_left_alone():
    faces = [plane_face(0.0, 10000.0, 0.0), plane_face(10000.0, 12000.0, 2.0)]
    out, done = fair_junctions(faces, [None, None], [(None, None)] * 2, 5.0)
    assert done == [] and all(o is f for o, f in zip(out, faces))


def test_a_trimmed_face_or_an_overlapping_pair_is_not_faired_at_its_sides():
    faces = [plane_face(0.0, 10000.0, 0.0), plane_face(10000.0, 12000.0, 12.0)]
    assert fair_junctions(faces, [object(), None], [(None, None)] * 2, 5.0)[1] == []
    assert fair_junctions(faces, [None, None], [(None, None)] * 2, 5.0, frozenset([frozenset((0, 1))]))[1] == []
    # sides outside the faces' kept x ranges (cuts before them) are on no junction
    assert fair_junctions(faces, [None, None], [(None, 9000.0), (11000.0, None)], 5.0)[1] == []


def test_dtmb5415s_hull_end_meets_its_stern_face_when_faired(tmp_path):
    """The main hull's aft end stands up to 15 mm off the stern face at ship scale (where the
    closest-point search from the stern's collapsed side would say 76 mm): faired onto it,
    its side lies on the stern face within a tenth of a millimetre; the stern keeps the file's
    surface."""
    from flatten.closest import SurfaceDistance, closest_with_sides
    from pipeline.hull.fairing import SIDES, side_gaps
    from pipeline.hull.plan import load_run

    path = _dtmb_config(tmp_path, "fair")
    data = yaml.safe_load(path.read_text())
    data["strake"]["plan"]["surfaces"].append({"iges": str(SHIP / "ship_5415.igs"), "directory": 9})
    runs = {}
    for how in ("keep", "fair"):
        data["strake"]["plan"]["junctions"] = how
        path.write_text(yaml.safe_dump(data))
        runs[how] = load_run(path)
    junctions = [f for f in runs["fair"].plan_fairings if f["kind"] == "junction"]
    assert [f["kind"] for f in runs["keep"].plan_fairings] == ["overlap"]
    assert len(junctions) == 1 and junctions[0]["taken"] and (junctions[0]["face"], junctions[0]["onto"]) == (1, 3)
    assert 10.0 < junctions[0]["gap_before_mm"] < 20.0 and junctions[0]["gap_after_mm"] < 0.1

    def surface(run, tag):
        return next(p.hull.surface for p in run.parts if tag in p.name)

    stern = SurfaceDistance(surface(runs["fair"], "_P3_"), grid=60)
    assert np.array_equal(surface(runs["keep"], "_P3_").poles, stern.surfaces[0].poles)
    aft = SIDES[1]  # the main hull's aft end: u = u1
    before = side_gaps(surface(runs["keep"], "_P1_"), aft, stern)
    after = side_gaps(surface(runs["fair"], "_P1_"), aft, stern)
    assert 10.0 < before.max() < 20.0 and after.max() < 0.1
    # the search from the nearest seed alone stops on the stern's collapsed side
    _, points = fairing._side_points(surface(runs["keep"], "_P1_"), aft, np.linspace(0.0, 0.15, 7))
    assert stern.closest(points)[1].max() > 50.0 and closest_with_sides(stern, points)[1].max() < 10.0
