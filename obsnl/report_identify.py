"""Rendering of the Table 2 analog (Markdown and LaTeX) from the ``table2.json`` document.

Everything here reads the plain dictionary written by ``obsnl reproduce`` (``Reproduction.to_dict()``),
so a committed ``table2.json`` can be re-rendered without running anything.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["summarize", "table2_markdown", "table2_latex"]

_TEX = {"k_m": r"$k_m$", "c_dm": r"$c_{dm}$", "c_eta_p": r"$c'_\eta$", "w_h": r"$w_h$", "c_p": r"$c'$",
        "h_p": r"$h'$", "Delta1": r"$\Delta_1$", "Delta2": r"$\Delta_2$", "N": r"$N$"}
_MD = {"k_m": "k_m", "c_dm": "c_dm", "c_eta_p": "c'_eta", "w_h": "w_h", "c_p": "c'", "h_p": "h'",
       "Delta1": "Δ1", "Delta2": "Δ2", "N": "N"}
_METHODS = {"ukf": "UKF", "dukf": "DUKF", "dukf-zero": "DUKF, P_AU = 0"}


def summarize(doc: Mapping[str, Any]) -> dict[tuple[str, int], dict[str, Any]]:
    """Per (method, passes): mean estimate, mean and worst |error| per parameter, flags, cost."""
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
        flags = {p: sum(p in r["practically_unidentifiable"] for r in runs) for p in params}
        out[key] = {
            "parameters": params, "seeds": [r["seed"] for r in runs], "mean_estimate": est.mean(axis=0),
            "mean_abs_error": err.mean(axis=0), "worst_abs_error": err.max(axis=0),
            "worst_seed": [runs[i]["seed"] for i in err.argmax(axis=0)], "flag_counts": flags,
            "seconds": float(np.mean(np.array([r["seconds"] for r in runs], float))),
            "seconds_per_pass": float(np.mean(np.array([r["seconds"] for r in runs], float) / key[1])),
            "repairs": int(sum(r["repairs"] for r in runs)),
            "implicit": int(sum(r["implicit_sigma_point_steps"] for r in runs)),
            "misfit": float(np.mean(np.array([r["output_misfit"] for r in runs], float))),
            "tuning": runs[0]["tuning"], "failed": [(r["seed"], r["error"]) for r in failed],
        }
    return out


def _flagged(s: Mapping[str, Any], p: str) -> bool:
    return s["flag_counts"][p] * 2 >= len(s["seeds"])


def _goal(s: Mapping[str, Any]) -> str:
    if s["failed"]:
        return f"not met ({len(s['failed'])} run(s) diverged: seed {', '.join(str(k) for k, _ in s['failed'])})"
    worst = [(p, w) for p, w in zip(s["parameters"], s["worst_abs_error"]) if not _flagged(s, p)]
    bad = [f"{_MD.get(p, p)} {w:.1f} %" for p, w in worst if w > 5.0]
    return "met" if not bad else "not met (" + ", ".join(bad) + ")"


def table2_markdown(doc: Mapping[str, Any]) -> str:
    """The Table 2 analog as Markdown: one table per protocol, then costs and flags."""
    summ = summarize(doc)
    exp = doc["experiment"]
    paper = doc["paper_errors_percent"]
    lines = [f"# Table 2 analog: {exp['model']} under {exp['record']['name']}", "",
             f"Noise {100 * exp['noise_ratio']:g} % (RMS) on input and output; branch table: {doc['branch_table']}; "
             f"tuning seeds {doc['tuning_seeds']} (never reported). Errors are |estimate - true| / |true| in %; "
             f"mean and worst over the reported seeds that ran to the end. † = flagged practically unidentifiable in at least half "
             f"of the seeds (not an estimate; see the flags below).", ""]
    for passes in sorted({k for _, k in summ}):
        methods = [m for m in ("ukf", "dukf", "dukf-zero") if (m, passes) in summ]
        if not methods:
            continue
        title = "one pass (the paper's protocol)" if passes == 1 else f"{passes} passes over the record"
        lines += [f"## {title}", ""]
        head = "| parameter | true | guess | " + " | ".join(
            f"{_METHODS[m]} mean est. | {_METHODS[m]} mean % | {_METHODS[m]} worst %" for m in methods)
        head += " | paper UKF % | paper DUKF % |" if passes == 1 else " |"
        lines += [head, "|" + "---|" * (head.count("|") - 1)]
        first = summ[(methods[0], passes)]
        for i, p in enumerate(first["parameters"]):
            cells = [_MD.get(p, p), f"{exp['truth'][p]:.4g}", f"{exp['guess'][p]:.4g}"]
            for m in methods:
                s = summ[(m, passes)]
                mark = " †" if _flagged(s, p) else ""
                cells += [f"{s['mean_estimate'][i]:.4g}", f"{s['mean_abs_error'][i]:.2f}{mark}",
                          f"{s['worst_abs_error'][i]:.2f}{mark}"]
            if passes == 1:
                cells += [f"{paper['ukf'][p]:.2f}", f"{paper['dukf'][p]:.2f}"]
            lines.append("| " + " | ".join(cells) + " |")
        lines += ["", "| filter | tuning (s0, q_theta, q_x) | s per run | s per pass | repairs | implicit "
                      "sigma-point steps | output misfit | 5 % goal (worst seed, unflagged) |",
                  "|---|---|---|---|---|---|---|---|"]
        for m in methods:
            s = summ[(m, passes)]
            t = s["tuning"]
            lines.append(f"| {_METHODS[m]} | {t['s0']:g}, {t['q_theta']:g}, {t['q_x']:g} | {s['seconds']:.3f} | "
                         f"{s['seconds_per_pass']:.3f} | {s['repairs']} | {s['implicit']} | {s['misfit']:.5f} | "
                         f"{_goal(s)} |")
        lines.append("")
    lines += ["## Practically unidentifiable (flag counts over seeds)", ""]
    for (m, k), s in sorted(summ.items()):
        flags = ", ".join(f"{_MD.get(p, p)} {c}/{len(s['seeds'])}" for p, c in s["flag_counts"].items() if c)
        lines.append(f"- {_METHODS[m]}, {k} pass(es): {flags or 'none'}")
    stopped = [r for r in doc["runs"] if r.get("error")]
    if stopped:
        lines += ["", "## Runs that stopped (reported, not dropped)", ""]
        lines += [f"- {_METHODS[r['method']]}, {r['passes']} pass(es), seed {r['seed']}: {r['error']}" for r in stopped]
    reasons = _example_reasons(doc["runs"])
    if reasons:
        lines += ["", "Reasons (first seed of the UKF, one pass):", ""]
        lines += [f"- {_MD.get(p, p)}: {why}" for p, why in reasons.items()]
    return "\n".join(lines) + "\n"


def _example_reasons(runs: Sequence[Mapping[str, Any]]) -> Mapping[str, str]:
    for r in runs:
        if r["method"] == "ukf" and r["passes"] == 1 and r.get("practical_identifiability"):
            return r["practical_identifiability"]["reasons"]
    return {}


def table2_latex(doc: Mapping[str, Any]) -> str:
    """The Table 2 analog as a booktabs LaTeX table (one pass and refined, UKF and DUKF, worst seed)."""
    summ = summarize(doc)
    exp = doc["experiment"]
    keys = [k for k in sorted(summ, key=lambda k: (k[1], k[0])) if k[0] in ("ukf", "dukf")]
    cols = "l" + "r" * (2 + 2 * len(keys))
    head = " & ".join(["", "true", "guess"] + [
        rf"\multicolumn{{2}}{{c}}{{{_METHODS[m]}, {k} pass{'es' if k > 1 else ''}}}" for m, k in keys]) + r" \\"
    sub = " & ".join(["", "", ""] + ["mean \\%", "worst \\%"] * len(keys)) + r" \\"
    rows = []
    params = summ[keys[0]]["parameters"]
    for i, p in enumerate(params):
        cells = [_TEX.get(p, p), f"{exp['truth'][p]:.3g}", f"{exp['guess'][p]:.3g}"]
        for key in keys:
            s = summ[key]
            mark = r"$^\dagger$" if _flagged(s, p) else ""
            cells += [f"{s['mean_abs_error'][i]:.2f}{mark}", f"{s['worst_abs_error'][i]:.2f}{mark}"]
        rows.append(" & ".join(cells) + r" \\")
    return "\n".join([
        r"\begin{table}[ht]", r"\centering",
        rf"\caption{{Table 2 analog ({exp['record']['name']}, {100 * exp['noise_ratio']:g}\,\% noise, "
        rf"{len(summ[keys[0]]['seeds'])} seeds). $^\dagger$ practically unidentifiable on this record.}}",
        rf"\begin{{tabular}}{{{cols}}}", r"\toprule", head, sub, r"\midrule", *rows, r"\bottomrule",
        r"\end{tabular}", r"\end{table}"]) + "\n"


def write_reproduction(rep: Any, out: Any) -> list[Any]:
    """Write ``table2.json/.md/.tex``, ``branch_table.json`` and the figures of a reproduction into ``out``."""
    import json
    from pathlib import Path

    from .plots import figure2, figure3

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    doc = rep.to_dict()
    files = [out / "table2.json", out / "table2.md", out / "table2.tex", out / "branch_table.json"]
    files[0].write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    files[3].write_text(rep.table.to_json(), encoding="utf-8")  # the DUKF's input, from the analysis
    files[1].write_text(table2_markdown(doc), encoding="utf-8")
    files[2].write_text(table2_latex(doc), encoding="utf-8")
    s = rep.setup
    summ = summarize(doc)
    t = s.record.t
    for k in sorted({k for _, k in rep.trajectories}):
        trs = {m: rep.trajectories[(m, k)] for m in ("ukf", "dukf") if (m, k) in rep.trajectories}
        if not trs:
            continue
        from .identify import make_data

        data = make_data(s, 0)
        tag = "1pass" if k == 1 else f"{k}passes"
        files.append(figure2(out / f"fig2_{tag}.png", t=t, accel=data.u, y_measured=data.y,
                             estimates={f"{m.upper()} (pass {k})": tr[-1].x[:, 0] for m, tr in trs.items()},
                             title=s.record.name))
        flagged = [p for p in s.model.parameters if any(_flagged(summ[(m, k)], p) for m in trs if (m, k) in summ)]
        tt = np.concatenate([t + i * (t[-1] + s.record.dt) for i in range(k)])
        panels = {f"({chr(97 + i)}) {m.upper()}" + (f", {k} passes back to back" if k > 1 else ""):
                  np.vstack([tr.theta for tr in trs[m]]) for i, m in enumerate(trs)}
        files.append(figure3(out / f"fig3_{tag}.png", t=tt, panels=panels, truth=s.theta_true,
                             parameters=s.model.parameters, flagged=flagged))
    return files
