"""Waterlines and decks on the shell expansion, against closed forms and independent sections:
a circular cylinder of axis x (a bilge: every level crosses each section twice, at girths
R (t0 +- acos(1 - h / R))), a sheer deck rising along it, a deck at the top of both its
edges and one above the shell; the 160 m hull's waterlines and deck line against its own
station curves (Orca3D's sections of the same hull, a file the surface was not made from
here), and bad deck input."""

from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.cli import main
from pipeline.hull.levels import crossings
from tests.hull_shapes import cylinder_along_iges

ROOT = Path(__file__).resolve().parents[1]
SHIP = ROOT / "tests" / "data" / "ship"
R, ANGLE, LENGTH = 3000.0, 90.0, 20000.0
TOP = R * (1.0 - np.cos(np.radians(ANGLE) / 2))  # both edges' height, 878.68 mm
SHEER = ((5000.0, 300.0), (15000.0, 700.0))


def write_config(tmp_path: Path, name: str, strake: dict) -> Path:
    config = tmp_path / f"{name}.yaml"
    config.write_text(yaml.safe_dump({"name": name, "units": "mm", "resolution": {"chord_tolerance": 1.0},
                                      "output": {"png": True, "obj": False},
                                      "strake": dict({"margin": 0.2, "fit_tolerance": 5.0}, **strake)}))
    return config


def levels_of(path: Path) -> dict:
    """{layer: [(M, 2) polylines]} and the texts of the expansion DXF's waterline and deck layers."""
    import ezdxf

    msp = ezdxf.readfile(path).modelspace()
    lines = {}
    for e in msp.query("LWPOLYLINE"):
        if e.dxf.layer in ("EXP_WATERLINES", "EXP_DWL", "EXP_DECKS"):
            lines.setdefault(e.dxf.layer, []).append(np.array([p[:2] for p in e.get_points()]))
    texts = [(e.dxf.layer, e.dxf.text) for e in msp.query("TEXT")]
    return lines, texts


