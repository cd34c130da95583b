"""The seed paper's identification experiment end to end: ``obsnl reproduce``.

Analysis -> branch table -> UKF and DUKF tuned on unreported noise seeds by successive halving
(:func:`successive_halving`: every configuration of the grid on the first tuning seed, the best
``HALVING_KEEP`` of each protocol on the others; the same procedure for both filters) -> reported runs on
noise seeds ``0..seeds-1`` -> the maximum-likelihood refinement of each reported seed, started from the
estimate of the filter (UKF or DUKF, refined protocol) whose free-run output misfit on that seed is the
smaller -> the Table 2 analog (``table2.json``; text in :mod:`obsnl.report.identification`) and Figures 2-3
(:mod:`obsnl.report.figures`). Protocol details in :mod:`obsnl.identification.experiments` and
:mod:`obsnl.identification.likelihood`. Nothing here uses the true values except to score the reported runs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from obsnl.estimation.records import Record
from obsnl.identification.experiments import (DEFAULT_GRID, DIVERGED, Setup, Tuning, make_data, mc_spread)
from obsnl.executor import Executor
from obsnl.studies.seed_tasks import (FALLBACKS, ML_MAX_ITER, SEED_GUESS, Refined, RunResult, Spec, compile_task,
                                      context, late_task, reported_task, reported_with_fallbacks, seed_model_path,
                                      seed_setup, tuning_task)
from obsnl.identification.runs import check_replicates
from obsnl.identification.replicates import CHUNK
from obsnl.estimation.ukf import Trajectory

__all__ = ["RunResult", "Refined", "Reproduction", "seed_model_path", "seed_setup", "seed_branch_table", "reproduce",
           "write_reproduction", "reproduction_files", "SEED_GUESS", "PAPER_ERRORS", "TUNING_SEEDS", "reported_with_fallbacks",
           "successive_halving", "HALVING_KEEP"]

#: Errors (%) the seed paper reports in Table 2.
PAPER_ERRORS: Mapping[str, Mapping[str, float]] = {
    "dukf": {"k_m": 0.55, "c_dm": 0.01, "c_eta_p": 8.33, "c_p": 17.62, "h_p": 1.99, "N": 0.02, "w_h": 10.54,
             "Delta1": 11.39, "Delta2": 0.20},
    "ukf": {"k_m": 4.14, "c_dm": 0.02, "c_eta_p": 5.47, "c_p": 106.48, "h_p": 13.67, "N": 1.28, "w_h": 7.62,
            "Delta1": 13.93, "Delta2": 15.30},
}


#: Noise seeds of the tuning (never reported): 1000, 1001, ...; five by default.
TUNING_SEEDS = 1000
#: Monte-Carlo replicates per reported run of the UKF and the DUKF (:func:`obsnl.identification.experiments.monte_carlo`);
#: replicate noise seeds ``[MC_SEEDS + seed, b]``, disjoint from the reported and tuning seeds.
REPLICATES = 32
MC_SEEDS = 5000
#: Monte-Carlo replicates per task of the executor (any split gives the same replicates): the
#: same chunk as ``identify --replicates``.
MC_CHUNK = CHUNK
#: Successive halving of the tuning: after the first tuning seed, the best ``HALVING_KEEP`` configurations of
#: each protocol (one pass, and ``passes``) go on to the other tuning seeds (one rung, a quarter of the
#: 48-configuration grid per protocol; the union of the two protocols' survivors runs). The maximum-likelihood
#: refinement starts from the tuned filter's estimate and needs only its basin, which the survivors reach.
HALVING_KEEP = 12
#: The quick form of the main job (``obsnl reproduce --quick``, under a minute on two cores with a cold cache of
#: compiled filters): the first 300 samples, one reported and one tuning seed, no Monte-Carlo replicates. Its
#: Table 2 says little (most parameters are flagged on 3 s of record): it checks that the pipeline runs.
QUICK: dict[str, int] = {"samples": 300, "seeds": 1, "tuning_seeds": 1, "replicates": 0}


@dataclass(frozen=True, eq=False)
class Reproduction:
    """Result of :func:`reproduce`: tuning, every reported run, trajectories of the first seed."""

    setup: Setup
    table: Any
    table_source: str
    tuning: Mapping[tuple[str, int], tuple[Tuning, Mapping[Tuning, float]]]
    runs: tuple[RunResult, ...]
    trajectories: Mapping[tuple[str, int], tuple[Trajectory, ...]] = field(repr=False)
    tuning_seeds: tuple[int, ...] = ()
    compile_seconds: Mapping[str, float] = field(default_factory=dict)
    refinements: tuple[Refined, ...] = ()
    tuning_runs: Mapping[tuple[str, Tuning, int], int] = field(default_factory=dict)  # seeds per configuration, protocol
    halving_keep: int | None = None

    def to_dict(self) -> dict[str, Any]:
        s = self.setup
        n_grid = len({t for _, t, _ in self.tuning_runs})
        return {
            "experiment": s.to_dict(), "branch_table": self.table_source, "tuning_seeds": list(self.tuning_seeds),
            "tuning_protocol": _tuning_protocol(self.halving_keep, n_grid, len(self.tuning_seeds),
                                                sum(v for (_, _, k), v in self.tuning_runs.items() if k == 1)),
            "tuning": [{"method": m, "passes": k, "chosen": t.to_dict(),
                        "scores": [{**g.to_dict(), "misfit": v, "seeds": self.tuning_runs.get((m, g, k))}
                                   for g, v in sc.items()]}
                       for (m, k), (t, sc) in self.tuning.items()],
            "compile_seconds": dict(self.compile_seconds), "diverged_factor": DIVERGED, "fallbacks": FALLBACKS,
            "paper_errors_percent": {k: dict(v) for k, v in PAPER_ERRORS.items()},
            "runs": [r.to_dict(s.model.parameters, s.theta_true) for r in self.runs],
            "refinement_protocol": ML_PROTOCOL if self.refinements else None,
            "refinements": [r.to_dict(s.model.parameters, s.theta_true) for r in self.refinements],
        }


#: How the third column of Table 2 is made (written into ``table2.json``).
ML_PROTOCOL = ("maximum likelihood of the measured output given the measured input (output error, single shooting: "
               "obsnl.identification.refine.refine), started on each reported seed from the estimate of the "
               "filter (UKF or DUKF, refined protocol) whose free-run output misfit on that seed is the smaller (no "
               "true value used); every parameter free (none held), the initial state estimated; Levenberg-Marquardt "
               f"with exact derivatives, at most {ML_MAX_ITER} iterations per weighting; std from the Fisher "
               "information at the estimate (no profile likelihood: too slow for the main job); converged only when "
               "the first-order condition holds and the last step moved no parameter by more than 0.1 std")


def _tuning_protocol(keep: int | None, n_grid: int, n_seeds: int, n_runs: int) -> str:
    """One sentence on how the configurations were chosen."""
    if keep is None or keep >= n_grid or n_seeds < 2:
        return (f"full grid: {n_grid} configurations x {n_seeds} tuning seed(s) per filter ({n_runs} runs); the smallest "
                f"mean free-run output misfit wins")
    return (f"successive halving: {n_grid} configurations on the first tuning seed, the best {keep} of each protocol "
            f"(one pass, refined) on the other {n_seeds - 1}, each as far as the protocols it was kept for ({n_runs} "
            f"runs for both filters); per protocol, the smallest mean free-run output misfit over the tuning seeds "
            f"wins among the configurations that ran on all of them")


def successive_halving(names: Sequence[str], grid: Sequence[Tuning], seeds: Sequence[int],
                       run: Any, *, keep: int | None, protocols: Sequence[int]
                       ) -> tuple[dict[tuple[str, int], tuple[list[Tuning], dict[Tuning, float]]],
                                  dict[tuple[str, Tuning, int], int]]:
    """Tune each filter by one rung of successive halving: every configuration on ``seeds[0]`` scored for every
    protocol, then the best ``keep`` of each protocol on the other seeds, each run only as far as the protocols it
    goes on for (a configuration kept for the one-pass protocol alone runs one pass there).

    Parameters
    ----------
    names : sequence of str
        The filters.
    grid : sequence of Tuning
        The configurations.
    seeds : sequence of int
        Tuning noise seeds (the first one screens).
    run : callable
        ``run([(name, tuning, seed, passes), ...]) -> [{protocol: misfit}, ...]``, a run of ``passes`` passes
        giving the misfit of every protocol up to ``passes`` (in one batch: the executor's map).
    keep : int or None
        Survivors per protocol (None, or at least ``len(grid)``: the full grid on every seed).
    protocols : sequence of int
        The protocols scored (passes: 1 and the refined protocol's).

    Returns
    -------
    tuple
        ``({(name, protocol): (ranking, scores)}, {(name, tuning, protocol): seeds run})``: per protocol, the
        configurations that ran on the most seeds first, each group by its mean misfit (ties: grid order); the
        first of the ranking is the chosen one, the next ones are the fallbacks of a diverged reported run.

    Examples
    --------
    >>> g = [Tuning(s, 0.0, 1.0) for s in (0.1, 0.2, 0.3)]
    >>> misfit = {(0.1, 0): 1.0, (0.2, 0): 2.0, (0.3, 0): 3.0, (0.1, 1): 5.0, (0.2, 1): 0.0, (0.3, 1): 0.0}
    >>> fake = lambda tasks: [{1: misfit[(t.s0, s)]} for _, t, s, _ in tasks]
    >>> ranks, runs = successive_halving(["ukf"], g, [0, 1], fake, keep=2, protocols=[1])
    >>> [t.s0 for t in ranks[("ukf", 1)][0]], runs[("ukf", g[2], 1)]   # 0.3 was screened out on seed 0
    ([0.2, 0.1, 0.3], 1)
    """
    got: dict[tuple[str, Tuning, int], Mapping[int, float]] = {}
    last = max(protocols)

    def rung(tasks: list[tuple[str, Tuning, int, int]]) -> None:
        got.update(((n, t, s), v) for (n, t, s, _), v in zip(tasks, run(tasks)))

    def scored(name: str, t: Tuning, k: int) -> list[float]:
        return [v[k] for (n, t_, _), v in got.items() if n == name and t_ == t and k in v]

    order = {t: i for i, t in enumerate(grid)}
    rung([(n, t, seeds[0], last) for n in names for t in grid])
    if len(seeds) > 1:
        later = []
        for n in names:
            goes_on = {t: last for t in grid}  # passes each configuration runs on the other seeds
            if keep is not None and keep < len(grid):
                goes_on = {}
                for k in protocols:
                    for t in sorted(grid, key=lambda t: (float(np.mean(scored(n, t, k))), order[t]))[:keep]:
                        goes_on[t] = max(goes_on.get(t, 0), k)
            later += [(n, t, s, goes_on[t]) for t in grid if t in goes_on for s in seeds[1:]]
        rung(later)
    runs = {(n, t, k): len(scored(n, t, k)) for n in names for t in grid for k in protocols}
    out = {}
    for n in names:
        for k in protocols:
            scores = {t: float(np.mean(scored(n, t, k))) for t in grid}
            out[(n, k)] = (sorted(grid, key=lambda t: (-runs[(n, t, k)], scores[t], order[t])), scores)
    return out, runs


def rate_from_here(progress: Any) -> None:
    """Measure a tqdm bar's rate (and so its estimate of the time left) from now on.

    A tqdm bar takes its rate from the time since its last update: before the first run that time
    includes the analysis and the building of the filters (20 s or more), and the first estimate
    said hours where the runs take minutes. Other progress objects are left alone.

    Parameters
    ----------
    progress : tqdm-like or None
        The bar.

    Examples
    --------
    >>> import io
    >>> from tqdm import tqdm
    >>> bar = tqdm(total=10, file=io.StringIO(), mininterval=0.0)
    >>> now = [bar.start_t + 20.0]             # a clock of our own: the build took 20 s
    >>> bar._time = lambda: now[0]
    >>> rate_from_here(bar)
    >>> now[0] += 0.5                          # one run half a second later
    >>> _ = bar.update(1)
    >>> round(bar.format_dict["rate"], 6)      # 2 runs/s, not 1 run in 20.5 s
    2.0
    >>> bar.close()                            # closed while our clock still exists
    """
    if progress is not None and hasattr(progress, "last_print_t") and callable(getattr(progress, "_time", None)):
        progress.last_print_t, progress.last_print_n = progress._time(), progress.n


def seed_branch_table(*, seed: int = 0) -> tuple[Any, str]:
    """The branch table of the seed model from obsnl's analysis, checked against the paper's Table 1."""
    from obsnl.observability.analyze import analyze
    from obsnl.model.files import read_model
    from obsnl.observability.contract.branch_table import BranchTable

    model = read_model(seed_model_path())
    table = BranchTable.from_result(analyze(model, seed=seed))
    paper = {1: {"Delta2"}, -1: {"Delta1", "w_h"}}  # Table 1: by the sign of (r - eta') x2
    agrees = all(set(b.unidentifiable_parameters) == paper[b.signs[0] * b.signs[1]] for b in table.branches)
    source = (f"obsnl analysis ({table.method}, seed {seed}); "
              f"{'agrees with' if agrees else 'DIFFERS from'} the seed paper's Table 1")
    return table, source


def reproduce(*, record: Record | None = None, seeds: int = 5, tuning_seeds: int = 5, passes: int = 3,
              grid: Sequence[Tuning] = DEFAULT_GRID, jit: bool = True, samples: int | None = None,
              replicates: int = REPLICATES, progress: Any = None, executor: Executor | None = None,
              keep: int | None = HALVING_KEEP, refine: bool = True) -> Reproduction:
    """Table 2 of the seed paper with obsnl's UKF and DUKF and the maximum-likelihood refinement (module
    docstring for the protocol).

    Parameters
    ----------
    record : Record or None
        Another ground motion (default: Northridge 1994, the paper's record).
    seeds, tuning_seeds : int
        Reported noise seeds ``0..seeds-1``; tuning seeds ``1000..`` (never reported; five by default,
        decided before any reported seed was looked at). A reported run that diverged (it stopped, or
        its free-run output misfit is above ``DIVERGED`` times the output noise level) is redone with
        the next configuration of the tuning ranking, at most ``FALLBACKS`` times; the discarded
        attempts are kept in the run's ``redone`` list.
    passes : int
        Passes of the refined protocol (the paper's protocol is one pass).
    grid : sequence of Tuning
        Tuning configurations.
    jit : bool
        Compile the filters to C (cached on disk: :mod:`obsnl.estimation.jitcache`).
    samples : int or None
        Use only the first samples of the record (quick runs).
    replicates : int
        Monte-Carlo replicates of the practical-identifiability check per reported run of the UKF and
        the DUKF that did not diverge (0: off; the ablation ``dukf-zero`` gets none).
    progress : Any
        A tqdm-like object (``total``, ``update(n)``) or None.
    executor : Executor or None
        Where the independent runs go (:class:`obsnl.executor.Executor`; default: this process).
        Every run's noise is fixed by its own seeds: the result does not depend on the executor.
    keep : int or None
        Configurations per protocol that go on after the first tuning seed (:func:`successive_halving`;
        None: the full grid on every tuning seed, the protocol before issue 27).
    refine : bool
        Refine each reported seed by maximum likelihood (the third column of Table 2).
    """
    check_replicates(replicates)
    executor = executor or Executor(workers=1)
    t_seeds = tuple(range(TUNING_SEEDS, TUNING_SEEDS + tuning_seeds))
    protocols = sorted({1, passes})
    names = ("ukf", "dukf")
    n_tuning = len(names) * (len(grid) + (tuning_seeds - 1) * min(len(grid), len(protocols) * (keep or len(grid))))
    if progress is not None:  # known before anything is built (the tuning at most): the bar shows from the start
        progress.total = (n_tuning + seeds * (len(names) + 1) * len(protocols) + (seeds if refine else 0)
                          + replicates * seeds * len(names) * len(protocols))
        progress.refresh() if hasattr(progress, "refresh") else None
    stage = (lambda text: progress.set_postfix_str(text)) if hasattr(progress, "set_postfix_str") else (lambda text: None)
    stage("analysis")
    table, source = seed_branch_table()
    spec = Spec(record=record, samples=samples, jit=jit, table_json=table.to_json())
    stage("building the experiment")
    ctx = context(spec)  # the workers build the same from the spec
    setup, filters = ctx["setup"], ctx["filters"]
    tick = (lambda i, r, n=1: progress.update(n)) if progress is not None else None
    with executor.session() as session:
        # each filter compiled once into the disk cache, the three at once on the workers (a fresh machine)
        stage(f"building the filters ({', '.join(filters)}; from the disk cache, else compiled once: ~15 s each)")
        compile_seconds = dict(zip(filters, session.map(compile_task, [(spec, name) for name in filters])))
        stage(f"tuning ({executor.kind})")
        rate_from_here(progress)  # the estimate of the time left counts from the first run, not the build
        ranked, tuning_runs = successive_halving(
            names, grid, t_seeds, lambda tasks: session.map(tuning_task, [(spec, *task) for task in tasks], done=tick),
            keep=keep, protocols=protocols)
        if progress is not None:  # the survivors are known: the bar's total is exact now
            progress.total -= n_tuning - sum(v for (_, _, k), v in tuning_runs.items() if k == protocols[0])
            progress.refresh() if hasattr(progress, "refresh") else None
        chosen = {key: (ranking[0], scores) for key, (ranking, scores) in ranked.items()}
        stage(f"reported runs ({executor.kind})")
        rtasks = []
        for name in (*names, "dukf-zero"):
            for k in protocols:
                ranking = ranked[("dukf" if name == "dukf-zero" else name, k)][0]
                rtasks += [(spec, name, k, seed, tuple(ranking), FALLBACKS) for seed in range(seeds)]
        reported = session.map(reported_task, rtasks, done=tick)
        stage(f"maximum likelihood and Monte-Carlo replicates ({executor.kind})" if refine
              else f"Monte-Carlo replicates ({executor.kind})")
        ltasks: list[tuple[str, tuple]] = [("refine", _refine_task(spec, seed, rtasks, reported, names, passes))
                                           for seed in range(seeds)] if refine else []
        owners = [-1] * len(ltasks)
        for j, ((_, name, k, seed, _, _), (result, _)) in enumerate(zip(rtasks, reported)):
            if not (replicates and name in names):
                continue
            if result.practical is None or result.practical.inconclusive:
                if progress is not None:
                    progress.update(replicates)
                continue
            for lo in range(0, replicates, MC_CHUNK):
                ltasks.append(("replicates", (spec, name, seed, result.theta, result.tuning, k, MC_SEEDS + seed,
                                              tuple(range(lo, min(replicates, lo + MC_CHUNK))))))
                owners.append(j)
        late = session.map(late_task, ltasks, done=(lambda i, r: progress.update(
            1 if ltasks[i][0] == "refine" else len(ltasks[i][1][-1]))) if progress is not None else None)
    refinements = tuple(r for (kind, _), r in zip(ltasks, late) if kind == "refine")
    mc = [r for (kind, _), r in zip(ltasks, late) if kind == "replicates"]
    owners = [j for j in owners if j >= 0]
    runs, trajs = [], {}
    for j, ((_, name, k, seed, _, _), (result, trs)) in enumerate(zip(rtasks, reported)):
        outcomes = [o for i, o in zip(owners, mc) if i == j]
        if any(i == j for i in owners):
            flat = [o for chunk in outcomes for o in chunk]
            spread = mc_spread(setup, flat, replicates=replicates, seed=MC_SEEDS + seed, simulated=bool(flat))
            result = replace(result, practical=result.practical.with_spread(spread))
        runs.append(result)
        if seed == 0 and trs is not None:
            trajs[(name, k)] = trs
    stage("done")
    return Reproduction(setup=setup, table=table, table_source=source, tuning=chosen, runs=tuple(runs),
                        trajectories=trajs, tuning_seeds=t_seeds, compile_seconds=compile_seconds,
                        refinements=refinements, tuning_runs=tuning_runs, halving_keep=keep)


def _refine_task(spec: Spec, seed: int, rtasks: Sequence[tuple], reported: Sequence[tuple], names: Sequence[str],
                 passes: int) -> tuple[Spec, int, tuple[float, ...], dict[str, Any]]:
    """The refinement of reported seed ``seed``: from the estimate of the filter (``names``, ``passes`` passes)
    whose free-run output misfit on that seed is the smaller (data only; a run that stopped is not a start)."""
    cands = [(result.misfit, names.index(name), result) for (_, name, k, s, _, _), (result, _) in zip(rtasks, reported)
             if s == seed and k == passes and name in names and not result.failed and np.isfinite(result.misfit)]
    if not cands:  # no estimate that can be simulated: start from the guesses (said in ``start``)
        return spec, seed, tuple(map(float, context(spec)["setup"].theta_guess)), {"method": "guess", "passes": 0, "output_misfit": None}
    misfit, _, best = min(cands, key=lambda c: (c[0], c[1]))
    return spec, seed, best.theta, {"method": best.method, "passes": best.passes, "output_misfit": float(misfit)}


#: The text files a reproduction writes (the figures ``fig2_*.png``, ``fig3_*.png`` come on top).
REPRODUCTION_FILES: tuple[str, ...] = ("table2.json", "table2.md", "table2.tex", "branch_table.json")


def reproduction_files(rep: Reproduction) -> list[str]:
    """The files :func:`write_reproduction` writes for ``rep``: :data:`REPRODUCTION_FILES`, then
    ``fig2_<tag>.png`` and ``fig3_<tag>.png`` per protocol with trajectories (``1pass``, ``3passes``, ...)."""
    names = list(REPRODUCTION_FILES)
    for k in sorted({k for _, k in rep.trajectories}):
        if any((m, k) in rep.trajectories for m in ("ukf", "dukf")):
            tag = "1pass" if k == 1 else f"{k}passes"
            names += [f"fig2_{tag}.png", f"fig3_{tag}.png"]
    return names


def write_reproduction(rep: Reproduction, out: str | Path, *, force: bool = True) -> list[Path]:
    """Write ``table2.json/.md/.tex``, ``branch_table.json`` and Figures 2-3 of a reproduction into ``out``.

    Every file goes through :class:`obsnl.report.files.OutputFolder`: all are written into a staging
    folder inside ``out`` and moved in together, so a failure (a full disk) leaves none of them; ``out``
    must not be a symbolic link (it is never followed), and a link or hard-linked file in its place is
    replaced, never written through.

    Parameters
    ----------
    rep : Reproduction
        The reproduction.
    out : str or Path
        The folder.
    force : bool
        Replace existing files (the default: ``obsnl reproduce`` regenerates its default folder); False:
        refuse a file that exists, even one another run wrote while this one ran.

    Returns
    -------
    list of Path

    Raises
    ------
    OutputError
        When a file cannot be written, ``out`` is a link, or (without ``force``) a file exists.
    """
    import json

    from obsnl.report.figures import figure2, figure3
    from obsnl.report.identification import table2_latex, table2_markdown, table2_summary

    from obsnl.report.files import OutputFolder

    doc = rep.to_dict()
    texts = [json.dumps(doc, indent=1) + "\n", table2_markdown(doc), table2_latex(doc),
             rep.table.to_json()]  # the last is the DUKF's input, from the analysis
    s = rep.setup
    summ = table2_summary(doc)
    t = s.record.t
    data = make_data(s, 0)
    with OutputFolder(out, reproduction_files(rep), force=force) as folder:
        for n, text in zip(REPRODUCTION_FILES, texts):
            folder.write_text(n, text)
        for k in sorted({k for _, k in rep.trajectories}):
            trs = {m: rep.trajectories[(m, k)] for m in ("ukf", "dukf") if (m, k) in rep.trajectories}
            if not trs:
                continue
            tag = "1pass" if k == 1 else f"{k}passes"
            figure2(folder.path(f"fig2_{tag}.png"), t=t, accel=data.u, y_measured=data.y,
                    estimates={f"{m.upper()} (pass {k})": tr[-1].x[:, 0] for m, tr in trs.items()},
                    title=s.record.name)
            flagged = [p for p in s.model.parameters
                       if any(s_["flag_counts"][p] * 2 >= len(s_["seeds"]) for m in trs if (s_ := summ.get((m, k))))]
            tt = np.concatenate([t + i * (t[-1] + s.record.dt) for i in range(k)])
            panels = {f"({chr(97 + i)}) {m.upper()}" + (f", {k} passes back to back" if k > 1 else ""):
                      np.vstack([tr.theta for tr in trs[m]]) for i, m in enumerate(trs)}
            figure3(folder.path(f"fig3_{tag}.png"), t=tt, panels=panels, truth=s.theta_true,
                    parameters=s.model.parameters, flagged=flagged)
        return folder.commit()
