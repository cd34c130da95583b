"""The modal summary of an identified model: its linearisation at rest (or at a state given), natural frequencies,
damping ratios and mode shapes at the measured outputs, each with a std propagated from the estimates' covariance.

The model ``x' = f(x, theta, u)``, ``y = h(x, theta, u)`` is linearised by casadi's exact derivatives at the state
``x*`` and the input ``u = 0``: ``A = df/dx``, ``B = df/du``, ``C = dh/dx``, ``D = dh/du``. Each complex pair of
eigenvalues ``lambda = -zeta w +- i w sqrt(1 - zeta^2)`` of ``A`` is a mode of natural frequency
``w / (2 pi) = |lambda| / (2 pi)`` (Hz) and damping ratio ``zeta = -Re(lambda) / |lambda|``; its shape at the
measured outputs is ``C v`` (``v`` the eigenvector), scaled so that its largest entry is 1 and read as its real
part (the shape of a classically damped structure is real; the largest imaginary part left is kept as
``complexity``). Real eigenvalues are no modes (an overdamped or a first-order part, a hysteretic state): they are
listed as ``real_poles``.

The std follow the delta method (Ljung, "System Identification: Theory for the User", 1999, sec. 9.4): with ``g``
the gradient of a modal figure with respect to the parameters (central differences of the eigen-analysis, each
mode matched to the nearest eigenvalue) and ``Sigma`` the covariance of the estimates,
``std = sqrt(g' Sigma g)``. ``Sigma = D R D`` from each parameter's std ``D`` and the correlations ``R`` of the
maximum-likelihood fit; without the fit, the correlations are taken as zero and the result says so.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from obsnl._display import render
from obsnl._text import block, names, number, one_line
from obsnl.errors import ModelError, OptionError

__all__ = ["Modal", "eigen_modes", "linearise", "modal", "parameter_covariance"]

#: Relative step of the central differences of the eigen-analysis (truncation ~ step**2, rounding ~ eps / step).
STEP = 1e-5
#: ``|x'|`` at the state over the scale of ``A x`` below which the state is taken as an equilibrium.
AT_REST = 1e-9


@dataclass(frozen=True, eq=False)
class Modal:
    """The modes of a model linearised at a state (module docstring), each figure with its std.

    ``frequency_hz``, ``damping_ratio`` and their ``_std`` (None where the covariance is not finite: a flat
    direction), lowest frequency first; ``shapes``: per mode, ``{output: amplitude}`` with the largest 1, and
    ``shapes_std`` alike; ``complexity``: per mode, the largest imaginary part of the scaled shape;
    ``real_poles``: the real eigenvalues (1/s); ``state``: where the model was linearised (the inputs at 0);
    ``A``, ``B``, ``C``, ``D``: the linearisation; ``assumptions``: what the figures rest on.
    """

    model: str
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    state: Mapping[str, float]
    frequency_hz: tuple[float, ...]
    frequency_hz_std: tuple[float | None, ...]
    damping_ratio: tuple[float, ...]
    damping_ratio_std: tuple[float | None, ...]
    shapes: tuple[Mapping[str, float], ...]
    shapes_std: tuple[Mapping[str, float | None], ...]
    complexity: tuple[float, ...]
    real_poles: tuple[float, ...]
    assumptions: tuple[str, ...]
    A: np.ndarray = field(repr=False)
    B: np.ndarray = field(repr=False)
    C: np.ndarray = field(repr=False)
    D: np.ndarray = field(repr=False)

    @property
    def oscillatory(self) -> bool:
        """Whether the linearisation has at least one mode (a complex pair of eigenvalues)."""
        return bool(self.frequency_hz)

    @property
    def poles(self) -> np.ndarray:
        """The eigenvalues of ``A`` (1/s)."""
        return np.linalg.eigvals(self.A) if self.A.size else np.zeros(0, complex)

    def __repr__(self) -> str:
        modes = names([f"{number(f)} Hz, zeta {number(z)}" for f, z in zip(self.frequency_hz, self.damping_ratio)], 4)
        return one_line(
            "Modal",
            f"model={self.model!r}",
            f"modes={len(self.frequency_hz)}",
            f"'{modes}'" if modes else "",
            f"real_poles={len(self.real_poles)}" if self.real_poles else "",
        )

    def summary(self) -> str:
        """A few lines of plain text: each mode's frequency and damping ratio with their std, and its shape."""

        def pm(v: float, s: float | None, scale: float = 1.0, unit: str = "") -> str:
            return f"{number(scale * v)}{unit} (std {number(None if s is None else scale * s)}{unit})"

        rows = [
            f"mode {i + 1}: {pm(f, fs, unit=' Hz')}, damping {pm(z, zs, 100, ' %')}, shape "
            + names([f"{o} {a:+.3g}" for o, a in sh.items()], 6)
            for i, (f, fs, z, zs, sh) in enumerate(
                zip(self.frequency_hz, self.frequency_hz_std, self.damping_ratio, self.damping_ratio_std, self.shapes)
            )
        ]
        at = names([f"{k}={number(v)}" for k, v in self.state.items()], 6)
        return block(
            f"{self.model} linearised at {at} (inputs 0): {len(rows)} mode(s)"
            + (f", {len(self.real_poles)} real pole(s)" if self.real_poles else ""),
            *rows[:9],
            f"... and {len(rows) - 9} more modes" if len(rows) > 9 else "",
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``modes`` (each ``frequency_hz``, ``damping_ratio``, their std, ``shape``, ``shape_std``,
        ``complexity``), ``real_poles``, the state, the matrices and the assumptions."""
        fin = lambda v: None if v is None or not math.isfinite(v) else float(v)
        modes = [
            {
                "frequency_hz": fin(f),
                "frequency_hz_std": fin(fs),
                "damping_ratio": fin(z),
                "damping_ratio_std": fin(zs),
                "shape": {o: fin(a) for o, a in sh.items()},
                "shape_std": {o: fin(a) for o, a in ss.items()},
                "complexity": fin(c),
            }
            for f, fs, z, zs, sh, ss, c in zip(
                self.frequency_hz,
                self.frequency_hz_std,
                self.damping_ratio,
                self.damping_ratio_std,
                self.shapes,
                self.shapes_std,
                self.complexity,
            )
        ]
        matrix = lambda M: [[fin(float(v)) for v in row] for row in np.asarray(M, float)]
        return {
            "model": self.model,
            "state": {k: fin(v) for k, v in self.state.items()},
            "inputs_at": 0.0,
            "modes": modes,
            "real_poles": [fin(p) for p in self.real_poles],
            "states": list(self.states),
            "inputs": list(self.inputs),
            "outputs": list(self.outputs),
            "A": matrix(self.A),
            "B": matrix(self.B),
            "C": matrix(self.C),
            "D": matrix(self.D),
            "assumptions": list(self.assumptions),
        }

    def _repr_html_(self) -> str | None:
        """Notebook display: the modes as a table, drawn by :mod:`obsnl.report` (:mod:`obsnl._display`)."""
        return render("html", self)

    def to_control(self) -> Any:
        """The linearisation as a python-control ``StateSpace`` (``pip install control``), with the model's names.

        Returns
        -------
        control.StateSpace

        Raises
        ------
        OptionError
            python-control is not installed.
        """
        try:
            import control
        except ImportError:
            raise OptionError("the export needs python-control: pip install control (or the 'control' extra)") from None
        return control.ss(
            self.A,
            self.B,
            self.C,
            self.D,
            states=list(self.states),
            inputs=list(self.inputs),
            outputs=list(self.outputs),
            name=self.model,
        )


def linearise(model: Any, theta: Any, state: Any) -> tuple[np.ndarray, ...]:
    """``(A, B, C, D, xdot)`` of a compiled model at ``state``, the parameters ``theta`` and zero inputs.

    Parameters
    ----------
    model : NumericModel
        The model compiled (:func:`obsnl.estimation.codegen.to_casadi`).
    theta, state : array_like
        The parameters and the state, in model order.

    Returns
    -------
    tuple of numpy.ndarray
        The four matrices and the vector field at the state.

    Examples
    --------
    >>> import obsnl
    >>> from obsnl.estimation.codegen import to_casadi
    >>> num = to_casadi(obsnl.Model(name="osc", states=["x", "v"], parameters=["k"], inputs=["F"],
    ...                             equations={"x": "v", "v": "F - k*x"}, outputs={"y": "x"}))
    >>> A, B, C, D, xdot = linearise(num, [4.0], [0.0, 0.0])
    >>> A.tolist(), B.ravel().tolist(), C.tolist()
    ([[0.0, 1.0], [-4.0, 0.0]], [0.0, 1.0], [[1.0, 0.0]])
    """
    import casadi as ca

    x, u = ca.SX.sym("x", model.nx), ca.SX.sym("u", len(model.inputs))
    p = ca.DM(np.asarray(theta, float))
    fx, hx = model.f(x, p, u), model.h(x, p, u)
    fn = ca.Function(
        "lin", [x, u], [ca.jacobian(fx, x), ca.jacobian(fx, u), ca.jacobian(hx, x), ca.jacobian(hx, u), fx]
    )
    out = fn(np.asarray(state, float), np.zeros(len(model.inputs)))
    return tuple(np.array(ca.DM(m), float).reshape(ca.DM(m).shape) for m in out)


def eigen_modes(A: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The modes of ``A``: eigenvalues with a positive imaginary part (by frequency), their shapes ``C v`` scaled to
    a largest entry of 1 (complex), and the real eigenvalues.

    Parameters
    ----------
    A, C : numpy.ndarray
        The state matrix ``(nx, nx)`` and the output matrix ``(ny, nx)``.

    Returns
    -------
    tuple of numpy.ndarray
        ``(eigenvalues, shapes (modes, ny), real eigenvalues)``.

    Examples
    --------
    >>> lam, shapes, real = eigen_modes(np.array([[0.0, 1.0], [-4.0, -0.4]]), np.array([[1.0, 0.0]]))
    >>> np.round(lam, 6).tolist(), np.round(shapes.real, 6).tolist(), real.tolist()
    ([(-0.2+1.989975j)], [[1.0]], [])
    """
    w, V = np.linalg.eig(A)
    scale = max(float(np.max(np.abs(w))) if w.size else 0.0, 1e-300)
    pair = w.imag > 1e-9 * scale
    real = np.sort(w[np.abs(w.imag) <= 1e-9 * scale].real)
    order = np.argsort(np.abs(w[pair]))
    lam, vec = w[pair][order], V[:, pair][:, order]
    shapes = C @ vec if C.size else np.zeros((0, lam.size), complex)
    for k in range(lam.size):
        if shapes.shape[0]:
            big = shapes[int(np.argmax(np.abs(shapes[:, k]))), k]
            shapes[:, k] = shapes[:, k] / big if big != 0 else shapes[:, k]
    return lam, shapes.T, real


def _figures(lam: np.ndarray, shapes: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Per mode: frequency (Hz), damping ratio and the shape's real parts scaled at the entries ``ref``."""
    w = np.abs(lam)
    scaled = np.array([s / s[r] if s[r] != 0 else s for s, r in zip(shapes, ref)]).reshape(len(lam), shapes.shape[1])
    return np.column_stack([w / (2 * np.pi), -lam.real / w, scaled.real])


def _matched(lam0: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """For each nominal eigenvalue, the index of the nearest one in ``lam`` (distinct modes stay apart under a
    small step)."""
    return np.array([int(np.argmin(np.abs(lam - z))) for z in lam0], int)


def parameter_covariance(result: Any) -> tuple[np.ndarray, str]:
    """The covariance of the estimates ``D R D`` (module docstring) in the order of ``result.parameters``, and how
    it was made: a held parameter has no variance, a parameter along a flat direction an infinite one.

    Parameters
    ----------
    result : Identification
        The run.

    Returns
    -------
    tuple
        ``(Sigma, assumption)``.
    """
    ps = result.parameters
    d = np.array([0.0 if p.held else (math.inf if p.std is None else float(p.std)) for p in ps])
    corr = {} if result.refinement is None else result.refinement.correlation
    R = np.eye(len(ps))
    for i, p in enumerate(ps):
        for j, q in enumerate(ps):
            v = (corr.get(p.name) or {}).get(q.name)
            if i != j and v is not None:
                R[i, j] = float(v)
    with np.errstate(invalid="ignore"):
        S = np.where(np.outer(d, d) == 0, 0.0, R * np.outer(d, d))
    how = (
        "the covariance of the estimates from their std and the maximum-likelihood correlations (delta method: "
        "the figures linear in the parameters over their spread)"
        if corr
        else "the covariance of the estimates from their std alone, the correlations taken as zero (no maximum-"
        "likelihood fit: refine=False, or it could not run); the std of the modal figures may be off"
    )
    held = [p.name for p in ps if p.held]
    return S, how + (f"; {names(held)} held at the guess, taken as exact" if held else "")


def modal(result: Any, *, state: Mapping[str, float] | Sequence[float] | None = None) -> Modal:
    """The modal summary of an identified model (module docstring): :meth:`Identification.modal` delegates here.

    Parameters
    ----------
    result : Identification
        The run; it keeps the model it fitted (:func:`obsnl.identify`).
    state : mapping of str to float, sequence of float or None
        The state linearised at (None: rest, every state 0, which must be an equilibrium under zero inputs).

    Returns
    -------
    Modal

    Raises
    ------
    OptionError
        The result keeps no model, or ``state`` does not name the model's states.
    ModelError
        The zero state is not at rest under zero inputs (give ``state=``, an equilibrium), or the linearisation
        there is not finite.
    """
    from obsnl.estimation.codegen import to_casadi

    if result.fitted_model is None:
        raise OptionError(
            f"this result of {result.model!r} keeps no model (it was not made by obsnl.identify); "
            f"the modal summary linearises the model fitted"
        )
    num = to_casadi(result.fitted_model)
    values = {p.name: p.guess if p.held else p.estimate for p in result.parameters}
    theta = np.array([values.get(n, num.values.get(n, math.nan)) for n in num.parameters], float)
    if not np.all(np.isfinite(theta)):
        raise OptionError(f"the estimate of {result.model!r} is not finite; no modal summary at it")
    x0 = _state(num.states, state)
    A, B, C, D, xdot = linearise(num, theta, x0)
    if not all(np.all(np.isfinite(M)) for M in (A, B, C, D, xdot)):
        raise ModelError(
            f"the linearisation of {result.model!r} at the state is not finite (a term without a "
            f"derivative there, such as x/|x| at 0); give state= where the model is smooth"
        )
    scale = float(np.linalg.norm(A, ord=np.inf)) * max(float(np.linalg.norm(x0, ord=np.inf)), 1.0) + 1.0
    rest = float(np.linalg.norm(xdot, ord=np.inf)) <= AT_REST * scale
    notes = []
    if not rest and state is None:
        raise ModelError(
            f"{result.model!r} is not at rest at the zero state under zero inputs (|x'| = "
            f"{float(np.linalg.norm(xdot, ord=np.inf)):.3g}); give state=, an equilibrium"
        )
    notes.append(
        "linearised at rest: every state 0, every input 0"
        if state is None
        else "linearised at the state given, every input 0"
        + (
            ""
            if rest
            else f"; it is no equilibrium (|x'| = {float(np.linalg.norm(xdot, ord=np.inf)):.3g}"
            f"): the modes are those of the tangent model there"
        )
    )
    notes.append(
        "non-smooth terms (sign, abs, ...) linearised by the derivative of the branch at the state (0 for sign)"
    )
    lam, shapes, real = eigen_modes(A, C)
    ref = np.array([int(np.argmax(np.abs(s))) for s in shapes], int)
    base = _figures(lam, shapes, ref)
    Sigma, how = parameter_covariance(result)
    notes.append(how)
    order = {p.name: i for i, p in enumerate(result.parameters)}
    G = np.zeros(base.shape + (len(result.parameters),))
    for k, name in enumerate(num.parameters):
        i = order.get(name)
        if i is None or Sigma[i, i] == 0:
            continue
        h = STEP * max(abs(theta[k]), 1e-12)
        pair: list[np.ndarray] = []
        for sgn in (1.0, -1.0):
            th = theta.copy()
            th[k] += sgn * h
            Ak, _, Ck, _, _ = linearise(num, th, x0)
            if not (np.all(np.isfinite(Ak)) and np.all(np.isfinite(Ck))):
                pair = []
                break
            lk, sk, _ = eigen_modes(Ak, Ck)
            if lk.size != lam.size:  # a pair turned real within the step: no derivative there
                pair = []
                break
            m = _matched(lam, lk)
            pair.append(_figures(lk[m], sk[m], ref))
        G[..., i] = (pair[0] - pair[1]) / (2 * h) if pair else math.nan
    with np.errstate(invalid="ignore"):
        finite = np.isfinite(np.diag(Sigma))
        var = np.einsum(
            "abi,ij,abj->ab",
            np.where(finite, G, 0.0),
            np.where(np.outer(finite, finite), Sigma, 0.0),
            np.where(finite, G, 0.0),
        )
        touched = np.any((G != 0) & ~finite, axis=2)  # a figure that moves along a parameter of infinite std
        var = np.where(touched, math.inf, var)
    std = np.sqrt(np.clip(var, 0.0, None))
    opt = lambda v: None if not math.isfinite(v) else float(v)
    outs = tuple(num.outputs)
    return Modal(
        model=result.model,
        states=tuple(num.states),
        inputs=tuple(num.inputs),
        outputs=outs,
        state=dict(zip(num.states, map(float, x0))),
        frequency_hz=tuple(map(float, base[:, 0])),
        frequency_hz_std=tuple(opt(v) for v in std[:, 0]),
        damping_ratio=tuple(map(float, base[:, 1])),
        damping_ratio_std=tuple(opt(v) for v in std[:, 1]),
        shapes=tuple(dict(zip(outs, map(float, row[2:]))) for row in base),
        shapes_std=tuple({o: opt(v) for o, v in zip(outs, row[2:])} for row in std),
        complexity=tuple(float(np.max(np.abs((s / s[r]).imag))) if s.size else 0.0 for s, r in zip(shapes, ref)),
        real_poles=tuple(map(float, real)),
        assumptions=tuple(notes),
        A=A,
        B=B,
        C=C,
        D=D,
    )


def _state(states: Sequence[str], state: Mapping[str, float] | Sequence[float] | None) -> np.ndarray:
    """The state as an array in model order (None: zeros)."""
    if state is None:
        return np.zeros(len(states))
    if isinstance(state, Mapping):
        other = [k for k in state if k not in states]
        missing = [s for s in states if s not in state]
        if other or missing:
            raise OptionError(
                f"state= names every state of the model ({names(states)}); "
                + (f"{names(other)} is not one" if other else f"{names(missing)} missing")
            )
        x = np.array([state[s] for s in states], float)
    else:
        x = np.asarray(state, float).ravel()
        if x.size != len(states):
            raise OptionError(f"state= has {x.size} values; the model has {len(states)} states ({names(states)})")
    if not np.all(np.isfinite(x)):
        raise OptionError("state= holds a value that is not finite; give numbers")
    return x
