"""Shop outputs of steel plates: allowances (cut line outside the net line), the one-page
shop drawing, physical tolerance defaults, and a hull plate whose ends are rulings."""

import json
from pathlib import Path

import ezdxf
import numpy as np
import pytest
import shapely
import yaml

from pipeline.shop.allowance import cut_outline
from pipeline.cli import main
from pipeline.config import load_config
from tests.shipped_configs import plain_uniform, with_files_from

ROOT = Path(__file__).resolve().parents[1]


def _polylines(path, layer):
    msp = ezdxf.readfile(path).modelspace()
    return [np.array([p[:2] for p in e.get_points("xy")]) for e in msp.query(f"LWPOLYLINE[layer=='{layer}']")]


def _rectangle(w, h, per_side=5):
    """A w x h rectangle traced as the outline code does: c along the bottom, the end
    ruling up the right, d backwards along the top, the start ruling down the left."""
    xs = np.linspace(0.0, w, per_side + 1)
    points = np.vstack([np.column_stack([xs[:-1], np.zeros(per_side)]), [[w, 0.0]],
                        np.column_stack([xs[::-1][:-1], np.full(per_side, h)]), [[0.0, h]]])
    edges = ("c",) * per_side + ("end",) + ("d",) * per_side + ("start",)
    return points, edges


@pytest.mark.parametrize("allowance", [{"c": 10, "d": 20, "start": 30, "end": 40}, {"c": 0, "d": 5, "end": 12.5},
                                       {"start": 7}])
def test_allowance_on_a_rectangle_is_the_rectangle_grown_edge_by_edge(allowance):
    """Closed form: each side moves out by its own allowance, the corners mitred."""
    w, h = 3000.0, 1500.0
    points, edges = _rectangle(w, h)
    cut = cut_outline(points, edges, allowance)
    a = {k: allowance.get(k, 0.0) for k in ("c", "d", "start", "end")}
    expected = shapely.box(-a["start"], -a["c"], w + a["end"], h + a["d"])
    assert shapely.Polygon(cut).symmetric_difference(expected).area <= 1e-9 * expected.area
    assert len(cut) == 4  # the corners only: no vertex left where two buffers meet
    assert cut_outline(points, edges, {"c": 0, "d": 0}) is points


def _cylinder(tmp_path, shop, name="cyl"):
    from tests.oracles import circular_arc

    def curve(c):
        return {"degree": c.degree, "control_points": c.control_points.tolist(), "weights": c.weights.tolist(),
                "knots": c.knots.tolist()}

    c = circular_arc(2000.0, 0.0, 2 * np.pi / 3)
    d = circular_arc(2000.0, 1500.0, 2 * np.pi / 3, name="d")
    data = {"name": name, "units": "mm", "curves": {"c": curve(c), "d": curve(d)}, "resolution": {"rulings": 7},
            "shop": shop}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_cylinder_plate_cut_with_its_allowances(tmp_path):
    """A cylinder R 2000, 120 degrees, 1500 high develops to a 4188.79 x 1500 rectangle:
    with 10 + 2 mm on c, 2 on d, 30 + 2 on start and end, the cut line is that rectangle
    grown so, the net line is on MARK_NET, and the report and part data state it."""
    shop = {"excess": {"c": 10, "start": 30, "end": 30}, "shrinkage": 2}
    out = tmp_path / "o"
    assert main(["run", str(_cylinder(tmp_path, shop)), "--out", str(out), "--quiet"]) == 0
    [cut] = _polylines(out / "cyl.dxf", "CUT_OUTER")
    [net] = _polylines(out / "cyl.dxf", "MARK_NET")
    arc = 2000.0 * 2 * np.pi / 3
    net_poly, cut_poly = shapely.Polygon(net), shapely.Polygon(cut)
    assert net_poly.area == pytest.approx(arc * 1500.0, rel=1e-5)
    # the rectangle's sides: c at the bottom (the pattern puts the c chord along +x)
    x0, y0, x1, y1 = net_poly.bounds
    assert (x1 - x0, y1 - y0) == (pytest.approx(arc, rel=1e-5), pytest.approx(1500.0, rel=1e-9))
    expected = shapely.box(x0 - 32, y0 - 12, x1 + 32, y1 + 2)
    assert cut_poly.is_valid and cut_poly.contains(net_poly)
    assert cut_poly.symmetric_difference(expected).area <= 2e-5 * expected.area
    rep = json.loads((out / "cyl.json").read_text())
    allowance = rep["outline"]["allowance"]
    assert allowance["total"] == {"c": 12.0, "d": 2.0, "start": 32.0, "end": 32.0} and allowance["units"] == "mm"
    assert allowance["excess"]["c"] == 10 and allowance["shrinkage"]["d"] == 2
    assert allowance["cut_area_m2"] == pytest.approx(expected.area / 1e6, rel=2e-5)
    # area and weight stay the net plate's
    assert rep["area_m2"] == pytest.approx(net_poly.area / 1e6, rel=1e-9)
    texts = [t.dxf.text for t in ezdxf.readfile(out / "cyl.dxf").modelspace().query("TEXT[layer=='MARK_TEXT']")]
    assert "ALLOWANCE MM C 12, D 2, START 32, END 32" in texts
    # the stock check holds the cut plate, not the net one
    assert max(rep["stock"]["part_rectangle"]) == pytest.approx(arc + 64, rel=1e-5)


