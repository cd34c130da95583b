"""The Table 2 analog of the seed paper (Markdown and LaTeX) and its summary statistics, rendered from the
reproduction's value (:class:`obsnl.studies.seed_reproduction.Reproduction`; a committed ``table2.json`` is read
back with its ``from_dict`` and re-rendered without running anything).

The report room sits below the studies on the data flow and does not import them: what the renderers read is
written down here as protocols (:class:`Table2Document` and the values it holds), which the reproduction's values
satisfy as they are. The statistics of a column over the reported seeds are frozen values too
(:class:`FilterColumn`, :class:`MLColumn`).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from obsnl.report.tex import tex_escape

__all__ = [
    "Table2Document",
    "FilterColumn",
    "MLColumn",
    "table2_summary",
    "table2_ml_summary",
    "table2_markdown",
    "table2_latex",
]


# Text of the Table 2 analog (seed paper 000_d24855f97fc8bdd4.txt) from the reproduction's value written by
# ``obsnl reproduce`` (``obsnl.studies.seed_paper``), so that a committed table2.json, read back, can be
# re-rendered without running anything. Writing files and figures stays in obsnl.studies.seed_reproduction.


# the members are read-only properties: the values read are frozen dataclasses
class _Tuning(Protocol):
    @property
    def s0(self) -> float: ...
    @property
    def q_theta(self) -> float: ...
    @property
    def q_x(self) -> float: ...
    @property
    def gate(self) -> float: ...  # inf: off


class _Spread(Protocol):
    @property
    def std(self) -> Sequence[float]: ...
    @property
    def held(self) -> Sequence[str]: ...


class _Practical(Protocol):
    @property
    def reasons(self) -> Mapping[str, str]: ...
    @property
    def undecided(self) -> Mapping[str, str]: ...
    @property
    def inconclusive(self) -> str: ...
    @property
    def spread(self) -> _Spread | None: ...


class _Attempt(Protocol):
    @property
    def tuning(self) -> _Tuning: ...
    @property
    def misfit(self) -> float: ...
    @property
    def error(self) -> str: ...


class _Run(Protocol):
    @property
    def method(self) -> str: ...
    @property
    def passes(self) -> int: ...
    @property
    def seed(self) -> int: ...
    @property
    def tuning(self) -> _Tuning: ...
    @property
    def theta(self) -> Sequence[float]: ...
    @property
    def seconds(self) -> float: ...
    @property
    def repairs(self) -> int: ...
    @property
    def implicit(self) -> int: ...
    @property
    def misfit(self) -> float: ...
    @property
    def practical(self) -> _Practical | None: ...
    @property
    def error(self) -> str: ...
    @property
    def interventions(self) -> Mapping[str, int]: ...
    @property
    def redone(self) -> Sequence[_Attempt]: ...
    @property
    def flagged(self) -> Sequence[str] | None: ...
    @property
    def flagged_linearised(self) -> Sequence[str]: ...
    def errors(self, truth: np.ndarray) -> np.ndarray: ...


class _Start(Protocol):
    @property
    def method(self) -> str: ...
    @property
    def passes(self) -> int: ...
    @property
    def misfit(self) -> float: ...


class _Adequacy(Protocol):
    @property
    def passed(self) -> bool: ...


class _Refined(Protocol):
    @property
    def seed(self) -> int: ...
    @property
    def start(self) -> _Start: ...
    @property
    def theta(self) -> Sequence[float]: ...
    @property
    def converged(self) -> bool: ...
    @property
    def reason(self) -> str: ...
    @property
    def seconds(self) -> float: ...
    @property
    def iterations(self) -> int: ...
    @property
    def misfit_over_noise(self) -> Mapping[str, float]: ...
    @property
    def at_edge(self) -> Sequence[str]: ...
    @property
    def error(self) -> str: ...
    @property
    def adequacy(self) -> _Adequacy | None: ...
    def errors(self, truth: np.ndarray) -> np.ndarray: ...
    def std_percent(self) -> np.ndarray: ...


class _Record(Protocol):
    @property
    def name(self) -> str: ...


class _Experiment(Protocol):
    @property
    def model(self) -> str: ...
    @property
    def record(self) -> _Record: ...
    @property
    def truth(self) -> Mapping[str, float]: ...
    @property
    def guess(self) -> Mapping[str, float]: ...
    @property
    def noise_ratio(self) -> float: ...
    @property
    def parameters(self) -> Sequence[str]: ...
    @property
    def theta_true(self) -> np.ndarray: ...


class Table2Document(Protocol):
    """What the Table 2 renderers read of a reproduction (:class:`obsnl.studies.seed_reproduction.Reproduction`):
    the experiment, the branch table's source, the tuning seeds and protocol, every reported run, the
    maximum-likelihood refinements and their protocol, the reported runs' rules (diverged factor, fallbacks, noise
    floor: None for a document of the former rule) and the paper's errors per filter and parameter."""

    @property
    def experiment(self) -> _Experiment: ...
    @property
    def table_source(self) -> str: ...
    @property
    def tuning_seeds(self) -> Sequence[int]: ...
    @property
    def tuning_protocol(self) -> str | None: ...
    @property
    def runs(self) -> Sequence[_Run]: ...
    @property
    def refinements(self) -> Sequence[_Refined]: ...
    @property
    def refinement_protocol(self) -> str | None: ...
    @property
    def diverged_factor(self) -> float: ...
    @property
    def fallbacks(self) -> int | None: ...
    @property
    def noise_floor_factor(self) -> float | None: ...
    @property
    def paper_errors(self) -> Mapping[str, Mapping[str, float]]: ...


