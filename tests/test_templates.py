"""Templates of curved plates against closed forms and the hull's own sections."""

import json
from pathlib import Path

import ezdxf
import numpy as np
import pytest
import shapely
import yaml

from pipeline.cli import main

ROOT = Path(__file__).resolve().parents[1]
SHIP = ROOT / "tests" / "data" / "ship"


def _curve(c):
    return {"degree": c.degree, "control_points": c.control_points.tolist(), "weights": c.weights.tolist(),
            "knots": c.knots.tolist()}


def _write(tmp_path, data, name):
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _cylinder(tmp_path, radius=2000.0, angle=2 * np.pi / 3, height=1500.0, shop=None):
    from tests.oracles import circular_arc

    data = {"name": "cyl", "units": "mm", "resolution": {"rulings": 7}, "shop": shop or {},
            "curves": {"c": _curve(circular_arc(radius, 0.0, angle)),
                       "d": _curve(circular_arc(radius, height, angle, name="d"))}}
    return _write(tmp_path, data, "cyl")


def _all_templates(config_path, part_index=0):
    """Run one part in process and take every candidate section as a template (the
    geometry, whatever the count rule picks): (result, templates with sight lines)."""
    from pipeline.config import load_config
    from pipeline.shop.plate import plate_tracer, strip_templates
    from pipeline.stages import run_part

    config = load_config(config_path)
    result = run_part(config.parts[part_index], config)
    assert result.ok
    _, candidates = strip_templates(result, plate_tracer(result), config.mm_per_unit,
                                    result.shop.outline.points, "double", config.spec.shop)
    return result, candidates


def test_cylinder_sections_are_arcs_of_its_radius_and_it_gets_no_template(tmp_path):
    """A circular cylinder R 2000 mm, 120 degrees, 1500 mm high: its sections across the
    rulings (horizontal planes) are arcs of R 2000: every point 2000 mm from the axis
    (0.1 mm), the heights over the base line the sagitta of the arc; one radius, so the
    count rule gives none, and says why."""
    config = _cylinder(tmp_path)
    _, candidates = _all_templates(config)
    assert len(candidates) == 1  # ceil(1500 / 3500) planes, through the middle of the middle ruling
    for t in candidates:
        r = np.hypot(t.points[:, 0], t.points[:, 1])
        assert np.abs(r - 2000.0).max() <= 0.1
        assert np.ptp(t.points[:, 2]) <= 1e-6 and t.points[0, 2] == pytest.approx(750.0, abs=1e-6)
        half = 0.5 * t.length
        sagitta = np.sqrt(2000.0 ** 2 - (t.stations - half) ** 2) - np.sqrt(2000.0 ** 2 - half ** 2)
        assert np.abs(t.heights - sagitta).max() <= 0.1
        assert np.all(np.diff(t.stations)[:-1] == pytest.approx(250.0))
        # ends 100 mm inside the plate: the arc's ends lie 100 mm (along the arc) from the butts
        azimuth = np.sort(np.arctan2(t.points[[0, -1], 1], t.points[[0, -1], 0]))
        assert azimuth * 2000.0 == pytest.approx([100.0, 2000.0 * 2 * np.pi / 3 - 100.0], abs=0.05)
    out = tmp_path / "o"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    rep = json.loads((out / "cyl.json").read_text())["templates"]
    assert rep["count"] == 0 and "one radius" in rep["rule"]
    assert rep["candidate_sections"][0]["arc_radius"] == pytest.approx(2000.0, abs=0.1)
    assert rep["candidate_sections"][0]["arc_deviation"] <= 0.1
    assert not (out / "cyl_templates.dxf").exists()
    lines = json.loads((out / "cyl.json").read_text())["bending"]["lines"]
    assert lines and all(line["checked_by"] == ["radius gauge"] for line in lines)


