"""Reading: the text of a model.

Owns the safe expression parser (``parse``), the checks of names (``names``), LaTeX names
(``latex``) and the declared number of unknown-input derivatives (``unknown_inputs``).

May import: ``model.bounds``, ``errors``. Must never import: ``model.core``, ``model.files``,
``model.branching`` or any other room of obsnl.
"""
