"""The engineer's figures of an identification run, made from the run and its model and drawn by
:mod:`obsnl.report.identification.diagnostics`: the residual analysis, the frequency response against the measured
H1 estimate (a model that linearises at rest), and the hysteresis loop (a model with a hysteretic state).

The hysteresis loop needs the restoring force, which no sensor measures: it is read from the model's equations.
Where the model has a displacement state ``d`` measured by an output (``y = d``), whose derivative is a velocity
state ``v`` (``d' = v``), and the velocity's equation takes the one input with a constant gain
``b = dv'/du`` (``1/m`` for a force on a mass ``m``), the restoring force in the input's units is
``r = u - v'/b``: measured, with ``v'`` the second derivative of the measured displacement (Savitzky-Golay, cubic,
over a quarter of the response's dominant period); the model's, with ``v' = f_v`` along its simulation at the
estimate from rest. A model with a hysteretic state but not of that form gets no loop (and says why).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from obsnl.errors import ObsnlError
from obsnl.identification.validation.job import HYSTERETIC_STATE
from obsnl.report.identification.diagnostics import HysteresisLoop, NoHysteresisLoop

__all__ = ["figure_files", "write_figures", "restoring_force", "FIGURES"]

#: The figures :func:`write_figures` may write, besides ``identify.json``, ``fit.png``, ``traces.png`` and
#: ``profiles.png``.
FIGURES = ("residuals.png", "frf.png", "hysteresis.png")


def figure_files(result: Any) -> tuple[str, ...]:
    """The figures of :data:`FIGURES` this run gets: ``residuals.png`` always, ``frf.png`` where the model linearises
    at rest and its inputs were kept, ``hysteresis.png`` where the model has a hysteretic state."""
    files = ["residuals.png"]
    if result.u_measured is not None and np.size(result.u_measured) and result.linear_at_rest is not None:
        files.append("frf.png")
    if result.fitted_model is not None and HYSTERETIC_STATE in [s.name for s in result.fitted_model.states]:
        files.append("hysteresis.png")
    return tuple(files)


def write_figures(result: Any, folder: Any, files: Sequence[str]) -> None:
    """Draw the figures ``files`` (of :func:`figure_files`) into the open output folder ``folder``.

    Parameters
    ----------
    result : Identification
        The run.
    folder : OutputFolder
        The folder being written (:class:`obsnl.report.files.OutputFolder`).
    files : sequence of str
        The figures to draw.
    """
    from obsnl.report.identification.diagnostics import plot_frf, plot_hysteresis, plot_residuals

    u = None if result.u_measured is None else np.asarray(result.u_measured, float).reshape(len(result.t), -1)
    if "residuals.png" in files:
        level = result.adequacy.level if result.adequacy is not None else 0.01
        plot_residuals(
            folder.path("residuals.png"),
            residuals=result.y_measured - result.y_fit,
            inputs=u,
            outputs=result.outputs,
            input_names=result.inputs,
            level=level,
        )
    if "frf.png" in files and u is not None:
        lin = result.linear_at_rest
        plot_frf(
            folder.path("frf.png"),
            t=result.t,
            inputs=u,
            measured=result.y_measured,
            A=lin.A,
            B=lin.B,
            C=lin.C,
            D=lin.D,
            input_names=result.inputs,
            outputs=result.outputs,
        )
    if "hysteresis.png" in files:
        plot_hysteresis(folder.path("hysteresis.png"), restoring_force(result))


def _derivative_state(A: np.ndarray, B: np.ndarray, d: int) -> int | None:
    """The state ``v`` with ``x_d' = x_v`` in the linearisation (a unit row, no input), else None."""
    row = A[d]
    hits = np.flatnonzero(row != 0)
    if len(hits) == 1 and row[hits[0]] == 1.0 and not np.any(B[d] != 0):
        return int(hits[0])
    return None


