"""A large sheet on small pages (pipeline/io/tiled.py): the windows cover the sheet with the
overlap asked for and no page more than needed, and every character of the shell
expansion's A0 sheet is on each page whose window holds it, where the window puts it (the
sheet read back with pdfplumber, page by page); the config option and its bad values."""

from itertools import pairwise

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.cli import main
from pipeline.io.tiled import OVERLAP, PAGES, tile_windows

PT = 72.0 / 25.4


def test_an_a0_sheet_goes_on_nine_a3_pages_and_twenty_five_a4():
    a3 = tile_windows((1189.0, 841.0), "A3")
    assert len(a3) == 9 and {t.size for t in a3} == {(420.0, 297.0)}
    assert (a3[0].row, a3[0].col, a3[0].x0) == (1, 1, 0.0)
    assert a3[0].y0 + 297.0 == pytest.approx(841.0)  # row 1 at the top
    assert a3[-1].x0 + 420.0 == pytest.approx(1189.0) and a3[-1].y0 == 0.0
    assert len(tile_windows((1189.0, 841.0), "A4")) == 5 * 5  # ceil((1189 - 15) / 282) x ceil((841 - 15) / 195)
    assert len(tile_windows((400.0, 280.0), "A3")) == 1  # a sheet that fits one page


@settings(max_examples=60, deadline=None, derandomize=True)
@given(w=st.floats(100.0, 3000.0), h=st.floats(100.0, 2000.0), page=st.sampled_from(sorted(PAGES)))
def test_the_pages_cover_the_sheet_overlapping_and_no_fewer_would(w, h, page):
    tiles = tile_windows((w, h), page)
    pw, ph = PAGES[page]
    xs = sorted({t.x0 for t in tiles})
    ys = sorted({t.y0 for t in tiles})
    assert len(tiles) == len(xs) * len(ys)
    for starts, window, length in ((xs, pw, w), (ys, ph, h)):
        assert starts[0] == 0.0
        assert starts[-1] + window >= length - 1e-9
        if len(starts) > 1:
            assert starts[-1] + window == pytest.approx(length)
            assert min(b - a for a, b in pairwise(starts)) > 0
            assert min(a + window - b for a, b in pairwise(starts)) >= OVERLAP - 1e-9  # each pair overlaps
            # one page fewer could not cover it with that overlap
            assert (len(starts) - 1) * (window - OVERLAP) + OVERLAP < length


def chars(page) -> list[tuple[str, float, float, float]]:
    return [(c["text"], round(c["size"], 3), c["x0"], c["top"]) for c in page.chars]


def test_every_character_of_the_sheet_is_where_its_page_window_puts_it(tmp_path):
    import pdfplumber

    from pipeline.hull.expansion_sheet import plan_sheet, write_expansion_pdf
    from tests.test_expansion_faces import BOW, FLAT, SIDE, drawn, plate

    drawing = drawn([plate("flat_plate_one", FLAT, (0.1, 0.5), (0.2, 0.9)),
                     plate("side_plate_two", SIDE, (0.1, 0.5), (0.2, 0.8)), plate("bow_plate", BOW, (0, 1), (0, 1))])
    sheet = plan_sheet(drawing.x_range, drawing.height, 1.0, [])
    info = {"drawing": "T-EXP", "hull": "t", "plates": 3, "side": "Y > 0", "bow": "low", "notes": []}
    whole, tiled = tmp_path / "t_expansion.pdf", tmp_path / "t_expansion_tiles.pdf"
    write_expansion_pdf(whole, drawing, sheet, 1.0, "t", info, ("A3", tiled))
    tiles = tile_windows(sheet.size, "A3")
    h = sheet.size[1]
    with pdfplumber.open(whole) as pdf:
        reference = chars(pdf.pages[0])
    with pdfplumber.open(tiled) as pdf:
        pages = [chars(p) for p in pdf.pages]
        sizes = {(round(p.width / PT, 6), round(p.height / PT, 6)) for p in pdf.pages}
    assert len(pages) == len(tiles) == 9 and sizes == {(420.0, 297.0)}
    found = 0
    for tile, page in zip(tiles, pages):
        left, top = tile.x0 * PT, (h - tile.y0 - tile.size[1]) * PT  # the window in the sheet's points, from its top
        on_page = {(t, s): np.array([(x, y) for tt, ss, x, y in page if (tt, ss) == (t, s)]) for t, s, _, _ in reference}
        for text, size, x, y in reference:
            if left + 1 <= x <= left + tile.size[0] * PT - 2 * size and top + 1 <= y <= top + tile.size[1] * PT - 2 * size:
                there = on_page[(text, size)]
                assert len(there) and np.abs(there - (x - left, y - top)).sum(axis=1).min() < 0.05, (text, tile)
                found += 1
        label = "".join(t for t, _, _, _ in page)
        assert f"PAGE {tile.row}-{tile.col}, ROW {tile.row} OF 3, COLUMN {tile.col} OF 3" in label
    assert found >= len(reference)  # every character on at least one page


def test_the_tiles_option_writes_them_and_a_bad_one_exits_2(tmp_path, capsys):
    from tests.hull_shapes import cylinder_along_iges

    surface = cylinder_along_iges(tmp_path / "bilge.igs", length=20000.0)
    data = {"name": "tiled", "units": "mm", "output": {"png": True, "obj": False, "expansion_tiles": "A4"},
            "resolution": {"chord_tolerance": 1.0},
            "strake": {"surface": {"iges": str(surface), "entity": 0}, "margin": 0.2, "fit_tolerance": 5.0,
                       "plan": {"method": "uniform", "stock": {"max_length": 12000, "max_width": 3000,
                                                              "min_length": 3000, "min_width": 1000}}}}
    config = tmp_path / "tiled.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--out", str(tmp_path / "out")]) == 0
    import pdfplumber

    with pdfplumber.open(tmp_path / "out" / "tiled_expansion_tiles.pdf") as pdf:
        assert len(pdf.pages) >= 2 and {(round(p.width / PT), round(p.height / PT)) for p in pdf.pages} == {(297, 210)}
    data["output"]["expansion_tiles"] = "A2"
    config.write_text(yaml.safe_dump(data))
    assert main(["check", str(config)]) == 2
    err = capsys.readouterr().err
    assert "expansion_tiles" in err and "A2" in err
    data["output"].update(expansion_tiles="A3", png=False)
    config.write_text(yaml.safe_dump(data))
    assert main(["check", str(config)]) == 2
    assert "expansion_tiles needs png" in capsys.readouterr().err
