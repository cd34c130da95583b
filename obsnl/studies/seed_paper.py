"""The seed paper's identification experiment end to end: ``obsnl reproduce``.

Analysis -> branch table -> UKF and DUKF tuned on unreported noise seeds (:func:`obsnl.identification.experiments.tune`,
the same procedure for both filters) -> reported runs on noise seeds ``0..seeds-1`` -> the Table 2
analog (``table2.json``; text in :mod:`obsnl.report.tables`) and Figures 2-3 (:mod:`obsnl.report.figures`).
Protocol details in :mod:`obsnl.identification.experiments`. Nothing here uses the true values except to score the
reported runs.
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
from obsnl.studies.seed_tasks import (FALLBACKS, SEED_GUESS, RunResult, Spec, compile_task, context, replicates_task,
                                      reported_task, reported_with_fallbacks, seed_model_path, seed_setup,
                                      tuning_task)
from obsnl.identification.runs import check_replicates
from obsnl.identification.replicates import CHUNK
from obsnl.estimation.ukf import Trajectory

__all__ = ["RunResult", "Reproduction", "seed_model_path", "seed_setup", "seed_branch_table", "reproduce",
           "write_reproduction", "reproduction_files", "SEED_GUESS", "PAPER_ERRORS", "TUNING_SEEDS", "reported_with_fallbacks"]

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

    def to_dict(self) -> dict[str, Any]:
        s = self.setup
        return {
            "experiment": s.to_dict(), "branch_table": self.table_source, "tuning_seeds": list(self.tuning_seeds),
            "tuning": [{"method": m, "passes": k, "chosen": t.to_dict(),
                        "scores": [{**g.to_dict(), "misfit": v} for g, v in sc.items()]}
                       for (m, k), (t, sc) in self.tuning.items()],
            "compile_seconds": dict(self.compile_seconds), "diverged_factor": DIVERGED, "fallbacks": FALLBACKS,
            "paper_errors_percent": {k: dict(v) for k, v in PAPER_ERRORS.items()},
            "runs": [r.to_dict(s.model.parameters, s.theta_true) for r in self.runs],
        }


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
    """
    if progress is not None and hasattr(progress, "last_print_t") and callable(getattr(progress, "_time", None)):
        progress.last_print_t, progress.last_print_n = progress._time(), progress.n


def seed_branch_table(*, seed: int = 0) -> tuple[Any, str]:
    """The branch table of the seed model from obsnl's analysis, checked against the paper's Table 1."""
    from obsnl.observability.analyze import analyze
    from obsnl.model.files import load_model
    from obsnl.observability.contract.branch_table import BranchTable

    model = load_model(seed_model_path())
    table = BranchTable.from_result(analyze(model, seed=seed))
    paper = {1: {"Delta2"}, -1: {"Delta1", "w_h"}}  # Table 1: by the sign of (r - eta') x2
    agrees = all(set(b.unidentifiable_parameters) == paper[b.signs[0] * b.signs[1]] for b in table.branches)
    source = (f"obsnl analysis ({table.method}, seed {seed}); "
              f"{'agrees with' if agrees else 'DIFFERS from'} the seed paper's Table 1")
    return table, source


def reproduce(*, record: Record | None = None, seeds: int = 5, tuning_seeds: int = 5, passes: int = 3,
              grid: Sequence[Tuning] = DEFAULT_GRID, jit: bool = True, samples: int | None = None,
              replicates: int = REPLICATES, progress: Any = None, executor: Executor | None = None) -> Reproduction:
    """Table 2 of the seed paper with obsnl's UKF and DUKF (module docstring for the protocol).

    Parameters
    ----------
    record
        Another ground motion (default: Northridge 1994, the paper's record).
    seeds, tuning_seeds
        Reported noise seeds ``0..seeds-1``; tuning seeds ``1000..`` (never reported; five by default,
        decided before any reported seed was looked at). A reported run that diverged (it stopped, or
        its free-run output misfit is above ``DIVERGED`` times the output noise level) is redone with
        the next configuration of the tuning ranking, at most ``FALLBACKS`` times; the discarded
        attempts are kept in the run's ``redone`` list.
    passes
        Passes of the refined protocol (the paper's protocol is one pass).
    grid
        Tuning configurations.
    jit
        Compile the filters to C (cached on disk: :mod:`obsnl.estimation.jitcache`).
    samples
        Use only the first samples of the record (quick runs).
    replicates
        Monte-Carlo replicates of the practical-identifiability check per reported run of the UKF and
        the DUKF that did not diverge (0: off; the ablation ``dukf-zero`` gets none).
    progress
        A tqdm-like object (``total``, ``update(n)``) or None.
    executor
        Where the independent runs go (:class:`obsnl.executor.Executor`; default: this process).
        Every run's noise is fixed by its own seeds: the result does not depend on the executor.
    """
    check_replicates(replicates)
    executor = executor or Executor(workers=1)
    t_seeds = tuple(range(TUNING_SEEDS, TUNING_SEEDS + tuning_seeds))
    protocols = sorted({1, passes})
    names = ("ukf", "dukf")
    if progress is not None:  # known before anything is built: the bar shows from the start
        progress.total = (len(names) * len(grid) * tuning_seeds + seeds * (len(names) + 1) * len(protocols)
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
        ttasks = [(spec, name, t, s, passes) for name in names for t in grid for s in t_seeds]
        got = session.map(tuning_task, ttasks, done=tick)
        chosen: dict[tuple[str, int], tuple[Tuning, Mapping[Tuning, float]]] = {}
        for name in names:
            for k in protocols:
                sc = {t: float(np.mean([g[k] for (_, n, t_, _, _), g in zip(ttasks, got) if n == name and t_ == t]))
                      for t in grid}
                chosen[(name, k)] = (min(sc, key=lambda t: (sc[t], grid.index(t))), sc)
        stage(f"reported runs ({executor.kind})")
        rtasks = []
        for name in (*names, "dukf-zero"):
            for k in protocols:
                tuned, scores = chosen[("dukf" if name == "dukf-zero" else name, k)]
                ranking = [tuned] + [t for t in sorted(scores, key=lambda t: (scores[t], grid.index(t))) if t != tuned]
                rtasks += [(spec, name, k, seed, tuple(ranking), FALLBACKS) for seed in range(seeds)]
        reported = session.map(reported_task, rtasks, done=tick)
        stage(f"Monte-Carlo replicates ({executor.kind})")
        mtasks, owners = [], []
        for j, ((_, name, k, seed, _, _), (result, _)) in enumerate(zip(rtasks, reported)):
            if not (replicates and name in names):
                continue
            if result.practical is None or result.practical.inconclusive:
                if progress is not None:
                    progress.update(replicates)
                continue
            for lo in range(0, replicates, MC_CHUNK):
                mtasks.append((spec, name, seed, result.theta, result.tuning, k, MC_SEEDS + seed,
                               tuple(range(lo, min(replicates, lo + MC_CHUNK)))))
                owners.append(j)
        mc = session.map(replicates_task, mtasks, done=(lambda i, r: progress.update(len(mtasks[i][-1])))
                         if progress is not None else None)
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
                        trajectories=trajs, tuning_seeds=t_seeds, compile_seconds=compile_seconds)


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
