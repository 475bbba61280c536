"""Heating lines of formed plates (pipeline.shop.heating) and the workshop method.

Closed forms: a spherical cap's heating lines are radial and rotation-symmetric, as many
cross each circle as its required circumferential shrink asks; a cylinder (developable) gets
none; a dome is heated on the inside of its roll curvature, a saddle on the outside; the
workshop method scales the development so that every strain has one sign.
"""

import json

import numpy as np
import pytest
import yaml

from flatten.patchflat import arap_development, triangle_stretches
from pipeline.cli import main
from pipeline.shop.heating import LineModel, heating_lines, method_scale, principal_strains
from pipeline.shop.templates import grid_faces
from tests.hull_shapes import cylinder_sphere_iges

RADIUS, RIM = 10000.0, 1500.0  # the cap: sphere radius and geodesic radius of its rim, mm


def _cap(radius=RADIUS, rim=RIM, h=30.0):
    """A round spherical cap: rings of points every h mm of geodesic radius (Delaunay
    triangles in geodesic polar coordinates), vertices (V, 3) on the sphere about the origin."""
    from scipy.spatial import Delaunay

    pts = [[0.0, 0.0]]
    for r in np.arange(h, rim + 1e-9, h):
        n = int(np.ceil(2 * np.pi * r / h))
        th = np.arange(n) * 2 * np.pi / n
        pts += list(np.column_stack([r * np.cos(th), r * np.sin(th)]))
    ab = np.array(pts)
    faces = Delaunay(ab).simplices
    phi = np.linalg.norm(ab, axis=1) / radius
    th = np.arctan2(ab[:, 1], ab[:, 0])
    return np.column_stack([radius * np.sin(phi) * np.cos(th), radius * np.sin(phi) * np.sin(th),
                            radius * np.cos(phi)]), faces


def _developed(v, f, method):
    import igl

    uv, _ = arap_development(v, f)
    ps = principal_strains(v, uv, f)
    scale = method_scale(ps.strain, ps.valid, method)
    uv = uv * scale
    return uv, uv[igl.boundary_loop(f)], scale


@pytest.fixture(scope="module")
def cap():
    return _cap()


