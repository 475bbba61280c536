"""The steel shop: what a plater and a cutting machine get from a developed plate, in mm.

Takes a part's result (its strip, development and hull region). Gives the exact cut outline
(``outline``), numbered bending lines (``bending``) and which of them are rolled (``rolling``:
the no-roll radius per thickness), frame lines and edge names (``marks``), excess and
shrinkage allowances (``allowance``), the texts' places (``layout``), the templates that
check a formed plate (``templates``), its pin-jig table (``pinjig``) and heating lines
(``heating``, with the workshop method's scale of the development), the shop data of a
plate (``plate``), and its files: the R2000 cutting DXF (``dxf``) and the one-page shop
drawing (``drawing``). Knows nothing of hulls, runs or configs beyond the settings passed in.
"""
