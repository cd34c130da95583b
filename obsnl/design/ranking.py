"""Which sufficient sensor set informs the parameters best? Practical ranking by the Cramer-Rao bound
along a simulated response, and effective independence on the linear part's modes.

:func:`rank_sensor_sets` answers for a given experiment (a record and a noise model). The model's
``[values]`` (parameters and initial states) are simulated under the record by obsnl's integrator,
and the output-error residuals of the identification room
(:func:`obsnl.identification.likelihood.objective`) give, once, the exact derivative of EVERY output at
every sample with respect to

* the log of each parameter ranked (``phi = log|theta|``, so a derivative is a *relative* sensitivity
  ``theta dy/dtheta``), and
* the initial state (by default): records start in motion and the likelihood fit estimates ``x0`` too,
  so the initial states are nuisance parameters. The bound of a parameter is the corresponding
  diagonal entry of the inverse of the whole Fisher information (parameters and initial states
  together), which is larger than the inverse of the parameters' block alone; ``estimate_x0=False``
  takes the initial state as known.

Noise model: independent Gaussian white noise on each output of the set, of standard deviation
``sigma_c = level_c * RMS(y_c)`` (the RMS of the noise-free output along the response; ``level`` 1 % by
default), the same model as the identification room's relative noise. For a set ``S`` the Fisher
information is ``F = sum_{c in S} sum_k J_ck' J_ck / sigma_c^2`` and the Cramer-Rao bound of ``phi`` is
``F^-1``; since ``d phi = d theta / theta``, ``sqrt(CRB_ii)`` of ``phi`` is exactly the relative bound
``sqrt(CRB(theta)_ii) / |theta_i|``. The inverse is taken by
:func:`obsnl.identification.likelihood.covariance`: an eigen-decomposition of ``F`` scaled to its
correlation form, a coordinate along a flat direction (relative eigenvalue below 1e-10) gets an
infinite bound: a singular ``F`` never fails. ``log_det_fim`` is the log-determinant of the
parameters' information once the initial states are eliminated (the Schur complement, ``-log det``
of the parameters' block of the bound), in the log coordinates, i.e. of the relative-scaled
information (D-optimality); ``-inf`` when a bound is infinite.

:func:`effective_independence` answers without a record: Kammer's effective independence (Kammer 1991,
doi:10.2514/3.20635) on the mode shapes of the model linearised at rest.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from obsnl.errors import DataError, OptionError
from obsnl.estimation.accelerogram import Record, check_times
from obsnl.estimation.codegen import NumericModel, log_map, to_casadi
from obsnl.identification.likelihood import covariance, objective
from obsnl.identification.setup import MIN_NOISE, Data, Setup
from obsnl.model.core import Model

__all__ = ["RankedSet", "Ranking", "rank_sensor_sets", "mode_shapes", "effective_independence"]


@dataclass(frozen=True)
class RankedSet:
    """The Cramer-Rao bounds of one sensor set.

    Attributes
    ----------
    sensors
        The outputs of the set, as given.
    worst_relative_std
        ``max_i sqrt(CRB_ii) / |theta_i|`` over the ranked parameters (``inf``: some parameter is not
        informed at all).
    worst
        The parameter that attains it.
    log_det_fim
        Log-determinant of the parameters' relative-scaled information, initial states eliminated.
    relative_std
        ``sqrt(CRB_ii) / |theta_i|`` per ranked parameter (in :attr:`Ranking.parameters` order).
    """

    sensors: tuple[str, ...]
    worst_relative_std: float
    worst: str
    log_det_fim: float
    relative_std: tuple[float, ...]

    def to_dict(self, parameters: Sequence[str] | None = None) -> dict[str, Any]:
        """JSON-ready fields (``inf`` written as None); ``relative_std`` keyed by ``parameters`` if given."""
        std = [_num(s) for s in self.relative_std]
        return {
            "sensors": list(self.sensors),
            "worst_relative_std": _num(self.worst_relative_std),
            "worst": self.worst,
            "log_det_fim": _num(self.log_det_fim),
            "relative_std": dict(zip(parameters, std)) if parameters is not None else std,
        }


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


@dataclass(frozen=True)
class Ranking:
    """Sensor sets sorted best first: by ``worst_relative_std``, then by larger ``log_det_fim``.

    Attributes
    ----------
    rows
        One :class:`RankedSet` per set.
    parameters
        The parameters ranked (the others held at their values, known).
    nuisance
        The initial states estimated with them (empty with ``estimate_x0=False``).
    noise_level, noise_std
        Per output of the model: the relative noise level and the noise std it gives on this response.
    samples, dt
        The record.
    seconds
        Wall time (simulation and sensitivities, then the bounds of every set).
    """

    rows: tuple[RankedSet, ...]
    parameters: tuple[str, ...]
    nuisance: tuple[str, ...]
    noise_level: Mapping[str, float]
    noise_std: Mapping[str, float]
    samples: int
    dt: float
    seconds: float

    def position(self, sensors: Sequence[str]) -> int:
        """The 0-based place of the set ``sensors`` (order within the set ignored); ValueError if absent."""
        want = frozenset(sensors)
        for i, r in enumerate(self.rows):
            if frozenset(r.sensors) == want:
                return i
        raise ValueError(f"{list(sensors)} is not among the ranked sets")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "criterion": "worst relative Cramer-Rao std over the parameters (then larger log det of the "
            "relative-scaled Fisher information)",
            "parameters": list(self.parameters),
            "nuisance": list(self.nuisance),
            "noise": "independent Gaussian white noise per output, std = level x RMS of the noise-free output",
            "noise_level": dict(self.noise_level),
            "noise_std": dict(self.noise_std),
            "samples": self.samples,
            "dt": self.dt,
            "seconds": round(self.seconds, 3),
            "rows": [r.to_dict(self.parameters) for r in self.rows],
        }


def _numeric(model: Model | NumericModel) -> NumericModel:
    return model if isinstance(model, NumericModel) else to_casadi(model)


def _inputs(num: NumericModel, inputs: Any, T: int) -> np.ndarray:
    if isinstance(inputs, Mapping):
        missing = [n for n in num.inputs if n not in inputs]
        if missing:
            raise DataError(f"no samples for input(s) {', '.join(missing)} of {num.name!r}")
        inputs = np.column_stack([np.asarray(inputs[n], float) for n in num.inputs])
    u = np.asarray(inputs, float)
    u = u.reshape(-1, 1) if u.ndim == 1 else u
    if u.shape != (T, num.nu):
        raise DataError(
            f"inputs must have shape ({T}, {num.nu}) (one column per input {', '.join(num.inputs)}), got {u.shape}"
        )
    return u


def _levels(num: NumericModel, noise: float | Mapping[str, float]) -> np.ndarray:
    given = dict(noise) if isinstance(noise, Mapping) else {o: float(noise) for o in num.outputs}
    bad = sorted(set(given) - set(num.outputs))
    if bad:
        raise OptionError(f"noise given for {bad}, which are not outputs of {num.name!r} ({', '.join(num.outputs)})")
    levels = np.array([float(given.get(o, 0.01)) for o in num.outputs])
    if not np.all(np.isfinite(levels) & (levels >= MIN_NOISE)):
        raise OptionError(
            f"noise levels must be finite numbers of at least {MIN_NOISE:g} (noise to signal RMS; "
            f"below it double precision cannot resolve the noise), got {given}"
        )
    return levels


def rank_sensor_sets(
    model: Model | NumericModel,
    sets: Sequence[Sequence[str]],
    *,
    t: Any,
    inputs: Any,
    noise: float | Mapping[str, float] = 0.01,
    parameters: Sequence[str] | None = None,
    estimate_x0: bool = True,
    substeps: int = 8,
    refine: int = 8,
) -> Ranking:
    """Rank sensor sets by the Cramer-Rao bounds of the parameters along a simulated response.

    Parameters
    ----------
    model : Model or NumericModel
        The model with every candidate sensor as an output, with ``[values]`` for every parameter
        (nonzero: the bounds are relative) and optionally the initial states (default 0).
    sets : sequence of sequence of str
        Candidate sets, each a sequence of output names.
    t : Any
        Sample times of the record (evenly spaced).
    inputs : Any
        Input samples: ``(T,)`` for one input, ``(T, nu)``, or ``{input name: samples}``.
    noise : float or mapping of str to float
        Relative noise level of every output, or ``{output: level}`` (default 0.01 each): the noise std of
        output ``c`` is ``level_c * RMS(y_c)`` along the response (module docstring).
    parameters : sequence of str or None
        The parameters ranked (default all); the others are taken as known.
    estimate_x0 : bool
        The initial states are unknown nuisance parameters (default, as in the likelihood fit); False:
        known.
    substeps, refine : int
        RK4 substeps per sample and the refinement of a crossing substep (the integrator of the
        likelihood fit, :meth:`obsnl.estimation.codegen.NumericModel.step`).

    Returns
    -------
    Ranking

    Raises
    ------
    OptionError
        No set, an unknown output or parameter, a parameter without a nonzero value, bad noise levels.
    DataError
        Irregular times, inputs of the wrong shape.
    EstimatorError
        The model cannot be simulated at its values.

    References
    ----------
    .. [1] D. C. Kammer, "Sensor placement for on-orbit modal identification and correlation of large space
       structures", J. Guidance, Control, and Dynamics 14(2), 251-259, 1991. doi:10.2514/3.20635

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="osc", states=["x", "v"], parameters=["k", "c", "g"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x - c*v"},
    ...           outputs={"d": "x", "dg": "g*x"}, values={"k": 4.0, "c": 0.4, "g": 2.0})
    >>> t = np.arange(200) * 0.05
    >>> r = rank_sensor_sets(m, [["dg"], ["d", "dg"]], t=t, inputs=np.sin(1.7 * t), parameters=["k", "c"])
    >>> [row.sensors for row in r.rows], bool(r.rows[0].worst_relative_std < r.rows[1].worst_relative_std)
    ([('d', 'dg'), ('dg',)], True)
    >>> rank_sensor_sets(m, [["d"]], t=t, inputs=np.sin(1.7 * t)).rows[0].worst  # g does not reach d
    'g'
    """
    t0 = time.perf_counter()
    num = _numeric(model)
    candidates = [tuple(s) for s in sets]
    if not candidates or any(not s for s in candidates):
        raise OptionError("give at least one sensor set, each of at least one output")
    unknown = sorted({o for s in candidates for o in s} - set(num.outputs))
    if unknown:
        raise OptionError(
            f"{', '.join(map(repr, unknown))} is not an output of {num.name!r}; the candidate "
            f"sensors are {', '.join(num.outputs)}"
        )
    ranked = tuple(num.parameters if parameters is None else parameters)
    bad = [p for p in ranked if p not in num.parameters]
    if bad or not ranked:
        raise OptionError(f"parameters {bad or '(none)'} to rank: choose among {', '.join(num.parameters)}")
    theta = num.nominal(num.parameters)
    zero = [p for p, v in zip(num.parameters, theta) if v == 0.0 and p in ranked]
    if zero:
        raise OptionError(
            f"{', '.join(zero)} {'is' if len(zero) == 1 else 'are'} 0 in [values]: a relative bound "
            f"needs a nonzero value (or leave it out of parameters=)"
        )
    t = np.asarray(t, float)
    dt = check_times(t, "the record")
    u = _inputs(num, inputs, len(t))
    levels = _levels(num, noise)
    values = dict(zip(num.parameters, map(float, theta)))
    coords = log_map(
        num.parameters,
        signs={p: -1 for p, v in values.items() if v < 0},
        linear=[p for p, v in values.items() if v == 0.0],
    )  # a held 0 cannot take log coordinates
    record = Record("record", u if num.nu != 1 else u[:, 0], dt, channels=num.inputs if num.nu != 1 else ())
    setup = Setup(
        model=num,
        record=record,
        truth=values,
        guess=values,
        coordinates=coords,
        substeps=substeps,
        refine=refine,
        fit_substeps=substeps,
    )
    data = Data(seed=None, u=u, y=setup.y_true)
    obj = objective(setup, data, theta=theta, substeps=substeps, sigma=np.ones(num.ny))
    _, jac = obj.evaluate(np.r_[coords.to_phi(theta), np.zeros(num.nx)])
    assert jac is not None  # evaluate returns the Jacobian unless told not to
    J = jac.reshape(len(t), num.ny, -1)
    keep = [num.parameters.index(p) for p in ranked] + (list(range(num.np, num.np + num.nx)) if estimate_x0 else [])
    J = J[:, :, keep]
    rms = np.sqrt(np.mean(np.asarray(setup.y_true, float).reshape(len(t), -1) ** 2, axis=0))
    sigma = levels * rms
    weight = np.where(sigma > 0, 1.0 / np.where(sigma > 0, sigma, 1.0), 0.0)  # a silent output informs nothing
    rows = []
    for s in candidates:
        idx = [num.outputs.index(o) for o in s]
        C, _ = covariance((J[:, idx, :] * weight[idx][None, :, None]).reshape(-1, len(keep)))
        std = np.sqrt(np.diag(C)[: len(ranked)])
        block = C[: len(ranked), : len(ranked)]
        logdet = -float(np.linalg.slogdet(block)[1]) if np.all(np.isfinite(std)) else -math.inf
        w = int(np.argmax(std))
        rows.append(RankedSet(s, float(std[w]), ranked[w], logdet, tuple(float(x) for x in std)))
    rows.sort(key=lambda r: (r.worst_relative_std, -r.log_det_fim))
    return Ranking(
        rows=tuple(rows),
        parameters=ranked,
        nuisance=tuple(num.states) if estimate_x0 else (),
        noise_level=dict(zip(num.outputs, map(float, levels))),
        noise_std=dict(zip(num.outputs, map(float, sigma))),
        samples=len(t),
        dt=dt,
        seconds=time.perf_counter() - t0,
    )


def mode_shapes(
    model: Model | NumericModel, modes: int, *, candidates: Sequence[str] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The output shapes ``Psi = C Phi`` of the lowest ``modes`` modes of the model linearised at rest.

    The model is linearised at states 0, inputs 0 and its parameter ``[values]``: ``A = df/dx`` and
    ``C = dh/dx`` (the output row of an acceleration is its expression's derivative, so it contains
    the dynamics). The modes are the eigenvectors of ``A``; a complex-conjugate pair counts once (the
    member with positive imaginary part), eigenvalues below 1e-9 of the largest in modulus (static
    modes, such as the hysteretic variables' offsets) are left out, and the rest are ordered by
    ``|lambda|`` (the undamped natural frequency of a pair). A complex shape ``psi = C phi`` is made
    real by rotating it so that its largest entry is real and positive, then taking the real part (for
    classically damped modes this is exact; for others it keeps the dominant in-phase part).

    Parameters
    ----------
    model : Model or NumericModel
        The model with ``[values]`` for every parameter.
    modes : int
        How many modes.
    candidates : sequence of str or None
        The outputs (rows of ``Psi``; default every output), in this order.

    Returns
    -------
    tuple
        ``(Psi, lambda)``: ``Psi`` of shape ``(len(candidates), modes)`` and the modes' eigenvalues.

    Raises
    ------
    OptionError
        An unknown output, or fewer vibration modes than asked for.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="osc", states=["x", "v"], parameters=["k"], equations={"x": "v", "v": "-k*x"},
    ...           outputs={"d": "x", "a": "-k*x"}, values={"k": 4.0})
    >>> psi, lam = mode_shapes(m, 1)
    >>> np.round(psi[:, 0] / psi[0, 0], 6).tolist(), np.round(lam, 6).tolist()
    ([1.0, -4.0], [2j])
    """
    num = _numeric(model)
    names = tuple(num.outputs if candidates is None else candidates)
    bad = [o for o in names if o not in num.outputs]
    if bad or not names:
        raise OptionError(f"candidates {bad or '(none)'}: choose among the outputs {', '.join(num.outputs)}")
    x, u = ca.SX.sym("x", num.nx), ca.SX.sym("u", num.nu)
    p = num.nominal(num.parameters)
    lin = ca.Function("lin", [x, u], [ca.jacobian(num.f(x, p, u), x), ca.jacobian(num.h(x, p, u), x)])
    A, C = (np.asarray(m, float) for m in lin(np.zeros(num.nx), np.zeros(num.nu)))
    lam, V = np.linalg.eig(A)
    tol = 1e-9 * max(float(np.abs(lam).max(initial=0.0)), 1e-300)
    sel = [i for i in np.argsort(np.abs(lam), kind="stable") if np.abs(lam[i]) > tol and lam[i].imag >= 0]
    if len(sel) < modes:
        raise OptionError(f"{num.name!r} has {len(sel)} vibration modes at rest, fewer than the {modes} asked for")
    sel = sel[:modes]
    Psi = C[[num.outputs.index(o) for o in names]] @ V[:, sel]
    top = np.abs(Psi).argmax(axis=0)
    Psi = (Psi * np.exp(-1j * np.angle(Psi[top, np.arange(len(sel))]))).real
    return Psi, lam[sel]


