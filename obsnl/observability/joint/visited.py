"""The branches an experiment visits: simulate the model's ``[values]`` under a record and collect the sign
patterns of its switching functions, the time spent in each and the crossings of each surface.

The simulation is the classical Runge-Kutta scheme with ``substeps`` fixed steps per sample interval
(bounded work whatever the field does: on a sliding surface it chatters instead of stalling an
adaptive step) on the model's right-hand side
(``sympy.lambdify``), the record's input held linear between samples; the switching functions are
evaluated at the record's sample times. A sample at which some switching function is zero (a state at
rest on a surface) belongs to no branch and is not counted.

This is the reading at the samples only: a contact that opens and closes between two samples is no visit here, and
a mass that dry friction holds chatters across ``v = 0`` (the fixed steps have no sliding mode). ``obsnl design``
and ``obsnl analyze --record`` read the visits along the continuous trajectory instead
(:mod:`obsnl.design.continuous`, which sits above the estimation room whose located, sliding step it uses); this
module keeps the :class:`Visits` they return and the record checks they share (:func:`checked_record`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import sympy as sp

from obsnl.errors import AnalysisError
from obsnl.model.bounds.budget import check_time
from obsnl.model.branching.switching import expr_text, switching_of
from obsnl.model.core import NONSMOOTH_FUNCTIONS, Model

__all__ = ["Visits", "visited_patterns", "checked_record", "BlewUp"]


class BlewUp(AnalysisError):
    """The simulation under a record left the finite numbers: ``time`` is the exact sample time it did so."""

    def __init__(self, time: float) -> None:
        super().__init__(
            f"the simulation under the record blew up at t = {time:.4g}; check the [values] and the record's amplitude"
        )
        self.time = float(time)


@dataclass(frozen=True)
class Visits:
    """Sign patterns visited by a simulation, with the seconds spent in each and the crossings.

    Attributes
    ----------
    switching
        The switching functions (text), in the order of the patterns' signs.
    patterns
        ``{signs: seconds}`` in order of first visit.
    crossings
        ``{switching function: number of sign changes}``.
    """

    switching: tuple[str, ...]
    patterns: Mapping[tuple[int, ...], float]
    crossings: Mapping[str, int]


def checked_record(
    model: Model, t: np.ndarray, inputs: Mapping[str, np.ndarray], values: Mapping[str, float] | None = None
) -> tuple[dict[str, float], np.ndarray, list[np.ndarray]]:
    """The numbers, the times and the input samples (in the model's input order) of a simulation under a record,
    checked: increasing times, a number for every parameter and known constant, every input known, finite and as
    long as the times.

    Parameters
    ----------
    model : Model
        The model simulated.
    t : ndarray
        Sample times.
    inputs : mapping of str to ndarray
        One array per model input, sampled at ``t``.
    values : mapping of str to float or None
        Numbers to use instead of the model's ``[values]``.

    Returns
    -------
    tuple
        ``(values, t, signals)``.

    Raises
    ------
    AnalysisError
        What is missing or wrong, in one line.
    """
    vals = dict(model.values if values is None else values)
    t = np.asarray(t, float)
    if t.ndim != 1 or len(t) < 2 or not np.all(np.diff(t) > 0):
        raise AnalysisError("the record's times must increase; fix the record")
    missing = [s.name for s in list(model.parameters) + list(model.known_constants) if s.name not in vals]
    if missing:
        raise AnalysisError(f"record= simulates the model's [values]: give a number for {', '.join(missing)}")
    lacking = [u.name for u in model.inputs if u.name not in inputs]
    if lacking or model.unknown_inputs:
        raise AnalysisError(
            f"record= needs every input of the model as a known signal (missing: "
            f"{', '.join(lacking + [w.name for w in model.unknown_inputs])})"
        )
    signals = [
        np.asarray(inputs[u.name], float) for u in model.inputs
    ]  # checked first, even where nothing is simulated
    if any(u.shape != t.shape for u in signals) or not all(np.all(np.isfinite(u)) for u in signals):
        raise AnalysisError("the record's input must be finite and as long as its time column")
    return vals, t, signals


def visited_patterns(
    model: Model,
    t: np.ndarray,
    inputs: Mapping[str, np.ndarray],
    *,
    values: Mapping[str, float] | None = None,
    substeps: int = 10,
) -> Visits:
    """Simulate ``model`` under ``inputs`` and collect the visited sign patterns.

    Parameters
    ----------
    model : Model
        A model with numbers for every parameter and known constant in ``values`` (default: the
        model's ``[values]``); initial states from ``values`` too (0 when absent).
    t : ndarray
        Sample times (increasing).
    inputs : mapping of str to ndarray
        One array per model input, sampled at ``t``.
    values : mapping of str to float or None
        Numbers to use instead of the model's ``[values]``.
    substeps : int
        Fixed Runge-Kutta steps per sample interval (the input is linear in between).

    Returns
    -------
    Visits

    Raises
    ------
    AnalysisError
        A missing number or input, or a simulation that fails.

    Examples
    --------
    >>> import numpy as np
    >>> from obsnl import Model
    >>> m = Model(name="relay", states=["x", "v"], parameters=["k", "s"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x - s*sign(v)"}, outputs={"y": "x"},
    ...           values={"k": 1.0, "s": 0.1, "x": 0.0, "v": 0.0})
    >>> t = np.linspace(0.0, 10.0, 1001)
    >>> vis = visited_patterns(m, t, {"u": np.sin(t)})
    >>> sorted(vis.patterns), vis.switching
    ([(-1,), (1,)], ('v',))
    """
    vals, t, signals = checked_record(model, t, inputs, values)
    xs, us = list(model.states), list(model.inputs)
    exprs = list(model.rhs) + list(model.output_exprs)
    if not any(e.has(*NONSMOOTH_FUNCTIONS) for e in exprs):
        return Visits((), {(): float(t[-1] - t[0])}, {})
    sw = tuple(switching_of(exprs, model.switching, {}))
    subs = {s: sp.Float(vals[s.name]) for s in list(model.parameters) + list(model.known_constants)}
    f = sp.lambdify([xs, us], [e.xreplace(subs) for e in model.rhs], modules="numpy")
    g = sp.lambdify([xs, us], [e.xreplace(subs) for e in sw], modules="numpy")
    U = np.vstack(signals) if us else np.zeros((0, len(t)))

    def rhs(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return np.asarray(f(list(x), list(u)), float)

    X = np.zeros((len(t), len(xs)))
    X[0] = [float(vals.get(s.name, 0.0)) for s in xs]
    with np.errstate(all="ignore"):  # a blow-up is refused below in one line, not warned of on the way
        for k in range(len(t) - 1):
            if k % 256 == 0:  # a command's --max-seconds covers the simulation (200 000 samples took 32 s)
                check_time(
                    f"simulating the model under the record (sample {k} of {len(t)})",
                    "raise max_seconds=, or give a shorter record",
                )
            x, h = X[k].copy(), (t[k + 1] - t[k]) / substeps
            for i in range(substeps):
                a0, a1 = i / substeps, (i + 0.5) / substeps
                u0, um, u1 = (U[:, k] * (1 - a) + U[:, k + 1] * a for a in (a0, a1, (i + 1) / substeps))
                k1 = rhs(x, u0)
                k2 = rhs(x + h / 2 * k1, um)
                k3 = rhs(x + h / 2 * k2, um)
                k4 = rhs(x + h * k3, u1)
                x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            if not np.all(np.isfinite(x)):
                raise BlewUp(t[k + 1])
            X[k + 1] = x
    with np.errstate(all="ignore"):  # every sample at once (a constant switching function broadcasts)
        G = np.column_stack([np.broadcast_to(np.asarray(c, float), (len(t),)) for c in g(list(X.T), list(U))])
    scale = np.maximum(np.max(np.abs(G), axis=0), 1e-300)
    signs = np.sign(np.where(np.abs(G) > 1e-12 * scale, G, 0.0)).astype(int)
    dt = np.diff(t, append=t[-1] + (t[-1] - t[-2]))
    patterns: dict[tuple[int, ...], float] = {}
    for k in range(len(t)):
        key = tuple(int(s) for s in signs[k])
        if 0 in key:
            continue
        patterns[key] = patterns.get(key, 0.0) + float(dt[k])
    crossings = {}
    for j, expr in enumerate(sw):
        col = signs[:, j][signs[:, j] != 0]
        crossings[expr_text(expr)] = int(np.count_nonzero(np.diff(col)))
    return Visits(tuple(expr_text(e) for e in sw), patterns, crossings)
