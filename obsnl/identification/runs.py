"""One identification run, from measured data or from a simulated experiment, as one result value.

:func:`identify_measured` estimates a compiled model's parameters from measured inputs and outputs
(no true value anywhere): noise per channel given or estimated (:func:`obsnl.estimation.measured.estimate_noise`),
the filter tuned by the free-run output misfit over a small grid, several passes
(:func:`obsnl.identification.experiments.run_passes`), practical identifiability at the estimate, the fit of
the model simulated at the estimate. :func:`simulation_study` runs the same protocol on the model's own
simulated response to a record (the model's ``[values]`` are the truth) and adds true values and errors.

Both return an :class:`Identification` (frozen; :meth:`Identification.to_dict` is ``identify.json``).
The structural analysis that comes first is done by the caller (:func:`obsnl.identification.identify.identify`;
the estimators read the analysis only through the branch table).

Reporting rules: a parameter held at its guess after the first pass (poorly informed) is reported as
held, with ``estimate`` and ``std`` ``null``, and counted in ``held``, never as an estimate; a
relative error with a zero truth is given as an absolute error instead; no NaN or inf reaches the JSON.
The convergence check and the fit simulate with ``FIT_SUBSTEPS`` RK4 substeps per sample, and the
truth of a simulation study is made with the same integrator, so that a converged run is never called
diverged by a discretisation mismatch.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace as replace_field
from typing import Any

import numpy as np

from obsnl.errors import CompileError, DataError, EstimatorError, ObsnlError, OptionError
from obsnl.estimation.codegen import NumericModel
from obsnl.estimation.intersample import between_samples, drive, intersample_kinds
from obsnl.estimation.measured import NOISE_FLOOR, UPPER_BOUND, Measured, estimate_noise
from obsnl.estimation.simulate import simulate
from obsnl.estimation.ukf import Trajectory
from obsnl.executor import Executor
from obsnl.identification.adequacy import FLAG_REASON
from obsnl.identification.experiments import Tuning, make_filter, run_passes
from obsnl.identification.practical import practical_identifiability
from obsnl.identification.profile import THRESHOLD, Profile, judge, profiles
from obsnl.identification.refine import Refinement, adequacy_of, refine
from obsnl.identification.replicates import check_passes, check_replicates, spread_on
from obsnl.identification.results import Identification, ParameterEstimate, clean_json, error_of
from obsnl.identification.setup import MIN_NOISE, Data, Setup, coordinates, free_start, output_misfit
from obsnl.identification.summaries import NoiseLevel, RecordSummary, RefinementSummary
from obsnl.observability.contract.branch_table import BranchTable
from obsnl.report.identification.run import between_said

__all__ = [
    "check_replicates",
    "check_unknowns",
    "identify_measured",
    "tune_and_run",
    "assemble_identification",
    "protocol_assumptions",
    "Identification",
    "ParameterEstimate",
    "MEASURED_GRID",
    "FIT_SUBSTEPS",
    "HOLD_BELOW",
    "RANDOM_INPUT",
    "clean_json",
    "error_of",
]

#: Parameters flagged as poorly informed are held at their guess after the first pass whose output misfit is
#: at most this many times the output noise level (the filter has reached the noise floor).
HOLD_BELOW = 2.0
#: An input whose noise, estimated from its differences, is this share of its RMS or more cannot be told from its
#: noise: its samples differ as white noise does (a random excitation, not oversampled). Such an estimate is only an
#: upper bound, and the input is taken as exact (a white-noise force read as 90 % noise widened every std 530x).
RANDOM_INPUT = 0.5
#: RK4 substeps per sample of the convergence check, the fit and the truth of a simulation study.
FIT_SUBSTEPS = 32
#: Tuning grid of measured data (prior std of the log-parameters, state noise factor): 4 configurations,
#: each run for one pass; the smallest free-run output misfit wins (no true value used).
MEASURED_GRID: tuple[Tuning, ...] = (
    Tuning(0.3, 0.0, 1.0),
    Tuning(0.5, 0.0, 1.0),
    Tuning(0.3, 0.0, 100.0),
    Tuning(0.5, 0.0, 100.0),
)


def tune_and_run(
    setup: Setup,
    data: Data,
    *,
    method: str,
    table: BranchTable | None,
    grid: Sequence[Tuning],
    passes: int,
    replicates: int,
    seed: int,
    progress: Callable[[], Any] | None,
    hold: bool = False,
    executor: Executor | None = None,
) -> tuple[Tuning, tuple, tuple[Trajectory, ...], tuple[str, ...], Any, float]:
    """Tune over ``grid`` (one pass each, output misfit), then the protocol with the winner.

    The filter part that :func:`identify_measured` and :func:`obsnl.identification.simulation.simulation_study`
    share: each tuning of the grid runs one pass and the smallest free-run output misfit wins (no true value
    used), the winner runs ``passes`` passes, and the practical identifiability is checked at the estimate (with
    the Monte-Carlo spread of ``replicates`` runs when asked).

    Parameters
    ----------
    setup : Setup
        The experiment: compiled model, record, guess, coordinates.
    data : Data
        The inputs and outputs the filter reads.
    method : str
        The filter, ``"ukf"`` or ``"dukf"`` (the DUKF needs ``table``).
    table : BranchTable or None
        The model's branch table.
    grid : sequence of Tuning
        The tunings to try (one: taken as given, without a tuning pass).
    passes : int
        Passes over the record with the winning tuning.
    replicates : int
        Monte-Carlo replicates of the practical-identifiability check (0: off, else at least 3).
    seed : int
        Noise seed of the replicates.
    progress : callable or None
        Called after every pass (tuning passes included) and once per replicate.
    hold : bool
        Hold the parameters flagged as poorly informed at their guess (after the first pass whose output misfit
        is at most :data:`HOLD_BELOW` times the noise level).
    executor : Executor or None
        Where the replicates run (default: this process).

    Returns
    -------
    tuple
        ``(tuning, scores, trajectories, held, practical, misfit)``: the winning :class:`Tuning`; each tried
        tuning with its output misfit (inf where its pass failed; empty for a grid of one); the filter's
        trajectory of each pass; the names of the parameters held; the practical-identifiability check at the
        estimate; and the output misfit there.

    Raises
    ------
    OptionError
        ``method="dukf"`` without ``table``, a tuning out of range, or a bad number of passes or replicates.
    CompileError
        The filter could not be compiled.
    """
    check_replicates(replicates)
    check_passes(passes)
    if method == "dukf" and table is None:
        raise OptionError(
            "method='dukf' needs table= (a branch table: write one with `obsnl analyze MODEL --format json-table`)"
        )
    for t in grid:  # NaN fails every comparison, so it is refused too
        for option, value, ok, rule in (
            (
                "s0=",
                t.s0,
                1e-6 <= t.s0 <= 10.0,
                "a number from 1e-6 to 10 (the prior std of log-parameters: 10 already spans a factor e**10)",
            ),
            ("q_theta=", t.q_theta, 0 <= t.q_theta < np.inf, "a number >= 0"),
            ("q_x=", t.q_x, 0 <= t.q_x < np.inf, "a number >= 0"),
            ("gate=", t.gate, t.gate > 0, "a number > 0 (inf: off)"),
        ):
            if not ok:
                raise OptionError(f"{option} must be {rule}, got {value!r}")
    filt = make_filter(setup, method, table=table)
    scores = []
    if len(grid) > 1:
        for t in grid:
            try:
                (tr,), _ = run_passes(setup, filt, data, t, passes=1, fix_flagged=False)
                scores.append((t, output_misfit(setup, tr.theta[-1], data)))
            except CompileError:  # the compiler's failure, not this tuning's: said once, not once per tuning
                raise
            except ObsnlError:
                scores.append((t, float("inf")))
            if progress:
                progress()
    tuning = min(scores, key=lambda s: s[1])[0] if scores else grid[0]
    trs, held = run_passes(
        setup, filt, data, tuning, passes=passes, progress=progress, hold_below=HOLD_BELOW, fix_flagged=hold
    )
    theta = trs[-1].theta[-1]
    misfit = output_misfit(setup, theta, data)
    prac = practical_identifiability(setup, theta, data, first=trs[0], prior_std=tuning.s0, misfit=misfit)
    if replicates and not prac.inconclusive:
        prac = prac.with_spread(
            spread_on(
                executor,
                setup,
                filt,
                theta,
                data,
                tuning,
                method=method,
                table=table,
                passes=passes,
                replicates=replicates,
                seed=seed,
                progress=progress,
                fix_flagged=hold,
                hold_below=HOLD_BELOW,
            )
        )
    elif replicates and progress:  # not run (the estimate diverged): the count still ends at its total
        for _ in range(replicates):
            progress()
    return tuning, tuple(scores), trs, held, prac, misfit


def _refine(
    setup: Setup,
    data: Data,
    theta: np.ndarray,
    held: Sequence[str],
    progress: Callable[[], Any] | None,
    executor: Executor | None = None,
    input_noise: np.ndarray | None = None,
) -> tuple[Refinement | None, tuple[Profile, ...], str]:
    """The maximum-likelihood refinement and the profiles (on ``executor``); ``(None, (), why)`` where it could
    not run. ``input_noise``: the inputs' noise std propagated into the std (default: the setup's levels).

    A profile that finds a point fitting better than the estimate shows the fit stopped short of the maximum: the
    fit restarts from the best such point (its parameters and initial state) and the profiles are computed again,
    once; the third element then says so."""
    try:
        ref = refine(setup, data, theta, held=held, input_noise=input_noise)
        if progress:
            progress()
        profs = profiles(ref, progress=progress, executor=executor)
        # a profile that found a better point gives its chi2 and its coordinates together
        best = min(
            ((p.better, p.name, p.better_z) for p in profs if p.better is not None and p.better_z is not None),
            key=lambda b: b[0],
            default=None,
        )
        if best is None:
            return ref, profs, ""
        chi2, name, better_z = best
        z = np.asarray(better_z, float)
        obj = ref.objective
        again = refine(
            setup,
            data,
            obj.theta(z),
            held=held,
            input_noise=input_noise,
            x0=obj.x0(z),
            gain=z[len(z) - obj.n_gains :] if obj.n_gains else None,
        )
        return (
            again,
            profiles(again, executor=executor),
            (
                f"the profile of {name} found a point {ref.chi2 - chi2:.3g} lower in chi2 than the first "
                f"optimum: the fit restarted from it and the profiles were computed again"
            ),
        )
    except EstimatorError as exc:
        return None, (), f"the likelihood refinement could not run: {exc}"


def _held_bias(ref: Refinement, names: Sequence[str], h: int) -> str:
    """What holding parameter ``h`` 10 % off does to the free estimates (linearised at the estimate)."""
    J = ref.fit.J
    states = ref.objective.setup.model.states
    free = [
        i
        for i in range(J.shape[1])
        if i != h
        and (
            names[i] not in ref.held
            if i < len(names)
            else i >= len(names) + len(states) or states[i - len(names)] not in ref.known  # a predictor gain: free
        )
    ]
    Jf = J[:, free]
    shift = -np.linalg.lstsq(Jf, J[:, h], rcond=None)[0] * math.log(1.1)
    effects = sorted(
        ((abs(s), names[i], 100 * math.expm1(s)) for i, s in zip(free, shift) if i < len(names)), reverse=True
    )[:3]
    said = ", ".join(f"{n} by {e:+.2g} %" for _, n, e in effects)
    return f"held 10 % off, it would shift {said} (linearised at the estimate)" if said else ""


def assemble_identification(
    setup: Setup,
    data: Data,
    *,
    mode: str,
    method: str,
    passes: int,
    tuning: Tuning,
    scores: tuple,
    trs: tuple[Trajectory, ...],
    held: tuple[str, ...],
    prac: Any,
    misfit: float,
    noise: Mapping[str, NoiseLevel],
    record: RecordSummary,
    assumptions: Sequence[str],
    seed: int | None,
    refined: bool = True,
    progress: Callable[[], Any] | None = None,
    executor: Executor | None = None,
    input_noise: np.ndarray | None = None,
) -> Identification:
    """The :class:`Identification` of a filter run (:func:`tune_and_run`): refined by maximum likelihood and
    profiled where asked, then each parameter's estimate, std and interval, the fit, the convergence and the
    adequacy of the model.

    Parameters
    ----------
    setup : Setup
        The experiment the filter ran on.
    data : Data
        Its inputs and outputs.
    mode : str
        ``"measured"`` or ``"simulation"``.
    method : str
        The filter, ``"ukf"`` or ``"dukf"``.
    passes : int
        The passes asked for.
    tuning : Tuning
        The winning tuning.
    scores : tuple
        Each tried tuning with its output misfit.
    trs : tuple of Trajectory
        The filter's trajectory of each pass.
    held : tuple of str
        The parameters held at their guess.
    prac : Any
        The practical-identifiability check at the filter's estimate.
    misfit : float
        The output misfit at the filter's estimate (replaced by the fit's where the refinement ran).
    noise : mapping of str to NoiseLevel
        The noise level of each channel and where it came from.
    record : RecordSummary
        What the record was.
    assumptions : sequence of str
        What the result assumes (:func:`protocol_assumptions`).
    seed : int or None
        The noise seed (None for measured data).
    refined : bool
        Refine by maximum likelihood and profile the likelihood (default on).
    progress : callable or None
        Called after the refinement and after each profile.
    executor : Executor or None
        Where the profiles run (default: this process).
    input_noise : numpy.ndarray or None
        The inputs' noise std propagated into the std (default: the setup's levels).

    Returns
    -------
    Identification
    """
    m = setup.model
    theta = trs[-1].theta[-1]
    var = np.diag(trs[-1].P[-1])[m.nx :]
    t0 = time.perf_counter()
    ref, profs, failed = (
        _refine(setup, data, theta, held, progress, executor, input_noise) if refined else (None, (), "")
    )
    restarted = failed if ref is not None else ""  # with a refinement, the third element says a restart
    refine_seconds = time.perf_counter() - t0
    x0 = setup.x0
    if ref is not None:
        theta, x0 = ref.theta, ref.x0
    params = _estimates(setup, theta, var, held, prac, trs, ref, {pr.name: pr for pr in profs})
    y_fit, per = _fitted_response(setup, data, theta, x0)
    if ref is not None:
        misfit = float(np.sqrt(np.mean(per**2)))
    converged, reason = _convergence(ref, profs, restarted, refined, failed)
    adequate = None if ref is None else adequacy_of(ref, data, input_noise=input_noise)
    if adequate is not None and not adequate.passed:  # every std and interval assumes a right model
        params = [
            replace_field(p, flagged=True, reason="; ".join(w for w in (FLAG_REASON, p.reason) if w)) for p in params
        ]
    return Identification(
        model=m.name,
        mode=mode,
        method=method,
        parameters=tuple(params),
        adequacy=adequate,
        fit={o: float(100 * v) for o, v in zip(m.outputs, per)},
        passes=passes,
        passes_run=len(trs),
        seconds=float(sum(t.seconds for t in trs)) + refine_seconds,
        converged=converged,
        output_misfit=misfit if math.isfinite(misfit) else None,
        noise=dict(noise),
        tuning=tuning,
        tuning_scores=scores,
        data=record,
        practical=prac,
        assumptions=tuple(assumptions),
        repairs=int(sum(t.total_repairs for t in trs)),
        seed=seed,
        traces=trs,
        t=setup.record.t,
        y_measured=np.asarray(data.y, float).reshape(len(setup.record), -1),
        y_fit=y_fit,
        outputs=m.outputs,
        converged_reason=reason,
        refinement=None if ref is None else RefinementSummary.from_refinement(ref),
        profiles=profs,
    )


def _estimates(
    setup: Setup,
    theta: np.ndarray,
    var: np.ndarray,
    held: tuple[str, ...],
    prac: Any,
    trs: tuple[Trajectory, ...],
    ref: Refinement | None,
    by_name: Mapping[str, Profile],
) -> list[ParameterEstimate]:
    """Each parameter's estimate, std, interval and flag: the refinement's (its Fisher std, its profile's interval
    and judgement, an estimate on the edge of the valid region) where it ran, else the filter's (its posterior
    variance, the practical check's flags); a held parameter has no estimate."""
    m = setup.model
    truth = None if setup.truth is None else setup.theta_true
    params = []
    for i, p in enumerate(m.parameters):
        is_held = p in held
        why = ["held at its guess: poorly informed once the filter had reached the noise floor"] if is_held else []
        prof = by_name.get(p)
        if ref is not None:
            flag = judge(prof) if prof is not None else None
            if p in ref.at_edge:
                flag = (
                    "its estimate rests on the edge of the valid region (a factor 100 from its guess): the "
                    "likelihood would rise further beyond it (a true value of 0, or a far guess)"
                    + (f"; {flag}" if flag else "")
                )
            if flag:
                why.append(flag)
            if is_held:
                why.append(_held_bias(ref, m.parameters, i))
            std = None if is_held else float(ref.std[i])
            flagged = is_held or flag is not None
        else:
            if p in prac.reasons:
                why.append(prac.reasons[p])
            v = float(var[i]) if len(var) == m.np else math.nan
            std = None if is_held or not 0 < v < math.inf else float(abs(theta[i]) * math.sqrt(v))
            if not is_held and len(var) == m.np and std is None:  # a zero std would claim certainty
                why.append(
                    f"no std: the filter's posterior variance of log|{p}| is {v:.3g} (its covariance "
                    f"collapsed after {sum(tr.total_repairs for tr in trs)} repairs)"
                )
            flagged = is_held or p in prac.flagged
        est = None if is_held else float(theta[i])
        err = kind = tru = None
        if truth is not None:
            tru = float(truth[i])
            err, kind = error_of(est, tru)
        params.append(
            ParameterEstimate(
                name=p,
                guess=float(setup.guess[p]),
                estimate=est,
                std=std,
                held=is_held,
                flagged=flagged,
                reason="; ".join(w for w in why if w) or None,
                true=tru,
                error=err,
                error_kind=kind,
                interval=None if prof is None or prof.shape in _NO_INTERVAL else prof.interval,
                interval_method=None
                if prof is None
                else f"profile likelihood, 95 % (chi2(1) threshold 3.84{_widened(prof)}), {prof.shape}",
            )
        )
    return params


