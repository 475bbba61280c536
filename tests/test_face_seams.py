"""Seams across a face junction (pipeline/hull/faceseams.py): where two faces of a plan are cut
at one plane, the later face's seams run on from the earlier face's seam ends there or end at
least the butt stagger from them (yard rules), checked on closed-form cones and on KVLCC2."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.hull.faceseams import (
    meet_at_junctions,
    seam_crossings,
    section_at,
    shared_planes,
)
from pipeline.hull.region import Girth
from tests.hull_shapes import cylinder_along_iges, write_iges_surface

STAGGER = 300.0
REPO = Path(__file__).resolve().parent.parent


def cone_piece_iges(path: Path, x0: float, x1: float, r_at, angle_deg: float = 90.0) -> Path:
    """The piece x0..x1 of one cone of axis x (radius ``r_at(x)``, linear): u along x, v
    around the arc; pieces of the same cone lie on each other where their x ranges overlap."""
    h = np.radians(angle_deg) / 2

    def arc(x):
        r = r_at(x)
        return [[x, -r * np.sin(h), r * (1 - np.cos(h))], [x, 0.0, r - r / np.cos(h)],
                [x, r * np.sin(h), r * (1 - np.cos(h))]]

    w = np.array([1.0, np.cos(h), 1.0])
    return write_iges_surface(path, 1, 2, np.array([arc(x0), arc(x1)]), np.vstack([w, w]), [0, 0, 1, 1],
                              [0, 0, 0, 1, 1, 1])


def _radius(x):
    return 4500.0 - 0.05 * x


def _arc_point(r: float, x: float, girth: float, angle_deg: float = 90.0) -> np.ndarray:
    """The point ``girth`` along the cone's arc at x from its first edge (v = 0)."""
    theta = girth / r - np.radians(angle_deg) / 2
    return np.array([x, r * np.sin(theta), r * (1 - np.cos(theta))])


def _load(path: Path):
    from pipeline.config import SurfaceSource
    from pipeline.hull.region import load_surface

    return load_surface(SurfaceSource(iges=str(path)), path.parent, 1.0)


@pytest.mark.parametrize("x", [12345.0, 12301.0, 12301.9])
def test_a_seams_crossing_with_a_plane_is_the_arc_point_there(tmp_path, x):
    """Also at planes 1 and 1.9 mm from a sample along the cone (every 100 mm): the crossing
    is bisected, not taken at the sample."""
    surface = _load(cone_piece_iges(tmp_path / "c.igs", 0.0, 20000.0, _radius))
    _, at = section_at(surface, 0, x)
    assert np.allclose(at[:, 0], x, atol=1e-6)
    # the section is the cone's circular arc of radius r(x): every point at r from the axis line
    centre = np.array([x, 0.0, _radius(x)])
    assert np.allclose(np.linalg.norm(at - centre, axis=1), _radius(x), rtol=1e-9)
    (point,) = seam_crossings(surface, 0, [Girth.iso(0.5)], x)
    assert point == pytest.approx([x, 0.0, 0.0], abs=1e-6)  # the arc's middle
    # a seam that does not reach the plane has no crossing
    assert np.isnan(seam_crossings(surface, 0, [Girth.iso(0.5)], 25000.0)).all()


def _cylinder(tmp_path):
    return _load(cylinder_along_iges(tmp_path / "cyl.igs"))


def _arc_of(surface, x, value):
    g, at = section_at(surface, 0, x)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(at, axis=0), axis=1))])
    return float(np.interp(value, g, arc)), g, arc, at


