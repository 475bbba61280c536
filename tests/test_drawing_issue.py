"""The drawings' issue (``output.issue``): revision, date of issue and who drew and approved
them in the title blocks of the plates' shop drawings and of the shell expansion (PDF and the
DXF's paper space), read back from the files; without it the title blocks are as before; a
bad revision or date exits 2 naming the field and the value, and writes nothing."""

import pytest
import yaml

from pipeline.cli import main
from tests.hull_shapes import cylinder_along_iges

ISSUE = {"revision": "B", "date": "2026-12-08", "drawn_by": "J. Smith", "approved_by": "A. Surveyor"}


def _config(tmp_path, issue) -> object:
    iges = cylinder_along_iges(tmp_path / "c.igs", radius=3000.0, angle_deg=60.0, length=8000.0)
    output = {"png": True, "obj": False, "drawing": True, **({"issue": issue} if issue is not None else {})}
    config = tmp_path / "iss.yaml"
    config.write_text(yaml.safe_dump({
        "name": "iss", "units": "mm", "resolution": {"chord_tolerance": 5.0}, "output": output,
        "strake": {"surface": {"iges": str(iges)}, "seams": [{"iso": {"v": 0.0}}, {"iso": {"v": 1.0}}],
                   "butts": [0.0, 4000.0, 8000.0], "bow": "high", "margin": 0.1, "fit_tolerance": 5.0}}))
    return config


def _pdf_text(path) -> str:
    import pdfplumber

    with pdfplumber.open(path) as pdf:
        return "\n".join(page.extract_text() or "" for page in pdf.pages)


@pytest.mark.parametrize("issue", [ISSUE, None])
def test_the_issue_is_in_every_title_block(tmp_path, issue):
    import ezdxf

    out = tmp_path / "out"
    assert main(["run", str(_config(tmp_path, issue)), "--out", str(out), "--quiet"]) == 0
    drawings = sorted(out.glob("iss_S1_B*_drawing.pdf"))
    assert len(drawings) == 2
    expansion = _pdf_text(out / "iss_expansion.pdf")
    paper = [t.dxf.text for t in ezdxf.readfile(out / "iss_expansion.dxf").layouts.get("SHELL EXPANSION")
             .query("TEXT")]
    if issue is None:
        assert all("REV " not in _pdf_text(d) for d in drawings)
        assert "REVISION" not in expansion and "REVISION" not in paper
        assert "DEVFLAT" in paper and "DRAWN BY" in paper
        return
    for drawing in drawings:
        assert "REV B ISSUED 2026-12-08 DRAWN BY J. SMITH APPROVED BY A. SURVEYOR" in " ".join(
            _pdf_text(drawing).split())
    for text in (expansion, "\n".join(paper)):
        assert "B, ISSUED 2026-12-08" in text and "J. SMITH (DEVFLAT)" in text and "A. SURVEYOR" in text
    assert {"REVISION", "DRAWN BY", "APPROVED BY"} <= set(paper)


@pytest.mark.parametrize("field, value", [("revision", "B 2"), ("date", "2026-13-40"), ("drawn_by", "")])
def test_a_bad_issue_exits_2_naming_the_field_and_writes_nothing(tmp_path, capsys, field, value):
    out = tmp_path / "out"
    assert main(["run", str(_config(tmp_path, dict(ISSUE, **{field: value}))), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "iss.yaml" in err and f"output.issue.{field}" in err and (value in err if value else True)
    assert not out.exists() or not any(out.iterdir())