def _fitted_response(setup: Setup, data: Data, theta: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The model's response at the estimate (``y_fit``) and its RMS error per output over the samples measured,
    relative to the output's RMS; NaN and infinite errors where the simulation fails."""
    m = setup.model
    try:
        y_fit = simulate(
            m,
            theta=theta,
            x0=x0,
            u=data.u,
            dt=setup.record.dt,
            substeps=setup.fit_substeps or setup.substeps,
            refine=setup.refine,
        ).y
        y = np.asarray(data.y, float).reshape(len(y_fit), -1)
        rms = lambda a: np.sqrt(np.nanmean(a**2, axis=0))  # noqa: E731 - over the samples measured
        per = rms(y_fit - y) / np.maximum(rms(y), 1e-300)
    except EstimatorError:
        y_fit = np.full(np.shape(setup.y_true), np.nan)
        per = np.full(m.ny, np.inf)
    return y_fit, per


def _convergence(
    ref: Refinement | None, profs: Sequence[Profile], restarted: str, refined: bool, failed: str
) -> tuple[bool, str]:
    """Whether the identification converged, and why or why not: the refinement's first-order conditions, unless a
    profile found a better point; not converged where the refinement failed or was skipped."""
    if ref is not None:
        better = [pr.name for pr in profs if pr.better is not None]
        converged, reason = ref.converged and not better, "; ".join(w for w in (restarted, ref.reason) if w)
        if better:
            reason = (
                f"the profile of {better[0]} found a lower chi2 than the estimate"
                + (" again after the fit restarted from the first better point" if restarted else "")
                + ": it is not the maximum of the likelihood; no interval is claimed"
            )
    elif refined:
        converged, reason = False, failed
    else:
        converged, reason = (
            False,
            (
                "not checked: the maximum-likelihood refinement was skipped (refine=False), whose "
                "first-order conditions define convergence"
            ),
        )
    return converged, reason


#: Profile shapes that claim no interval (none is printed or written for them).
_NO_INTERVAL = ("not-optimal", "not-computed")


def _widened(prof: Profile) -> str:
    """How the measured inputs' noise raised a profile's threshold ('' when it did not, to 4 digits)."""
    w = math.sqrt(prof.threshold / THRESHOLD)
    return f" x {w:.4g}^2 for the noise of the measured inputs" if round(w, 4) > 1 else ""


_COMMON = (
    "the model is right: its equations describe the structure, its known constants are right",
    "measurement noise is white, Gaussian and independent between channels; its level per channel is "
    "given under 'noise'",
    "parameters are estimated as log|theta| with the sign of the guess; each stays within a factor 100 of its guess",
    f"held: only with hold=True: after the first pass whose output misfit is at most {HOLD_BELOW:g}x the "
    "noise level, the parameters flagged there are put back to their guess and no longer estimated",
)
_FILTER_ONLY = (
    "std: the filter's posterior std after the last pass (optimistic: the record is reused over passes)",
    "converged: not checked without the likelihood refinement (refine=False)",
    "flagged: these data cannot pin the parameter within 5 % at 3 sigma (Cramér-Rao bound, the filter's "
    "posterior against its prior, and the Monte-Carlo spread when replicates= is given)",
)
_REFINED = (
    "the filter's estimate starts a maximum-likelihood fit (output error: the model simulated from an "
    "estimated initial state under the measured input; Levenberg-Marquardt with exact derivatives); the "
    "noise std per output is re-estimated from the fit's residuals",
    "std: from the Fisher information (Gauss-Newton Hessian) at the maximum-likelihood estimate, plus the "
    "noise of the measured inputs (its level under 'noise') propagated to first order through the exact "
    "sensitivity of the fit to every input sample",
    "interval: 95 % profile-likelihood interval (Raue et al. 2009, chi2(1) threshold 3.84, raised by the "
    "square of the inputs' widening of the std), each other parameter and the initial state re-optimised "
    "at every profile point",
    "converged: the first-order condition holds (Newton decrement <= 0.01), the last step moved no "
    "parameter by more than 0.1 of its std, and no parameter rests on its search bound",
    "adequacy: the residuals are tested for whiteness, for correlation with each input and for a misfit above "
    "the noise level estimated from the raw record, at the 1 % level over all tests (under 'adequacy'); when "
    "they fail, every parameter is flagged: its std and interval assume a right model",
    "flagged: its 95 % interval is wider than +-5 % of the estimate, or open, or the profile is flat",
    f"fit: NRMSE of the model simulated at the estimate ({FIT_SUBSTEPS} RK4 substeps per sample) from the "
    "estimated initial state, against the measurement",
)


_PREDICTION = (
    "objective prediction: the fit minimises the one-step prediction errors of a predictor that corrects the state "
    "by a constant gain times each innovation, the gain fitted with the parameters (the innovations form of the "
    "prediction-error method, Ljung 1999, section 4.3): the residuals are the innovations, the plant may drift "
    "under unmeasured disturbances; adequacy tests their whiteness and their independence of the inputs, not their "
    "level; a validation (the model simulated on another record) runs without the gain"
)


def protocol_assumptions(refined: bool, *more: str) -> tuple[str, ...]:
    """What an identification's result assumes: the lines common to every run, those of the likelihood
    refinement or of the filter alone, then the run's own.

    Parameters
    ----------
    refined : bool
        The run was refined by maximum likelihood.
    *more : str
        The run's own assumptions, in order.

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> protocol_assumptions(False, "one tuning, as given")[-1]
    'one tuning, as given'
    >>> len(protocol_assumptions(True)) - len(protocol_assumptions(False))  # 7 lines of the refinement, not 3
    4
    """
    return _COMMON + (_REFINED if refined else _FILTER_ONLY) + more


def check_unknowns(
    parameters: Sequence[str], states: Sequence[str], data: Measured, *, known: Sequence[str] = ()
) -> None:
    """Refuse, before any work, a record with no more output samples measured than the fit's unknowns.

    The fit estimates every parameter and every initial state not declared known; with as many unknowns as samples
    measured (or more) it can pass through every sample, so no noise level, std or interval can be had from it,
    whatever the initial guesses.

    Parameters
    ----------
    parameters, states : sequence of str
        The model's parameters and states.
    data : Measured
        The record (its output samples measured are counted).
    known : sequence of str
        States whose initial values are declared known (not estimated).

    Raises
    ------
    DataError
        The unknowns are at least the samples measured.

    Examples
    --------
    >>> from obsnl.estimation.measured import measured
    >>> d = measured({"t": range(20), "u": [1.0] * 20, "y": range(20)}, inputs=["u"], outputs=["y"])
    >>> check_unknowns([f"p{i}" for i in range(20)], ["x", "v"], d)
    Traceback (most recent call last):
    ...
    obsnl.errors.DataError: 22 unknowns (20 parameters, 2 initial states) against 20 output samples measured: the fit could pass through every sample, so nothing could be said of its precision; give a record of more than 22 output samples (or declare known initial states, or fewer parameters)
    """
    free = [s for s in states if s not in set(known)]
    unknowns = len(parameters) + len(free)
    seen = int(np.sum(data.present))
    if unknowns >= seen:
        raise DataError(
            f"{unknowns} unknowns ({len(parameters)} parameters, {len(free)} initial states) against "
            f"{seen} output samples measured: the fit could pass through every sample, so nothing could "
            f"be said of its precision; give a record of more than {unknowns} output samples (or declare "
            f"known initial states, or fewer parameters)"
        )


def _noise_levels(num: NumericModel, data: Measured, noise: Mapping[str, float] | None) -> dict[str, NoiseLevel]:
    """The noise level of every input and output of a measured record: the ratio given in ``noise``, else estimated
    from the record (:func:`~obsnl.estimation.measured.estimate_noise`, floored at :data:`NOISE_FLOOR`); an input whose
    samples differ as white noise does (a random excitation) is taken as exact, its estimate kept as an upper bound.
    A misspelt channel and a ratio outside ``[MIN_NOISE, 1)`` are refused."""
    given = dict(noise or {})
    unknown = sorted(set(given) - set(num.inputs) - set(num.outputs))
    if unknown:  # a misspelt channel is refused, never ignored
        raise OptionError(
            f"noise given for {unknown[0]!r}, which is not an input or output of {num.name!r} "
            f"({', '.join(num.inputs + num.outputs)}); check the spelling"
        )
    bad = [
        f"{k}={v!r}"
        for k, v in given.items()
        if isinstance(v, bool) or not (isinstance(v, (int, float)) and MIN_NOISE <= v < 1)
    ]
    if bad:
        raise OptionError(
            f"the noise= ratio {bad[0]} must lie in [{MIN_NOISE:g}, 1) (noise to signal RMS; below "
            f"{MIN_NOISE:g} double precision cannot resolve it: for noise-free data give the "
            f"integrator's accuracy, e.g. 1e-6)"
        )
    levels: dict[str, NoiseLevel] = {}
    for names, arr in ((num.inputs, data.u), (num.outputs, data.y)):
        for j, c in enumerate(names):
            if c in given:
                levels[c] = NoiseLevel(float(given[c]), "given")
            else:
                r, note = estimate_noise(arr[:, j])
                levels[c] = NoiseLevel(
                    max(r, NOISE_FLOOR),
                    f"estimated {note}" + (f"; floored at {NOISE_FLOOR:g}" if r < NOISE_FLOOR else ""),
                    estimate=r,
                    upper_bound=UPPER_BOUND in note,
                )
                if c in num.inputs and r >= RANDOM_INPUT:  # a random excitation: its samples differ as noise does
                    levels[c] = NoiseLevel(
                        NOISE_FLOOR,
                        f"estimated {note}; that is {100 * r:.2g} % of the input's RMS: its samples differ as white "
                        f"noise does (a random excitation, not oversampled), so this is only an upper bound and the "
                        f"input is taken as exact (the filter gets the floor {NOISE_FLOOR:g}); give its noise level "
                        f"to count it",
                        estimate=r,
                        upper_bound=True,
                    )
    return levels


def identify_measured(
    num: NumericModel,
    data: Measured,
    *,
    guess: Mapping[str, float],
    method: str = "ukf",
    table: BranchTable | None = None,
    noise: Mapping[str, float] | None = None,
    grid: Sequence[Tuning] = MEASURED_GRID,
    passes: int = 3,
    replicates: int = 0,
    seed: int = 0,
    jit: bool = False,
    hold: bool = False,
    progress: Callable[[], Any] | None = None,
    executor: Executor | None = None,
    refined: bool = True,
    intersample: Mapping[str, str] | None = None,
    known_initial: Mapping[str, float] | None = None,
    objective: str = "output",
    bounds: Mapping[str, tuple[float, float]] | None = None,
) -> Identification:
    """Identify ``num``'s parameters from measured inputs and outputs (no true value used).

    Parameters
    ----------
    num : NumericModel
        The compiled model (:func:`obsnl.estimation.to_casadi`).
    data : Measured
        Measured inputs and outputs (:func:`obsnl.estimation.measured.read_measured`), named as in the model.
    guess : mapping of str to float
        Initial guess of every parameter.
    method : {"ukf", "dukf"}
        The filter (the DUKF needs the branch table).
    table : BranchTable or None
        The model's branch table.
    noise : mapping of str to float or None
        Noise-to-signal RMS ratio per channel (input or output name); the others are estimated from
        the data (:func:`obsnl.estimation.measured.estimate_noise`), floored at ``NOISE_FLOOR``.
    grid : sequence of Tuning
        Tuning configurations, run one pass each; the smallest output misfit wins (one: no tuning).
    passes, replicates, seed : int
        Passes over the record; Monte-Carlo replicates of the practical-identifiability check (0: off)
        and their noise seed.
    jit : bool
        Compile the filter and the likelihood fit to C.
    hold : bool
        Hold the parameters flagged once the filter reached the noise floor at their guess (default:
        off; every parameter is estimated in every pass and the flags are judged at the end).
    progress : callable or None
        Called after every pass (tuning passes included: ``len(grid) + passes`` calls when tuning) and
        once per Monte-Carlo replicate.
    executor : Executor or None
        Where the profile likelihoods and the Monte-Carlo replicates run (:class:`obsnl.executor.Executor`;
        default: this process); the same numbers on any executor.
    refined : bool
        Refine the filter's estimate by maximum likelihood, with Fisher std and profile-likelihood
        intervals (:mod:`obsnl.identification.likelihood`, :mod:`obsnl.identification.profile`; default on).
    intersample : mapping of str to str or None
        How each input behaves between samples: ``zoh``, ``linear`` (default) or ``bandlimited``
        (:mod:`obsnl.estimation.intersample`); the filter and the fit both use it.
    known_initial : mapping of str to float or None
        The initial value of each state known (a free decay from a known displacement): the filter starts there
        and the fit holds it; the fit estimates the other initial states (for a record whose motion the model at
        rest at the guess cannot make, the filter and the fit start from them fitted to its first samples,
        :func:`obsnl.identification.setup.free_start`).
    objective : {"output", "prediction"}
        What the maximum-likelihood fit minimises (:data:`obsnl.identification.setup.OBJECTIVES`).
    bounds : mapping of str to (float, float) or None
        Declared bounds of parameters (the model's ``[bounds]``): the fit searches inside them.

    Returns
    -------
    Identification

    Raises
    ------
    OptionError
        A missing guess, a bad option, noise for an unknown channel.
    DataError
        Data whose channels are not the model's.
    """
    if data.inputs != num.inputs or data.outputs != num.outputs:
        raise OptionError(
            f"the data have inputs {list(data.inputs)} and outputs {list(data.outputs)}, model "
            f"{num.name!r} has {list(num.inputs)} and {list(num.outputs)}"
        )
    known = dict(known_initial or {})
    data.record()  # fewer samples than MIN_SAMPLES is named first
    check_unknowns(num.parameters, num.states, data, known=tuple(known))  # before the noise levels and the filter
    missing = [q for q in num.parameters if q not in guess]
    if missing:
        raise OptionError(
            f"no initial guess for {', '.join(missing)}; give guess= {missing[0]}=VALUE for each, or a "
            f"[guess] table in the model file"
        )
    for j, c in enumerate(data.outputs):
        seen = data.y[data.present[:, j], j]  # the samples measured
        if seen.size and np.all(seen == seen[0]):
            raise DataError(
                f"output {c!r} of {data.name!r} is constant ({float(seen[0])!r} throughout): there "
                f"is no response to identify from; check the column"
            )
    levels = _noise_levels(num, data, noise)
    # the refinement's std counts an input's noise at its given level or its estimate (not the filter's floor); a
    # level that is only an upper bound (the channel is not oversampled) would swamp the std with signal: not counted
    bound = [c for c in num.inputs if levels[c].upper_bound]
    input_noise = np.array(
        [
            0.0 if c in bound else levels[c].ratio if levels[c].estimate is None else levels[c].estimate
            for c in num.inputs
        ]
    ) * np.sqrt(np.mean(np.asarray(data.u, float) ** 2, axis=0))
    kinds = intersample_kinds(intersample, num.inputs)
    between = between_samples(data.u, num.inputs, kinds) if num.inputs else ()
    stepped, U = drive(num, data.u, kinds)
    record = data.record() if stepped is num else dataclasses.replace(data.record(), accel=U)
    said = [between_said(b) for b in between]
    setup = Setup(
        model=stepped,
        record=record,
        truth=None,
        guess=dict(guess),
        jit=jit,
        y_true=data.y,
        channel_noise={c: v.ratio for c, v in levels.items()},
        fit_substeps=FIT_SUBSTEPS,
        coordinates=coordinates(num, "log", reference=guess),
        initial=known,
        known=tuple(known),
        objective=objective,
        bounds=dict(bounds or {}),
    )
    start = free_start(stepped, theta=setup.theta_guess, x0=setup.x0, u=U, y=data.y, dt=data.dt, known=tuple(known))
    if start is not None:  # the record moves where the model at rest would not: it starts in motion
        setup = dataclasses.replace(setup, initial={**dict(zip(num.states, map(float, start))), **known})
        said.append(
            "the record moves where the model at rest at the guess would not (a free decay, or a start in "
            "motion): the unknown initial states start from their fit to the first samples at the guess"
        )
    d = Data(seed=None, u=U, y=data.y)
    for b in between:
        if b.matters:
            sys.stderr.write(f"obsnl: warning: {between_said(b)}\n")
    tuning, scores, trs, held, prac, misfit = tune_and_run(
        setup,
        d,
        method=method,
        table=table,
        grid=grid,
        passes=passes,
        replicates=replicates,
        seed=seed,
        progress=progress,
        hold=hold,
        executor=executor,
    )
    how = (
        "tuned without any true value: each configuration of the grid ran one pass, the smallest free-run "
        "output misfit won"
        if len(grid) > 1
        else "one tuning, as given"
    )
    return assemble_identification(
        setup,
        d,
        mode="measured",
        method=method,
        passes=passes,
        tuning=tuning,
        scores=scores,
        trs=trs,
        held=held,
        prac=prac,
        misfit=misfit,
        noise=levels,
        seed=seed,
        record=dataclasses.replace(RecordSummary.from_dict(data.to_dict()), intersample=tuple(between)),
        refined=refined,
        progress=progress,
        executor=executor,
        input_noise=input_noise,
        assumptions=protocol_assumptions(
            refined,
            how,
            (
                "the initial state is estimated with the parameters"
                if refined
                else "the filter starts from the initial states of the model file, else 0"
            )
            + (f"; known initial states held: {', '.join(f'{k} = {v:g}' for k, v in known.items())}" if known else ""),
            *(
                [
                    f"input {', '.join(bound)}: taken as exact by the std and intervals "
                    "(its noise level estimated from the data is only an upper bound: "
                    "the channel is not oversampled); give its noise level to count it"
                ]
                if bound and refined
                else []
            ),
            *([_PREDICTION] if refined and objective == "prediction" else []),
            *said,
            *data.notes(),
        ),
    )