_T2_TEX = {
    "k_m": r"$k_m$",
    "c_dm": r"$c_{dm}$",
    "c_eta_p": r"$c'_\eta$",
    "w_h": r"$w_h$",
    "c_p": r"$c'$",
    "h_p": r"$h'$",
    "Delta1": r"$\Delta_1$",
    "Delta2": r"$\Delta_2$",
    "N": r"$N$",
}
_T2_MD = {
    "k_m": "k_m",
    "c_dm": "c_dm",
    "c_eta_p": "c'_eta",
    "w_h": "w_h",
    "c_p": "c'",
    "h_p": "h'",
    "Delta1": "Δ1",
    "Delta2": "Δ2",
    "N": "N",
}
_T2_METHODS = {"ukf": "UKF", "dukf": "DUKF", "dukf-zero": "DUKF, P_AU = 0"}
#: The ML column's flag: a std (the Cramér-Rao bound at the maximum-likelihood estimate, the measured input's noise
#: counted) above 5/3 % of the estimate, i.e. the 5 % band cannot be reached at 3 sigma: the linearised rule of the
#: filters' flags (obsnl.identification.practical.CRB_LIMIT), applied to the refinement's own Fisher information.
_ML_PIN = 100 * 0.05 / 3

#: Per Delta: the true yield displacement and the ``|error|`` in % of each run's (None: a model without them).
YieldErrors = Mapping[str, tuple[float, np.ndarray]]


@dataclass(frozen=True, eq=False)
class FilterColumn:
    """One filter's column of Table 2 (one method, one protocol) over its reported seeds.

    The statistics are over the runs that ran to the end (``seeds``; the first run when none did): the mean
    estimate, the mean and worst ``|error|`` in % per parameter and the seed of the worst, the flags per parameter
    (all criteria, and the linearised ones alone), the mean Monte-Carlo spread (None: no run has one), the yield
    displacements' errors, the runs whose flags were not decided and why, the cost; ``repairs``,
    ``interventions`` and ``implicit`` count every run, ``redone`` (seed, attempts, the configuration reported) and
    ``failed`` (seed, error) name them.
    """

    parameters: tuple[str, ...]
    seeds: tuple[int, ...]
    mean_estimate: np.ndarray
    mean_abs_error: np.ndarray
    worst_abs_error: np.ndarray
    worst_seed: tuple[int, ...]
    flag_counts: Mapping[str, int]
    flag_counts_linearised: Mapping[str, int]
    spread: tuple[float, ...] | None
    yield_errors: YieldErrors | None
    undecided: tuple[tuple[int, str], ...]
    seconds: float
    seconds_per_pass: float
    repairs: int
    interventions: Mapping[str, int]
    implicit: int
    misfits: tuple[float, ...]
    tuning: _Tuning
    redone: tuple[tuple[int, Sequence[_Attempt], _Tuning], ...]
    failed: tuple[tuple[int, str], ...]

    def flagged(self, p: str, *, linearised: bool = False) -> bool:
        """``p`` is flagged in at least half of the seeds (by the linearised criteria alone: ``linearised``)."""
        counts = self.flag_counts_linearised if linearised else self.flag_counts
        return counts[p] * 2 >= len(self.seeds)


@dataclass(frozen=True, eq=False)
class MLColumn:
    """The maximum-likelihood column of Table 2 over the refinements (``runs``) that ran (``seeds``): the mean
    estimate, the mean and worst ``|error|`` and the mean std in % per parameter, the worst error in std, the flags
    (std above 5/3 % of the estimate), how many unflagged estimates lie within 4 std (or 1 %) of the truth, the yield
    displacements' errors, the seeds that converged, failed (seed, error) or failed adequacy."""

    parameters: tuple[str, ...]
    seeds: tuple[int, ...]
    runs: tuple[_Refined, ...]
    mean_estimate: np.ndarray
    mean_abs_error: np.ndarray
    worst_abs_error: np.ndarray
    mean_std_percent: np.ndarray
    worst_error_in_std: np.ndarray
    flag_counts: Mapping[str, int]
    within_4_std: tuple[int, int]
    yield_errors: YieldErrors | None
    converged: tuple[int, ...]
    failed: tuple[tuple[int, str], ...]
    inadequate: tuple[int, ...]

    def flagged(self, p: str, *, linearised: bool = False) -> bool:
        """``p`` is flagged on at least half of the seeds (one criterion: ``linearised`` changes nothing)."""
        return self.flag_counts[p] * 2 >= len(self.seeds)


