"""The maximum-likelihood refinement of a filter's estimate, with its verdict on the fit."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from obsnl._text import block, names, number, one_line
from obsnl.errors import EstimatorError, OptionError
from obsnl.estimation.periods import periodic_noise
from obsnl.estimation.simulate import simulate
from obsnl.identification.adequacy import LEVEL, Adequacy, adequacy
from obsnl.identification.likelihood import (
    DECREMENT,
    NOISE_FLOOR,
    STEP_LIMIT,
    Fit,
    Objective,
    covariance,
    levenberg_marquardt,
    objective,
)
from obsnl.identification.setup import BOUND, Data, Setup

__all__ = ["Refinement", "refine", "residual_dof", "adequacy_of", "ADVICE"]

#: What to try when the refinement does not converge: the filter initialises it, so its start moves with the
#: guesses and with the number of passes (``guess=``/``passes=`` in Python, ``--guess``/``--passes`` on the command line).
ADVICE = "try other initial guesses or more filter passes"


@dataclass(frozen=True, eq=False)
class Refinement:
    """The maximum-likelihood estimate and what it rests on.

    ``theta``, ``x0``: the estimate; ``std``: per parameter, from the Fisher information at the estimate
    (``inf`` along a flat direction) with the measured inputs' noise propagated (``input_cov``); ``cov``: the
    inverse Fisher information of ``z = (phi, s)`` (the output noise alone: the curvature the profiles follow);
    ``input_cov``: what noise on the measured inputs adds to it (zero for inputs given as exact,
    :meth:`~obsnl.identification.likelihood.Objective.input_covariance`); ``sigma``: the noise std per
    output estimated from the residuals over their degrees of freedom (:func:`residual_dof`; the weights of
    ``cov``); ``misfit``: per output, the RMS residual
    over the noise level given or estimated before the fit (1: at the noise floor); ``converged`` with
    ``reason``; ``known``: the states whose initial value was held (declared known); ``objective`` and ``fit`` feed
    the profiles (:mod:`obsnl.identification.profile`); ``left_out``: per output that jumps with the field, the
    samples next to a jump the fit left out (:func:`near_jumps`; the objective's data hold them as missing).
    """

    theta: np.ndarray
    x0: np.ndarray
    std: np.ndarray
    cov: np.ndarray = field(repr=False)
    sigma: np.ndarray = field(repr=False)
    misfit: dict[str, float] = field(default_factory=dict)
    chi2: float = math.nan
    converged: bool = False
    reason: str = ""
    iterations: int = 0
    seconds: float = 0.0
    held: tuple[str, ...] = ()
    known: tuple[str, ...] = ()
    at_edge: tuple[str, ...] = ()
    # what the fit rests on: refine() and a worker's rebuild always set it; None only in a Refinement built by hand
    # for its text (repr, summary), which reads none of it, so the readers (to_dict, the profiles, the adequacy
    # tests) take it as set
    lower: np.ndarray = field(default=None, repr=False)  # type: ignore[arg-type]
    upper: np.ndarray = field(default=None, repr=False)  # type: ignore[arg-type]
    fit: Fit = field(default=None, repr=False)  # type: ignore[assignment]
    objective: Objective = field(default=None, repr=False)  # type: ignore[assignment]
    input_cov: np.ndarray | None = field(default=None, repr=False)
    left_out: dict[str, int] = field(default_factory=dict)

    def total_cov(self) -> np.ndarray:
        """The covariance of ``z`` under the noise of the outputs and of the measured inputs."""
        return self.cov if self.input_cov is None else self.cov + self.input_cov

    def widening(self, i: int) -> float:
        """How much the measured inputs' noise widens coordinate ``i``'s std (1: exact inputs, or a flat
        coordinate). A profile-likelihood interval ends where its rise reaches ``THRESHOLD * widening**2``: the
        output-error profile's curvature is ``1 / cov[i, i]``, the estimate's variance ``total_cov()[i, i]``."""
        c = float(self.cov[i, i])
        extra = 0.0 if self.input_cov is None else float(self.input_cov[i, i])
        return math.sqrt(1.0 + extra / c) if math.isfinite(c) and c > 0 else 1.0

    def _parameters(self) -> list[str]:
        """The parameter names (from the objective; ``p0, p1, ...`` without one)."""
        return (
            list(self.objective.setup.model.parameters)
            if self.objective is not None
            else [f"p{i}" for i in range(len(self.theta))]
        )

    def __repr__(self) -> str:
        theta = names([f"{p}={number(v)}" for p, v in zip(self._parameters(), self.theta)], 6)
        return one_line(
            "Refinement",
            f"converged={self.converged}",
            f"chi2={number(self.chi2)}",
            f"iterations={self.iterations}",
            f"theta='{theta}'",
        )

    def summary(self) -> str:
        """A few lines of plain text: converged or not and why, each parameter with its std, the misfit."""
        rows = [
            f"{p} = {number(v)} (std {number(s)})"
            + (" held" if p in self.held else "")
            + (" at the edge of the valid region" if p in self.at_edge else "")
            for p, v, s in zip(self._parameters(), self.theta, self.std)
        ]
        return block(
            f"maximum likelihood: {'converged' if self.converged else 'NOT converged'} ({self.reason}), "
            f"chi2 {number(self.chi2)}, {self.iterations} iterations, {self.seconds:.3g} s",
            *rows[:9],
            f"... and {len(rows) - 9} more parameters" if len(rows) > 9 else "",
            f"RMS residual over the noise level: {names([f'{o} {number(v)}' for o, v in self.misfit.items()])}",
            (
                "left out next to a jump of the field: "
                + names([f"{n} samples of {o}" for o, n in self.left_out.items()])
                if self.left_out
                else ""
            ),
        )

    def correlation(self) -> dict[str, dict[str, float | None]]:
        """The correlations of the estimated parameters (in log|theta|, at the estimate, the initial state
        integrated out): ``None`` for a held parameter or one along a flat direction.

        With the std, they give the joint (Wald) region: ``e' (D R D)^-1 e <= chi2(k, 0.95)`` for the errors
        ``e`` of ``k`` parameters, ``D`` their std, ``R`` these correlations.
        """
        n = len(self.theta)
        C = np.asarray(self.total_cov(), float)[:n, :n]
        d = np.sqrt(np.diag(C))
        ok = np.isfinite(d) & (d > 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            R = C / np.outer(d, d)
        ps = self._parameters()
        return {
            p: {q: (round(float(R[i, j]), 6) if ok[i] and ok[j] else None) for j, q in enumerate(ps)}
            for i, p in enumerate(ps)
        }

    @property
    def gain(self) -> np.ndarray:
        """The prediction-error objective's fitted predictor gain ``K`` ``(nx, ny)`` (state per output); zeros for
        the output-error objective (:meth:`~obsnl.identification.likelihood.Objective.gain`)."""
        return self.objective.gain(self.fit.z)

    def to_dict(self) -> dict[str, Any]:
        f, obj = self.fit, self.objective
        m = obj.setup.model
        kind = (
            "prediction error, a constant-gain predictor whose gain is fitted with the parameters"
            if obj.predictor
            else "output error, single shooting"
        )
        return {
            "method": f"maximum likelihood ({kind}; Levenberg-Marquardt with exact "
            f"derivatives through the {obj.substeps}-substep integrator)",
            "objective": "prediction" if obj.predictor else "output",
            "predictor_gain": (
                {s: {o: float(k) for o, k in zip(m.outputs, row)} for s, row in zip(m.states, self.gain)}
                if obj.predictor
                else None
            ),
            "converged": self.converged,
            "reason": self.reason,
            "iterations": self.iterations,
            "evaluations": f.evaluations,
            "newton_decrement": f.decrement,
            "last_step_in_std": f.last_step,
            "chi2": self.chi2,
            "samples": int(np.sum(self.objective.measured)),
            "seconds": self.seconds,
            "noise_std": {o: float(s) for o, s in zip(self.objective.setup.model.outputs, self.sigma)},
            "misfit_over_noise": dict(self.misfit),
            "x0": {s: float(v) for s, v in zip(self.objective.setup.model.states, self.x0)},
            "correlation": self.correlation(),
            "input_noise_widening": {p: round(self.widening(i), 6) for i, p in enumerate(self._parameters())},
            "left_out_near_jumps": dict(self.left_out),
        }


def refine(
    setup: Setup,
    data: Data,
    theta0: np.ndarray,
    *,
    held: Sequence[str] = (),
    substeps: int | None = None,
    max_iter: int = 60,
    advice: str = ADVICE,
    input_noise: Sequence[float] | np.ndarray | None = None,
    x0: Sequence[float] | np.ndarray | None = None,
    known: Sequence[str] | None = None,
    gain: Sequence[float] | np.ndarray | None = None,
) -> Refinement:
    """Maximum-likelihood refinement of the filter's estimate ``theta0`` (module docstring).

    Parameters
    ----------
    setup : Setup
        The experiment (model, coordinates, noise levels, valid region: ``BOUND`` around the guesses).
    data : Data
        Measured inputs and outputs.
    theta0 : numpy.ndarray
        The starting parameters (the filter's estimate).
    held : sequence of str
        Parameters kept at their value in ``theta0``.
    substeps : int or None
        RK4 substeps per sample of the objective (default: twice the filter's, ``2 * setup.substeps``; a
        crossing substep is refined as everywhere).
    max_iter : int
        Levenberg-Marquardt iterations at most, per weighting.
    advice : str
        What to try when the refinement does not converge (the end of the reason); a caller whose guesses
        are fixed (the seed paper's study) names only what its user can change.
    input_noise : sequence of float, numpy.ndarray or None
        The noise std of each measured input, propagated into the std (:attr:`Refinement.input_cov`); default:
        the setup's levels on these data; 0 takes an input as exact.
    x0 : sequence of float, numpy.ndarray or None
        The initial state the fit starts from (default: the setup's, ``setup.x0``): a restart from a better point.
    known : sequence of str or None
        States whose initial value is known (``setup.x0``'s): those coordinates are held, never fitted, and carry
        no std (default: ``setup.known``).
    gain : sequence of float, numpy.ndarray or None
        The prediction-error objective's gain coordinates to start from (``z``'s tail: a restart from a better
        point); default: the gains fitted first with the parameters held.

    Returns
    -------
    Refinement

    Raises
    ------
    EstimatorError
        The model cannot be simulated at ``theta0``.
    """
    t0 = time.perf_counter()
    m = setup.model
    obj = objective(setup, data, theta=theta0, substeps=substeps or 2 * setup.substeps)
    phi0 = setup.coordinate_map.to_phi(theta0)
    guess = setup.coordinate_map.to_phi(setup.theta_guess)
    g = obj.n_gains
    declared_lower, declared_upper = declared_bounds(setup)
    lower = np.r_[np.maximum(guess - BOUND, declared_lower), np.full(m.nx + g, -np.inf)]
    upper = np.r_[np.minimum(guess + BOUND, declared_upper), np.full(m.nx + g, np.inf)]
    known = tuple(setup.known if known is None else known)
    unknown = sorted(set(known) - set(m.states))
    if unknown:
        raise OptionError(f"known initial states {unknown} are not states of {m.name!r} ({', '.join(m.states)})")
    free = np.r_[[p not in held for p in m.parameters], [s not in known for s in m.states], np.ones(g, bool)]
    start = np.zeros(m.nx) if x0 is None else (np.asarray(x0, float) - setup.x0) / obj.scale
    kappa = np.zeros(g) if gain is None else np.asarray(gain, float).ravel()
    z = np.r_[phi0, np.where(free[m.np : m.np + m.nx], start, 0.0), kappa]
    noise = obj.sigma
    iterations = 0
    if g and gain is None:
        # the predictor's gains and the initial state first, the parameters held at the filter's estimate, from the
        # best of a few gains that feed back a share of each innovation (_gain_start): from a zero gain (the free
        # simulation) a drifting record's misfit is the drift, and Gauss-Newton crawls there
        z[m.np + m.nx :] = _gain_start(obj, z)
        first = free.copy()
        first[: m.np] = False
        z = levenberg_marquardt(obj.evaluate, z, lower, upper, free=first, max_iter=GAIN_ITERATIONS).z
    left_out, measured_y = np.zeros((len(data.u), m.ny), bool), data.y
    for _ in range(JUMP_ROUNDS if any(m.output_jumps) else 0):
        # an output that jumps with the field (an accelerometer under Coulomb friction): its samples next to a jump
        # hang on the crossing's time to within a sample, and chi2 jumps wherever a crossing passes a sample; they
        # are left out, as where they are at the current point, and the fit goes on without them
        near = near_jumps(obj, z)
        if np.array_equal(near, left_out):
            break
        left_out = near
        data = Data(seed=data.seed, u=data.u, y=_left_out(measured_y, left_out))
        obj = dataclasses.replace(obj, data=data)
        z = levenberg_marquardt(obj.evaluate, z, lower, upper, free=free, max_iter=max_iter).z
    factor = 1.0  # the common factor of a re-weighting that changed every weight alike (then no refit)
    for _ in range(2):  # the given noise levels, then the ML levels of the fit (concentrated likelihood)
        fit = levenberg_marquardt(obj.evaluate, z, lower, upper, free=free, max_iter=max_iter)
        iterations += fit.iterations
        res = fit.r.reshape(-1, m.ny) * obj.sigma
        # the integrator's error scales with the response's variation, not with its offset (a position far from 0)
        floor = NOISE_FLOOR * np.nanstd(np.asarray(data.y, float), axis=0)
        # a missing output sample (a zero row of J, a zero residual) counts in no N: N_c is the samples measured
        dof = np.maximum(residual_dof(fit.J[:, free], m.ny) - (len(data.u) - obj.measured), 1.0)
        sigma = np.maximum(np.sqrt(np.sum(res**2, axis=0) / dof), np.maximum(floor, 1e-300))
        z = fit.z
        if np.allclose(sigma, obj.sigma, rtol=1e-3):
            break
        ratio = sigma / obj.sigma
        obj = obj.reweighted(sigma)
        if np.allclose(ratio, ratio[0], rtol=1e-12):
            # one output, or every channel off by the same factor: chi2 only scales by 1/factor^2 and its
            # minimiser stays where it is, so a refit would end where it starts (it cost a Jacobian or more)
            factor = float(ratio[0])
            break
    r, J = obj.evaluate(z)
    # the first-order measures in the final weights: a common factor c divides the decrement by c^2 and, the
    # std growing by c, the last step (in std) by c
    fit = Fit(
        z=z,
        chi2=float(r @ r),
        iterations=fit.iterations,
        evaluations=fit.evaluations,
        decrement=fit.decrement / factor**2,
        last_step=fit.last_step / factor,
        at_bound=fit.at_bound,
        stalled=fit.stalled,
        J=J,
        r=r,
    )
    C_free, _ = covariance(J[:, free])
    C = np.zeros((len(z), len(z)))
    C[np.ix_(free, free)] = C_free
    su = setup.noise_std(data)[0] if input_noise is None else np.asarray(input_noise, float)
    Cu = obj.input_covariance(z, J, C, su)  # the measured inputs' noise, propagated
    theta = obj.theta(z)
    std = np.array([abs(theta[i]) * math.sqrt(C[i, i] + Cu[i, i]) if free[i] else 0.0 for i in range(m.np)])
    res = r.reshape(-1, m.ny) * obj.sigma
    misfit = {
        o: float(np.sqrt(np.sum(res[:, j] ** 2) / obj.measured[j]) / noise[j])  # over the samples measured
        for j, o in enumerate(m.outputs)
    }
    converged, reason = _verdict(
        fit,
        m.parameters,
        advice,
        switched=fit.decrement > DECREMENT and _switched(setup, obj, theta, obj.x0(z), data),
        declared=tuple(
            m.parameters[i]
            for i in fit.at_bound
            if i < m.np
            and (
                (fit.z[i] <= lower[i] and lower[i] == declared_lower[i])
                or (fit.z[i] >= upper[i] and upper[i] == declared_upper[i])
            )
        ),
    )
    return Refinement(
        theta=theta,
        x0=obj.x0(z),
        std=std,
        cov=C,
        sigma=obj.sigma,
        misfit=misfit,
        chi2=fit.chi2,
        converged=converged,
        reason=reason,
        iterations=iterations,
        at_edge=tuple(m.parameters[i] for i in fit.at_bound if i < m.np),
        seconds=time.perf_counter() - t0,
        held=tuple(held),
        known=tuple(known),
        lower=lower,
        upper=upper,
        fit=fit,
        objective=obj,
        input_cov=Cu,
        left_out={o: int(n) for o, n in zip(m.outputs, left_out.sum(axis=0)) if n},
    )


#: Rounds at most of leaving out the samples of a jumping output next to a jump (:func:`near_jumps`), each at the
#: point the last round's fit reached.
JUMP_ROUNDS = 3


def near_jumps(obj: Objective, z: np.ndarray) -> np.ndarray:
    """``(T, ny)``: True at the samples of an output that jumps with the field
    (:attr:`~obsnl.estimation.numeric.NumericModel.output_jumps`) next to a crossing of a switching function across
    which the field jumps, along the model simulated at ``z``: both samples around a sign change between two
    samples, and a sample on the surface (a sliding mode: the output there is Filippov's combination, not the
    branch's). Nothing for a model whose outputs do not jump.

    Parameters
    ----------
    obj : Objective
        The objective (its model, record and step).
    z : numpy.ndarray
        The point (parameters and initial state) at which the model is simulated.

    Returns
    -------
    numpy.ndarray
        Boolean ``(T, ny)``.
    """
    m = obj.setup.model
    T = len(obj.data.u)
    jumping_outputs = np.asarray(m.output_jumps or [False] * m.ny, bool)
    sign = (
        _jump_signs(obj.setup, obj.theta(z), obj.x0(z), obj.data.u, obj.substeps, locate=True)
        if jumping_outputs.any()
        else None
    )
    if sign is None:
        return np.zeros((T, m.ny), bool)
    change = np.any(sign[1:] != sign[:-1], axis=1)
    near = np.any(sign == 0, axis=1)
    near[:-1] |= change
    near[1:] |= change
    return near[:, None] & jumping_outputs[None, :]


def _jump_signs(
    setup: Setup, theta: np.ndarray, x0: np.ndarray, u: Any, substeps: int, *, locate: bool
) -> np.ndarray | None:
    """``(T, k)``: the signs at the samples of the ``k`` switching functions across which the field may jump, along
    the model simulated at ``theta`` from ``x0`` (``locate``: the fit's step); None for a model without them."""
    m = setup.model
    g_size = m.g.size1_out(0) if m.switching else 0
    jumps = np.asarray(m.jumps if m.jumps else [True] * g_size, bool)
    if not g_size or not jumps.any():
        return None
    u = np.asarray(u, float).reshape(len(u), -1)
    sim = simulate(
        m, theta=theta, x0=x0, u=u, dt=setup.record.dt, substeps=substeps, refine=setup.refine, locate=locate
    )
    T = len(sim.x)
    G = np.asarray(m.g.map(T)(sim.x.T, np.tile(theta, (T, 1)).T, u.T), float).T
    return np.sign(G[:, jumps])


def _left_out(y: Any, left_out: np.ndarray) -> np.ndarray:
    """The outputs with the samples ``left_out`` missing (NaN)."""
    return np.where(left_out, np.nan, np.asarray(y, float).reshape(left_out.shape))


#: Iterations at most of the prediction-error fit's first stage (the gains and the initial state, the parameters
#: held): it only brings the gains near their optimum, which the full fit then reaches.
GAIN_ITERATIONS = 8
#: The shares of the innovation a starting gain feeds back (:func:`_gain_start`).
GAIN_SHARES = (0.0, 0.01, 0.03, 0.1, 0.3, 0.6, 1.0)


def _gain_start(obj: Objective, z: np.ndarray) -> np.ndarray:
    """The prediction-error fit's starting gains: ``kappa = a * pinv(H)``, ``H`` the outputs' mean sensitivity to
    the states along the simulated response (in the states' and outputs' scales), so that the correction puts back
    the share ``a`` of each innovation; the ``a`` of :data:`GAIN_SHARES` whose chi2 is least (0, the free simulation,
    among them)."""
    setup = obj.setup
    m = setup.model
    theta, x0 = obj.theta(z), obj.x0(z)
    u = np.asarray(obj.data.u, float).reshape(len(obj.data.u), -1)
    try:
        sim = simulate(m, theta=theta, x0=x0, u=u, dt=setup.record.dt, substeps=obj.substeps, refine=setup.refine)
    except EstimatorError:
        return np.zeros(obj.n_gains)
    rows = np.unique(np.linspace(0, len(u) - 1, 20).astype(int))
    H = np.zeros((m.ny, m.nx))
    for k in rows:
        for j in range(m.nx):
            e = np.zeros(m.nx)
            e[j] = 1e-6 * obj.scale[j]
            up = np.asarray(m.h(sim.x[k] + e, theta, u[k]), float).ravel()
            down = np.asarray(m.h(sim.x[k] - e, theta, u[k]), float).ravel()
            H[:, j] += (up - down) / (2e-6 * obj.scale[j]) / len(rows)
    Hs = H * obj.scale[None, :] / np.asarray(obj.yscale, float)[:, None]
    unit = np.linalg.pinv(Hs).ravel(order="F")  # kappa (nx, ny), column-major as in z
    best, chi2 = np.zeros(obj.n_gains), math.inf
    for a in GAIN_SHARES:
        zz = z.copy()
        zz[m.np + m.nx :] = a * unit
        r, _ = obj.evaluate(zz, jacobian=False)
        c = float(r @ r) if np.all(np.isfinite(r)) else math.inf
        if c < chi2:
            best, chi2 = a * unit, c
    return best


def declared_bounds(setup: Setup) -> tuple[np.ndarray, np.ndarray]:
    """The declared bounds of the parameters (``setup.bounds``, the model's ``[bounds]``) in the fit's coordinates
    ``phi = log(s theta)``, ``s`` the sign of the guess: ``-inf``/``inf`` where none binds (an end of the other sign
    than the guess, or none declared; the coordinates keep the guess's sign anyway).

    Examples
    --------
    >>> import obsnl
    >>> from types import SimpleNamespace
    >>> from obsnl.estimation.codegen import to_casadi
    >>> num = to_casadi(obsnl.Model(name="d", states=["x"], parameters=["k", "F"], inputs=["u"],
    ...                             equations={"x": "u - k*x - F"}, outputs={"y": "x"}))
    >>> lo, hi = declared_bounds(SimpleNamespace(model=num, bounds={"k": (1.0, 100.0)},
    ...                                          theta_guess=np.array([10.0, -1.0])))
    >>> np.round(np.exp(lo), 6).tolist(), np.round(np.exp(hi), 6).tolist()
    ([1.0, 0.0], [100.0, inf])
    """
    m = setup.model
    lower, upper = np.full(m.np, -np.inf), np.full(m.np, np.inf)
    guess = np.asarray(setup.theta_guess, float)
    with np.errstate(divide="ignore"):
        for i, p in enumerate(m.parameters):
            lo, hi = (setup.bounds or {}).get(p, (-math.inf, math.inf))
            s = 1.0 if guess[i] > 0 else -1.0
            a, b = sorted((s * lo, s * hi))  # the bounds of |theta| = s theta
            lower[i] = math.log(a) if a > 0 else -math.inf
            upper[i] = math.log(b) if b > 0 else -math.inf
    return lower, upper


def residual_dof(J: np.ndarray, ny: int) -> np.ndarray:
    """Each output's residual degrees of freedom at a least-squares fit: ``N_c - h_c``.

    ``h_c`` is the trace of the hat matrix ``J (J'J)^+ J'`` over output ``c``'s rows (the rows of the whitened
    residuals are sample by sample, ``ny`` outputs each): the share of the fitted coordinates that output's
    samples carry; the ``h_c`` sum to the rank of ``J``. ``RSS_c / (N_c - h_c)`` estimates that output's noise
    variance without the bias of the maximum-likelihood ``RSS_c / N_c``, which is low by the fitted coordinates
    (exactly so for a model linear in them: Seber & Wild, Nonlinear Regression, 1989, section 2.1).

    Parameters
    ----------
    J : numpy.ndarray
        The Jacobian of the whitened residuals at the fit, ``(N * ny, n)``, its columns the fitted coordinates.
    ny : int
        The number of outputs.

    Returns
    -------
    numpy.ndarray
        ``N_c - h_c`` per output (at least 1).

    Examples
    --------
    >>> J = np.c_[np.ones(8), np.arange(8.0)]        # one output, a straight line fitted to 8 samples
    >>> residual_dof(J, 1).round(12).tolist()
    [6.0]
    >>> residual_dof(np.c_[np.tile([1.0, 0.0], 4)], 2).round(12).tolist()   # the one parameter seen by output 0
    [3.0, 4.0]
    """
    h = np.sum((J @ covariance(J, mark_flat=False)[0]) * J, axis=1) if J.size else np.zeros(len(J))
    n = len(J) // ny
    return np.maximum(n - h.reshape(n, ny).sum(axis=0), 1.0)


def adequacy_of(
    ref: Refinement, data: Data, *, level: float = LEVEL, input_noise: Sequence[float] | np.ndarray | None = None
) -> Adequacy | None:
    """Whether the refined model explains ``data`` to the noise level: the residual tests of
    :mod:`obsnl.identification.adequacy` on the residual the fit minimised (its own integrator).

    Each output's degrees of freedom are its samples measured less its share of the fitted coordinates
    (:func:`residual_dof`; a missing sample is a zero row of the Jacobian and a zero residual: it counts in no N).
    The tests take the residual of a right model as the output noise alone; the share of the residual variance the
    inputs' noise makes through the model is gauged by one seeded draw of it (the model simulated at the estimate
    under the measured input and under it plus the draw) and carried into the verdict.

    Parameters
    ----------
    ref : Refinement
        The maximum-likelihood fit (:func:`refine`).
    data : Data
        The inputs and outputs it was fitted to (NaN: an output sample missing).
    level : float
        The family-wise level of the tests.
    input_noise : sequence of float, numpy.ndarray or None
        The noise std of each measured input (default: the set-up's levels on these data; 0: exact).

    Returns
    -------
    Adequacy or None
        None where the tests cannot be run (fewer samples measured than they need).
    """
    m = ref.objective.setup.model
    n = len(ref.objective.setup.record)
    if ref.left_out:  # the samples the fit left out next to a jump are missing to the tests too
        data = ref.objective.data
    y = np.asarray(data.y, float).reshape(n, -1)
    u = np.asarray(data.u, float).reshape(n, -1)[:, : len(m.inputs)]  # a driven model's row starts with the sample
    measured = np.sum(np.isfinite(y), axis=0)
    free = np.r_[
        [p not in ref.held for p in m.parameters],
        [s not in ref.known for s in m.states],
        np.ones(ref.objective.n_gains, bool),
    ]
    J, r = ref.fit.J, ref.fit.r
    if not J.shape[0] == r.size == n * m.ny:
        return None
    dof = residual_dof(J[:, free], m.ny) - (n - measured)
    e = np.where(np.isfinite(y), r.reshape(n, m.ny) * ref.sigma, np.nan)
    setup = ref.objective.setup
    su = setup.noise_std(data)[0] if input_noise is None else np.asarray(input_noise, float)
    draws = [] if ref.objective.predictor else _input_noise_draws(ref, data, su)
    try:
        return adequacy(
            e,
            measured=y,
            inputs=u,
            outputs=m.outputs,
            input_names=m.inputs,
            dof=np.clip(dof, 1.0, measured),
            level=level,
            input_noise_share=_share(draws, e, m.outputs),
            noise=periodic_noise(u, y),
            innovations=ref.objective.predictor,
            input_effect=_left_in_residual(ref, draws),
        )
    except OptionError:  # fewer samples measured than the tests need
        return None


def _input_noise_draws(ref: Refinement, data: Data, su: np.ndarray) -> list[np.ndarray]:
    """Seeded draws ``(T, ny)`` of what the inputs' noise ``su`` moves the model's output by at the estimate: the
    model simulated under the measured input plus a draw of the noise, less under the measured input (NaN where
    the output is missing); [] without input noise, for a model driven by input blocks, or where it cannot be
    simulated.

    As many draws as keep about 20 000 samples in all (a short record's output is narrow-band: one draw of it is
    far from its mean), 8 at most."""
    setup = ref.objective.setup
    m = setup.model
    u = np.asarray(data.u, float).reshape(len(data.u), -1)
    if not np.any(su > 0) or u.shape[1] != len(m.inputs):
        return []
    rng = np.random.default_rng(0)

    def run(uu: np.ndarray) -> np.ndarray:
        return simulate(
            m,
            theta=ref.theta,
            x0=ref.x0,
            u=uu,
            dt=setup.record.dt,
            substeps=ref.objective.substeps,
            refine=setup.refine,
            locate=True,
        ).y

    y = np.asarray(data.y, float).reshape(len(u), -1)
    try:
        y0 = run(u)
        draws = [run(u + rng.standard_normal(u.shape) * su) - y0 for _ in range(max(1, min(8, 20000 // len(u))))]
    except EstimatorError:
        return []
    return [np.where(np.isfinite(y), d, np.nan) for d in draws]


def _left_in_residual(ref: Refinement, draws: Sequence[np.ndarray]) -> list[np.ndarray]:
    """What of each draw of the inputs' noise stays in the residual: the fit absorbs what lies in the span of its
    sensitivities (to first order, the projection on the columns of ``J`` it moved), the rest stays."""
    m = ref.objective.setup.model
    J = ref.fit.J
    free = np.r_[
        [p not in ref.held for p in m.parameters],
        [s not in ref.known for s in m.states],
        np.ones(ref.objective.n_gains, bool),
    ]
    out = []
    for d in draws:
        missing = ~np.isfinite(d)
        Jf = J[:, free] if J is not None and J.shape == (d.size, len(free)) else None
        d = np.where(missing, 0.0, d)
        if Jf is not None and Jf.size:
            w = (d / ref.sigma).ravel()  # whitened, sample-major as the residuals
            w = w - Jf @ np.linalg.lstsq(Jf, w, rcond=None)[0]
            d = w.reshape(d.shape) * ref.sigma
        out.append(np.where(missing, np.nan, d))
    return out


def _share(draws: Sequence[np.ndarray], e: np.ndarray, outputs: Sequence[str]) -> dict[str, float]:
    """Per output, the variance the draws of the inputs' noise make over the residual's; {} without draws."""
    if not draws:
        return {}
    d2 = np.mean([d**2 for d in draws], axis=0)
    return {o: float(np.nanmean(d2[:, j]) / max(np.nanmean(e[:, j] ** 2), 1e-300)) for j, o in enumerate(outputs)}


def _switched(setup: Setup, obj: Objective, theta: np.ndarray, x0: np.ndarray, data: Data) -> bool:
    """Whether the model simulated at the estimate crosses a switching function across which its field may jump
    (between two samples): only then can a switch inside a step make the objective rough."""
    try:
        sign = _jump_signs(setup, theta, x0, data.u, obj.substeps, locate=False)
    except EstimatorError:
        return False
    return sign is not None and bool(np.any(np.diff(sign, axis=0) != 0))


def _verdict(
    fit: Fit, parameters: Sequence[str], advice: str = ADVICE, *, switched: bool = False, declared: Sequence[str] = ()
) -> tuple[bool, str]:
    """Converged or not, and why: the reason names only what happened (a switch of the field inside a step only
    where the fitted trajectory crosses a switching function, ``switched``; a parameter on a bound the model file
    declared, ``declared``, as such)."""
    edge = [parameters[i] for i in fit.at_bound if i < len(parameters) and parameters[i] not in declared]
    if fit.decrement > DECREMENT:
        what = "no step lowers the misfit any more" if fit.stalled else f"stopped after {fit.iterations} iterations"
        rough = (
            "; the objective may be rough here (the fitted response crosses a switching function: a switch of "
            "the field inside a step)"
            if switched
            else ""
        )
        return False, (
            f"first-order condition not met: a Gauss-Newton step would still lower chi2 by "
            f"{fit.decrement:.3g} ({what}){rough}: {advice}"
        )
    if fit.last_step > STEP_LIMIT:
        return False, (
            f"the last step moved a parameter by {fit.last_step:.2g} of its std (more than {STEP_LIMIT:g}); {advice}"
        )
    if declared:  # the model file's bound holds the estimate: the data pull it past what the model allows
        return False, (
            f"{', '.join(declared)} rests on its declared bound (the model's [bounds]): the likelihood would rise "
            f"beyond it, so the data pull it past what the model file allows (a bound too tight, or a model that does "
            f"not fit); check the bound and the model"
        )
    if edge:  # the bounded problem's first-order conditions hold there, but a search bound is no maximum
        return False, (
            f"{', '.join(edge)} rests on its search bound (a factor 100 from its guess): the likelihood "
            f"would rise further beyond it, so this is not its maximum (a true value of 0, a sign or a "
            f"guess far off, or a model that does not fit); check the guess and the model"
        )
    return True, (
        f"first-order condition met (Newton decrement {fit.decrement:.2g} <= {DECREMENT:g}) and the last "
        f"step moved no parameter by more than {STEP_LIMIT:g} of its std"
    )
