"""The result of ``obsnl reproduce``: the :class:`Reproduction` value, its Table 2 document and its files.

:meth:`Reproduction.to_dict` is the document of ``table2.json`` (the experiment, the tuning and how it was
chosen, every reported run, the maximum-likelihood refinements, the paper's errors next to them); its text
forms are made in :mod:`obsnl.report.identification`. :func:`write_reproduction` writes the document, its
Markdown and LaTeX tables, the branch table and Figures 2-3 (:mod:`obsnl.report.figures`) into one folder.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from obsnl._files import read_document
from obsnl._text import shorten
from obsnl.errors import DataError, OptionError, refuse_non_path
from obsnl.estimation.ukf import Trajectory
from obsnl.identification.experiments import DIVERGED, Setup, Tuning, make_data
from obsnl.studies.seed_document import FIX, Experiment, TuningChoice, TuningScore, read_part
from obsnl.studies.seed_runs import FALLBACKS, FLOOR, Refined, RunResult
from obsnl.studies.seed_tasks import ML_MAX_ITER
from obsnl.studies.seed_tuning import tuning_protocol

if TYPE_CHECKING:
    from obsnl.observability.contract.branch_table import BranchTable

__all__ = [
    "PAPER_ERRORS",
    "ML_PROTOCOL",
    "Reproduction",
    "REPRODUCTION_FILES",
    "read_reproduction",
    "reproduction_files",
    "write_reproduction",
]

#: Errors (%) the seed paper reports in Table 2.
PAPER_ERRORS: Mapping[str, Mapping[str, float]] = {
    "dukf": {
        "k_m": 0.55,
        "c_dm": 0.01,
        "c_eta_p": 8.33,
        "c_p": 17.62,
        "h_p": 1.99,
        "N": 0.02,
        "w_h": 10.54,
        "Delta1": 11.39,
        "Delta2": 0.20,
    },
    "ukf": {
        "k_m": 4.14,
        "c_dm": 0.02,
        "c_eta_p": 5.47,
        "c_p": 106.48,
        "h_p": 13.67,
        "N": 1.28,
        "w_h": 7.62,
        "Delta1": 13.93,
        "Delta2": 15.30,
    },
}


@dataclass(frozen=True, eq=False)
class Reproduction:
    """Result of :func:`~obsnl.studies.seed_paper.reproduce`: the Table 2 document as typed values (the experiment,
    the tuning and how it was chosen, every reported run, the maximum-likelihood refinements, the paper's errors),
    and what the run leaves beside it for the figures (the :class:`~obsnl.identification.setup.Setup`, the branch
    table, the trajectories of the first seed).

    :meth:`to_dict` is ``table2.json``; :meth:`from_dict` reads it back (then ``setup`` and ``table`` are None and
    there are no trajectories: the document renders, the figures need the run). :meth:`of_run` builds it from the
    parts of a run.
    """

    experiment: Experiment
    table_source: str
    runs: tuple[RunResult, ...]
    tuning: tuple[TuningChoice, ...] = ()
    tuning_seeds: tuple[int, ...] = ()
    tuning_protocol: str | None = None
    compile_seconds: Mapping[str, float] = field(default_factory=dict)
    refinements: tuple[Refined, ...] = ()
    refinement_protocol: str | None = None
    diverged_factor: float = DIVERGED
    fallbacks: int | None = FALLBACKS  # None: a document of the former rule (redone only when diverged)
    noise_floor_factor: float | None = FLOOR
    paper_errors: Mapping[str, Mapping[str, float]] = field(default_factory=lambda: PAPER_ERRORS)
    setup: Setup | None = field(default=None, repr=False)
    table: BranchTable | None = field(default=None, repr=False)
    trajectories: Mapping[tuple[str, int], tuple[Trajectory, ...]] = field(default_factory=dict, repr=False)

    @classmethod
    def of_run(
        cls,
        *,
        setup: Setup,
        table: BranchTable,
        table_source: str,
        tuning: Mapping[tuple[str, int], tuple[Tuning, Mapping[Tuning, float]]],
        runs: tuple[RunResult, ...],
        trajectories: Mapping[tuple[str, int], tuple[Trajectory, ...]],
        tuning_seeds: tuple[int, ...] = (),
        compile_seconds: Mapping[str, float] | None = None,
        refinements: tuple[Refined, ...] = (),
        tuning_runs: Mapping[tuple[str, Tuning, int], int] | None = None,
        halving_keep: int | None = None,
    ) -> Reproduction:
        """The reproduction of a run: ``tuning`` per (method, passes) the configuration chosen and the mean misfit
        of each one tried, ``tuning_runs`` the tuning seeds each ran on per (method, configuration, passes),
        ``halving_keep`` the survivors of the successive halving (None: the full grid)."""
        seeds_of = dict(tuning_runs or {})
        n_grid = len({t for _, t, _ in seeds_of})
        return cls(
            experiment=Experiment.from_setup(setup),
            table_source=table_source,
            runs=tuple(runs),
            tuning=tuple(
                TuningChoice(m, k, t, tuple(TuningScore(g, v, seeds_of.get((m, g, k))) for g, v in sc.items()))
                for (m, k), (t, sc) in tuning.items()
            ),
            tuning_seeds=tuple(tuning_seeds),
            tuning_protocol=tuning_protocol(
                halving_keep,
                n_grid,
                len(tuning_seeds),
                sum(v for (_, _, k), v in seeds_of.items() if k == 1),
                floor=FLOOR,
                candidates=FALLBACKS + 1,
            ),
            compile_seconds=dict(compile_seconds or {}),
            refinements=tuple(refinements),
            refinement_protocol=ML_PROTOCOL if refinements else None,
            setup=setup,
            table=table,
            trajectories=trajectories,
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Reproduction:
        """The reproduction a ``table2.json`` holds (:meth:`to_dict`), without its run's setup, branch table and
        trajectories.

        Raises
        ------
        DataError
            The document is not an object, lacks a part or holds a value of the wrong kind: the message names the
            part and says to give the document ``obsnl reproduce`` writes.

        Examples
        --------
        >>> Reproduction.from_dict({"experiment": {}, "branch_table": "", "runs": []})
        Traceback (most recent call last):
        ...
        obsnl.errors.DataError: the experiment in the Table 2 document lacks 'model'; give the table2.json that obsnl reproduce writes, or regenerate it with obsnl reproduce
        """
        if not isinstance(d, Mapping):
            raise DataError(f"the Table 2 document is {type(d).__name__}, not an object; {FIX}")
        doc = d
        lacking = [k for k in ("experiment", "branch_table", "runs") if k not in doc]
        if lacking:
            raise DataError(f"the Table 2 document lacks {', '.join(map(repr, lacking))}; {FIX}")
        experiment = read_part("the experiment", Experiment.from_dict, doc["experiment"])

        def listed(key: str) -> list[Any]:
            items = doc.get(key) or []
            if not isinstance(items, list):
                raise DataError(f"{key!r} in the Table 2 document is {type(items).__name__}, not a list; {FIX}")
            return items

        runs = tuple(read_part(f"run {i}", RunResult.from_dict, r) for i, r in enumerate(listed("runs")))
        refs = tuple(read_part(f"refinement {i}", Refined.from_dict, r) for i, r in enumerate(listed("refinements")))
        sizes = [("run", i, len(r.theta)) for i, r in enumerate(runs)]
        sizes += [("refinement", i, len(r.theta)) for i, r in enumerate(refs)]
        for what, i, n in sizes:
            if n != len(experiment.parameters):
                raise DataError(
                    f"{what} {i} of the Table 2 document has {n} parameters, its experiment "
                    f"{len(experiment.parameters)}; {FIX}"
                )
        floor, fallbacks = doc.get("noise_floor_factor"), doc.get("fallbacks")
        return read_part(
            "the top level",
            lambda _: cls(
                experiment=experiment,
                table_source=str(doc["branch_table"]),
                runs=runs,
                tuning=tuple(
                    read_part(f"tuning {i}", TuningChoice.from_dict, t) for i, t in enumerate(listed("tuning"))
                ),
                tuning_seeds=tuple(map(int, listed("tuning_seeds"))),
                tuning_protocol=doc.get("tuning_protocol"),
                compile_seconds={str(k): float(v) for k, v in (doc.get("compile_seconds") or {}).items()},
                refinements=refs,
                refinement_protocol=doc.get("refinement_protocol"),
                diverged_factor=float(doc.get("diverged_factor", 10.0)),
                fallbacks=None if fallbacks is None else int(fallbacks),
                noise_floor_factor=None if floor is None else float(floor),
                paper_errors={
                    str(m): {str(p): float(v) for p, v in e.items()}
                    for m, e in (doc.get("paper_errors_percent") or {}).items()
                },
            ),
            doc,
        )

    def to_dict(self) -> dict[str, Any]:
        """``table2.json``."""
        e = self.experiment
        return {
            "experiment": e.to_dict(),
            "branch_table": self.table_source,
            "tuning_seeds": list(self.tuning_seeds),
            "tuning_protocol": self.tuning_protocol,
            "tuning": [t.to_dict() for t in self.tuning],
            "compile_seconds": dict(self.compile_seconds),
            "diverged_factor": self.diverged_factor,
            "fallbacks": self.fallbacks,
            "noise_floor_factor": self.noise_floor_factor,
            "paper_errors_percent": {k: dict(v) for k, v in self.paper_errors.items()},
            "runs": [r.to_dict(e.parameters, e.theta_true) for r in self.runs],
            "refinement_protocol": self.refinement_protocol,
            "refinements": [r.to_dict(e.parameters, e.theta_true) for r in self.refinements],
        }


#: How the third column of Table 2 is made (written into ``table2.json``).
ML_PROTOCOL = (
    "maximum likelihood of the measured output given the measured input (output error, single shooting: "
    "obsnl.identification.refine.refine), started on each reported seed from the estimate of the "
    "filter (UKF or DUKF, refined protocol) whose free-run output misfit on that seed is the smaller (no "
    "true value used); every parameter free (none held), the initial state estimated; Levenberg-Marquardt "
    f"with exact derivatives, at most {ML_MAX_ITER} iterations per weighting; std from the Fisher "
    "information at the estimate with the input's 0.1 % noise propagated (no profile likelihood: too "
    "slow for the main job); converged only when the first-order condition holds and the last step "
    "moved no parameter by more than 0.1 std"
)


#: The text files a reproduction writes (the figures ``fig2_*.png``, ``fig3_*.png`` come on top).
REPRODUCTION_FILES: tuple[str, ...] = ("table2.json", "table2.md", "table2.tex", "branch_table.json")
#: The figure of Table 2's errors per parameter and filter.
TABLE2_FIGURE = "table2_errors.png"


def read_reproduction(path: str | Path) -> Reproduction:
    """The reproduction a ``table2.json`` holds (:meth:`Reproduction.from_dict`): its tables render again, without
    running anything.

    Parameters
    ----------
    path : str or Path
        The ``table2.json`` written by ``obsnl reproduce``.

    Returns
    -------
    Reproduction

    Raises
    ------
    DataError
        The file cannot be read, is not JSON, or is not a Table 2 document (the message names the part).
    """
    import json

    refuse_non_path(path, "read_reproduction takes the path of a table2.json")
    where = shorten(Path(path).name, 100)
    text = read_document(path, where=where, error=DataError, fix=FIX)  # a FIFO or a device refused
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DataError(f"{where} is not JSON ({exc}); {FIX}") from None
    return Reproduction.from_dict(doc)


def reproduction_files(rep: Reproduction) -> list[str]:
    """The files :func:`write_reproduction` writes for ``rep``: :data:`REPRODUCTION_FILES`, then
    ``fig2_<tag>.png`` and ``fig3_<tag>.png`` per protocol with trajectories (``1pass``, ``3passes``, ...)."""
    names = [*REPRODUCTION_FILES, TABLE2_FIGURE]
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
    OptionError
        ``rep`` was read back from a ``table2.json`` (:meth:`Reproduction.from_dict`): no run to draw the figures
        from.
    """
    import json

    from obsnl.report.figures import figure2, figure3, table2_errors_figure
    from obsnl.report.files import OutputFolder
    from obsnl.report.identification import table2_latex, table2_markdown, table2_summary
    from obsnl.report.identification.table2 import table2_errors

    s = rep.setup
    if s is None or rep.table is None:
        raise OptionError(
            "this reproduction was read back from a table2.json: it has no run to draw Figures 2-3 from; "
            "render its tables with obsnl.report.identification (table2_markdown, table2_latex), or run reproduce"
        )
    texts = [
        json.dumps(rep.to_dict(), indent=1) + "\n",
        table2_markdown(rep),
        table2_latex(rep),
        rep.table.to_json(),
    ]  # the last is the DUKF's input, from the analysis
    summ = table2_summary(rep)
    t = s.record.t
    data = make_data(s, 0)
    with OutputFolder(out, reproduction_files(rep), force=force) as folder:
        for n, text in zip(REPRODUCTION_FILES, texts):
            folder.write_text(n, text)
        names, errors, flags = table2_errors(rep)
        table2_errors_figure(folder.path(TABLE2_FIGURE), parameters=names, errors=errors, flagged=flags)
        for k in sorted({k for _, k in rep.trajectories}):
            trs = {m: rep.trajectories[(m, k)] for m in ("ukf", "dukf") if (m, k) in rep.trajectories}
            if not trs:
                continue
            tag = "1pass" if k == 1 else f"{k}passes"
            figure2(
                folder.path(f"fig2_{tag}.png"),
                t=t,
                accel=data.u,
                y_measured=data.y,
                estimates={f"{m.upper()} (pass {k})": tr[-1].x[:, 0] for m, tr in trs.items()},
                title=s.record.name,
            )
            flagged = [
                p for p in s.model.parameters if any(c.flagged(p) for m in trs if (c := summ.get((m, k))) is not None)
            ]
            tt = np.concatenate([t + i * (t[-1] + s.record.dt) for i in range(k)])
            panels = {
                f"({chr(97 + i)}) {m.upper()}" + (f", {k} passes back to back" if k > 1 else ""): np.vstack(
                    [tr.theta for tr in trs[m]]
                )
                for i, m in enumerate(trs)
            }
            figure3(
                folder.path(f"fig3_{tag}.png"),
                t=tt,
                panels=panels,
                truth=s.theta_true,
                parameters=s.model.parameters,
                flagged=flagged,
            )
        return folder.commit()