def _abs_errors(r: _Run | _Refined, truth: np.ndarray) -> np.ndarray:
    """``|error|`` in % per parameter, NaN where there is none (no estimate)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.abs(np.asarray(r.errors(truth), float))
    return np.where(np.isfinite(e), e, np.nan)


def table2_summary(doc: Table2Document) -> dict[tuple[str, int], FilterColumn]:
    """Per (method, passes): mean estimate, mean and worst ``|error|`` per parameter, flags, cost, interventions
    (:class:`FilterColumn`)."""
    exp = doc.experiment
    truth = exp.theta_true
    params = tuple(exp.parameters)
    groups: dict[tuple[str, int], list[_Run]] = {}
    for r in doc.runs:
        groups.setdefault((r.method, r.passes), []).append(r)
    out = {}
    for key, every in groups.items():
        runs = [r for r in every if not r.error] or every[:1]
        failed = [r for r in every if r.error]
        est = np.array([list(r.theta) for r in runs], float)
        err = np.array([_abs_errors(r, truth) for r in runs], float)
        kinds: Counter[str] = Counter()
        for r in every:
            kinds.update(r.interventions)
        tunings = [r.tuning for r in every]
        out[key] = FilterColumn(
            parameters=params,
            seeds=tuple(r.seed for r in runs),
            mean_estimate=est.mean(axis=0),
            mean_abs_error=err.mean(axis=0),
            worst_abs_error=err.max(axis=0),
            worst_seed=tuple(runs[i].seed for i in err.argmax(axis=0)),
            flag_counts={p: sum(p in (r.flagged or ()) for r in runs) for p in params},
            flag_counts_linearised={p: sum(p in r.flagged_linearised for r in runs) for p in params},
            spread=_mean_spread(runs, params),
            yield_errors=_yield_errors(runs, exp),
            undecided=tuple(
                (r.seed, (r.practical.inconclusive if r.practical else "") or r.error or "no estimate")
                for r in runs
                if r.flagged is None
            ),
            seconds=float(np.mean(np.array([r.seconds for r in runs], float))),
            seconds_per_pass=float(np.mean(np.array([r.seconds for r in runs], float) / key[1])),
            repairs=int(sum(r.repairs for r in every)),
            interventions=dict(kinds),
            implicit=int(sum(r.implicit for r in every)),
            misfits=tuple(r.misfit for r in runs),
            tuning=max(tunings, key=tunings.count),
            redone=tuple((r.seed, r.redone, r.tuning) for r in every if r.redone),
            failed=tuple((r.seed, r.error) for r in failed),
        )
    return out


def table2_ml_summary(doc: Table2Document) -> MLColumn | None:
    """The maximum-likelihood column (``doc.refinements``): mean and worst ``|error|``, mean std, flags,
    the convergence verdict per seed (:class:`MLColumn`); None when the document has no refinement."""
    refs = tuple(doc.refinements)
    if not refs:
        return None
    exp = doc.experiment
    truth = exp.theta_true
    ran = [r for r in refs if not r.error]
    params = tuple(exp.parameters)
    est = np.array([list(r.theta) for r in ran], float).reshape(len(ran), len(params))
    err = np.array([_abs_errors(r, truth) for r in ran], float).reshape(est.shape)
    rel = np.array([r.std_percent() for r in ran], float).reshape(est.shape)
    std = np.where(np.isfinite(rel), rel, np.inf)  # no finite std: a flat direction
    flags = ~(std <= _ML_PIN)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = err / std
    ok = [
        (p, e, s)
        for row_e, row_s, row_f in zip(err, std, flags)
        for p, e, s, f in zip(params, row_e, row_s, row_f)
        if not f
    ]  # unflagged: within 4 std, or 1 % (issue 27's calibration rule)
    nan = np.full(len(params), np.nan)
    return MLColumn(
        parameters=params,
        seeds=tuple(r.seed for r in ran),
        runs=refs,
        mean_estimate=est.mean(axis=0) if ran else nan,
        mean_abs_error=err.mean(axis=0) if ran else nan,
        worst_abs_error=err.max(axis=0) if ran else nan,
        mean_std_percent=std.mean(axis=0) if ran else nan,
        worst_error_in_std=np.where(np.isfinite(z), z, np.nan).max(axis=0) if ran else nan,
        flag_counts={p: int(flags[:, i].sum()) for i, p in enumerate(params)},
        within_4_std=(sum(e <= max(4 * s, 1.0) for _, e, s in ok), len(ok)),
        yield_errors=_yield_errors(ran, exp) if ran else None,
        converged=tuple(r.seed for r in ran if r.converged),
        failed=tuple((r.seed, r.error) for r in refs if r.error),
        inadequate=tuple(r.seed for r in ran if r.adequacy is not None and r.adequacy.passed is False),
    )


def _yield_displacement(delta: float, n: float) -> float:
    """``|Delta|**(-1/(2N))``: with ``Delta = (beta +- gamma) / r_y**(2N)`` (seed paper 000_d24855f97fc8bdd4.txt,) the yield
    displacement up to the factor ``|beta +- gamma|**(-1/(2N))``."""
    return abs(delta) ** (-1 / (2 * n))


def _yield_errors(runs: Sequence[_Run] | Sequence[_Refined], exp: _Experiment) -> YieldErrors | None:
    """Per Delta: the true yield displacement and the ``|error|`` in % of each run's (the direction the
    seed model's data inform along the Delta-N ridge); None for a model without Delta1, Delta2, N."""
    truth = exp.truth
    if not {"Delta1", "Delta2", "N"} <= set(truth):
        return None
    at = {p: i for i, p in enumerate(exp.parameters)}
    out = {}
    for d in ("Delta1", "Delta2"):
        true = _yield_displacement(truth[d], truth["N"])
        est = np.array(
            [
                _yield_displacement(r.theta[at[d]], r.theta[at["N"]])
                if not np.isnan(r.theta[at[d]]) and not np.isnan(r.theta[at["N"]]) and r.theta[at["N"]]
                else np.nan
                for r in runs
            ],
            float,
        )
        out[d] = (true, np.abs(100 * (est - true) / true))
    return out