@pytest.mark.parametrize("max_width, how", [(2000.0, "runs on"), (1700.0, "staggered"), (1600.0, None)])
def test_a_seam_near_an_end_across_the_junction_runs_on_or_keeps_the_stagger_within_the_stock(tmp_path, max_width,
                                                                                               how):
    """A cylinder along x (radius 3 m, a quarter round: 4712 mm of girth), three strakes at
    v = 1/3, 2/3 (1533, 1646, 1533 mm: the rational arc's parameter is not its length); an
    earlier face's seam end 200 mm below its first seam at x = 20000: the seam runs on onto it
    where the second strake may widen to 1846 mm, else ends 300 mm above it (1633 and 1546 mm
    wide), else stays (no room)."""
    surface = _cylinder(tmp_path)
    x = 20000.0
    seams = [0.0, 1 / 3, 2 / 3, 1.0]
    own, g, arc, at = _arc_of(surface, x, seams[1])
    sample = np.argmin(np.abs(arc - (own - 200.0)))  # a section sample: 200 mm +- 6 along the girth
    end = at[sample]
    gap = float(np.linalg.norm(seam_crossings(surface, 0, [Girth.iso(seams[1])], x)[0] - end))

    def widest(v):  # the cylinder's sections are all alike
        return np.interp(v, g, arc)

    moved, moves, left = meet_at_junctions(surface, 0, seams, widest, [(x, end[None])], STAGGER, max_width, 50.0)
    if how is None:
        assert moves == [] and left == 1 and moved == seams
        return
    (move,) = moves
    assert (move.seam, move.how, move.gap) == (1, how, pytest.approx(gap, abs=0.05))
    assert moved[0] == 0.0 and moved[2:] == seams[2:]
    now = np.linalg.norm(seam_crossings(surface, 0, [Girth.iso(moved[1])], x)[0] - end)
    if how == "runs on":
        assert now < 1e-3
    else:
        assert STAGGER <= now < STAGGER + 1.0  # the stagger and a thousandth
    assert np.diff(widest(np.array(moved))).max() <= max_width


def test_faces_cut_together_are_found_by_their_shared_plane():
    limits = [(None, 100.0), (100.0, 250.0), (250.0, None), (100.0, None)]
    assert shared_planes(limits, 0) == []
    assert shared_planes(limits, 1) == [(0, 100.0)]
    assert shared_planes(limits, 2) == [(1, 250.0)]
    assert shared_planes(limits, 3) == [(0, 100.0), (1, 100.0)]


def _two_cones(tmp_path, stagger=True, max_width=1500.0) -> Path:
    """Two pieces of one cone that overlap over x 19..21 m (the plan cuts them at a plane
    there): the aft one 4.5 m in radius at its widest, five strakes of 1.41 m, the fore one
    3.55 m, four of 1.39 m (with stock 1.42 to 1.76 m wide); at the cut their seams end 272 mm
    apart twice."""
    aft = cone_piece_iges(tmp_path / "aft.igs", 0.0, 21000.0, _radius)
    fore = cone_piece_iges(tmp_path / "fore.igs", 19000.0, 30000.0, _radius)
    plan = {"method": "uniform", "surfaces": [{"iges": str(fore)}],
            "stock": {"max_length": 16000, "max_width": max_width, "min_length": 1000, "min_width": 500}}
    if stagger:
        plan["butt_stagger"] = STAGGER
    data = {"name": "cones", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
            "strake": {"surface": {"iges": str(aft)}, "margin": 0.2, "fit_tolerance": 5.0, "plan": plan},
            "shop": {"stock": [[10000.0, 40000.0]]}}
    path = tmp_path / "cones.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _ends_at_the_cut(parts) -> tuple[float, dict]:
    """The cut's x and each face's seam ends there (model units), from the planned plates."""
    cut = next(x for p in parts for x in p.hull.x_limits if x is not None)
    ends = {}
    for part in parts:
        if any(plane is not None and abs(plane.offset - cut) < 1e-6 for plane in part.hull.butts):
            points = seam_crossings(part.hull.surface, part.hull.long_axis, part.hull.girths, cut)
            ends.setdefault(part.name.split("_")[1], []).extend(points)
    return cut, {face: np.unique(np.round(np.array(p), 6), axis=0) for face, p in ends.items()}


def _gaps(ends: dict) -> np.ndarray:
    """Distances from each of the second face's seam ends to the first face's nearest."""
    first, second = ends["P1"], ends["P2"]
    return np.linalg.norm(second[:, None] - first[None], axis=2).min(axis=1)


def _corners(part):
    """A stand-in for the plate's evaluated result: its region's corners, where its seams cross
    its butt planes (what :func:`.yardrules.cross_joints` reads)."""
    from types import SimpleNamespace

    hull = part.hull
    corners = [point for plane in hull.butts if plane is not None
               for point in seam_crossings(hull.surface, hull.long_axis, hull.girths, plane.offset)]
    return SimpleNamespace(figures={"region": {"corners": [list(p) for p in corners]}})


