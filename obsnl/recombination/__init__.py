"""recombination: which combinations of the hidden parameters can still be identified.

Owns the identifiable reparametrization of a model, branch by branch and merged (``reparametrize``, its value
``reparametrization``), the readable invariants of translation and scaling symmetries (``invariants``), a
section of the scalings (``scalings``), a generating set of the identifiable functions (``identifiable``) and
the fields of functions decided modulo a prime (``fields``).

May import: ``errors``, ``_text``, ``_exports``, ``model``, ``algebra``, ``observability``.
Must never import: ``estimation``, ``linear``, ``report``, ``identification``, ``studies``, ``design``,
``batch``, ``cli``.
"""

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "identifiable_functions": "identifiable", "IdentifiableFunctions": "identifiable",
    "Reparametrization": "reparametrization", "same_field": "fields", "FieldComparison": "fields",
}

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
