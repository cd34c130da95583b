"""Why does Table 2's ML column end above the noise floor on LOS000?  (issue 27, the seed study)

On the LOS000 record the maximum-likelihood fit of the seed model converges with its RMS residual at 1.07-1.08
times the output noise, on LOS270 at 1.00-1.01. Two causes are possible: the fit's integrator (RK4 with 8
substeps per sample, the crossing substeps refined) against the truth's (100 substeps), or the measured
input's 0.1 % noise, which the fit simulates through as if it were the ground motion. This refits one noise
seed from the true parameters with each cause removed in turn (the input replaced by the clean record; 32
substeps instead of 8) and, for each record, measures the input noise's own effect on the output at the
truth: the RMS difference of the simulated displacement under the noisy and the clean input, over the
output noise level.

Run from the repository root, with this tree's obsnl importable (e.g. ``PYTHONPATH=.``):
``python benchmarks/bench_seed_misfit.py [--seed 0] [--out reports/benchmarks/seed_misfit.md]`` (about two
minutes; the 32-substep fits compile their own sensitivities).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

import obsnl
from obsnl.estimation.simulate import simulate
from obsnl.identification.refine import refine
from obsnl.identification.setup import Data, make_data
from obsnl.studies.seed_experiment import seed_setup

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_likelihood as B  # noqa: E402  (its revision())
RECORDS = {"LOS000": "northridge1994_LOS000_femap695_ngawest1_accel.csv",
           "LOS270": "northridge1994_LOS270_ngawest2_accel.csv"}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmarks" / "seed_misfit.md"))
    a = ap.parse_args(argv)
    fits, effects, double = [], [], []
    for rec_name, file in RECORDS.items():
        setup = seed_setup(record=obsnl.read_record(str(ROOT / "obsnl" / "studies" / "data" / file)), jit=True)
        m, truth = setup.model, setup.theta_true
        sig_y = setup.noise * np.sqrt(np.mean(np.asarray(setup.y_true, float) ** 2))
        clean_y = simulate(m, theta=truth, x0=setup.x0, u=setup.record.accel, dt=setup.record.dt, substeps=8).y
        for seed in (a.seed, a.seed + 1, a.seed + 2):
            d = make_data(setup, seed)
            noisy_y = simulate(m, theta=truth, x0=setup.x0, u=d.u, dt=setup.record.dt, substeps=8).y
            v = float(np.sqrt(np.mean((noisy_y - clean_y) ** 2)) / sig_y)
            effects.append(f"| {rec_name} | {seed} | {v:.3f} | {np.sqrt(1 + v * v):.3f} |")
            print(effects[-1], flush=True)
        data = make_data(setup, a.seed)
        clean = Data(seed=a.seed, u=np.asarray(setup.record.accel, float), y=data.y)
        for label, d, sub in (("measured (noisy) input, 8 substeps (the main job's fit)", data, None),
                              ("clean input, 8 substeps", clean, None),
                              ("measured (noisy) input, 32 substeps", data, 32),
                              ("clean input, 32 substeps", clean, 32)):
            t0 = time.perf_counter()
            r = refine(setup, d, truth, substeps=sub, max_iter=40)
            worst = max(zip(m.parameters, np.abs((r.theta - truth) / r.std)), key=lambda kv: kv[1])
            fits.append(f"| {rec_name} | {label} | {r.misfit['y']:.4f} | {'yes' if r.converged else 'no'} "
                        f"| {worst[0]} {worst[1]:.1f} | {time.perf_counter() - t0:.0f} |")
            print(fits[-1], flush=True)
            if d is data and sub is None:  # the reported std against those with the true output noise level
                C, Cu = np.diag(r.cov), np.diag(r.input_cov)
                k = (sig_y / r.sigma[0]) ** 2
                ok = np.isfinite(C) & (C > 0)
                over = np.sqrt((C[ok] + Cu[ok]) / (k * C[ok] + Cu[ok]))
                double.append(f"| {rec_name} | {r.sigma[0] / sig_y:.3f} | {over.min():.3f}-{over.max():.3f} |")
    lines = [
        "# The seed study's ML residual above the noise floor on LOS000: the measured input's noise",
        "",
        f"Written by `python benchmarks/bench_seed_misfit.py --seed {a.seed}` (obsnl {B.revision()}; "
        f"{platform.machine()}). The seed model (damage_healing_reparam), the main job's experiment: 0.1 % noise on "
        "the ground motion and on the displacement, the ML refinement of Table 2 started from the true parameters.",
        "",
        f"Refits of noise seed {a.seed} (residual RMS over the output noise level; the largest |error| / reported std):",
        "",
        "| record | input, integrator | residual / noise | converged | largest error / std | s |",
        "|---|---|---:|---|---|---:|",
        *fits,
        "",
        "The input noise's own effect at the truth (initial state and parameters fixed): RMS of the displacement "
        "under the noisy input minus under the clean one, over the output noise level, and the residual it would "
        "give alone (sqrt(1 + ratio^2)):",
        "",
        "| record | noise seed | input effect / output noise | residual / noise if nothing absorbed it |",
        "|---|---:|---:|---:|",
        *effects,
        "",
        "Reading: the cause is the measured input's noise, not the integrator. With the clean input the fit ends at "
        "the noise floor, and 32 substeps instead of 8 leave the residual unchanged to the fourth digit. On LOS000 "
        "the ground motion's 0.1 % noise, integrated twice by the structure, moves the displacement by about as "
        "much as the output noise; the fit absorbs part of that drift (initial state, parameters) and the rest "
        "stays in the residual. On LOS270 the same noise moves the displacement by less than a fifth of the output "
        "noise. The refinement counts the input's noise in every std (`input_noise_widening`); the residual over "
        "the output noise level (`misfit_over_noise`) does not subtract it, so on a record like LOS000 a residual "
        "somewhat above 1 is the input's noise, not a misfit of the model or of the integrator.",
        "",
        "A consequence for the std: the noise level re-estimated from the residuals absorbs that excess, and the "
        "input's noise is then counted again by its propagation (`input_cov`). Against the std computed with the "
        "true output noise level and the same propagation, the reported std are wider by the factor below "
        "(the main job's fit, noise seed as above): conservative, by a few percent at most here.",
        "",
        "| record | re-estimated noise / true output noise | reported std / std at the true noise level |",
        "|---|---:|---:|",
        *double,
        "",
    ]
    Path(a.out).write_text("\n".join(lines))
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
