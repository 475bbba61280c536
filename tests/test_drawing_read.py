"""Shop drawings read back as a plater reads them (pdfplumber): every text at least 2.5 mm
high (capital height, ISO 3098) and inside the frame, no two texts overlapping, no text
crossing a drawn line, every bending line's number and every marked frame present, the
plate laid lengthwise, and the table's stations and ordinates measured along the lines they
claim (the centre line, edges C and D from the start corners). At three scales: the 1 m
model plate of DTMB 5415, the bilge plate of configs/plate.yaml and the 25.8 m NAPA plate;
a 60-line plate's table continues on a second page."""

import json
from pathlib import Path

import numpy as np
import pytest

from pipeline.cli import main

ROOT = Path(__file__).resolve().parents[1]
MM = 25.4 / 72.0
CAP = 0.718  # Helvetica's capital height per em (its AFM)


def _read(path: Path):
    """Per page: (width, height mm, chars [(text, (x0, y0, x1, y1) mm from the bottom left,
    capital height mm, angle)], segments (S, 2, 2) mm of every drawn path)."""
    pdfplumber = pytest.importorskip("pdfplumber")
    pages = []
    with pdfplumber.open(path) as pdf:
        for page in pdf.pages:
            h = float(page.height)
            chars = []
            for c in page.chars:
                a, b = c["matrix"][:2]
                angle = round(float(np.degrees(np.arctan2(b, a))))
                box = (c["x0"] * MM, (h - c["bottom"]) * MM, c["x1"] * MM, (h - c["top"]) * MM)
                em = box[3] - box[1] if angle == 0 else box[2] - box[0]  # the em box across the baseline
                chars.append((c["text"], box, em * CAP, angle))
            segs = []
            for obj in page.curves + page.lines + page.rects:
                pts = np.array([(x, h - y) for x, y in obj["pts"]], dtype=float) * MM
                if "width" in obj and len(pts) == 2 and obj.get("object_type") == "rect":
                    continue
                if len(pts) >= 2:
                    segs.append(np.stack([pts[:-1], pts[1:]], axis=1))
            pages.append((float(page.width) * MM, h * MM, chars, np.concatenate(segs) if segs else np.zeros((0, 2, 2))))
    return pages


def _runs(chars) -> list[tuple[str, tuple]]:
    """The texts as drawn: consecutive characters on one baseline and in one direction."""
    runs, text, box, last = [], "", None, None
    for ch, b, _, angle in chars:
        cont = last is not None and angle == last[3] and (
            abs(b[1] - last[1][1]) < 0.05 and -0.5 < b[0] - last[1][2] < 1.5 if angle == 0
            else abs(b[0] - last[1][0]) < 0.05 and -0.5 < b[1] - last[1][3] < 1.5)
        if cont:
            text += ch
            box = (min(box[0], b[0]), min(box[1], b[1]), max(box[2], b[2]), max(box[3], b[3]))
        else:
            if text:
                runs.append((text, box))
            text, box = ch, b
        last = (ch, b, None, angle)
    if text:
        runs.append((text, box))
    return runs


def _segment_hits_box(segs: np.ndarray, box) -> bool:
    """Whether any segment (S, 2, 2) passes through the box (x0, y0, x1, y1) (Liang-Barsky)."""
    p0, d = segs[:, 0], segs[:, 1] - segs[:, 0]
    t0, t1 = np.zeros(len(segs)), np.ones(len(segs))
    for k, (lo, hi) in enumerate(((box[0], box[2]), (box[1], box[3]))):
        with np.errstate(divide="ignore", invalid="ignore"):
            a, b = (lo - p0[:, k]) / d[:, k], (hi - p0[:, k]) / d[:, k]
        still = d[:, k] == 0
        inside = (p0[:, k] > lo) & (p0[:, k] < hi)
        t0 = np.where(still, np.where(inside, t0, 2.0), np.maximum(t0, np.minimum(a, b)))
        t1 = np.where(still, np.where(inside, t1, -1.0), np.minimum(t1, np.maximum(a, b)))
    return bool(np.any(t0 < t1))


