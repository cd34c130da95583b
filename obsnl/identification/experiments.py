"""Identification experiments: set-up, tuning without the true values, practical identifiability.

The seed experiment (``000_d24855f97fc8bdd4.txt`` §5, Table 2): the damage-healing oscillator in its
identifiable coordinates (``models/damage_healing_reparam.toml``) under the 1994 Northridge record,
true values and initial guesses of Table 2, Gaussian noise of 0.1 % noise-to-signal RMS on input and
output. :func:`obsnl.studies.seed_paper.reproduce` runs the whole pipeline (analysis -> branch table -> UKF
and DUKF).

Protocol, the same for the UKF and the DUKF:

* Log-parameters are kept within a factor 100 of the guesses (``BOUND``; a mean leaving it is put back on its
  edge and counted as a repair).
* ``R`` = (noise ratio x RMS of the measured output)², the states' process noise from the input noise (``sigma_u``
  = ratio x RMS of the measured input, mapped through the discrete step) scaled by ``q_x``; parameter
  coordinates ``log|theta|`` with prior std ``s0`` and random walk ``q_theta``.
* ``passes`` runs over the record; pass ``k+1`` starts at rest from the estimate of pass ``k`` with the
  parameter covariance ``inflate x diag(P_final)`` (the record is reused: later passes refine the
  estimate, their covariance is optimistic). With ``fix_flagged`` (the seed paper's protocol; ``obsnl.identify``
  only with ``hold=True``) the parameters found practically unidentifiable after the first pass
  (:func:`practical_identifiability`) are put back to their guess and held fixed. A first pass that diverged (free-run output misfit above ``DIVERGED`` x the noise level) flags nothing: its sensitivities
  are those of a wrong model. An estimate that cannot be simulated at all ends the run.
* Robust step (:mod:`obsnl.estimation.ukf_step`): every update that is not finite or clearly indefinite is
  rejected (the prediction is kept), standard deviations are capped at ``STATE_CAP`` typical magnitudes
  (states) and ``BOUND`` (log-parameters), and the innovation gate ``gate`` (a tuning choice, off or 3)
  scales the gain down beyond that Mahalanobis distance; every intervention is counted per kind.
* Tuning: every configuration of the grid (``DEFAULT_GRID``: ``s0``, ``q_theta``, ``q_x``, ``gate``) runs on noise
  seeds that are not reported (five by default); the smallest mean free-run output misfit (the estimate simulated
  under the measured input, against the measured output) wins, a failed run counting as infinite. No truth used.
* Practical identifiability (:func:`practical_identifiability`, :func:`monte_carlo`): a parameter is
  flagged when these data cannot pin it within the 5 % band at 3 sigma: by the linearised Cramér-Rao
  bound, by the filter's posterior against its prior, or by the Monte-Carlo spread of the whole
  protocol at the estimate (a parametric bootstrap; it sees the ridges of a non-smooth response that
  the linearised bound misses). Parameters flagged after the first pass by the first two criteria
  are held at their guess; the Monte-Carlo flag only marks an estimate as poorly informed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from obsnl.errors import CompileError, EstimatorError, ObsnlError, OptionError
from obsnl.estimation.simulate import simulate
from obsnl.estimation.ukf import UKF, Trajectory
from obsnl.identification.practical import Practical, Spread, practical_identifiability
from obsnl.identification.setup import (
    BOUND,
    DEFAULT_GRID,
    DIVERGED,
    STATE_CAP,
    Data,
    Setup,
    Tuning,
    coordinates,
    make_data,
    make_filter,
    output_misfit,
)

__all__ = [
    "Tuning",
    "DEFAULT_GRID",
    "Setup",
    "Data",
    "Practical",
    "coordinates",
    "make_data",
    "make_filter",
    "run_passes",
    "output_misfit",
    "practical_identifiability",
    "DIVERGED",
    "BOUND",
    "STATE_CAP",
    "Spread",
    "monte_carlo",
    "mc_truth",
    "mc_replicates",
    "mc_spread",
    "tune_one",
]


def _noise(setup: Setup, filt: UKF, data: Data, tuning: Tuning) -> tuple[np.ndarray, np.ndarray]:
    m, dt = setup.model, setup.record.dt
    su, sy = setup.noise_std(data)
    step = m.step(dt, method="rk4", substeps=setup.substeps)
    x0, th, u0 = setup.x0, setup.theta_guess, np.zeros(m.nu)
    base = np.asarray(step(x0, th, u0, u0)[0]).ravel()
    Qx = np.zeros((m.nx, m.nx))
    for j in range(len(m.inputs)):  # each sample's noise enters the steps before and after it
        e = np.zeros(m.nu)
        e[j :: len(m.inputs)] = 1.0  # a driven model: the sample's whole block (held), which the step reads alone
        for a, b in ((e, u0), (u0, e)):
            g = (np.asarray(step(x0, th, a, b)[0]).ravel() - base) / filt.state_scale
            with np.errstate(over="ignore", invalid="ignore"):  # overflow: refused below
                Qx += su[j] ** 2 * np.outer(g, g)
    if not np.all(np.isfinite(Qx)):  # a guess many orders off: the step overflows (it ended in 'Q contains NaN/inf')
        raise EstimatorError(
            f"the step of {m.name!r} overflows at the guess: give guesses nearer the structure's values"
        )
    Q = np.zeros((filt.size, filt.size))
    Q[: m.nx, : m.nx] = tuning.q_x * Qx
    Q[m.nx :, m.nx :] = tuning.q_theta * np.eye(filt.size - m.nx)
    return Q, np.diag(np.maximum(sy, 1e-300) ** 2)


def run_passes(
    setup: Setup,
    filt: UKF,
    data: Data,
    tuning: Tuning,
    *,
    passes: int = 3,
    inflate: float = 16.0,
    fix_flagged: bool = True,
    progress: Callable[[], None] | None = None,
    hold_below: float | None = None,
) -> tuple[tuple[Trajectory, ...], tuple[str, ...]]:
    """Run ``filt`` ``passes`` times over the record (protocol in the module docstring).

    Returns the trajectories (fewer than ``passes`` when an estimate could not be simulated, which
    ends the run) and the parameters held at their guess after the first pass. ``progress`` is
    called after each pass. ``hold_below``: hold the flagged parameters only after the first pass
    whose output misfit is at most this many times the noise level (the filter has reached the noise
    floor; before that, a parameter's information is judged at a wrong model), instead of after
    the first pass whenever it did not diverge.

    Parameters
    ----------
    setup : Setup
        The experiment.
    filt : UKF
        The filter (noise covariances set here).
    data : Data
        Measured input and output.
    tuning : Tuning
        Filter configuration.
    passes : int
        Number of passes.
    inflate : float
        Factor on the parameter variances carried into the next pass.
    fix_flagged : bool
        Hold poorly informed parameters at their guess after the first pass.
    progress : callable or None
        Called after each pass.
    hold_below : float or None
        See above.

    Returns
    -------
    tuple
        ``(trajectories, held parameter names)``.

    Raises
    ------
    EstimatorError
        A non-positive prior std, or a collapsed parameter covariance.
    """
    trs, fixed, _ = _run_passes(
        setup,
        filt,
        data,
        tuning,
        passes=passes,
        inflate=inflate,
        fix_flagged=fix_flagged,
        progress=progress,
        hold_below=hold_below,
    )
    return trs, fixed


def _run_passes(
    setup: Setup,
    filt: UKF,
    data: Data,
    tuning: Tuning,
    *,
    passes: int,
    inflate: float = 16.0,
    fix_flagged: bool = True,
    progress: Callable[[], None] | None = None,
    hold_below: float | None = None,
) -> tuple[tuple[Trajectory, ...], tuple[str, ...], dict[int, float]]:
    """:func:`run_passes`, also returning the output misfits it computed on the way (``{pass index: misfit}``)."""
    Q, R = _noise(setup, filt, data, tuning)
    f = filt.with_options(Q=Q, R=R, gate=tuning.gate)
    nx = setup.model.nx
    theta, Pth = setup.theta_guess, np.full(filt.size - nx, tuning.s0**2)
    Px = np.full(nx, 1e-8)  # the record starts at rest
    out: list[Trajectory] = []
    fixed: tuple[str, ...] = ()
    misfits: dict[int, float] = {}
    held_once = False
    for k in range(passes):
        bad = [p for p, v in zip(filt.names[nx:], Pth) if not (np.isfinite(v) and v > 0)]
        if bad and k == 0:
            raise EstimatorError(f"the prior std s0 must be a positive number, got {tuning.s0!r}")
        if bad and not misfits.get(k - 1, np.inf) <= DIVERGED * setup.noise_level:  # a diverged pass, no prior
            raise EstimatorError(
                f"pass {k} diverged (output misfit {misfits.get(k - 1, np.inf):.3g} against a noise "
                f"level of {setup.noise_level:.3g}) and left no usable covariance: lower the prior "
                f"std s0 (s0=0.1), gate the innovations (gate=3) or start closer (guess=)"
            )
        if bad:  # the previous pass ended with a collapsed parameter covariance: no prior for this one
            raise EstimatorError(
                f"pass {k} ended with a non-positive or non-finite variance of {bad}: the filter's "
                f"covariance collapsed; lower the random walk q_theta or run fewer passes"
            )
        est = f.initial(x0=setup.x0, theta0=theta, P0=np.concatenate([Px, Pth]))
        tr = f.run(est, data.y, data.u)
        out.append(tr)
        if progress:
            progress()
        theta, Pth = tr.theta[-1].copy(), inflate * np.diag(tr.P[-1])[nx:]
        if k == passes - 1:
            break
        misfit = misfits[k] = output_misfit(setup, theta, data)
        if not np.isfinite(misfit):  # no later pass can start from an estimate that cannot be simulated
            break
        ready = k == 0 if hold_below is None else (not held_once and misfit <= hold_below * setup.noise_level)
        if ready and fix_flagged:
            held_once = True
            prac = practical_identifiability(setup, theta, data, first=tr, prior_std=tuning.s0, misfit=misfit)
            fixed = prac.flagged  # empty when the pass diverged (inconclusive)
            f = f.with_options(fixed=fixed)
            for p in fixed:  # poorly informed: back to the prior guess, not estimated any more
                theta[setup.model.parameters.index(p)] = setup.guess[p]
            Pth = np.where(f.allowed[nx:] > 0, Pth, tuning.s0**2)
    return tuple(out), fixed, misfits


def monte_carlo(
    setup: Setup,
    filt: UKF,
    theta: np.ndarray,
    data: Data,
    tuning: Tuning,
    *,
    passes: int,
    replicates: int = 32,
    seed: int = 0,
    confidence: float = 0.99,
    progress: Callable[[], None] | None = None,
    fix_flagged: bool = True,
    hold_below: float | None = None,
) -> Spread:
    """Spread of the whole identification protocol at the estimate ``theta`` (no true value used).

    The linearised Cramér-Rao bound of :func:`practical_identifiability` can be far too optimistic where the
    response is not smooth in a parameter (the seed model's Delta-N ridge: 4x on 20 noise seeds,
    ``reports/identification/notes.md``). This measures the estimator itself, as in the Monte-Carlo analysis of
    Miao, Xia, Perelson and Wu (SIAM Review 53(1), 2011, doi:10.1137/090757009): each replicate takes the
    measured input as the true one, simulates the output at ``theta``, adds fresh input and output noise at the
    experiment's levels and runs :func:`run_passes` with the same filter, tuning, ``passes``, ``fix_flagged`` and
    ``hold_below`` (the reported run's: a replicate holds a parameter only where the reported run would).

    Parameters
    ----------
    setup : Setup
    filt : UKF
    tuning : Tuning
    passes : int
        The experiment, the filter, its configuration and the number of passes (as in the reported run).
    theta : ndarray
        The estimate (the replicates' truth).
    data : Data
        The measured record (its input is the replicates' input; the noise levels come from it).
    replicates : int
        Number of replicates. With 32 and ``confidence=0.99`` (chi-square, Gaussian estimates): a parameter whose
        true spread is at the limit is flagged with probability at most 0.005, one at twice the limit is flagged with
        probability 0.997, one at half the limit is cleared (neither flagged nor undecided) with probability 0.998; in
        between it may be named undecided.
    seed : int
        Noise seed of the replicates.
    confidence : float
        Level of the two-sided interval of each std; a decision against a limit then errs with probability at most
        ``(1 - confidence) / 2``.
    progress : callable or None
        Called once per replicate.
    """
    if replicates < 3:
        raise OptionError(f"monte_carlo needs at least 3 replicates, got {replicates}")
    if not 0 < confidence < 1:
        raise OptionError(f"confidence must lie in (0, 1), got {confidence}")
    y_hat = mc_truth(setup, theta, data)
    outcomes = (
        []
        if y_hat is None
        else mc_replicates(
            setup,
            filt,
            data,
            y_hat,
            tuning,
            passes=passes,
            seed=seed,
            indices=range(replicates),
            progress=progress,
            fix_flagged=fix_flagged,
            hold_below=hold_below,
        )
    )
    return mc_spread(
        setup, outcomes, replicates=replicates, seed=seed, confidence=confidence, simulated=y_hat is not None
    )


def mc_truth(setup: Setup, theta: np.ndarray, data: Data) -> np.ndarray | None:
    """The replicates' noise-free output: the model at ``theta`` under the measured input (None: it cannot be simulated).

    Parameters
    ----------
    setup : Setup
        The experiment.
    theta : numpy.ndarray
        Parameter values.
    data : Data
        Measured input and output (the input is used).

    Returns
    -------
    numpy.ndarray or None
    """
    try:
        return simulate(
            setup.model,
            theta=theta,
            x0=setup.x0,
            u=data.u,
            dt=setup.record.dt,
            substeps=setup.substeps,
            refine=setup.refine,
            jit=setup.jit,
        ).y
    except EstimatorError:
        return None


def mc_replicates(
    setup: Setup,
    filt: UKF,
    data: Data,
    y_hat: np.ndarray,
    tuning: Tuning,
    *,
    passes: int,
    seed: int,
    indices: Sequence[int],
    progress: Callable[[], None] | None = None,
    fix_flagged: bool = True,
    hold_below: float | None = None,
) -> list[tuple]:
    """Replicates ``indices`` of :func:`monte_carlo` (replicate ``b`` draws its noise from ``[seed, b]``, so
    any split of the indices over workers gives the same outcomes): ``(log|estimate| or None, held)``.

    Parameters
    ----------
    setup : Setup
        The experiment.
    filt : UKF
        The filter.
    data : Data
        Measured input and output (the input is perturbed).
    y_hat : numpy.ndarray
        Noise-free output of the replicates (:func:`mc_truth`).
    tuning : Tuning
        Filter configuration.
    passes : int
        Passes per replicate.
    seed : int
        Root seed of the replicates.
    indices : sequence of int
        The replicates to run.
    progress : callable or None
        Called after each replicate.
    fix_flagged : bool
        As in :func:`run_passes` (the reported run's setting).
    hold_below : float or None
        As in :func:`run_passes` (the reported run's setting).

    Returns
    -------
    list of tuple
        Per replicate ``(log|estimate| or None when it diverged, held parameters)``.
    """
    su, sy = setup.noise_std(data)
    out = []
    for b in indices:
        rng = np.random.default_rng([seed, b])
        rep = Data(
            seed=seed,
            u=data.u + su * rng.standard_normal(data.u.shape),
            y=np.where(np.isnan(data.y), np.nan, y_hat + sy * rng.standard_normal(y_hat.shape)),
        )  # its gaps
        try:
            trs, fixed = run_passes(
                setup, filt, rep, tuning, passes=passes, fix_flagged=fix_flagged, hold_below=hold_below
            )
            est = trs[-1].theta[-1]
            ok = len(trs) == passes and output_misfit(setup, est, rep) <= DIVERGED * setup.noise_level
        except CompileError:  # the compiler's failure, not this replicate's
            raise
        except ObsnlError:
            ok = False
        out.append((np.log(np.abs(est)), tuple(fixed)) if ok else (None, ()))
        if progress:
            progress()
    return out


def mc_spread(
    setup: Setup,
    outcomes: Sequence[tuple],
    *,
    replicates: int,
    seed: int,
    confidence: float = 0.99,
    simulated: bool = True,
) -> Spread:
    """The :class:`Spread` of the replicates' outcomes (in replicate order) from :func:`mc_replicates`.

    Parameters
    ----------
    setup : Setup
        The experiment.
    outcomes : sequence of tuple
        The replicates' outcomes.
    replicates : int
        Number of replicates asked for.
    seed : int
        Root seed, recorded.
    confidence : float
        Level of the chi-square interval of the std.
    simulated : bool
        False when the estimate could not be simulated (inconclusive).

    Returns
    -------
    Spread
    """
    from scipy.stats import chi2

    m = setup.model
    nan = (float("nan"),) * m.np
    blank = Spread(
        parameters=m.parameters,
        std=nan,
        lower=nan,
        upper=nan,
        replicates=0,
        diverged=0,
        confidence=confidence,
        seed=seed,
    )
    if not simulated:
        return replace(blank, inconclusive="the estimate cannot be simulated")
    logs = [lg for lg, _ in outcomes if lg is not None]
    held = set(m.parameters)
    for lg, fixed in outcomes:
        if lg is not None:
            held &= set(fixed)
    n, diverged = len(logs), len(outcomes) - len(logs)
    if n < 3 or diverged * 4 > replicates:
        return replace(
            blank,
            replicates=n,
            diverged=diverged,
            inconclusive=f"the estimator diverged on {diverged} of {replicates} replicates",
        )
    std = np.std(np.array(logs), axis=0, ddof=1)
    a = 1.0 - confidence
    lower = std * np.sqrt((n - 1) / chi2.ppf(1 - a / 2, n - 1))
    upper = std * np.sqrt((n - 1) / chi2.ppf(a / 2, n - 1))
    return Spread(
        parameters=m.parameters,
        std=tuple(map(float, std)),
        lower=tuple(map(float, lower)),
        upper=tuple(map(float, upper)),
        replicates=n,
        diverged=diverged,
        confidence=confidence,
        seed=seed,
        held=tuple(p for p in m.parameters if p in held),
    )


def tune_one(setup: Setup, filt: UKF, data: Data, tuning: Tuning, *, passes: int) -> dict[int, float]:
    """Output misfit of one configuration on one record after 1 pass and after ``passes`` (inf: it failed).

    Parameters
    ----------
    setup : Setup
        The experiment.
    filt : UKF
        The filter.
    data : Data
        Measured input and output.
    tuning : Tuning
        The configuration.
    passes : int
        Number of passes.

    Returns
    -------
    dict of int to float
    """
    try:
        trs, _, seen = _run_passes(setup, filt, data, tuning, passes=passes)
        first = seen[0] if 0 in seen else output_misfit(setup, trs[0].theta[-1], data)
        return {1: first, passes: output_misfit(setup, trs[-1].theta[-1], data)}
    except CompileError:  # the compiler's failure, not this tuning's
        raise
    except ObsnlError:
        return {1: float("inf"), passes: float("inf")}
