"""The minimal sensor sets of n-storey Bouc-Wen buildings: analyses run against the 2^m sets there are,
and the time against the plain search that analyses every set up to the same size.

Model: :func:`obsnl.studies.buildings.bouc_wen_building` (every floor's absolute acceleration a candidate:
m = n candidates, 5 n parameters, unit masses, the ground acceleration known). Target: every state and
parameter. Search: all minimal sets of at most ``--max-size`` sensors
(:func:`obsnl.design.sensors.sensors`, the monotone level-wise search, on ``--workers`` processes).
Baseline ("plain"): the same sufficiency test (:func:`obsnl.design.sufficiency.check_sensors`) on every set
of at most ``--max-size`` sensors, then the minimal ones kept, on the same executor; run alternately with the
search, both warm, ``--repeat`` times each, medians and their ratio printed. The plain search is skipped for
n above ``--plain-max`` (its cost is then the number of sets times the time of one analysis, printed).

    python benchmarks/bench_sensors.py [--storeys 3,5,10] [--max-size 2] [--workers 2] [--repeat 1]
                                       [--out reports/benchmarks/sensors.md]
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import sys
import time
from pathlib import Path

from obsnl.design.sensors import sensors
from obsnl.design.sufficiency import check_sensors, resolve_targets
from obsnl.executor import Executor
from obsnl.studies.buildings import bouc_wen_building

ROOT = Path(__file__).resolve().parents[1]


def _plain_task(task: tuple) -> bool | None:
    model, names, targets = task
    return check_sensors(model, names, targets, seed=0).sufficient


def plain(model, max_size: int, executor: Executor) -> tuple[list[tuple[str, ...]], int]:
    """Every set of at most ``max_size`` outputs analysed; the minimal sufficient ones."""
    names = list(model.output_names)
    targets = resolve_targets(model, "all")
    sets = [c for k in range(1, max_size + 1) for c in itertools.combinations(names, k)]
    answers = executor.map(_plain_task, [(model, s, targets) for s in sets])
    good = [frozenset(s) for s, a in zip(sets, answers) if a]
    minimal = [tuple(n for n in names if n in s) for s in good if not any(o < s for o in good)]
    return sorted(minimal, key=lambda c: (len(c), [names.index(n) for n in c])), len(sets)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--storeys", default="3,5,10")
    ap.add_argument("--max-size", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--plain-max", type=int, default=5, help="largest n run with the plain search")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    ex = Executor(workers=args.workers)
    rows = []
    for n in [int(x) for x in args.storeys.split(",") if x]:
        model = bouc_wen_building(n)
        sensors(bouc_wen_building(2), max_size=1)  # warm (imports, caches)
        ours, theirs, res, base = [], [], None, None
        for _ in range(args.repeat):
            t = time.perf_counter()
            res = sensors(model, max_size=args.max_size, executor=ex)
            ours.append(time.perf_counter() - t)
            if n <= args.plain_max:
                t = time.perf_counter()
                base = plain(model, args.max_size, ex)
                theirs.append(time.perf_counter() - t)
        a, b = statistics.median(ours), (statistics.median(theirs) if theirs else None)
        same = None if base is None else [tuple(s) for s in res.minimal_sets] == base[0]
        sets = sum(len(list(itertools.combinations(range(n), k))) for k in range(1, args.max_size + 1))
        rows.append((n, 5 * n, res.analyses, sets, 2 ** n - 1, a, b, same, len(res.minimal_sets)))
        print(f"n={n}: {res.analyses} analyses (plain: {sets} sets of <= {args.max_size}; 2^m - 1 = {2 ** n - 1}), "
              f"{a:.1f} s" + (f", plain {b:.1f} s, ratio {b / a:.1f}, same answer {same}" if b else ""), flush=True)
    lines = [
        "# Minimal sensor sets of n-storey Bouc-Wen buildings", "",
        f"Made by `python benchmarks/bench_sensors.py --storeys {args.storeys} --max-size {args.max_size} "
        f"--workers {args.workers} --repeat {args.repeat}`. Every floor's absolute acceleration is a candidate "
        "sensor; the target is every state and parameter; all minimal sets of at most "
        f"{args.max_size} sensors are searched. 'plain' analyses every set of at most {args.max_size} sensors "
        "with the same test on the same executor (run alternately with the search; medians).", "",
        "| storeys | parameters | minimal sets | analyses (search) | sets of <= K | 2^m - 1 | search s | plain s | "
        "plain / search | same answer |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for n, p, an, sets, full, a, b, same, k in rows:
        lines.append(f"| {n} | {p} | {k} | {an} | {sets} | {full} | {a:.1f} | {'' if b is None else f'{b:.1f}'} | "
                     f"{'' if b is None else f'{b / a:.1f}'} | {'' if same is None else same} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
