"""``reproduce``: serial vs local processes vs Dask; or the whole main job against another revision.

Plain script (no pytest):

    python benchmarks/bench_reproduce.py [--grid 4] [--seeds 1] [--tuning-seeds 1] [--replicates 3]
                                         [--samples N] [--out reports/benchmarks/reproduce.md]
    python benchmarks/bench_reproduce.py --main-job --against REV [--order other,this]
                                         [--out reports/benchmarks/reproduce_main_job.md]

The first form runs :func:`obsnl.studies.seed_paper.reproduce` with the same arguments on each executor,
one after the other (the compiled filters come from the disk cache; a first run compiles them), reports
the wall times and checks that the runs' estimates, misfits, tunings and Monte-Carlo spreads are equal
(``--grid`` takes the first configurations and tunes on the full grid of them). The full protocol is
``--grid 48 --seeds 5 --tuning-seeds 5 --replicates 32``.

The second form times the main job as a user runs it, ``obsnl reproduce --out DIR`` (the command line of
each revision, its default options), on a cold cache (``OBSNL_CACHE_DIR`` a fresh empty folder) for this
checkout and for ``REV`` (checked out into a temporary git worktree), one after the other in ``--order``,
each in a fresh interpreter, with the 1-minute load average before and after each and the CPU seconds of
its processes; then compares the two ``table2.json``: per filter, protocol and parameter the mean and worst
|error| against the truth, whether the estimates are the same, the chosen tunings, and this side's
maximum-likelihood column. The machine is not reserved: the ratio of the two walls, taken in the same
period, is the measure; the absolute times drift with the load.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _content(rep) -> list:
    doc = rep.to_dict()
    return [(r["method"], r["passes"], r["seed"], r["tuning"], r["parameters"], r["output_misfit"],
             r["practical_identifiability"], r["redone"]) for r in doc["runs"]] + [doc["tuning"]] + [
        {k: v for k, v in r.items() if k != "seconds"} for r in doc["refinements"]]


MAIN_JOB = r"""
import sys
sys.path.insert(0, sys.argv[1])
import obsnl
assert obsnl.__file__.startswith(sys.argv[1]), obsnl.__file__
from obsnl.cli import main
sys.exit(main(["reproduce", "--out", sys.argv[2]]))
"""


def _main_job(root: Path, out: Path) -> dict:
    """``obsnl reproduce --out out`` of the checkout ``root`` on a cold cache: wall, CPU, load."""
    import resource
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory(prefix="obsnl-cold-") as cache:
        os.chmod(cache, 0o700)
        env = {**os.environ, "OBSNL_CACHE_DIR": cache}
        load0, cpu0 = os.getloadavg()[0], resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", MAIN_JOB, str(root), str(out)], check=True, env=env,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
        cpu1, load1 = resource.getrusage(resource.RUSAGE_CHILDREN), os.getloadavg()[0]
    return {"wall": wall, "cpu": (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime),
            "load": (load0, load1)}


def _errors(doc: dict) -> dict:
    """Per (method, passes): parameter -> (mean |error|, worst |error|) over the seeds that ran, and the tuning."""
    import numpy as np

    out = {}
    for key in sorted({(r["method"], r["passes"]) for r in doc["runs"]}):
        runs = [r for r in doc["runs"] if (r["method"], r["passes"]) == key and not r.get("error")]
        errs = {p: [abs(r["parameters"][p]["error_percent"]) for r in runs] for p in runs[0]["parameters"]}
        out[key] = {p: (float(np.mean(e)), float(np.max(e))) for p, e in errs.items()}
    return out


def _same_estimates(a: dict, b: dict) -> dict:
    """Per (method, passes): the largest relative difference of an estimate between the two documents."""
    out: dict = {}
    for ra, rb in zip(a["runs"], b["runs"]):
        key = (ra["method"], ra["passes"])
        assert key == (rb["method"], rb["passes"]) and ra["seed"] == rb["seed"]
        d = max((abs(ra["parameters"][p]["estimate"] - rb["parameters"][p]["estimate"])
                 / abs(rb["parameters"][p]["estimate"]) if ra["parameters"][p]["estimate"] is not None
                 and rb["parameters"][p]["estimate"] is not None else float("inf")) for p in ra["parameters"])
        out[key] = max(out.get(key, 0.0), d)
    return out


def main_job(args: argparse.Namespace) -> None:
    import json
    import subprocess
    import tempfile

    rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.against], capture_output=True,
                         text=True, check=True).stdout.strip()
    here = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True, check=True).stdout.strip()
    if subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--", "obsnl"], capture_output=True,
                      text=True, check=True).stdout.strip():
        here += " + uncommitted changes"  # the package as it is in the working tree, not as committed
    times, docs = {}, {}
    with tempfile.TemporaryDirectory(prefix="obsnl-main-job-") as tmp:
        other = Path(tmp) / "other"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(other), rev], check=True,
                       capture_output=True)
        try:
            for side in args.order.split(","):
                root = ROOT if side == "this" else other
                times[side] = _main_job(root, Path(tmp) / f"out-{side}")
                docs[side] = json.loads((Path(tmp) / f"out-{side}" / "table2.json").read_text())
                t = times[side]
                print(f"{side}: {t['wall']:.1f} s wall, {t['cpu']:.0f} CPU-s, load {t['load'][0]:.2f} -> "
                      f"{t['load'][1]:.2f}", flush=True)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(other)], capture_output=True)
    old, new = docs["other"], docs["this"]
    eo, en, same = _errors(old), _errors(new), _same_estimates(new, old)
    mins = lambda s: f"{int(s // 60)} min {s % 60:.0f} s"  # noqa: E731
    lines = ["# The main job, `obsnl reproduce`, on a cold cache: this checkout against the previous protocol", "",
             f"Generated by `python benchmarks/bench_reproduce.py --main-job --against {args.against} --order "
             f"{args.order}` on {platform.machine()} ({os.cpu_count()} cores), Python {platform.python_version()}: "
             f"{here} (this checkout's working tree) against {rev}, each `obsnl reproduce --out DIR` "
             f"with its default options, a fresh empty `OBSNL_CACHE_DIR` (the three filters compiled), one after the "
             f"other. The machine was shared with other jobs: the 1-minute load average is given; the ratio is the "
             f"measure.", "",
             "| side | tuning | wall | CPU (all processes) | load before -> after |", "|---|---|---:|---:|---|"]
    for side, label in (("other", rev), ("this", here)):
        t = times[side]
        lines.append(f"| {label} | {docs[side].get('tuning_protocol') or 'full grid: 48 configurations x 5 tuning seeds'} "
                     f"| {mins(t['wall'])} | {t['cpu']:.0f} s | {t['load'][0]:.2f} -> {t['load'][1]:.2f} |")
    ratio = times["this"]["wall"] / times["other"]["wall"]
    lines += ["", f"Wall ratio {here} / {rev}: {ratio:.2f}; CPU ratio {times['this']['cpu'] / times['other']['cpu']:.2f}.",
              "", "## Table 2 before and after: mean / worst |error| in % over the reported seeds", "",
              "Same estimates: the largest relative difference of any reported estimate between the two runs, per "
              "filter and protocol (0: bit for bit the same runs).", ""]
    params = list(next(iter(eo.values())))
    lines += ["| filter, passes | " + " | ".join(params) + " | same estimates |",
              "|---|" + "---|" * (len(params) + 1)]
    for key in eo:
        for label, e in ((rev, eo), (here, en)):
            cells = [f"{e[key][p][0]:.2f} / {e[key][p][1]:.2f}" for p in params]
            lines.append(f"| {key[0].upper()}, {key[1]} ({label}) | " + " | ".join(cells)
                         + f" | {same[key]:.2g} |")
    refs = new.get("refinements") or []
    if refs:
        import numpy as np

        ran = [r for r in refs if not r.get("error")]
        cells = [f"{np.mean([abs(r['parameters'][p]['error_percent']) for r in ran]):.2f} / "
                 f"{np.max([abs(r['parameters'][p]['error_percent']) for r in ran]):.2f}" for p in params]
        lines.append(f"| ML, from the better filter ({here}) | " + " | ".join(cells) + " | - |")
        conv = sum(r["converged"] for r in ran)
        lines += ["", f"ML (new third column): converged on {conv} of {len(refs)} seeds; seconds per refinement "
                      + ", ".join(f"{r['seconds']:.0f}" for r in refs) + "."]
    tunings = [(t["method"], t["passes"], t["chosen"]) for t in old["tuning"]]
    chosen_new = {(t["method"], t["passes"]): t["chosen"] for t in new["tuning"]}
    lines += ["", "Chosen tunings equal: " + ", ".join(f"{m.upper()} {k} pass(es) "
                                                      f"{'yes' if chosen_new.get((m, k)) == c else 'NO'}"
                                                      for m, k, c in tunings) + "."]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text, encoding="utf-8")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--main-job", action="store_true", help="time obsnl reproduce against --against (cold cache)")
    ap.add_argument("--against", default="HEAD", help="with --main-job: the other revision")
    ap.add_argument("--order", default="other,this", help="with --main-job: which side runs first")
    ap.add_argument("--grid", type=int, default=4, help="first configurations of the tuning grid (48: all)")
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--tuning-seeds", type=int, default=1)
    ap.add_argument("--replicates", type=int, default=3)
    ap.add_argument("--samples", type=int, default=None)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    if args.main_job:
        return main_job(args)
    from distributed import Client, LocalCluster

    from obsnl.identification.setup import DEFAULT_GRID
    from obsnl.executor import Executor
    from obsnl.studies.seed_paper import reproduce

    kw = dict(seeds=args.seeds, tuning_seeds=args.tuning_seeds, grid=DEFAULT_GRID[:args.grid],
              replicates=args.replicates, samples=args.samples, keep=None)
    rows, contents = [], {}
    for label in ("serial", "2 local processes", "Dask LocalCluster, 2 workers"):
        t0 = time.perf_counter()
        if label.startswith("Dask"):
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                              dashboard_address=None) as cluster, Client(cluster) as client:
                rep = reproduce(**kw, executor=Executor(scheduler=client))
        else:
            rep = reproduce(**kw, executor=Executor(workers=1 if label == "serial" else 2))
        wall = time.perf_counter() - t0
        contents[label] = _content(rep)
        rows.append((label, wall, sum(rep.compile_seconds.values()), len(rep.runs)))
        print(f"{label:32s} {wall:7.1f} s (building the filters: {rows[-1][2]:.1f} s)", flush=True)
    same = all(c == contents["serial"] for c in contents.values())
    load = os.getloadavg()[0]
    n_tune = 2 * args.grid * args.tuning_seeds
    n_rep = 3 * 2 * args.seeds
    n_mc = args.replicates * args.seeds * 2 * 2
    print(f"equal results: {same}; load average {load:.2f}")
    if args.out:
        lines = ["# `obsnl reproduce`: serial, local processes, Dask", "",
                 f"Generated by `python benchmarks/bench_reproduce.py --grid {args.grid} --seeds {args.seeds} "
                 f"--tuning-seeds {args.tuning_seeds} --replicates {args.replicates}"
                 + (f" --samples {args.samples}" if args.samples else "") + f"` on {platform.machine()} "
                 f"({os.cpu_count()} cores; 1-minute load average {load:.2f} at the end), Python {platform.python_version()}. A reduced protocol: {n_tune} tuning "
                 f"runs, {n_rep} reported runs, {n_mc} Monte-Carlo replicates (the full grid: 480, 30, 640; "
                 f"plus one maximum-likelihood refinement per reported seed). "
                 f"Compiled filters from the disk cache. Results equal on every executor: "
                 f"{'yes' if same else 'NO'}.", "",
                 "| executor | wall (s) | building the filters (s) |", "|---|---:|---:|"]
        lines += [f"| {k} | {w:.1f} | {c:.1f} |" for k, w, c, _ in rows]
        Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
