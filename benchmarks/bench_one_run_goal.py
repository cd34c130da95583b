"""How often do exactly calibrated intervals fail issue 27's one-run coverage goal?  (issue 27)

The goal: in one run, the 95 % intervals contain the truth for at least 80 % of the parameters. For intervals
that are exactly right, each one misses with probability 5 %, but the misses are not independent: the
estimates are correlated, and one draw of the noise along a correlated direction moves several estimates
out of their intervals at once. This computes, for each committed case of ``bench_likelihood.py``, the
probability that the goal fails when the errors are exactly ``N(0, D R D)``, ``D`` the run's reported std and
``R`` its reported correlations (``identify.json``: ``parameters[].std``, ``refinement.correlation``), and
each interval is ``estimate +- 1.96 std``: the failure rate of a perfect estimator with that run's
correlation structure. Nothing is fitted here; only the committed reports are read.

Monte Carlo with ``--draws`` draws (default 2 000 000) from a seeded generator (``--seed``, default 12345);
the standard error of each probability is printed beside it. Run from the repository root:
``python benchmarks/bench_one_run_goal.py [--out reports/identification/one_run_goal.md]`` (a few seconds).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
from pathlib import Path

import numpy as np
from scipy import stats

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_likelihood as B  # noqa: E402  (its revision())
CASES = ("boucwen_benchmark", "frame2_full", "frame3_roof")
Z95 = float(stats.norm.ppf(0.975))


def miss_distribution(corr: np.ndarray, draws: int, rng: np.random.Generator, batch: int = 200_000) -> np.ndarray:
    """P(m of the intervals miss the truth), m = 0 .. k, for errors ``N(0, corr)`` in std units.

    ``corr``: the estimates' correlation matrix (positive definite); every interval is ``+- 1.96`` std.
    """
    k = len(corr)
    L = np.linalg.cholesky(corr)
    counts = np.zeros(k + 1)
    done = 0
    while done < draws:
        n = min(batch, draws - done)
        z = rng.standard_normal((n, k)) @ L.T
        counts += np.bincount((np.abs(z) > Z95).sum(axis=1), minlength=k + 1)
        done += n
    return counts / draws


def failure_probability(corr: np.ndarray, share: float, draws: int, rng: np.random.Generator) -> tuple[float, float, float]:
    """P(fewer than ``share`` of the intervals cover the truth), its standard error, and the mean misses."""
    dist = miss_distribution(corr, draws, rng)
    p = float(dist[misses_allowed(len(corr), share) + 1:].sum())
    return p, math.sqrt(p * (1 - p) / draws), float(dist @ np.arange(len(dist)))


def misses_allowed(k: int, share: float) -> int:
    """Most intervals of ``k`` that may miss while at least ``share`` of them cover the truth."""
    return k - math.ceil(share * k - 1e-12)


def observed_misses(files: list[Path], names: list[str]) -> list[int]:
    """Misses per run of the normal 95 % intervals in bench_std_spread.py's tables (the rows with the input's 0.1 %
    noise; each cell is a parameter's error over its reported std)."""
    out = []
    for f in files:
        for line in f.read_text().splitlines():
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) >= 2 + len(names) and cells[0].isdigit() and cells[1] == "0.1 %":
                out.append(sum(abs(float(c)) > Z95 for c in cells[2:2 + len(names)]))
    return out


def independent_probability(k: int, share: float) -> float:
    """The same probability for independent estimates (binomial)."""
    return float(stats.binom.sf(misses_allowed(k, share), k, 0.05))


def read_case(folder: Path) -> tuple[list[str], np.ndarray]:
    """The estimated parameters (finite positive std) of a committed run and their correlation matrix."""
    d = json.loads((folder / "identify.json").read_text())
    names = [p["name"] for p in d["parameters"]
             if p.get("std") is not None and np.isfinite(p["std"]) and p["std"] > 0]
    corr = d["refinement"]["correlation"]
    return names, np.array([[corr[a][b] for b in names] for a in names], float)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--draws", type=int, default=2_000_000)
    ap.add_argument("--seed", type=int, default=12345)
    ap.add_argument("--share", type=float, default=0.8)
    ap.add_argument("--reports", default=str(ROOT / "reports" / "identification"))
    ap.add_argument("--out", default=str(ROOT / "reports" / "identification" / "one_run_goal.md"))
    a = ap.parse_args(argv)
    rng = np.random.default_rng(a.seed)
    rows = []
    for case in CASES:
        names, R = read_case(Path(a.reports) / case)
        p, se, mean = failure_probability(R, a.share, a.draws, rng)
        k = len(names)
        off = np.abs(R[np.triu_indices(k, 1)])
        rows.append(f"| {case} | {k} | {misses_allowed(k, a.share)} | {off.max():.2f} | {mean:.3f} "
                    f"| {100 * p:.2f} % +- {100 * se:.2f} | {100 * independent_probability(k, a.share):.2f} % |")
        print(rows[-1], flush=True)
    names, R = read_case(Path(a.reports) / "frame2_full")
    seen = observed_misses([Path(a.reports) / "std_spread.md", Path(a.reports) / "std_spread_more.md"], names)
    dist = miss_distribution(R, a.draws, rng)
    top = max(4, max(seen, default=0))
    compare = [f"| {m if m < top else f'{top} or more'} | {len(seen) * (dist[m] if m < top else dist[top:].sum()):.1f} "
               f"| {sum(1 for x in seen if (x == m if m < top else x >= top))} |" for m in range(top + 1)]
    lines = [
        "# The one-run coverage goal for exactly calibrated intervals (issue 27)",
        "",
        f"Written by `python benchmarks/bench_one_run_goal.py` (obsnl {B.revision()}; {platform.machine()}; "
        f"{a.draws} draws, generator seed {a.seed}). For each committed case of bench_likelihood.py: the "
        "probability that fewer than "
        f"{100 * a.share:.0f} % of the 95 % intervals cover the truth when the errors are exactly Gaussian with the "
        "run's reported std and correlations (`identify.json`) and each interval is the estimate +- 1.96 std. That is "
        "the rate at which a perfect estimator with this correlation structure fails the one-run goal; the last "
        "column is the rate for independent estimates. Parameters with no finite std (held or flat) are left out.",
        "",
        "| case | parameters | misses allowed | largest abs. correlation | mean misses | P(goal fails), calibrated "
        "| P(goal fails), independent |",
        "|---|---:|---:|---:|---:|---:|---:|",
        *rows,
        "",
        "Reading: the goal is a random event even for intervals that are exactly right. Correlated estimates "
        "miss together (on frame2_full k1 and kh1 at -0.98, k2 and kh2 at -0.96: their sums are the storeys' "
        "initial stiffnesses), which makes several misses in one run more likely than for independent ones. "
        "Measured on frame2_full's noise seeds 0-59 (`std_spread.md`, `std_spread_more.md`; read in "
        "`likelihood.md`), 3 runs of 60 (5 %) fail the goal with these normal intervals, seed 0 among them, as "
        "this rate predicts; the joint 95 % region, the claim a run can keep at its level, holds the truth on "
        "58 of 60.",
        "",
        f"frame2_full, misses per run: expected over {len(seen)} runs for exact intervals (the committed run's "
        f"correlations) against the runs of `std_spread.md` and `std_spread_more.md` (noise seeds 0-{len(seen) - 1}, "
        "the input's 0.1 % noise, normal intervals from each run's reported std):",
        "",
        "| intervals missing the truth | expected runs (exact intervals) | observed runs |",
        "|---|---:|---:|",
        *compare,
        "",
    ]
    Path(a.out).write_text("\n".join(lines))
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
