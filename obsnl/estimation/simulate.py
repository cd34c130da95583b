"""Simulate a compiled model over a record: the "truth" of an identification experiment.

The input is interpolated linearly between samples; the whole record is one casadi ``mapaccum``
call. The default discretisation (RK4 with 100 substeps per sample; a substep in which a switching
function across which the field can jump changes sign redone with 8 finer ones) is converged far
below the 0.1 % measurement noise of the seed experiment for the damage-healing model (the switching
of the healing operator makes its right-hand side discontinuous, so fixed-step methods converge only
to first order there; ``tests/test_seed_models.py`` checks the default against scipy's LSODA).

Evaluation on numpy buffers (:func:`call`). A filter run over a record returns about half a million
numbers (the covariance at every sample); casadi's usual call turns each into a Python float on the
way out, which took about a fifth of a seed-experiment pass. :func:`call` binds caller-owned numpy buffers to the Function instead
(casadi's ``Function.buffer``): the same compiled code on the same inputs, so the numbers are the
same, bit for bit, as those of ``fn(*args)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from obsnl._text import block, names, number, one_line
from obsnl.errors import DataError, EstimatorError
from obsnl.estimation.jitcache import jit_compile
from obsnl.estimation.numeric import NumericModel

__all__ = ["Simulation", "simulate", "simulate_many", "call", "residual_graph", "residuals"]


#: A forward sensitivity below this is set to 0 in the compiled residuals: the initial state's sensitivities of a
#: damped structure decay along the record into subnormal numbers, on which the processor is tens of times slower
#: (on the Bouc-Wen benchmark they took 1.2 of the 1.9 processor seconds of one evaluation). No residual changes;
#: a Jacobian entry below 1e-200 is 0 to any use of it.
TINY_SENSITIVITY = 1e-200


def _dense_input(fn: ca.Function, i: int, value: Any) -> np.ndarray:
    shape = fn.size_in(i)
    arr = np.asarray(value, float)
    if arr.size != shape[0] * shape[1]:
        raise EstimatorError(
            f"input {fn.name_in(i)!r} of {fn.name()!r} needs {shape[0]}x{shape[1]} values, got shape {arr.shape}"
        )
    if arr.ndim == 2 and arr.shape != shape and 1 not in shape:
        raise EstimatorError(f"input {fn.name_in(i)!r} of {fn.name()!r} needs shape {shape}, got {arr.shape}")
    return arr.reshape(shape, order="F") if arr.ndim < 2 else arr


def call(fn: ca.Function, args: Sequence[Any]) -> list[np.ndarray]:
    """``fn(*args)`` as dense numpy arrays (one per output, in casadi's shapes).

    Every input must be given in full (no broadcasting); an input with a sparse pattern falls back
    to casadi's usual call.

    Parameters
    ----------
    fn : casadi.Function
        The function.
    args : sequence of array_like
        One value per input, of the input's shape (a vector may be 1-D).

    Returns
    -------
    list of numpy.ndarray

    Raises
    ------
    EstimatorError
        A wrong size, or the evaluation failed.

    Examples
    --------
    >>> import casadi as ca
    >>> x = ca.SX.sym("x", 2)
    >>> f = ca.Function("f", [x], [ca.vertcat(x[0] * x[1], x[0] + 1)])
    >>> call(f, [[2.0, 3.0]])[0].ravel().tolist()
    [6.0, 3.0]
    """
    if len(args) != fn.n_in():
        raise EstimatorError(f"{fn.name()!r} takes {fn.n_in()} inputs, got {len(args)}")
    if not all(fn.sparsity_in(i).is_dense() for i in range(fn.n_in())):
        return [np.asarray(o) for o in fn(*args)]
    flat = [np.ascontiguousarray(_dense_input(fn, i, a).reshape(-1, order="F")) for i, a in enumerate(args)]
    nz = [np.zeros(fn.nnz_out(j)) for j in range(fn.n_out())]
    buf, evaluate = fn.buffer()
    # casadi's stubs list a size after the buffer, which its wrapper takes from the memoryview (a third argument
    # is refused at run time); ``a.data`` is the array's memoryview
    for i, a in enumerate(flat):  # the arrays stay referenced until the evaluation is done
        buf.set_arg(i, a.data)  # type: ignore[call-arg]
    for j, r in enumerate(nz):
        buf.set_res(j, r.data)  # type: ignore[call-arg]
    evaluate()
    if buf.ret() != 0:
        raise EstimatorError(f"the evaluation of {fn.name()!r} failed (return code {buf.ret()})")
    out = []
    for j, r in enumerate(nz):
        sp = fn.sparsity_out(j)
        if sp.is_dense():
            out.append(np.ascontiguousarray(r.reshape(sp.shape, order="F")))  # row-major, as casadi's own conversion
        else:
            full = np.zeros(sp.shape)
            rows, cols = sp.get_triplet()
            full[np.asarray(rows, int), np.asarray(cols, int)] = r
            out.append(full)
    return out


@dataclass(frozen=True, eq=False)
class Simulation:
    """States ``x`` ``(T, nx)`` and outputs ``y`` ``(T, ny)`` at the sample times ``t``."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    states: tuple[str, ...]
    outputs: tuple[str, ...]

    def __repr__(self) -> str:
        return one_line(
            "Simulation",
            f"samples={len(self.t)}",
            f"t={number(self.t[0])}..{number(self.t[-1])} s",
            f"states={names(self.states, 6)!r}",
            f"outputs={names(self.outputs, 6)!r}",
        )

    def summary(self) -> str:
        """A few lines of plain text: the span simulated and the peak of each output."""
        peaks = [f"{o} {number(float(np.max(np.abs(self.y[:, j]))))}" for j, o in enumerate(self.outputs)]
        return block(
            f"simulation of {len(self.t)} samples, t = {number(self.t[0])} to {number(self.t[-1])} s",
            f"states: {names(self.states, 12)}",
            f"peak |output|: {names(peaks, 8)}",
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "t": self.t.tolist(),
            "states": list(self.states),
            "outputs": list(self.outputs),
            "x": self.x.tolist(),
            "y": self.y.tolist(),
        }


_RUNS: dict[tuple, tuple[NumericModel, ca.Function]] = {}


def _built(key: tuple, model: NumericModel, build: Callable[[], ca.Function]) -> ca.Function:
    """``build()`` once per ``key`` of ``model`` (the last 64 kept; the entry keeps the model alive, so
    its id in the key stays unique)."""
    key = (id(model), *key)
    if key not in _RUNS:
        _RUNS[key] = (model, build())
        if len(_RUNS) > 64:
            _RUNS.pop(next(iter(_RUNS)))
    return _RUNS[key][1]


def _runner(
    model: NumericModel,
    dt: float,
    T: int,
    method: str,
    substeps: int,
    refine: int,
    jit: bool,
    n: int = 1,
    locate: bool = False,
) -> ca.Function:
    """``(x0, theta, u0s, u1s) -> X`` over ``T - 1`` steps for ``n`` parameter vectors side by side; with
    ``jit`` one compiled step (cached per model) looped over the record."""

    def build() -> ca.Function:
        step = model.step(dt, method=method, substeps=substeps, refine=refine, locate=locate)
        X, P = ca.MX.sym("x", model.nx), ca.MX.sym("p", model.np)
        U0, U1 = ca.MX.sym("u0", model.nu, T - 1), ca.MX.sym("u1", model.nu, T - 1)
        if jit:  # one step in C; the fallbacks stay conditional (evaluated only where needed)
            Xs, Ps = ca.MX.sym("x", model.nx), ca.MX.sym("p", model.np)
            Ua, Ub = ca.MX.sym("u0", model.nu), ca.MX.sym("u1", model.nu)
            step = jit_compile(ca.Function(step.name(), [Xs, Ps, Ua, Ub], step.call([Xs, Ps, Ua, Ub])))
        one = ca.Function("simulation", [X, P, U0, U1], [step.mapaccum(T - 1)(X, P, U0, U1)[0]])
        return one if n == 1 else one.map(n, "serial")

    return _built(
        ("run", float(dt), int(T), method, int(substeps), int(refine), bool(jit), int(n), bool(locate)), model, build
    )


def _outputs(model: NumericModel, T: int) -> ca.Function:
    """The output map over ``T`` samples (built once per model and length)."""
    return _built(("h", int(T)), model, lambda: model.h.map(int(T)))


def _checked_input(model: NumericModel, u: Any) -> np.ndarray:
    u = np.asarray(u, float)
    u = u.reshape(-1, 1) if u.ndim == 1 else u
    if u.ndim != 2 or u.shape[1] != model.nu or len(u) < 2:
        raise DataError(f"input must have shape (T, {model.nu}) with T >= 2, got {u.shape}")
    if not np.all(np.isfinite(u)):
        raise DataError("input contains NaN/inf")
    return u


def simulate(
    model: NumericModel,
    *,
    theta: Any,
    x0: Any,
    u: Any,
    dt: float,
    method: str = "auto",
    substeps: int = 100,
    refine: int = 8,
    jit: bool = False,
    locate: bool = False,
) -> Simulation:
    """Simulate ``model`` from ``x0`` with parameters ``theta`` under the input samples ``u``.

    Parameters
    ----------
    model : NumericModel
        Compiled model.
    theta, x0 : Any
        Parameter values and initial state (model order).
    u : Any
        Input samples, shape ``(T,)`` for one input or ``(T, nu)``.
    dt : float
        Sampling interval.
    method : str
        Discretisation (:meth:`obsnl.estimation.numeric.NumericModel.step`).
    substeps, refine : int
        Discretisation (:meth:`obsnl.estimation.numeric.NumericModel.step`).
    jit : bool
        Compile the step to C once per model, step and record length (a few seconds), for
        repeated simulations (tuning, sensitivities); the same numbers as without.
    locate : bool
        Locate the crossings where the field jumps and follow sliding modes (a mass that sticks):
        :meth:`obsnl.estimation.numeric.NumericModel.step`.

    Raises
    ------
    DataError
        Bad shapes or non-finite input.
    EstimatorError
        The simulation left the finite numbers (the parameters make the model unstable).
    """
    got = simulate_many(
        model,
        thetas=[theta],
        x0=x0,
        u=u,
        dt=dt,
        method=method,
        substeps=substeps,
        refine=refine,
        jit=jit,
        locate=locate,
    )[0]
    if isinstance(got, EstimatorError):
        raise got
    return got


def simulate_many(
    model: NumericModel,
    *,
    thetas: Sequence[Any],
    x0: Any,
    u: Any,
    dt: float,
    method: str = "auto",
    substeps: int = 100,
    refine: int = 8,
    jit: bool = False,
    locate: bool = False,
) -> list[Simulation | EstimatorError]:
    """:func:`simulate` for several parameter vectors in one compiled call (the same numbers as one at a time).

    Parameters
    ----------
    model : NumericModel
        Compiled model.
    thetas : sequence of array_like
        Parameter vectors (model order).
    x0 : array_like
        Initial state.
    u : array_like
        Input samples, ``(T,)`` or ``(T, nu)``.
    dt : float
        Sampling interval.
    method : str
        Discretisation.
    substeps : int
        RK4 substeps per sample.
    refine : int
        Finer substeps of a crossing substep.
    jit : bool
        Compile the step to C.
    locate : bool
        As in :func:`simulate`.

    Returns
    -------
    list
        Per parameter vector its :class:`Simulation`, or the :class:`~obsnl.errors.EstimatorError` of a
        simulation that left the finite numbers.

    Raises
    ------
    DataError
        Bad shapes or non-finite input.
    """
    u = _checked_input(model, u)
    thetas = [np.asarray(th, float) for th in thetas]
    x0 = np.asarray(x0, float)
    if not thetas or any(th.shape != (model.np,) for th in thetas) or x0.shape != (model.nx,):
        raise DataError(f"theta needs {model.np} values and x0 {model.nx}")
    n, T = len(thetas), len(u)
    run = _runner(model, dt, T, method, substeps, refine, jit, n, locate)
    Xs = call(
        run, [np.repeat(x0[:, None], n, axis=1), np.column_stack(thetas), np.tile(u[:-1].T, n), np.tile(u[1:].T, n)]
    )[0]
    out: list[Simulation | EstimatorError] = []
    h = _outputs(model, T)
    for i, th in enumerate(thetas):
        X = np.vstack([x0, Xs[:, i * (T - 1) : (i + 1) * (T - 1)].T])
        if not np.all(np.isfinite(X)):
            k = int(np.flatnonzero(~np.all(np.isfinite(X), axis=1))[0])
            out.append(EstimatorError(f"the simulation of {model.name!r} left the finite numbers at sample {k}"))
            continue
        Y = call(h, [X.T, np.repeat(th[:, None], T, axis=1), u.T])[0].T
        out.append(Simulation(t=np.arange(T) * dt, x=X, y=Y, states=model.states, outputs=model.outputs))
    return out


def residual_graph(
    model: NumericModel,
    forward: ca.Function,
    dt: float,
    T: int,
    *,
    substeps: int,
    refine: int,
    locate: bool = False,
    predictor: bool = False,
) -> tuple[ca.MX, ...]:
    """``(z, u, y, w, x0, scale, [present, yscale,] r)``: the whitened output residuals ``r`` of ``T`` samples as
    a casadi graph.

    ``z = (phi, s)``: the coordinates ``phi`` of the parameters (``theta = forward(phi)``) and the scaled
    initial state (``x0 + scale * s``); ``u`` ``(nu, T)``, ``y`` ``(ny, T)``, ``w`` the weight of each output
    (``1 / sigma``); ``r = vec((y_hat - y) * w)``, sample-major.

    With ``predictor``, ``y_hat`` is the one-step prediction of a constant-gain predictor (the innovations form of
    the prediction-error method): ``z = (phi, s, kappa)``, and before each step the state is corrected by the
    sample's innovation, ``x <- x + K (y_k - h(x))`` with ``K = diag(scale) kappa diag(1 / yscale)`` (``kappa``
    ``(nx, ny)`` column-major in ``z``: dimensionless, each state's scale per output scale). ``present`` ``(ny, T)``
    is 1 where the output sample was measured and 0 at a gap (no correction); ``yscale`` ``(ny,)`` the outputs'
    scales. ``kappa = 0`` is the output-error simulation.

    Parameters
    ----------
    model : NumericModel
        Compiled model.
    forward : casadi.Function
        ``phi -> theta``, the coordinates of the parameters (:class:`obsnl.estimation.numeric.ParameterMap`).
    dt : float
        Sampling interval.
    T : int
        Samples of the record.
    substeps, refine : int
        RK4 substeps per sample and the factor of a crossing substep (:meth:`NumericModel.step`).
    locate : bool
        Split a substep in which the field jumps at the located crossing (:meth:`NumericModel.step`).
    predictor : bool
        The constant-gain predictor's residuals (the innovations) instead of the simulation's.

    Returns
    -------
    tuple of casadi.MX
        The symbols ``z, u, y, w, x0, scale`` (then ``present, yscale`` with ``predictor``) and the expression ``r``.
    """
    step = model.step(dt, substeps=substeps, refine=refine, locate=locate)
    gains = model.nx * model.ny if predictor else 0
    z, phi, x0, U, Y, W, X0, SC = _record_symbols(model, T, gains)
    th = forward(phi)
    if not predictor:
        X = ca.horzcat(x0, step.mapaccum(T - 1)(x0, th, U[:, :-1], U[:, 1:])[0])
        Yhat = model.h.map(T)(X, ca.repmat(th, 1, T), U)
        return z, U, Y, W, X0, SC, ca.vec((Yhat - Y) * ca.repmat(W, 1, T))
    M, YS = ca.MX.sym("present", model.ny, T), ca.MX.sym("yscale", model.ny)
    corrected = _corrected_step(model, step)
    kappa = z[model.np + model.nx :]
    X = ca.horzcat(
        x0,
        corrected.mapaccum(T - 1)(x0, th, kappa, U[:, :-1], U[:, 1:], Y[:, :-1], M[:, :-1], SC, YS),
    )
    Yhat = model.h.map(T)(X, ca.repmat(th, 1, T), U)
    return z, U, Y, W, X0, SC, M, YS, ca.vec((Yhat - Y) * ca.repmat(W, 1, T))


def _corrected_step(model: NumericModel, step: ca.Function) -> ca.Function:
    """``(x, theta, kappa, u0, u1, y0, present0, scale, yscale) -> x_next``: the predictor's step, the state first
    corrected by the sample's innovation (:func:`residual_graph`)."""
    x, th = ca.MX.sym("x", model.nx), ca.MX.sym("theta", model.np)
    kappa = ca.MX.sym("kappa", model.nx * model.ny)
    u0, u1 = ca.MX.sym("u0", model.nu), ca.MX.sym("u1", model.nu)
    y0, m0 = ca.MX.sym("y0", model.ny), ca.MX.sym("present0", model.ny)
    sc, ys = ca.MX.sym("scale", model.nx), ca.MX.sym("yscale", model.ny)
    innovation = m0 * (y0 - model.h(x, th, u0)) / ys
    corrected = x + sc * ca.mtimes(ca.reshape(kappa, model.nx, model.ny), innovation)
    return ca.Function("predictor_step", [x, th, kappa, u0, u1, y0, m0, sc, ys], [step(corrected, th, u0, u1)[0]])


def _record_symbols(model: NumericModel, T: int, gains: int = 0) -> tuple[ca.MX, ...]:
    """``(z, phi, x0, u, y, w, x0_ref, scale)``: the arguments of the residuals of ``T`` samples, ``z = (phi, s)``
    (then ``gains`` predictor gains) with the initial state ``x0 = x0_ref + scale * s``."""
    z = ca.MX.sym("z", model.np + model.nx + gains)
    U, Y, W = ca.MX.sym("u", model.nu, T), ca.MX.sym("y", model.ny, T), ca.MX.sym("w", model.ny)
    X0, SC = ca.MX.sym("x0", model.nx), ca.MX.sym("scale", model.nx)
    return z, z[: model.np], X0 + SC * z[model.np : model.np + model.nx], U, Y, W, X0, SC


def residuals(
    model: NumericModel,
    forward: ca.Function,
    dt: float,
    T: int,
    *,
    substeps: int,
    refine: int,
    locate: bool = False,
    jit: bool = False,
    predictor: bool = False,
) -> ca.Function:
    """``(z, u, y, w, x0, scale) -> (r, J)``: the residuals of :func:`residual_graph` and their exact Jacobian
    ``J = dr/dz`` ``(T * ny, nz)``.

    Without ``jit``, casadi's forward mode through the whole record's graph. With ``jit``, the same derivative
    as forward sensitivities: one step ``(x, S) -> (x_next, d x_next/dx S + d x_next/dz)`` and one output
    ``(x, S) -> (r, dr/dz)``, each compiled to C once per model, step and number of substeps
    (:func:`obsnl.estimation.jitcache.jit_compile`; the record's length, its initial state and its scale
    are inputs, not part of the code), looped over the record: about ten times faster on the seed model, and
    equal to the graph's derivative to rounding (``tests/test_crossing.py``).

    Parameters
    ----------
    model : NumericModel
        Compiled model.
    forward : casadi.Function
        ``phi -> theta`` (as :func:`residual_graph`).
    dt : float
        Sampling interval.
    T : int
        Samples of the record.
    substeps, refine : int
        The step's substeps and refinement (as :func:`residual_graph`).
    locate : bool
        Locate the crossings of a jump (as :func:`residual_graph`).
    jit : bool
        Forward sensitivities compiled to C (cached on disk: :mod:`obsnl.estimation.jitcache`).
    predictor : bool
        The constant-gain predictor's residuals (:func:`residual_graph`): ``z`` then ends with the gains
        ``kappa``, and the function takes ``present`` and ``yscale`` after ``scale``.

    Returns
    -------
    casadi.Function
        ``output_error`` (``prediction_error`` with ``predictor``): inputs ``z, u, y, w, x0, scale`` (then
        ``present, yscale``), outputs ``r`` ``(T * ny,)`` and ``J`` ``(T * ny, nz)``.

    Examples
    --------
    >>> import obsnl
    >>> from obsnl.estimation.codegen import to_casadi
    >>> num = to_casadi(obsnl.Model(name="decay", states=["x"], parameters=["k"], inputs=["u"],
    ...                             equations={"x": "u - k*x"}, outputs={"y": "x"}))
    >>> phi = ca.SX.sym("phi")
    >>> f = residuals(num, ca.Function("forward", [phi], [ca.exp(phi)]), 0.1, 3, substeps=20, refine=1)
    >>> r, J = call(f, [[0.0, 0.0], [[0.0, 0.0, 0.0]], [[0.0, 0.0, 0.0]], [1.0], [1.0], [1.0]])
    >>> # x = exp(-k t) with k = exp(phi) = 1, so dx/dphi = -k t exp(-k t)
    >>> np.round(r.ravel(), 6).tolist(), round(float(J[2, 0]), 6)
    ([1.0, 0.904837, 0.818731], -0.163746)
    """
    gains = model.nx * model.ny if predictor else 0
    nz = model.np + model.nx + gains
    names = ["z", "u", "y", "w", "x0", "scale"] + (["present", "yscale"] if predictor else [])
    label = "prediction_error" if predictor else "output_error"
    if not jit:
        *args, R = residual_graph(
            model, forward, dt, T, substeps=substeps, refine=refine, locate=locate, predictor=predictor
        )
        return ca.Function(label, args, [R, ca.jacobian(R, args[0])], names, ["r", "J"])
    step = model.step(dt, substeps=substeps, refine=refine, locate=locate)
    x, S, phi = ca.MX.sym("x", model.nx), ca.MX.sym("S", model.nx, nz), ca.MX.sym("phi", model.np)
    u0, u1 = ca.MX.sym("u0", model.nu), ca.MX.sym("u1", model.nu)
    y, w = ca.MX.sym("y", model.ny), ca.MX.sym("w", model.ny)
    th = forward(phi)
    E = ca.horzcat(ca.MX.eye(model.np), ca.MX.zeros(model.np, model.nx + gains))  # d phi / d z
    yh = model.h(x, th, u0)
    dr = (ca.jtimes(yh, x, S) + ca.jtimes(yh, phi, E)) * ca.repmat(w, 1, nz)
    out = jit_compile(ca.Function("sensitivity_output", [x, S, phi, u0, y, w], [(yh - y) * w, dr.T]))
    z, ph, x0, U, Y, W, X0, SC = _record_symbols(model, T, gains)
    S0 = ca.horzcat(ca.MX.zeros(model.nx, model.np), ca.diag(SC), ca.MX.zeros(model.nx, gains))
    if not predictor:
        xn = step(x, th, u0, u1)[0]
        sens = ca.jtimes(xn, x, S) + ca.jtimes(xn, phi, E)
        sens = ca.if_else(ca.fabs(sens) >= TINY_SENSITIVITY, sens, 0.0)
        advance = jit_compile(ca.Function("sensitivity_step", [x, S, phi, u0, u1], [xn, sens]))
        X, Ss = advance.mapaccum("sensitivity_loop", T - 1, 2)(x0, S0, ph, U[:, :-1], U[:, 1:])
        extra: list[ca.MX] = []
    else:
        kappa, m0 = ca.MX.sym("kappa", gains), ca.MX.sym("present0", model.ny)
        sc, ys = ca.MX.sym("scale", model.nx), ca.MX.sym("yscale", model.ny)
        Ek = ca.horzcat(ca.MX.zeros(gains, model.np + model.nx), ca.MX.eye(gains))  # d kappa / d z
        xn = _corrected_step(model, step)(x, th, kappa, u0, u1, y, m0, sc, ys)
        sens = ca.jtimes(xn, x, S) + ca.jtimes(xn, phi, E) + ca.jtimes(xn, kappa, Ek)
        sens = ca.if_else(ca.fabs(sens) >= TINY_SENSITIVITY, sens, 0.0)
        advance = jit_compile(
            ca.Function("predictor_sensitivity_step", [x, S, phi, kappa, u0, u1, y, m0, sc, ys], [xn, sens])
        )
        M, YS = ca.MX.sym("present", model.ny, T), ca.MX.sym("yscale", model.ny)
        X, Ss = advance.mapaccum("predictor_loop", T - 1, 2)(
            x0, S0, ph, z[model.np + model.nx :], U[:, :-1], U[:, 1:], Y[:, :-1], M[:, :-1], SC, YS
        )
        extra = [M, YS]
    R, JT = out.map(T)(ca.horzcat(x0, X), ca.horzcat(S0, Ss), ca.repmat(ph, 1, T), U, Y, ca.repmat(W, 1, T))
    return ca.Function(label, [z, U, Y, W, X0, SC, *extra], [ca.vec(R), JT.T], names, ["r", "J"])