@pytest.fixture(scope="module")
def bilge(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bilge")
    iges = cylinder_along_iges(tmp / "c.igs", radius=R, angle_deg=ANGLE, length=LENGTH)
    strake = {"surface": {"iges": str(iges)}, "seams": [{"iso": {"v": v}} for v in (0.0, 0.5, 1.0)],
              "butts": [5000.0, 10000.0, 15000.0], "base_line": 0.0,
              "waterlines": {"spacing": 200.0, "design": 500.0},
              "decks": [{"name": "SHEER DECK", "at_side": [list(p) for p in SHEER]},
                        {"name": "TOP DECK", "height": float(TOP)},
                        {"name": "HIGH DECK", "height": 2000.0}]}
    out = tmp / "out"
    assert main(["run", str(write_config(tmp, "bilge", strake)), "--out", str(out), "--quiet"]) == 0
    return out


def girths_at(height: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two closed-form girths (from the edge at t0 = -angle / 2) of the cylinder's section
    at z = height: R (t - t0) with 1 - cos t = height / R."""
    t = np.arccos(1.0 - np.asarray(height) / R)
    t0 = -np.radians(ANGLE) / 2
    return R * (-t - t0), R * (t - t0)


def assert_on_both_crossings(lines: list, height_at, x_range=(5000.0, 15000.0)):
    """Every point of the lines lies on one of the two closed-form crossings, and each
    crossing is drawn over the whole x range."""
    covered = {0: [], 1: []}
    for line in lines:
        low, high = girths_at(height_at(line[:, 0]))
        gap = np.minimum(np.abs(line[:, 1] - low), np.abs(line[:, 1] - high))
        assert gap.max() < 0.1  # mm on girths up to 4.7 m (measured 0.002 to 0.01)
        side = int(np.abs(line[:, 1] - high).mean() < np.abs(line[:, 1] - low).mean())
        covered[side].append((line[:, 0].min(), line[:, 0].max()))
    for side in (0, 1):
        assert covered[side], f"crossing {side} not drawn"
        assert min(lo for lo, _ in covered[side]) == pytest.approx(x_range[0], abs=1e-6)
        assert max(hi for _, hi in covered[side]) == pytest.approx(x_range[1], abs=1e-6)


def test_waterlines_cross_each_bilge_section_twice_at_their_closed_form_girths(bilge):
    lines, texts = levels_of(bilge / "bilge_expansion.dxf")
    names = {t for layer, t in texts if layer == "EXP_WATERLINES"}
    # every 200 mm up to the top (878.7 mm), the design waterline named apart on its own layer
    assert names == {"WL 200", "WL 400", "WL 600", "WL 800"}
    assert {t for layer, t in texts if layer == "EXP_DWL"} == {"DWL 500"}
    assert len(lines["EXP_DWL"]) == 2
    waterlines = lines["EXP_WATERLINES"] + lines["EXP_DWL"]
    assert len(waterlines) == 2 * 5
    for h in (200.0, 400.0, 500.0, 600.0, 800.0):
        low, high = girths_at(h)
        mine = [p for p in waterlines if min(np.abs(p[:, 1] - low).max(), np.abs(p[:, 1] - high).max()) < 0.1]
        assert len(mine) == 2, h
        assert_on_both_crossings(mine, lambda x, h=h: np.full(len(x), h))


def test_a_sheer_deck_follows_its_rising_height_and_a_deck_at_the_edge_runs_along_both_edges(bilge):
    lines, texts = levels_of(bilge / "bilge_expansion.dxf")
    decks = lines["EXP_DECKS"]
    (x0, z0), (x1, z1) = SHEER
    sheer = [p for p in decks if np.ptp(p[:, 1]) > 100.0]  # the rising one: its girth changes along x
    assert len(sheer) == 2
    assert_on_both_crossings(sheer, lambda x: z0 + (x - x0) * (z1 - z0) / (x1 - x0), (x0, x1))
    edges = [p for p in decks if np.ptp(p[:, 1]) <= 100.0]
    assert len(edges) == 2  # the top deck meets the shell only along its two edges (snapped)
    girth = R * np.radians(ANGLE)
    assert sorted(float(np.abs(p[:, 1] - 0.0).max() < 0.5 or np.abs(p[:, 1] - girth).max() < 0.5)
                  for p in edges) == [1.0, 1.0]
    assert sorted(float(p[:, 1].mean() > girth / 2) for p in edges) == [0.0, 1.0]
    for p in edges:
        assert p[:, 0].min() == pytest.approx(5000.0, abs=1e-6) and p[:, 0].max() == pytest.approx(15000.0, abs=1e-6)
    deck_names = [t for layer, t in texts if layer == "EXP_DECKS"]
    # named on each line at a quarter and three quarters of the drawing's length
    assert deck_names.count("SHEER DECK") == 4 and deck_names.count("TOP DECK") == 4
    assert "HIGH DECK" not in deck_names
    notes = [t for layer, t in texts if layer == "EXP_TEXT" and "HIGH DECK" in t]
    assert len(notes) == 1 and "DOES NOT MEET THE SHELL" in notes[0] and "2000" in notes[0]


def test_the_pdf_names_its_waterlines_and_decks_and_says_what_it_left_out(bilge):
    import pdfplumber

    with pdfplumber.open(bilge / "bilge_expansion.pdf") as pdf:
        # the characters in the order the PDF writes them: the names along sloping lines are
        # turned, and a reading in layout order would interleave them
        text = "".join(c["text"] for c in pdf.pages[0].chars)
    for name in ("WL 200", "WL 800", "DWL 500", "SHEER DECK", "TOP DECK"):
        assert text.count(name) >= 2, name
    assert "WATERLINES (WL), THE DESIGN WATERLINE (DWL), DECKS AT SIDE: HEIGHTS ABOVE THE BASE LINE Z = 0 MM" in text
    assert "HIGH DECK (AT Z 2000) DOES NOT MEET THE SHELL" in text


def station_curves() -> dict:
    """The 160 m hull's 31 station curves (Orca3D's, in mm) as dense points, keel first, by x."""
    from pipeline.io.iges import iges_curve, read_iges

    iges = read_iges(SHIP / "test_1_hull_sections.igs")
    curves = {}
    for entity in (e for e in iges.entities if e.type == 126):
        curve = iges_curve(iges, entity, 1000.0, "station")
        points = curve(np.linspace(*curve.domain, 20001))
        curves[round(float(points[0, 0]))] = points
    return curves


def station_girth(points: np.ndarray, z: float) -> float:
    """Arc length along a station curve's points (keel first) to its first height z (the
    whole length at its top end)."""
    if z >= points[-1, 2] - 1e-6:
        return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
    k = int(np.argmax(points[:, 2] >= z))
    seg = np.linalg.norm(np.diff(points[:k + 1], axis=0), axis=1)
    f = (z - points[k - 1, 2]) / (points[k, 2] - points[k - 1, 2])
    return float(seg[:-1].sum() + f * seg[-1])


def test_the_160m_hull_waterlines_and_deck_meet_its_own_station_curves(tmp_path):
    """hullmod's strakes over x = 72 .. 104 m, waterlines every 2 m above the keel (z = -8 m)
    and the deck at side given by the model's deck curve (z = 10 m): at the stations
    x = 75 .. 100 m of test_1_hull_sections.igs each waterline's girth is the station curve's
    arc length from the keel to its height, and the deck's the curve's whole length."""

    spec = yaml.safe_load((ROOT / "configs" / "hullmod_strake.yaml").read_text())
    strake = dict(spec["strake"], surface={"iges": str(SHIP / "test_1_hull_exported.igs"), "entity": 0},
                  base_line=-8000.0, waterlines={"spacing": 2000.0},
                  decks=[{"name": "UPPER DECK", "curve": {"iges": str(SHIP / "test_1_deck.igs")}}])
    strake["butts"] = strake["butts"][1:4]
    out = tmp_path / "out"
    assert main(["run", str(write_config(tmp_path, "hm", strake)), "--out", str(out), "--quiet"]) == 0
    lines, texts = levels_of(out / "hm_expansion.dxf")
    names = {t for layer, t in texts if layer == "EXP_WATERLINES"}
    # WL 18000 lies on the deck line (z = 10 m): drawn once, as the deck
    assert names == {f"WL {h}" for h in range(2000, 16001, 2000)}
    stations = station_curves()
    checked = 0
    for X in range(75000, 100001, 5000):
        points = stations[X]
        for h in range(2000, 16001, 2000):
            expected = station_girth(points, -8000.0 + h)
            at = [np.interp(X, *p[np.argsort(p[:, 0])].T) for p in lines["EXP_WATERLINES"]
                  if p[:, 0].min() <= X <= p[:, 0].max()]
            assert min(abs(g - expected) for g in at) < 5.0, (X, h)  # measured
            checked += 1
        whole = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
        deck = [np.interp(X, *p[np.argsort(p[:, 0])].T) for p in lines["EXP_DECKS"]]
        assert min(abs(g - whole) for g in deck) < 5.0, X
    assert checked == 6 * 8


@pytest.mark.parametrize("deck, words", [
    ({"name": "D", "height": 1.0, "at_side": [[0, 1], [1, 2]]},
     ["strake.decks[0]", "exactly one of height, at_side, curve"]),
    ({"name": "D", "at_side": [[5000, 1], [5000, 2]]}, ["strake.decks[0]", "at_side x must ascend", "5000"]),
    ({"name": "D", "height": float("nan")}, ["strake.decks[0].height"]),
    ({"name": "", "height": 1.0}, ["strake.decks[0].name"]),
    ({"name": "ACROSS", "curve": {"points": [[5000, 0, 0], [5000, 1000, 200], [5000, 2000, 600],
                                             [5000, 3000, 878]]}},
     ["strake.decks[0]", "does not run one way along x", "ACROSS"]),
])
def test_bad_deck_input_exits_2_naming_the_file_and_the_deck_and_writes_nothing(tmp_path, capsys, deck, words):
    iges = cylinder_along_iges(tmp_path / "c.igs", radius=R, angle_deg=ANGLE, length=LENGTH)
    config = write_config(tmp_path, "bad", {"surface": {"iges": str(iges)}, "seams": [{"iso": {"v": 0.0}},
                                                                                     {"iso": {"v": 1.0}}],
                                            "butts": [5000.0, 15000.0], "decks": [deck]})
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert str(config) in err or config.name in err
    for word in words:
        assert word in err, (word, err)
    assert not out.exists() or not any(out.iterdir())


def hull160_sections(stations: np.ndarray):
    """The girth table of the 160 m hull's surface (mm) at ``stations``."""
    from pipeline.config import SurfaceSource
    from pipeline.hull.expansion import section_table
    from pipeline.hull.region import load_surface_noted, long_axis_of

    surface, _ = load_surface_noted(SurfaceSource(iges=str(SHIP / "test_1_hull_exported.igs"), entity=0), ROOT,
                                    1.0, 1.0)
    return section_table(surface, long_axis_of(surface), stations)


