"""The plan's cost and the shell expansion drawing against closed forms and independent
computations: a strake of a circular cylinder of axis x (seams its generators, butts its
circular sections: every weld length and every girth is closed-form), a staggered (brick)
layout of flat plates for the shared-edge rule, and the 160 m hull's strake, whose girths are
measured again along its sections by root finding on each iso-curve."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.cli import main
from pipeline.hull.cost import PlateEdges, plan_line, weld_lengths
from tests.hull_shapes import cylinder_along_iges

ROOT = Path(__file__).resolve().parents[1]
SHIP = ROOT / "tests" / "data" / "ship"
R, ANGLE, LENGTH = 3000.0, 90.0, 20000.0
SEAMS = (0.0, 0.37, 1.0)
BUTTS = (5000.0, 10000.0, 15000.0)


def run(tmp_path, name, strake, png=True, quiet=True) -> Path:
    config = tmp_path / f"{name}.yaml"
    config.write_text(yaml.safe_dump({"name": name, "units": "mm", "resolution": {"chord_tolerance": 1.0},
                                      "output": {"png": png, "obj": False},
                                      "strake": dict({"margin": 0.2, "fit_tolerance": 5.0}, **strake)}))
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out)] + (["--quiet"] if quiet else [])) == 0
    return out


def dxf_plates(path: Path):
    """Plate outlines (by layer) and texts of the expansion DXF."""
    import ezdxf

    doc = ezdxf.readfile(path)
    assert doc.dxfversion == "AC1015" and doc.header["$INSUNITS"] == 4  # R2000, millimetres
    msp = doc.modelspace()
    outlines = [(e.dxf.layer, np.array([p[:2] for p in e.get_points()])) for e in msp.query("LWPOLYLINE")
                if e.closed]
    texts = [e.dxf.text for e in msp.query("TEXT")]
    return outlines, texts


@pytest.fixture(scope="module")
def cylinder(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cyl")
    iges = cylinder_along_iges(tmp / "c.igs", radius=R, angle_deg=ANGLE, length=LENGTH)
    out = run(tmp, "cyl", {"surface": {"iges": str(iges)}, "seams": [{"iso": {"v": v}} for v in SEAMS],
                           "butts": list(BUTTS), "frames": {"spacing": 2500.0}})
    return out


def theta_of(points: np.ndarray) -> np.ndarray:
    """The arc angle of points on the cylinder y = R sin t, z = R (1 - cos t)."""
    return np.arctan2(points[:, 1], R - points[:, 2])


def test_the_plan_cost_of_a_cylinder_strake_is_its_closed_form(cylinder):
    """Two strakes of two plates between x = 5 and 15 m: the interior seam is the generator
    between the strakes (10 m), the interior butt the whole quarter circle at x = 10 m
    (R pi / 2); the outer edge two generators and two quarter circles. The welds per m^2 are
    those over the 10 m x R pi / 2 shell; the narrowest plate is the lower strake, whose
    girth is R times the angle of its upper seam from the edge (read off its corners). The
    two strakes butt at one x: a cross joint, the only one."""
    summary = json.loads((cylinder / "cyl_summary.json").read_text())
    cost = summary["plan_cost"]
    arc = R * np.radians(ANGLE) / 1000.0  # m
    assert cost["plates"] == 4
    assert cost["seam_weld_m"] == pytest.approx(10.0, rel=1e-9)
    # the butts are polylines of 32 chords a quarter circle: relative chord error < 3e-5
    assert cost["butt_weld_m"] == pytest.approx(arc, rel=1e-4)
    assert cost["weld_m"] == pytest.approx(cost["seam_weld_m"] + cost["butt_weld_m"], rel=1e-12)
    assert cost["boundary_m"] == pytest.approx(20.0 + 2 * arc, rel=1e-4)
    assert cost["shell_area_m2"] == pytest.approx(10.0 * arc, rel=1e-3)
    assert cost["weld_per_m2"] == pytest.approx((10.0 + arc) / (10.0 * arc), rel=1e-3)
    corners = np.array(json.loads((cylinder / "cyl_S1_B1.json").read_text())["region"]["corners"])
    lower = R * (theta_of(corners).max() - theta_of(corners).min()) / 1000.0
    narrow = min(lower, arc - lower)
    assert cost["narrowest"]["width_m"] == pytest.approx(narrow, rel=1e-4)
    assert cost["narrowest"]["plate"].startswith("cyl_S1" if lower < arc - lower else "cyl_S2")
    assert cost["shares"]["strip"] == pytest.approx(1.0)  # a cylinder's plates are its strips
    assert sum(cost["shares"].values()) == pytest.approx(1.0)
    # both strakes butt at x = 10 m: the one cross joint, where the seam meets that butt
    (cross,) = cost["cross_joints"]
    assert cross["at"][0] == pytest.approx(10000.0) and sorted(cross["plates"]) == [
        f"cyl_S{i}_B{j}" for i in (1, 2) for j in (1, 2)]
    # on the interior seam: a corner of the lower strake's plate that is not on the edges
    assert np.linalg.norm(corners - cross["at"], axis=1).min() < 1e-6
    upper = json.loads((cylinder / "cyl_S2_B2.json").read_text())["region"]["corners"]
    span = theta_of(np.vstack([corners, upper]))
    assert span.min() + 1e-6 < theta_of(np.array([cross["at"]]))[0] < span.max() - 1e-6


def test_the_console_says_the_plans_cost_as_the_closed_form_gives_it(tmp_path, capsys):
    """The run's `plan:` line for the cylinder strake: 4 plates, 10 m of seam and a quarter
    circle of butt over the 10 m x R pi / 2 shell, the lower strake the narrowest (R times its
    upper seam's angle), every plate a strip, one cross joint; no stock planned, so nothing
    is said of plates narrower than it."""
    iges = cylinder_along_iges(tmp_path / "c.igs", radius=R, angle_deg=ANGLE, length=LENGTH)
    run(tmp_path, "cyl", {"surface": {"iges": str(iges)}, "seams": [{"iso": {"v": v}} for v in SEAMS],
                          "butts": list(BUTTS)}, png=False, quiet=False)
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("plan:"))
    said = re.fullmatch(r"plan: (\d+) plates, ([\d.]+) m of weld \(([\d.]+) m per m2 of shell\), narrowest ([\d.]+) m "
                        r"\((\S+)\), (\d+) cross joints?; strip ([\d.]+) %", line)
    assert said, line
    arc = R * np.radians(ANGLE) / 1000.0  # m
    # the lower strake's girth: R times the arc angle to the seam v = 0.37 of the rational
    # quadratic arc (weights 1, cos h, 1), which does not run evenly along the arc
    h, v = np.radians(ANGLE) / 2, SEAMS[1]
    basis = np.array([(1 - v) ** 2, 2 * v * (1 - v) * np.cos(h), v ** 2])
    y, z = basis @ [[-R * np.sin(h), R * (1 - np.cos(h))], [0.0, R - R / np.cos(h)],
                    [R * np.sin(h), R * (1 - np.cos(h))]] / basis.sum()
    girth = R * (np.arctan2(y, R - z) + h) / 1000.0
    lower = min(girth, arc - girth)
    assert int(said[1]) == 4
    assert abs(float(said[2]) - (10.0 + arc)) <= 0.05 + 1e-3  # three significant figures
    assert abs(float(said[3]) - (10.0 + arc) / (10.0 * arc)) <= 5e-4 + 1e-3
    assert abs(float(said[4]) - lower) <= 5e-3 + 1e-3 and said[5].startswith("cyl_S1")
    assert int(said[6]) == 1 and float(said[7]) == 100.0


def test_the_plan_line_keeps_three_figures_of_a_model_scale_plan():
    """A model's plan (DTMB 5415's strake at model scale: 39 mm of weld, plates 20 mm wide)
    is not said to have 0 m of weld; a ship's keeps whole metres."""
    cost = {"plates": 3, "weld_m": 0.03934, "weld_per_m2": 0.674, "narrowest": {"plate": "S1_B1", "width_m": 0.01962},
            "narrower_than_stock": [], "cross_joints": [], "shares": {"strip": 1.0}, "share_area_m2": {"strip": 0.058}}
    assert plan_line(cost).startswith("plan: 3 plates, 0.0393 m of weld (0.674 m per m2 of shell), narrowest 0.0196 m")
    ship = dict(cost, weld_m=2340.94, narrowest={"plate": "S1_B2", "width_m": 0.7559})
    assert plan_line(ship, 1000.0, 1.0).startswith("plan: 3 plates, 2341 m of weld (0.674 m per m2 of shell), "
                                                   "narrowest 0.756 m (S1_B2), none narrower than the stock's 1 m")


