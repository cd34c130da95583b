"""The seed paper's identification experiment end to end: ``obsnl reproduce``.

Analysis -> branch table (:mod:`~obsnl.studies.seed_experiment`) -> UKF and DUKF tuned on unreported noise
seeds by successive halving (:func:`~obsnl.studies.seed_tuning.successive_halving`: every configuration of the
grid on the first tuning seed, the best ``HALVING_KEEP`` of each protocol on the others; the same procedure for
both filters; every tuning seed is a noise seed of the record at hand) -> reported runs on noise seeds
``0..seeds-1``, the tuning's choice confirmed on each one's own data or, where it leaves the output misfit above
the noise floor, replaced by the next configurations of the ranking (:mod:`~obsnl.studies.seed_runs`) -> the
maximum-likelihood refinement of each reported seed, started from the estimate of the filter (UKF or DUKF,
refined protocol) whose free-run output misfit on that seed is the smaller -> the Table 2 analog
(:class:`~obsnl.studies.seed_reproduction.Reproduction`, ``table2.json``; text in
:mod:`obsnl.report.identification`) and Figures 2-3 (:mod:`obsnl.report.figures`). Every run is a task of
:mod:`~obsnl.studies.seed_tasks`, mapped by an executor. Protocol details in
:mod:`obsnl.identification.experiments` and :mod:`obsnl.identification.likelihood`. Nothing here uses the true
values except to score the reported runs.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from obsnl._text import quote
from obsnl.errors import OptionError
from obsnl.estimation.jitcache import compiler_available
from obsnl.estimation.records import Record
from obsnl.executor import Executor
from obsnl.identification.experiments import DEFAULT_GRID, Tuning, mc_spread
from obsnl.identification.replicates import CHUNK, check_passes
from obsnl.identification.runs import check_replicates
from obsnl.studies.seed_experiment import seed_branch_table
from obsnl.studies.seed_reproduction import Reproduction
from obsnl.studies.seed_runs import FALLBACKS, Start
from obsnl.studies.seed_tasks import Spec, compile_task, context, late_task, reported_task, tuning_task
from obsnl.studies.seed_tuning import HALVING_KEEP, TUNING_SEEDS, successive_halving

__all__ = ["reproduce", "rate_from_here", "QUICK", "REPLICATES"]

#: Monte-Carlo replicates per reported run of the UKF and the DUKF (:func:`obsnl.identification.experiments.monte_carlo`);
#: replicate noise seeds ``[MC_SEEDS + seed, b]``, disjoint from the reported and tuning seeds.
REPLICATES = 32
MC_SEEDS = 5000
#: Monte-Carlo replicates per task of the executor (any split gives the same replicates): the
#: same chunk as ``identify --replicates``.
MC_CHUNK = CHUNK
#: The quick form of the main job (``obsnl reproduce --quick``, under a minute on two cores with a cold cache of
#: compiled filters): the first 300 samples, one reported and one tuning seed, no Monte-Carlo replicates. Its
#: Table 2 says little (most parameters are flagged on 3 s of record): it checks that the pipeline runs.
QUICK: dict[str, int] = {"samples": 300, "seeds": 1, "tuning_seeds": 1, "replicates": 0}
#: The maximum-likelihood fits are compiled (with ``jit``) only when the reported seeds hold this many samples in all.
#: Compiling the fit's sensitivities costs about 40 s once per machine; measured on 2 cores, the quick form's one fit
#: of 300 samples takes about 18 s uncompiled (its cold run 46 s instead of 66 s, warm 31 s instead of 13 s), while
#: the main job's five fits of 1999 samples took 11-22 s each uncompiled (at 12 iterations) against 2-4 s compiled.
FIT_JIT_SAMPLES = 2000


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


def _check_counts(seeds: object, tuning_seeds: object, samples: object) -> None:
    """Refuse a number of seeds that is not a whole number >= 1, and samples that are not a whole number or None."""
    for name, n in (("seeds", seeds), ("tuning_seeds", tuning_seeds)):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise OptionError(f"{name}= takes a whole number >= 1, got {quote(n, 30)}")
    if samples is not None and (isinstance(samples, bool) or not isinstance(samples, (int, np.integer))):
        raise OptionError(
            f"samples= takes a whole number of samples, or None for the whole record; got {quote(samples, 30)}"
        )


def reproduce(
    *,
    record: Record | None = None,
    seeds: int = 5,
    tuning_seeds: int = 5,
    passes: int = 3,
    grid: Sequence[Tuning] = DEFAULT_GRID,
    jit: bool | None = None,
    samples: int | None = None,
    replicates: int = REPLICATES,
    progress: Any = None,
    executor: Executor | None = None,
    keep: int | None = HALVING_KEEP,
    refine: bool = True,
) -> Reproduction:
    """Table 2 of the seed paper with obsnl's UKF and DUKF and the maximum-likelihood refinement (module
    docstring for the protocol).

    Parameters
    ----------
    record : Record or None
        Another ground motion (default: Northridge 1994, the paper's record).
    seeds, tuning_seeds : int
        Reported noise seeds ``0..seeds-1``; tuning seeds ``1000..`` (never reported; five by default,
        decided before any reported seed was looked at). The tuning's choice is confirmed on each
        reported seed's own data: a run whose free-run output misfit is above ``FLOOR`` times the output
        noise level (it has not reached the noise floor, or it stopped) is followed by the next
        configurations of the tuning ranking on the same data, at most ``FALLBACKS`` more, and the
        smallest misfit is reported (:func:`~obsnl.studies.seed_runs.reported_with_fallbacks`); the other
        attempts are kept in the run's ``redone`` list.
    passes : int
        Passes of the refined protocol (the paper's protocol is one pass).
    grid : sequence of Tuning
        Tuning configurations.
    jit : bool or None
        Compile the filters to C (cached on disk: :mod:`obsnl.estimation.jitcache`; the same numbers). None
        (default): where a C compiler is on PATH; without one the run is uncompiled, several times slower, and a
        warning on standard error says so.
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
        Configurations per protocol that go on after the first tuning seed (:func:`~obsnl.studies.seed_tuning.successive_halving`;
        None: the full grid on every tuning seed, the protocol before issue 27).
    refine : bool
        Refine each reported seed by maximum likelihood (the third column of Table 2).
    """
    check_replicates(replicates)
    check_passes(passes)
    _check_counts(seeds, tuning_seeds, samples)  # before any work: 0 seeds ran the whole tuning, then an IndexError
    if jit is None:
        jit = compiler_available()
        if not jit:
            sys.stderr.write(
                "obsnl: warning: no C compiler (gcc, cc or clang) on PATH: the filters and fits run "
                "uncompiled, several times slower (the same numbers)\n"
            )
    executor = executor or Executor(workers=1)
    t_seeds = tuple(range(TUNING_SEEDS, TUNING_SEEDS + tuning_seeds))
    protocols = sorted({1, passes})
    names = ("ukf", "dukf")
    n_tuning = len(names) * (len(grid) + (tuning_seeds - 1) * min(len(grid), len(protocols) * (keep or len(grid))))
    if progress is not None:  # known before anything is built (the tuning at most): the bar shows from the start
        progress.total = (
            n_tuning
            + seeds * (len(names) + 1) * len(protocols)
            + (seeds if refine else 0)
            + replicates * seeds * len(names) * len(protocols)
        )
        progress.refresh() if hasattr(progress, "refresh") else None
    stage = (
        (lambda text: progress.set_postfix_str(text)) if hasattr(progress, "set_postfix_str") else (lambda text: None)
    )
    stage("analysis")
    table, source = seed_branch_table()
    spec = Spec(record=record, samples=samples, jit=jit, table_json=table.to_json())
    stage("building the experiment")
    ctx = context(spec)  # the workers build the same from the spec
    setup, filters = ctx["setup"], ctx["filters"]
    spec = replace(spec, fit_jit=jit and seeds * len(setup.record.accel) >= FIT_JIT_SAMPLES)
    tick = (lambda i, r, n=1: progress.update(n)) if progress is not None else None
    with executor.session() as session:
        # each filter compiled once into the disk cache, the three at once on the workers (a fresh machine)
        stage(f"building the filters ({', '.join(filters)}; from the disk cache, else compiled once: ~15 s each)")
        compile_seconds = dict(zip(filters, session.map(compile_task, [(spec, name) for name in filters])))
        stage(f"tuning ({executor.kind})")
        rate_from_here(progress)  # the estimate of the time left counts from the first run, not the build
        ranked, tuning_runs = successive_halving(
            names,
            grid,
            t_seeds,
            lambda tasks: session.map(tuning_task, [(spec, *task) for task in tasks], done=tick),
            keep=keep,
            protocols=protocols,
        )
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
        stage(
            f"maximum likelihood and Monte-Carlo replicates ({executor.kind})"
            if refine
            else f"Monte-Carlo replicates ({executor.kind})"
        )
        ltasks: list[tuple[str, tuple]] = (
            [("refine", _refine_task(spec, seed, rtasks, reported, names, passes)) for seed in range(seeds)]
            if refine
            else []
        )
        owners = [-1] * len(ltasks)
        for j, ((_, name, k, seed, _, _), (result, _)) in enumerate(zip(rtasks, reported)):
            if not (replicates and name in names):
                continue
            if result.practical is None or result.practical.inconclusive:
                if progress is not None:
                    progress.update(replicates)
                continue
            for lo in range(0, replicates, MC_CHUNK):
                ltasks.append(
                    (
                        "replicates",
                        (
                            spec,
                            name,
                            seed,
                            result.theta,
                            result.tuning,
                            k,
                            MC_SEEDS + seed,
                            tuple(range(lo, min(replicates, lo + MC_CHUNK))),
                        ),
                    )
                )
                owners.append(j)
        late = session.map(
            late_task,
            ltasks,
            done=(lambda i, r: progress.update(1 if ltasks[i][0] == "refine" else len(ltasks[i][1][-1])))
            if progress is not None
            else None,
        )
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
    return Reproduction.of_run(
        setup=setup,
        table=table,
        table_source=source,
        tuning=chosen,
        runs=tuple(runs),
        trajectories=trajs,
        tuning_seeds=t_seeds,
        compile_seconds=compile_seconds,
        refinements=refinements,
        tuning_runs=tuning_runs,
        halving_keep=keep,
    )


def _refine_task(
    spec: Spec, seed: int, rtasks: Sequence[tuple], reported: Sequence[tuple], names: Sequence[str], passes: int
) -> tuple[Spec, int, tuple[float, ...], Start]:
    """The refinement of reported seed ``seed``: from the estimate of the filter (``names``, ``passes`` passes)
    whose free-run output misfit on that seed is the smaller (data only; a run that stopped is not a start)."""
    cands = [
        (result.misfit, names.index(name), result)
        for (_, name, k, s, _, _), (result, _) in zip(rtasks, reported)
        if s == seed and k == passes and name in names and not result.failed and np.isfinite(result.misfit)
    ]
    if not cands:  # no estimate that can be simulated: start from the guesses (said in ``start``)
        return (
            spec,
            seed,
            tuple(map(float, context(spec)["setup"].theta_guess)),
            Start("guess", 0, float("nan")),
        )
    misfit, _, best = min(cands, key=lambda c: (c[0], c[1]))
    return spec, seed, best.theta, Start(best.method, best.passes, float(misfit))