def test_cone_templates_vary_as_its_radius_does(tmp_path):
    """The frustum (configs/frustum.yaml: radii 3000 and 2000 mm, 1500 mm apart): sections
    square to its middle generator, at most 600 mm apart. Every template point lies on the exact
    cone (0.1 mm); each section's curvature where it crosses the middle generator is the
    cone's normal curvature across it, cos(alpha) / r (Meusnier), r the distance from the
    axis there: the templates vary as the radius does. The count rule gives one template
    (varying radius), written to the DXF with its heights."""
    data = yaml.safe_load((ROOT / "configs" / "frustum.yaml").read_text())
    data["shop"] = {"template_spacing": 600}
    config = _write(tmp_path, data, "frustum")
    _, candidates = _all_templates(config)
    assert len(candidates) == int(np.ceil(np.hypot(1000.0, 1500.0) / 600.0)) == 4
    cos_alpha = 1500.0 / np.hypot(1000.0, 1500.0)
    measured, expected = [], []
    for t in candidates:
        r_of_z = 3000.0 - 1000.0 * t.points[:, 2] / 1500.0
        assert np.abs(np.hypot(t.points[:, 0], t.points[:, 1]) - r_of_z).max() <= 0.1
        # where the section crosses the middle generator (azimuth 60 degrees)
        azimuth = np.arctan2(t.points[:, 1], t.points[:, 0])
        k = int(np.argmin(np.abs(azimuth - np.pi / 3)))
        r = float(np.hypot(*t.origin[:2]))
        near = np.linalg.norm(t.points - t.points[k], axis=1) <= 60.0
        from pipeline.shop.templates import circle_fit

        radius, _ = circle_fit(t.profile[near])
        measured.append(radius)
        expected.append(r / cos_alpha)
    assert np.allclose(measured, expected, rtol=5e-3)
    assert np.ptp(expected) > 0.2 * min(expected)  # they do vary: 2.4 to 3.4 m
    out = tmp_path / "o"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 0
    rep = json.loads((out / "frustum.json").read_text())["templates"]
    assert rep["count"] == 1 and "varying radius" in rep["rule"]
    # the template runs across the rulings: it checks the bending lines it reaches (the
    # middle ones; its plane leaves the cone's end rulings), a gauge the others
    lines = json.loads((out / "frustum.json").read_text())["bending"]["lines"]
    checks = [line["checked_by"] for line in lines]
    assert len(lines) == 13 and checks[6] == ["T1"] and checks.count(["T1"]) >= 5
    assert all(c in (["T1"], ["radius gauge"]) for c in checks)
    doc = ezdxf.readfile(out / "frustum_templates.dxf")
    assert doc.dxfversion == "AC1015" and doc.header["$INSUNITS"] == 4 and not doc.audit().errors
    block = doc.blocks.get("TEMPLATE_T1")
    texts = [e.dxf.text for e in block.query("TEXT")]
    first = rep["templates"][0]
    assert [f"{h:.1f}" for h in first["heights"]] == [t for t in texts if not t.startswith("frustum")]
    assert any(t.startswith("frustum T1") for t in texts)
    cut = block.query("LWPOLYLINE[layer=='TEMPLATE_CUT']")[0]
    profile = np.array(cut.get_points("xy"))[:-2]
    assert profile[-1, 0] == pytest.approx(first["length"], abs=1e-6)
    # the sight line lies in one plane for every template: the plane's offset from each end
    assert all(h is not None and h < 0 for h in first["sight_line_heights"])


def _hull_section(surface, x, vs):
    """The hull surface's own section by the plane x = X: per v, the u where x(u, v) = X
    (bracketed on a grid, then brentq), (n, 3)."""
    from scipy.optimize import brentq

    (u0, u1) = surface.domain_u
    us = np.linspace(u0, u1, 65)
    grid_x = surface(np.repeat(us, len(vs)), np.tile(vs, len(us)))[:, 0].reshape(len(us), len(vs)) - x
    section = []
    for j, v in enumerate(vs):
        g = grid_x[:, j]
        k = np.flatnonzero(np.sign(g[:-1]) != np.sign(g[1:]))
        if len(k):
            u = brentq(lambda u: float(surface(np.array([u]), np.array([v]))[0, 0]) - x, us[k[0]], us[k[0] + 1],
                       xtol=1e-12)
            section.append(surface(np.array([u]), np.array([v]))[0])
    return np.array(section)


def _distance_to_polyline(points, line):
    a, b = line[:-1], line[1:]
    d = b - a
    w = np.clip(np.einsum("pkj,kj->pk", points[:, None, :] - a[None], d) / np.einsum("kj,kj->k", d, d), 0, 1)
    return np.linalg.norm(points[:, None, :] - (a[None] + w[..., None] * d[None]), axis=2).min(axis=1)


def _check_against_hull(templates, surface, vs, outline):
    """Every template on the hull's own frame section (0.5 mm), its ends 100 mm inside the
    plate; returns the largest distance."""
    ring = shapely.LinearRing(outline)
    worst = 0.0
    for t in templates:
        x = float(t.origin[0])
        assert np.abs(t.points[:, 0] - x).max() <= 1e-6
        dist = _distance_to_polyline(t.points, _hull_section(surface, x, vs))
        assert dist.max() <= 0.5, (t.name, dist.max())
        worst = max(worst, float(dist.max()))
        # both ends 100 mm inside the plate (on the flat plate: the development is isometric)
        ends = shapely.distance(shapely.points(t.flat[[0, -1]]), ring)
        assert np.allclose(ends, 100.0, atol=0.5) and t.length > 700.0
    return worst


