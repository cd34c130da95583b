"""Stick-slip: the maximum-likelihood fit of a friction oscillator whose mass sticks  (issue 27)

The packaged ``coulomb_friction`` model driven weakly (multisine RMS 0.7 N against F_c = 0.5 N, 6 s at 100 Hz) so
that the mass sticks eight times, 0.9 s in all. Data: scipy's stick-slip solution (``tests/test_sliding.py``:
slip phases by ``solve_ivp`` with the reversal as an event, Coulomb's sticking condition, the exact breakaway),
1 % noise on the displacement. For each noise seed the fit (``obsnl.identification.refine``) starts 3 % off
as the filter leaves it, then the 95 % profile interval of each parameter. Per seed: converged or why not, which
intervals cover the truth, error / reported std. Summary: counts, RMS error / std (1 for a right std), the
Wald statistic's mean (chi2(4): 4) and the seeds' time.

Run from the repository root: ``python benchmarks/bench_stick_slip.py [--seeds 60] [--out FILE]`` (about 2 s a
seed compiled, when a C compiler is present).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_likelihood import revision  # noqa: E402
from tests.conftest import HAVE_CC  # noqa: E402
from tests.test_sliding import DT, TRUTH, stick_record, stick_slip  # noqa: E402

import obsnl  # noqa: E402
from obsnl.estimation.accelerogram import Record  # noqa: E402
from obsnl.estimation.codegen import to_casadi  # noqa: E402
from obsnl.identification.profile import profiles  # noqa: E402
from obsnl.identification.refine import refine  # noqa: E402
from obsnl.identification.setup import Data, Setup  # noqa: E402

START = {"m": 1.03, "c": 0.194, "k": 38.8, "F_c": 0.515}

#: The reading of the committed run, written by hand after it (regenerating appends it unchanged: check it against
#: the table when the code has changed).
FINDINGS = """## Reading (by hand, of the committed run and seven side runs)

- Before the sliding rule (this script, 10 seeds, on commit 63fbc9b with this script and tests copied in): 0 of 10
  fits converged, each stopping with a Newton decrement of about 480 where no step lowered chi2; the profile
  intervals were open (they "covered" 10 of 10 by saying nothing) and the Wald mean was 137. The plain stages
  chattered across v = 0 while the mass was stuck, and the objective jumped.
- With the sliding rule alone (commit 25b77c9), 57 of 60 converged; the other three stopped with decrements of
  0.014-0.1. On seed 1, chi2 along the last Gauss-Newton direction jumped by 0.028 at 0.077 of the step: a reversal
  (not a stick) 0.86 of the way through a refined substep, whose plain RK4 end had not yet crossed v = 0. The step
  after the located crossing started on the side of that plain end, the old side, so its first stage sampled the
  old field, and the map jumped where the plain end crossed the surface with the parameters. The step now starts
  on the side opposite the start (`tests/test_crossing.py`, the late crossing against its parabola): 60 of 60
  converge, and the coverage and the std are as before.
- Calibrated on average over these 60: the Wald mean is 3.93 against 4. The marginal coverage of c and F_c is 54
  of 60 (90 %; P(at most 54 of 60 | 95 %) = 0.08 each), their RMS error / std 1.11 and 1.13; the two miss together
  on seeds 5 and 32 (they are correlated), and the joint region holds the truth on 54 of 60.
- A side run over 200 seeds (`--seeds 200`, commit 8c8a793, not committed as the table): 200 of 200 converge; the
  intervals cover m, c, k, F_c 186, 187, 190, 183 times (P(at most that | 95 %) = 0.13, 0.20, 0.55, 0.024); RMS error
  / std 1.07, 1.07, 1.00, 1.08; Wald mean 4.34 (P = 0.05), the joint region 184 of 200 (P = 0.044). So the std is
  slightly small, by about 7 %, and F_c's interval covers about 92 % instead of 95 %: borderline, not explained
  yet (the ML noise estimate's N - p bias is 1 % here; the Jacobian at seed 5's estimate equals central
  differences to 1e-9).
