"""Fit-up across a trim line: a plate cut at its face's trim meets the plates of the face that
carries the shell on from there (KCS's flat bottom and its main hull meet so at the bilge's
knuckle). The trimmed plate's TRIM edge is paired with the other face's plates along it and
measured like any shared edge."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from flatten.surface import nurbs_surface
from pipeline.cli import main
from pipeline.hull.trimcut import grid_map
from tests.hull_shapes import write_step_faces

RADIUS, LENGTH, KNUCKLE = 3000.0, 12000.0, 3000.0  # mm: the cylinder's radius, the faces' length, the trim's y


def flat_bottom(width: float = 5000.0):
    """The plane z = 0 over x 0-12 m, y 0 to ``width`` mm (u along x, v along y)."""
    poles = np.array([[[x, y, 0.0] for y in (0.0, width)] for x in (0.0, LENGTH)])
    return nurbs_surface(1, 1, poles, [0, 0, 1, 1], [0, 0, 1, 1], np.ones((2, 2)), name="bottom")


def bilge(lift: float = 0.0):
    """A quarter cylinder of axis x that leaves the plane tangentially at y = KNUCKLE (its v = 0
    edge), raised by ``lift`` mm: a gap at the knuckle that the fit-up must show."""
    h = np.radians(45.0)
    arc = np.array([[KNUCKLE, 0.0], [KNUCKLE + RADIUS, 0.0], [KNUCKLE + RADIUS, RADIUS]])
    w = np.array([1.0, np.cos(h), 1.0])
    poles = np.array([[[x, y, z + lift] for y, z in arc] for x in (0.0, LENGTH)])
    return nurbs_surface(1, 2, poles, [0, 0, 1, 1], [0, 0, 0, 1, 1, 1], np.vstack([w, w]), name="bilge")


def run_knuckle(folder: Path, lift: float, trimmed: bool = True) -> dict:
    """The flat bottom trimmed at y = 3 m (or, ``trimmed`` False, a bottom face that ends there
    untrimmed) and the bilge beside it, planned uniformly as two surfaces and run; the summary."""
    bottom = (flat_bottom(), (0, 1, 0, KNUCKLE / 5000.0)) if trimmed else (flat_bottom(KNUCKLE), (0, 1, 0, 1))
    model = write_step_faces(folder / "knuckle.step", [bottom, (bilge(lift), (0, 1, 0, 1))])
    data = {"name": "knuckle", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": False},
            "steel": {"thickness": 12, "material": "S355"},
            "strake": {"surface": {"model": str(model), "face": 0}, "fit_tolerance": 5.0,
                       "plan": {"method": "uniform", "surfaces": [{"model": str(model), "face": 1}],
                                "stock": {"max_length": 6000, "max_width": 2000, "min_length": 1000,
                                          "min_width": 1000}}}}
    config = folder / "knuckle.yaml"
    config.write_text(yaml.safe_dump(data))
    out = folder / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) in (0, 1)
    return json.loads((out / "knuckle_summary.json").read_text())


@pytest.fixture(scope="module")
def knuckles(tmp_path_factory):
    runs = {lift: run_knuckle(tmp_path_factory.mktemp(f"lift{lift:g}"), lift) for lift in (0.0, 4.0, 30.0)}
    runs["untrimmed"] = run_knuckle(tmp_path_factory.mktemp("untrimmed"), 0.0, trimmed=False)
    return runs


def test_a_plate_cut_at_the_trim_is_paired_with_the_next_faces_plates_along_it(knuckles):
    """The bottom's plates cut at y = 3 m (one per 6 m butt) meet the bilge's first strake
    along the whole 12 m of the knuckle, each the plate over its own x range; the faces meet
    exactly, so the steps are the plates' own round-off and the flat and strip plates'
    developed lengths agree."""
    summary = knuckles[0.0]
    trims = [p for p in summary["shell"]["pairs"] if p["kind"] == "trim"]
    assert summary["shell"]["trims"] == len(trims) == 2, trims
    plates = {p["id"]: p for p in summary["parts"]}
    for pair in trims:
        bottom, side = pair["plates"]
        assert "_P1_" in bottom and "_P2_S01_" in side
        assert plates[bottom]["class"] == "flat"
        assert pair["edge"] == "TRIM"
        assert min(pair["length_3d_mm"]) == pytest.approx(6000.0, rel=1e-3)
        assert pair["step_max_mm"] < 0.1 and pair["mismatch_mm"] < 0.1
    assert sum(min(p["length_3d_mm"]) for p in trims) == pytest.approx(LENGTH, rel=1e-3)


def test_the_cut_plates_edges_end_at_the_trim(knuckles):
    """The bottom's second strake (y 1667-3333 mm) is cut at y = 3 m: the butt its two plates
    share at x = 6 m is measured over the steel, 1333 mm, up to the trim line."""
    (butt,) = [p for p in knuckles[0.0]["shell"]["pairs"]
               if p["kind"] == "butt" and all("_P1_S02_" in n for n in p["plates"])]
    assert min(butt["length_3d_mm"]) == pytest.approx(KNUCKLE - 5000.0 / 3.0, rel=1e-3)


def test_faces_that_run_beside_each_other_too_far_apart_are_listed_apart(knuckles):
    """The bilge raised 30 mm (six fit tolerances): the trim and the bilge's edge still run
    along each other, so the two pairs are listed apart with a warning, not dropped."""
    shell = knuckles[30.0]["shell"]
    assert not [p for p in shell["pairs"] if p["kind"] == "trim"]
    apart = [p for p in shell["apart"] if p["kind"] == "trim"]
    assert len(apart) == 2 and all(p["step_median_mm"] == pytest.approx(30.0, abs=0.5) for p in apart)
    assert sum("their faces run beside each other but their edges lie 30 mm apart" in w for w in shell["warnings"]) == 2


def test_a_trim_cut_straight_across_a_plate_is_its_trim_edge():
    """A cut outline with no vertex of its own along the trim (a straight cut from one side of
    the region to the other) still has its TRIM edge, end to end."""
    from pipeline.hull.fitup import _TrimCut

    x, y = np.meshgrid(np.linspace(0.0, 2000.0, 3), np.linspace(0.0, 2000.0, 3), indexing="ij")
    placed = np.column_stack([x.ravel(), y.ravel()])
    v3 = np.column_stack([placed, np.zeros(9)])
    outline = np.array([[0.0, 0.0], [2000.0, 0.0], [2000.0, 1200.0], [0.0, 1200.0]])
    edge = _TrimCut(v3, placed, (3, 3), outline).edge
    assert edge is not None and edge.side == "trim"
    assert np.allclose(edge.points3[:, 1], 1200.0) and np.allclose(edge.points3[:, 2], 0.0)
    assert sorted(edge.points3[[0, -1], 0]) == pytest.approx([0.0, 2000.0])


def test_a_trim_loop_along_the_regions_side_keeps_the_sides_grid_points():
    """A trim loop that runs along the region's side (a face's own edge), a round-off off it,
    cuts a formed plate along its developed side through the side's grid points, not straight
    across between the loop's corners (KVLCC2's 33 mm leftover, formed: its seam was cut as a
    chord and taken for its TRIM edge)."""
    from types import SimpleNamespace

    from shapely.geometry import Polygon

    from flatten.patch import grid_triangles
    from pipeline.hull.fitup import _TrimCut
    from pipeline.hull.trimcut import cut_at_trim

    trim = SimpleNamespace(polygon=lambda *box: Polygon([(0.0, 1e-12), (4.0, 1e-12), (4.0, 1.0)]),
                           inside=lambda u, v: v <= u / 4.0)
    u, v = np.meshgrid(np.linspace(0.0, 4.0, 5), np.linspace(0.0, 1.0, 3), indexing="ij")
    params = np.stack([u, v], axis=-1)
    placed = np.column_stack([1000.0 * u.ravel(), 1000.0 * v.ravel() + 100.0 * u.ravel() ** 2])  # a curved side
    cut = cut_at_trim(trim, params, placed, grid_triangles(5, 3))
    side = placed.reshape(5, 3, 2)[:, 0]
    assert all(np.linalg.norm(cut.outline - p, axis=1).min() < 1e-6 for p in side)
    v3 = np.column_stack([placed, np.zeros(15)])
    edge = _TrimCut(v3, placed, (5, 3), cut.outline).edge
    assert len(edge.points2) == 2  # the diagonal, corner to corner: none of the side
    assert sorted(map(tuple, np.round(edge.points2, 6))) == [(0.0, 0.0), (4000.0, 2600.0)]


def test_a_gap_at_the_knuckle_is_a_misfit_at_the_trim(knuckles):
    """The bilge raised 4 mm off the bottom: the same pairs, each stepping by the gap, over
    the limit of 0.15 t = 1.8 mm."""
    trims = [p for p in knuckles[4.0]["shell"]["pairs"] if p["kind"] == "trim"]
    assert len(trims) == 2
    for pair in trims:
        assert pair["step_median_mm"] == pytest.approx(4.0, abs=0.1)
        assert pair["misfit"] and pair["step_limit_mm"] == pytest.approx(1.8)
    warnings = knuckles[4.0]["shell"]["warnings"]
    assert sum(w.startswith("fit-up: trim TRIM between") for w in warnings) == 2


def test_two_faces_that_meet_along_their_own_edges_pair_their_plates_there(knuckles):
    """A bottom face that ends at y = 3 m untrimmed: its outer strake's plates meet the bilge's
    first strake along the knuckle (kind face, each edge named on both plates), exactly."""
    shell = knuckles["untrimmed"]["shell"]
    faces = [p for p in shell["pairs"] if p["kind"] == "face"]
    assert shell["faces"] == len(faces) == 2 and shell["trims"] == 0, faces
    for pair in faces:
        assert "_P1_" in pair["plates"][0] and "_P2_S01_" in pair["plates"][1]
        assert pair["edge"].startswith("SEAM") and " | SEAM" in pair["edge"]
        assert min(pair["length_3d_mm"]) == pytest.approx(6000.0, rel=1e-3)
        assert pair["step_max_mm"] < 0.1 and pair["mismatch_mm"] < 0.1
    assert not any(p["kind"] == "face" for p in knuckles[0.0]["shell"]["pairs"])  # the trim names those


def test_a_point_a_round_off_outside_the_grid_takes_the_value_on_its_edge():
    """A corner where a trim meets a plate's boundary lies on the grid's edge, and round-off
    can put it a hair outside: it takes the linear value there, not the nearest grid point's
    (half a cell away: 80 mm on a KCS bottom plate)."""
    u, v = np.meshgrid(np.linspace(0.0, 3.0, 4), np.linspace(0.0, 2.0, 3), indexing="ij")
    params = np.column_stack([u.ravel(), v.ravel()])
    idx = np.arange(12).reshape(4, 3)
    a, b, d, e = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.column_stack([a, b, e]), np.column_stack([a, e, d])])
    values = np.column_stack([2.0 * params[:, 0] + 3.0 * params[:, 1], params[:, 1] ** 2])
    query = np.array([[3.0 + 1e-12, 0.7], [1.3, -1e-13], [1.5, 1.0]])
    got = grid_map(params, faces, values, query)
    assert got[:, 0] == pytest.approx(2.0 * query[:, 0] + 3.0 * query[:, 1], abs=1e-9)
    assert got[0, 1] == pytest.approx(0.7, abs=1e-9)  # linear between v = 0 (0) and v = 1 (1)


def _plate(name: str, surface: object, side: str, points3: np.ndarray):
    """A fit-up record of a flat plate with one edge (its development: x, y of the points)."""
    from types import SimpleNamespace

    from pipeline.hull.fitup import Edge, PlateEdges

    edge = Edge(side, "TRIM" if side == "trim" else "BUTT X960", points3, points3[:, :2].copy())
    hull = SimpleNamespace(surface=surface, fit_tolerance=5.0, girths=None, butts=(None, None))
    return name, (PlateEdges(name, "flat", True, (edge,), points3), SimpleNamespace(hull=hull))


@pytest.mark.parametrize(("end", "paired"), [((1000.0, 4.0, 0.0), True), ((960.0, 30.0, 0.0), False)])
def test_an_edge_that_rises_from_a_trim_line_at_its_end_is_no_pair(end, paired):
    """A TRIM edge along x from 0 to 1000 mm and an edge of another face's plate: one running
    beside it 4 mm off over its whole length is its neighbour; one that rises from its end at
    an angle (a butt of the next face: about 14 mm median over a 40 mm common part, within
    five fit tolerances) is not."""
    from pipeline.hull.fitup import shared_edges

    t = np.linspace(0.0, 1.0, 51)[:, None]
    trim = np.hstack([1000.0 * t, np.zeros((51, 2))])
    start = np.array([0.0, 4.0, 0.0]) if paired else np.array([1000.0, 0.0, 0.0])
    other = start + t * (np.array(end) - start)
    records = dict([_plate("bottom", object(), "trim", trim), _plate("side", object(), "butt0", other)])
    pairs, apart = shared_edges(records, 1.0, 12.0)
    assert not apart
    assert [(p.a, p.b, p.kind) for p in pairs] == ([("bottom", "side", "trim")] if paired else [])
    if paired:
        assert pairs[0].step_max == pytest.approx(4.0, abs=1e-6)