def _mean_spread(runs: Sequence[_Run], params: Sequence[str]) -> tuple[float, ...] | None:
    """Mean Monte-Carlo relative std per parameter over the runs that have one (None: no run has)."""
    mcs = [r.practical.spread for r in runs if r.practical is not None and r.practical.spread is not None]
    rows = [
        [np.nan if p in mc.held else v for p, v in zip(params, mc.std)] for mc in mcs if len(mc.std)
    ]  # held at the guess: no spread to show
    if not rows:
        return None
    a = np.array(rows, float)
    return tuple(float(np.nanmean(c)) if np.isfinite(c).any() else float("nan") for c in a.T)


def _t2_misfit(s: FilterColumn) -> str:
    """Mean output misfit of the runs whose estimate could be simulated; the others are named."""
    ok = [v for v in s.misfits if np.isfinite(v)]
    bad = [seed for seed, v in zip(s.seeds, s.misfits) if not np.isfinite(v)]
    text = f"{np.mean(ok):.5f}" if ok else "-"
    if bad:
        text += f" (seed {', '.join(map(str, bad))}: the estimate cannot be simulated)"
    return text


def _t2_goal(s: FilterColumn, *, linearised: bool = False) -> str:
    if s.failed:
        return f"not met ({len(s.failed)} run(s) stopped: seed {', '.join(str(k) for k, _ in s.failed)})"
    worst = [(p, w) for p, w in zip(s.parameters, s.worst_abs_error) if not s.flagged(p, linearised=linearised)]
    bad = [f"{_T2_MD.get(p, p)} {w:.1f} %" for p, w in worst if w > 5.0]
    return _goal(bad, len(s.parameters) - len(worst), len(s.parameters))


def _goal(bad: list[str], flagged: int, total: int) -> str:
    """The 5 % goal over the unflagged parameters: never "met" when most parameters are flagged (not judged)."""
    if bad:
        return "not met (" + ", ".join(bad) + ")"
    if 2 * flagged > total:
        return f"not judged ({flagged} of {total} parameters flagged; the other {total - flagged} within 5 %)"
    return "met"


def _t2_tuning(t: _Tuning) -> str:
    gate = "off" if np.isinf(t.gate) else f"{t.gate:g}"
    return f"{t.s0:g}, {t.q_theta:g}, {t.q_x:g}, {gate}"


def _t2_kinds(s: FilterColumn) -> str:
    return ", ".join(f"{k} {v}" for k, v in s.interventions.items() if v) or "none"


def _ml_goal(ml: MLColumn) -> str:
    """The maximum-likelihood column's 5 % goal: met only on adequate, unflagged estimates of seeds that ran."""
    worst = [(p, w) for p, w in zip(ml.parameters, ml.worst_abs_error) if not ml.flagged(p)]
    bad = [f"{_T2_MD.get(p, p)} {w:.1f} %" for p, w in worst if not w <= 5.0]
    goal = _goal(bad, len(ml.parameters) - len(worst), len(ml.parameters))
    if ml.failed:
        goal = f"not met ({len(ml.failed)} refinement(s) could not run)"
    elif ml.inadequate:  # the estimates' std assume a right model: no goal is met without one
        goal = (
            f"not met (the model does not explain the data to the noise level on seed(s) "
            f"{', '.join(map(str, ml.inadequate))}: adequacy failed)"
        )
    return goal


def _worst_unflagged(s: FilterColumn | MLColumn) -> str:
    """The largest worst-seed error among a column's unflagged parameters, with its name."""
    rows = [(w, p) for p, w in zip(s.parameters, s.worst_abs_error) if not s.flagged(p) and np.isfinite(w)]
    if not rows:
        return "- (all flagged)"
    w, p = max(rows)
    return f"{w:.2f} % ({_T2_MD.get(p, p)})"


def _summary_rows(summ: Mapping[tuple[str, int], FilterColumn], ml: MLColumn | None, ml_passes: int) -> list[str]:
    """The compact summary: per protocol and filter (and the maximum-likelihood column), the worst error on the
    unflagged parameters, what is flagged, and the 5 % goal."""
    lines = [
        "| protocol | filter | worst error, unflagged (worst seed) | flagged | 5 % goal |",
        "|---|---|---|---|---|",
    ]
    for passes in sorted({k for _, k in summ}):
        for m in [m for m in _T2_METHODS if (m, passes) in summ]:
            s = summ[(m, passes)]
            flagged = ", ".join(_T2_MD.get(p, p) for p in s.parameters if s.flagged(p)) or "none"
            lines.append(
                f"| {_passes_title(passes)} | {_T2_METHODS[m]} | {_worst_unflagged(s)} | {flagged} | {_t2_goal(s)} |"
            )
        if ml and passes == ml_passes:
            flagged = ", ".join(_T2_MD.get(p, p) for p in ml.parameters if ml.flagged(p)) or "none"
            lines.append(
                f"| {_passes_title(passes)} | maximum likelihood | {_worst_unflagged(ml)} | "
                f"{flagged} | {_ml_goal(ml)} |"
            )
    return lines


