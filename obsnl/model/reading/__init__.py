"""Reading: the text of a model.

Owns the safe expression parser (``parse``), the checks of names (``names``), LaTeX names
(``latex``), the declared number of unknown-input derivatives (``unknown_inputs``), and the reading of
every field of a model with these (``fields``: what :class:`~obsnl.model.core.Model` keeps of what it
was given).

May import: ``model.bounds``, ``errors``. Must never import: ``model.core``, ``model.files``,
``model.branching`` or any other room of obsnl.
"""
