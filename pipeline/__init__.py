"""devflat's run: a configuration in, a part's or a hull's files out.

The top level holds the run itself: ``cli`` (the ``devflat`` command), ``validate``,
``config``, ``stages`` (solve, strip, check, unroll, pattern), ``runner``, ``export``,
``report``, ``outdir`` (the output folder as a transaction), ``plots`` and the start-up
helpers ``lazymodules`` and ``renderproc``. The trades live in wings below it: ``io``,
``shop``, ``hull``, ``textile``, ``nest``. docs/architecture.md draws the floors; a wing
imports only downward (tests/test_architecture.py).
"""