def table2_found(doc: Table2Document) -> str:
    """What a reproduction found, in a few plain lines: per protocol and filter (and the maximum-likelihood column),
    the worst error on the unflagged parameters, what is flagged and the 5 % goal (the summary of
    :func:`table2_markdown`).

    Parameters
    ----------
    doc : Table2Document
        The reproduction (:class:`obsnl.studies.seed_reproduction.Reproduction`; a ``table2.json`` read back with
        its ``from_dict``).

    Returns
    -------
    str
    """
    summ = table2_summary(doc)
    ml = table2_ml_summary(doc)
    ml_passes = max(k for _, k in summ)
    lines = []
    for row in _summary_rows(summ, ml, ml_passes)[2:]:
        protocol, column, worst, flagged, goal = (c.strip() for c in row.strip("|").split(" | "))
        lines.append(f"{column}, {protocol}: worst unflagged error {worst}; flagged {flagged}; 5 % goal {goal}")
    return "\n".join(lines)


def table2_errors(doc: Table2Document) -> tuple[list[str], dict[str, list[float]], dict[str, list[bool]]]:
    """What :func:`obsnl.report.figures.table2_errors_figure` draws: the parameters, and per column (protocol and
    filter, and the maximum-likelihood column) the worst-seed error in % of each parameter and whether it is
    flagged."""
    summ = table2_summary(doc)
    ml = table2_ml_summary(doc)
    ml_passes = max(k for _, k in summ)
    params = list(next(iter(summ.values())).parameters)
    errors: dict[str, list[float]] = {}
    flags: dict[str, list[bool]] = {}
    for passes in sorted({k for _, k in summ}):
        tag = "1 pass" if passes == 1 else f"{passes} passes"
        for m in [m for m in _T2_METHODS if (m, passes) in summ]:
            s = summ[(m, passes)]
            errors[f"{_T2_METHODS[m]}, {tag}"] = [float(v) for v in s.worst_abs_error]
            flags[f"{_T2_METHODS[m]}, {tag}"] = [s.flagged(p) for p in params]
        if ml and passes == ml_passes:
            errors["ML"] = [float(v) for v in ml.worst_abs_error]
            flags["ML"] = [ml.flagged(p) for p in params]
    return [_T2_MD.get(p, p) for p in params], errors, flags


def _above_floor(doc: Table2Document, *, with_ml: bool) -> list[str]:
    """A paragraph naming the filters' reported runs that stayed above the noise floor with every configuration
    they tried (a document that states its floor only; none: nothing)."""
    floor = doc.noise_floor_factor
    if floor is None:
        return []
    line = floor * doc.experiment.noise_ratio
    seeds: dict[tuple[str, int], list[int]] = {}
    for r in doc.runs:
        if r.method != "dukf-zero" and not r.misfit <= line:  # NaN: the estimate cannot be simulated
            seeds.setdefault((r.method, r.passes), []).append(r.seed)
    if not seeds:
        return []
    named = "; ".join(
        f"{_T2_METHODS[m]}, {k} pass(es): seed(s) {', '.join(map(str, s))}" for (m, k), s in sorted(seeds.items())
    )
    return [
        f"Above the noise floor (the reported run's output misfit over {floor:g}x the noise level with every "
        f"configuration it tried): {named}. Such an estimate does not reproduce its data and is not the likelihood's "
        "optimum"
        + (
            "; the maximum-likelihood column (refined protocol), started on each seed from the better filter's "
            "estimate, is the result to read for these data."
            if with_ml
            else "."
        ),
        "",
    ]


def table2_markdown(doc: Table2Document) -> str:
    """The Table 2 analog as Markdown: a compact summary first (per protocol and filter: the worst error on the
    unflagged parameters, the flags, the goal), then one table per protocol (the refined one with the
    maximum-likelihood column) with costs, interventions and the refinement's verdict per seed, the flags, and the
    protocol last."""
    summ = table2_summary(doc)
    ml = table2_ml_summary(doc)
    ml_passes = max(k for _, k in summ)
    lines = _opening(doc, summ, ml, ml_passes)
    for passes in sorted({k for _, k in summ}):
        lines += _passes_section(doc, summ, passes, ml if passes == ml_passes else None)
    lines += _flag_counts(summ, ml)
    lines += _stopped_runs(doc)
    lines += _first_reasons(doc, summ)
    lines += ["", *_protocol(doc, ml, ml_passes)]
    return "\n".join(lines).rstrip("\n") + "\n"


def _opening(
    doc: Table2Document, summ: Mapping[tuple[str, int], FilterColumn], ml: MLColumn | None, ml_passes: int
) -> list[str]:
    """The heading, how to read the errors and the flags, the compact summary, and the runs above the noise
    floor."""
    exp = doc.experiment
    return [
        f"# Table 2 analog: {exp.model} under {exp.record.name}",
        "",
        "Errors are |estimate - true| / |true| in %, worst over the reported seeds; † = flagged practically "
        "unidentifiable (these data cannot pin it within 5 % at 3 sigma); `table2_errors.png` draws every "
        "column. The protocol is at the end.",
        "",
        *_summary_rows(summ, ml, ml_passes),
        "",
        *_above_floor(doc, with_ml=bool(ml)),
    ]


def _passes_section(
    doc: Table2Document, summ: Mapping[tuple[str, int], FilterColumn], passes: int, ml: MLColumn | None
) -> list[str]:
    """The section of one protocol (one pass, or ``passes`` over the record): its estimates, its filters' costs and
    goals, the runs redone with another configuration, and (``ml``: the refined protocol) the refinement's protocol
    and verdict per seed."""
    methods = [m for m in _T2_METHODS if (m, passes) in summ]
    lines = [f"## {_passes_title(passes)}", ""]
    lines += _estimates_table(doc, _columns(summ, methods, passes, ml), passes, summ[(methods[0], passes)])
    lines += ["", *_filters_table(summ, methods, passes)]
    lines += _redone(doc, summ, methods, passes)
    if ml:
        lines += ["", *_ml_markdown(doc, ml)]
    lines.append("")
    return lines


