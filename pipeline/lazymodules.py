"""Modules that libraries import at their top but devflat's runs never use, loaded on
first use instead (``importlib.util.LazyLoader``, the standard library's lazy import: the
module object is registered at once and executed when an attribute is first read, so any
code that does use it gets the real module at that moment).

- ``fontTools.subset``: ``matplotlib.backends.backend_pdf`` imports it (through
  ``_backend_pdf_ps``) to subset TrueType fonts embedded as Type 42, a third of the
  backend's import (~0.1 s CPU: fontTools' OpenType tables). devflat's PDFs never embed
  Type 42: the shop drawing writes in the PDF core fonts (nothing embedded) and the
  textile printout embeds DejaVu as Type 3 (matplotlib's default ``pdf.fonttype``),
  which matplotlib converts without fontTools.
- ``scipy.ndimage``: trimesh's voxel module imports it when trimesh is imported (~0.04 s,
  a third of trimesh's import); devflat uses trimesh's meshes, never its voxels.
- ``numpy.testing`` and ``numpy.f2py``: scipy's bundled ``array_api_compat.numpy`` runs
  ``from numpy import *``, and numpy 2 lists these lazily loaded submodules in its
  ``__all__``, so every ``import scipy.interpolate`` loads numpy's test helpers (unittest)
  and the Fortran wrapper generator (which pulls in charset_normalizer): ~0.06 s of a
  0.33 s scipy import, for modules nothing in a run calls. Deferred, the star import binds
  the registered module objects without executing them.

And one library's work that devflat's runs repeat needlessly:

- a PDF core font's AFM file: matplotlib's PDF backend parses it whole (its kerning pairs,
  ~2.6 ms for Helvetica) each time it writes a PDF that uses the font, only to read the
  font's name (``PdfFile._write_afm_font``); a hull run writes a shop drawing per plate in
  the core fonts (1.7 CPU s of the 160 m hull's run). :func:`pdf_backend` has the backend
  parse each AFM file once per process (:class:`ParsedOnce`).
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import sys


def defer(name: str) -> None:
    """Register the module ``name`` ("package.module") to load on first use (no-op when it
    is already imported or cannot be found). Imports its parent package now."""
    if name in sys.modules:
        return
    spec = importlib.util.find_spec(name)
    if spec is None or spec.loader is None:
        return
    spec.loader = importlib.util.LazyLoader(spec.loader)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    parent, _, child = name.rpartition(".")
    setattr(sys.modules[parent], child, module)  # as the import statement would


def defer_unused() -> None:
    """Defer, at a process's start (before scipy is imported), the modules above that
    the scientific stack imports without using them."""
    for name in ("numpy.testing", "numpy.f2py"):
        defer(name)


def pdf_backend():
    """The ``matplotlib.backends.backend_pdf`` module, imported without ``fontTools.subset``,
    parsing each core font's AFM file once (:class:`ParsedOnce`)."""
    if "matplotlib.backends.backend_pdf" not in sys.modules:
        defer("fontTools.subset")
    backend = importlib.import_module("matplotlib.backends.backend_pdf")
    parse = getattr(backend, "AFM", None)
    if parse is not None and not isinstance(parse, ParsedOnce):
        backend.AFM = ParsedOnce(parse)
    return backend


class ParsedOnce:
    """``parse(file)`` (an AFM font parser called on an open file) answered from the first
    parse of the same file: the same device, inode, size and modification time. The PDF
    backend calls its ``AFM`` only to write a core font's dictionary, and reads nothing from
    the parse but the font's name; an AFM object is not changed by reading it. A file object
    without a descriptor (``BytesIO``) is parsed each time."""

    def __init__(self, parse):
        self.parse = parse
        self.parsed: dict = {}

    def __call__(self, file):
        try:
            stat = os.fstat(file.fileno())
        except (AttributeError, OSError, ValueError):  # io.UnsupportedOperation is both of the last two
            return self.parse(file)
        key = (stat.st_dev, stat.st_ino, stat.st_size, stat.st_mtime_ns)
        if key not in self.parsed:
            self.parsed[key] = self.parse(file)
        return self.parsed[key]
