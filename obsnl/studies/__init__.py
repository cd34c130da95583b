"""studies"""

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "reproduce": "seed_paper", "Reproduction": "seed_paper", "run_link_study": "link_study",
    "build_cantilever": "cantilever", "read_link_spec": "link_model", "BreathingCrack": "cantilever",
    "bouc_wen_building": "buildings",
}

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
