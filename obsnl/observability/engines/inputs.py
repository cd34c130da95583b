"""The checks of a model and of the options before any engine runs: the method, the bounds, the
unknown inputs' derivatives, the names of the variables.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from obsnl.errors import AnalysisError
from obsnl.model.core import Model
from obsnl.model.reading.unknown_inputs import ARBITRARY, check_unknown_input_derivatives
from obsnl.observability.limits import UNKNOWN_INPUT_OPTION, check_analysis_limits

__all__ = [
    "METHODS",
    "Checked",
    "check_model_and_options",
    "resolve_unknown_input_derivatives",
    "unknown_variable_names",
]

#: The engines that ``method=`` names (``auto`` picks one per branch).
METHODS = ("auto", "orc", "sedoglavic")


class Checked(NamedTuple):
    """What the checks settle for an analysis: the unknown-input assumption in force (the caller's option, else
    the model's key, else ``"arbitrary"``) and the reported variables (every state, then every parameter)."""

    unknown_input_derivatives: int | str
    variables: tuple[str, ...]


def check_model_and_options(
    model: Model,
    method: str,
    seed: int | None,
    max_seconds: float | None,
    prob: float,
    unknown_input_derivatives: int | str | None,
    input_derivatives: int | None,
    *,
    option: str = UNKNOWN_INPUT_OPTION,
) -> Checked:
    """Refuse bad options and a model the engines cannot take, before any work; return what they settle.

    The one check of an analysis's options and model (:func:`obsnl.observability.analyze.check_analysis` and
    :func:`obsnl.observability.engines.smooth.analyze_smooth` call it), what it settles resolved here once.

    Parameters
    ----------
    model : Model
        The model to analyse.
    method : str
        The engine, one of :data:`METHODS`.
    seed : int or None
        The random seed: a non-negative integer, or None for a fresh one.
    max_seconds : float or None
        The time limit: a positive finite number of seconds, or None for none.
    prob : float
        The required probability of a correct answer, strictly between 0 and 1.
    unknown_input_derivatives : int, str or None
        The caller's unknown-input option (None: the model's key, else ``"arbitrary"``).
    input_derivatives : int or None
        The known inputs' degree: a non-negative integer, or None for generic inputs.
    option : str
        How messages name the caller's unknown-input option, as for
        :func:`~obsnl.observability.limits.check_analysis_limits`.

    Returns
    -------
    Checked
        The unknown-input assumption in force and the reported variables (every state, then every parameter).

    Raises
    ------
    AnalysisError
        When ``model`` is not a :class:`~obsnl.model.core.Model`, an option is invalid, the model has no output,
        an output depends on no unknown or no output on a state, or the model has more unknowns than
        :data:`~obsnl.observability.limits.MAX_UNKNOWNS`.
    OptionError
        When the caller's ``unknown_input_derivatives`` is invalid, beyond its bound, or given for a model
        without unknown inputs.
    ModelError
        When the model's ``unknown_input_derivatives`` key is invalid or beyond its bound.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x"], parameters=["a"], equations={"x": "-a*x"}, outputs={"y": "x"})
    >>> check_model_and_options(m, "auto", 0, None, 0.99, None, None)
    Checked(unknown_input_derivatives='arbitrary', variables=('x', 'a'))
    """
    if not isinstance(model, Model):
        raise AnalysisError(f"expected an obsnl Model, got {type(model).__name__}; load one with obsnl.read_model")
    variables = _variable_names(model)
    if method not in METHODS:
        raise AnalysisError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if seed is not None and (not isinstance(seed, int) or isinstance(seed, bool) or seed < 0):
        raise AnalysisError(f"seed must be a non-negative integer or None, got {seed!r}")
    if max_seconds is not None and not (isinstance(max_seconds, (int, float)) and 0 < max_seconds < math.inf):
        raise AnalysisError(f"max_seconds= must be a positive finite number or None, got {max_seconds!r}")
    if not (isinstance(prob, float | int) and 0 < prob < 1):
        raise AnalysisError(f"prob must be strictly between 0 and 1, got {prob!r}")
    if input_derivatives is not None and (not isinstance(input_derivatives, int) or input_derivatives < 0):
        raise AnalysisError(f"input_derivatives must be a non-negative integer or None, got {input_derivatives!r}")
    if not model.outputs:
        raise AnalysisError(f"model {model.name!r} has no outputs; add at least one measured quantity")
    states = set(model.states)
    unknowns = states | set(model.parameters) | set(model.unknown_inputs)
    for name, expr in model.outputs.items():
        if not (expr.free_symbols & unknowns):
            raise AnalysisError(
                f"output {name!r} = {expr} of model {model.name!r} depends on no state, parameter or unknown "
                f"input; it carries no information: remove it or write what it measures"
            )
    if not any(expr.free_symbols & states for expr in model.outputs.values()):
        raise AnalysisError(f"no output of model {model.name!r} depends on a state; measure at least one state")
    # last: the unknown-input option (checked once, there) and the size of what the engines will hold (refused before
    # any heavy work)
    return Checked(check_analysis_limits(model, unknown_input_derivatives, option=option), variables)


def resolve_unknown_input_derivatives(model: Model, value: int | str | None) -> int | str:
    """The unknown-input assumption in force: ``value`` if given, else the model's
    ``unknown_input_derivatives`` key, else ``"arbitrary"`` (any function of time).

    Parameters
    ----------
    model : Model
        The model.
    value : int, str or None
        The caller's option.

    Returns
    -------
    int or "arbitrary"

    Raises
    ------
    ModelError
        When the value is neither ``"arbitrary"`` nor a non-negative integer.
    """
    if value is None:
        value = model.unknown_input_derivatives
    return ARBITRARY if value is None else check_unknown_input_derivatives(value)


def unknown_variable_names(model: Model) -> tuple[str, ...]:
    """The names of the variables an engine solves for: every state whose initial value is not known, then every
    parameter.

    Parameters
    ----------
    model : Model
        The (smooth) model or block.

    Returns
    -------
    tuple[str, ...]
        The states' names (those with a known initial value left out), then the parameters' names.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x", "v"], parameters=["a"], equations={"x": "v", "v": "-a*x"},
    ...           outputs={"y": "x"}, known_initial_conditions=["v"])
    >>> unknown_variable_names(m)
    ('x', 'a')
    """
    known = set(model.known_initial_conditions)
    return tuple(s.name for s in model.states if s not in known) + tuple(s.name for s in model.parameters)


def _variable_names(model: Model) -> tuple[str, ...]:
    """Reported variables: every state (a known initial value is observable) and parameter."""
    return tuple(s.name for s in model.states) + tuple(s.name for s in model.parameters)