def test_the_expansion_draws_each_cylinder_plate_once_at_its_closed_form_girth(cylinder):
    """Girth along the section from the edge v = 0 to a point is R (t - t0), t its arc angle
    (from its 3D coordinates): every plate corner of the reports appears as an outline vertex
    at (x, R (t - t0)); the outlines fill x in [5, 15] m and girth in [0, R pi / 2]."""
    outlines, texts = dxf_plates(cylinder / "cyl_expansion.dxf")
    names = [f"cyl_S{i}_B{j}" for i in (1, 2) for j in (1, 2)]
    assert sorted(t for t in texts if t.startswith("cyl_S")) == names  # each plate named once
    assert sum(t == "t 10" for t in texts) == 4  # its thickness (the default 10 mm)
    plates = [o for layer, o in outlines if layer.startswith("EXP_")]
    assert len(plates) == 4 and {layer for layer, _ in outlines} == {"EXP_STRIP"}
    t0 = -np.radians(ANGLE) / 2
    vertices = np.vstack(plates)
    for name in names:
        corners = np.array(json.loads((cylinder / f"{name}.json").read_text())["region"]["corners"])
        expected = np.column_stack([corners[:, 0], R * (theta_of(corners) - t0)])
        gap = np.linalg.norm(vertices[None, :, :] - expected[:, None, :], axis=2).min(axis=1)
        assert gap.max() < 0.05  # mm, on girths of up to 4.7 m
    assert vertices[:, 0].min() == pytest.approx(5000.0, abs=1e-6)
    assert vertices[:, 0].max() == pytest.approx(15000.0, abs=1e-6)
    assert vertices[:, 1].min() == pytest.approx(0.0, abs=1e-6)
    assert vertices[:, 1].max() == pytest.approx(R * np.radians(ANGLE), rel=1e-5)


