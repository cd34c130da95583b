"""recombination"""

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "identifiable_functions": "identifiable", "IdentifiableFunctions": "identifiable",
    "Reparametrization": "reparametrization", "same_field": "fields", "FieldComparison": "fields",
}

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
