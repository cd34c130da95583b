"""How long obsnl takes to identify the Bouc-Wen benchmark's whole training record (issue 40's goal: under 60 s on a
2-core machine, compiled).

The band-limited identification of ``bench_boucwen.py`` (the benchmark's 40 960 samples, ``obsnl.identify`` with
``intersample="bandlimited"``, ``jit=True``, the profiles on two local processes), run ``--runs`` times after one
warm-up run (which also fills the cache of compiled functions); each run's wall time and the machine's load average
before and after it are written to ``reports/benchmarks/boucwen/timing.md``. There is no peer: the goal is absolute.

Run from the repository root on a quiet machine: ``python benchmarks/bench_boucwen_time.py [--runs 2] [--out FILE]``.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import subprocess
import time
from pathlib import Path

import numpy as np

import obsnl
from obsnl.executor import Executor

ROOT = Path(__file__).resolve().parents[1]


def _cpu() -> float:
    """Processor seconds of this process and of its finished children (the profiles' worker processes)."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def _run(model: obsnl.Model, data: dict[str, np.ndarray]) -> tuple[float, float, bool, bool]:
    """One identification: (wall s, processor s, adequate, converged)."""
    t0, c0 = time.perf_counter(), _cpu()
    res = obsnl.identify(model, data, intersample="bandlimited", jit=True, progress=False, executor=Executor(workers=2))
    return time.perf_counter() - t0, _cpu() - c0, bool(res.adequacy and res.adequacy.passed), res.converged


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--out", default=None, help="the table's file (default reports/benchmarks/boucwen/timing.md)")
    a = ap.parse_args()
    model = obsnl.read_model(ROOT / "reports" / "benchmarks" / "boucwen" / "model.toml")
    d = np.loadtxt(ROOT / "benchmarks" / "data" / "boucwen" / "train_multisine.csv", delimiter=",", skiprows=1)
    data = {"time_s": d[:, 0], "u": d[:, 1], "y_meas": d[:, 2]}
    warm = _run(model, data)[0]
    rows = []
    for i in range(a.runs):
        before = os.getloadavg()[0]
        secs, cpu, adequate, converged = _run(model, data)
        rows.append(
            f"| {i + 1} | {secs:.1f} | {cpu:.1f} | {before:.2f} | {os.getloadavg()[0]:.2f} | {adequate} | {converged} |"
        )
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT).stdout
    text = "\n".join(
        [
            "# Bouc-Wen benchmark: time of one identification of the whole training record",
            "",
            f"Written by `python benchmarks/bench_boucwen_time.py --runs {a.runs}` (obsnl {obsnl.__version__}, commit "
            f'{commit.strip()}; {os.cpu_count()} cores, {platform.machine()}). 40 960 samples, `intersample="bandlimited"`, '
            f"compiled, profiles on 2 local processes; after a warm-up run of {warm:.1f} s. Goal of issue 40: under 60 s "
            f"of wall time on a quiet machine. Processor seconds are those of this process and its worker processes: on a "
            f"machine that others load they grow less than the wall time does.",
            "",
            "| run | wall s | processor s | load before | load after | adequate | converged |",
            "|---:|---:|---:|---:|---:|---|---|",
            *rows,
            "",
        ]
    )
    out = Path(a.out) if a.out else ROOT / "reports" / "benchmarks" / "boucwen" / "timing.md"
    out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