def test_sections_that_start_on_the_stern_or_stem_contour_count_their_girth_from_it():
    """At the 160 m hull's ends the sections x = const start on the stern or stem contour, not
    at the keel: their girth counts from where the contour crosses the section, found between
    the girth samples (it was counted from the first sample on the section: 142 mm off at
    x = 5 m). Each waterline's girth at the stations x = 5, 10, 15, 145, 150 and 155 m against
    the station curves' arc length from their start (measured: at most 2.6 mm)."""
    from pipeline.hull.levels import crossings

    stations = np.array([5000.0, 10000.0, 15000.0, 145000.0, 150000.0, 155000.0])
    table = hull160_sections(stations)
    curves = station_curves()
    checked = 0
    for h in range(2000, 18001, 2000):
        z = -8000.0 + h
        lines = crossings(table.stations, table.girth, table.z, np.full(len(stations), z), 0.5)
        for x in stations:
            points = curves[int(x)]
            if points[:, 2].min() > z:
                continue  # the section starts above this waterline
            expected = station_girth(points, z)
            at = [np.interp(x, *p[np.argsort(p[:, 0])].T) for p in lines if p[:, 0].min() <= x <= p[:, 0].max()]
            assert min(abs(g - expected) for g in at) < 5.0, (x, h)
            checked += 1
    assert checked == 41