def test_allowance_on_a_real_plate_is_the_net_outline_buffered(tmp_path):
    """configs/plate.yaml (a curved bilge plate): one allowance all round gives shapely's
    mitred buffer of the net outline; per edge, every net vertex away from the corners
    lies its own edge's allowance inside the cut line."""
    base = yaml.safe_load((ROOT / "configs" / "plate.yaml").read_text())
    outlines = {}
    for key, shop in (("zero", {"excess": 0}), ("none", {}), ("all", {"excess": 15}),
                      ("edges", {"excess": {"c": 5, "d": 25, "start": 40, "end": 0}})):
        data = dict(base, shop=shop) if shop else base
        config = tmp_path / f"{key}.yaml"
        config.write_text(yaml.safe_dump(data))
        out = tmp_path / key
        assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
        outlines[key] = (_polylines(out / "bilge_plate.dxf", "CUT_OUTER")[0], _polylines(out / "bilge_plate.dxf", "MARK_NET"),
                         json.loads((out / "bilge_plate.json").read_text()))
    # zero allowance: today's output, no net line
    zero, none = ezdxf.readfile(tmp_path / "zero" / "bilge_plate.dxf"), ezdxf.readfile(tmp_path / "none" / "bilge_plate.dxf")
    assert [(e.dxftype(), e.dxf.layer) for e in zero.modelspace()] == [(e.dxftype(), e.dxf.layer) for e in none.modelspace()]
    assert np.array_equal(outlines["zero"][0], outlines["none"][0]) and outlines["zero"][1] == []
    assert "allowance" not in outlines["zero"][2]["outline"]
    net = shapely.Polygon(outlines["none"][0])
    cut, [net_line], _ = outlines["all"]
    assert np.allclose(net_line, outlines["none"][0])
    buffered = net.buffer(15.0, join_style="mitre", mitre_limit=10.0)
    assert shapely.Polygon(cut).symmetric_difference(buffered).area <= 1e-6 * net.area
    cut, [net_line], rep = outlines["edges"]
    ring = shapely.LinearRing(cut)
    widths = rep["outline"]["allowance"]["total"]
    from pipeline.shop.allowance import edge_runs

    # the per-segment edge names of the net line (the exact outline of the run without allowance)
    edges = _edge_names_of(tmp_path / "none" / "bilge_plate.json", len(net_line))
    for name, segs in edge_runs(edges):
        inner = net_line[segs[1:]] if len(segs) > 2 else net_line[segs[:1]]
        keep = np.min([np.linalg.norm(inner - net_line[segs[0]], axis=1),
                       np.linalg.norm(inner - net_line[(segs[-1] + 1) % len(net_line)], axis=1)], axis=0) > 100.0
        if not keep.any():
            continue
        distance = shapely.distance(shapely.points(inner[keep]), ring)
        # a mitre at a vertex of a convex curved edge lies a / cos(turn / 2) out: 1e-4 mm here
        assert distance == pytest.approx(np.full(keep.sum(), widths[name]), abs=1e-3), name
    assert shapely.Polygon(cut).is_valid and shapely.Polygon(cut).contains(net)


