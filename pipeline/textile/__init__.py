"""Textile pieces: from a developed strip to what a cutting room and a sewing room read.

Takes parts run through the stages with the textile profile. Gives pieces with sew line,
seam allowance, notches and grain line (``pieces``), the seams that pieces share and sew edge
to edge (``seams``), ASTM D6673 / AAMA DXF written and read (``aama``), 1:1 printouts
(``printout``) and the piece's preview picture (``preview``).
"""
