"""Nesting: flat parts onto a fabric roll (a marker) or steel stock plates.

``engine`` wraps sparrow (spyrrow) and checks every placement with shapely; ``command`` is
``devflat nest``: it runs the parts as ``devflat run`` does, nests them and writes the marker
or stock DXFs, the cutting list, the nesting report and pictures. Above the run's export.
"""
