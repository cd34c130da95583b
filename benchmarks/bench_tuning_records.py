"""Does the main job's tuning hold off its own record?  (issue 40, item 7)

``obsnl reproduce`` ranks the filter configurations by successive halving on tuning noise seeds of the record it is
given; each reported run then confirms the first choice on its own data or, where it leaves the free-run output
misfit above ``FLOOR`` times the noise level, runs the next configurations of the ranking on those data and reports
the smallest misfit (``obsnl.studies.seed_runs``). This runs the main job on Northridge LOS270 (the seed paper's
record, on which the tuning grid and the halving were chosen) and on LOS000 (the same station's other component)
and writes the UKF's, the DUKF's and the maximum-likelihood column's |error| per parameter, mean and worst over the
reported seeds, next to the committed reports' numbers ("before": the table2.json files at ``--before``, read with
git; the former rule reported the tuning's choice unless the run diverged, misfit above 10x the noise level).

Run from the repository root, with this tree's obsnl importable (e.g. ``PYTHONPATH=.``):
``python benchmarks/bench_tuning_records.py [--seeds 5] [--replicates 0] [--out reports/benchmarks/tuning_records.md]``
(7.5 minutes per record measured on two workers of a machine shared with other jobs, without replicates; the
replicates only change the flags, which the tables here do not use). ``--force`` replaces an existing output.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import obsnl
from obsnl.executor import Executor
from obsnl.report.files import safe_write
from obsnl.studies.seed_paper import reproduce
from obsnl.studies.seed_runs import CANDIDATES, FLOOR

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_likelihood as B  # noqa: E402  (its revision())

DATA = ROOT / "obsnl" / "studies" / "data"
#: record label -> (file of the record, None: the main job's default; folder of its committed Table 2)
RECORDS = {
    "LOS270": (None, "reports/identification/table2.json"),
    "LOS000": (
        "northridge1994_LOS000_femap695_ngawest1_accel.csv",
        "reports/identification/northridge1994_LOS000_femap695_ngawest1_accel/table2.json",
    ),
}
ROWS = (
    ("UKF, 1 pass", "ukf", 1),
    ("DUKF, 1 pass", "dukf", 1),
    ("UKF, 3 passes", "ukf", 3),
    ("DUKF, 3 passes", "dukf", 3),
)


#: What the numbers say, written on the run at commit bd552d0 with this change applied (5 seeds, no replicates); a
#: rerun on other code must read its own tables before it keeps this text.
READING = """## Reading

Where the tuning decision is taken: on the record at hand. The tuning seeds (1000-1004) are noise seeds of the
record `obsnl reproduce --record` is given (`seed_tasks.tuning_task` builds its experiment from that record), and
the ranking on LOS000 is LOS000's own. What was fixed on LOS270 is the grid (48 configurations), the halving's rung
(12) and the reported run's fallback rule, which kept the tuning's first choice unless the run diverged (misfit above
10x the noise level) and tried at most two more.