def test_the_expansion_pdf_names_every_plate_and_states_its_scale(cylinder):
    import pdfplumber

    with pdfplumber.open(cylinder / "cyl_expansion.pdf") as pdf:
        assert len(pdf.pages) == 1
        page = pdf.pages[0]
        size_mm = sorted((page.width * 25.4 / 72, page.height * 25.4 / 72))
        assert size_mm == pytest.approx([594.0, 841.0], abs=0.5) or size_mm == pytest.approx([841.0, 1189.0], abs=0.5)
        text = page.extract_text()
        # words in the order the PDF writes them (each label one text object): small labels
        # of neighbouring plates would interleave in a layout-ordered reading
        words = [w["text"] for w in page.extract_words(use_text_flow=True)]
    for name in (f"cyl_S{i}_B{j}" for i in (1, 2) for j in (1, 2)):
        assert words.count(name) == 1
    assert "scale 1:" in text and "FR 4" in text  # frame 4 at x = 10 m


def square(x0, x1, y0, y1, n=9) -> np.ndarray:
    """A flat rectangular plate's region grid (n, 2n - 1, 3) in z = 0, rows along x."""
    x, y = np.meshgrid(np.linspace(x0, x1, 2 * n - 1), np.linspace(y0, y1, n))
    return np.stack([x, y, np.zeros_like(x)], axis=2)