def test_sections_aft_of_the_transom_edge_continue_the_girths_of_those_that_pass_it():
    """The 160 m hull's flat bottom ends in the transom's lower edge at x = 158.237 m (its bow
    is the raked stem at x = 0). Forward of that edge each section runs from the centre plane
    across the bottom (about 3.4 m) and up the side; aft of it each starts on the transom's
    edge, off the centre plane, and counts its girth from there along that edge from the
    centre plane. So at every height the girth runs on smoothly across the edge: within
    0.5 mm per mm of station spacing + 5 mm (measured: at most 0.3 per mm); counted from 0 at
    the edge, as it was, it dropped by 3.4 m over 15 mm of length."""
    stations = np.array([158150.0, 158200.0, 158230.0, 158245.0, 158260.0, 158300.0, 158400.0])
    table = hull160_sections(stations)
    assert np.all(table.start_girth[:3] == 0.0) and np.all(table.start_girth[3:] > 3000.0)
    for z in (500.0, 1000.0, 2000.0, 4000.0, 8000.0):
        at, girths = [], []
        for x, row, heights in zip(stations, table.girth, table.z):
            ok = np.isfinite(row)
            g, h = row[ok], heights[ok]
            k = np.flatnonzero((h[:-1] - z) * (h[1:] - z) <= 0)  # the first crossing, up from the start
            if len(k):  # (the sections aft of x = 158.3 m start above z = 500)
                at.append(x)
                girths.append(g[k[0]] + (z - h[k[0]]) / (h[k[0] + 1] - h[k[0]]) * (g[k[0] + 1] - g[k[0]]))
        assert len(at) >= 6 and at[3] == 158245.0
        assert np.all(np.abs(np.diff(girths)) <= 0.5 * np.diff(at) + 5.0), (z, np.round(girths))