The degradation on LOS000 came from that rule: on reported seed 2 the DUKF's first four configurations diverge or
stop in both protocols (misfit 705-717x), so the former rule reported a diverged run (N 12967 %, h' 7886 %, w_h
585 % with three passes). Now each reported run confirms the choice on its own data (misfit at most 2x the noise
level) or tries the next configurations of the ranking there, at most 6 in all, and reports the smallest misfit: the
DUKF's seed 2 ends at 3.2x (three passes) and 7.3x (one pass), and its worst error on LOS000 falls from thousands of
per cent to h' 9.5 %, Delta 8.4 / 8.2 % (three passes) and h' 9.5 %, Delta2 8.7 % (one pass). The UKF with one
pass gains a little on LOS000 (seed 0 from 4.7x to 3.9x: Delta2 worst 3.21 to 2.20 %, h' 11.29 to 10.86 %). The
UKF with three passes (worst h' 3.72 %) and the ML column are bit for bit the same on both records.

What the rule cannot do: the DUKF stays above the noise floor on LOS000 on every seed with every configuration it
tried (2.1-7.3x), and a lower misfit does not make it more accurate. Every one of the 48 configurations run on the
5 reported seeds of LOS000 (an exploration outside this script, not committed), the smallest misfit per seed taken
over the whole grid, still leaves Delta 8.4 / 8.2 % and h' 13 % for the DUKF with three passes. Its error there is
its own (the frozen parameters of the branch table, `reports/identification/notes.md`), not its tuning's. On such
data the maximum-likelihood column carries the result (LOS000: w_h 1.46 % worst, every other unflagged parameter
within 0.3 %); Table 2 now names the runs left above the noise floor under its summary and says so.

Northridge LOS270 (the main job's Table 2): the tuning is the same (the same chosen configurations and scores), the
UKF columns of both protocols and the ML column are bit for bit the same. The DUKF changes on seeds 0 and 1 (one
pass) and 0 (three passes), the ablation (P_AU = 0) on four runs: DUKF one pass worst Delta1 14.33 to 16.13 %, w_h
3.55 to 4.06 %; three passes h' 2.89 to 1.43 %, Delta2 1.88 to 3.14 %. So Table 2's DUKF and ablation columns (and
their Monte-Carlo flags, not computed here) change when the main job is regenerated; its UKF and ML columns do not.

Cost: the reported attempts rise from 33 to 67 on LOS270 and from 41 to 141 on LOS000 (the DUKF and its ablation
try every allowed configuration where none reaches the floor): about 43 and 112 more filter-seconds at this run's
load (each run's seconds about twice the committed quiet-machine ones), by these counts some 10-30 s of wall on two
quiet workers (an estimate, not measured) against a job of about 4-5 minutes; the tuning itself is unchanged.

Checked besides this script: the whole main job (`obsnl reproduce`, LOS270, 5 seeds, 32 Monte-Carlo replicates per
run, the ML refinements) with this change, against the committed `reports/identification/table2.json`: the
tuning, every UKF run (estimates, flags, Monte-Carlo spreads) and every ML refinement are equal; Table 2's summary
changes only in the DUKF rows (one pass: worst unflagged still 18.61 % (Delta2), Delta1 14.3 to 16.1 %; three passes:
worst unflagged 2.89 % (h') to 1.70 % (w_h), the goal met in both) and the ablation's, and it gains the line that
names the runs left above the noise floor (DUKF one pass seeds 0 and 2, three passes seeds 0 and 3). 22 minutes of
wall on a machine at load 7-12 (not a measure of the job's time).
"""


def errors(doc: dict[str, Any], method: str, passes: int | None) -> dict[str, list[float]]:
    """|error| in % per parameter over the reported seeds (ML: ``method="ml"``); runs without an estimate left out."""
    runs = (
        doc["refinements"]
        if method == "ml"
        else [r for r in doc["runs"] if r["method"] == method and r["passes"] == passes]
    )
    out: dict[str, list[float]] = {}
    for r in runs:
        for p, v in r["parameters"].items():
            if v["error_percent"] is not None:
                out.setdefault(p, []).append(abs(v["error_percent"]))
    return out


def cell(values: list[float]) -> str:
    return f"{np.mean(values):.2f} / {max(values):.2f}" if values else "-"


def misfits(doc: dict[str, Any], method: str, passes: int) -> str:
    """The reported runs' output misfits in times the noise level, seed by seed."""
    noise = doc["experiment"]["noise_ratio"]
    ms = [r["output_misfit"] for r in doc["runs"] if r["method"] == method and r["passes"] == passes]
    return ", ".join("stopped" if m is None else f"{m / noise:.1f}" for m in ms)


def choices(doc: dict[str, Any]) -> list[str]:
    """One line per reported run whose first configuration was not kept, or that tried others."""
    noise = doc["experiment"]["noise_ratio"]

    def cfg(t: dict[str, Any]) -> str:
        gate = "off" if t["gate"] is None else f"{t['gate']:g}"
        return f"({t['s0']:g}, {t['q_theta']:g}, {t['q_x']:g}, {gate})"

    def mf(m: float | None) -> str:
        return "stopped" if m is None else f"{m / noise:.3g}x"

    lines = []
    for r in doc["runs"]:
        if r["method"] in ("ukf", "dukf") and r["redone"]:
            tried = "; ".join(f"{cfg(a['tuning'])} {mf(a['output_misfit'])}" for a in r["redone"])
            lines.append(
                f"- {r['method'].upper()}, {r['passes']} pass(es), seed {r['seed']}: tried {tried} -> "
                f"reported {cfg(r['tuning'])} {mf(r['output_misfit'])}"
            )
    return lines


def table(before: dict[str, Any], after: dict[str, Any]) -> list[str]:
    names = list(after["runs"][0]["parameters"])
    lines = [
        "| filter | table | " + " | ".join(names) + " | output misfit / noise, seeds 0-4 |",
        "|---|---|" + "---|" * len(names) + "---|",
    ]
    for label, m, k in (*ROWS, ("ML (from the better filter's 3-pass estimate)", "ml", None)):
        for tag, doc in (("before", before), ("after", after)):
            e = errors(doc, m, k)
            mis = "-" if m == "ml" else misfits(doc, m, k or 0)
            lines.append(f"| {label} | {tag} | " + " | ".join(cell(e.get(p, [])) for p in names) + f" | {mis} |")
    return lines


def git_json(repo: Path, commit: str, path: str) -> dict[str, Any]:
    out = subprocess.run(["git", "-C", str(repo), "show", f"{commit}:{path}"], capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(f"cannot read {path} at {commit}: {out.stderr.strip()} (give --before and --repo)")
    return json.loads(out.stdout)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--replicates", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--records", nargs="+", default=list(RECORDS), choices=list(RECORDS))
    ap.add_argument("--before", default="bd552d0", help="the commit whose committed reports are 'before'")
    ap.add_argument("--repo", default=str(ROOT), help="the git repository holding --before")
    ap.add_argument("--revision", default=None, help="say which code ran (default: this tree's commit)")
    ap.add_argument("--save-json", default=None, help="also write each record's table2 document into this folder")
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmarks" / "tuning_records.md"))
    ap.add_argument("--force", action="store_true")
    a = ap.parse_args(argv)
    sections, walls = [], []
    for label in a.records:
        file, committed = RECORDS[label]
        record = obsnl.read_record(str(DATA / file)) if file else None
        before = git_json(Path(a.repo), a.before, committed)
        tic = time.perf_counter()
        rep = reproduce(record=record, seeds=a.seeds, replicates=a.replicates, executor=Executor(workers=a.workers))
        wall = time.perf_counter() - tic
        after = json.loads(json.dumps(rep.to_dict()))
        if a.save_json:
            Path(a.save_json, f"table2_{label}.json").write_text(json.dumps(after, indent=1) + "\n")
        walls.append(f"{label} {wall / 60:.1f} min")
        chosen = choices(after)
        sections += [
            f"## {label}",
            "",
            "|error| in %, mean / worst over the reported seeds (every parameter; the committed tables flag c' on "
            "every record and mark the Deltas and h' by the Monte-Carlo spread, which this table does not use).",
            "",
            *table(before, after),
            "",
            f"Reported runs whose tuning's first choice left a misfit above {FLOOR:g}x the noise level ('after'):",
            "",
            *(chosen or ["- none"]),
            "",
        ]
        print("\n".join(sections[-len(chosen) - 2 :]), flush=True)
    text = "\n".join(
        [
            "# The main job's tuning on the record at hand: LOS270 and LOS000",
            "",
            f"Written by `python benchmarks/bench_tuning_records.py --seeds {a.seeds} --replicates {a.replicates}` "
            f"({a.revision or 'obsnl ' + B.revision()}; {platform.machine()}; wall {', '.join(walls)} on a "
            f"machine shared with other jobs). 'before': the committed reports at {a.before} (the former rule: the "
            f"tuning's first choice unless the run diverged, misfit above 10x the noise level, then the next, at most "
            f"2 more, the last reported). 'after': the same tuning (successive halving on tuning noise seeds of the "
            f"same record), each reported run's configuration confirmed on its own data (misfit at most {FLOOR:g}x "
            f"the noise level), else the smallest misfit of the first {CANDIDATES} configurations of the ranking on "
            "those data. No true value is used by either rule; the errors below use it to score.",
            "",
            *sections,
            READING,
        ]
    )
    safe_write(a.out, text, force=a.force)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
