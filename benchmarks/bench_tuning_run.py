"""The unit of work of ``obsnl reproduce``, this checkout against another revision, A/B.

One tuning run of the seed experiment (three passes of the filter over the 1999-sample record, the
output misfits and the sensitivities of the practical-identifiability check after the first pass:
what :func:`obsnl.identification.experiments.tune_one` does 480 times in ``reproduce``, and a
Monte-Carlo replicate of the three-pass protocol does 320 times) for the UKF and the DUKF.

Plain script (no pytest):

    python benchmarks/bench_tuning_run.py --against REV [--rounds 3] [--repeats 4]
                                          [--out reports/benchmarks/tuning_run.md]

``REV`` (a commit, tag or branch) is checked out into a temporary git worktree. Each side runs in
its own fresh interpreter (its compiled filters from the disk cache, compiled first if missing),
warm (one run first, not timed), then ``--repeats`` timed runs; the sides alternate for
``--rounds`` rounds, so that a change of the machine's load hits both. Printed: the median seconds
per run of each side, their ratio, and the two sides' misfits (equal when the change kept every
bit).
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
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
import obsnl
assert obsnl.__file__.startswith(sys.argv[1]), obsnl.__file__
from obsnl.identification.experiments import Tuning, make_data, tune_one
from obsnl.studies.seed_experiment import seed_branch_table
from obsnl.studies.seed_tasks import Spec, context

table, _ = seed_branch_table()
ctx = context(Spec(record=None, samples=None, jit=True, table_json=table.to_json()))
setup, name, repeats = ctx["setup"], sys.argv[2], int(sys.argv[3])
tuning = Tuning(s0=0.1, q_theta=0.0, q_x=1.0, gate=3.0)
data = make_data(setup, 1000)
tune_one(setup, ctx["filters"][name], data, tuning, passes=3)  # warm
times = []
for _ in range(repeats):
    tic = time.perf_counter()
    got = tune_one(setup, ctx["filters"][name], data, tuning, passes=3)
    times.append(time.perf_counter() - tic)
print(json.dumps({"times": times, "misfits": [got[1], got[3]]}))
"""


def _side(root: Path, name: str, repeats: int, env: dict[str, str] | None = None) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, str(root), name, str(repeats)], capture_output=True,
                         text=True, check=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def alternate(name: str, sides: dict[str, tuple[Path, dict[str, str] | None]], *, rounds: int,
              repeats: int) -> tuple[dict[str, list[float]], dict[str, list[float]]]:
    """Time filter ``name`` on each side (``label: (checkout, environment)``), the sides alternating
    for ``rounds`` rounds; ``(seconds per run, last misfits)``, each by side label."""
    times: dict[str, list[float]] = {side: [] for side in sides}
    misfits: dict[str, list[float]] = {}
    for r in range(rounds):
        for side, (root, env) in sides.items():
            got = _side(root, name, repeats, env)
            times[side] += got["times"]
            misfits[side] = got["misfits"]
            print(f"{name} round {r + 1} {side}: median {statistics.median(got['times']):.3f} s", flush=True)
    return times, misfits


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", required=True, help="the other revision (commit, tag or branch)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=4)
    ap.add_argument("--out", default=None, help="write the table as Markdown here")
    args = ap.parse_args()
    rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.against], capture_output=True,
                         text=True, check=True).stdout.strip()
    here = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True, check=True).stdout.strip()
    with tempfile.TemporaryDirectory(prefix="obsnl-ab-") as tmp:
        other = Path(tmp) / "other"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(other), rev], check=True,
                       capture_output=True)
        try:
            rows = []
            load0 = os.getloadavg()[0]
            for name in ("ukf", "dukf"):
                times, misfits = alternate(name, {"other": (other, None), "this": (ROOT, None)},
                                           rounds=args.rounds, repeats=args.repeats)
                a, b = statistics.median(times["other"]), statistics.median(times["this"])
                rows.append((name, a, b, misfits["other"], misfits["this"]))
            load1 = os.getloadavg()[0]
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(other)], capture_output=True)
    lines = [f"# One tuning run of the seed experiment: {here} (this checkout) against {rev}", "",
             f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; "
             f"1-minute load average {load0:.2f} at the start, {load1:.2f} at the end. Each side in a fresh "
             f"interpreter, warm, {args.repeats} timed runs per round, {args.rounds} rounds alternating. "
             f"Generated by `python benchmarks/bench_tuning_run.py --against {args.against}`.", "",
             f"| filter | {rev} s per run | {here} s per run | speed-up | misfits {rev} (1 pass, 3 passes) | "
             f"misfits {here} |", "|---|---:|---:|---:|---|---|"]
    for name, a, b, ma, mb in rows:
        lines.append(f"| {name} | {a:.3f} | {b:.3f} | {a / b:.2f}x | {ma[0]:.17g}, {ma[1]:.17g} | "
                     f"{mb[0]:.17g}, {mb[1]:.17g} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
