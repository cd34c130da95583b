"""What the exact engines refuse before any heavy work: models too large for their dense arrays, and
unknown inputs with more derivatives than the rank test can use.

Size. Both engines (:mod:`obsnl.observability.engines.sedoglavic`, :mod:`obsnl.observability.engines.orc`) and the
joint verdict (:mod:`obsnl.observability.joint.verdict`, which works on the whole model, not on its
independent blocks) hold dense int64 *jets*: a value and its gradient with respect to the ``M``
unknowns (initial states, parameters, Taylor coefficients of the unknown inputs). The Taylor stepper
(:class:`obsnl.algebra.taylor.Stepper`) keeps the tangent map of every node of the model's program,
an ``(n_sources, M + 1)`` array per node with at least one source per state, and the series of the
right-hand sides and outputs over up to ``M`` orders (:meth:`obsnl.algebra.problem.Problem.order_bound`),
a ``(orders, rows, M + 1)`` array. Memory therefore grows as the cube of the model's size: at least
``8 (M + 1) n_x (n_x + M)`` bytes (:func:`dense_bytes`), and on the cheapest model there is, the linear
chain ``s_i' = -k s_i + u`` with ``y = s_0``, ``obsnl analyze`` measured (2 cores) 0.66 GB and 3.5 s at
200 unknowns, 1.8 GB and 9 s at 300, 4.2 GB and 24 s at 400, and was killed for memory at 3001.
:data:`MAX_UNKNOWNS` (300) is seven times the largest model of the catalogue and the test cases
(42 states and parameters, ``genssi_highdimnonlin``) and keeps such a model within a few GB.

Unknown-input derivatives: at most :func:`obsnl.model.reading.unknown_inputs.max_unknown_input_derivatives`
(states + parameters + 16); its docstring says why more cannot change a verdict.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from obsnl._text import shorten
from obsnl.errors import AnalysisError, ModelError, OptionError
from obsnl.model.reading.unknown_inputs import (
    ARBITRARY,
    DERIVATIVES_MARGIN,
    check_unknown_input_derivatives,
    max_unknown_input_derivatives,
)

if TYPE_CHECKING:  # only annotated: the command line reads the limits for its help without loading sympy
    from obsnl.model.core import Model

__all__ = [
    "MAX_UNKNOWNS",
    "analysis_size",
    "dense_bytes",
    "check_analysis_limits",
    "out_of_memory",
    "check_file_limits",
    "UNKNOWN_INPUT_OPTION",
]

#: The most unknowns (states + parameters + unknown-input coefficients) an analysis accepts.
MAX_UNKNOWNS = 300

#: How messages name the caller's unknown-input option by default (the keyword of :func:`obsnl.analyze`).
UNKNOWN_INPUT_OPTION = "unknown_input_derivatives"


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" + ("" if n == 1 else "s")


def analysis_size(model: Model, unknown_input_derivatives: int | str) -> int:
    """Number of unknowns the engines handle for ``model``: states, parameters, and the Taylor
    coefficients of the unknown inputs (``K + 1`` each; ``states + parameters + 1`` each when they are
    arbitrary, the count of :func:`obsnl.algebra.problem.arbitrary_terms` without augmented functions).

    States with a known initial value count too: they are not Jacobian columns, but every state
    carries its series and tangent map, so the count stays a lower bound of the engines' work.

    Parameters
    ----------
    model : Model
        The model to analyse.
    unknown_input_derivatives : int or "arbitrary"
        The unknown-input assumption in force.

    Returns
    -------
    int

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x", "v"], parameters=["c", "k"], unknown_inputs=["w"],
    ...           equations={"x": "v", "v": "-c*v - k*x + w"}, outputs={"y": "x"})
    >>> analysis_size(m, 1), analysis_size(m, "arbitrary")
    (6, 9)
    """
    n = len(model.states) + len(model.parameters)
    if not model.unknown_inputs:
        return n
    per_input = n + 1 if unknown_input_derivatives == ARBITRARY else int(unknown_input_derivatives) + 1
    return n + len(model.unknown_inputs) * per_input


def dense_bytes(n_states: int, size: int) -> int:
    """A lower bound of the memory (bytes) the dense jet arrays of an analysis take.

    The tangent maps of the state nodes, ``n_states`` arrays of at least ``n_states x (size + 1)``
    int64, plus the kept series of the state right-hand sides over ``size`` orders,
    ``size x n_states x (size + 1)`` int64: ``8 (size + 1) n_states (n_states + size)``.

    Parameters
    ----------
    n_states : int
        Number of states.
    size : int
        Number of unknowns (:func:`analysis_size`).

    Returns
    -------
    int

    Examples
    --------
    >>> dense_bytes(3000, 3001) // 2**30
    402
    """
    return 8 * (size + 1) * n_states * (n_states + size)


def _gib(nbytes: int) -> str:
    gib = nbytes / 2**30
    return f"{gib:.0f} GiB" if gib >= 10 else f"{gib:.1f} GiB" if gib >= 0.1 else f"{nbytes / 2**20:.0f} MiB"


def _given(where: str, value: object) -> str:
    """``where`` and the value given: ``--flag 5``, ``keyword=5`` (a Python keyword), else ``where = 5``."""
    if where.startswith("-"):
        return f"{where} {value}"
    if where.isidentifier() or where.endswith("="):
        return f"{where.rstrip('=')}={value}"
    return f"{where} = {value}"


def check_analysis_limits(
    model: Model, unknown_input_derivatives: int | str | None = None, *, option: str = UNKNOWN_INPUT_OPTION
) -> int | str:
    """Refuse, before any heavy work, an analysis of ``model`` larger than the engines can hold.

    Checks that ``unknown_input_derivatives`` (the caller's option, else the model's key, else
    ``"arbitrary"``) is valid and, when the model has unknown inputs, at most
    :func:`~obsnl.model.reading.unknown_inputs.max_unknown_input_derivatives`; then that the number of unknowns
    (:func:`analysis_size`) is at most :data:`MAX_UNKNOWNS`.

    Parameters
    ----------
    model : Model
        The model to analyse.
    unknown_input_derivatives : int, str or None
        The caller's unknown-input option (None: the model's key, else ``"arbitrary"``).
    option : str
        How the caller's option is named in messages (``"--unknown-input-derivatives"`` on the
        command line).

    Returns
    -------
    int or "arbitrary"
        The unknown-input assumption in force.

    Raises
    ------
    OptionError
        The caller's ``unknown_input_derivatives`` is not ``"arbitrary"``, nor an integer from 0 to the bound, or
        is given for a model without unknown inputs (it would be ignored).
    ModelError
        The same for the model's ``unknown_input_derivatives`` key.
    AnalysisError
        The model has more than :data:`MAX_UNKNOWNS` unknowns.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="ui", states=["x", "v"], parameters=["c", "k"], unknown_inputs=["w"],
    ...           equations={"x": "v", "v": "-c*v - k*x + w"}, outputs={"y": "x"})
    >>> check_analysis_limits(m, "3")
    3
    >>> try:
    ...     check_analysis_limits(m, 999999)
    ... except OptionError as exc:
    ...     print(str(exc)[:70])
    unknown_input_derivatives=999999 is more than model 'ui' can use: at m
    """
    given = unknown_input_derivatives is not None
    value = unknown_input_derivatives if given else model.unknown_input_derivatives
    where = option if given else "the model's unknown_input_derivatives key"
    error = OptionError if given else ModelError
    try:
        k = ARBITRARY if value is None else check_unknown_input_derivatives(value)
    except ModelError as exc:
        raise error(f"{where}: {exc}") from None
    if given and not model.unknown_inputs:  # it describes the unknown inputs: without any it would be ignored
        raise OptionError(
            f"{where} describes the unknown inputs, and model {model.name!r} has none; drop it "
            f"(or declare the model's unknown_inputs)"
        )
    n_x, n_p = len(model.states), len(model.parameters)
    bound = max_unknown_input_derivatives(n_x, n_p)
    if model.unknown_inputs and k != ARBITRARY and int(k) > bound:
        raise error(
            f"{_given(where, k)} is more than model {model.name!r} can use: at most {bound} (states + parameters "
            f"+ {DERIVATIVES_MARGIN} = {n_x} + {n_p} + {DERIVATIVES_MARGIN}): even an arbitrary unknown input enters "
            f"the rank test through its first states + parameters + augmented functions + 1 Taylor coefficients "
            f"only (obsnl.algebra.problem.arbitrary_terms), so more derivatives add nothing but cost; give "
            f"K <= {bound} or 'arbitrary'"
        )
    size = analysis_size(model, k)
    if size > MAX_UNKNOWNS:
        parts = [_plural(n_x, "state"), _plural(n_p, "parameter")]
        if model.unknown_inputs:
            parts.append(_plural(size - n_x - n_p, "unknown-input coefficient"))
        raise AnalysisError(
            f"model {model.name!r} has {size} unknowns ({' + '.join(parts)}), more than the {MAX_UNKNOWNS} the "
            f"exact engines accept (their dense arrays grow as the cube of that number: at least "
            f"{_gib(dense_bytes(n_x, size))} here); analyse a reduced model (fewer states or parameters"
            f"{', fewer unknown inputs or a smaller unknown_input_derivatives' if model.unknown_inputs else ''})"
        )
    return k


def check_file_limits(data: Mapping[str, Any]) -> None:
    """Refuse, on a model file's raw content and before any expression is parsed, a model whose states and
    parameters alone exceed :data:`MAX_UNKNOWNS` (reading 50 000 states took 99 s before the refusal).

    Parameters
    ----------
    data : mapping
        The file's keys (:func:`obsnl.model.files.read_model_file`), not validated yet.

    Raises
    ------
    AnalysisError
        Naming the counts and the bound, as :func:`check_analysis_limits` does for a loaded model.

    Examples
    --------
    >>> check_file_limits({"name": "chain", "states": [f"s{i}" for i in range(400)], "parameters": ["k"]})
    Traceback (most recent call last):
    ...
    obsnl.errors.AnalysisError: model 'chain' has 401 unknowns (400 states + 1 parameter), more than the 300 the exact engines accept (their dense arrays grow as the cube of that number: at least 1.0 GiB here); analyse a reduced model (fewer states or parameters)
    """

    def count(key: str) -> int:
        v = data.get(key)
        return len(v) if isinstance(v, (list, tuple)) else 0

    n_x, n_p = count("states"), count("parameters")
    if n_x + n_p > MAX_UNKNOWNS:
        name = data.get("name")
        raise AnalysisError(
            f"model {shorten(repr(name if isinstance(name, str) else '?'), 40)} has "
            f"{'at least ' if count('unknown_inputs') else ''}{n_x + n_p} unknowns "
            f"({_plural(n_x, 'state')} + {_plural(n_p, 'parameter')}), more than the {MAX_UNKNOWNS} the exact "
            f"engines accept (their dense arrays grow as the cube of that number: at least "
            f"{_gib(dense_bytes(n_x, n_x + n_p))} here); analyse a reduced model (fewer states or parameters)"
        )


def out_of_memory(model: Model, unknown_input_derivatives: int | str | None = None) -> AnalysisError:
    """The one-line error that replaces a ``MemoryError`` raised inside an analysis of ``model``.

    Parameters
    ----------
    model : Model
        The analysed model.
    unknown_input_derivatives : int, str or None
        The unknown-input assumption in force (None: not known, the size then leaves it out).

    Returns
    -------
    AnalysisError
        To be raised by the caller, outside its ``except MemoryError`` block (so that the arrays the
        failed computation held are freed first).

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x"], parameters=["a"], equations={"x": "-a*x"}, outputs={"y": "x"})
    >>> str(out_of_memory(m))[:40]
    "ran out of memory analysing model 'm' (2"
    """
    k = ARBITRARY if unknown_input_derivatives is None else unknown_input_derivatives
    size = analysis_size(model, k)
    fewer = (
        "fewer states, parameters or unknown inputs, or a smaller unknown_input_derivatives"
        if model.unknown_inputs
        else "fewer states or parameters"
    )
    return AnalysisError(
        f"ran out of memory analysing model {model.name!r} ({size} unknowns); give the process more memory, "
        f"or analyse a reduced model ({fewer})"
    )