def check_readable(path: Path) -> list[set]:
    """Assert the drawing's rules on every page; returns each page's words."""
    pages = _read(path)
    words = []
    for width, height, chars, segs in pages:
        assert chars
        for ch, box, cap, angle in chars:
            assert cap >= 2.5 - 1e-6, (ch, cap)
            assert angle in (0, 90)
            # inside the frame (10 mm in from the sheet's edge)
            assert box[0] >= 10.0 and box[1] >= 10.0 and box[2] <= width - 10.0 and box[3] <= height - 10.0, (ch, box)
        runs = _runs(chars)
        boxes = np.array([b for _, b in runs])
        # no two texts overlap
        for i in range(len(runs)):
            o = boxes[i + 1:]
            hit = (o[:, 0] < boxes[i, 2] - 1e-3) & (o[:, 2] > boxes[i, 0] + 1e-3) & \
                  (o[:, 1] < boxes[i, 3] - 1e-3) & (o[:, 3] > boxes[i, 1] + 1e-3)
            assert not hit.any(), (runs[i][0], [runs[i + 1 + k][0] for k in np.flatnonzero(hit)])
        # no text on a drawn line
        for text, b in runs:
            assert not _segment_hits_box(segs, (b[0] + 0.02, b[1] + 0.02, b[2] - 0.02, b[3] - 0.02)), text
        words.append({w for text, _ in runs for w in text.split()})
    return words


def _table(path: Path) -> dict:
    """{B-number: (station, on C, on D)} from the bending-line table (rows of 6 cells)."""
    rows = {}
    for _, _, chars, _ in _read(path):
        runs = [(t, b) for t, b in _runs(chars)]
        lines = {}
        for t, b in runs:
            lines.setdefault(round(b[1], 1), []).append((b[0], t))
        for cells in lines.values():
            cells = [t for _, t in sorted(cells)]
            for k in range(len(cells) - 5):
                if cells[k].startswith("B") and cells[k][1:].isdigit() and cells[k + 2] in ("CVX", "CCV", "-"):
                    rows[int(cells[k][1:])] = tuple(float(v) for v in cells[k + 3:k + 6])
    return rows


def _run(config: str, out: Path) -> None:
    assert main(["run", str(ROOT / "configs" / config), "--out", str(out), "--quiet"]) in (0, 1)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("drawings")
    for config in ("plate.yaml", "napa_bilge.yaml", "dtmb5415_strake.yaml"):
        _run(config, out / Path(config).stem)
    return out


@pytest.mark.parametrize("config", ["plate", "napa_bilge", "dtmb5415_strake"])
def test_drawings_read_back_at_every_scale(runs, config):
    reports = [json.loads(p.read_text()) for p in sorted((runs / config).glob("*.json"))]
    reports = [r for r in reports if r.get("layout", {}).get("drawings")]
    assert reports
    scales = set()
    for rep in reports:
        [drawing] = rep["layout"]["drawings"]
        path = runs / config / drawing["file"]
        words = set().union(*check_readable(path))
        scales.add(drawing["scale"])
        n = rep.get("bending", {}).get("count", 0)
        assert {f"B{k}" for k in range(1, n + 1)} <= words
        for frame in rep["layout"]["frames_marked"]:
            assert set(frame.split()) <= words, frame
        assert drawing["not_placed"] == []
        assert f"1:{drawing['scale'].split(':')[1]}" in words
    if config == "napa_bilge":  # 25.8 m long: lengthwise on A3 at 1:100 (upright it took 1:200)
        assert scales == {"1:100"} and drawing["paper"] == "A3 landscape"
    if config == "dtmb5415_strake":  # the 1 m model plate, drawn large
        assert all(int(s.split(":")[1]) <= 10 for s in scales)


def test_table_stations_and_ordinates_are_measured_along_their_lines(runs):
    """The bilge plate (no allowance: the DXF's outline is the net one, traced c, end, d
    backwards, start): the table's ON C / ON D are the arc lengths along edges C and D from
    the corners at the start butt to the line's ends, its AT CL the stations along the centre
    line (400 mm apart, as the chain's figures say), each to the mm."""
    import ezdxf
    import shapely

    rep = json.loads((runs / "plate" / "bilge_plate.json").read_text())
    doc = ezdxf.readfile(runs / "plate" / "bilge_plate.dxf")
    [cut] = [np.array([tuple(p)[:2] for p in e.get_points()]) for e in doc.modelspace().query("LWPOLYLINE")
             if e.dxf.layer == "CUT_OUTER"]
    counts = rep["outline"]["edges"]
    nc, ne, nd = counts["c"], counts["end"], counts["d"]
    edge_c = shapely.LineString(cut[:nc + 1])
    edge_d = shapely.LineString(cut[nc + ne:nc + ne + nd + 1][::-1])
    table = _table(runs / "plate" / "bilge_plate_drawing.pdf")
    lines = rep["bending"]["lines"]
    assert sorted(table) == [b["number"] for b in lines]
    for b in lines:
        station, on_c, on_d = table[b["number"]]
        assert station == pytest.approx(b["station"], abs=0.5)
        assert on_c == pytest.approx(edge_c.project(shapely.Point(b["start"])), abs=0.5)
        assert on_d == pytest.approx(edge_d.project(shapely.Point(b["end"])), abs=0.5)
    # the chain's figures: the stations' steps, and the middles of the lines that far apart
    steps = np.diff([b["station"] for b in lines])
    words = set().union(*check_readable(runs / "plate" / "bilge_plate_drawing.pdf"))
    assert {f"{round(s):g}" for s in steps} <= words
    mids = np.array([0.5 * (np.array(b["start"]) + np.array(b["end"])) for b in lines])
    chords = np.linalg.norm(np.diff(mids, axis=0), axis=1)
    # the bilge plate's middles move straight across its lines: a chord between two middles is
    # the station's step, the distance across the lines, to the lines' fanning (an arc about
    # their apex against its chord)
    np.testing.assert_allclose(chords, steps, rtol=1e-3)