def _edge_names_of(report_path, n):
    """Per-segment edge names of an outline traced c, end, d backwards, start (the run
    lengths from the report's edge counts)."""
    counts = json.loads(report_path.read_text())["outline"]["edges"]
    edges = ("c",) * counts["c"] + ("end",) * counts["end"] + ("d",) * counts["d"] + ("start",) * counts["start"]
    assert len(edges) == n
    return edges


def test_shop_drawing_is_one_page_to_scale_with_numbered_bending_lines(tmp_path):
    """The cylinder plate's drawing: one landscape A4/A3 page, its stated scale measured
    on the drawn cut line against the plate, every bending line's number on it."""
    pdfplumber = pytest.importorskip("pdfplumber")
    out = tmp_path / "o"
    # no allowance: the cut line keeps the traced outline's vertices (an allowance's cut
    # line on this rectangle is its 4 corners, a path pdfplumber reports as a rectangle)
    assert main(["run", str(_cylinder(tmp_path, {})), "--out", str(out), "--quiet"]) == 0
    rep = json.loads((out / "cyl.json").read_text())
    [drawing] = rep["layout"]["drawings"]
    assert drawing["file"] == "cyl_drawing.pdf" and "cyl_drawing.pdf" in rep["files"]
    paper = {"A4 landscape": (297.0, 210.0), "A3 landscape": (420.0, 297.0)}[drawing["paper"]]
    scale = int(drawing["scale"].split(":")[1])
    [cut] = _polylines(out / "cyl.dxf", "CUT_OUTER")
    with pdfplumber.open(out / "cyl_drawing.pdf") as pdf:
        assert len(pdf.pages) == 1
        page = pdf.pages[0]
        mm = 25.4 / 72.0
        assert (page.width * mm, page.height * mm) == (pytest.approx(paper[0], abs=0.5), pytest.approx(paper[1], abs=0.5))
        words = {w["text"] for w in page.extract_words()}
        # the cut line is the drawn path with as many points as the DXF's (closed once more)
        paths = [c for c in page.curves + page.rects + page.lines if len(c.get("pts", [])) == len(cut) + 1]
        assert paths
        pts = np.array(paths[0]["pts"], dtype=float)
    n = rep["bending"]["count"]
    assert n >= 2 and {f"B{k}" for k in range(1, n + 1)} <= words
    assert f"1:{scale}" in words and "400" in words
    # the plate's extent on the paper, in mm, times the scale: the plate
    extent = np.ptp(pts, axis=0) * mm * scale
    assert extent == pytest.approx(np.ptp(cut, axis=0), rel=2e-3)
    assert f"{np.ptp(cut[:, 0]):.0f}" in words and f"{np.ptp(cut[:, 1]):.0f}" in words
    # a drawing fits its sheet: the smallest standard scale that does
    assert np.all(np.ptp(cut, axis=0) / scale < np.array(paper))


def test_drawing_follows_the_previews_for_runs_of_several_parts(tmp_path):
    """The drawing follows the previews switch (output.png) unless output.drawing says."""
    base = yaml.safe_load((ROOT / "configs" / "plate.yaml").read_text())
    curves = base.pop("curves")
    name = base.pop("name")
    data = dict(base, parts=[{"name": f"{name}_a", "curves": curves}, {"name": f"{name}_b", "curves": curves}],
                output={"png": False})
    config = tmp_path / "two.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    assert not list((tmp_path / "o").glob("*.pdf"))
    data["output"]["drawing"] = True
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "p"), "--quiet"]) == 0
    assert sorted(p.name for p in (tmp_path / "p").glob("*.pdf")) == ["bilge_plate_a_drawing.pdf",
                                                                        "bilge_plate_b_drawing.pdf"]


