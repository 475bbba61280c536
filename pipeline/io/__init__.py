"""Input and output at the bottom of the pipeline: files in, files out, nothing of a run.

Takes paths and bytes: YAML read within limits (``inputs``), IGES curves and surfaces
(``iges``), curve sources beside inline NURBS (``sources``: IGES, DXF, point lists).
Gives files written whole or not at all (``atomic``) and the strip as OBJ (``meshio``).
Imports only ``flatten`` and itself.
"""