@settings(max_examples=40, derandomize=True, deadline=None)
@given(seed=st.integers(0, 100_000))
def test_a_level_on_a_linear_table_is_found_exactly_where_sections_reach_it(seed):
    """Sections whose z grows linearly with girth (z = a + b girth + c x, b > 0), each
    starting and ending at its own girth (the rest NaN, as at a hull's ends): the level Z is
    crossed at girth (Z - a - c x) / b, exactly under linear interpolation, on every station
    whose section reaches it inside a cell it shares with a neighbouring section (a contour
    runs through cells of four points), and on no station whose section does not reach it."""
    rng = np.random.default_rng(seed)
    stations = np.sort(rng.uniform(0.0, 1000.0, 30))
    stations = stations[np.concatenate([[True], np.diff(stations) > 1.0])]
    girth = np.tile(np.linspace(0.0, 500.0, 41), (len(stations), 1))
    start = rng.integers(0, 15, len(stations))
    stop = rng.integers(26, 42, len(stations))
    cols = np.arange(41)
    girth[(cols[None, :] < start[:, None]) | (cols[None, :] >= stop[:, None])] = np.nan
    a, b, c = rng.uniform(-50, 50), rng.uniform(0.5, 2.0), rng.uniform(-0.05, 0.05)
    z = a + b * girth + c * stations[:, None]
    level = a + b * rng.uniform(200.0, 300.0) + c * stations.mean()  # inside every section somewhere
    lines = crossings(stations, girth, z, np.full(len(stations), level), 1e-9)
    expected = (level - a - c * stations) / b
    reached = (expected >= np.nanmin(girth, axis=1)) & (expected <= np.nanmax(girth, axis=1))
    points = np.vstack(lines) if lines else np.zeros((0, 2))
    assert np.allclose(points[:, 1], (level - a - c * points[:, 0]) / b, atol=1e-7)
    present = np.isfinite(girth)
    found = 0
    for k, (x, g, hit) in enumerate(zip(stations, expected, reached)):
        near = points[np.abs(points[:, 0] - x) < 1e-9]
        j = min(int(g // 12.5), 39)
        shared = any(0 <= m < len(stations) and present[m, j] and present[m, j + 1] for m in (k - 1, k + 1))
        if hit and present[k, j] and present[k, j + 1] and shared:
            assert len(near) and np.abs(near[:, 1] - g).min() < 1e-7
            found += 1
        if not hit:
            assert not len(near)
    assert found >= 1


def test_a_hull_ending_in_a_plane_within_millimetres_has_whole_sections_up_to_its_end(tmp_path):
    """A bilge cylinder whose end poles stand 0, 1 and 2 mm short of x = 20 m (a face cut by
    a transverse plane, as KCS's fore main-hull face is, within 2 mm): the sections through
    that last 2 mm are whole (each iso-curve's end taken, not a gap that ended the section
    and left the end plates' outlines as wedges or NaN), girth R pi / 2 within 2 mm; and a
    girth asked off every section comes from the nearest section that has it, never NaN."""
    from pipeline.config import SurfaceSource
    from pipeline.hull.expansion import section_table
    from pipeline.hull.region import load_surface_noted, long_axis_of
    from tests.hull_shapes import write_iges_surface

    h = np.radians(ANGLE) / 2
    arc = np.array([[-R * np.sin(h), R * (1 - np.cos(h))], [0.0, R - R / np.cos(h)],
                    [R * np.sin(h), R * (1 - np.cos(h))]])
    w = np.array([1.0, np.cos(h), 1.0])
    poles = np.array([[[x, y, z] for y, z in arc] for x in (0.0, LENGTH)])
    poles[1, :, 0] -= [0.0, 1.0, 2.0]
    iges = write_iges_surface(tmp_path / "cut.igs", 1, 2, poles, np.vstack([w, w]), [0, 0, 1, 1], [0, 0, 0, 1, 1, 1])
    surface, _ = load_surface_noted(SurfaceSource(iges=str(iges)), tmp_path, 1.0, 1.0)
    table = section_table(surface, long_axis_of(surface), np.array([10000.0, LENGTH - 1.5, LENGTH - 0.5]))
    assert np.isfinite(table.girth).all()
    assert table.total() == pytest.approx(np.full(3, R * np.radians(ANGLE)), abs=2.0)
    off = table.at(np.array([LENGTH + 50.0]), np.array([0.5 * (table.g[0] + table.g[-1])]))
    assert np.isfinite(off).all() and off[0] == pytest.approx(R * np.radians(ANGLE) / 2, abs=5.0)