def test_hull_plate_templates_are_the_hulls_own_frame_sections(tmp_path):
    """A plate of the 160 m hull (hullmod, seams v = 4.0 / 4.3, butts 88 / 104 m, frames
    every 2.5 m), delivered as a strip: each frame template of the strip lies within 0.5 mm
    of the hull surface's own section by the frame plane, computed here from the surface
    (x(u, v) = X solved per v), and its ends stay 100 mm inside the seams."""
    from pipeline.hull.plan import load_run
    from pipeline.hull.plates import run_part
    from pipeline.shop.plate import plate_tracer, strip_templates

    data = {"name": "hp", "units": "mm", "resolution": {"chord_tolerance": 1.0},
            "steel": {"thickness": 14, "material": "AH36"},
            "strake": {"surface": {"iges": str(SHIP / "test_1_hull_exported.igs")},
                       "seams": [{"iso": {"v": 4.0}}, {"iso": {"v": 4.3}}], "butts": [88000, 104000],
                       "frames": {"spacing": 2500}, "margin": 0.2, "fit_tolerance": 5.0}}
    plan = load_run(_write(tmp_path, data, "hp"))
    result = run_part(plan.parts[0], plan)
    assert result.ok and result.solution is not None
    _, templates = strip_templates(result, plate_tracer(result), plan.mm_per_unit, result.shop.outline.points,
                                   "double", plan.spec.shop)
    assert [t.name for t in templates] == [f"FR {x}" for x in range(90000, 104000, 2500)]
    worst = _check_against_hull(templates, result.part.hull.surface, np.linspace(3.95, 4.35, 401),
                                result.shop.outline.points)
    print(f"hull strip plate frame templates: largest distance to the hull's own section {worst:.3f} mm")


def test_formed_plate_gets_a_template_at_every_frame_on_the_hull(tmp_path):
    """A doubly curved plate of DTMB 5415 (ship scale, seams v = 2.0 / 2.4, butts 40 / 54 m,
    frames every 2.5 m; formed: no developable strip fits): the count rule gives a template
    at each of its 5 frames (at least 3), each on the hull's own section (0.5 mm), their
    sight lines in one plane; NAME_templates.dxf holds one block per template."""
    data = {"name": "dt", "units": "mm", "steel": {"thickness": 14, "material": "AH36"},
            "strake": {"surface": {"iges": str(SHIP / "ship_5415.igs"), "directory": 5},
                       "seams": [{"iso": {"v": 2.0}}, {"iso": {"v": 2.4}}], "butts": [40000.0, 54000.0],
                       "scale": 24.824, "frames": {"spacing": 2500}, "margin": 0.2}}
    from pipeline.hull.plan import load_run
    from pipeline.hull.plates import run_part

    plan = load_run(_write(tmp_path, data, "dt"))
    result = run_part(plan.parts[0], plan)
    assert result.ok and result.figures["plate_class"]["class"] == "formed"
    templates = result.templates
    assert [t.name for t in templates] == [f"FR {x}" for x in range(42500, 54000, 2500)]
    assert "double curvature" in result.figures["templates"]["rule"]
    outline = result.pattern.outline * plan.mm_per_unit
    worst = _check_against_hull(templates, result.part.hull.surface, np.linspace(1.95, 2.45, 401), outline)
    print(f"formed plate frame templates: largest distance to the hull's own section {worst:.3f} mm")
    # the sight lines' ends, back in 3D, lie in one plane
    ends = []
    for t in templates:
        e1 = (t.points[-1] - t.points[0]) / t.length
        e2 = np.cross(t.normal, e1)
        e2 *= np.sign(np.mean((t.points - t.points[0]) @ e2))
        ends += [t.points[0] + s * e1 + h * e2 for s, h in zip((0.0, t.length), t.sight)]
    ends = np.array(ends)
    _, sv, _ = np.linalg.svd(ends - ends.mean(axis=0))
    assert sv[-1] <= 1e-6 * sv[0]
    out = tmp_path / "o"
    assert main(["run", str(tmp_path / "dt.yaml"), "--out", str(out), "--quiet"]) == 0
    doc = ezdxf.readfile(out / "dt_S1_B1_templates.dxf")
    blocks = sorted(b.name for b in doc.blocks if b.name.startswith("TEMPLATE_"))
    assert blocks == [f"TEMPLATE_T{k}" for k in range(1, 6)]
    assert len(doc.modelspace().query("INSERT")) == 5 and not doc.audit().errors