def _columns(
    summ: Mapping[tuple[str, int], FilterColumn], methods: Sequence[str], passes: int, ml: MLColumn | None
) -> list[tuple[str, FilterColumn | MLColumn]]:
    """One protocol's columns: the filters', the maximum likelihood's (``ml``: the refined protocol), DUKF-zero
    last."""
    columns: list[tuple[str, FilterColumn | MLColumn]] = [(m, summ[(m, passes)]) for m in methods if m != "dukf-zero"]
    columns += [("ml", ml)] if ml else []
    columns += [(m, summ[(m, passes)]) for m in methods if m == "dukf-zero"]
    return columns


def _estimates_table(
    doc: Table2Document, columns: Sequence[tuple[str, FilterColumn | MLColumn]], passes: int, first: FilterColumn
) -> list[str]:
    """One protocol's estimates: per parameter the truth, the guess and each column's mean estimate, mean and
    worst ``|error|`` (the ML column's mean std too; the paper's errors after one pass), then the yield
    displacements where every column has them (``first``: the first filter's column)."""
    exp = doc.experiment
    head = "| parameter | true | guess | " + " | ".join(
        "ML mean est. | ML mean % | ML worst % | ML std %"
        if m == "ml"
        else f"{_T2_METHODS[m]} mean est. | {_T2_METHODS[m]} mean % | {_T2_METHODS[m]} worst %"
        for m, _ in columns
    )
    head += " | paper UKF % | paper DUKF % |" if passes == 1 else " |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for i, p in enumerate(first.parameters):
        cells = [_T2_MD.get(p, p), f"{exp.truth[p]:.4g}", f"{exp.guess[p]:.4g}"]
        for _, c in columns:
            mark = " †" if c.flagged(p) else ""
            cells += [
                _num(c.mean_estimate[i], ".4g"),
                _num(c.mean_abs_error[i], ".2f") + mark,
                _num(c.worst_abs_error[i], ".2f") + mark,
            ]
            if isinstance(c, MLColumn):
                cells.append(_num(c.mean_std_percent[i], ".3g", inf="flat"))
        if passes == 1:
            cells += [f"{doc.paper_errors['ukf'][p]:.2f}", f"{doc.paper_errors['dukf'][p]:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    if all(c.yield_errors for _, c in columns):  # what the ridge leaves informed
        lines += _yield_rows(columns, passes, first)
    return lines


def _yield_rows(columns: Sequence[tuple[str, FilterColumn | MLColumn]], passes: int, first: FilterColumn) -> list[str]:
    """The estimates table's last rows: per Delta the true yield displacement and each column's mean and worst
    ``|error|`` ("-": no seed ran to the end)."""
    lines = []
    for d in ("Delta1", "Delta2"):
        true = _ridge(first)[d][0]
        cells = [f"abs({_T2_MD[d]})^(-1/2N) (yield displ.)", f"{true:.4g}", "-"]
        for m, c in columns:
            e = np.asarray(_ridge(c)[d][1], float)
            mean_worst = [f"{np.nanmean(e):.2f}", f"{np.nanmax(e):.2f}"] if np.isfinite(e).any() else ["-", "-"]
            cells += ["-", *mean_worst] + (["-"] if m == "ml" else [])
        if passes == 1:
            cells += ["-", "-"]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def _filters_table(summ: Mapping[tuple[str, int], FilterColumn], methods: Sequence[str], passes: int) -> list[str]:
    """One protocol's filters: the tuning reported, the cost, the repairs and interventions, the output misfit and
    the 5 % goal (with all flags and with the linearised ones alone)."""
    lines = [
        "| filter | tuning (s0, q_theta, q_x, gate) | s per run | s per pass | repairs | interventions "
        "(all seeds) | implicit sigma-point steps | output misfit | 5 % goal (worst seed, unflagged) "
        "| 5 % goal, linearised flags only |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for m in methods:
        s = summ[(m, passes)]
        lines.append(
            f"| {_T2_METHODS[m]} | {_t2_tuning(s.tuning)} | {s.seconds:.3f} | "
            f"{s.seconds_per_pass:.3f} | {s.repairs} | {_t2_kinds(s)} | {s.implicit} | "
            f"{_t2_misfit(s)} | {_t2_goal(s)} | {_t2_goal(s, linearised=True)} |"
        )
    return lines


def _redone(
    doc: Table2Document, summ: Mapping[tuple[str, int], FilterColumn], methods: Sequence[str], passes: int
) -> list[str]:
    """One protocol's runs reported with another configuration than the tuning's first choice: the document's rule,
    then per run the configurations tried (misfit, why it stopped) and the one reported; none: nothing."""
    redone = [(m, r) for m in methods for r in summ[(m, passes)].redone]
    if not redone:
        return []
    factor = doc.diverged_factor
    floor = doc.noise_floor_factor  # None: a document of the former rule (redone when diverged)
    lines = [
        "",
        f"Redone (the run diverged: it stopped or its output misfit was above {factor:g}x the "
        "noise level; the next configuration of the tuning ranking was run instead):"
        if floor is None
        else f"Chosen on the seed's own data (the tuning's first choice left an output misfit above "
        f"{floor:g}x the noise level or stopped: the next configurations of the tuning ranking ran on "
        f"the same data, at most {doc.fallbacks} more, and the smallest misfit is reported):",
        "",
    ]
    for m, (seed, attempts, final) in redone:
        tried = "; ".join(
            f"({_t2_tuning(a.tuning)}) misfit "
            + (f"{a.misfit:.3g}" if np.isfinite(a.misfit) else "inf")
            + (f", {a.error}" if a.error else "")
            for a in attempts
        )
        lines.append(f"- {_T2_METHODS[m]}, seed {seed}: {tried} -> ({_t2_tuning(final)})")
    return lines


def _flag_counts(summ: Mapping[tuple[str, int], FilterColumn], ml: MLColumn | None) -> list[str]:
    """The flags counted over the seeds per filter and protocol (with the runs not decided and the mean
    Monte-Carlo spread), and the maximum-likelihood column's."""
    lines = ["## Practically unidentifiable (flag counts over seeds)", ""]
    for (m, k), s in sorted(summ.items()):
        undecided = "".join(f"; not decided on seed {seed}: {why}" for seed, why in s.undecided)
        spread = (
            "; Monte-Carlo std (mean over seeds) "
            + ", ".join(
                f"{_T2_MD.get(p, p)} " + (f"{100 * v:.2g} %" if np.isfinite(v) else "held")
                for p, v in zip(s.parameters, s.spread)
            )
            if s.spread
            else ""
        )
        lines.append(f"- {_T2_METHODS[m]}, {k} pass(es): {_counted(s)}{undecided}{spread}")
    if ml:
        lines.append(f"- ML (std above {_ML_PIN:.3g} %): {_counted(ml)}")
    return lines


def _counted(c: FilterColumn | MLColumn) -> str:
    """A column's flagged parameters, each with the seeds it is flagged on out of the column's; ``none``."""
    return ", ".join(f"{_T2_MD.get(p, p)} {n}/{len(c.seeds)}" for p, n in c.flag_counts.items() if n) or "none"


def _stopped_runs(doc: Table2Document) -> list[str]:
    """The reported runs that stopped, each with its error (none: nothing)."""
    stopped = [r for r in doc.runs if r.error]
    if not stopped:
        return []
    return [
        "",
        "## Runs that stopped (reported, not dropped)",
        "",
        *(f"- {_T2_METHODS[r.method]}, {r.passes} pass(es), seed {r.seed}: {r.error}" for r in stopped),
    ]


def _first_reasons(doc: Table2Document, summ: Mapping[tuple[str, int], FilterColumn]) -> list[str]:
    """Per protocol, why the first judged UKF run flagged a parameter or left it undecided (none: nothing)."""
    lines: list[str] = []
    for k in sorted({k for m, k in summ if m == "ukf"}):
        first = next((r.practical for r in doc.runs if r.method == "ukf" and r.passes == k and r.practical), None)
        if first is not None and (first.reasons or first.undecided):
            lines += ["", f"Reasons (first seed of the UKF, {k} pass(es)):", ""]
            lines += [f"- {_T2_MD.get(p, p)}: {why}" for p, why in first.reasons.items()]
            lines += [f"- {_T2_MD.get(p, p)}: not decided, {why}" for p, why in first.undecided.items()]
    return lines


def _protocol(doc: Table2Document, ml: MLColumn | None, ml_passes: int) -> list[str]:
    """The section "Protocol", last: the noise, the branch table and the tuning, what the errors, the flags and the
    goal columns mean, and where the ML column comes from."""
    exp = doc.experiment
    return [
        "## Protocol",
        "",
        f"Noise {100 * exp.noise_ratio:g} % (RMS) on input and output; branch table: {doc.table_source}; "
        f"tuning seeds {list(doc.tuning_seeds)} (never reported)"
        + (f"; tuning by {doc.tuning_protocol}" if doc.tuning_protocol else "")
        + ". Errors are |estimate - true| / |true| in %; "
        "mean and worst over the reported seeds that ran to the end. † = flagged practically unidentifiable "
        "in at least half of the seeds: these data cannot pin it within 5 % at 3 sigma, by the linearised "
        "Cramér-Rao bound, the filter's posterior or the Monte-Carlo spread of the protocol at the estimate "
        "(see the flags below). The goal column is given with all flags and with the linearised ones alone."
        + (
            f" ML = the maximum-likelihood refinement of each reported seed: the third column of the table "
            f"of {ml_passes} passes, which it starts from (its protocol and verdict per seed below that table)."
            if ml
            else ""
        ),
        "",
    ]


def _passes_title(passes: int) -> str:
    return "one pass (the paper's protocol)" if passes == 1 else f"{passes} passes over the record"


def _num(v: float | None, fmt: str, *, inf: str = "-") -> str:
    """A number in ``fmt``; ``-`` for a missing one, ``inf`` for an infinite one."""
    if v is None or np.isnan(v):
        return "-"
    return inf if np.isinf(v) else format(v, fmt)


def _ridge(c: FilterColumn | MLColumn) -> YieldErrors:
    """The yield displacements' errors of a column that has them."""
    assert c.yield_errors is not None  # the callers render the ridge rows only where every column has them
    return c.yield_errors


def _ml_markdown(doc: Table2Document, ml: MLColumn) -> list[str]:
    """The refinement's protocol, its verdict per seed, and its goals."""
    n = len(ml.runs)
    within, of = ml.within_4_std
    goal = _ml_goal(ml)
    lines = [
        f"ML column: {doc.refinement_protocol or 'maximum likelihood'}. † in the ML column: its std "
        "(the Fisher information's, the measured input's noise propagated) is above "
        f"{_ML_PIN:.3g} % of the estimate on at least half of the seeds (the 5 % band cannot be "
        f"reached at 3 sigma; 'flat': no information at all). Converged on {len(ml.converged)} of {n} "
        f"seed(s); 5 % goal (worst seed, unflagged): {goal}; unflagged estimates within 4 std (or 1 %) "
        f"of the truth: {within} of {of}.",
        "",
        "| seed | started from (its output misfit) | iterations | s | residual RMS / noise | converged | reason |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in ml.runs:
        st = r.start
        start = f"{_T2_METHODS.get(st.method, st.method)}, {st.passes} pass(es) ({_num(st.misfit, '.3g')})"
        fit = ", ".join(f"{k} {_num(v, '.3f')}" for k, v in r.misfit_over_noise.items()) or "-"
        verdict = "could not run" if r.error else ("yes" if r.converged else "NO")
        why = (r.error or r.reason or "").replace("|", "/")
        if r.at_edge:
            why += f" (on the edge of the valid region: {', '.join(r.at_edge)})"
        if r.adequacy is not None and r.adequacy.passed is False:
            why += "; NOT adequate: the model does not explain the data to the noise level"
        lines.append(f"| {r.seed} | {start} | {r.iterations} | {_num(r.seconds, '.1f')} | {fit} | {verdict} | {why} |")
    return lines


def table2_latex(doc: Table2Document) -> str:
    """The Table 2 analog as a booktabs LaTeX table (one pass and refined, UKF and DUKF, worst seed; then the
    maximum-likelihood refinement: mean and worst error, mean std)."""
    summ = table2_summary(doc)
    ml = table2_ml_summary(doc)
    exp = doc.experiment
    keys = [k for k in sorted(summ, key=lambda k: (k[1], k[0])) if k[0] in ("ukf", "dukf")]
    blocks: list[FilterColumn | MLColumn] = [summ[k] for k in keys] + ([ml] if ml else [])
    ridge = all(b.yield_errors for b in blocks)
    cols = "l" + "r" * (2 + 2 * len(keys) + (3 if ml else 0))
    head = (
        " & ".join(
            ["", "true", "guess"]
            + [rf"\multicolumn{{2}}{{c}}{{{_T2_METHODS[m]}, {k} pass{'es' if k > 1 else ''}}}" for m, k in keys]
            + ([r"\multicolumn{3}{c}{ML}"] if ml else [])
        )
        + r" \\"
    )
    sub = (
        " & ".join(
            ["", "", ""] + ["mean \\%", "worst \\%"] * len(keys) + (["mean \\%", "worst \\%", "std \\%"] if ml else [])
        )
        + r" \\"
    )
    rows = []
    for i, p in enumerate(summ[keys[0]].parameters):
        cells = [_T2_TEX.get(p, p), f"{exp.truth[p]:.3g}", f"{exp.guess[p]:.3g}"]
        for b in blocks:
            mark = r"$^\dagger$" if b.flagged(p) else ""
            cells += [_num(b.mean_abs_error[i], ".2f") + mark, _num(b.worst_abs_error[i], ".2f") + mark]
        if ml:
            cells.append(_num(ml.mean_std_percent[i], ".2g", inf="flat"))
        rows.append(" & ".join(cells) + r" \\")
    if ridge:  # the combinations the Delta-N ridge leaves informed
        rows.append(r"\midrule")
        for d in ("Delta1", "Delta2"):
            true = _ridge(summ[keys[0]])[d][0]
            cells = [rf"$|{_T2_TEX[d].strip('$')}|^{{-1/2N}}$", f"{true:.3g}", "--"]
            for b in blocks:
                e = _ridge(b)[d][1]
                cells += [f"{np.nanmean(e):.2f}", f"{np.nanmax(e):.2f}"]
            rows.append(" & ".join(cells + (["--"] if ml else [])) + r" \\")
    ml_text = ""
    if ml:
        st = {r.start.passes for r in ml.runs}
        ml_text = (
            rf"; ML: maximum likelihood (output error) started on each seed from the better "
            rf"{'/'.join(map(str, sorted(st)))}-pass filter estimate (smaller output misfit), std from the "
            rf"Fisher information with the input's noise propagated, converged on {len(ml.converged)} of "
            rf"{len(ml.runs)} seeds, "
            rf"$^\dagger$ there: std above 5/3\,\%"
        )
    return (
        "\n".join(
            [
                r"\begin{table}[ht]",
                r"\centering",
                rf"\caption{{Table 2 analog ({tex_escape(exp.record.name)}, {100 * exp.noise_ratio:g}\,\% noise, "
                rf"{len(summ[keys[0]].seeds)} seeds). $^\dagger$ practically unidentifiable on this record"
                + ml_text
                + (
                    r"; last rows: the yield displacements $|\Delta_i|^{-1/2N}$, which the record pins along the "
                    r"$\Delta$--$N$ ridge"
                    if ridge
                    else ""
                )
                + ".}",
                rf"\begin{{tabular}}{{{cols}}}",
                r"\toprule",
                head,
                sub,
                r"\midrule",
                *rows,
                r"\bottomrule",
                r"\end{tabular}",
                r"\end{table}",
            ]
        )
        + "\n"
    )
