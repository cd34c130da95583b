"""Joint: which branches are analysed, and the verdict over all of them together.

Owns the choice of branches (all, representatives, or those a record visits: ``selection``,
``visited``), the stacked rank test over the visited branches (``visits``) and the joint verdict
(``verdict``): what only the branches together determine.

May import: ``observability.engines``, ``observability.limits``, ``observability.verdicts``,
``observability.assumptions``, ``model``, ``algebra``, ``errors``, ``_text``. Must never import: ``observability.certificates``,
``observability.results``, ``observability.analyze``, ``observability.contract``.
"""