def test_a_long_table_continues_on_the_next_page(tmp_path):
    """60 bending lines 300 mm apart on a 20 m x 1.8 m plate with radii up to 96 km: every
    row in the table (beside the plate, then page 2), never cut at the sheet's edge, every
    B-number on the plate; frames every 2.5 m named beyond their lines."""
    from pipeline.shop.drawing import write_shop_drawing
    from pipeline.shop.layout import Layout, Text

    cut = np.array([[0.0, 0.0], [20000.0, 0.0], [20000.0, 1800.0], [0.0, 1800.0]])
    xs = 300.0 + 300.0 * np.arange(60) + 50.0
    bends = [(k + 1, f"B{k + 1} R{96076 - 1000 * k} {'CVX' if k % 2 else 'CCV'}", np.array([x, 0.0]),
              np.array([x + 30.0, 1800.0]), x + 15.0) for k, x in enumerate(xs)]
    frames = [np.array([[x, 0.0], [x, 1800.0]]) for x in np.arange(2500.0, 20000.0, 2500.0)]
    layout = Layout(cut=cut, net=None, lines=[("bend", np.array([a, b])) for _, _, a, b, _ in bends]
                    + [("frame", f) for f in frames],
                    texts=[Text("frame", f"FR {f[0, 0]:g}", (f[0, 0] + 100.0, 900.0), 40.0, 90.0) for f in frames])
    edges = {"SEAM C": cut[:2], "SEAM D": cut[2:4][::-1], "BUTT A": cut[[3, 0]], "BUTT F": cut[1:3]}
    info = write_shop_drawing(tmp_path / "long.pdf", layout, "LONG: SHOP DRAWING", ["PART LONG"], bends, 300.0,
                              ["BENDING LINES B1-B60 EVERY 300 MM"], edges)
    assert info["pages"] >= 2 and info["not_placed"] == []
    words = check_readable(tmp_path / "long.pdf")
    assert {f"B{k}" for k in range(1, 61)} <= words[0]
    table = _table(tmp_path / "long.pdf")
    assert sorted(table) == list(range(1, 61))
    assert all(table[k][0] == pytest.approx(xs[k - 1] + 15.0, abs=0.5) for k in table)
    assert {f"R{96076 - 1000 * k}" for k in range(60)} <= set().union(*words)
    assert {f"{x:g}" for x in np.arange(2500.0, 20000.0, 2500.0)} <= words[0]


@pytest.mark.parametrize("fault", ["overlap", "on a line", "too small", "outside"])
def test_the_reader_finds_each_fault(tmp_path, fault):
    """The checks above fail on a page that breaks their rule (drawn by the same renderer)."""
    from pipeline.shop.drawing import Label, Page, draw_pages

    page = Page(297.0, 210.0)
    page.add("cut", [np.array([[50.0, 50.0], [150.0, 50.0]])])
    page.labels.append(Label("B12", 100.0, 100.0))
    page.labels.append({"overlap": Label("FR 2500", 102.0, 100.5, angle=90), "on a line": Label("B7", 60.0, 49.5),
                        "too small": Label("B7", 60.0, 150.0, h=1.8), "outside": Label("B7", 5.0, 150.0)}[fault])
    draw_pages(tmp_path / "f.pdf", [page], "FAULT")
    with pytest.raises(AssertionError):
        check_readable(tmp_path / "f.pdf")
    page.labels.pop()
    draw_pages(tmp_path / "ok.pdf", [page], "FAULT")
    assert {"B12"} <= check_readable(tmp_path / "ok.pdf")[0]