def test_staggered_butts_weld_each_shared_piece_once():
    """A brick layout: strake 1 plates 10 m long, strake 2 offset by 5 m, both 3 m wide over
    x in [0, 20]: one 20 m seam between the strakes; butts: 1 in strake 1 and 2 in strake 2,
    each 3 m; the outer edge 2 x 20 m + 4 x 3 m."""
    plates = [square(0, 10, 0, 3), square(10, 20, 0, 3), square(0, 5, 3, 6), square(5, 15, 3, 6),
              square(15, 20, 3, 6)]
    edges = [PlateEdges(f"p{k}", p, np.zeros(p.shape[:2] + (2,))) for k, p in enumerate(plates)]
    weld = weld_lengths(edges)
    assert weld.seams == pytest.approx(20.0, rel=1e-12)
    assert weld.butts == pytest.approx(9.0, rel=1e-12)
    assert weld.boundary == pytest.approx(52.0, rel=1e-12)


@pytest.mark.parametrize("x_len, width", [(12.0, 3.0), (8.0, 2.5)])
def test_a_large_grid_of_plates_welds_the_grid_formula(x_len, width):
    """n x m plates of L x W: interior welds (n - 1) m L + n (m - 1) W over n m L W, which
    tends to (L + W) / (L W) (DESIGN.md §8)."""
    n, m = 6, 8
    edges = [PlateEdges(f"p{i}_{j}", square(j * x_len, (j + 1) * x_len, i * width, (i + 1) * width),
                        np.zeros((9, 17, 2))) for i in range(n) for j in range(m)]
    weld = weld_lengths(edges)
    interior = (n - 1) * m * x_len + n * (m - 1) * width
    assert weld.seams + weld.butts == pytest.approx(interior, rel=1e-12)
    per_m2 = interior / (n * m * x_len * width)
    assert per_m2 < (x_len + width) / (x_len * width) and per_m2 == pytest.approx(
        (x_len + width) / (x_len * width), rel=0.2)


def test_the_160m_hull_strake_girths_match_its_sections_measured_again(tmp_path):
    """hullmod's two strakes (seams v = 4.0, 4.3, 4.6; butts every 16 m): at each butt x = X
    the section is found again independently (brentq on x(u, v) = X along 1500 iso-v curves,
    its chord lengths summed from v = 0), and each plate outline's corner girths at X equal
    the girth of the seams there (21-24 m from the keel)."""
    from scipy.optimize import brentq

    from pipeline.hull.plan import load_run

    spec = yaml.safe_load((ROOT / "configs" / "hullmod_strake.yaml").read_text())
    strake = dict(spec["strake"], surface={"iges": str(SHIP / "test_1_hull_exported.igs"), "entity": 0})
    strake["butts"] = strake["butts"][1:4]  # two plates a strake, x = 72 .. 104 m
    out = run(tmp_path, "hm", strake, png=True)
    outlines, texts = dxf_plates(out / "hm_expansion.dxf")
    assert sorted(t for t in texts if t.startswith("hm_S")) == ["hm_S1_B1", "hm_S1_B2", "hm_S2_B1", "hm_S2_B2"]
    config = load_run(tmp_path / "hm.yaml")
    surface = config.parts[0].hull.surface
    vertices = np.vstack([o for _, o in outlines])
    v = np.linspace(0.0, 4.6, 1500)
    for X in strake["butts"]:
        pts = []
        for vv in v:
            u = brentq(lambda uu: surface(np.array([uu]), np.array([vv]))[0, 0] - X, *surface.domain_u, xtol=1e-12)
            pts.append(surface(np.array([u]), np.array([vv]))[0])
        girth = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        expected = np.interp([4.0, 4.3, 4.6], v, girth)
        at = vertices[np.abs(vertices[:, 0] - X) < 1e-6, 1]
        assert len(at)
        for g in expected:
            # measured 0.09-0.10 mm on girths of 21-24 m (the two chord samplings differ)
            assert np.abs(at - g).min() < 0.5
    import pdfplumber

    with pdfplumber.open(out / "hm_expansion.pdf") as pdf:
        words = [w["text"] for w in pdf.pages[0].extract_words(use_text_flow=True)]
    assert all(words.count(name) == 1 for name in ("hm_S1_B1", "hm_S1_B2", "hm_S2_B1", "hm_S2_B2"))
