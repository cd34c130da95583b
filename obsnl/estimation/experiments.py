"""Identification experiments: set-up, tuning without the true values, practical identifiability.

The seed experiment (``000_d24855f97fc8bdd4.txt`` §5, Table 2): the damage-healing oscillator in its
identifiable coordinates (``models/damage_healing_reparam.toml``) under the 1994 Northridge record,
true values and initial guesses of Table 2, Gaussian noise of 0.1 % noise-to-signal RMS on input and
output. :func:`obsnl.studies.seed_paper.reproduce` runs the whole pipeline (analysis -> branch table -> UKF
and DUKF).

Protocol, the same for the UKF and the DUKF:

* Log-parameters are kept within a factor 100 of the guesses (``BOUND``; a mean that leaves this
  region is put back on its edge and counted as a repair).
* ``R`` = (noise ratio x RMS of the measured output)², the process noise of the states from the
  input noise (``sigma_u`` = ratio x RMS of the measured input, mapped through the discrete step),
  scaled by ``q_x``; parameter coordinates ``log|theta|`` with prior std ``s0`` and random walk ``q_theta``.
* ``passes`` runs over the record; pass ``k+1`` starts at rest from the estimate of pass ``k`` with the
  parameter covariance ``inflate x diag(P_final)`` (the record is reused: later passes refine the
  estimate, their covariance is optimistic). After the first pass the parameters found practically
  unidentifiable (:func:`practical_identifiability`) are put back to their guess and held fixed.
  A first pass that diverged (free-run output misfit above ``DIVERGED`` x the noise level) flags
  nothing: its sensitivities are those of a wrong model, and holding parameters at their guess
  would lock the later passes out of a recovery; they go on with every parameter free. An estimate
  that cannot be simulated at all ends the run (no later pass can start from it).
* Robust step (:mod:`obsnl.estimation.ukf_step`): every update that is not finite or clearly indefinite is
  rejected (the prediction is kept), standard deviations are capped at ``STATE_CAP`` typical magnitudes
  (states) and ``BOUND`` (log-parameters), and the innovation gate ``gate`` (a tuning choice, off or 3)
  scales the gain down beyond that Mahalanobis distance; every intervention is counted per kind.
* Tuning: every configuration of the grid (``DEFAULT_GRID``: ``s0``, ``q_theta``, ``q_x``, ``gate``) is
  run on noise seeds that are not reported (five by default); the one with the smallest mean free-run
  output misfit (simulation with the estimate under the measured input, against the measured output)
  wins; a run that fails counts as infinite misfit. No true value is used.
* Practical identifiability (:func:`practical_identifiability`, :func:`monte_carlo`): a parameter is
  flagged when these data cannot pin it within the 5 % band at 3 sigma: by the linearised Cramér-Rao
  bound, by the filter's posterior against its prior, or by the Monte-Carlo spread of the whole
  protocol at the estimate (a parametric bootstrap; it sees the ridges of a non-smooth response that
  the linearised bound misses). Parameters flagged after the first pass by the first two criteria
  are held at their guess; the Monte-Carlo flag only marks an estimate as poorly informed.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from obsnl.estimation.codegen import NumericModel, ParameterMap, parameter_map
from obsnl.estimation.records import Record, add_noise, rms
from obsnl.estimation.dukf import DUKF
from obsnl.errors import EstimatorError, ObsnlError
from obsnl.estimation.simulate import simulate
from obsnl.estimation.ukf import UKF, Trajectory

__all__ = ["SEED_GUESS", "PAPER_ERRORS", "Tuning", "DEFAULT_GRID", "Setup", "Data", "Practical",
           "coordinates", "make_data", "make_filter", "run_passes", "output_misfit",
           "practical_identifiability", "input_noise_crb", "tune", "DIVERGED", "Spread", "monte_carlo"]

#: Initial guesses of Table 2 of the seed paper (DESIGN.md).
SEED_GUESS: Mapping[str, float] = {"k_m": 5e3, "c_dm": 50.0, "c_eta_p": 3e3, "c_p": 4.0, "h_p": 4e-3, "N": 3.0,
                                   "w_h": 0.3, "Delta1": 3e10, "Delta2": -6e9}
#: Errors (%) the seed paper reports in Table 2.
PAPER_ERRORS: Mapping[str, Mapping[str, float]] = {
    "dukf": {"k_m": 0.55, "c_dm": 0.01, "c_eta_p": 8.33, "c_p": 17.62, "h_p": 1.99, "N": 0.02, "w_h": 10.54,
             "Delta1": 11.39, "Delta2": 0.20},
    "ukf": {"k_m": 4.14, "c_dm": 0.02, "c_eta_p": 5.47, "c_p": 106.48, "h_p": 13.67, "N": 1.28, "w_h": 7.62,
            "Delta1": 13.93, "Delta2": 15.30},
}
#: Threshold on the Cramér-Rao standard deviation of log(theta): a parameter whose 3-sigma bound is
#: wider than the 5 % goal cannot be pinned to it by any unbiased estimator on this record.
CRB_LIMIT = 0.05 / 3
#: Valid region of the log-parameter coordinates: within a factor exp(BOUND) = 100 of the guesses.
BOUND = float(np.log(100.0))
#: A filter that kept more than this fraction of its prior standard deviation learnt (almost) nothing.
POSTERIOR_LIMIT = 0.5
#: An estimate whose free-run output misfit exceeds this many times the stated output noise level
#: (the misfit's floor is 1x) comes from a diverged filter: its output sensitivities say nothing about
#: what the record can inform, so no parameter is flagged there. Uses the measured data only.
DIVERGED = 10.0


#: Covariance ceiling (standard deviation) of the scaled states: 100 typical magnitudes at the guess.
STATE_CAP = 100.0


@dataclass(frozen=True)
class Tuning:
    """One filter configuration: prior std of log-parameters, their random walk, state-noise factor,
    innovation gate (Mahalanobis distance beyond which the gain is scaled down; inf: off)."""

    s0: float
    q_theta: float
    q_x: float
    gate: float = float("inf")

    def to_dict(self) -> dict[str, float | None]:
        return {"s0": self.s0, "q_theta": self.q_theta, "q_x": self.q_x,
                "gate": self.gate if np.isfinite(self.gate) else None}


#: The tuning grid, the same for the UKF and the DUKF: 48 configurations. The gate is off or at the
#: textbook 3 (Mahalanobis distance of a scalar innovation); decided before any reported seed was run.
DEFAULT_GRID: tuple[Tuning, ...] = tuple(Tuning(s, q, x, g) for g, s, q, x in itertools.product(
    (float("inf"), 3.0), (0.1, 0.2, 0.3, 0.5), (0.0, 1e-9, 1e-8), (1.0, 100.0)))


@dataclass(frozen=True, eq=False)
class Setup:
    """An identification experiment: compiled model, record, truth, guesses, noise, filter options."""

    model: NumericModel
    record: Record
    truth: Mapping[str, float]
    guess: Mapping[str, float]
    noise: float = 1e-3
    coordinates: ParameterMap | None = None
    substeps: int = 4
    refine: int = 8
    jit: bool = False
    y_true: np.ndarray = field(default=None, repr=False)
    x0: np.ndarray = field(default=None, repr=False)

    def __post_init__(self) -> None:
        m = self.model
        for what, vals in (("truth", self.truth), ("guess", self.guess)):
            missing = [p for p in m.parameters if p not in vals]
            if missing:
                raise ObsnlError(f"{what} lacks values for {missing}")
        if self.coordinates is None:
            object.__setattr__(self, "coordinates", coordinates(m, "log", reference=self.guess))
        x0 = np.array([float(m.values.get(s, 0.0)) for s in m.states])
        object.__setattr__(self, "x0", x0)
        if self.y_true is None:
            sim = simulate(m, theta=self.theta_true, x0=x0, u=self.record.accel, dt=self.record.dt)
            object.__setattr__(self, "y_true", sim.y)

    @property
    def theta_true(self) -> np.ndarray:
        return np.array([float(self.truth[p]) for p in self.model.parameters])

    @property
    def theta_guess(self) -> np.ndarray:
        return np.array([float(self.guess[p]) for p in self.model.parameters])

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model.name, "record": self.record.to_dict(), "truth": dict(self.truth),
                "guess": dict(self.guess), "noise_ratio": self.noise, "coordinates": self.coordinates.to_dict(),
                "substeps": self.substeps, "refine": self.refine,
                "integrator": "RK4; a substep in which a switching function across which the field can jump "
                              "changes sign redone with refine finer ones; ROS2 (refine x the substeps) where stiff"}


def coordinates(model: NumericModel, kind: str = "log", *, reference: Mapping[str, float]) -> ParameterMap:
    """Filter coordinates of the parameters.

    ``"log"``: ``log|theta|`` (the sign taken from ``reference``). ``"yield"``: as ``"log"`` but
    ``Delta1, Delta2`` replaced by the log yield displacements ``log |Delta_i|**(-1/(2N))`` (straightens
    the Delta-N ridge; needs parameters named ``Delta1, Delta2, N``).
    """
    fwd, inv = {}, {}
    for p in model.parameters:
        sign = "-" if float(reference[p]) < 0 else ""
        if kind == "yield" and p in ("Delta1", "Delta2"):
            if "N" not in model.parameters:
                raise ObsnlError("yield coordinates need a parameter 'N'")
            fwd[p], inv[f"log_ry_{p}"] = f"{sign}exp(-2*exp(log_N)*log_ry_{p})", f"-log({sign}{p})/(2*N)"
        elif kind in ("log", "yield"):
            fwd[p], inv[f"log_{p}"] = f"{sign}exp(log_{p})", f"log({sign}{p})"
        else:
            raise ObsnlError(f"unknown coordinates {kind!r}; use 'log' or 'yield'")
    return parameter_map(model.parameters, fwd, inv, check=reference)


@dataclass(frozen=True, eq=False)
class Data:
    """One noisy realisation of the experiment."""

    seed: int
    u: np.ndarray
    y: np.ndarray


def make_data(setup: Setup, seed: int) -> Data:
    """Measured input and output: truth plus Gaussian noise (``setup.noise`` x RMS), seeded."""
    rng = np.random.default_rng(seed)
    u = add_noise(setup.record.accel, ratio=setup.noise, seed=rng)
    y = add_noise(setup.y_true, ratio=setup.noise, seed=rng)
    return Data(seed=seed, u=u, y=y)


def make_filter(setup: Setup, kind: str, *, table: Any = None, cross: str = "regression") -> UKF:
    """A UKF (``kind="ukf"``) or DUKF (``"dukf"``) for this experiment (noise set per run)."""
    m = setup.model
    sim = simulate(m, theta=setup.theta_guess, x0=setup.x0, u=setup.record.accel, dt=setup.record.dt,
                   substeps=setup.substeps, refine=setup.refine)
    typical = np.sqrt(np.mean(sim.x ** 2, axis=0))  # typical magnitudes at the guess, floored at 1 %
    scale = np.maximum(typical, 1e-2 * max(typical.max(), 1e-300))  # of the largest (a state idle at the guess)
    phi0 = setup.coordinates.to_phi(setup.theta_guess)  # valid region: within 100x of the guesses
    bounds = (np.r_[np.full(m.nx, -np.inf), phi0 - BOUND], np.r_[np.full(m.nx, np.inf), phi0 + BOUND])
    cap = np.r_[np.full(m.nx, STATE_CAP), np.full(len(phi0), BOUND)]  # ceilings: sanity, not tuning
    opts = dict(dt=setup.record.dt, coordinates=setup.coordinates, state_scale=scale, R=1.0,
                substeps=setup.substeps, refine=setup.refine, jit=setup.jit, bounds=bounds, cap=cap)
    if kind == "ukf":
        return UKF(m, **opts)
    if kind == "dukf":
        return DUKF(m, table=table, cross=cross, **opts)
    raise ObsnlError(f"unknown filter {kind!r}; use 'ukf' or 'dukf'")


def _noise(setup: Setup, filt: UKF, data: Data, tuning: Tuning) -> tuple[np.ndarray, np.ndarray]:
    m, dt = setup.model, setup.record.dt
    su, sy = setup.noise * rms(data.u), setup.noise * rms(data.y)
    step = m.step(dt, method="rk4", substeps=setup.substeps)
    x0, th, u0 = setup.x0, setup.theta_guess, np.zeros(m.nu)
    base = np.asarray(step(x0, th, u0, u0)[0]).ravel()
    Qx = np.zeros((m.nx, m.nx))
    for j in range(m.nu):  # each sample's noise enters the steps before and after it
        e = np.zeros(m.nu)
        e[j] = 1.0
        for a, b in ((e, u0), (u0, e)):
            g = (np.asarray(step(x0, th, a, b)[0]).ravel() - base) / filt.state_scale
            Qx += su ** 2 * np.outer(g, g)
    Q = np.zeros((filt.size, filt.size))
    Q[:m.nx, :m.nx] = tuning.q_x * Qx
    Q[m.nx:, m.nx:] = tuning.q_theta * np.eye(filt.size - m.nx)
    return Q, np.eye(m.ny) * sy ** 2


def run_passes(setup: Setup, filt: UKF, data: Data, tuning: Tuning, *, passes: int = 3, inflate: float = 16.0,
               fix_flagged: bool = True) -> tuple[tuple[Trajectory, ...], tuple[str, ...]]:
    """Run ``filt`` ``passes`` times over the record (protocol in the module docstring).

    Returns the trajectories (fewer than ``passes`` when an estimate could not be simulated, which
    ends the run) and the parameters held at their guess after the first pass.
    """
    Q, R = _noise(setup, filt, data, tuning)
    f = filt.with_options(Q=Q, R=R, gate=tuning.gate)
    nx = setup.model.nx
    theta, Pth = setup.theta_guess, np.full(filt.size - nx, tuning.s0 ** 2)
    Px = np.full(nx, 1e-8)  # the record starts at rest
    out: list[Trajectory] = []
    fixed: tuple[str, ...] = ()
    for k in range(passes):
        bad = [p for p, v in zip(filt.names[nx:], Pth) if not (np.isfinite(v) and v > 0)]
        if bad and k == 0:
            raise EstimatorError(f"the prior std s0 must be a positive number, got {tuning.s0!r}")
        if bad:  # the previous pass ended with a collapsed parameter covariance: no prior for this one
            raise EstimatorError(f"pass {k} ended with a non-positive or non-finite variance of {bad}: the filter's "
                                 f"covariance collapsed; lower the random walk q_theta or run fewer passes")
        est = f.initial(x0=setup.x0, theta0=theta, P0=np.concatenate([Px, Pth]))
        tr = f.run(est, data.y, data.u)
        out.append(tr)
        theta, Pth = tr.theta[-1].copy(), inflate * np.diag(tr.P[-1])[nx:]
        if k == passes - 1:
            break
        misfit = output_misfit(setup, theta, data)
        if not np.isfinite(misfit):  # no later pass can start from an estimate that cannot be simulated
            break
        if k == 0 and fix_flagged:
            prac = practical_identifiability(setup, theta, data, first=tr, prior_std=tuning.s0, misfit=misfit)
            fixed = prac.flagged  # empty when the pass diverged (inconclusive)
            f = f.with_options(fixed=fixed)
            for p in fixed:  # poorly informed: back to the prior guess, not estimated any more
                theta[setup.model.parameters.index(p)] = setup.guess[p]
            Pth = np.where(f.allowed[nx:] > 0, Pth, tuning.s0 ** 2)
    return tuple(out), fixed


def output_misfit(setup: Setup, theta: np.ndarray, data: Data) -> float:
    """RMS of (simulated - measured output) / RMS(measured output); simulation under the measured input."""
    try:
        sim = simulate(setup.model, theta=theta, x0=setup.x0, u=data.u, dt=setup.record.dt, substeps=setup.substeps,
                       refine=setup.refine, jit=setup.jit)
    except EstimatorError:
        return float("inf")
    return rms(sim.y - data.y) / rms(data.y)


@dataclass(frozen=True)
class Practical:
    """Practical identifiability of the parameters on one record, at one estimate.

    ``crb``: Cramér-Rao standard deviation of ``log|theta_i|`` (relative error), from the Fisher
    information of the output sensitivities (central differences of the simulated output in
    ``log|theta|``) and the output noise; ``sensitivity``: RMS of ``d y / d log|theta_i|`` over the
    noise std; ``posterior``: the filter's final std over its prior std (first pass). A parameter is
    flagged when ``crb > CRB_LIMIT`` or ``posterior > POSTERIOR_LIMIT``, and, once a Monte-Carlo spread
    is joined (:meth:`with_spread`), when the estimator's own spread exceeds the same limit (the
    linearised bound misses the spread along ridges of a non-smooth response). ``inconclusive`` (non-empty)
    says why nothing could be decided (the estimate diverged or cannot be simulated); then nothing
    is flagged and the numbers are NaN.
    """

    parameters: tuple[str, ...]
    crb: tuple[float, ...]
    sensitivity: tuple[float, ...]
    posterior: tuple[float, ...]
    flagged: tuple[str, ...]
    reasons: Mapping[str, str]
    inconclusive: str = ""
    spread: Spread | None = None
    undecided: Mapping[str, str] = field(default_factory=dict)
    linearised: tuple[str, ...] | None = None  # the flags before the Monte-Carlo criterion was joined

    @property
    def flagged_linearised(self) -> tuple[str, ...]:
        """The parameters flagged by the Cramér-Rao and posterior criteria alone."""
        return self.flagged if self.linearised is None else self.linearised

    def to_dict(self) -> dict[str, Any]:
        return {"parameters": list(self.parameters), "crb_relative_std": _nums(self.crb),
                "sensitivity_over_noise": _nums(self.sensitivity), "posterior_over_prior_std": _nums(self.posterior),
                "flagged": list(self.flagged), "flagged_linearised": list(self.flagged_linearised),
                "reasons": dict(self.reasons),
                "inconclusive": self.inconclusive or None, "undecided": dict(self.undecided),
                "monte_carlo": self.spread.to_dict() if self.spread else None}

    def with_spread(self, spread: Spread, *, limit: float = CRB_LIMIT) -> Practical:
        """These flags joined with the Monte-Carlo criterion (:class:`Spread`) at the same limit.

        A parameter is flagged when the lower confidence bound of its Monte-Carlo spread exceeds
        ``limit``; when the interval contains ``limit`` it is *undecided* for that criterion (named,
        not flagged). Parameters the protocol held at their guess have no spread and keep their flag.
        """
        if self.inconclusive:
            return replace(self, spread=spread)
        if spread.inconclusive:  # the other criteria stand; the 5 % band of the rest is not decided
            return replace(self, spread=spread, undecided={
                p: f"no Monte-Carlo spread: {spread.inconclusive}" for p in self.parameters if p not in self.reasons})
        reasons, undecided = dict(self.reasons), {}
        for p, sd, lo, hi in zip(self.parameters, spread.std, spread.lower, spread.upper):
            if p in spread.held:
                continue
            band = (f"Monte-Carlo std of the relative error {100 * sd:.2g} % ({100 * spread.confidence:g} % "
                    f"interval {100 * lo:.2g}-{100 * hi:.2g} %, {spread.replicates} replicates)")
            if lo > limit:
                reasons[p] = "; ".join(filter(None, [reasons.get(p), f"{band} > {100 * limit:.2g} %"]))
            elif hi > limit and p not in reasons:
                undecided[p] = f"{band} contains {100 * limit:.2g} %"
        return replace(self, spread=spread, reasons=reasons, undecided=undecided, linearised=self.flagged_linearised,
                       flagged=tuple(p for p in self.parameters if p in reasons))


def _nums(v: Sequence[float]) -> list[float | None]:
    """Finite numbers, None for NaN/inf (JSON has no NaN)."""
    return [float(x) if np.isfinite(x) else None for x in v]


@dataclass(frozen=True)
class Spread:
    """Monte-Carlo spread of an estimator at an estimate (a parametric bootstrap).

    ``std``: sample standard deviation of ``log|theta_i|`` (the relative error) over the replicates
    that did not diverge; ``lower``/``upper``: its ``confidence`` interval (chi-square with
    ``replicates - 1`` degrees of freedom, Gaussian estimates assumed); ``held``: parameters the
    protocol held at their guess in every replicate (no spread). Replicate ``b`` draws its noise from
    ``numpy.random.default_rng([seed, b])``. ``inconclusive`` says why no spread could be given.
    """

    parameters: tuple[str, ...]
    std: tuple[float, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    replicates: int
    diverged: int
    confidence: float
    seed: int
    held: tuple[str, ...] = ()
    inconclusive: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"parameters": list(self.parameters), "relative_std": _nums(self.std), "lower": _nums(self.lower),
                "upper": _nums(self.upper), "replicates": self.replicates, "diverged": self.diverged,
                "confidence": self.confidence, "seed": self.seed, "held": list(self.held),
                "inconclusive": self.inconclusive or None}


def monte_carlo(setup: Setup, filt: UKF, theta: np.ndarray, data: Data, tuning: Tuning, *, passes: int,
                replicates: int = 32, seed: int = 0, confidence: float = 0.99,
                progress: Callable[[], None] | None = None) -> Spread:
    """Spread of the whole identification protocol at the estimate ``theta`` (no true value used).

    The linearised Cramér-Rao bound of :func:`practical_identifiability` can be far too optimistic
    where the response is not smooth in a parameter (the seed model's Delta-N ridge: 4x on 20 noise
    seeds, ``reports/identification/notes.md``). This measures the estimator itself, as in the
    Monte-Carlo practical-identifiability analysis of Miao, Xia, Perelson and Wu (SIAM Review 53,
    2011): each replicate takes the measured input as the true one, simulates the output at
    ``theta``, adds fresh input and output noise at the experiment's levels and runs
    :func:`run_passes` with the same filter, tuning and ``passes``.

    Parameters
    ----------
    setup, filt, tuning, passes
        The experiment, the filter, its configuration and the number of passes (as in the reported run).
    theta
        The estimate (the replicates' truth).
    data
        The measured record (its input is the replicates' input; the noise levels come from it).
    replicates
        Number of replicates. With 32 and ``confidence=0.99`` (chi-square, Gaussian estimates): a
        parameter whose true spread is at the limit is flagged with probability at most 0.005, one at
        twice the limit is flagged with probability 0.997, one at half the limit is cleared (neither
        flagged nor undecided) with probability 0.998; in between it may be named undecided.
    seed
        Noise seed of the replicates.
    confidence
        Level of the two-sided interval of each std; a decision against a limit then errs with
        probability at most ``(1 - confidence) / 2``.
    progress
        Called once per replicate.
    """
    from scipy.stats import chi2

    m = setup.model
    if replicates < 3:
        raise ObsnlError(f"monte_carlo needs at least 3 replicates, got {replicates}")
    if not 0 < confidence < 1:
        raise ObsnlError(f"confidence must lie in (0, 1), got {confidence}")
    nan = (float("nan"),) * m.np
    blank = dict(parameters=m.parameters, std=nan, lower=nan, upper=nan, confidence=confidence, seed=seed)
    try:
        y_hat = simulate(m, theta=theta, x0=setup.x0, u=data.u, dt=setup.record.dt, substeps=setup.substeps,
                         refine=setup.refine, jit=setup.jit).y
    except EstimatorError:
        return Spread(replicates=0, diverged=0, inconclusive="the estimate cannot be simulated", **blank)
    su, sy = setup.noise * rms(data.u), setup.noise * rms(data.y)
    logs, held, diverged = [], set(m.parameters), 0
    for b in range(replicates):
        rng = np.random.default_rng([seed, b])
        rep = Data(seed=seed, u=data.u + su * rng.standard_normal(data.u.shape),
                   y=y_hat + sy * rng.standard_normal(y_hat.shape))
        try:
            trs, fixed = run_passes(setup, filt, rep, tuning, passes=passes)
            est = trs[-1].theta[-1]
            ok = len(trs) == passes and output_misfit(setup, est, rep) <= DIVERGED * setup.noise
        except ObsnlError:
            ok = False
        if ok:
            logs.append(np.log(np.abs(est)))
            held &= set(fixed)
        else:
            diverged += 1
        if progress:
            progress()
    n = len(logs)
    if n < 3 or diverged * 4 > replicates:
        return Spread(replicates=n, diverged=diverged, **blank,
                      inconclusive=f"the estimator diverged on {diverged} of {replicates} replicates")
    std = np.std(np.array(logs), axis=0, ddof=1)
    a = 1.0 - confidence
    lower = std * np.sqrt((n - 1) / chi2.ppf(1 - a / 2, n - 1))
    upper = std * np.sqrt((n - 1) / chi2.ppf(a / 2, n - 1))
    return Spread(parameters=m.parameters, std=tuple(map(float, std)), lower=tuple(map(float, lower)),
                  upper=tuple(map(float, upper)), replicates=n, diverged=diverged, confidence=confidence, seed=seed,
                  held=tuple(p for p in m.parameters if p in held))


def fisher(setup: Setup, theta: np.ndarray, u: np.ndarray, sigma: float, *, step: float = 1e-2) -> np.ndarray:
    """Output sensitivities ``(T*ny, np)`` to ``log|theta|``, divided by the noise std ``sigma``.

    Central differences with a 1 % step: the response of the non-smooth model is rough on finer
    scales (switching instants move), and smaller steps overstate the information several times.
    """
    m, dt = setup.model, setup.record.dt
    cols = []
    for i in range(m.np):
        ys = []
        for s in (step, -step):
            th = np.array(theta, float)
            th[i] *= np.exp(s)
            ys.append(simulate(m, theta=th, x0=setup.x0, u=u, dt=dt, substeps=setup.substeps, refine=setup.refine,
                               jit=setup.jit).y.ravel())
        cols.append((ys[0] - ys[1]) / (2 * step) / sigma)
    return np.array(cols).T


def input_noise_crb(setup: Setup, theta: np.ndarray | None = None, *, u: np.ndarray | None = None) -> dict[str, Any]:
    """Cramér-Rao std of ``log|theta_i|`` with the input noise counted (a diagnostic, not a flag).

    The filters and fits see the *measured* input ``u + w``; to first order the output they should
    reproduce is off by ``-J_u w`` (``J_u = dy/du``, one column per input sample, by central
    differences of the simulation), so the effective output noise has covariance
    ``Sigma = sigma_y^2 I + sigma_u^2 J_u J_u^T`` and the Fisher information is ``S^T Sigma^-1 S``
    (``S = dy/dlog|theta|``). ``crb_output_only`` is the bound with ``sigma_u = 0`` (the one the
    practical-identifiability flag uses). Costs two simulations per input sample (about a minute).
    """
    m, dt = setup.model, setup.record.dt
    theta = setup.theta_true if theta is None else np.asarray(theta, float)
    u = setup.record.accel if u is None else np.asarray(u, float)
    su, sy = setup.noise * rms(u), setup.noise * rms(setup.y_true)
    S = fisher(setup, theta, u, 1.0)  # raw sensitivities dy/dlog|theta|
    sim = lambda uu: simulate(m, theta=theta, x0=setup.x0, u=uu, dt=dt, substeps=setup.substeps,  # noqa: E731
                              refine=setup.refine, jit=setup.jit).y.ravel()
    Ju = np.zeros((len(S), len(u)))
    for k in range(len(u)):
        e = np.zeros_like(u)
        e[k] = su
        Ju[:, k] = (sim(u + e) - sim(u - e)) / (2 * su)
    out = {}
    for name, cov in (("crb_output_only", sy ** 2 * np.eye(len(S))), ("crb_with_input_noise",
                                                                       sy ** 2 * np.eye(len(S)) + su ** 2 * Ju @ Ju.T)):
        F = S.T @ np.linalg.solve(cov, S)
        out[name] = dict(zip(m.parameters, np.sqrt(np.clip(np.diag(np.linalg.pinv(F, rcond=1e-12)), 0, None))))
    out["input_noise_output_rms_over_sigma_y"] = float(su * np.sqrt(np.trace(Ju @ Ju.T) / len(S)) / sy)
    return out


def practical_identifiability(setup: Setup, theta: np.ndarray, data: Data, *, first: Trajectory,
                              prior_std: float, misfit: float | None = None) -> Practical:
    """Flag the parameters this record cannot pin down (see :class:`Practical`).

    Parameters
    ----------
    setup, data
        The experiment and the measured record.
    theta
        The estimate at which the output sensitivities are taken.
    first
        The first pass of the filter (its final covariance against ``prior_std``).
    prior_std
        The filter's prior std of the log-parameters.
    misfit
        The free-run output misfit of ``theta`` if already computed (else computed here). Above
        ``DIVERGED`` x the noise level, or when ``theta`` cannot be simulated, the result is
        inconclusive: sensitivities of a diverged estimate say nothing about these data.
    """
    m = setup.model
    misfit = output_misfit(setup, theta, data) if misfit is None else float(misfit)
    why_not = ""
    if not np.isfinite(misfit):
        why_not = "the estimate cannot be simulated (the filter diverged)"
    elif misfit > DIVERGED * setup.noise:
        why_not = (f"the estimate's output misfit {misfit:.3g} is above {DIVERGED:g}x the noise level "
                   f"{setup.noise:g} (the filter did not converge on these data)")
    if not why_not:
        try:
            S = fisher(setup, theta, data.u, setup.noise * rms(data.y))
        except EstimatorError:
            why_not = "a perturbed estimate cannot be simulated (no sensitivities)"
    if why_not:
        nan = (float("nan"),) * m.np
        return Practical(parameters=m.parameters, crb=nan, sensitivity=nan, posterior=nan, flagged=(), reasons={},
                         inconclusive=why_not)
    F = S.T @ S
    crb = np.sqrt(np.clip(np.diag(np.linalg.pinv(F, rcond=1e-12)), 0, None))
    sens = np.sqrt(np.mean(S ** 2, axis=0))
    nx = m.nx
    post = np.sqrt(np.clip(np.diag(first.P[-1])[nx:], 0, None)) / prior_std
    # posterior ratios are per filter coordinate; with log coordinates they are per parameter
    post = post if len(post) == m.np else np.full(m.np, np.nan)
    reasons = {}
    for p, c, r in zip(m.parameters, crb, post):
        why = []
        if c > CRB_LIMIT:
            why.append(f"Cramér-Rao std of the relative error {100 * c:.2g} % > {100 * CRB_LIMIT:.2g} %")
        if r > POSTERIOR_LIMIT:
            why.append(f"the filter kept {100 * r:.0f} % of its prior std")
        if why:
            reasons[p] = "; ".join(why)
    return Practical(parameters=m.parameters, crb=tuple(float(c) for c in crb),
                     sensitivity=tuple(float(s) for s in sens), posterior=tuple(float(r) for r in post),
                     flagged=tuple(p for p in m.parameters if p in reasons), reasons=reasons)


def tune(setup: Setup, filt: UKF, seeds: Sequence[int], *, grid: Sequence[Tuning] = DEFAULT_GRID,
         passes: int = 3, progress: Callable[[], None] | None = None) -> dict[int, dict[Tuning, float]]:
    """Mean output misfit of every configuration on ``seeds``, after 1 pass and after ``passes``."""
    scores: dict[int, dict[Tuning, list[float]]] = {1: {}, passes: {}}
    datas = [make_data(setup, s) for s in seeds]
    for t in grid:
        for d in datas:
            try:
                trs, _ = run_passes(setup, filt, d, t, passes=passes)
                got = {1: output_misfit(setup, trs[0].theta[-1], d), passes: output_misfit(setup, trs[-1].theta[-1], d)}
            except ObsnlError:
                got = {1: float("inf"), passes: float("inf")}
            for k, v in got.items():
                scores[k].setdefault(t, []).append(v)
            if progress:
                progress()
    return {k: {t: float(np.mean(v)) for t, v in s.items()} for k, s in scores.items()}

