"""The Table 2 analog of the seed paper (Markdown and LaTeX) and its summary statistics, rendered from the
``table2.json`` document alone: a committed document is re-rendered without running anything."""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from obsnl.report.tex import tex_escape

__all__ = ["table2_summary", "table2_ml_summary", "table2_markdown", "table2_latex"]


# Text of the Table 2 analog (seed paper 000_d24855f97fc8bdd4.txt) from the plain ``table2.json``
# document written by ``obsnl reproduce`` (``obsnl.studies.seed_paper``), so that a committed table2.json
# can be re-rendered without running anything. Writing files and figures stays in obsnl.studies.seed_reproduction.

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


def table2_summary(doc: Mapping[str, Any]) -> dict[tuple[str, int], dict[str, Any]]:
    """Per (method, passes): mean estimate, mean and worst ``|error|`` per parameter, flags, cost, interventions."""
    groups: dict[tuple[str, int], list[Mapping[str, Any]]] = {}
    for r in doc["runs"]:
        groups.setdefault((r["method"], r["passes"]), []).append(r)
    out = {}
    for key, every in groups.items():
        runs = [r for r in every if not r.get("error")] or every[:1]
        failed = [r for r in every if r.get("error")]
        params = list(runs[0]["parameters"])
        est = np.array([[r["parameters"][p]["estimate"] for p in params] for r in runs], float)
        err = np.abs(np.array([[r["parameters"][p]["error_percent"] for p in params] for r in runs], float))
        kinds: Counter[str] = Counter()
        for r in every:
            kinds.update(r.get("interventions") or {})
        out[key] = {
            "parameters": params,
            "seeds": [r["seed"] for r in runs],
            "mean_estimate": est.mean(axis=0),
            "mean_abs_error": err.mean(axis=0),
            "worst_abs_error": err.max(axis=0),
            "worst_seed": [runs[i]["seed"] for i in err.argmax(axis=0)],
            "flag_counts": {p: sum(p in (r["practically_unidentifiable"] or ()) for r in runs) for p in params},
            "flag_counts_linearised": {p: sum(p in _linearised_flags(r) for r in runs) for p in params},
            "spread": _mean_spread(runs, params),
            "yield": _yield_errors(runs, doc["experiment"]["truth"]),
            "undecided": [
                (
                    r["seed"],
                    (r.get("practical_identifiability") or {}).get("inconclusive") or r.get("error") or "no estimate",
                )
                for r in runs
                if r["practically_unidentifiable"] is None
            ],
            "seconds": float(np.mean(np.array([r["seconds"] for r in runs], float))),
            "seconds_per_pass": float(np.mean(np.array([r["seconds"] for r in runs], float) / key[1])),
            "repairs": int(sum(r["repairs"] for r in every)),
            "interventions": dict(kinds),
            "implicit": int(sum(r["implicit_sigma_point_steps"] for r in every)),
            "misfits": [r["output_misfit"] for r in runs],
            "tuning": max((r["tuning"] for r in every), key=[r["tuning"] for r in every].count),
            "redone": [(r["seed"], r["redone"], r["tuning"]) for r in every if r.get("redone")],
            "failed": [(r["seed"], r["error"]) for r in failed],
        }
    return out


