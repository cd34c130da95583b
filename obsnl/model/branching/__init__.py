"""Branching: a non-smooth model as smooth branches.

Owns the switching functions (``switching``), the feasibility of their sign patterns
(``feasibility``), the split into branches (``branches``), representatives when there are too many
(``representatives``), the one choice between them that an analysis makes at its entry (``structure``),
where the vector field jumps (``jumps``) and the model's signature that a branch table is bound to
(``signature``).

May import: ``model.core``, ``model.reading``, ``model.bounds``, ``errors``. Must never import:
``model.files`` or any other room of obsnl.
"""
