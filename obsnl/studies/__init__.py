"""studies"""

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "reproduce": "seed_paper", "Reproduction": "seed_paper", "run_link_study": "link_study",
    "build_cantilever": "cantilever", "read_link_spec": "link_model", "BreathingCrack": "cantilever",
    "bouc_wen_building": "buildings",
}

__all__ = list(_LAZY)


def __getattr__(name: str):
    if name in _LAZY:
        from importlib import import_module

        value = getattr(import_module(f"{__name__}.{_LAZY[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
