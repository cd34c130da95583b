"""recombination: which combinations of the hidden parameters can still be identified.

Owns the identifiable reparametrization of a model, branch by branch and merged (``reparametrize``, its value
``reparametrization``), the readable invariants of translation and scaling symmetries (``invariants``), a
section of the scalings (``scalings``), a generating set of the identifiable functions (``identifiable``) and
the fields of functions decided modulo a prime (``fields``).

May import: ``errors``, ``_text``, ``_exports``, ``model``, ``algebra``, ``observability``.
Must never import: ``estimation``, ``linear``, ``report``, ``identification``, ``studies``, ``design``,
``batch``, ``cli``.
"""

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "identifiable_functions": "identifiable",
    "IdentifiableFunctions": "identifiable",
    "Reparametrization": "reparametrization",
    "same_field": "fields",
    "FieldComparison": "fields",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.recombination.fields import FieldComparison as FieldComparison
    from obsnl.recombination.fields import same_field as same_field
    from obsnl.recombination.identifiable import (
        IdentifiableFunctions as IdentifiableFunctions,
    )
    from obsnl.recombination.identifiable import (
        identifiable_functions as identifiable_functions,
    )
    from obsnl.recombination.reparametrization import Reparametrization as Reparametrization

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
