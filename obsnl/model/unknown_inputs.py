"""What an analysis assumes about the unknown inputs ``w(t)`` of a model: the value of the model key
and analysis option ``unknown_input_derivatives``.

``"arbitrary"``: any (analytic) function of time, what an engineer means by an unmeasured force;
``K``: a polynomial in t with K non-zero derivatives (STRIKE-GOLDD's ``opts.nnzDerW``; 0 = a constant).
"""

from __future__ import annotations

from typing import Any

from obsnl.errors import ModelError

__all__ = ["ARBITRARY", "check_unknown_input_derivatives"]

#: The value of ``unknown_input_derivatives`` for unknown inputs that are any function of time.
ARBITRARY = "arbitrary"


def check_unknown_input_derivatives(value: Any, *, allow_none: bool = False) -> int | str | None:
    """``"arbitrary"`` or a non-negative integer ``K`` (None too when ``allow_none``); else a ModelError.

    Parameters
    ----------
    value : Any
        ``"arbitrary"`` (any case), a non-negative int, or its decimal text.
    allow_none : bool
        Accept None (not given) and return it.

    Returns
    -------
    int, "arbitrary" or None

    Raises
    ------
    ModelError
        For any other value.

    Examples
    --------
    >>> check_unknown_input_derivatives("Arbitrary"), check_unknown_input_derivatives(1)
    ('arbitrary', 1)
    """
    if value is None and allow_none:
        return None
    if isinstance(value, str) and value.strip().lower() == ARBITRARY:
        return ARBITRARY
    if isinstance(value, str) and value.strip().isdigit() and len(value.strip()) <= 6:
        return int(value.strip())
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= 10**6:
        return value
    raise ModelError(
        f"unknown_input_derivatives must be \"arbitrary\" (any unknown input) or a non-negative integer K "
        f"(polynomial unknown inputs with K non-zero derivatives, STRIKE-GOLDD's nnzDerW), got {value!r}"
    )