@pytest.mark.parametrize("method", ["none", "contraction"])
def test_spherical_cap_heating_lines_are_radial_and_rotation_symmetric(cap, method):
    """Every line radial (0.5 deg); the lines start on the rim inset by the margin, evenly
    round it (gaps within 2 %); the line length in each 45-degree sector within 15 % of
    the mean (the lines that stop early are levelled dyadically round the rim, and 54 or 85
    lines are no power of two: one sector may hold one long line more); and as many lines
    cross each circle as the required circumferential shrink there asks (2 pi r e / delta),
    within the factor sqrt(2) the spacing rule allows."""
    v, f = cap
    uv, ring, scale = _developed(v, f, method)
    model = LineModel(12.0)
    heat = heating_lines(v, uv, f, ring, model, method=method, scale=scale)
    c = ring.mean(axis=0)
    assert np.ptp(np.linalg.norm(ring - c, axis=1)) < 0.05  # the developed rim is a circle
    lines = heat.lines
    assert len(lines) >= 40 and heat.figures["lines"] == len(lines)
    for line in lines:
        chord, mid = line[-1] - line[0], 0.5 * (line[0] + line[-1]) - c
        cos = abs(chord @ mid) / np.linalg.norm(chord) / np.linalg.norm(mid)
        assert np.degrees(np.arccos(min(cos, 1.0))) <= 0.5
        # each line runs inwards from the rim, the margin inside it
        assert np.linalg.norm(line[0] - c) == pytest.approx(RIM * scale - 50.0, abs=2.5)
        assert np.linalg.norm(line[-1] - c) < np.linalg.norm(line[0] - c)
    angles = np.sort([np.arctan2(*(line[0] - c)[::-1]) for line in lines])
    gaps = np.diff(np.r_[angles, angles[0] + 2 * np.pi])
    assert gaps.max() / gaps.min() <= 1.02
    sector = np.zeros(8)
    for line in lines:
        mid = 0.5 * (line[1:] + line[:-1]) - c
        k = (np.arctan2(mid[:, 1], mid[:, 0]) % (2 * np.pi)) // (np.pi / 4)
        np.add.at(sector, k.astype(int), np.linalg.norm(np.diff(line, axis=0), axis=1))
    assert np.abs(sector / sector.mean() - 1).max() <= 0.15
    # the required shrink: circumferential (within 3 deg) and the same all round (sector
    # means of each 100 mm ring within 2e-5 of each other)
    ps = principal_strains(v, uv, f)
    centres = uv[f].mean(axis=1) - c
    r = np.linalg.norm(centres, axis=1)
    tangent = np.column_stack([-centres[:, 1], centres[:, 0]]) / r[:, None]
    need = ps.strain[:, 0] > 1e-3
    assert np.abs(np.einsum("ij,ij->i", ps.flat[need, 0], tangent[need])).min() >= np.cos(np.radians(3))
    ring_k, sector_k = (r // 100).astype(int), ((np.arctan2(centres[:, 1], centres[:, 0]) % (2 * np.pi)) //
                                                (np.pi / 4)).astype(int)
    for k in range(4, 15):
        means = [ps.strain[(ring_k == k) & (sector_k == s), 0].mean() for s in range(8)]
        assert np.ptp(means) <= 2e-5
    delta = model.per_line
    crossing_checked = 0
    for radius in (1000.0, 1200.0, 1400.0):
        e = ps.strain[np.abs(r - radius) < 30.0, 0].mean()
        if e <= 1.5e-3:
            continue
        wanted = 2 * np.pi * radius * e / max(delta, e * 100.0)
        crossing = sum(1 for line in lines if np.linalg.norm(line - c, axis=1).min() <= radius
                       <= np.linalg.norm(line - c, axis=1).max())
        assert wanted / np.sqrt(2) - 1 <= crossing <= wanted * np.sqrt(2) + 1
        crossing_checked += 1
    assert crossing_checked >= 1
    # the side: a dome, heated on its concave side, where the sphere's centre is; the drawn
    # side's normal is the face normal oriented as the flat triangle is (counter-clockwise up)
    p, q = uv[f], v[f]
    signed = np.sign((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                     - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    drawn_normal = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]) * signed[:, None]
    centre_on_drawn_side = np.mean(np.einsum("ij,ij->i", drawn_normal, -q.mean(axis=1)) > 0) > 0.5
    assert [g["shape"] for g in heat.groups] == ["dome"]
    assert heat.groups[0]["side"] == ("drawn" if centre_on_drawn_side else "other")
    assert heat.groups[0]["lines"] == len(lines)
    # a plate the caller found rollable keeps its figures and gets no line
    rolled = heating_lines(v, uv, f, ring, model, method=method, scale=scale, rollable=True)
    assert not rolled.lines and rolled.figures["max_required_strain"] == heat.figures["max_required_strain"] > 1e-3


def test_cylinder_plate_gets_no_heating_lines():
    """A developable (cylindrical) plate develops without strain: no heating line, whatever
    the workshop method (its scale stays within round-off of 1)."""
    R, n = 3000.0, (61, 31)
    th, y = np.meshgrid(np.linspace(-0.4, 0.4, n[0]), np.linspace(0.0, 1500.0, n[1]), indexing="ij")
    v = np.column_stack([R * np.sin(th).ravel(), y.ravel(), R * (1 - np.cos(th)).ravel()])
    f = grid_faces(*n)
    for method in ("none", "contraction", "expansion"):
        uv, ring, scale = _developed(v, f, method)
        heat = heating_lines(v, uv, f, ring, LineModel(12.0), method=method, scale=scale)
        assert abs(scale - 1.0) < 1e-4
        assert heat.figures["lines"] == 0 and not heat.lines
        assert heat.figures["max_required_strain"] == 0.0


def _quadric(longitudinal_sign):
    """z = -(x^2 / 2 R1) * sign - y^2 / (2 R2) on 3 m x 1.5 m: the transverse (roll) curvature
    the same, the longitudinal one of the given sign: +1 a dome, -1 a saddle."""
    n = (61, 31)
    x, y = np.meshgrid(np.linspace(-1500, 1500, n[0]), np.linspace(-750, 750, n[1]), indexing="ij")
    z = -longitudinal_sign * x ** 2 / (2 * 6000.0) - y ** 2 / (2 * 6000.0)
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()]), grid_faces(*n)


