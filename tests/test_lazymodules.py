"""pipeline.lazymodules: the PDF backend parses a core font's AFM file once per process, and
the PDFs it writes stay byte for byte what matplotlib writes parsing it every time."""

from __future__ import annotations

import io

import matplotlib
import pytest

from pipeline.lazymodules import ParsedOnce, pdf_backend
from pipeline.shop.drawing import CORE_FONTS


def _core_font_pdf(backend, path) -> bytes:
    from matplotlib.figure import Figure

    with matplotlib.rc_context(CORE_FONTS):
        fig = Figure(figsize=(4, 3))
        backend.FigureCanvasPdf(fig)
        fig.text(0.1, 0.5, "FR 112  BUTT X5000  BL 3", fontsize=9)
        fig.text(0.1, 0.3, "P2_S07_B03-2-1", fontsize=12, fontweight="bold")
        fig.savefig(path, format="pdf", metadata={"CreationDate": None})
    return path.read_bytes()


def test_each_core_font_is_parsed_once_and_the_pdfs_are_unchanged(tmp_path, monkeypatch):
    backend = pdf_backend()
    assert isinstance(backend.AFM, ParsedOnce)
    original = backend.AFM.parse
    monkeypatch.setattr(backend, "AFM", original)  # matplotlib's own: parsed for every PDF
    reference = _core_font_pdf(backend, tmp_path / "reference.pdf")
    assert b"/BaseFont /Helvetica" in reference and b"/BaseFont /Helvetica-Bold" in reference

    files = []

    def counted(file):
        files.append(file.name)
        return original(file)

    monkeypatch.setattr(backend, "AFM", ParsedOnce(counted))
    pdfs = [_core_font_pdf(backend, tmp_path / f"plate{k}.pdf") for k in range(3)]
    assert all(pdf == reference for pdf in pdfs)
    assert len(files) == 2 and len(set(files)) == 2  # Helvetica and Helvetica-Bold, once each


def test_a_file_without_a_path_is_parsed_each_time():
    calls = []
    once = ParsedOnce(lambda file: calls.append(file.read()) or len(calls))
    assert [once(io.BytesIO(b"StartFontMetrics")) for _ in range(2)] == [1, 2]


def test_pdf_backend_wraps_the_parser_once():
    backend = pdf_backend()
    wrapped = backend.AFM
    assert pdf_backend().AFM is wrapped and not isinstance(wrapped.parse, ParsedOnce)


@pytest.mark.parametrize("name", ["Helvetica", "Helvetica-Bold"])
def test_the_parse_read_back_names_its_font(name):
    from matplotlib.font_manager import FontProperties, findfont

    backend = pdf_backend()
    with matplotlib.rc_context(CORE_FONTS):
        path = findfont(FontProperties(family="Helvetica", weight="bold" if "Bold" in name else "normal"),
                        fontext="afm")
    with open(path, "rb") as file:
        first = backend.AFM(file)
    with open(path, "rb") as file:
        assert backend.AFM(file) is first
    assert first.get_fontname() == name


def test_a_file_rewritten_at_the_same_path_is_parsed_again(tmp_path):
    path = tmp_path / "Font.afm"
    once = ParsedOnce(lambda file: file.read())
    path.write_bytes(b"StartFontMetrics 2.0\nFontName A\n")
    with open(path, "rb") as file:
        first = once(file)
    with open(path, "rb") as file:
        assert once(file) is first
    path.write_bytes(b"StartFontMetrics 2.0\nFontName Another\n")  # another size: another file
    with open(path, "rb") as file:
        assert once(file) == b"StartFontMetrics 2.0\nFontName Another\n"
