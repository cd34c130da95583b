"""Issue 27's evidence: the filter alone against the filter followed by the maximum-likelihood refinement.

For each case the data are made with scipy (``solve_ivp``, LSODA, rtol 1e-9 and a tight atol, at most one
sample per step, the input linear between samples as obsnl assumes), never with obsnl's simulator; Gaussian
noise with a fixed seed is added to the outputs (and 0.1 % to the measured input). ``obsnl.identify`` then runs
twice on the same data: ``refine=False`` (the UKF passes alone) and the default (the passes, then the
maximum-likelihood refinement and the profile-likelihood intervals), each timed. The noise levels given to
``obsnl.identify`` are the ones used to make the data; everything else is the tool's default. The true values
are used only to make the data and to score; the guesses are fixed below (25-50 % off) and were not tuned.

Cases:

* ``boucwen_benchmark``: the Bouc-Wen benchmark of Noel & Schoukens (2016), multisine force, displacement with
  1 % noise; identified in the identifiable parameters that ``obsnl.reparametrize`` proposes.
* ``frame2_full``: a two-storey Bouc-Wen shear frame under the Northridge record (scaled by 2 so that both
  hysteretic springs yield), both absolute floor accelerations with 2 % noise.
* ``frame3_roof``: a three-storey Bouc-Wen shear frame under the same record, the roof acceleration only
  (partial instrumentation), 2 % noise.

Each case writes ``DIR/CASE/README.md`` (the tables and the goals of issue 27), ``DIR/CASE/model.toml`` (the
model identified, with its ``[values]`` and ``[guess]``) and the files of ``write_identification`` for the refined
run (``identify.json``, ``fit.png``, ``traces.png``, ...); then the refined run is repeated on the noise-free data
(the model's and the integrator's own bias) and on other noise seeds (``--seeds``; ``DEFAULT_SEEDS`` per case).
``DIR/likelihood.md`` gathers every case folder present, with ``FINDINGS`` (the reading of the committed run).

Run from the repository root: ``python benchmarks/bench_likelihood.py [--case NAME] [--out DIR] [--samples N]
[--seeds K] [--workers N] [--jit] [--gather]`` (default: every case, ``--out reports/identification``; about half an
hour on 2 cores, 7-8 minutes with ``--workers 2 --jit``).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

import obsnl
from obsnl.model.files import model_to_toml
from obsnl.identification.identify import IDENTIFY_FILES, write_identification

ROOT = Path(__file__).resolve().parents[1]
RECORD = ROOT / "obsnl" / "studies" / "data" / "northridge1994_LOS270_ngawest2_accel.csv"
LIMIT_S = 300.0  # the goal: a run under 5 minutes
INPUT_NOISE = 1e-3  # measured inputs carry 0.1 % noise (given to the tool as such)
NOISE_SEED = 0
CMD = "python benchmarks/bench_likelihood.py"


@dataclass
class Case:
    """One experiment: the model identified (with [values] = truth and [guess]), its data, what to say about it."""

    name: str
    title: str
    model: obsnl.Model
    truth: dict[str, float]
    guess: dict[str, float]
    t: np.ndarray
    u: np.ndarray  # (T, nu) noise-free input
    y: np.ndarray  # (T, ny) noise-free outputs
    noise: dict[str, float]  # noise-to-signal RMS ratio per output
    notes: list[str] = field(default_factory=list)
    derived: Callable[[dict[str, float]], dict[str, float]] | None = None  # published quantities from the estimates
    derived_truth: dict[str, float] = field(default_factory=dict)
    data_seconds: float = 0.0
    sigma: dict[str, float] = field(default_factory=dict)  # the true noise std per output (set with the data)


def revision() -> str:
    """The commit of this tree and whether obsnl/ differs from it (the results depend on the code that ran)."""
    try:
        def git(*a):
            return subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True, check=True).stdout

        head = git("rev-parse", "--short", "HEAD").strip()
        dirty = bool(git("status", "--porcelain", "--", "obsnl").strip())
        return f"commit {head}" + (" with uncommitted changes under obsnl/" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "commit unknown"


def lsoda(rhs, t, x0, atol):
    """scipy's LSODA at rtol 1e-9, at most one sample per step, outputs at the samples."""
    sol = solve_ivp(rhs, (t[0], t[-1]), x0, method="LSODA", t_eval=t, rtol=1e-9, atol=atol, max_step=t[1] - t[0])
    if not sol.success:
        raise RuntimeError(sol.message)
    return sol.y.T


# ---------------------------------------------------------------- case 1: the Bouc-Wen benchmark
BW_PUBLISHED = {"m": 2.0, "c": 10.0, "k": 5e4, "alpha": 5e4, "beta": 1e3, "gamma": 0.8, "delta": -1.1, "nu": 1.0}
FS, PERIOD = 750.0, 8192