def _points_plate(units: str) -> dict:
    """configs/plate.yaml's seams given as offsets (60 points each), in mm or m, without
    tolerances: the defaults must be the same physical ones."""
    from flatten import nurbs_curve

    base = yaml.safe_load((ROOT / "configs" / "plate.yaml").read_text())
    factor = {"mm": 1.0, "m": 1e-3}[units]
    curves = {}
    for key in ("c", "d"):
        spec = base["curves"][key]
        curve = nurbs_curve(np.array(spec["control_points"], dtype=float), spec["degree"])
        pts = curve(np.linspace(*curve.domain, 60)) * factor
        curves[key] = {"points": pts.tolist()}
    return {"name": "bilge_plate", "units": units, "curves": curves}


def test_tolerance_defaults_are_physical_whatever_the_units(tmp_path):
    """The same plate in mm and in m: fitted offsets, chord tolerance, rulings, outline
    and a strake's fit tolerance come out the same in mm."""
    reports = {}
    for units in ("mm", "m"):
        config = tmp_path / f"{units}.yaml"
        config.write_text(yaml.safe_dump(_points_plate(units)))
        assert main(["run", str(config), "--out", str(tmp_path / units), "--quiet"]) == 0
        reports[units] = json.loads((tmp_path / units / "bilge_plate.json").read_text())
    mm, m = reports["mm"], reports["m"]
    for key in ("curves.c", "curves.d"):
        assert mm["curve_fits"][key]["tolerance"] == pytest.approx(0.5)
        assert m["curve_fits"][key]["tolerance"] * 1000 == pytest.approx(0.5)
        assert mm["curve_fits"][key]["max_error"] <= 0.5 and m["curve_fits"][key]["max_error"] * 1000 <= 0.5
        assert m["curve_fits"][key]["control_points"] == mm["curve_fits"][key]["control_points"]
    assert m["resolution"]["count"] == mm["resolution"]["count"]
    assert m["area_m2"] == pytest.approx(mm["area_m2"], rel=1e-6)
    # IGES section, DXF polyline and strake fit tolerances: mm defaults converted
    for units, factor in (("mm", 1.0), ("m", 1000.0)):
        data = {"name": "s", "units": units,
                "strake": {"surface": {"iges": str(ROOT / "tests" / "data" / "ship" / "test_1_hull_exported.igs")},
                           "seams": [{"iso": {"v": 4.0}}, {"iso": {"v": 4.3}}], "butts": [72, 88]}}
        config = tmp_path / f"strake_{units}.yaml"
        config.write_text(yaml.safe_dump(data))
        assert load_config(config).spec.strake.fit_tolerance * factor == pytest.approx(5.0)
        data = {"name": "p", "units": units, "curves": {
            "c": {"iges": "x.igs", "section": {"point": [0, 0, 0], "normal": [0, 0, 1]}},
            "d": {"dxf": "x.dxf", "layer": "A"}}}
        from pipeline.config import RunSpec

        spec = RunSpec.model_validate(data)
        assert spec.curves.c.tolerance * factor == pytest.approx(0.5)
        assert spec.curves.d.tolerance * factor == pytest.approx(0.1)
        data["curves"]["c"]["tolerance"] = 2.0  # a given tolerance is in the config's units
        assert RunSpec.model_validate(data).curves.c.tolerance == 2.0


