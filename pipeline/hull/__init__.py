"""The hull: a strake or a whole shell planned into plates, and each plate run to its class.

Takes the validated configuration (``config``) with its hull surface. Gives plates (``region``:
seams, butts, the plate record; ``plan``: a hand-laid strake and ``load_run``; ``planner``: the
adaptive plan, with ``splitting`` and ``seamlines``; ``trims``: IGES trims), each plate run
through the stages (``plates``: flat, strip, best-fit strip, patch or formed, with
``platestrip``, ``bestfit`` and ``strake``'s trimming), and the shell's plan DXF and class
picture (``planout``, ``hullplots``). Imports the stages and the shop below it, never export.
"""
