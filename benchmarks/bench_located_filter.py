"""The filters' located step (``Setup(locate=True)``) against their default refined step on the seed model.

The README's script example (the seed model in its identifiable coordinates, the first 800 samples of the
packaged Northridge record, 0.1 % noise on input and output, the seed paper's Table 2 guesses, the UKF with
s0 0.2, q_theta 0, q_x 1, two passes) over noise seeds; per seed and step: the free-run output misfit of the
final estimate over the noise level, whether the practical identifiability was decided, what was held and
flagged, and c''s error. The data are obsnl's fine simulation of the model (the README example's own), so
this compares two filter steps on the same data, not the model against an independent integrator.

Run from the repository root: ``python benchmarks/bench_located_filter.py [--seeds 12]
[--out reports/identification/located_filter.md]`` (about 10 s a seed).
"""

from __future__ import annotations

import argparse
import platform
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_likelihood import revision  # noqa: E402

import obsnl  # noqa: E402
from obsnl.errors import EstimatorError  # noqa: E402
from obsnl.estimation import to_casadi  # noqa: E402
from obsnl.identification import Setup, Tuning, make_data, make_filter, practical_identifiability, run_passes  # noqa: E402
from obsnl.identification.setup import output_misfit  # noqa: E402

GUESS = {"k_m": 5e3, "c_dm": 50.0, "c_eta_p": 3e3, "c_p": 4.0, "h_p": 4e-3, "N": 3.0, "w_h": 0.3,
         "Delta1": 3e10, "Delta2": -6e9}


def _row(num, record, seed: int, locate: bool) -> str:
    setup = Setup(model=num, record=record, truth=dict(num.values), guess=GUESS, noise=1e-3, locate=locate)
    tuning = Tuning(s0=0.2, q_theta=0.0, q_x=1.0)
    data = make_data(setup, seed=seed)
    step = "located" if locate else "default"
    try:
        trs, held = run_passes(setup, make_filter(setup, "ukf"), data, tuning, passes=2)
    except EstimatorError as exc:
        return f"| {seed} | {step} | stopped: {str(exc).split(' and ')[0]} | | | | |"
    theta = trs[-1].theta[-1]
    misfit = output_misfit(setup, theta, data)
    prac = practical_identifiability(setup, theta, data, first=trs[0], prior_std=tuning.s0, misfit=misfit)
    c = 100 * (theta[list(num.parameters).index("c_p")] / num.values["c_p"] - 1)
    return (f"| {seed} | {step} | {misfit / setup.noise_level:.3g} | {'no' if prac.inconclusive else 'yes'} | "
            f"{', '.join(held) or '-'} | {', '.join(prac.flagged) or '-'} | {c:+.0f} |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=12)
    ap.add_argument("--out", type=Path, default=ROOT / "reports" / "identification" / "located_filter.md")
    a = ap.parse_args(argv)
    num = to_casadi(obsnl.read_model(ROOT / "models" / "damage_healing_reparam.toml"))
    record = obsnl.read_record(ROOT / "obsnl" / "studies" / "data" / "northridge1994_LOS270_ngawest2_accel.csv").head(800)
    rows = []
    for seed in range(a.seeds):
        for locate in (False, True):
            rows.append(_row(num, record, seed, locate))
            print(rows[-1], flush=True)
    lines = ["# The filters' located step on the seed model (README script example)", "",
             f"Written by `python benchmarks/bench_located_filter.py --seeds {a.seeds}` (obsnl {obsnl.__version__}, "
             f"{revision()}; {platform.machine()}). What it runs: the docstring of the script.", "",
             "| noise seed | step | final misfit / noise | practical identifiability decided | held | flagged "
             "| c' error % |", "|---:|---|---:|---|---|---|---:|", *rows, "",
             "A misfit above 10x the noise leaves the practical identifiability not decided (nothing is flagged "
             "then, and `prac.summary()` says so).", ""]
    a.out.write_text("\n".join(lines))
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