@pytest.fixture(scope="module")
def hull_end_plates(tmp_path_factory):
    """Plates S01_B10 and S01_B11 of configs/hull160_shell.yaml (the keel strake near the
    stern: its rulings run parallel to the butt planes, the plate ends are rulings lying
    in them). The uniform plan lays the same plates as the adaptive one, in seconds."""
    from pipeline.export import export_part
    from pipeline.hull.plates import run_plate

    tmp = tmp_path_factory.mktemp("hull")
    config = hull160_uniform(tmp)
    out = {}
    for name in ("hull160_S01_B10", "hull160_S01_B11"):
        part = next(p for p in config.parts if p.name == name)
        result = run_plate(part, config)
        assert result.ok, result.reason
        folder = tmp / name
        folder.mkdir()
        export_part(result, config, folder)
        out[name] = (folder, result)
    return out


@pytest.mark.parametrize("name", ["hull160_S01_B10", "hull160_S01_B11"])
def test_hull_plate_ending_on_rulings_has_a_simple_cut_outline(hull_end_plates, name):
    """The butt edges were traced back and forth along the ruling lying in the butt plane
    (a self-intersecting CUT_OUTER); now each edge is one run, each butt edge is the
    straight ruling of its own plane, as long as the plate's end is in 3D."""
    folder, result = hull_end_plates[name]
    [cut] = _polylines(folder / f"{name}.dxf", "CUT_OUTER")
    poly = shapely.Polygon(cut)
    assert poly.is_valid, shapely.is_valid_reason(poly)
    outline = result.shop.outline
    runs = [e for k, e in enumerate(outline.edges) if outline.edges[k - 1] != e]
    assert sorted(runs) == ["c", "d", "end", "start"]
    v3 = result.strip.vertices.reshape(result.strip.n_rulings, -1, 3)
    for key, plane in zip(("start", "end"), result.part.hull.butts):
        edge = outline.edge_points(key)
        # the 3D end of the plate on this plane: the trimmed strip's end ruling lying in it
        ends = [v for v in (v3[0], v3[-1]) if np.abs(plane.signed(v)).max() <= 1e-6]
        assert len(ends) == 1, key
        length_3d = np.linalg.norm(ends[0][-1] - ends[0][0])
        assert np.linalg.norm(edge[-1] - edge[0]) == pytest.approx(length_3d, rel=1e-6)
        assert np.linalg.norm(np.diff(edge, axis=0), axis=1).sum() == pytest.approx(length_3d, rel=1e-6)
    rep = json.loads((folder / f"{name}.json").read_text())
    assert rep["outline"]["max_deviation"] <= 0.05
    assert rep["area_m2"] == pytest.approx(rep["plate_class"]["area_3d_m2"], rel=1e-4)


def test_previews_true_aspect_legend_clear_and_sheet_at_one_scale(tmp_path):
    from pipeline.plots import flat_pattern_figure, sheet_layout, sheet_png

    # a long thin plate and a short one (mm)
    long_ = np.array([[0.0, 0.0], [12000.0, 0.0], [12000.0, 2500.0], [0.0, 2500.0]])
    short = np.array([[0.0, 0.0], [3000.0, 0.0], [3000.0, 1000.0], [0.0, 1000.0]])
    bends = np.array([[[1000.0, 0.0], [1000.0, 2500.0]]])
    fig = flat_pattern_figure(long_, bends, "plate", "mm")
    fig.canvas.draw()
    ax = fig.axes[0]
    box = ax.get_window_extent()
    # equal axes: one mm is as many pixels across as up
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert box.width / (x1 - x0) == pytest.approx(box.height / (y1 - y0), rel=1e-6)
    legend = ax.get_legend().get_window_extent()
    assert legend.y0 >= box.y1 - 1e-6  # above the axes, never over the part
    # the sheet: one scale for every plate, the largest fills its cell
    patterns = [("a", long_, bends), ("b", short, bends[:, :, :] * 0.25)]
    scale, outlines, _ = sheet_layout(patterns, cols=2)
    drawn = [np.ptp(o, axis=0) for o in outlines]
    assert drawn[0] / np.ptp(long_, axis=0) == pytest.approx([scale, scale])
    assert drawn[1] / np.ptp(short, axis=0) == pytest.approx([scale, scale])
    assert drawn[0][0] == pytest.approx(2.6 - 0.2)
    assert sheet_png(tmp_path / "s.png", patterns, "mm") == scale and (tmp_path / "s.png").stat().st_size > 0


