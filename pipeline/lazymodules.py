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


def defer_unused() -> None:
    """Defer, at a process's start (before scipy is imported), the modules above that
    the scientific stack imports without using them."""
    for name in ("numpy.testing", "numpy.f2py"):
        defer(name)


def pdf_backend():
    """The ``matplotlib.backends.backend_pdf`` module, imported without ``fontTools.subset``."""
    if "matplotlib.backends.backend_pdf" not in sys.modules:
        defer("fontTools.subset")
    return importlib.import_module("matplotlib.backends.backend_pdf")
