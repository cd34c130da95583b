"""Noise on the measured ground motion: is the reported std still calibrated?  (issue 27)

frame2_full of bench_likelihood.py (scipy LSODA data, 2 % noise on both floor accelerations) with the ground
motion measured as noisily as the floors: 2 % of its RMS (``--input-noise``), given to the tool as such. The
refinement's std counts the input's noise (its first-order propagation through the exact input sensitivities,
``refinement.input_noise_widening``); before, the std was that of the output noise alone. Per seed: each
parameter's error over the reported std and over the output noise's std alone (error / std x widening), the
Wald statistic of the ten errors under the reported std and correlations, and whether the parameter's normal
95 % interval (estimate +- 1.96 std) covers the truth under each. The profiles are skipped (they change
neither the estimate nor the std; tests/test_input_noise.py checks the profile intervals' coverage).

Run from the repository root: ``python benchmarks/bench_input_noise.py [--seeds 20] [--input-noise 0.02]
[--out FILE]`` (about 30 s a seed on 2 cores).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_likelihood as B  # noqa: E402  (the cases and their scipy data)
from bench_joint_region import wald  # noqa: E402

import obsnl  # noqa: E402
from obsnl.identification import runs  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--input-noise", type=float, default=0.02)
    ap.add_argument("--out", default=str(B.ROOT / "reports" / "identification" / "input_noise.md"))
    a = ap.parse_args(argv)
    runs.profiles = lambda ref, **kw: ()  # the profiles change neither the estimate nor the std
    B.INPUT_NOISE = a.input_noise
    case = B.case_frame2(None)
    names = [str(p) for p in case.model.parameters]
    Z, Zout, Ws, rows, widen = [], [], [], [], []
    for seed in range(a.seeds):
        data = B.noisy(case, seed=seed)
        noise = dict(case.noise) | {s.name: a.input_noise for s in case.model.inputs}
        tic = time.perf_counter()
        res = obsnl.identify(case.model, data, guess=case.guess, noise=noise, progress=False)
        wall = time.perf_counter() - tic
        w = res.refinement.input_noise_widening
        z = np.array([(p.estimate - case.truth[p.name]) / p.std for p in res.parameters])
        zo = z * np.array([w[p.name] for p in res.parameters])
        Z.append(z), Zout.append(zo), Ws.append(wald(res, case.truth)[0]), widen.append([w[n] for n in names])
        rows.append(f"| {seed} | " + " | ".join(f"{v:+.2f} ({o:+.1f})" for v, o in zip(z, zo))
                    + f" | {Ws[-1]:.1f} | {int(np.sum(np.abs(z) <= 1.96))}/{len(z)} | {int(np.sum(np.abs(zo) <= 1.96))}"
                      f"/{len(z)} | {res.converged} | {wall:.0f} |")
        print(rows[-1], flush=True)
    Z, Zout, widen = np.array(Z), np.array(Zout), np.array(widen)
    k, n = len(names), len(Ws)
    lines = ["# Noise on the measured ground motion: frame2_full (issue 27)", "",
             f"Written by `python benchmarks/bench_input_noise.py {' '.join(sys.argv[1:] if argv is None else argv)}` "
             f"(obsnl {B.revision()}; {platform.machine()}). " + " ".join(__doc__.split("\n\n")[1].split()), "",
             f"Input noise {100 * a.input_noise:g} % of the ground motion's RMS. Each cell: error / reported std "
             "(in brackets: error / the std of the output noise alone, as reported before the input's noise was "
             "counted).", "",
             "| seed | " + " | ".join(names) + " | W | covered (reported) | covered (output noise alone) | converged "
             "| wall s |", "|---:|" + "---:|" * k + "---:|---|---|---|---:|", *rows, "",
             "| | " + " | ".join(names) + " |", "|---|" + "---:|" * k,
             "| widening (mean) | " + " | ".join(f"{v:.2f}" for v in widen.mean(axis=0)) + " |",
             "| RMS error / reported std | " + " | ".join(f"{v:.2f}" for v in np.sqrt(np.mean(Z ** 2, axis=0))) + " |",
             "| RMS error / output-noise std | " + " | ".join(f"{v:.2f}" for v in np.sqrt(np.mean(Zout ** 2, axis=0)))
             + " |", "",
             f"Normal 95 % intervals covering the truth: {int(np.sum(np.abs(Z) <= 1.96))} of {Z.size} with the reported "
             f"std, {int(np.sum(np.abs(Zout) <= 1.96))} of {Z.size} with the output noise's alone. Wald statistic: mean "
             f"{np.mean(Ws):.2f} against chi2({k})'s {k}; the sum {sum(Ws):.1f} against chi2({k * n}): P = "
             f"{stats.chi2.sf(sum(Ws), k * n):.2f}; the truth inside the joint 95 % region on "
             f"{sum(W <= stats.chi2.ppf(0.95, k) for W in Ws)} of {n} seeds.", ""]
    Path(a.out).write_text("\n".join(lines), encoding="utf-8")
    print("\n".join(lines[-2:]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
