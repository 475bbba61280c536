"""Nest sheets keep every mark the plate's own DXF has (bend numbers, radii, CVX/CCV, frame
and edge names, part data), moved with the part, and the part ids cross no bending line."""

from collections import Counter

import numpy as np
import pytest

from pipeline.cli import main
from tests.test_nesting import plate_config

ezdxf = pytest.importorskip("ezdxf")


def _texts(doc, layers) -> Counter:
    return Counter(e.dxf.text for e in doc.modelspace().query("TEXT") if e.dxf.layer in layers)


def test_stock_sheets_carry_the_parts_own_marks_and_ids_clear_of_bending_lines(tmp_path):
    import shapely

    config = plate_config(tmp_path, pairs=True, quantities={"bilge_plate": 1})
    assert main(["run", str(config), "--out", str(tmp_path / "own"), "--quiet"]) in (0, 1)
    assert main(["nest", str(config), "--out", str(tmp_path / "nest"), "--quiet"]) == 0
    own = ezdxf.readfile(tmp_path / "own" / "bilge_plate.dxf")
    marks = ("MARK_BEND", "MARK_EDGE", "MARK_FRAME")
    wanted = _texts(own, marks)
    assert any(t.startswith("B1 R") and t.endswith(("CVX", "CCV")) for t in wanted)
    own_bends = len(own.modelspace().query("LINE LWPOLYLINE").query("*[layer=='MARK_BEND']"))
    sheets = sorted((tmp_path / "nest").glob("bilge_plate_*.dxf"))
    sheets = [s for s in sheets if "cutting" not in s.name]
    assert sheets
    got, ids, bends = Counter(), [], 0
    for path in sheets:
        doc = ezdxf.readfile(path)
        assert not doc.audit().errors
        got += _texts(doc, marks)
        msp = doc.modelspace()
        lines = [np.array([tuple(p)[:2] for p in e.get_points()]) for e in msp.query("LWPOLYLINE[layer=='MARK_BEND']")]
        bends += len(lines)
        for e in msp.query("TEXT[layer=='MARK_TEXT']"):
            if "#" not in e.dxf.text:
                continue
            h, n = e.dxf.height, len(e.dxf.text)
            box = shapely.affinity.rotate(shapely.box(-0.5 * n * h, -0.65 * h, 0.5 * n * h, 0.65 * h),
                                          e.dxf.rotation, origin=(0, 0))
            box = shapely.affinity.translate(box, *tuple(e.dxf.align_point)[:2])
            ids.append(e.dxf.text)
            assert not any(box.intersects(shapely.LineString(line)) for line in lines), e.dxf.text
    # both sides (SB and its mirror PS) carry every mark text of the part's own DXF
    assert sorted(ids) == ["bilge_plate_PS#1", "bilge_plate_SB#1"]
    assert all(got[t] == 2 * n for t, n in wanted.items()), (wanted, got)
    assert bends == 2 * own_bends