- The same 200 seeds on the same oscillator forced at RMS 5 N, where the mass never sticks (this script with
  `stick_record(600, 5.0)`, commit f3223e9, not committed): 200 of 200 converge, coverage 190, 191, 190, 193 of
  200, RMS error / std 1.00, 0.95, 1.00, 0.97, Wald mean 4.04 (P = 0.41), the joint region 186 of 200. So the
  shortfall comes with sticking: suspects are the breakaways (where u - k x reaches F_c slowly, the breakaway
  time moves fast and nonlinearly with the parameters) and the kinks where a reversal grazes the sticking
  condition.
- A side run over 1000 seeds, the fit alone (`--seeds 1000 --no-profiles`, commit 9d1e3bc, not committed as the
  table; its first 200 are the seeds of the 200-seed run): 1000 of 1000 converge; the normal 95 % intervals
  (estimate +- 1.96 std) cover m, c, k, F_c 940, 944, 955, 934 times (P(at most that | 95 %) = 0.09, 0.21, 0.79,
  0.015); RMS error / std 1.02, 1.02, 1.00, 1.04; Wald mean 4.11 (P = 0.12); the joint region 940 of 1000 (P =
  0.09). Seeds 200-999 alone: RMS error / std 1.01, 1.01, 1.00, 1.03, Wald mean 4.05. So the 7 % of the first 200
  seeds was mostly a high draw: with sticking too the std is right to within about 4 %. The reported std hardly
  moves from seed to seed (3 % spread) and not with the error (correlation with |error| -0.01 to -0.05). What
  might remain was F_c's coverage, 93.4 % (P = 0.015 alone, 0.06 for the lowest of four): see the next run.
- 4000 more seeds (`--start 1000 --seeds 4000 --no-profiles`, commit 7c984a2, not committed as the table), and
  with the 1000 above, seeds 0-4999: 5000 of 5000 converge; the normal intervals cover m, c, k, F_c 4731, 4749,
  4734, 4760 times (94.6 %, 95.0 %, 94.7 %, 95.2 %; P(at most that | 95 %) = 0.12, 0.48, 0.16, 0.75); RMS error /
  std 1.01, 1.00, 1.00, 0.99. F_c's 93.4 % was a low draw: each std is right to about 1 %. The joint statement
  is a little weaker: the Wald mean is 4.07 (P = 0.045) and the joint 95 % region holds the truth 4709 times
  (94.2 %, P = 0.005); W stays below its chi2(4) 90 %, 95 %, 99 % points 89.3 %, 94.2 %, 98.7 % of the time, so
  the joint tail is slightly heavier than chi2(4) (the errors' kurtosis is within +-0.08 of a normal's).
