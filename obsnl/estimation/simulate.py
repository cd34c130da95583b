"""Simulate a compiled model over a record: the "truth" of an identification experiment.

The input is interpolated linearly between samples; the whole record is one casadi ``mapaccum``
call. The default discretisation (RK4 with 100 substeps per sample; a substep in which a switching
function across which the field can jump changes sign redone with 8 finer ones) is converged far
below the 0.1 % measurement noise of the seed experiment for the damage-healing model (the switching
of the healing operator makes its right-hand side discontinuous, so fixed-step methods converge only
to first order there; ``tests/test_seed_models.py`` checks the default against scipy's LSODA).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

import casadi as ca

from obsnl.errors import DataError, EstimatorError
from obsnl.estimation.jitcache import jit_compile
from obsnl.estimation.numeric import NumericModel

__all__ = ["Simulation", "simulate"]


@dataclass(frozen=True, eq=False)
class Simulation:
    """States ``x`` ``(T, nx)`` and outputs ``y`` ``(T, ny)`` at the sample times ``t``."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    states: tuple[str, ...]
    outputs: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        return {"t": self.t.tolist(), "states": list(self.states), "outputs": list(self.outputs),
                "x": self.x.tolist(), "y": self.y.tolist()}


_RUNS: dict[tuple, tuple[NumericModel, ca.Function]] = {}


def _runner(model: NumericModel, dt: float, T: int, method: str, substeps: int, refine: int,
            jit: bool) -> ca.Function:
    """``(x0, theta, u0s, u1s) -> X`` over ``T - 1`` steps; with ``jit`` one compiled loop (cached per model)."""
    key = (id(model), float(dt), int(T), method, int(substeps), int(refine), bool(jit))
    if key not in _RUNS:
        step = model.step(dt, method=method, substeps=substeps, refine=refine)
        if jit:  # one step in C; the fallbacks stay conditional (evaluated only where needed)
            X, P = ca.MX.sym("x", model.nx), ca.MX.sym("p", model.np)
            U0, U1 = ca.MX.sym("u0", model.nu), ca.MX.sym("u1", model.nu)
            step = jit_compile(ca.Function(step.name(), [X, P, U0, U1], step(X, P, U0, U1)))
        _RUNS[key] = (model, step.mapaccum(T - 1))  # keeps the model alive: its id stays unique
        if len(_RUNS) > 64:
            _RUNS.pop(next(iter(_RUNS)))
    return _RUNS[key][1]


def simulate(model: NumericModel, *, theta: Any, x0: Any, u: Any, dt: float, method: str = "auto",
             substeps: int = 100, refine: int = 8, jit: bool = False) -> Simulation:
    """Simulate ``model`` from ``x0`` with parameters ``theta`` under the input samples ``u``.

    Parameters
    ----------
    model
        Compiled model.
    theta, x0
        Parameter values and initial state (model order).
    u
        Input samples, shape ``(T,)`` for one input or ``(T, nu)``.
    dt
        Sampling interval.
    method, substeps, refine
        Discretisation (:meth:`obsnl.estimation.codegen.NumericModel.step`).
    jit
        Compile the step to C once per model, step and record length (a few seconds), for
        repeated simulations (tuning, sensitivities); the same numbers as without.

    Raises
    ------
    DataError
        Bad shapes or non-finite input.
    EstimatorError
        The simulation left the finite numbers (the parameters make the model unstable).
    """
    u = np.asarray(u, float)
    u = u.reshape(-1, 1) if u.ndim == 1 else u
    if u.ndim != 2 or u.shape[1] != model.nu or len(u) < 2:
        raise DataError(f"input must have shape (T, {model.nu}) with T >= 2, got {u.shape}")
    if not np.all(np.isfinite(u)):
        raise DataError("input contains NaN/inf")
    theta, x0 = np.asarray(theta, float), np.asarray(x0, float)
    if theta.shape != (model.np,) or x0.shape != (model.nx,):
        raise DataError(f"theta needs {model.np} values and x0 {model.nx}")
    run = _runner(model, dt, len(u), method, substeps, refine, jit)
    X = np.vstack([x0, np.asarray(run(x0, theta, u[:-1].T, u[1:].T)[0]).T])
    if not np.all(np.isfinite(X)):
        k = int(np.flatnonzero(~np.all(np.isfinite(X), axis=1))[0])
        raise EstimatorError(f"the simulation of {model.name!r} left the finite numbers at sample {k}")
    Y = np.asarray(model.h.map(len(u))(X.T, theta, u.T)).T
    return Simulation(t=np.arange(len(u)) * dt, x=X, y=Y, states=model.states, outputs=model.outputs)