@pytest.mark.parametrize("max_width, how", [(1500.0, "staggered"), (1700.0, "runs on")])
def test_a_later_faces_seams_meet_the_earlier_faces_at_their_cut_under_the_yards_rules(tmp_path, max_width, how):
    """With 1.5 m stock the fore face's strakes cannot widen by the 0.28 m a seam would need to
    run on (1.39 + 0.28 m): its two seams end the stagger from the aft face's; with 1.7 m they
    run on, and the cut is a block joint where they make cross joints."""
    from pipeline.config import load_config
    from pipeline.hull import planner
    from pipeline.hull.yardrules import cross_joints, face_junctions

    def plan(path):
        config = load_config(path)
        return planner.plan_hull(config.spec, path, config.mm_per_unit, config.lines)

    plain = plan(_two_cones(tmp_path, stagger=False, max_width=max_width))
    yard = plan(_two_cones(tmp_path, max_width=max_width))
    cut, ends = _ends_at_the_cut(yard)
    assert 19000.0 < cut < 21000.0
    assert len(ends["P1"]) == 6 and len(ends["P2"]) == 5  # edges included
    gaps = _gaps(ends)
    met = gaps < 1e-3
    assert met.sum() == (2 if how == "staggered" else 4)  # the edges (one cone), and the seams run on
    assert (gaps[~met] >= STAGGER).all() and (gaps[~met] < STAGGER + 1.0).sum() == (2 if how == "staggered" else 0)
    note = next(p.hull.surface_note for p in yard if "_P2_" in p.name)
    assert note.count(how) == 2 and "face junction" in note
    # the control: without the yard's rules the fore face keeps its own seams; the aft face's
    # ends at fifths of the arc, the fore face's at quarters: the first and last a twentieth
    # of the quarter round apart, a chord of 2 r sin(pi / 80) at the cut
    control = _gaps(_ends_at_the_cut(plain)[1])
    near = control[(control > 1e-3) & (control < STAGGER)]
    assert near == pytest.approx([2 * _radius(cut) * np.sin(np.pi / 80)] * 2, abs=0.01)
    assert [p.name for p in plain if "_P1_" in p.name] == [p.name for p in yard if "_P1_" in p.name]
    # the cut is a block joint of the plan: every strake of both faces butts there
    assert face_junctions(yard) == (cut,)
    assert face_junctions([p for p in yard if "_P1_" in p.name]) == ()
    crosses = [at for at, _ in cross_joints(yard, (), 1.0, _corners) if abs(at[0] - cut) < 1e-6]
    assert len(crosses) == (0 if how == "staggered" else 2)
    assert not [at for at, _ in cross_joints(yard, face_junctions(yard), 1.0, _corners) if abs(at[0] - cut) < 1.0]


def test_kvlcc2s_bow_and_stern_faces_meet_the_lofts_seam_ends():
    """KVLCC2's loft and the faces beyond its ends (x = 15.09 and 296.11 m): before, six seam
    ends of the bow and stern faces lay 92 to 286 mm from the loft's across the junction; the
    plan's layout now runs them on or keeps the stagger (the stern face one strake more)."""
    from pipeline.config import load_config
    from pipeline.hull.planner import plan_hull

    path = REPO / "configs" / "kvlcc2_shell.yaml"
    config = load_config(path)
    parts = plan_hull(config.spec, path, config.mm_per_unit, config.lines)
    loft = [p for p in parts if "_P1_" in p.name]
    for cut in {x for p in loft for x in p.hull.x_limits if x is not None}:
        at_cut = [p for p in parts if any(b is not None and abs(b.offset - cut) < 1e-6 for b in p.hull.butts)]
        mine = [p for p in at_cut if "_P1_" in p.name]
        others = [p for p in at_cut if "_P1_" not in p.name]
        assert mine and others
        first = np.concatenate([seam_crossings(p.hull.surface, 0, p.hull.girths, cut) for p in mine])
        _, section = section_at(mine[0].hull.surface, 0, cut)
        checked = 0
        for part in others:
            for end in seam_crossings(part.hull.surface, part.hull.long_axis, part.hull.girths, cut):
                # an end on the loft's section (a face's edge where the next face begins is off it)
                if np.linalg.norm(section - end, axis=1).min() > 50.0:
                    continue
                gap = float(np.nanmin(np.linalg.norm(first - end, axis=1)))
                assert gap < 0.5 or gap >= STAGGER, (part.name, end, gap)
                checked += 1
        assert checked >= 10
    # the stern face's nine strakes were within 14 mm of the 4 m stock: no seam could move
    stern = {p.hull.surface_note for p in parts if "_P2_" in p.name}
    assert len(stern) == 1 and "one strake more (10)" in stern.pop()
