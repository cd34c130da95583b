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
from typing import Any

import numpy as np

from obsnl.estimation.ukf import Trajectory
from obsnl.identification.experiments import DIVERGED, Setup, Tuning, make_data
from obsnl.studies.seed_runs import FALLBACKS, FLOOR, Refined, RunResult
from obsnl.studies.seed_tasks import ML_MAX_ITER
from obsnl.studies.seed_tuning import tuning_protocol

__all__ = [
    "PAPER_ERRORS",
    "ML_PROTOCOL",
    "Reproduction",
    "REPRODUCTION_FILES",
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
    tuning_runs: Mapping[tuple[str, Tuning, int], int] = field(
        default_factory=dict
    )  # seeds per configuration, protocol
    halving_keep: int | None = None

    def to_dict(self) -> dict[str, Any]:
        s = self.setup
        n_grid = len({t for _, t, _ in self.tuning_runs})
        return {
            "experiment": s.to_dict(),
            "branch_table": self.table_source,
            "tuning_seeds": list(self.tuning_seeds),
            "tuning_protocol": tuning_protocol(
                self.halving_keep,
                n_grid,
                len(self.tuning_seeds),
                sum(v for (_, _, k), v in self.tuning_runs.items() if k == 1),
                floor=FLOOR,
                candidates=FALLBACKS + 1,
            ),
            "tuning": [
                {
                    "method": m,
                    "passes": k,
                    "chosen": t.to_dict(),
                    "scores": [
                        {**g.to_dict(), "misfit": v, "seeds": self.tuning_runs.get((m, g, k))} for g, v in sc.items()
                    ],
                }
                for (m, k), (t, sc) in self.tuning.items()
            ],
            "compile_seconds": dict(self.compile_seconds),
            "diverged_factor": DIVERGED,
            "fallbacks": FALLBACKS,
            "noise_floor_factor": FLOOR,
            "paper_errors_percent": {k: dict(v) for k, v in PAPER_ERRORS.items()},
            "runs": [r.to_dict(s.model.parameters, s.theta_true) for r in self.runs],
            "refinement_protocol": ML_PROTOCOL if self.refinements else None,
            "refinements": [r.to_dict(s.model.parameters, s.theta_true) for r in self.refinements],
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
    """
    import json

    from obsnl.report.figures import figure2, figure3, table2_errors_figure
    from obsnl.report.files import OutputFolder
    from obsnl.report.identification import table2_latex, table2_markdown, table2_summary
    from obsnl.report.identification.table2 import table2_errors

    doc = rep.to_dict()
    texts = [
        json.dumps(doc, indent=1) + "\n",
        table2_markdown(doc),
        table2_latex(doc),
        rep.table.to_json(),
    ]  # the last is the DUKF's input, from the analysis
    s = rep.setup
    summ = table2_summary(doc)
    t = s.record.t
    data = make_data(s, 0)
    with OutputFolder(out, reproduction_files(rep), force=force) as folder:
        for n, text in zip(REPRODUCTION_FILES, texts):
            folder.write_text(n, text)
        names, errors, flags = table2_errors(doc)
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
                p
                for p in s.model.parameters
                if any(s_["flag_counts"][p] * 2 >= len(s_["seeds"]) for m in trs if (s_ := summ.get((m, k))))
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