def multisine(seed: int = 2016) -> np.ndarray:
    """One period of the benchmark's input: random-phase multisine, flat 5-150 Hz, RMS 50 N, 8192 samples at 750 Hz."""
    rng = np.random.default_rng(seed)
    f = np.arange(PERIOD // 2 + 1) * FS / PERIOD
    band = (f >= 5.0) & (f <= 150.0)
    spec = np.zeros(len(f), complex)
    spec[band] = np.exp(2j * np.pi * rng.random(int(band.sum())))
    u = np.fft.irfft(spec, PERIOD)
    return 50.0 * u / np.sqrt(np.mean(u ** 2))


def boucwen_physical(nu_known: bool = True) -> obsnl.Model:
    """The benchmark's equations; with ``nu_known`` the published nu = 1 is written in."""
    z_dot = ("alpha*v - beta*(gamma*Abs(v)*z + delta*v*Abs(z))" if nu_known else
             "alpha*v - beta*(gamma*Abs(v)*Abs(z)**(nu - 1)*z + delta*v*Abs(z)**nu)")
    params = ["m", "c", "k", "alpha", "beta", "gamma", "delta"] + ([] if nu_known else ["nu"])
    return obsnl.Model(name="boucwen_benchmark_physical", states=["y", "v", "z"], parameters=params, inputs=["u"],
                       equations={"y": "v", "v": "(u - c*v - k*y - z)/m", "z": z_dot}, outputs={"y_meas": "y"})


def case_boucwen(samples: int | None) -> Case:
    p = BW_PUBLISHED
    tic = time.perf_counter()
    u1 = multisine()
    u = np.r_[u1, u1]  # two periods from rest; the second is used (the record starts in motion)
    dt = 1.0 / FS
    t = np.arange(len(u)) * dt

    def rhs(tt, s):
        y, v, z = s
        return [v, (np.interp(tt, t, u) - p["c"] * v - p["k"] * y - z) / p["m"],
                p["alpha"] * v - p["beta"] * (p["gamma"] * abs(v) * z + p["delta"] * v * abs(z))]

    X = lsoda(rhs, t, [0.0, 0.0, 0.0], atol=[1e-13, 1e-11, 1e-9])
    n = samples or PERIOD
    X, u = X[PERIOD:PERIOD + n], u[PERIOD:PERIOD + n]
    v, z = X[:, 1], X[:, 2]
    nl_share = float(np.std(p["beta"] * (p["gamma"] * np.abs(v) * z + p["delta"] * v * np.abs(z)))
                     / np.std(p["alpha"] * v))
    data_s = time.perf_counter() - tic

    phys = boucwen_physical()
    a_phys = obsnl.analyze(phys, seed=0)
    free_nu = obsnl.analyze(boucwen_physical(nu_known=False), seed=0)
    tic = time.perf_counter()
    rep = obsnl.reparametrize(phys)
    rep_s = time.perf_counter() - tic
    a_rep = obsnl.analyze(rep.model, seed=0)
    by_name = {str(k): sp.sympify(v) for k, v in rep.mapping.items()}
    at = lambda e: e.subs({s: sp.Float(p[s.name]) for s in e.free_symbols})  # noqa: E731
    truth = {q.name: float(at(by_name[q.name])) for q in rep.model.parameters}
    # the combinations of the published beta, gamma, delta that the branches reveal (checked), and back
    sym = {s.name: s for e in by_name.values() for s in e.free_symbols}
    b, g, d = sym["beta"], sym["gamma"], sym["delta"]
    assert sp.simplify(by_name["Delta1"] - b * (g + d)) == 0 and sp.simplify(by_name["Delta2"] - b * (g - d)) == 0
    guess = {"m": 1.5, "c": 14.0, "k": 6.5e4, "alpha": 3.5e4, "Delta1": -420.0, "Delta2": 1250.0}
    model = dataclasses.replace(
        rep.model, name="boucwen_benchmark", values=truth, guess=guess,
        description="Bouc-Wen benchmark (Noel & Schoukens 2016) with nu = 1 known, in the identifiable parameters "
                    "of obsnl.reparametrize: Delta1 = beta*(gamma + delta), Delta2 = beta*(gamma - delta).",
        source="J.P. Noel, M. Schoukens (2016), Hysteretic benchmark with a dynamic nonlinearity, Workshop on "
               "Nonlinear System Identification Benchmarks, Brussels; nonlinearbenchmark.org")
    mapping = ", ".join(f"{k} = {v}" for k, v in rep.mapping.items() if str(k) != str(v))
    notes = [
        "Benchmark: m y'' + c y' + k y + z = u, z' = alpha y' - beta (gamma |y'| |z|^(nu-1) z + delta y' |z|^nu), "
        "published m = 2, c = 10, k = 5e4, alpha = 5e4, beta = 1e3, gamma = 0.8, delta = -1.1, nu = 1 "
        "(Noel & Schoukens 2016). Input: random-phase multisine, flat 5-150 Hz, RMS 50 N, 8192 samples per period "
        f"at 750 Hz (numpy, phase seed 2016). Data: scipy LSODA over two periods from rest (rtol 1e-9, atol 1e-13 / "
        f"1e-11 / 1e-9 on y / y' / z, max step one sample, {data_s:.1f} s); the identification uses the first {n} "
        f"samples of the second period ({n / FS:.2f} s; the record starts in motion). Noise: 1 % of RMS(y) on the "
        f"displacement, 0.1 % of RMS(u) on the force, seed {NOISE_SEED}. The nonlinear part of z' (all but alpha y') "
        f"has {100 * nl_share:.0f} % of the RMS of alpha y' over the record used (largest |z| "
        f"{np.abs(X[:, 2]).max():.3g} N): "
        f"the hysteresis is well engaged.",
        f"nu is taken as known (= 1): the benchmark fixes it. With nu free, `obsnl.analyze` gives jointly "
        f"unobservable {', '.join(free_nu.joint.unobservable) or 'nothing'} (nu itself jointly identifiable); with nu "
        f"= 1, the physical model (parameters {', '.join(s.name for s in phys.parameters)}): per-branch union "
        f"unobservable {', '.join(a_phys.overall_unobservable) or 'nothing'}, joint verdict unobservable "
        f"{', '.join(a_phys.joint.unobservable) or 'nothing'} ({len(a_phys.branches)} branches). The scaling z' = "
        f"alpha v - (beta gamma) |v| z - (beta delta) v |z| shows why: beta, gamma, delta enter only as beta*gamma "
        f"and beta*delta.",
        f"`obsnl.reparametrize` ({rep_s:.1f} s) proposes {mapping} (the invariants merged over the branches: each "
        f"branch sees beta (gamma +- delta)), i.e. beta*gamma = (Delta1 + Delta2)/2, beta*delta = (Delta1 - "
        f"Delta2)/2. The reparametrized model (`model.toml`) is analysed again: union unobservable "
        f"{', '.join(a_rep.overall_unobservable) or 'nothing'}, joint unobservable "
        f"{', '.join(a_rep.joint.unobservable) or 'nothing'}; it is the model identified. True values of Delta1, "
        f"Delta2 are the published beta, gamma, delta put into these definitions.",
    ]

    def derived(est):
        return {"beta*gamma": (est["Delta1"] + est["Delta2"]) / 2, "beta*delta": (est["Delta1"] - est["Delta2"]) / 2}

    return Case("boucwen_benchmark", "Bouc-Wen benchmark (Noel & Schoukens 2016), displacement measured",
                model, truth, guess, t[:n] - t[0], u[:, None], X[:, :1], {"y_meas": 0.01}, notes, derived,
                {"beta*gamma": p["beta"] * p["gamma"], "beta*delta": p["beta"] * p["delta"]}, data_s)


# ---------------------------------------------------------------- cases 2 and 3: Bouc-Wen shear frames
def frame_model(n: int, measured: list[int], name: str) -> obsnl.Model:
    """An n-storey shear frame, unit floor masses, storey force c_i d_i' + k_i d_i + kh_i z_i,
    z_i' = d_i' (1 - (beta_i sign(d_i' z_i) + gamma_i) z_i^2); the absolute accelerations of ``measured`` floors."""
    drift = lambda i: f"x{i}" if i == 1 else f"(x{i} - x{i - 1})"  # noqa: E731
    rate = lambda i: f"v{i}" if i == 1 else f"(v{i} - v{i - 1})"  # noqa: E731
    force = lambda i: f"(c{i}*{rate(i)} + k{i}*{drift(i)} + kh{i}*z{i})"  # noqa: E731
    acc = {i: f"-{force(i)}" + (f" + {force(i + 1)}" if i < n else "") for i in range(1, n + 1)}
    eqs = {}
    for i in range(1, n + 1):
        eqs[f"x{i}"] = f"v{i}"
    for i in range(1, n + 1):
        eqs[f"v{i}"] = f"-xg_dd {acc[i]}"
    for i in range(1, n + 1):
        eqs[f"z{i}"] = f"{rate(i)}*(1 - (beta{i}*sign({rate(i)}*z{i}) + gamma{i})*z{i}**2)"
    states = [f"{s}{i}" for s in "xvz" for i in range(1, n + 1)]
    params = [f"{q}{i}" for i in range(1, n + 1) for q in ("c", "k", "kh", "beta", "gamma")]
    return obsnl.Model(name=name, states=states, parameters=params, inputs=["xg_dd"], equations=eqs,
                       outputs={f"a{i}": acc[i] for i in measured})


def frame_response(n: int, p: dict[str, float], t: np.ndarray, xg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """States (x, v, z per floor) and absolute floor accelerations, by scipy."""
    c, k, kh, be, ga = (np.array([p[f"{q}{i}"] for i in range(1, n + 1)]) for q in ("c", "k", "kh", "beta", "gamma"))

    def forces(x, v, z):
        w = np.diff(np.r_[0.0, v])
        return c * w + k * np.diff(np.r_[0.0, x]) + kh * z, w

    def rhs(tt, s):
        x, v, z = s[:n], s[n:2 * n], s[2 * n:]
        f, w = forces(x, v, z)
        return np.r_[v, -np.interp(tt, t, xg) - f + np.r_[f[1:], 0.0], w * (1 - (be * np.sign(w * z) + ga) * z ** 2)]

    X = lsoda(rhs, t, np.zeros(3 * n), atol=1e-12)
    F = np.array([forces(s[:n], s[n:2 * n], s[2 * n:])[0] for s in X])
    return X, -F + np.c_[F[:, 1:], np.zeros(len(F))]


def frame_case(name: str, title: str, n: int, measured: list[int], truth: dict[str, float], guess: dict[str, float],
               scale: float, samples: int | None, extra: str) -> Case:
    rec = obsnl.read_record(RECORD)
    xg = scale * rec.accel[:samples] if samples else scale * rec.accel
    t = np.arange(len(xg)) * rec.dt
    tic = time.perf_counter()
    X, A = frame_response(n, truth, t, xg)
    data_s = time.perf_counter() - tic
    model = frame_model(n, measured, name)
    tic = time.perf_counter()
    res = obsnl.analyze(model, seed=0)
    an_s = time.perf_counter() - tic
    bad = [q for q in res.joint.unobservable if q in truth]
    undecided = [q for q in getattr(res.joint, "inconclusive", ()) if q in truth]
    model = dataclasses.replace(model, values=truth, guess=guess, description=(
        f"{n}-storey shear frame, unit floor masses, one Bouc-Wen element per storey (A = 1, n = 2 known); storey "
        f"force c_i d_i' + k_i d_i + kh_i z_i, z_i' = d_i' (1 - (beta_i sign(d_i' z_i) + gamma_i) z_i^2), d_i the "
        f"storey drift; absolute accelerations of floor(s) {', '.join(map(str, measured))} measured."),
        source="Bouc-Wen element: Wen Y.-K. (1976), J. Eng. Mech. Div. ASCE 102(2):249-263")
    zult = [1 / math.sqrt(truth[f"beta{i}"] + truth[f"gamma{i}"]) for i in range(1, n + 1)]
    zmax = np.abs(X[:, 2 * n:]).max(axis=0)
    notes = [
        f"Ground motion: Northridge 1994 LOS270 (the packaged record, 100 Hz), the first {len(t)} samples "
        f"({t[-1]:.1f} s) scaled by {scale:g} so that the springs yield clearly: largest |z_i| / z_ult,i = "
        + ", ".join(f"{zm / zu:.2f}" for zm, zu in zip(zmax, zult)) + " (z_ult = (beta + gamma)^(-1/2)). "
        f"Data: scipy LSODA from rest (rtol 1e-9, atol 1e-12, max step one sample, ground motion linear between "
        f"samples, {data_s:.1f} s). Noise: 2 % of each output's RMS on the absolute floor acceleration(s) "
        f"{', '.join(f'a{i}' for i in measured)}, 0.1 % on the ground motion, seed {NOISE_SEED}. " + extra,
        f"Structural check first (`obsnl.analyze`, {an_s:.1f} s, {len(res.branches)} branches): the per-branch union "
        f"calls {', '.join(res.overall_unobservable) or 'nothing'} unobservable (each branch sees beta_i, gamma_i "
        f"only as beta_i sign + gamma_i); the joint verdict (branches and crossings together) calls "
        f"{', '.join(bad) or 'no parameter'} unidentifiable and leaves {', '.join(undecided) or 'nothing'} undecided. "
        + ("Every parameter is jointly identifiable, so the physical model is identified as it is (no "
           "reparametrization)." if not bad and not undecided else
           "NOT every parameter is identifiable: see above."),
    ]
    return Case(name, title, model, truth, guess, t, xg[:, None], A[:, [i - 1 for i in measured]],
                {f"a{i}": 0.02 for i in measured}, notes, data_seconds=data_s)


FRAME2_TRUTH = {"c1": 0.4, "k1": 40.0, "kh1": 30.0, "beta1": 60.0, "gamma1": 40.0,
                "c2": 0.3, "k2": 30.0, "kh2": 20.0, "beta2": 70.0, "gamma2": 30.0}
FRAME2_GUESS = {"c1": 0.56, "k1": 26.0, "kh1": 42.0, "beta1": 84.0, "gamma1": 24.0,  # 30-50 % off (as in
                "c2": 0.195, "k2": 42.0, "kh2": 13.0, "beta2": 98.0, "gamma2": 45.0}  # benchmarks/models/frame2)
FRAME3_TRUTH = {"c1": 0.4, "k1": 40.0, "kh1": 30.0, "beta1": 60.0, "gamma1": 40.0,
                "c2": 0.35, "k2": 35.0, "kh2": 25.0, "beta2": 70.0, "gamma2": 30.0,
                "c3": 0.3, "k3": 30.0, "kh3": 20.0, "beta3": 50.0, "gamma3": 50.0}
FRAME3_GUESS = {"c1": 0.56, "k1": 26.0, "kh1": 42.0, "beta1": 84.0, "gamma1": 24.0,
                "c2": 0.245, "k2": 45.5, "kh2": 16.25, "beta2": 49.0, "gamma2": 42.0,
                "c3": 0.42, "k3": 21.0, "kh3": 27.0, "beta3": 70.0, "gamma3": 32.5}


def case_frame2(samples: int | None) -> Case:
    return frame_case("frame2_full", "Two-storey Bouc-Wen shear frame, both floor accelerations measured", 2, [1, 2],
                      FRAME2_TRUTH, FRAME2_GUESS, 2.0, samples, "Guesses 30-50 % off (those of "
                      "benchmarks/models/frame2_bouc_wen.toml).")


def case_frame3(samples: int | None) -> Case:
    return frame_case("frame3_roof", "Three-storey Bouc-Wen shear frame, roof acceleration only", 3, [3],
                      FRAME3_TRUTH, FRAME3_GUESS, 2.0, samples, "Guesses 30-40 % off. Only the roof is "
                      "instrumented: the two lower floors' responses are hidden states. The whole record: the "
                      "first version of this benchmark cut it to 1200 samples to stay within 5 minutes with the "
                      "profiles in one process (413 s on 1999 samples then); with the profiles on two workers "
                      "(--workers 2) the whole record fits, and it flags fewer parameters.")


CASES = {"boucwen_benchmark": case_boucwen, "frame2_full": case_frame2, "frame3_roof": case_frame3}


# ---------------------------------------------------------------- running and scoring
def noisy(case: Case, seed: int = NOISE_SEED, scale: float = 1.0) -> dict[str, np.ndarray]:
    """The measured columns: the outputs with ``case.noise`` and the input with 0.1 % noise (both times ``scale``:
    0 gives the noise-free data), Gaussian, from ``seed``."""
    rng = np.random.default_rng(seed)
    rms = lambda a: np.sqrt(np.mean(a ** 2, axis=0))  # noqa: E731
    cols = {"time_s": case.t}
    outs = list(case.model.outputs)
    ratio = np.array([case.noise[o] for o in outs])
    ys = case.y + scale * ratio * rms(case.y) * rng.standard_normal(case.y.shape)
    us = case.u + scale * INPUT_NOISE * rms(case.u) * rng.standard_normal(case.u.shape)
    cols.update({s.name: us[:, j] for j, s in enumerate(case.model.inputs)})
    cols.update({o: ys[:, j] for j, o in enumerate(outs)})
    case.sigma = {o: case.noise[o] * rms(case.y)[j] for j, o in enumerate(outs)}  # the true noise std
    return cols


#: Local processes for the profiles (``--workers``; 1: this process, one profile after the other).
WORKERS = 1
#: ``--jit``: the filter and the fit compiled to C (``obsnl.identify(..., jit=True)``; the same numbers to rounding).
JIT = False


def timed_identify(case: Case, data: dict, refine: bool):
    from obsnl.executor import Executor

    stamps = []
    tic = time.perf_counter()
    noise = dict(case.noise) | {s.name: INPUT_NOISE for s in case.model.inputs}
    res = obsnl.identify(case.model, data, guess=case.guess, noise=noise, refine=refine, jit=JIT,
                         progress=lambda: stamps.append(time.perf_counter() - tic),
                         executor=Executor(workers=WORKERS) if WORKERS > 1 else None)
    return res, time.perf_counter() - tic, stamps


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The exact (Clopper-Pearson) binomial interval of a proportion ``k / n``."""
    from scipy.stats import beta

    a = (1 - level) / 2
    return (0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1)),
            1.0 if k == n else float(beta.ppf(1 - a, k + 1, n - k)))


def covers(interval, truth) -> bool | None:
    if interval is None:
        return None
    lo, hi = interval
    return (lo is None or lo <= truth) and (hi is None or truth <= hi)


def fmt(x, digits=5) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{digits}g}"


def pct(x) -> str:
    return "-" if x is None else f"{x:+.3g}"


def within(p, truth: float) -> tuple[bool, bool]:
    """(within 5 %, within max(4 std, 1 % of the truth))."""
    if p.estimate is None:
        return False, False
    err = abs(p.estimate - truth)
    return err <= 0.05 * abs(truth), p.std is not None and err <= max(4 * p.std, 0.01 * abs(truth))


def residual_ratio(res, case: Case) -> dict[str, float]:
    """RMS(model at the estimate - measurement) / true noise std, per output (independent of the tool's levels)."""
    out = {}
    for j, o in enumerate(res.outputs):
        r = np.asarray(res.y_fit)[:, j] - np.asarray(res.y_measured)[:, j]
        out[o] = float(np.sqrt(np.mean(r ** 2)) / case.sigma[o])
    return out


def phases(res, wall: float, stamps: list[float], refined: bool) -> str:
    """Where the time went, from the progress calls (one per filter pass, one after the ML fit, one per profile)."""
    k = len(res.tuning_scores) + res.passes_run
    if len(stamps) < k:
        return f"{wall:.1f} s in all (progress calls: {len(stamps)})"
    parts = [f"structural analysis, compilation and {k} filter passes ({len(res.tuning_scores)} tuning, "
             f"{res.passes_run} protocol) {stamps[k - 1]:.1f} s"]
    last = stamps[k - 1]
    if refined and len(stamps) > k:
        parts.append(f"the filter's practical-identifiability check and the maximum-likelihood fit "
                     f"{stamps[k] - last:.1f} s (the fit itself, objective built and Levenberg-Marquardt: "
                     f"{res.refinement.seconds if res.refinement else float('nan'):.1f} s)")
        parts.append(f"{len(stamps) - k - 1} profiles {stamps[-1] - stamps[k]:.1f} s")
        last = stamps[-1]
        parts.append(f"the rest (fit simulation, result) {wall - last:.1f} s")
    else:
        parts.append(f"the rest (practical-identifiability check, fit simulation, result) {wall - last:.1f} s")
    return "; ".join(parts)


def repeats(case: Case, seeds: int) -> list[str]:
    """The refined identification again: on the noise-free data (the integrator's and the model's own bias), then
    on ``seeds`` other noise seeds (1, 2, ...): the spread of error/std and the coverage of the intervals."""
    if seeds <= 0:
        return []
    runs = [("noise-free", noisy(case, scale=0.0))] + [(f"seed {k}", noisy(case, seed=k)) for k in range(1, seeds + 1)]
    noisy(case)  # the true noise std of the main run again
    results = []
    for label, data in runs:
        res, wall, _ = timed_identify(case, data, refine=True)
        results.append((label, res, wall))
        print(f"  {case.name} {label}: {wall:.0f} s, converged {res.converged}", flush=True)
    head = "| parameter | " + " | ".join(label for label, _, _ in results) + " |"
    lines = ["## The refined run repeated", "",
             "The same identification (defaults, same guesses and given noise levels) on the noise-free data and on "
             f"{seeds} other noise seeds. Each cell: error % (error / reported std); a cross marks a 95 % interval "
             "that misses the truth, F a flagged parameter. On the noise-free data the reported std (from the "
             "residuals of the fit) is near 0, so only the error % is meaningful there: it is the bias of the model "
             "and of obsnl's integrator against scipy's.", "", head, "|---|" + "---:|" * len(results)]
    for q in case.model.parameters:
        cells = []
        for label, res, _ in results:
            p = {x.name: x for x in res.parameters}[q.name]
            tru = case.truth[q.name]
            if p.estimate is None:
                cells.append("held")
                continue
            e = 100 * (p.estimate - tru) / abs(tru)
            r = "" if label == "noise-free" or not p.std else f" ({(p.estimate - tru) / p.std:+.2f})"
            mark = ("" if label == "noise-free" or covers(p.interval, tru) else " x") + (" F" if p.flagged else "")
            cells.append(f"{e:+.3f}{r}{mark}")
        lines.append(f"| {q.name} | " + " | ".join(cells) + " |")
    n = len(case.model.parameters)
    cov = [sum(bool(covers(p.interval, case.truth[p.name])) for p in res.parameters) for _, res, _ in results]
    lines += ["| intervals covering | " + " | ".join("-" if lab == "noise-free" else f"{c}/{n}"
                                                   for (lab, _, _), c in zip(results, cov)) + " |",
              "| converged | " + " | ".join(str(res.converged) for _, res, _ in results) + " |",
              "| wall s | " + " | ".join(f"{w:.0f}" for _, _, w in results) + " |", ""]
    noisy_cov = sum(cov[1:])
    lo, hi = clopper_pearson(noisy_cov, seeds * n)
    meet = sum(c >= 0.8 * n for c in cov[1:])
    lines.append(f"Over these {seeds} seeds: {noisy_cov} of {seeds * n} intervals cover the truth "
                 f"({100 * noisy_cov / (seeds * n):.0f} %, exact 95 % binomial interval {100 * lo:.0f}-{100 * hi:.0f} %; "
                 f"nominal 95 %; the binomial interval takes the intervals as independent, those of one run are not, so it "
                 f"is too narrow); "
                 f"{meet} of {seeds} runs have at least 80 % of their intervals covering the truth (the goal of one "
                 f"run). Not converged: "
                 + ("; ".join(f"{lab}: {res.converged_reason}" for lab, res, _ in results if not res.converged)
                    or "none")
                 + ".")
    lines.append("")
    return lines


def run_case(case: Case, out: Path, seeds: int = 0, command: str = CMD) -> tuple[str, dict]:
    data = noisy(case)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    ukf, t_ukf, s_ukf = timed_identify(case, data, refine=False)
    ml, t_ml, s_ml = timed_identify(case, data, refine=True)
    folder = out / case.name
    folder.mkdir(parents=True, exist_ok=True)
    write_identification(ml, folder, force=True)
    (folder / "model.toml").write_text(model_to_toml(case.model, header=(
        f"Written by {command}: the model identified; [values] are the truth that made the data "
        f"(scored against, never used by the tool), [guess] the starting values.")), encoding="utf-8")
    u_by = {p.name: p for p in ukf.parameters}
    rows = ["| parameter | truth | guess | UKF alone | error % | refined | error % | std | error/std | "
            "95 % interval | covers truth | flagged (reason) |", "|---|" + "---:|" * 8 + "---|---|---|"]
    n_cov = n_int = 0
    bad_params = []
    for p in ml.parameters:
        tru = case.truth[p.name]
        u = u_by[p.name]
        e_u = None if u.estimate is None else 100 * (u.estimate - tru) / abs(tru)
        e_m = None if p.estimate is None else 100 * (p.estimate - tru) / abs(tru)
        ratio = None if p.estimate is None or not p.std else (p.estimate - tru) / p.std
        cov = covers(p.interval, tru)
        n_cov += bool(cov)
        n_int += 1
        iv = "-" if p.interval is None else "[" + ", ".join("open" if e is None else fmt(e) for e in p.interval) + "]"
        if not p.flagged:
            w5, w4 = within(p, tru)
            if not (w5 and w4):
                bad_params.append(f"{p.name} ({'outside 5 %' if not w5 else ''}{', ' if not w5 and not w4 else ''}"
                                  f"{'outside max(4 std, 1 %)' if not w4 else ''})")
        rows.append(f"| {p.name} | {fmt(tru)} | {fmt(case.guess[p.name])} | {fmt(u.estimate)} | {pct(e_u)} | "
                    f"{fmt(p.estimate)} | {pct(e_m)} | {fmt(p.std, 3)} | {fmt(ratio, 2)} | {iv} | "
                    f"{'-' if cov is None else 'yes' if cov else 'NO'} | "
                    f"{'yes: ' + (p.reason or '') if p.flagged else 'no'} |")
    if case.derived:
        dm = case.derived({p.name: p.estimate for p in ml.parameters})
        du = case.derived({p.name: p.estimate for p in ukf.parameters})
        for k, tru in case.derived_truth.items():
            rows.append(f"| {k} (derived) | {fmt(tru)} | - | {fmt(du[k])} | {pct(100 * (du[k] - tru) / abs(tru))} | "
                        f"{fmt(dm[k])} | {pct(100 * (dm[k] - tru) / abs(tru))} | - | - | - | - | - |")
    ref = ml.refinement  # None: no maximum-likelihood fit
    misfit = {} if ref is None else dict(ref.misfit_over_noise)
    rr_ml, rr_ukf = residual_ratio(ml, case), residual_ratio(ukf, case)
    flagged = list(ml.flagged)
    ukf_bad = [p.name for p in ukf.parameters if not p.flagged and not all(within(p, case.truth[p.name]))]
    goals = {
        "parameters": (not bad_params,
                       "every parameter not flagged within 5 % of its truth and within max(4 std, 1 %): "
                       + ("all " + str(len(ml.parameters) - len(flagged)) + " not flagged are" if not bad_params else
                          "not: " + "; ".join(bad_params)) + (f" (flagged: {', '.join(flagged)})" if flagged else
                                                              " (none flagged)")),
        "fit": (bool(misfit) and all(v <= 1.3 for v in misfit.values()),
                "fit, RMS residual / noise <= 1.3 per output: " + (", ".join(f"{o} {v:.3f}" for o, v in misfit.items())
                                                                   or "no refinement result")),
        "intervals": (n_cov >= 0.8 * len(ml.parameters),
                      f"95 % intervals contain the truth for >= 80 % of the parameters: {n_cov} of "
                      f"{len(ml.parameters)} ({100 * n_cov / len(ml.parameters):.0f} %)"),
        "time": (t_ml <= LIMIT_S, f"run under 5 minutes: {t_ml:.0f} s (the default `obsnl.identify` call"
                 + (", jit=True" if JIT else "") + ")"),
    }
    summary = f"**{case.name}**: " + "; ".join(f"{txt}: **{'met' if ok else 'NOT met'}**" for ok, txt in goals.values())
    lines = [f"# {case.title}", "",
             f"Written by `{command}` (obsnl {obsnl.__version__}, {revision()}; {os.cpu_count()} "
             f"cores, {platform.machine()}, load average {load:.2f} at the start). Model identified: `model.toml`; "
             + ", ".join(f"`{f}`" for f in IDENTIFY_FILES) + ": the refined run (`write_identification`).", ""]
    lines += [*(f"{n}\n" for n in case.notes)]
    jit = ", jit=True" if JIT else ""
    lines += [f"Identification: `obsnl.identify(model, data, guess=..., noise={{outputs as made, input 0.001}}{jit})`, "
              f"once with `refine=False` (the UKF passes alone) and once with the defaults (the passes, then maximum "
              f"likelihood and profile-likelihood intervals). {len(case.t)} samples, dt {case.t[1] - case.t[0]:.6g} s. "
              f"Filter tuning chosen by the tool: {ml.tuning.to_dict()} (UKF-alone run: {ukf.tuning.to_dict()}).", "",
              *rows, "",
              "error/std: (refined - truth) / std; std from the Fisher information at the estimate (refined run). "
              "An interval end marked open: the profile stayed below the threshold up to a factor 10 on that side "
              "(an open side counts as covering the truth). The UKF-alone std (the filter's posterior) is not in the "
              "table: " + ", ".join(f"{p.name} {fmt(p.std, 3)}" for p in ukf.parameters) + ".", "",
              f"**Converged** (refined run): {ml.converged}: {ml.converged_reason}. "
              f"Iterations {ref and ref.iterations}, evaluations {ref and ref.evaluations}, "
              f"Newton decrement {fmt(ref and ref.newton_decrement, 3)}, "
              f"chi2 {fmt(ref and ref.chi2, 6)} "
              f"over {ref and ref.samples} residuals.", "",
              "| output | noise (true std) | fit NRMSE % UKF alone | fit NRMSE % refined | misfit_over_noise (tool) | "
              "RMS residual / true noise std, UKF alone | refined |", "|---|---:|---:|---:|---:|---:|---:|"]
    for o in ml.outputs:
        lines.append(f"| {o} | {case.noise[o] * 100:g} % ({case.sigma[o]:.4g}) | {fmt(ukf.fit.get(o), 4)} | "
                     f"{fmt(ml.fit.get(o), 4)} | {fmt(misfit.get(o), 4)} | {rr_ukf[o]:.3f} | {rr_ml[o]:.3f} |")
    prof_rows = [f"{pr.name} {pr.shape} ({pr.evaluations} evaluations)" for pr in ml.profiles]
    lines += ["", f"**Wall time**: UKF alone {t_ukf:.1f} s; refined {t_ml:.1f} s. Refined run: "
              f"{phases(ml, t_ml, s_ml, True)}. UKF-alone run: {phases(ukf, t_ukf, s_ukf, False)}.", "",
              "Profiles: " + (", ".join(prof_rows) or "none") + ".", "",
              f"Flagged by the UKF alone (its practical-identifiability checks): {', '.join(ukf.flagged) or 'none'}; "
              f"UKF-alone parameters not flagged yet outside 5 % or max(4 posterior std, 1 %): "
              f"{', '.join(ukf_bad) or 'none'}.", "",
              "## Goals of issue 27 (refined run)", ""]
    lines += [f"- {txt}: **{'met' if ok else 'NOT met'}**" for ok, txt in goals.values()]
    lines.append("")
    lines += repeats(case, seeds)
    (folder / "README.md").write_text("\n".join(lines), encoding="utf-8")
    return summary, goals


#: Repeats of the refined run per case (the noise-free data and this many other noise seeds): as many as keep the
#: whole script near half an hour on 2 cores (frame3_roof's runs take about 4 minutes each).
DEFAULT_SEEDS = {"boucwen_benchmark": 4, "frame2_full": 4, "frame3_roof": 2}

#: The reading of the committed run, written by hand after it (regenerating rewrites everything else in
#: likelihood.md, not this; check it against the tables when the code has changed).
FINDINGS = """\
Reading of the committed runs (regenerated at commit 2be93d4, every case with `--workers 2 --jit`:
`obsnl.identify(..., jit=True)`, the filter and the maximum-likelihood fit compiled to C, the profiles on two workers;
frame2_full's folder is the run with `--seeds 20`, on a warm cache). This reading was written on the runs of commit
a83810c and checked against these: since then the noise per output is estimated over its degrees of freedom
(RSS / (N - h), not RSS / N), so every std is 0.1-0.5 % wider than there; every estimate, count and verdict below is
the same, and the times differ by a few seconds. The refinement counts the measured
input's 0.1 % noise (`refinement.input_noise_widening`): against the earlier runs without it (commits 3813115 and
4e26990) every estimate is the same and the std are 0.2-5 % wider (Bouc-Wen benchmark 2.5-5 %, frame2_full 0.5-1.3 %);
no verdict changed.

**What the refinement changes.** On the Bouc-Wen benchmark the UKF alone (3 passes, tuned by the tool) ends 20-30 %
off on c, k, alpha, Delta1 and Delta2, its simulated output misses the data by 8.1 times the noise, it flags nothing,
and its posterior std is far too small (k: std 24 for an error of 13 200, about 550 std). The refinement brings every
parameter within 0.8 % (k, alpha, Delta1, Delta2 within 0.21 %; the published beta*gamma and beta*delta, derived from
Delta1 and Delta2, within 0.22 %), the fit to 1.003 times the noise, converged, in 17 s. On frame2_full the filter
alone is already within 3.4 % and the refinement changes little (within 3.7 %). On frame3_roof (roof only, the whole
record) the filter alone flags 7 of 15 parameters, the refinement 4 (95 % intervals wider than +-5 %); the 11 it does
not flag are within 2.3 % (beta1 -2.24 %, beta3 +1.59 %, the others within 1.1 %); gamma2 is 9.1 % off (flagged; its interval
[24.0, 30.6] covers the truth 30).

**Goals.** boucwen_benchmark and frame3_roof: all four met. frame2_full: the coverage goal of one run is NOT met on
its reported seed 0 (7 of 10 intervals: k1 at +3.2 std, kh1 at -3.0 std, gamma2 at -2.1 std); the other three are
met. Each run is under 5 minutes: 17 s, 8 s (40 s in the first run of the machine, which compiles the fit) and 100 s
(the first run; its repeats take 25 s).

**Are the intervals calibrated? frame2_full over 20 more noise seeds.** 193 of 200 intervals cover the truth (96.5 %;
nominal 95 %), and 19 of the 20 runs meet the one-run goal (at least 8 of 10 covering); seed 5 misses it with 7 of 10
as seed 0 does. So the profile-likelihood intervals have their nominal coverage, and the one-run goal is a random
event: with ten correlated parameters it failed on 2 of 21 runs (seeds 0 and 5). The misses come in groups: k1 and kh1
miss together and in opposite directions (their sum is the storey's initial stiffness), and on seed 5 beta1 misses
with them; one draw along such a direction costs two or three intervals at once. Not the integrator nor the model: on the noise-free data the fit is
within 0.002 % of the truth for every parameter. Not the 0.1 % input noise: with output noise only (same seed 0;
checked once, not regenerated by the script) k1, kh1 and gamma2 were still at +2.8, -2.6 and -2.0 std. The
finite-noise bias of gamma2 that 5 seeds hinted at is not there: over the 20 seeds its errors are spread on both
sides (11 of 20 positive). Pooled over every noisy run of the three cases (main runs and repeats), 270 of 285
intervals cover the truth (95 %).

**The joint region holds the truth where the one-run goal fails.** `benchmarks/bench_joint_region.py` (written to
`joint_region.md`) checks the reported uncertainty as a whole on frame2_full: the Wald statistic of the truth under
the reported std and correlations (`identify.json`, `refinement.correlation`) follows chi2(10) when they are right.
Over noise seeds 0-8 its mean is 10.7 (chi2(10): 10; the sum 96.7 against chi2(90), P = 0.30), and the truth lies
inside the joint 95 % region on all 9 seeds, seeds 0 and 5 included (W 17.3 and 15.0 against 18.3): there the
estimate is off along the k1/kh1 direction that the reported correlations describe, and the one-parameter intervals,
each right on its own, miss together. The one-run goal of 8 in 10 marginal intervals is a random event even for
calibrated intervals (2 of 21 runs here); the joint region is the claim a run can keep every time at its level.
How often it fails for intervals that are exactly right is computed in `one_run_goal.md` (bench_one_run_goal.py:
Gaussian errors with each run's reported std and correlations, nothing fitted): 6.2 % of runs on frame2_full (1.2 %
if its estimates were independent), 7.0 % on the Bouc-Wen benchmark, 3.6 % on frame3_roof. Seeds 0-59 of
frame2_full fail it 3 times (5 %; below).

**Noise on the measured input.** At this benchmark's 0.1 % on the input, counting its noise widens the std by 0.2-5 %
(above), which changes no verdict here. It matters when the input is measured as noisily as the outputs:
`input_noise.md` (bench_input_noise.py, frame2_full with 2 % on the ground motion, 20 seeds): with the input's noise
counted 194 of 200 normal 95 % intervals cover the truth (Wald mean 9.75 against 10, P = 0.59); with the output noise's
std alone, as reported before, 104 of 200 (errors up to 11 of those std, the failure this issue opened with). The lead
of an earlier reading, that the 0.1 % input noise made k1 and kh1's std too small, is refuted by `std_spread.md`
(bench_std_spread.py): on seeds 0-19 their spread is 1.33 with that noise and 1.27 with a clean input (the same output
noise), and over seeds 0-59 (`std_spread_more.md` adds 20-59, the input's noise counted there) it is 1.06 and 1.04 (1 for a
right std; every parameter 0.86-1.08): the first 20 seeds were a high draw. Over those 60 seeds the Wald statistic's
mean is 10.09 (P = 0.43), the truth lies in the joint 95 % region on 58, 573 of 600 normal 95 % intervals cover it, and
57 of the 60 runs meet the one-run goal of 8 in 10 (seed 0, the reported one, is among the 3 that do not).

**Where the time goes.** Compiled (`jit=True`), the fit's Jacobian is forward sensitivities of one compiled step
(`obsnl.estimation.simulate.residuals`), built once per model, record step and substeps: the first run of a case pays
that compilation inside its "maximum-likelihood fit" time (9.6 s of the Bouc-Wen benchmark's 16.7 s, 33 s of
frame2_full's first 40 s, about 70 s of frame3_roof's 100 s); every later run loads it (frame2_full's reported run, warm:
8.2 s in all, the fit 1.6 s and ten profiles 4.4 s; frame3_roof's repeats 25 s). The profiles, the largest cost of the
uncompiled runs (29 of 46 s, 65 of 86 s and 158 of 180 s at commits 3813115 and 4e26990), take 4.3 s, 4.4 s and 15.1 s.
Without `jit` the numbers are the same to rounding and the runs take those earlier times.

**Other behaviour seen.** On frame2_full's noise-free data the refinement reports "not converged" (its last step moved
a parameter by 0.25 of its std), although the estimate is within 0.002 % of the truth: there the residuals are only the
difference between obsnl's integrator and scipy's, the re-estimated noise is at that scale, and so is every std. It
does not arise with noisy data (every noisy run of every case converged); the noise-free runs of the other two cases
converged.
"""


def gather(out: Path) -> None:
    """likelihood.md: every case folder present, in the order of CASES."""
    parts = ["# Maximum-likelihood refinement after the UKF (issue 27): evidence", "",
             f"Regenerate (from the repository root, with this tree's obsnl importable, e.g. `PYTHONPATH=.`): `{CMD}` "
             f"(every case with its repeats, one after the other: about half an hour on 2 cores, 7-8 minutes with `--workers 2 --jit`), or `{CMD} --case "
             f"NAME [--seeds K]`; `--out DIR` (default reports/identification); `--gather` only rebuilds this file "
             f"from the case folders. Each case's folder holds its README.md (copied below), model.toml and the "
             f"refined run's " + ", ".join(IDENTIFY_FILES) + ".", "",
             "Goals (issue 27, checked on the default run, i.e. with the refinement): every parameter not flagged "
             "within 5 % of its truth and within 4 reported std (or 1 %, whichever is larger); fit, RMS residual / "
             "noise, <= 1.3 per output; 95 % intervals containing the truth for >= 80 % of the parameters; the run "
             "under 5 minutes.", "", "## Summary", ""]
    bodies = []
    for name in CASES:
        readme = out / name / "README.md"
        if not readme.exists():
            continue
        text = readme.read_text(encoding="utf-8")
        body = "\n".join(("#" + ln if ln.startswith("#") else ln) for ln in text.splitlines())
        goal_lines = [ln for ln in text.splitlines() if ln.startswith("- ") and "**" in ln]
        parts.append(f"- **{name}**: " + "; ".join(g[2:] for g in goal_lines))
        bodies.append(body)
    if FINDINGS.strip():
        parts += ["", "## Findings", "", FINDINGS.strip()]
    (out / "likelihood.md").write_text("\n".join(parts + ["", *bodies, ""]), encoding="utf-8")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=sorted(CASES), default=None, help="run one case (default: all)")
    ap.add_argument("--out", default=str(ROOT / "reports" / "identification"))
    ap.add_argument("--samples", type=int, default=None, help="record length (default: each case's own)")
    ap.add_argument("--seeds", type=int, default=None, help="repeat the refined run on the noise-free data and on "
                    "this many other noise seeds (default: DEFAULT_SEEDS of the case; 0: not repeated)")
    ap.add_argument("--jit", action="store_true", help="compile the filter and the fit to C (identify(..., jit=True))")
    ap.add_argument("--gather", action="store_true", help="only rebuild likelihood.md from the case folders")
    ap.add_argument("--workers", type=int, default=1, help="local processes for the profiles (default 1: in this "
                    "process; `obsnl.identify(..., executor=Executor(workers=N))`)")
    args = ap.parse_args(argv)
    global WORKERS, JIT
    WORKERS, JIT = max(1, args.workers), args.jit
    out = Path(args.out)
    if args.gather:
        gather(out)
        return 0
    names = [args.case] if args.case else list(CASES)
    ok = True
    for name in names:
        tic = time.perf_counter()
        seeds = DEFAULT_SEEDS[name] if args.seeds is None else args.seeds
        case = CASES[name](args.samples)
        command = (f"{CMD} --case {name}" + (f" --samples {args.samples}" if args.samples else "")
                   + (f" --workers {WORKERS}" if WORKERS > 1 else "") + (" --jit" if JIT else "")
                   + (f" --seeds {seeds}" if seeds != DEFAULT_SEEDS[name] else ""))
        summary, goals = run_case(case, out, seeds, command)
        ok &= all(g for g, _ in goals.values())
        print(summary, f"({time.perf_counter() - tic:.0f} s with the data and the repeats)", flush=True)
    gather(out)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