def restoring_force(result: Any) -> HysteresisLoop | NoHysteresisLoop:
    """The hysteresis loop (module docstring): the measured and the model's displacement and restoring force, the
    axes' labels and the note on how they were made; or why there is none.

    Parameters
    ----------
    result : Identification
        The run; it keeps its model and measured inputs.

    Returns
    -------
    HysteresisLoop or NoHysteresisLoop
        The loop; or, where the model is not of the form the module docstring states (or its simulation fails),
        the reason in a sentence.
    """
    from scipy.signal import savgol_filter, welch

    from obsnl.estimation.codegen import to_casadi
    from obsnl.identification.modal import linearise

    lin = result.linear_at_rest
    if lin is None or result.u_measured is None:
        return NoHysteresisLoop("the model does not linearise at rest, or the run kept no inputs")
    u = np.asarray(result.u_measured, float).reshape(len(result.t), -1)
    if u.shape[1] != 1:
        return NoHysteresisLoop(f"the loop reads the restoring force from one input; the model has {u.shape[1]}")
    states = list(lin.states)
    found = None
    for j, _out in enumerate(result.outputs):  # an output that is a displacement state, whose derivative is a state
        hits = np.flatnonzero(lin.C[j] != 0)
        if len(hits) == 1 and lin.C[j, hits[0]] == 1.0 and not np.any(lin.D[j] != 0):
            v = _derivative_state(lin.A, lin.B, int(hits[0]))
            if v is not None and lin.B[v, 0] != 0:
                found = (j, int(hits[0]), v)
                break
    if found is None:
        return NoHysteresisLoop(
            "no measured output is a displacement state whose derivative is a velocity state driven by the input"
        )
    j, d, v = found
    b = float(lin.B[v, 0])
    num = to_casadi(result.fitted_model)
    values = {p.name: p.guess if p.held else p.estimate for p in result.parameters}
    theta = np.array([values[n] for n in num.parameters], float)
    rng = np.random.default_rng(0)  # two random states: the gain b must not depend on the state (input-affine)
    for _ in range(2):
        _, Bk, _, _, _ = linearise(num, theta, rng.standard_normal(num.nx))
        if not math.isclose(float(Bk[v, 0]), b, rel_tol=1e-9, abs_tol=1e-12):
            return NoHysteresisLoop(
                f"the gain of the input on {states[v]}' depends on the state: no restoring force to read"
            )
    dt = float(result.t[1] - result.t[0])
    y = np.asarray(result.y_measured[:, j], float)
    if np.any(np.isnan(y)):
        return NoHysteresisLoop(
            f"the measured {result.outputs[j]} has gaps: its second derivative is not read across them"
        )
    f, p = welch(y - y.mean(), fs=1 / dt, nperseg=min(len(y), 1024))
    peak = float(f[1:][np.argmax(p[1:])]) if len(f) > 1 else 0.0
    window = round(1 / (4 * peak * dt)) if peak > 0 else 5
    window = max(5, window + (window + 1) % 2)  # odd, at least 5
    window = min(window, len(y) - (1 - len(y) % 2))
    acc = savgol_filter(y, window, 3, deriv=2, delta=dt)
    try:
        sim = result.simulate(
            {
                "time_s": result.t,
                result.inputs[0]: u[:, 0],
                **{o: result.y_measured[:, k] for k, o in enumerate(result.outputs)},
            }
        )
    except ObsnlError as exc:  # the figure says why, the run's files are still written
        return NoHysteresisLoop(f"the model at the estimate could not be simulated from rest: {exc}")
    x = np.asarray(sim.x, float)
    fv = np.array([float(np.asarray(num.f(x[k], theta, u[k]), float).ravel()[v]) for k in range(len(x))])
    name = result.inputs[0]
    return HysteresisLoop(
        displacement_measured=y,
        force_measured=u[:, 0] - acc / b,
        displacement_model=x[:, d],
        force_model=u[:, 0] - fv / b,
        xlabel=f"displacement {states[d]} (measured as {result.outputs[j]})",
        ylabel=f"restoring force, in the units of {name}: {name} - {states[v]}' / b",
        note=f"b = d{states[v]}'/d{name} = {b:.4g} at the estimate; measured {states[v]}': the second "
        f"derivative of {result.outputs[j]} (Savitzky-Golay, cubic, {window} samples)",
    )
