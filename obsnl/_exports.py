"""The lazy exports of a package: each public name imported from the module that defines it on first use.

Every room of obsnl (and the top level) lists its public names in a table ``name -> module`` and takes its
``__getattr__`` and ``__dir__`` from :func:`lazy_exports`, so that importing one module of a room loads
nothing else and ``import obsnl`` loads no numeric library (PEP 562). A sub-package (a room) is imported on
first use too: ``import obsnl; obsnl.report.to_markdown(...)`` works as ``from obsnl import report`` does.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from importlib import import_module
from importlib.util import find_spec
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, namespace: dict[str, Any], table: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` of ``package`` for the names of ``table``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    namespace : dict
        The package's ``globals()``: a name, once imported, is kept there (later lookups do not come back).
    table : mapping of str to str
        Public name -> module of the package that defines it (relative, dotted: ``"engines.orc"``).

    Returns
    -------
    tuple of callable
        ``(__getattr__, __dir__)``.

    Examples
    --------
    >>> ns = {}
    >>> getattr_, dir_ = lazy_exports("obsnl", ns, {"OptionError": "errors"})
    >>> getattr_("OptionError").__name__, "OptionError" in ns, dir_()
    ('OptionError', True, ['OptionError'])
    >>> getattr_("report").__name__  # a room, imported on first use
    'obsnl.report'
    """

    def __getattr__(name: str) -> Any:
        if name in table:
            value = getattr(import_module(f"{package}.{table[name]}"), name)
            namespace[name] = value
            return value
        if not name.startswith("_") and name.isidentifier() and find_spec(f"{package}.{name}") is not None:
            return import_module(f"{package}.{name}")  # a sub-package or module: the import binds it
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(table))

    return __getattr__, __dir__
