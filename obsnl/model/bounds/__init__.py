"""Bounds: work decided before it is done.

Owns the estimates of symbolic work (``work``: expanded sizes, degrees, exact digits), the limits on a
model's text (``textsize``) and the one time budget from reading on (``budget``).

May import: ``errors``. Must never import: the rest of ``model`` or any other room of obsnl.
"""