def table2_ml_summary(doc: Mapping[str, Any]) -> dict[str, Any] | None:
    """The maximum-likelihood column (``doc["refinements"]``): mean and worst ``|error|``, mean std, flags,
    the convergence verdict per seed; None when the document has no refinement."""
    refs = doc.get("refinements") or []
    if not refs:
        return None
    ran = [r for r in refs if not r.get("error")]
    params = list(refs[0]["parameters"])
    val = lambda r, p, k: np.nan if r["parameters"][p][k] is None else r["parameters"][p][k]  # noqa: E731
    est = np.array([[val(r, p, "estimate") for p in params] for r in ran], float).reshape(len(ran), len(params))
    err = np.abs(np.array([[val(r, p, "error_percent") for p in params] for r in ran], float)).reshape(est.shape)
    std = np.array(
        [
            [np.inf if r["parameters"][p]["std_percent"] is None else r["parameters"][p]["std_percent"] for p in params]
            for r in ran
        ],
        float,
    ).reshape(est.shape)
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
    return {
        "parameters": params,
        "seeds": [r["seed"] for r in ran],
        "runs": refs,
        "mean_estimate": est.mean(axis=0) if ran else nan,
        "mean_abs_error": err.mean(axis=0) if ran else nan,
        "worst_abs_error": err.max(axis=0) if ran else nan,
        "mean_std_percent": std.mean(axis=0) if ran else nan,
        "worst_error_in_std": np.where(np.isfinite(z), z, np.nan).max(axis=0) if ran else nan,
        "flag_counts": {p: int(flags[:, i].sum()) for i, p in enumerate(params)},
        "within_4_std": (sum(e <= max(4 * s, 1.0) for _, e, s in ok), len(ok)),
        "yield": _yield_errors(ran, doc["experiment"]["truth"]) if ran else None,
        "converged": [r["seed"] for r in ran if r["converged"]],
        "failed": [(r["seed"], r["error"]) for r in refs if r.get("error")],
        "inadequate": [r["seed"] for r in ran if (r.get("adequacy") or {}).get("passed") is False],
    }


def _yield_displacement(delta: float, n: float) -> float:
    """``|Delta|**(-1/(2N))``: with ``Delta = (beta +- gamma) / r_y**(2N)`` (seed paper 000_d24855f97fc8bdd4.txt,) the yield
    displacement up to the factor ``|beta +- gamma|**(-1/(2N))``."""
    return abs(delta) ** (-1 / (2 * n))


def _yield_errors(
    runs: Sequence[Mapping[str, Any]], truth: Mapping[str, float]
) -> dict[str, tuple[float, np.ndarray]] | None:
    """Per Delta: the true yield displacement and the ``|error|`` in % of each run's (the direction the
    seed model's data inform along the Delta-N ridge); None for a model without Delta1, Delta2, N."""
    if not {"Delta1", "Delta2", "N"} <= set(truth):
        return None
    out = {}
    for d in ("Delta1", "Delta2"):
        true = _yield_displacement(truth[d], truth["N"])
        est = np.array(
            [
                _yield_displacement(r["parameters"][d]["estimate"], r["parameters"]["N"]["estimate"])
                if r["parameters"][d]["estimate"] is not None and r["parameters"]["N"]["estimate"]
                else np.nan
                for r in runs
            ],
            float,
        )
        out[d] = (true, np.abs(100 * (est - true) / true))
    return out


def _linearised_flags(run: Mapping[str, Any]) -> Sequence[str]:
    """The flags of a run by the linearised criteria alone (Cramér-Rao bound, posterior)."""
    prac = run.get("practical_identifiability") or {}
    return prac.get("flagged_linearised", run.get("practically_unidentifiable")) or ()


def _mean_spread(runs: Sequence[Mapping[str, Any]], params: Sequence[str]) -> list[float] | None:
    """Mean Monte-Carlo relative std per parameter over the runs that have one (None: no run has)."""
    mcs = [(r.get("practical_identifiability") or {}).get("monte_carlo") or {} for r in runs]
    rows = [
        [np.nan if v is None or p in mc.get("held", ()) else v for p, v in zip(params, mc["relative_std"])]
        for mc in mcs
        if mc.get("relative_std")
    ]  # held at the guess: no spread to show
    if not rows:
        return None
    a = np.array(rows, float)
    return [float(np.nanmean(c)) if np.isfinite(c).any() else float("nan") for c in a.T]


def _t2_flagged(s: Mapping[str, Any], p: str, key: str = "flag_counts") -> bool:
    return s[key][p] * 2 >= len(s["seeds"])


def _t2_misfit(s: Mapping[str, Any]) -> str:
    """Mean output misfit of the runs whose estimate could be simulated; the others are named."""
    ok = [v for v in s["misfits"] if v is not None and np.isfinite(v)]
    bad = [seed for seed, v in zip(s["seeds"], s["misfits"]) if v is None or not np.isfinite(v)]
    text = f"{np.mean(ok):.5f}" if ok else "-"
    if bad:
        text += f" (seed {', '.join(map(str, bad))}: the estimate cannot be simulated)"
    return text