def effective_independence(
    model: Model | NumericModel, size: int, *, candidates: Sequence[str] | None = None
) -> tuple[str, ...]:
    """Kammer's effective independence: the ``size`` outputs that keep the lowest ``size`` modes most
    linearly independent.

    With ``Psi`` the output shapes of the lowest ``size`` modes (:func:`mode_shapes`), each candidate's
    share of the determinant of the Fisher information ``Psi' Psi`` is ``E = diag(Psi (Psi' Psi)^+ Psi')``
    (the diagonal of the projection on the shapes' span); the candidate with the smallest ``E`` is
    deleted (the first in ``candidates`` order on a tie) and ``E`` computed again, until ``size`` remain
    (Kammer 1991).

    Parameters
    ----------
    model : Model or NumericModel
        The model with ``[values]`` for every parameter.
    size : int
        Sensors to keep (and modes targeted).
    candidates : sequence of str or None
        Outputs to choose from (default every output).

    Returns
    -------
    tuple of str
        The kept outputs, in ``candidates`` order.

    Raises
    ------
    OptionError
        ``size`` not between 1 and the number of candidates, or fewer vibration modes than ``size``.

    References
    ----------
    .. [1] D. C. Kammer, "Sensor placement for on-orbit modal identification and correlation of large space
       structures", J. Guidance, Control, and Dynamics 14(2), 251-259, 1991. doi:10.2514/3.20635

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="chain", states=["x1", "x2", "x3", "v1", "v2", "v3"], parameters=["k"],
    ...           equations={"x1": "v1", "x2": "v2", "x3": "v3", "v1": "-2*k*x1 + k*x2",
    ...                      "v2": "k*x1 - 2*k*x2 + k*x3", "v3": "k*x2 - k*x3"},
    ...           outputs={"d1": "x1", "d2": "x2", "d3": "x3"}, values={"k": 1.0})
    >>> effective_independence(m, 2)  # two modes of a 3-storey chain: E = 0.65, 0.46, 0.89, the middle goes
    ('d1', 'd3')
    """
    num = _numeric(model)
    names = tuple(num.outputs if candidates is None else candidates)
    if not (isinstance(size, int) and 1 <= size <= len(names)):
        raise OptionError(f"size must be an integer between 1 and the {len(names)} candidates, got {size!r}")
    Psi, _ = mode_shapes(num, size, candidates=names)
    live = list(range(len(names)))
    while len(live) > size:
        P = Psi[live]
        E = np.einsum("ij,ji->i", P, np.linalg.pinv(P))
        del live[int(np.flatnonzero(E <= E.min() + 1e-12)[0])]  # the first of a tie (up to rounding)
    return tuple(names[i] for i in live)
