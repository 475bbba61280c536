"""matplotlib's PDF backend, imported without fontTools' subsetter until a PDF needs it.

``matplotlib.backends.backend_pdf`` imports ``fontTools.subset`` at its top (through
``_backend_pdf_ps``) to subset TrueType fonts embedded as Type 42. That import is a third
of the backend's (~0.1 s CPU: fontTools' OpenType table definitions), and devflat's PDFs
never use it: the shop drawing writes in the PDF core fonts (nothing embedded) and the
textile printout embeds DejaVu as Type 3 (matplotlib's default ``pdf.fonttype``), which
matplotlib converts without fontTools. So ``fontTools.subset`` is registered to load on
its first attribute access (``importlib.util.LazyLoader``, the standard library's lazy
import): a PDF that does embed Type 42 fonts still gets the real module, at that moment.
"""

from __future__ import annotations

import importlib.util
import sys

SUBSETTER = "fontTools.subset"


def defer_font_subsetting() -> None:
    """Register ``fontTools.subset`` as a lazily loaded module (no-op when it is already
    imported or fontTools is missing)."""
    if SUBSETTER in sys.modules:
        return
    spec = importlib.util.find_spec(SUBSETTER)  # imports the small fontTools package itself
    if spec is None or spec.loader is None:
        return
    spec.loader = importlib.util.LazyLoader(spec.loader)
    module = importlib.util.module_from_spec(spec)
    sys.modules[SUBSETTER] = module
    spec.loader.exec_module(module)
    setattr(sys.modules["fontTools"], "subset", module)  # as the import statement would


def pdf_backend():
    """The ``matplotlib.backends.backend_pdf`` module."""
    if "matplotlib.backends.backend_pdf" not in sys.modules:
        defer_font_subsetting()
    from matplotlib.backends import backend_pdf

    return backend_pdf