- The noise per output re-estimated over its degrees of freedom, RSS / (N - h) instead of the maximum-likelihood
  RSS / N (`obsnl.identification.refine.residual_dof`; N = 600 samples, h = 6 fitted coordinates here): seeds 0-999
  rerun, the fit alone, before and after (a side run, not committed as the table). The estimates are the same (one
  output: the weights scale alike); the mean of sigma_hat / sigma goes from 0.9933 to 0.9983, the Wald mean from
  4.107 to 4.066, the joint 95 % region from 940 to 943 of 1000. With the true sigma in the covariance the Wald mean
  of the same fits is 4.039 (standard error over 1000 seeds 0.09): the N - p bias of the noise estimate was most of
  the excess; what is left is within the spread of these seeds."""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=60)
    ap.add_argument("--start", type=int, default=0, help="first noise seed (side runs on new seeds)")
    ap.add_argument("--no-profiles", dest="profiles", action="store_false",
                    help="the fit alone: coverage of the normal interval estimate +- 1.96 std instead of the profile")
    ap.add_argument("--out", type=Path, default=ROOT / "reports" / "identification" / "stick_slip.md")
    a = ap.parse_args(argv)
    t, u, X = stick_record(600)
    _, sticks, stuck = stick_slip(TRUTH, t, u)
    x = X[:, 0]
    num = to_casadi(obsnl.read_model("obsnl:coulomb_friction"))
    names = list(num.parameters)
    truth = np.array([TRUTH[n] for n in names])
    sigma = 0.01 * float(np.sqrt(np.mean(x ** 2)))
    rows, Z, W, cover, conv, secs = [], [], [], np.zeros(len(names), int), 0, []
    for seed in range(a.start, a.start + a.seeds):
        y = x + sigma * np.random.default_rng(seed).standard_normal(len(t))
        setup = Setup(model=num, record=Record("d", u, DT, channels=("u",)), truth=None, guess=START,
                      y_true=y.reshape(-1, 1), channel_noise={"y": 0.01, "u": 1e-6}, jit=HAVE_CC)
        t0 = time.perf_counter()
        ref = refine(setup, Data(seed=None, u=u.reshape(-1, 1), y=y.reshape(-1, 1)), setup.theta_guess)
        prs = {pr.name: pr for pr in profiles(ref)} if a.profiles else {}
        secs.append(time.perf_counter() - t0)
        err = np.asarray(ref.theta) - truth
        z = err / np.asarray(ref.std)
        Z.append(z)
        C = ref.total_cov()[:len(names), :len(names)]  # the fit's coordinates: log theta
        e = np.log(np.asarray(ref.theta)) - np.log(truth)
        W.append(float(e @ np.linalg.solve(C, e)))
        cov = [bool((prs[n].interval[0] is None or prs[n].interval[0] <= TRUTH[n])  # an open side covers
                    and (prs[n].interval[1] is None or TRUTH[n] <= prs[n].interval[1])) if prs else abs(zi) <= 1.96
               for n, zi in zip(names, z)]
        cover += cov
        conv += bool(ref.converged)
        rows.append(f"| {seed} | {'yes' if ref.converged else 'NO: ' + ref.reason} | "
                    + " | ".join(f"{zi:+.2f}{'' if c else ' x'}" for zi, c in zip(z, cov)) + f" | {W[-1]:.2f} |")
        print(seed, ref.converged, np.round(z, 2), flush=True)
    Z = np.array(Z)
    k = a.seeds
    how = (f"--seeds {k}" + (f" --start {a.start}" if a.start else "") + ("" if a.profiles else " --no-profiles"))
    interval = "95 % profile interval" if a.profiles else "normal 95 % interval (estimate +- 1.96 std)"
    p_w = float(stats.chi2.sf(sum(W), len(names) * k))
    lines = [
        "# Stick-slip: the maximum-likelihood fit of a friction oscillator whose mass sticks", "",
        f"Written by `python benchmarks/bench_stick_slip.py {how}` (obsnl {obsnl.__version__}, "
        f"{revision()}; {platform.machine()}, compiled: {HAVE_CC}). What it runs: the docstring of the script. "
        f"Truth m 1, c 0.2, k 40, F_c 0.5; start 3 % off. The record: {sticks} stick phases, {stuck:.2f} s of "
        f"{t[-1] + DT:.0f} s stuck.", "",
        "| | m | c | k | F_c |", "|---|---:|---:|---:|---:|",
        f"| {interval} covers the truth | " + " | ".join(f"{c} of {k}" for c in cover) + " |",
        "| RMS error / reported std | " + " | ".join(f"{v:.2f}" for v in np.sqrt((Z ** 2).mean(0))) + " |",
        "| mean error / reported std | " + " | ".join(f"{v:+.2f}" for v in Z.mean(0)) + " |", "",
        f"Converged: {conv} of {k}. Wald statistic of the four errors (in log theta, the fit's coordinates) under the reported covariance: mean "
        f"{np.mean(W):.2f} (chi2(4): 4; the sum against chi2({len(names) * k}): P = {p_w:.2f}); the truth inside the "
        f"joint 95 % region on {sum(w <= stats.chi2.ppf(0.95, len(names)) for w in W)} of {k}. Time per seed "
        f"({'fit and four profiles' if a.profiles else 'fit'}): median {np.median(secs):.1f} s.", "",
        "| seed | converged | m | c | k | F_c | Wald |", "|---:|---|---:|---:|---:|---:|---:|", *rows, "",
        f"Each cell: error / reported std; x marks a {interval} that misses the truth" + (
            " (an interval open on a side, its profile below the threshold up to a factor 10 there, counts as covering on "
            "that side)." if a.profiles else "."), "",
        FINDINGS, ""]
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text("\n".join(lines))
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