def _t2_goal(s: Mapping[str, Any], key: str = "flag_counts") -> str:
    if s["failed"]:
        return f"not met ({len(s['failed'])} run(s) stopped: seed {', '.join(str(k) for k, _ in s['failed'])})"
    worst = [(p, w) for p, w in zip(s["parameters"], s["worst_abs_error"]) if not _t2_flagged(s, p, key)]
    bad = [f"{_T2_MD.get(p, p)} {w:.1f} %" for p, w in worst if w > 5.0]
    return _goal(bad, len(s["parameters"]) - len(worst), len(s["parameters"]))


def _goal(bad: list[str], flagged: int, total: int) -> str:
    """The 5 % goal over the unflagged parameters: never "met" when most parameters are flagged (not judged)."""
    if bad:
        return "not met (" + ", ".join(bad) + ")"
    if 2 * flagged > total:
        return f"not judged ({flagged} of {total} parameters flagged; the other {total - flagged} within 5 %)"
    return "met"


def _t2_tuning(t: Mapping[str, Any]) -> str:
    gate = t.get("gate")
    return f"{t['s0']:g}, {t['q_theta']:g}, {t['q_x']:g}, {'off' if gate is None else f'{gate:g}'}"


def _t2_kinds(s: Mapping[str, Any]) -> str:
    return ", ".join(f"{k} {v}" for k, v in s["interventions"].items() if v) or "none"


def _ml_goal(ml: Mapping[str, Any]) -> str:
    """The maximum-likelihood column's 5 % goal: met only on adequate, unflagged estimates of seeds that ran."""
    worst = [(p, w) for p, w in zip(ml["parameters"], ml["worst_abs_error"]) if not _t2_flagged(ml, p)]
    bad = [f"{_T2_MD.get(p, p)} {w:.1f} %" for p, w in worst if not w <= 5.0]
    goal = _goal(bad, len(ml["parameters"]) - len(worst), len(ml["parameters"]))
    if ml["failed"]:
        goal = f"not met ({len(ml['failed'])} refinement(s) could not run)"
    elif ml.get("inadequate"):  # the estimates' std assume a right model: no goal is met without one
        goal = (
            f"not met (the model does not explain the data to the noise level on seed(s) "
            f"{', '.join(map(str, ml['inadequate']))}: adequacy failed)"
        )
    return goal


def _worst_unflagged(s: Mapping[str, Any]) -> str:
    """The largest worst-seed error among a column's unflagged parameters, with its name."""
    rows = [(w, p) for p, w in zip(s["parameters"], s["worst_abs_error"]) if not _t2_flagged(s, p) and np.isfinite(w)]
    if not rows:
        return "- (all flagged)"
    w, p = max(rows)
    return f"{w:.2f} % ({_T2_MD.get(p, p)})"


def _summary_rows(
    summ: Mapping[tuple[str, int], Mapping[str, Any]], ml: Mapping[str, Any] | None, ml_passes: int
) -> list[str]:
    """The compact summary: per protocol and filter (and the maximum-likelihood column), the worst error on the
    unflagged parameters, what is flagged, and the 5 % goal."""
    lines = [
        "| protocol | filter | worst error, unflagged (worst seed) | flagged | 5 % goal |",
        "|---|---|---|---|---|",
    ]
    for passes in sorted({k for _, k in summ}):
        for m in [m for m in _T2_METHODS if (m, passes) in summ]:
            s = summ[(m, passes)]
            flagged = ", ".join(_T2_MD.get(p, p) for p in s["parameters"] if _t2_flagged(s, p)) or "none"
            lines.append(
                f"| {_passes_title(passes)} | {_T2_METHODS[m]} | {_worst_unflagged(s)} | {flagged} | {_t2_goal(s)} |"
            )
        if ml and passes == ml_passes:
            flagged = ", ".join(_T2_MD.get(p, p) for p in ml["parameters"] if _t2_flagged(ml, p)) or "none"
            lines.append(
                f"| {_passes_title(passes)} | maximum likelihood | {_worst_unflagged(ml)} | "
                f"{flagged} | {_ml_goal(ml)} |"
            )
    return lines