def test_formed_plate_draws_its_shrink_and_stretch_areas(tmp_path):
    """hull160 S01_B01 (formed at the bow): each shrink / stretch region of its strain map
    is a closed outline on MARK_SHRINK / MARK_STRETCH whose area is the region's."""
    from pipeline.export import export_part
    from pipeline.hull.plates import run_plate

    config = hull160_uniform(tmp_path)
    part = next(p for p in config.parts if p.name == "hull160_S01_B01")
    result = run_plate(part, config)
    assert result.ok and result.figures["plate_class"]["class"] == "formed"
    export_part(result, config, tmp_path)
    rep = json.loads((tmp_path / "hull160_S01_B01.json").read_text())
    regions = rep["strain"]["regions"]
    [cut] = _polylines(tmp_path / "hull160_S01_B01.dxf", "CUT_OUTER")
    plate = shapely.Polygon(cut)
    for kind, layer in (("shrink", "MARK_SHRINK"), ("stretch", "MARK_STRETCH")):
        expected = [r for r in regions if r["kind"] == kind]
        rings = _polylines(tmp_path / "hull160_S01_B01.dxf", layer)
        assert len(rings) == len(expected) == rep["layout"][f"{kind}_areas"]
        flat_area = sum(shapely.Polygon(r).area for r in rings) / 1e6
        # the regions' areas are 3D (hull) areas: a formed plate's strain is ~1e-3
        assert flat_area == pytest.approx(sum(r["area_m2"] for r in expected), rel=5e-3)
        for ring in rings:
            assert shapely.Polygon(ring).is_valid and plate.buffer(1e-6).contains(shapely.Polygon(ring))
    assert rep["strain"]["shrink_area_m2"] > 0 and rep["strain"]["stretch_area_m2"] > 0


def test_strake_plate_figures_describe_the_trimmed_plate(hull_end_plates):
    """mesh / unroll of a hull plate: the trimmed plate of the OBJ and DXF (the extended
    strip's figures kept beside): the mesh's 3D area is the plate's, the flat c and d
    edges as long as the seams between the butts."""
    from pipeline.io.meshio import read_obj

    for name, (folder, result) in hull_end_plates.items():
        rep = json.loads((folder / f"{name}.json").read_text())
        v, vt, faces = read_obj(folder / f"{name}.obj")
        assert rep["mesh"]["vertices"] == len(v) and rep["mesh"]["faces"] == len(faces)
        assert rep["mesh"]["area_3d"] / 1e6 == pytest.approx(rep["plate_class"]["area_3d_m2"], rel=1e-3)
        assert rep["mesh"]["extended_strip"]["area_3d"] > 1.2 * rep["mesh"]["area_3d"]
        unroll = rep["unroll"]
        # mesh triangles across skew quads: O(h^2) chord effects, not an error of the development
        assert unroll["area_ratio"] == pytest.approx(1.0, abs=1e-5)
        assert unroll["ruling_edge_max_relative_error"] < 1e-9
        for key in ("c", "d"):
            assert abs(unroll[f"boundary_error_{key}_mm_per_m"]) < 0.01
        assert unroll["area_flat"] / 1e6 == pytest.approx(rep["area_m2"], rel=1e-3)


def hull160_uniform(folder: Path):
    """The 160 m hull's shell config with the uniform layout, planned (no plate run)."""
    from pipeline.hull.plan import load_run

    data = plain_uniform(yaml.safe_load((ROOT / "configs" / "hull160_shell.yaml").read_text()))
    data = with_files_from(data, ROOT / "configs")
    config_path = folder / "hull.yaml"
    config_path.write_text(yaml.safe_dump(data))
    return load_run(config_path)