def test_dome_and_saddle_are_heated_on_opposite_sides():
    """Same roll curvature across the plate, longitudinal curvature of the other sign: the
    dome is heated at its long edges, the saddle in its middle; both lines run across the
    plate (they shrink it lengthwise); the dome on the inside of the roll (-z here, concave
    both ways), the saddle on the outside (+z, concave lengthwise)."""
    import shapely

    found = {}
    for sign, shape in ((1, "dome"), (-1, "saddle")):
        v, f = _quadric(sign)
        uv, ring, scale = _developed(v, f, "none")
        heat = heating_lines(v, uv, f, ring, LineModel(12.0), method="none")
        assert heat.lines and {g["shape"] for g in heat.groups} == {shape}
        sides = {g["side"] for g in heat.groups}
        assert len(sides) == 1
        # the plate's long axis in the flat: where x runs; lines across it
        axis = uv[60 * 31] - uv[0]  # vertex (i, j) is i * 31 + j: from x = -1500 to x = 1500
        p, q = uv[f], v[f]
        signed = np.sign((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                         - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
        drawn_z = np.sign(np.mean(np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])[:, 2] * signed))
        found[shape] = (sides.pop(), drawn_z)
        across = np.array([-axis[1], axis[0]]) / np.linalg.norm(axis)
        chords = np.array([line[-1] - line[0] for line in heat.lines])
        length = np.linalg.norm(chords, axis=1)
        across_share = length[np.abs(chords @ axis) / length / np.linalg.norm(axis) <= np.sin(np.radians(35))].sum()
        assert across_share >= 0.8 * length.sum()  # the line length running across (the rest: the dome's ends)
        # where: the line length's mean distance from the plate's edge, in plate widths
        edge = shapely.Polygon(ring).exterior
        pts = np.vstack([line for line in heat.lines])
        depth = np.mean([edge.distance(shapely.Point(p)) for p in pts]) / (np.ptp(ring @ across))
        # the dome shrinks its edges (7 % of a width in, measured), the saddle its middle (37 %)
        assert depth <= 0.15 if shape == "dome" else depth >= 0.3
    # the heated side as a z direction: the dome's -z, the saddle's +z
    heated = {shape: drawn_z if side == "drawn" else -drawn_z for shape, (side, drawn_z) in found.items()}
    assert heated == {"dome": -1.0, "saddle": 1.0}


def test_workshop_method_sets_the_sign_of_the_strain(cap):
    """(1 + e') = scale (1 + e) for every principal strain; contraction leaves the least
    strain at 0 and none below, expansion the largest at 0 and none above; none keeps them."""
    v, f = cap
    uv0, _ = arap_development(v, f)
    s0 = triangle_stretches(v, uv0, f)
    ps = principal_strains(v, uv0, f)
    assert np.allclose(ps.strain + 1.0, s0, atol=1e-12)
    assert s0[:, 1].min() < 1 - 1e-3 and s0[:, 0].max() > 1 + 1e-3  # the minimal-strain development: both signs
    for method in ("contraction", "expansion", "none"):
        scale = method_scale(ps.strain, ps.valid, method)
        s = triangle_stretches(v, uv0 * scale, f)
        assert np.allclose(s, scale * s0, rtol=1e-12)
        if method == "contraction":
            assert scale == pytest.approx(1 / s0[:, 1].min(), rel=1e-12) and (s - 1).min() >= -1e-12
        elif method == "expansion":
            assert scale == pytest.approx(1 / s0[:, 0].max(), rel=1e-12) and (s - 1).max() <= 1e-12
        else:
            assert scale == 1.0
    with pytest.raises(ValueError, match="workshop method 'shrink'"):
        method_scale(ps.strain, ps.valid, "shrink")


def test_line_model_numbers():
    """delta = alpha Q / (c rho h): 1.2e-5 x 2000 / (4.7e-3 x 10) = 0.5106 mm; a measured
    shrinkage replaces it."""
    assert LineModel(10.0, 2000.0).per_line == pytest.approx(1.2e-5 * 2000.0 / (4.7e-3 * 10.0), rel=1e-12)
    assert LineModel(10.0, 2000.0).per_line == pytest.approx(0.5106, abs=1e-4)
    assert LineModel(16.0, 3000.0).per_line == pytest.approx(1.5 * 10 / 16 * 0.51064, rel=1e-4)
    assert LineModel(10.0, 2000.0, measured=0.8).per_line == 0.8


