"""The set-up of an identification experiment: the compiled model, the record, the noise, the filter,
its tuning and the coordinates in which parameters are estimated; the free-run output misfit that
judges a run without any true value. The protocol that uses them is in
:mod:`obsnl.identification.experiments`."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from obsnl.errors import DataError, EstimatorError, OptionError
from obsnl.estimation.accelerogram import Record
from obsnl.estimation.codegen import NumericModel, ParameterMap, parameter_map
from obsnl.estimation.dukf import DUKF
from obsnl.estimation.records import add_noise
from obsnl.estimation.simulate import simulate
from obsnl.estimation.ukf import UKF

__all__ = [
    "Tuning",
    "DEFAULT_GRID",
    "Setup",
    "Data",
    "coordinates",
    "make_data",
    "make_filter",
    "output_misfit",
    "free_start",
    "BOUND",
    "DIVERGED",
    "STATE_CAP",
    "OBJECTIVES",
]

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
#: What the maximum-likelihood fit minimises: ``"output"``, the output error of the model simulated from its
#: initial state (the right likelihood when the outputs' noise is the only disturbance); ``"prediction"``, the
#: prediction error of a constant-gain predictor whose gain is fitted with the parameters (the innovations form:
#: the plant may drift under unmeasured disturbances, or run in closed loop).
OBJECTIVES = ("output", "prediction")
#: The smallest noise-to-signal RMS ratio a channel may be given: below it double precision cannot resolve the noise
#: (its weight ``1 / sigma^2`` overflows the filter and the fit); for noise-free data give the integrator's accuracy.
MIN_NOISE = 1e-12


@dataclass(frozen=True)
class Tuning:
    """One filter configuration: prior std of log-parameters, their random walk, state-noise factor,
    innovation gate (Mahalanobis distance beyond which the gain is scaled down; inf: off)."""

    s0: float
    q_theta: float
    q_x: float
    gate: float = float("inf")

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Tuning:
        """The configuration :meth:`to_dict` wrote (``gate`` None: off, ``inf``).

        Examples
        --------
        >>> Tuning.from_dict(Tuning(0.1, 0.0, 1.0).to_dict())
        Tuning(s0=0.1, q_theta=0.0, q_x=1.0, gate=inf)
        """
        gate = d.get("gate")
        return cls(float(d["s0"]), float(d["q_theta"]), float(d["q_x"]), float("inf") if gate is None else float(gate))

    def to_dict(self) -> dict[str, float | None]:
        return {
            "s0": self.s0,
            "q_theta": self.q_theta,
            "q_x": self.q_x,
            "gate": self.gate if np.isfinite(self.gate) else None,
        }


#: The tuning grid, the same for the UKF and the DUKF: 48 configurations. The gate is off or at the
#: textbook 3 (Mahalanobis distance of a scalar innovation); decided before any reported seed was run.
DEFAULT_GRID: tuple[Tuning, ...] = tuple(
    Tuning(s, q, x, g)
    for g, s, q, x in itertools.product((float("inf"), 3.0), (0.1, 0.2, 0.3, 0.5), (0.0, 1e-9, 1e-8), (1.0, 100.0))
)


@dataclass(frozen=True, eq=False)
class Setup:
    """An identification experiment: compiled model, record, truth, guesses, noise, filter options.

    ``record`` holds the input samples (``(T,)`` for one input, ``(T, nu)`` for several). ``truth`` is
    ``None`` for measured data: then ``y_true`` must be the measured outputs (nothing is simulated).
    ``noise`` is the noise-to-signal RMS ratio of every channel; ``channel_noise`` overrides it per
    named input or output. ``fit_substeps``: the integrator (RK4 substeps per sample, with the same
    refinement) of the free-run output misfit, the convergence check and the fit; default: the
    filter's own (``substeps``). When set, a simulated truth is made with the fit's step at these substeps
    (crossings located, sliding modes followed), so that the check compares like with like and a converged
    run is never called diverged. ``initial``: the initial state per named state (over the model's ``[values]``,
    else 0): where the filter and the fit start; ``known``: the states whose initial value is known (held by the
    fit, :func:`obsnl.identification.refine.refine`). ``locate``: the filters' step splits a crossing substep at
    the located crossing and follows sliding modes, as the fit's does (off by default; on a mass that sticks, the
    stages of the refined step chatter across ``v = 0`` and bias the filter's estimate). ``objective``: what the
    maximum-likelihood fit minimises (:data:`OBJECTIVES`): the output error of the free simulation, or the
    prediction error of a constant-gain predictor (:mod:`obsnl.identification.likelihood`). ``bounds``: declared
    bounds of parameters, ``{name: (lo, hi)}`` (the model's ``[bounds]``): the fit searches inside them as well as
    within ``BOUND`` of the guesses.
    """

    model: NumericModel
    record: Record
    truth: Mapping[str, float] | None
    guess: Mapping[str, float]
    noise: float = 1e-3
    coordinates: ParameterMap | None = None
    substeps: int = 4
    refine: int = 8
    jit: bool = False
    # None: simulated from the truth in __post_init__, so never None once built (the readers take it as an array)
    y_true: np.ndarray = field(default=None, repr=False)  # type: ignore[arg-type]
    x0: np.ndarray = field(init=False, repr=False)  # the initial state, set in __post_init__ (initial, values, 0)
    channel_noise: Mapping[str, float] | None = None
    fit_substeps: int | None = None
    locate: bool = False
    initial: Mapping[str, float] | None = None
    known: tuple[str, ...] = ()
    objective: str = "output"
    bounds: Mapping[str, tuple[float, float]] | None = None

    def __post_init__(self) -> None:
        m = self.model
        for what, vals in (("truth", self.truth), ("guess", self.guess)):
            if vals is None and what == "truth" and self.y_true is not None:
                continue
            missing = [p for p in m.parameters if p not in (vals or {})]
            if missing:
                raise OptionError(f"{what} lacks values for {missing}")
        unknown = sorted(set(self.channel_noise or {}) - set(m.inputs) - set(m.outputs))
        if unknown:
            raise OptionError(
                f"noise given for {unknown}, which are not inputs or outputs of {m.name!r} "
                f"({', '.join(m.inputs + m.outputs)})"
            )
        if self.objective not in OBJECTIVES:
            raise OptionError(f"unknown objective {self.objective!r}; use one of {', '.join(OBJECTIVES)}")
        if self.coordinates is None:
            object.__setattr__(self, "coordinates", coordinates(m, "log", reference=self.guess))
        unknown = sorted(set(self.initial or {}).union(self.known) - set(m.states))
        if unknown:
            raise OptionError(
                f"initial values given for {unknown}, which are not states of {m.name!r} ({', '.join(m.states)})"
            )
        start = {**m.values, **(self.initial or {})}
        x0 = np.array([float(start.get(s, 0.0)) for s in m.states])
        object.__setattr__(self, "x0", x0)
        if self.y_true is None:
            # the fit's own step (located crossings, sliding modes) at the fit's substeps: the most exact flow
            fine = (
                {}
                if self.fit_substeps is None
                else {"substeps": self.fit_substeps, "refine": self.refine, "locate": True}
            )
            sim = simulate(m, theta=self.theta_true, x0=x0, u=self.record.accel, dt=self.record.dt, **fine)
            object.__setattr__(self, "y_true", sim.y)

    @property
    def coordinate_map(self) -> ParameterMap:
        """The parameter coordinates: those given, else log coordinates about the guesses (set once built)."""
        assert self.coordinates is not None  # __post_init__ sets the log coordinates where none were given
        return self.coordinates

    @property
    def theta_true(self) -> np.ndarray:
        if self.truth is None:
            raise OptionError("measured data have no true values")
        return np.array([float(self.truth[p]) for p in self.model.parameters])

    @property
    def theta_guess(self) -> np.ndarray:
        return np.array([float(self.guess[p]) for p in self.model.parameters])

    def ratios(self, names: tuple[str, ...]) -> np.ndarray:
        """Noise-to-signal RMS ratio of each named channel."""
        given = dict(self.channel_noise or {})
        return np.array([float(given.get(n, self.noise)) for n in names])

    @property
    def noise_level(self) -> float:
        """The output noise-to-signal ratio (RMS over the outputs): the misfit of a perfect model."""
        return float(np.sqrt(np.mean(self.ratios(self.model.outputs) ** 2)))

    def noise_std(self, data: Data) -> tuple[np.ndarray, np.ndarray]:
        """Absolute noise standard deviations ``(sigma_u (nu,), sigma_y (ny,))`` on these data."""
        # RMS over the samples measured (an output's missing samples are NaN)
        col = lambda a: np.sqrt(np.nanmean(np.asarray(a, float).reshape(len(a), -1) ** 2, axis=0))  # noqa: E731
        nu = len(self.model.inputs)  # a driven model's input rows are blocks: their first nu entries are the samples
        return (self.ratios(self.model.inputs) * col(data.u)[:nu], self.ratios(self.model.outputs) * col(data.y))

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model.name,
            "record": self.record.to_dict(),
            "truth": None if self.truth is None else dict(self.truth),
            "guess": dict(self.guess),
            "noise_ratio": self.noise,
            "channel_noise": dict(self.channel_noise or {}),
            "coordinates": self.coordinate_map.to_dict(),
            "substeps": self.substeps,
            "refine": self.refine,
            "locate": self.locate,
            "fit_substeps": self.fit_substeps,
            "integrator": "RK4; a substep in which a switching function across which the field can jump "
            "changes sign redone with refine finer ones; ROS2 (refine x the substeps) where stiff",
        }


def coordinates(model: NumericModel, kind: str = "log", *, reference: Mapping[str, float]) -> ParameterMap:
    """Filter coordinates of the parameters.

    ``"log"``: ``log|theta|`` (the sign taken from ``reference``). ``"yield"``: as ``"log"`` but
    ``Delta1, Delta2`` replaced by the log yield displacements ``log |Delta_i|**(-1/(2N))`` (straightens
    the Delta-N ridge; needs parameters named ``Delta1, Delta2, N``).

    Parameters
    ----------
    model : NumericModel
        The compiled model.
    kind : str
        ``"log"`` or ``"yield"``.
    reference : mapping of str to float
        A value per parameter giving its sign (and checking the map).

    Returns
    -------
    ParameterMap

    Raises
    ------
    OptionError
        For an unknown ``kind``, or ``"yield"`` without a parameter ``N``.
    """
    fwd, inv = {}, {}
    for p in model.parameters:
        sign = "-" if float(reference[p]) < 0 else ""
        if kind == "yield" and p in ("Delta1", "Delta2"):
            if "N" not in model.parameters:
                raise OptionError("yield coordinates need a parameter 'N'")
            fwd[p], inv[f"log_ry_{p}"] = f"{sign}exp(-2*exp(log_N)*log_ry_{p})", f"-log({sign}{p})/(2*N)"
        elif kind in ("log", "yield"):
            fwd[p], inv[f"log_{p}"] = f"{sign}exp(log_{p})", f"log({sign}{p})"
        else:
            raise OptionError(f"unknown coordinates {kind!r}; use 'log' or 'yield'")
    return parameter_map(model.parameters, fwd, inv, check=reference)


@dataclass(frozen=True, eq=False)
class Data:
    """One noisy realisation of the experiment."""

    seed: int | None
    u: np.ndarray
    y: np.ndarray


def make_data(setup: Setup, seed: int) -> Data:
    """Measured input and output: truth plus Gaussian noise (``setup.noise`` x RMS), seeded.

    Parameters
    ----------
    setup : Setup
        The experiment.
    seed : int
        Seed of the noise.

    Returns
    -------
    Data
    """
    rng = np.random.default_rng(seed)
    u = add_noise(setup.record.accel, ratio=setup.noise, seed=rng)
    y = add_noise(setup.y_true, ratio=setup.noise, seed=rng)
    return Data(seed=seed, u=u, y=y)


def make_filter(setup: Setup, kind: str, *, table: Any = None, cross: str = "regression") -> UKF:
    """A UKF (``kind="ukf"``) or DUKF (``"dukf"``) for this experiment (noise set per run).

    The state scaling is measured on the record (the RMS of the states simulated at the guess); like the
    valid region and the ceilings it is a run-time input of the compiled step, so the compiled filter
    depends on the model and the filter only and serves records of any length.

    Parameters
    ----------
    setup : Setup
        The experiment.
    kind : str
        ``"ukf"`` or ``"dukf"``.
    table : BranchTable or None
        The branch table (DUKF only).
    cross : str
        The DUKF cross-covariance rule, ``"regression"`` or ``"zero"``.

    Returns
    -------
    UKF

    Raises
    ------
    OptionError
        For an unknown ``kind``.
    """
    m = setup.model
    try:
        sim = simulate(
            m,
            theta=setup.theta_guess,
            x0=setup.x0,
            u=setup.record.accel,
            dt=setup.record.dt,
            substeps=setup.substeps,
            refine=setup.refine,
        )
    except EstimatorError as exc:  # the filter would start from a model that cannot follow the record
        raise DataError(
            f"{exc} when simulated at the guess under the measured input: give guesses nearer the "
            f"structure's values, or check the input's units"
        ) from None
    with np.errstate(over="ignore", invalid="ignore"):
        typical = np.sqrt(np.mean(sim.x**2, axis=0))  # typical magnitudes at the guess, floored at 1 %
    if not np.all(np.isfinite(typical)):  # no scale either (it ended in 'Q contains NaN/inf')
        g = setup.theta_guess
        far = int(np.argmax([abs(math.log(abs(v))) for v in g]))
        raise DataError(
            f"model {m.name!r} diverges when simulated at the guess under the measured input (state "
            f"{m.states[int(np.flatnonzero(~np.isfinite(typical))[0])]!r} overflows): give guesses nearer "
            f"the structure's values (the most extreme: {m.parameters[far]} = {g[far]:.3g}), or check "
            f"the input's units"
        )
    if not typical.max() > 0:  # no scale to set the filter's noise by (it ended in 'Q contains NaN/inf')
        u = np.asarray(setup.record.accel, float).reshape(len(setup.record.accel), -1)
        still = [c for j, c in enumerate(m.inputs) if not np.any(u[:, j])]
        why = (
            "the model has no input"
            if not m.inputs
            else "every input is 0 throughout"
            if len(still) == len(m.inputs) and len(still) > 1
            else f"input {still[0]!r} is 0 throughout"
            if len(still) == len(m.inputs)
            else f"the inputs move no state (largest |input| {float(np.max(np.abs(u))):.3g})"
        )
        raise DataError(
            f"{why}: model {m.name!r} stays at rest at the guess, so there is nothing to identify "
            f"from; give data with excitation (or initial values that are not at rest)"
        )
    scale = np.maximum(typical, 1e-2 * max(typical.max(), 1e-300))  # of the largest (a state idle at the guess)
    phi0 = setup.coordinate_map.to_phi(setup.theta_guess)  # valid region: within 100x of the guesses
    bounds = (np.r_[np.full(m.nx, -np.inf), phi0 - BOUND], np.r_[np.full(m.nx, np.inf), phi0 + BOUND])
    cap = np.r_[np.full(m.nx, STATE_CAP), np.full(len(phi0), BOUND)]  # ceilings: sanity, not tuning
    opts = dict(
        dt=setup.record.dt,
        coordinates=setup.coordinates,
        state_scale=scale,
        R=1.0,
        substeps=setup.substeps,
        refine=setup.refine,
        locate=setup.locate,
        jit=setup.jit,
        bounds=bounds,
        cap=cap,
    )
    if kind == "ukf":
        return UKF(m, **opts)
    if kind == "dukf":
        return DUKF(m, table=table, cross=cross, **opts)
    raise OptionError(f"unknown filter {kind!r}; use 'ukf' or 'dukf'")


def free_start(
    model: NumericModel,
    *,
    theta: np.ndarray,
    x0: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    dt: float,
    known: Sequence[str] = (),
    samples: int = 20,
    substeps: int = 4,
) -> np.ndarray | None:
    """An initial state for a record whose motion the model at rest cannot make (a free decay, a record that starts
    in motion): ``x0`` with the states not ``known`` fitted to the first ``samples`` output samples at ``theta``.

    Gauss-Newton on those samples (three steps, sensitivities by central differences of the simulated outputs):
    where the filter starts (the record read as starting there) and where the fit starts, which estimates the unknown
    initial states with the parameters. ``None`` when the model at ``theta`` moves from ``x0`` already (the record
    need not start in motion), when every state is known, or when no sample moves.

    Parameters
    ----------
    model : NumericModel
        The compiled model.
    theta, x0 : numpy.ndarray
        Parameters (the guess) and the initial state given (known values, the model's values, else 0).
    u, y : numpy.ndarray
        The record's input rows and output samples (NaN: missing).
    dt : float
        The sampling step.
    known : sequence of str
        States whose initial value is known (kept).
    samples, substeps : int
        Output samples fitted; RK4 substeps per sample.

    Returns
    -------
    numpy.ndarray or None
    """
    free = [j for j, s in enumerate(model.states) if s not in set(known)]
    n = min(len(y), max(samples, 4 * len(free)))
    yy = np.asarray(y, float).reshape(len(y), -1)[:n]
    uu = np.asarray(u, float)[:n]

    def outputs(x: np.ndarray) -> np.ndarray:
        return simulate(model, theta=theta, x0=x, u=uu, dt=dt, substeps=substeps).y

    try:
        at_rest = not np.any(simulate(model, theta=theta, x0=x0, u=u, dt=dt, substeps=substeps).x - x0)
    except EstimatorError:
        return None
    seen = np.isfinite(yy)
    if not at_rest or not free or not np.any(np.abs(yy[seen] - yy[seen][0]) > 0):
        return None
    x = np.array(x0, float)
    size = max(float(np.max(np.abs(yy[seen]))), 1e-300)
    for _ in range(3):
        try:
            base = outputs(x)
            cols = []
            for j in free:
                h = 1e-6 * max(abs(x[j]), size)
                up, down = x.copy(), x.copy()
                up[j] += h
                down[j] -= h
                cols.append(((outputs(up) - outputs(down)) / (2 * h))[seen])
        except EstimatorError:
            return None
        step = np.linalg.lstsq(np.column_stack(cols), (yy - base)[seen], rcond=None)[0]
        x[free] += step
    return x


def output_misfit(setup: Setup, theta: np.ndarray, data: Data, *, per_output: bool = False) -> Any:
    """Free-run output misfit: the model simulated at ``theta`` under the measured input (integrator:
    ``setup.fit_substeps``, default the filter's), against the measured output.

    Per output ``j``: ``RMS(sim_j - y_j) / RMS(y_j)`` over the samples measured (NaN: missing); returned as the
    RMS over the outputs (one output: that ratio), or the per-output array with ``per_output=True``; ``inf``
    where the model cannot be simulated at ``theta``.

    Parameters
    ----------
    setup : Setup
        The experiment.
    theta : numpy.ndarray
        Parameter values.
    data : Data
        Measured input and output.
    per_output : bool
        Return one ratio per output.

    Returns
    -------
    float or numpy.ndarray
    """
    try:
        sim = simulate(
            setup.model,
            theta=theta,
            x0=setup.x0,
            u=data.u,
            dt=setup.record.dt,
            substeps=setup.fit_substeps or setup.substeps,
            refine=setup.refine,
            jit=setup.jit,
        )
    except EstimatorError:
        out = np.full(setup.model.ny, np.inf)
    else:
        y = np.asarray(data.y, float).reshape(len(sim.y), -1)
        rms = lambda a: np.sqrt(np.nanmean(a**2, axis=0))  # noqa: E731 - over the samples measured
        out = rms(sim.y - y) / np.maximum(rms(y), 1e-300)
    return out if per_output else float(np.sqrt(np.mean(out**2)))
