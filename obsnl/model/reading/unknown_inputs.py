"""What an analysis assumes about the unknown inputs ``w(t)`` of a model: the value of the model key
and analysis option ``unknown_input_derivatives``.

``"arbitrary"``: any (analytic) function of time, what an engineer means by an unmeasured force;
``K``: a polynomial in t with K non-zero derivatives (STRIKE-GOLDD's ``opts.nnzDerW``; 0 = a constant).

How large ``K`` may be for a model is :func:`max_unknown_input_derivatives`: the number of states
plus parameters plus :data:`DERIVATIVES_MARGIN`; the analyses refuse larger values before any work.
"""

from __future__ import annotations

from typing import Any, Literal, overload

from obsnl._text import quote
from obsnl.errors import ModelError

__all__ = [
    "ARBITRARY",
    "DERIVATIVES_MARGIN",
    "check_unknown_input_derivatives",
    "max_unknown_input_derivatives",
]

#: The value of ``unknown_input_derivatives`` for unknown inputs that are any function of time.
ARBITRARY = "arbitrary"

#: Derivatives allowed beyond the number of states plus parameters (room for the augmented functions
#: of exp, sin, ... terms, which :func:`obsnl.algebra.problem.arbitrary_terms` also counts).
DERIVATIVES_MARGIN = 16


@overload
def check_unknown_input_derivatives(value: Any, *, allow_none: Literal[False] = ...) -> int | str: ...


@overload
def check_unknown_input_derivatives(value: Any, *, allow_none: bool) -> int | str | None: ...


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
        f'unknown_input_derivatives must be "arbitrary" (any unknown input) or a non-negative integer K '
        f"(polynomial unknown inputs with K non-zero derivatives, STRIKE-GOLDD's nnzDerW), got {quote(value)}"
    )


def max_unknown_input_derivatives(n_states: int, n_parameters: int) -> int:
    """The largest ``K`` (non-zero derivatives of each unknown input) worth analysing for a model with
    ``n_states`` states and ``n_parameters`` parameters: ``n_states + n_parameters + DERIVATIVES_MARGIN``.

    Why this bound. For arbitrary unknown inputs the exact engines read ``N = n + 1`` Taylor
    coefficients of each input, ``n`` being the states, parameters and augmented functions of the
    model (:func:`obsnl.algebra.problem.arbitrary_terms`): the output coefficients of orders ``0..N-1``
    depend on the input's coefficients of orders ``0..N-1`` only, and ``n + 1`` orders are where the
    information the outputs give stops growing. A polynomial input with ``K >= n`` non-zero
    derivatives is already free in every coefficient those orders see; more derivatives only add
    unknowns (one column and one series term per unknown input each: ``K = 999999`` asked for a
    7 TiB array) and cannot add anything to the rank test. :data:`DERIVATIVES_MARGIN` stands for the
    augmented functions, which are not known before the model is rewritten.

    Parameters
    ----------
    n_states : int
        Number of states of the model.
    n_parameters : int
        Number of parameters of the model.

    Returns
    -------
    int
        The bound (at least :data:`DERIVATIVES_MARGIN`).

    Examples
    --------
    >>> max_unknown_input_derivatives(2, 2)
    20
    """
    return int(n_states) + int(n_parameters) + DERIVATIVES_MARGIN