def _sphere_plate(tmp_path, shop=None):
    iges = cylinder_sphere_iges(tmp_path / "cs.igs")
    data = {"name": "sph", "units": "mm", "steel": {"thickness": 12, "material": "AH36"},
            "strake": {"surface": {"iges": str(iges)}, "seams": [{"iso": {"v": 0.45}}, {"iso": {"v": 0.95}}],
                       "butts": [-1500.0, 1500.0], "fit_tolerance": 5.0, "frames": {"spacing": 700}},
            "output": {"png": False}}
    if shop:
        data["shop"] = shop
    path = tmp_path / "sph.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_formed_sphere_plate_heating_in_dxf_and_report(tmp_path):
    """A plate on a 10 m sphere (formed): its report's heating lines are the DXF's MARK_HEAT
    entities, inside the plate by the margin, with one text per group; contraction makes
    the plate larger by the reported scale (area by its square) and every strain >= 0;
    expansion smaller, every strain <= 0 and no heating line."""
    import ezdxf
    import shapely

    runs = {}
    for method in ("none", "contraction", "expansion"):
        (tmp_path / method).mkdir()
        path = _sphere_plate(tmp_path / method, {"workshop_method": method})
        out = tmp_path / method / "o"
        assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
        rep = json.loads((out / "sph_S1_B1.json").read_text())
        assert rep["plate_class"]["class"] == "formed"
        runs[method] = (rep, out / "sph_S1_B1.dxf")
    rep, dxf = runs["none"]
    heat = rep["heating"]
    assert heat["method"] == "none" and heat["development_scale"] == 1.0
    assert heat["lines"] >= 10 and heat["max_required_strain"] > 2e-3
    assert heat["model"]["shrinkage_per_line_mm"] == pytest.approx(1.2e-5 * 2000 / (4.7e-3 * 12), rel=1e-9)
    doc = ezdxf.readfile(dxf)
    msp = doc.modelspace()
    marks = [e for e in msp if e.dxf.layer == "MARK_HEAT" and e.dxftype() != "TEXT"]
    assert len(marks) == heat["lines"] == len(heat["polylines"])
    assert sum(len(g["text"]) > 0 for g in heat["groups"]) == len(heat["groups"]) >= 1
    texts = [t.dxf.text for t in msp.query("TEXT")]
    for g in heat["groups"]:
        assert g["text"] in texts and ("THIS SIDE" in g["text"] or "OTHER SIDE" in g["text"])
    # each group named beside its lines on the heat layer, clear of every other text
    labels = [t for t in msp.query("TEXT") if t.dxf.layer == "MARK_HEAT"]
    assert sorted(t.dxf.text for t in labels) == sorted(f"G{g['group']}" for g in heat["groups"])
    from pipeline.shop.layout import Text

    boxes = [Text("", t.dxf.text, tuple(t.dxf.align_point)[:2], t.dxf.height, t.dxf.rotation).box()
             for t in msp.query("TEXT")]
    for i, t in enumerate(msp.query("TEXT")):
        if t.dxf.layer == "MARK_HEAT":
            assert not any(boxes[i].intersects(b) for j, b in enumerate(boxes) if j != i)
            g = int(t.dxf.text[1:])
            own = [np.asarray(line) for line, k in zip(heat["polylines"], heat["line_group"]) if k == g]
            assert min(shapely.LineString(line).distance(boxes[i]) for line in own) <= 2 * t.dxf.height
    outline = shapely.Polygon(np.array(next(iter(msp.query("LWPOLYLINE[layer=='CUT_OUTER']"))).get_points("xy")))
    for e in marks:
        pts = (np.array([e.dxf.start, e.dxf.end])[:, :2] if e.dxftype() == "LINE"
               else np.array(e.get_points("xy")))
        assert shapely.contains_xy(outline, pts[:, 0], pts[:, 1]).all()
        assert min(outline.exterior.distance(shapely.Point(p)) for p in pts) >= heat["margin_mm"] - 1.0
    assert doc.layers.get("MARK_HEAT").color == 10
    # contraction and expansion: the development's scale, the strain's sign, the area
    for method, sign in (("contraction", 1), ("expansion", -1)):
        other = runs[method][0]
        scale = other["heating"]["development_scale"]
        assert (scale - 1.0) * sign > 1e-3
        assert other["area_m2"] == pytest.approx(rep["area_m2"] * scale ** 2, rel=1e-9)
        if sign > 0:
            assert other["strain"]["max_compress_strain"] >= -1e-9
            assert other["heating"]["lines"] >= heat["lines"]
        else:
            assert other["strain"]["max_stretch_strain"] <= 1e-9
            assert other["heating"]["lines"] == 0
            doc = ezdxf.readfile(runs[method][1])
            assert not [e for e in doc.modelspace() if e.dxf.layer == "MARK_HEAT"]


@pytest.mark.parametrize("field,value", [("workshop_method", "shrink"), ("heat_input", -5.0),
                                         ("heat_spacing", 5.0)])
def test_bad_heating_settings_exit_2(tmp_path, capsys, field, value):
    path = _sphere_plate(tmp_path, {field: value})
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and f"shop.{field}" in err and str(value) in err
    assert not (tmp_path / "o").exists()