def table2_found(doc: Mapping[str, Any]) -> str:
    """What a reproduction found, in a few plain lines: per protocol and filter (and the maximum-likelihood column),
    the worst error on the unflagged parameters, what is flagged and the 5 % goal (the summary of
    :func:`table2_markdown`).

    Parameters
    ----------
    doc : mapping
        The reproduction's ``table2.json``.

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


def table2_errors(doc: Mapping[str, Any]) -> tuple[list[str], dict[str, list[float]], dict[str, list[bool]]]:
    """What :func:`obsnl.report.figures.table2_errors_figure` draws: the parameters, and per column (protocol and
    filter, and the maximum-likelihood column) the worst-seed error in % of each parameter and whether it is
    flagged."""
    summ = table2_summary(doc)
    ml = table2_ml_summary(doc)
    ml_passes = max(k for _, k in summ)
    params = list(next(iter(summ.values()))["parameters"])
    errors: dict[str, list[float]] = {}
    flags: dict[str, list[bool]] = {}
    for passes in sorted({k for _, k in summ}):
        tag = "1 pass" if passes == 1 else f"{passes} passes"
        for m in [m for m in _T2_METHODS if (m, passes) in summ]:
            s = summ[(m, passes)]
            errors[f"{_T2_METHODS[m]}, {tag}"] = [float(v) for v in s["worst_abs_error"]]
            flags[f"{_T2_METHODS[m]}, {tag}"] = [_t2_flagged(s, p) for p in params]
        if ml and passes == ml_passes:
            errors["ML"] = [float(v) for v in ml["worst_abs_error"]]
            flags["ML"] = [_t2_flagged(ml, p) for p in params]
    return [_T2_MD.get(p, p) for p in params], errors, flags


def _above_floor(doc: Mapping[str, Any], *, with_ml: bool) -> list[str]:
    """A paragraph naming the filters' reported runs that stayed above the noise floor with every configuration
    they tried (a document that states its floor only; none: nothing)."""
    floor = doc.get("noise_floor_factor")
    if floor is None:
        return []
    line = floor * doc["experiment"]["noise_ratio"]
    seeds: dict[tuple[str, int], list[int]] = {}
    for r in doc["runs"]:
        if r["method"] != "dukf-zero" and (r["output_misfit"] is None or r["output_misfit"] > line):
            seeds.setdefault((r["method"], r["passes"]), []).append(r["seed"])
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


def table2_markdown(doc: Mapping[str, Any]) -> str:
    """The Table 2 analog as Markdown: a compact summary first (per protocol and filter: the worst error on the
    unflagged parameters, the flags, the goal), then one table per protocol (the refined one with the
    maximum-likelihood column) with costs, interventions and the refinement's verdict per seed, the flags, and the
    protocol last."""
    summ = table2_summary(doc)
    ml = table2_ml_summary(doc)
    ml_passes = max(k for _, k in summ)
    exp = doc["experiment"]
    paper = doc["paper_errors_percent"]
    lines = [
        f"# Table 2 analog: {exp['model']} under {exp['record']['name']}",
        "",
        "Errors are |estimate - true| / |true| in %, worst over the reported seeds; † = flagged practically "
        "unidentifiable (these data cannot pin it within 5 % at 3 sigma); `table2_errors.png` draws every "
        "column. The protocol is at the end.",
        "",
        *_summary_rows(summ, ml, ml_passes),
        "",
        *_above_floor(doc, with_ml=bool(ml)),
    ]
    protocol = [
        "## Protocol",
        "",
        f"Noise {100 * exp['noise_ratio']:g} % (RMS) on input and output; branch table: {doc['branch_table']}; "
        f"tuning seeds {doc['tuning_seeds']} (never reported)"
        + (f"; tuning by {doc['tuning_protocol']}" if doc.get("tuning_protocol") else "")
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
    for passes in sorted({k for _, k in summ}):
        methods = [m for m in _T2_METHODS if (m, passes) in summ]
        with_ml = ml if passes == ml_passes else None
        # each column's summary: the filters', the maximum likelihood's after the refined protocol, DUKF-zero last
        columns = (
            [(m, summ[(m, passes)]) for m in methods if m != "dukf-zero"]
            + ([("ml", with_ml)] if with_ml else [])
            + [(m, summ[(m, passes)]) for m in methods if m == "dukf-zero"]
        )
        cols = [m for m, _ in columns]
        lines += [f"## {_passes_title(passes)}", ""]
        head = "| parameter | true | guess | " + " | ".join(
            "ML mean est. | ML mean % | ML worst % | ML std %"
            if m == "ml"
            else f"{_T2_METHODS[m]} mean est. | {_T2_METHODS[m]} mean % | {_T2_METHODS[m]} worst %"
            for m in cols
        )
        head += " | paper UKF % | paper DUKF % |" if passes == 1 else " |"
        lines += [head, "|" + "---|" * (head.count("|") - 1)]
        for i, p in enumerate(summ[(methods[0], passes)]["parameters"]):
            cells = [_T2_MD.get(p, p), f"{exp['truth'][p]:.4g}", f"{exp['guess'][p]:.4g}"]
            for m, s in columns:
                mark = " †" if _t2_flagged(s, p) else ""
                cells += [
                    _num(s["mean_estimate"][i], ".4g"),
                    _num(s["mean_abs_error"][i], ".2f") + mark,
                    _num(s["worst_abs_error"][i], ".2f") + mark,
                ]
                if m == "ml":
                    cells.append(_num(s["mean_std_percent"][i], ".3g", inf="flat"))
            if passes == 1:
                cells += [f"{paper['ukf'][p]:.2f}", f"{paper['dukf'][p]:.2f}"]
            lines.append("| " + " | ".join(cells) + " |")
        if all(s["yield"] for _, s in columns):  # what the ridge leaves informed
            for d in ("Delta1", "Delta2"):
                true = summ[(methods[0], passes)]["yield"][d][0]
                cells = [f"abs({_T2_MD[d]})^(-1/2N) (yield displ.)", f"{true:.4g}", "-"]
                for m, s in columns:
                    e = np.asarray(s["yield"][d][1], float)
                    mean_worst = [f"{np.nanmean(e):.2f}", f"{np.nanmax(e):.2f}"] if np.isfinite(e).any() else ["-", "-"]
                    cells += ["-", *mean_worst] + (["-"] if m == "ml" else [])  # "-": no seed ran to the end
                if passes == 1:
                    cells += ["-", "-"]
                lines.append("| " + " | ".join(cells) + " |")
        lines += [
            "",
            "| filter | tuning (s0, q_theta, q_x, gate) | s per run | s per pass | repairs | interventions "
            "(all seeds) | implicit sigma-point steps | output misfit | 5 % goal (worst seed, unflagged) "
            "| 5 % goal, linearised flags only |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for m in methods:
            s = summ[(m, passes)]
            lines.append(
                f"| {_T2_METHODS[m]} | {_t2_tuning(s['tuning'])} | {s['seconds']:.3f} | "
                f"{s['seconds_per_pass']:.3f} | {s['repairs']} | {_t2_kinds(s)} | {s['implicit']} | "
                f"{_t2_misfit(s)} | {_t2_goal(s)} | {_t2_goal(s, 'flag_counts_linearised')} |"
            )
        redone = [(m, r) for m in methods for r in summ[(m, passes)]["redone"]]
        if redone:
            factor = doc.get("diverged_factor", 10)
            floor = doc.get("noise_floor_factor")  # absent: a document of the former rule (redone when diverged)
            lines += [
                "",
                f"Redone (the run diverged: it stopped or its output misfit was above {factor:g}x the "
                "noise level; the next configuration of the tuning ranking was run instead):"
                if floor is None
                else f"Chosen on the seed's own data (the tuning's first choice left an output misfit above "
                f"{floor:g}x the noise level or stopped: the next configurations of the tuning ranking ran on "
                f"the same data, at most {doc.get('fallbacks')} more, and the smallest misfit is reported):",
                "",
            ]
            for m, (seed, attempts, final) in redone:
                tried = "; ".join(
                    f"({_t2_tuning(a['tuning'])}) misfit "
                    + (f"{a['output_misfit']:.3g}" if a["output_misfit"] is not None else "inf")
                    + (f", {a['error']}" if a["error"] else "")
                    for a in attempts
                )
                lines.append(f"- {_T2_METHODS[m]}, seed {seed}: {tried} -> ({_t2_tuning(final)})")
        if with_ml:
            lines += ["", *_ml_markdown(doc, with_ml)]
        lines.append("")
    lines += ["## Practically unidentifiable (flag counts over seeds)", ""]
    for (m, k), s in sorted(summ.items()):
        flags = ", ".join(f"{_T2_MD.get(p, p)} {c}/{len(s['seeds'])}" for p, c in s["flag_counts"].items() if c)
        undecided = "".join(f"; not decided on seed {seed}: {why}" for seed, why in s["undecided"])
        spread = (
            "; Monte-Carlo std (mean over seeds) "
            + ", ".join(
                f"{_T2_MD.get(p, p)} " + (f"{100 * v:.2g} %" if np.isfinite(v) else "held")
                for p, v in zip(s["parameters"], s["spread"])
            )
            if s["spread"]
            else ""
        )
        lines.append(f"- {_T2_METHODS[m]}, {k} pass(es): {flags or 'none'}{undecided}{spread}")
    if ml:
        flags = ", ".join(f"{_T2_MD.get(p, p)} {c}/{len(ml['seeds'])}" for p, c in ml["flag_counts"].items() if c)
        lines.append(f"- ML (std above {_ML_PIN:.3g} %): {flags or 'none'}")
    stopped = [r for r in doc["runs"] if r.get("error")]
    if stopped:
        lines += ["", "## Runs that stopped (reported, not dropped)", ""]
        lines += [
            f"- {_T2_METHODS[r['method']]}, {r['passes']} pass(es), seed {r['seed']}: {r['error']}" for r in stopped
        ]
    for k in sorted({k for m, k in summ if m == "ukf"}):
        first: Mapping[str, Any] = next(
            (
                r["practical_identifiability"]
                for r in doc["runs"]
                if r["method"] == "ukf" and r["passes"] == k and r.get("practical_identifiability")
            ),
            {},
        )
        if first.get("reasons") or first.get("undecided"):
            lines += ["", f"Reasons (first seed of the UKF, {k} pass(es)):", ""]
            lines += [f"- {_T2_MD.get(p, p)}: {why}" for p, why in first.get("reasons", {}).items()]
            lines += [f"- {_T2_MD.get(p, p)}: not decided, {why}" for p, why in (first.get("undecided") or {}).items()]
    lines += ["", *protocol]
    return "\n".join(lines).rstrip("\n") + "\n"


def _passes_title(passes: int) -> str:
    return "one pass (the paper's protocol)" if passes == 1 else f"{passes} passes over the record"


def _num(v: Any, fmt: str, *, inf: str = "-") -> str:
    """A number in ``fmt``; ``-`` for a missing one, ``inf`` for an infinite one."""
    if v is None or np.isnan(v):
        return "-"
    return inf if np.isinf(v) else format(v, fmt)


def _ml_markdown(doc: Mapping[str, Any], ml: Mapping[str, Any]) -> list[str]:
    """The refinement's protocol, its verdict per seed, and its goals."""
    n = len(ml["runs"])
    within, of = ml["within_4_std"]
    goal = _ml_goal(ml)
    lines = [
        f"ML column: {doc.get('refinement_protocol') or 'maximum likelihood'}. † in the ML column: its std "
        "(the Fisher information's, the measured input's noise propagated) is above "
        f"{_ML_PIN:.3g} % of the estimate on at least half of the seeds (the 5 % band cannot be "
        f"reached at 3 sigma; 'flat': no information at all). Converged on {len(ml['converged'])} of {n} "
        f"seed(s); 5 % goal (worst seed, unflagged): {goal}; unflagged estimates within 4 std (or 1 %) "
        f"of the truth: {within} of {of}.",
        "",
        "| seed | started from (its output misfit) | iterations | s | residual RMS / noise | converged | reason |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in ml["runs"]:
        st = r["start"]
        start = (
            f"{_T2_METHODS.get(st['method'], st['method'])}, {st['passes']} pass(es) "
            f"({_num(st['output_misfit'], '.3g')})"
        )
        fit = ", ".join(f"{k} {_num(v, '.3f')}" for k, v in r["misfit_over_noise"].items()) or "-"
        verdict = "could not run" if r.get("error") else ("yes" if r["converged"] else "NO")
        why = (r.get("error") or r["reason"] or "").replace("|", "/")
        if r.get("at_edge"):
            why += f" (on the edge of the valid region: {', '.join(r['at_edge'])})"
        if (r.get("adequacy") or {}).get("passed") is False:
            why += "; NOT adequate: the model does not explain the data to the noise level"
        lines.append(
            f"| {r['seed']} | {start} | {r['iterations']} | {_num(r['seconds'], '.1f')} | {fit} | {verdict} | {why} |"
        )
    return lines


def table2_latex(doc: Mapping[str, Any]) -> str:
    """The Table 2 analog as a booktabs LaTeX table (one pass and refined, UKF and DUKF, worst seed; then the
    maximum-likelihood refinement: mean and worst error, mean std)."""
    summ = table2_summary(doc)
    ml = table2_ml_summary(doc)
    exp = doc["experiment"]
    keys = [k for k in sorted(summ, key=lambda k: (k[1], k[0])) if k[0] in ("ukf", "dukf")]
    blocks = [summ[k] for k in keys] + ([ml] if ml else [])
    ridge = all(b["yield"] for b in blocks)
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
    for i, p in enumerate(summ[keys[0]]["parameters"]):
        cells = [_T2_TEX.get(p, p), f"{exp['truth'][p]:.3g}", f"{exp['guess'][p]:.3g}"]
        for s in blocks:
            mark = r"$^\dagger$" if _t2_flagged(s, p) else ""
            cells += [_num(s["mean_abs_error"][i], ".2f") + mark, _num(s["worst_abs_error"][i], ".2f") + mark]
        if ml:
            cells.append(_num(ml["mean_std_percent"][i], ".2g", inf="flat"))
        rows.append(" & ".join(cells) + r" \\")
    if ridge:  # the combinations the Delta-N ridge leaves informed
        rows.append(r"\midrule")
        for d in ("Delta1", "Delta2"):
            true = summ[keys[0]]["yield"][d][0]
            cells = [rf"$|{_T2_TEX[d].strip('$')}|^{{-1/2N}}$", f"{true:.3g}", "--"]
            for s in blocks:
                e = s["yield"][d][1]
                cells += [f"{np.nanmean(e):.2f}", f"{np.nanmax(e):.2f}"]
            rows.append(" & ".join(cells + (["--"] if ml else [])) + r" \\")
    ml_text = ""
    if ml:
        st = {r["start"]["passes"] for r in ml["runs"]}
        ml_text = (
            rf"; ML: maximum likelihood (output error) started on each seed from the better "
            rf"{'/'.join(map(str, sorted(st)))}-pass filter estimate (smaller output misfit), std from the "
            rf"Fisher information with the input's noise propagated, converged on {len(ml['converged'])} of "
            rf"{len(ml['runs'])} seeds, "
            rf"$^\dagger$ there: std above 5/3\,\%"
        )
    return (
        "\n".join(
            [
                r"\begin{table}[ht]",
                r"\centering",
                rf"\caption{{Table 2 analog ({tex_escape(exp['record']['name'])}, {100 * exp['noise_ratio']:g}\,\% noise, "
                rf"{len(summ[keys[0]]['seeds'])} seeds). $^\dagger$ practically unidentifiable on this record"
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
