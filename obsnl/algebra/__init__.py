"""algebra: the exact arithmetic of the randomized rank test, below every engine.

Owns non-rational terms rewritten over augmented functions (``atoms``, ``atom_table``,
``augment``), straight-line programs (``slp``), arithmetic modulo a prime (``modp``), first-order jets and
truncated power series on those programs (``jets``, ``series``, ``taylor``), a smooth model prepared for the
engines (``problem``) and the rank, kernel and probability bounds they share (``bounds``).

May import: ``errors``, ``_text``, ``_exports``, ``model``.
Must never import: ``observability``, ``recombination``, ``estimation``, ``linear``, ``report``,
``identification``, ``studies``, ``design``, ``batch``, ``cli``.
"""
