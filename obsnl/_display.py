"""The notebook display hook of result values: a result asks for its rendering by format, the top level wires the
renderers of :mod:`obsnl.report` in.

Result values live below the report room and never import it (renderings live in ``report`` only). A result's
``_repr_markdown_`` calls :func:`render`; ``obsnl/__init__`` (which Python imports before any module of the package)
registers, for each format, a function that imports the report's renderer on first use. An import of the room
that defines a result therefore never loads the report, and no module imports a room above its own.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["register", "render"]

_RENDERERS: dict[str, Callable[[Any], str | None]] = {}


def register(fmt: str, renderer: Callable[[Any], str | None]) -> None:
    """Render results in ``fmt`` (``"md"``, ``"tex"``, ``"html"``) with ``renderer(result) -> str``.

    Parameters
    ----------
    fmt : str
        The format.
    renderer : callable
        ``result -> text`` (None: not drawn in this format, the notebook falls back).
    """
    _RENDERERS[fmt] = renderer


def render(fmt: str, result: Any) -> str | None:
    """The registered rendering of ``result`` in ``fmt``, or None where no renderer is registered (a notebook then
    shows the plain ``repr``).

    Parameters
    ----------
    fmt : str
        The format.
    result : Any
        The result value.

    Returns
    -------
    str or None

    Examples
    --------
    >>> register("demo", lambda r: f"<{r}>")
    >>> render("demo", 3), render("no such format", 3)
    ('<3>', None)
    """
    renderer = _RENDERERS.get(fmt)
    return None if renderer is None else renderer(result)
