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
"""

from __future__ import annotations

import importlib
import importlib.util
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


def pdf_backend():
    """The ``matplotlib.backends.backend_pdf`` module, imported without ``fontTools.subset``."""
    if "matplotlib.backends.backend_pdf" not in sys.modules:
        defer("fontTools.subset")
    return importlib.import_module("matplotlib.backends.backend_pdf")
