"""Engines: the rank test on one smooth branch.

Owns the observability rank condition (``orc``), Sedoglavic's power-series test mod p (``sedoglavic``),
the observability Jacobian mod p (``jacobian``), the split of a model into output-reachable blocks
(``decompose``) and the per-branch driver that picks an engine and states a verdict (``smooth``).

May import: ``observability.limits``, ``observability.verdicts``, ``model``, ``algebra``, ``errors``,
``_text``. Must never import: ``observability.joint``, ``observability.certificates``,
``observability.results``, ``observability.analyze``, ``observability.contract``.
"""
