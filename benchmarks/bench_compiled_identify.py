"""What the default compilation of ``obsnl identify`` buys: the same command with ``--no-jit`` and with the
default (compiled where a C compiler is on PATH), wall time of whole commands, alternating.

Plain script (no pytest):

    python benchmarks/bench_compiled_identify.py [--repeat 3] [--out reports/benchmarks/compiled_identify.md]

Cases: a simulation study of ``models/coulomb_friction.toml`` under the first 1000 samples of the packaged
Northridge record (guesses 20-50 % off; the fit's step locates the crossings of the friction jump), and of the
seed model ``models/damage_healing_reparam.toml`` over 600 samples (the seed paper's guesses, 0.1 % noise).
Each command runs in a fresh interpreter with two profile workers. The first compiled run of each case starts
from an empty library cache (what a first run on a machine pays: the compilation); the rounds after it
alternate the uncompiled and the compiled command (the library then loads from the cache) and their medians
are compared. The script also checks that both give the same ``identify.json`` numbers (estimates, std,
intervals to 1e-9 relative) and says so.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RECORD = ROOT / "obsnl" / "studies" / "data" / "northridge1994_LOS270_ngawest2_accel.csv"
SEED_GUESS = ["k_m=5e3", "c_dm=50", "c_eta_p=3e3", "c_p=4", "h_p=4e-3", "N=3", "w_h=0.3", "Delta1=3e10",
              "Delta2=-6e9"]
CASES = {
    "coulomb_friction, 1000 samples": ["models/coulomb_friction.toml", "--samples", "1000",
                                       *sum((["--guess", g] for g in ("m=1.3", "c=0.3", "k=30", "F_c=0.7")), [])],
    "damage_healing_reparam, 600 samples": ["models/damage_healing_reparam.toml", "--samples", "600",
                                            "--noise", "0.001", *sum((["--guess", g] for g in SEED_GUESS), [])],
}


def _run(args: list[str], out: Path, env: dict) -> tuple[float, dict]:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "obsnl", "identify", *args, "--record", str(RECORD), "--workers", "2",
                    "--out", str(out), "--force"], env=env, check=True, cwd=ROOT,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0, json.loads((out / "identify.json").read_text())


def _numbers(doc: dict) -> list[float]:
    return [v for p in doc["parameters"] for v in (p["estimate"], p["std"], *(x or 0.0 for x in p["interval"]))]


def _same(a: dict, b: dict) -> bool:
    return all(abs(x - y) <= 1e-9 * max(abs(x), abs(y), 1e-300) for x, y in zip(_numbers(a), _numbers(b)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, PYTHONPATH=str(ROOT), OBSNL_CACHE_DIR=str(Path(tmp) / "cache"))
        for name, case in CASES.items():
            cold, doc_c = _run(case, Path(tmp) / "c", env)
            assert doc_c["compiled"] is True, "no C compiler on PATH: nothing to compare"
            plain, fast, same = [], [], True
            for _ in range(args.repeat):
                t, doc_p = _run([*case, "--no-jit"], Path(tmp) / "p", env)
                plain.append(t)
                t, doc_c = _run(case, Path(tmp) / "c", env)
                fast.append(t)
                same = same and _same(doc_p, doc_c) and doc_p["compiled"] is False
            rows.append((name, cold, statistics.median(plain), statistics.median(fast), same))
            print(rows[-1], flush=True)
    lines = [
        "# `obsnl identify`: compiled by default vs `--no-jit`", "",
        f"Written by `python benchmarks/bench_compiled_identify.py --repeat {args.repeat}` ({platform.machine()}, "
        f"{os.cpu_count()} cores). What it runs: the docstring of the script. Wall time of the whole command "
        "(interpreter start, analysis, tuning, filter passes, fit, profiles on 2 workers, files).", "",
        "| case | first compiled run, empty cache (s) | `--no-jit`, median (s) | compiled, cached, median (s) "
        "| `--no-jit` / compiled | same numbers |",
        "|---|---:|---:|---:|---:|---|",
        *(f"| {n} | {c:.1f} | {p:.1f} | {f:.1f} | {p / f:.1f}x | {'yes' if s else 'NO'} |"
          for n, c, p, f, s in rows), ""]
    text = "\n".join(lines)
    print(text)
    if args.out:
        Path(args.out).write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
