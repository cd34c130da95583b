"""Certificates: proofs that a parameter is not observable.

Owns the exact check of a candidate symmetry generator (``proofs``), the search for Lie symmetries of
one model (``symmetry``) and the symmetries shared by every branch, which certify the joint verdict
(``certify``).

May import: ``observability.joint``, ``observability.engines``, ``observability.limits``,
``observability.verdicts``, ``model``, ``algebra``, ``errors``, ``_text``. Must never import:
``observability.results``, ``observability.analyze``, ``observability.contract``.
"""
