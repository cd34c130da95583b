"""Contract: the branch table, the one view of an analysis that the estimators read.

Owns the branch table's value, its JSON reading and writing (``branch_table``) and the check of a
table against a fresh analysis of its model (``table_check``).

May import: everything else in ``observability``, ``model``, ``errors``, ``_text``. Must never import:
``estimation`` or anything above it (the estimators import this room, not the other way round).
"""
