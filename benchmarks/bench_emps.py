"""EMPS benchmark (Janot, Gautier, Brunot 2019): obsnl's estimates against the published IDIM-LS values.

The record (benchmarks/data/emps/, with its provenance) is a real ball-screw drive under a PD position
controller, 1 kHz, 24 841 samples: four periods of one bang-bang trajectory. The first three periods (up to the
sample where the reference last returns to 0, 75 % of the record) are identified; the fourth, a whole period,
is the held-out test record. Nothing here uses obsnl to make a reference answer:

- IDIM-LS is recomputed with numpy/scipy exactly as the authors' script does it (4th-order Butterworth at 100 Hz
  run forwards and backwards, central differences, decimation by 10, least squares): it must give the published
  values, which checks the data;
- the test figures of merit come from scipy's solve_ivp (RK45, rtol 1e-10), one hold interval of 1 ms at a
  time, with Coulomb friction's sticking handled as Filippov's solution: "closed loop" runs the benchmark's
  digital PD controller (its law, its FIR velocity, its 10 V saturation) on the reference position, as the
  authors' Simulink reference simulation does; "open loop" holds the measured motor force over each sample.
  Both start from the state at the test record's start, estimated from its first WARMUP samples (a quadratic
  fit), and are scored from there on. Every parameter set (IDIM-LS, each obsnl run) is simulated the same way;
- the closed-loop model file is checked against the digital loop it stands for: obsnl identifies it on that
  loop's response (scipy) to the same reference at the IDIM-LS values, where the truth is known.

obsnl identifies two model files written into the report folder: the closed loop (input qref_m; the
controller written into the model, its sampling represented by two first-order Pade delay states) and the
open loop (input force_N, the rigid plant alone), the open loop twice: by its output error, and by its prediction
error (``objective="prediction"``: a constant-gain predictor fitted with the parameters, for a plant that drifts).
Run: ``python benchmarks/bench_emps.py [--out DIR] [--force] [--only closed|open|open_prediction]``; writes
DIR/README.md, results.json, the model files, the figures and one identify folder per run (default DIR
reports/benchmarks/emps). The runs take one after the other, about 6 minutes in all on a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy import signal
from scipy.integrate import solve_ivp

import obsnl
from obsnl.estimation.measured import measured
from obsnl.identification.identify import write_identification
from obsnl.report.files import OutputFolder, check_folder

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "benchmarks" / "data" / "emps" / "emps_train.csv"
OUT = ROOT / "reports" / "benchmarks" / "emps"

# the benchmark's controller and drive (description, section 1.3 and 2.2; Simulation_EMPS.m)
KP, KV, GTAU, VMAX, DT = 160.18, 243.45, 35.15065188, 10.0, 1e-3
#: Published IDIM-LS estimates and their std (description, section 3.4).
PUBLISHED = {"M": (95.1089, 0.1085), "Fv": (203.5034, 1.1460), "Fc": (20.3935, 0.1012), "offset": (-3.1648, 0.0444)}
UNITS = {"M": "kg", "Fv": "N s/m", "Fc": "N", "offset": "N"}
PARAMS = tuple(PUBLISHED)
#: Samples at the test record's start used to estimate the initial state (excluded from the score).
WARMUP = 20
#: The delays the digital loop adds, as the closed-loop model file represents them: the zero-order hold of the
#: controller's output (half a sample on average) and, for the velocity, the two-sample difference of the FIR-
#: filtered position (one sample more).
DELAY_HOLD, DELAY_VELOCITY = 0.5 * DT, 1.5 * DT
#: The motor encoder's step on the load side (m): 50 000 counts per revolution.
ENCODER = 5e-8
#: Guesses given to obsnl: round numbers 15-37 % away from the IDIM-LS values.
GUESS = {"M": 80.0, "Fv": 150.0, "Fc": 15.0, "offset": -2.0}
#: What the issue asks of obsnl's estimates (per cent of IDIM-LS) and of the test RMSE (ratio to IDIM-LS's).
GOAL_PERCENT, GOAL_RMSE_RATIO, GOAL_SECONDS = 3.0, 1.1, 60.0

_GUESS_TOML = "\n".join(f"{k} = {v}" for k, v in GUESS.items())
CLOSED_LOOP = f'''name = "emps_closed_loop"
description = """EMPS (Janot, Gautier, Brunot 2019) in closed loop: the rigid ball-screw drive
M q'' + Fv q' + Fc sign(q') + offset = gtau*vir under the benchmark's PD controller
vir = kp*kv*(qref - q) - kv*q', driven by the reference position qref_m; the measured motor position q_m is the
output. The controller is digital (1 kHz): its output is held over each sample (a delay of th = dt/2 on
average) and its velocity is a two-sample difference of the position (a further dt, tv = 3 dt/2 in all). Each
delay is a first-order Pade state: we for the position error delayed by th, wv for the velocity delayed by tv
(a signal x delayed by t is 2 w - x with w' = 2 (x - w)/t). The 10 V saturation of the authors' simulation
is left out: the record never comes near it (|vir| <= 4.33 V)."""
source = """A. Janot, M. Gautier, M. Brunot, Data Set and Reference Models of EMPS, Workshop on Nonlinear
System Identification Benchmarks, 2019."""
states = ["q", "v", "we", "wv"]
parameters = ["M", "Fv", "Fc", "offset"]
inputs = ["qref_m"]
known_constants = ["kp", "kv", "gtau", "th", "tv"]

[outputs]
q_m = "q"

[equations]
q = "v"
v = "(gtau*(kp*kv*(2*we - (qref_m - q)) - kv*(2*wv - v)) - Fv*v - Fc*sign(v) - offset)/M"
we = "2*(qref_m - q - we)/th"
wv = "2*(v - wv)/tv"

[intersample]
qref_m = "linear"

[values]
kp = {KP}
kv = {KV}
gtau = {GTAU}
th = {DELAY_HOLD}
tv = {DELAY_VELOCITY}

[guess]
{_GUESS_TOML}
'''
OPEN_LOOP = f'''name = "emps_open_loop"
description = """EMPS (Janot, Gautier, Brunot 2019) in open loop: the rigid ball-screw drive
M q'' + Fv q' + Fc sign(q') + offset = force_N driven by the measured motor force (gtau times the recorded
controller output, held over each sample by the digital controller); the motor position q_m is the output.
A pure integrator: a simulation drifts with every force error."""
source = """A. Janot, M. Gautier, M. Brunot, Data Set and Reference Models of EMPS, Workshop on Nonlinear
System Identification Benchmarks, 2019."""
states = ["q", "v"]
parameters = ["M", "Fv", "Fc", "offset"]
inputs = ["force_N"]

[outputs]
q_m = "q"

[equations]
q = "v"
v = "(force_N - Fv*v - Fc*sign(v) - offset)/M"

[intersample]
force_N = "zoh"

[guess]
{_GUESS_TOML}
'''
#: run name -> (model file, model text, the input's kind between samples, what the run is)
RUNS = {
    "closed": ("emps_closed_loop.toml", CLOSED_LOOP, "linear",
               "input qref_m, a smooth reference, linear between samples; the controller's hold is in the model"),
    "open": ("emps_open_loop.toml", OPEN_LOOP, "zoh",
             "input force_N, a digital controller's output, held between samples"),
    "open_prediction": ("emps_open_loop.toml", OPEN_LOOP, "zoh",
                        "the open-loop file fitted by its prediction error (objective='prediction'): a predictor "
                        "corrects the position and velocity by a gain fitted with the parameters, so the drift of "
                        "the real drive that the rigid model lacks is not read as its parameters"),
}
#: run name -> obsnl.identify's objective (output error where not named)
OBJECTIVE = {"open_prediction": "prediction"}
#: run name -> how the tables name it
LABEL = {"closed": "closed loop", "open": "open loop", "open_prediction": "open loop, prediction error"}
FILES = ("README.md", "results.json", "test_closed_loop.png", "test_open_loop.png", "idim_ls.png",
         *dict.fromkeys(r[0] for r in RUNS.values()))


# ---------------------------------------------------------------------------------------------- data, IDIM-LS
def read_data(path: Path = DATA) -> dict[str, np.ndarray]:
    d = np.genfromtxt(path, delimiter=",", names=True)
    return {k: np.asarray(d[k], float) for k in d.dtype.names or ()}


def test_start(d: dict[str, np.ndarray]) -> int:
    """The last sample where the reference is back at its start (0): the fourth period begins there."""
    zeros = np.flatnonzero(d["qref_m"] == 0.0)
    return int(zeros[-1])


def _filtfilt(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    # MATLAB's filtfilt: odd reflection over 3*(order) samples
    return signal.filtfilt(b, a, x, padtype="odd", padlen=3 * (max(len(a), len(b)) - 1))


def _diffcent(x: np.ndarray, h: float) -> np.ndarray:
    y = np.empty_like(x)
    y[1:-1] = (x[2:] - x[:-2]) / (2 * h)
    y[0], y[-1] = (x[1] - x[0]) / h, (x[-1] - x[-2]) / h
    return y


def _decimate(x: np.ndarray, r: int) -> np.ndarray:
    # MATLAB's decimate: Chebyshev I of order 8, 0.05 dB, cut-off 0.8/r, zero phase; the samples kept end at the last
    b, a = signal.cheby1(8, 0.05, 0.8 / r)
    nout = math.ceil(len(x) / r)
    return _filtfilt(b, a, x)[r - (r * nout - len(x)) - 1::r]


def idim_ls(d: dict[str, np.ndarray]) -> dict:
    """IDIM-LS as Script_IDIM_LS.m computes it, on the whole record (as published)."""
    b, a = signal.butter(4, 100.0 / 500.0)
    qf = _filtfilt(b, a, d["q_m"])
    dq = _diffcent(qf, DT)
    ddq = _diffcent(dq, DT)
    border = 49  # MATLAB's n_border = 50, 1-based
    X = np.column_stack([ddq, dq, np.sign(dq), np.ones_like(dq)])[border:]
    y = d["force_N"][border:]
    r = round(0.8 * 500 / 40)
    Xd = np.column_stack([_decimate(c, r) for c in X.T])
    yd = _decimate(y, r)
    theta = np.linalg.lstsq(Xd, yd, rcond=None)[0]
    e = yd - Xd @ theta
    std = np.std(e, ddof=1) * np.sqrt(np.diag(np.linalg.inv(Xd.T @ Xd)))
    return {"theta": dict(zip(PARAMS, map(float, theta))), "std": dict(zip(PARAMS, map(float, std))),
            "error_norm": float(np.linalg.norm(e)), "relative_error_percent": float(100 * np.linalg.norm(e) /
                                                                                   np.linalg.norm(yd)),
            "condition": float(np.linalg.cond(Xd)), "decimation": r, "samples": len(yd),
            "force": yd, "force_fit": Xd @ theta}


def control_law_rms(d: dict[str, np.ndarray]) -> float:
    """RMS difference between the recorded controller output and the benchmark's law on the recorded signals."""
    q, qr = d["q_m"], d["qref_m"]
    vel = np.r_[0.0, 0.0, (q[2:] - q[:-2]) / (2 * DT)]
    return float(np.sqrt(np.mean((KP * KV * (qr - q) - KV * vel - d["vir_V"])[10:] ** 2)))


# ------------------------------------------------------------------------------------------ scipy simulations
def _event(f: Callable[[float, np.ndarray], float], direction: float) -> Callable[[float, np.ndarray], float]:
    """``f`` as a terminal event of solve_ivp, crossing in ``direction``."""
    def event(t: float, x: np.ndarray) -> float:
        return f(t, x)

    setattr(event, "terminal", True)  # noqa: B010 - the attributes solve_ivp reads
    setattr(event, "direction", direction)  # noqa: B010
    return event


def _interval(x: np.ndarray, t1: float, slip: Callable[[float, np.ndarray, float], list],
              stick: Callable[[float, np.ndarray], list], net: Callable[[float, np.ndarray], float],
              fc: float) -> np.ndarray:
    """Integrate ``x`` (position, velocity first) over [0, t1] with Coulomb friction as Filippov's solution:
    ``slip(t, x, s)`` while the velocity has the sign s, ``stick(t, x)`` while it is 0 and the net force
    ``net(t, x)`` (all but friction) is within the friction level ``fc``."""
    t = 0.0
    for _ in range(50):
        if t >= t1 * (1 - 1e-12):
            return x
        s = float(np.sign(x[1]))
        if s == 0.0:
            n = net(t, x)
            if abs(n) <= fc:  # stuck: until the net force reaches the friction level
                ev = _event(lambda tt, xx: abs(net(tt, xx)) - fc, 1.0)
                sol = solve_ivp(stick, (t, t1), x, method="RK45", rtol=1e-10, atol=1e-13, events=ev)
                x, t = sol.y[:, -1].copy(), float(sol.t[-1])
                x[1] = 0.0
                if sol.status != 1:
                    return x
                n = net(t, x)
            s = float(np.sign(n))
        ev = _event(lambda tt, xx: xx[1], -s)
        sol = solve_ivp(lambda tt, xx, s=s: slip(tt, xx, s), (t, t1), x, method="RK45", rtol=1e-10, atol=1e-13,
                        events=ev)
        x, t = sol.y[:, -1].copy(), float(sol.t[-1])
        if sol.status == 1:
            x[1] = 0.0
    raise RuntimeError("more than 50 velocity reversals within one sample")


def simulate(p: dict[str, float], d: dict[str, np.ndarray], k0: int, k1: int, x0: tuple[float, float],
             loop: str) -> tuple[np.ndarray, np.ndarray]:
    """Position, velocity and acceleration at samples k0..k1-1 (columns) and the force applied over each
    sample: ``loop`` "closed" (the digital PD controller on qref_m, saturated at VMAX) or "open" (the measured
    force held)."""
    M, Fv, Fc, off = (p[k] for k in PARAMS)
    x = np.array(x0, float)
    hist = [x[0] - DT * x[1], x[0] - 2 * DT * x[1]]  # the controller's memory, q(k-1), q(k-2): consistent with x0
    x_out, u_out = np.empty((k1 - k0, 3)), np.empty(k1 - k0)
    for i, k in enumerate(range(k0, k1)):
        if loop == "closed":
            dq = (0.5 * (x[0] + hist[0]) - 0.5 * (hist[0] + hist[1])) / DT
            u = GTAU * min(VMAX, max(-VMAX, KP * KV * (d["qref_m"][k] - x[0]) - KV * dq))
        else:
            u = d["force_N"][k]
        x_out[i], u_out[i] = (x[0], x[1], (u - Fv * x[1] - Fc * np.sign(x[1]) - off) / M), u
        hist = [x[0], hist[0]]
        slip, stick, net = _held_field(float(u), M, Fv, Fc, off)
        x = _interval(x, DT, slip, stick, net, Fc)
    return x_out, u_out


#: The field of one sample: slipping (with the sign of the velocity), stuck, and the net force but friction.
Field = tuple[Callable[[float, np.ndarray, float], list], Callable[[float, np.ndarray], list],
              Callable[[float, np.ndarray], float]]


def _held_field(u: float, M: float, Fv: float, Fc: float, off: float) -> Field:
    """The plant's field over one sample under the force u held: slipping, stuck, and the net force but friction."""
    return (lambda t, xx, s: [xx[1], (u - Fv * xx[1] - Fc * s - off) / M], lambda t, xx: [0.0, 0.0],
            lambda t, xx: u - off)


def _loop_field(r0: float, r1: float, th: float | None, tv: float | None, M: float, Fv: float, Fc: float,
                off: float) -> Field:
    """The closed-loop model file's field over one sample (reference linear from r0 to r1): slipping, stuck, and
    the net force on the load but friction."""
    ref = lambda t: r0 + (r1 - r0) * t / DT
    if th is None:  # no delay states: the controller as if it were continuous
        drive = lambda t, xx: GTAU * (KP * KV * (ref(t) - xx[0]) - KV * xx[1])
        delays = lambda t, xx: [0.0, 0.0]
    else:
        drive = lambda t, xx: GTAU * (KP * KV * (2 * xx[2] - (ref(t) - xx[0])) - KV * (2 * xx[3] - xx[1]))
        delays = lambda t, xx: [2 * (ref(t) - xx[0] - xx[2]) / th, 2 * (xx[1] - xx[3]) / tv]
    return (lambda t, xx, s: [xx[1], (drive(t, xx) - Fv * xx[1] - Fc * s - off) / M, *delays(t, xx)],
            lambda t, xx: [0.0, 0.0, *delays(t, xx)], lambda t, xx: drive(t, xx) - off)


def simulate_model_file(p: dict[str, float], d: dict[str, np.ndarray], th: float | None = DELAY_HOLD,
                        tv: float | None = DELAY_VELOCITY) -> np.ndarray:
    """The closed-loop model file's equations (Pade delays th, tv; qref linear between samples) over the whole
    record from rest, by scipy: to compare with the digital loop it stands for. ``th = tv = None``: without the
    delay states."""
    M, Fv, Fc, off = (p[k] for k in PARAMS)
    qr = d["qref_m"]
    x = np.array([0.0, 0.0, qr[0], 0.0])
    out = np.empty(len(qr))
    for k in range(len(qr)):
        out[k] = x[0]
        if k + 1 == len(qr):
            break
        slip, stick, net = _loop_field(qr[k], qr[k + 1], th, tv, M, Fv, Fc, off)
        x = _interval(x, DT, slip, stick, net, Fc)
    return out


def initial_state(d: dict[str, np.ndarray], k0: int) -> tuple[float, float]:
    """Position and velocity at sample k0 from a quadratic fitted to the WARMUP measured positions from k0."""
    c = np.polyfit(np.arange(WARMUP) * DT, d["q_m"][k0:k0 + WARMUP], 2)
    return float(c[2]), float(c[1])


def merit(sim: np.ndarray, meas: np.ndarray) -> dict[str, float]:
    """RMSE, NRMSE (over the measurement's deviation from its mean), fit % (MATLAB's compare), dB."""
    e, y = sim[WARMUP:] - meas[WARMUP:], meas[WARMUP:]
    rmse, dev = float(np.sqrt(np.mean(e ** 2))), float(np.sqrt(np.mean((y - y.mean()) ** 2)))
    return {"rmse": rmse, "nrmse": rmse / dev, "fit_percent": 100 * (1 - rmse / dev),
            "db": 20 * math.log10(rmse / float(np.sqrt(np.mean(y ** 2))))}


# ------------------------------------------------------------------------------------------------- obsnl runs
def identify(name: str, d: dict[str, np.ndarray], k1: int, folder: Path, force: bool, *,
             synthetic: np.ndarray | None = None, tag: str | None = None) -> dict:
    """One obsnl identification of the first k1 samples with the model of RUNS[name], as a user would call it:
    what it said, and its time. ``synthetic``: positions to identify from instead of the measured ones."""
    file, _, kind, what = RUNS[name]
    model_input = "qref_m" if name == "closed" else "force_N"
    q = d["q_m"][:k1] if synthetic is None else synthetic
    data = measured({"time_s": d["time_s"][:k1], model_input: d[model_input][:k1], "q_m": q},
                    inputs=[model_input], outputs=["q_m"], source=DATA.name,
                    name=f"emps_train samples 0-{k1 - 1}" + ("" if synthetic is None else ", q_m simulated"))
    options: dict[str, Any] = {"intersample": {model_input: kind}}
    if name in OBJECTIVE:
        options["objective"] = OBJECTIVE[name]
    name = tag or name
    entry = {"run": name, "what": what, "model": file, "samples": k1, "options": options}
    tic = time.perf_counter()
    try:
        res = obsnl.identify(folder / file, data, progress=False, **options)
    except obsnl.ObsnlError as exc:  # a refusal is a result: reported as obsnl said it
        entry.update(wall_seconds=time.perf_counter() - tic, refused=f"{type(exc).__name__}: {exc}")
    except Exception as exc:  # noqa: BLE001 - a crash is a bug of obsnl: recorded as one, the other run goes on
        entry.update(wall_seconds=time.perf_counter() - tic, crashed=f"{type(exc).__name__}: {exc}",
                     where=traceback.format_exc(limit=-3).strip().splitlines())
    else:
        entry["wall_seconds"] = time.perf_counter() - tic
        sub = folder / f"identify_{name}"
        write_identification(res, sub, force=force)
        entry.update(identify=res.to_dict(), folder=sub.name, summary=res.summary())
    print(f"{name}: {entry['wall_seconds']:.1f} s {entry.get('refused') or entry.get('crashed') or ''}",
          file=sys.stderr)
    return entry


def obsnl_validate(folder: Path, d: dict[str, np.ndarray], k0: int, sets: dict[str, dict[str, float]]) -> dict:
    """obsnl's own simulator on the test record (``obsnl.simulate``, the initial state estimated on the WARMUP
    first samples with the parameters fixed): each model file with each parameter set, RMSE of q_m."""
    out: dict[str, dict[str, float | str]] = {}
    for name, (file, _, kind, _) in RUNS.items():
        if name in OBJECTIVE:  # the same model file as another run
            continue
        model_input = "qref_m" if name == "closed" else "force_N"
        record = measured({"time_s": d["time_s"][k0:], model_input: d[model_input][k0:], "q_m": d["q_m"][k0:]},
                          inputs=[model_input], outputs=["q_m"], name=f"emps_train samples {k0}-", source=DATA.name)
        out[name] = {}
        for who, p in sets.items():
            try:
                v = obsnl.simulate(folder / file, p, record, intersample={model_input: kind}, warmup=WARMUP)
                out[name][who] = float(v.outputs["q_m"].rmse)
            except Exception as exc:  # noqa: BLE001 - recorded as obsnl said it
                out[name][who] = f"{type(exc).__name__}: {exc}"
    return out


def estimates(entry: dict) -> dict[str, float] | None:
    doc = entry.get("identify")
    if not doc:
        return None
    est = {p["name"]: p["estimate"] for p in doc["parameters"]}
    return None if any(est.get(k) is None for k in PARAMS) else {k: float(est[k]) for k in PARAMS}


# --------------------------------------------------------------------------------------------------- figures
def figure_idim(idim: dict, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(9, 3.6))
    t = np.arange(len(idim["force"])) * DT * idim["decimation"]
    ax.plot(t, idim["force"], lw=1.2, label="measured force (decimated)")
    ax.plot(t, idim["force_fit"], "--", lw=1, label="IDIM-LS reconstruction")
    ax.plot(t, idim["force"] - idim["force_fit"], lw=0.8, label="difference")
    ax.set(xlabel="time from the record's sample 50 (s)", ylabel="force (N)",
           title="IDIM-LS recomputed on the whole record (as published)")
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def figure_test(d: dict[str, np.ndarray], k0: int, sims: dict[str, np.ndarray], loop: str, path: Path) -> None:
    """Overlay (tracking error in closed loop, position in open loop), a zoomed window, the error and its spectrum."""
    meas = d["q_m"][k0:]
    t = d["time_s"][k0:] - d["time_s"][k0]
    shown = (lambda q: q - d["qref_m"][k0:]) if loop == "closed" else (lambda q: q)
    label = "q - qref (m)" if loop == "closed" else "q (m)"
    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    a0, a1, a2, a3 = axes.ravel()
    a0.plot(t, shown(meas), "k", lw=1.2, label="measured")
    for name, q in sims.items():
        a0.plot(t, shown(q), lw=0.9, label=name)
    err = {name: q - meas for name, q in sims.items()}
    worst = int(np.argmax(np.abs(next(iter(err.values()))))) if loop == "closed" else len(t) // 2
    lo, hi = max(0, worst - 150), min(len(t), worst + 150)
    a1.plot(t[lo:hi], shown(meas)[lo:hi], "k.-", lw=1, ms=3, label="measured")
    for name, q in sims.items():
        a1.plot(t[lo:hi], shown(q)[lo:hi], lw=1, label=name)
    for name, e in err.items():
        a2.plot(t, e, lw=0.8, label=name)
        f, pxx = signal.welch(e[WARMUP:], fs=1 / DT, nperseg=1024)
        a3.loglog(f[1:], np.sqrt(pxx[1:]), lw=0.9, label=name)
    a0.axvspan(0, WARMUP * DT, color="0.85")
    a0.set(xlabel="time in the test record (s)", ylabel=label, title=f"{loop} loop on the held-out period")
    a1.set(xlabel="time (s)", ylabel=label, title="zoom")
    a2.set(xlabel="time (s)", ylabel="simulated - measured q (m)", title="error")
    a3.set(xlabel="frequency (Hz)", ylabel="error ASD (m/sqrt(Hz))", title="error spectrum (Welch)")
    for a in axes.ravel():
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ----------------------------------------------------------------------------------------------------- report
def _f(x: float | None, digits: int = 4) -> str:
    return "-" if x is None else f"{x:.{digits}g}"


def _interval_text(p: dict) -> str:
    iv = p.get("interval")
    if not iv:
        return "-"
    return "[" + ", ".join("open" if v is None else f"{v:.5g}" for v in iv) + "]"


def readme(res: dict) -> str:
    idim, runs, tests = res["idim_ls"], res["runs"], res["test"]
    lines = [
        "# EMPS benchmark: obsnl against the published IDIM-LS values", "",
        ("Written by `python benchmarks/bench_emps.py` (the numbers below are measured by that run; "
        f"obsnl as committed at {res['commit']}" + (f", except {res['differ']} files of it" if res["differ"] else "")
        + "). "
        "Data: the benchmark's training record, `benchmarks/data/emps/` (its provenance there): A. Janot, "
        "M. Gautier, M. Brunot, *Data Set and Reference Models of EMPS*, Workshop on Nonlinear System "
        "Identification Benchmarks, 2019."), "",
        "## Record and split", "",
        (f"24 841 samples at 1 kHz, the recorded clock as it is (largest deviation from k * 1 ms: "
        f"{res['clock_deviation']:.2g} s). The record is four periods of one bang-bang trajectory. Identified: "
        f"samples 0 to {res['split'] - 1} (the first three periods, up to where the reference last returns to 0; "
        f"{100 * res['split'] / res['samples']:.1f} %). Test: samples {res['split']} to {res['samples'] - 1}, "
        f"the fourth period ({res['samples'] - res['split']} samples, "
        f"{100 * (1 - res['split'] / res['samples']):.1f} %), held out. Each simulation of the test record starts "
        f"from the state estimated on its first {WARMUP} samples (a quadratic through the measured positions), "
        f"which are not scored."), "",
        "## IDIM-LS recomputed (a check of the data)", "",
        ("The authors' Script_IDIM_LS.m in numpy/scipy (Butterworth order 4 at 100 Hz forwards and backwards, "
        "central differences, 49 edge samples dropped, decimation by 10 with a Chebyshev filter, least squares), "
        "on the whole record as published:"), "",
        "| parameter | published | std | recomputed | std |", "|---|---:|---:|---:|---:|"]
    for k in PARAMS:
        lines.append(f"| {k} ({UNITS[k]}) | {PUBLISHED[k][0]} | {PUBLISHED[k][1]} | {idim['theta'][k]:.4f} | "
                     f"{idim['std'][k]:.4f} |")
    lines += ["", (f"Error norm {idim['error_norm']:.4f} (published 108.7569), relative error "
              f"{idim['relative_error_percent']:.4f} % (4.0834), condition number {idim['condition']:.4f} (25.9883). "
              f"The benchmark's control law applied to the recorded signals gives the recorded controller output "
              f"to {res['control_law_rms']:.2g} V RMS. Figure: `idim_ls.png`."), "",
              "## The models", "",
              ("- `emps_closed_loop.toml`: input `qref_m`, output `q_m`; the PD controller is written into the "
              "model, and its sampling as two first-order Pade delay states (the hold, dt/2 on the position error; "
              "the hold and the two-sample velocity difference, 3 dt/2 on the velocity). Over the whole record "
              f"from rest at the IDIM-LS values, this model (scipy) differs from the digital loop it stands for "
              f"(scipy) by {res['pade_check']['with_delays']:.2g} m RMS; without the delay states "
              f"(th, tv -> 0) by {res['pade_check']['without_delays']:.2g} m (the encoder's step is 5e-8 m). "
              "The 10 V saturation is left out of the file: the record's controller output stays within "
              f"{res['max_vir']:.3g} V."),
              "- `emps_open_loop.toml`: input `force_N`, output `q_m`; the rigid plant alone, a pure integrator.", "",
              (f"Guesses for both: {', '.join(f'{k} {v:g}' for k, v in GUESS.items())} (15-37 % from IDIM-LS). "
               "obsnl's defaults otherwise (3 UKF passes tuned by the output misfit, then maximum likelihood, "
               "profile-likelihood intervals). Each file's `[intersample]` table says how its input behaves between "
               "samples. One run, in Python:"), "",
              "```python",
              "import numpy as np, obsnl",
              "d = np.genfromtxt('benchmarks/data/emps/emps_train.csv', delimiter=',', names=True)",
              f"train = {{c: d[c][:{res['split']}] for c in ('time_s', 'qref_m', 'q_m')}}  # the recorded clock",
              "fit = obsnl.identify('reports/benchmarks/emps/emps_closed_loop.toml', train)",
              "```", ""]
    lines += ["## Estimates", "",
              ("IDIM-LS is the published reference, not the truth: it fits the same rigid model to the same record by "
               "another criterion (the force error of filtered derivatives, where obsnl fits the position). "
               "Difference in per cent of the published IDIM-LS value, and in units of its published std."), ""]
    head = "| parameter | IDIM-LS (published) |"
    rule = "|---|---:|"
    for name, r in runs.items():
        head += f" obsnl {LABEL[name]}: estimate (std) | 95 % interval | vs IDIM-LS |"
        rule += "---:|---|---:|"
    lines += [head, rule]
    for k in PARAMS:
        row = f"| {k} ({UNITS[k]}) | {PUBLISHED[k][0]} +- {PUBLISHED[k][1]} |"
        for name, r in runs.items():
            p = next((p for p in (r.get("identify") or {}).get("parameters", []) if p["name"] == k), None)
            if p is None or p.get("estimate") is None:
                row += " - | - | - |"
                continue
            dev = p["estimate"] - PUBLISHED[k][0]
            row += (f" {p['estimate']:.5g} ({_f(p['std'], 2)}) | {_interval_text(p)}"
                    f"{' flagged' if p.get('flagged') else ''} | {100 * dev / abs(PUBLISHED[k][0]):+.2f} %, "
                    f"{dev / PUBLISHED[k][1]:+.1f} std |")
        lines.append(row)
    lines.append("")
    for name, r in runs.items():
        lines.append(f"**{LABEL[name]}** ({r['what']}; obsnl.identify options {r['options']}):")
        lines.append("")
        if "refused" in r or "crashed" in r:
            lines += [(f"obsnl {'refused the run' if 'refused' in r else 'crashed (a bug)'} after "
                      f"{r['wall_seconds']:.1f} s: `{r.get('refused') or r.get('crashed')}`"), ""]
            continue
        doc = r["identify"]
        ref = doc.get("refinement") or {}
        lines.append(f"- converged: {doc.get('converged')} ({doc.get('converged_reason')})")
        lines.append(f"- `refinement.noise_std` (the residuals' RMS over their degrees of freedom, floored at 1e-5 of "
                     f"the channel's RMS) {_f((ref.get('noise_std') or {}).get('q_m'), 3)} m; `refinement.misfit_over_"
                     f"noise` {_f((ref.get('misfit_over_noise') or {}).get('q_m'), 3)} (over the noise level the "
                     f"fit was given: {(doc.get('noise') or {}).get('q_m', {}).get('source', '-')})")
        ad = doc.get("adequacy")
        if ad is None:
            lines.append("- adequacy: not reported (obsnl at this commit has no residual tests)")
        else:
            lines.append(f"- adequacy at the {ad.get('level')} level: {'passed' if ad.get('passed') else 'FAILED'}; "
                         "share of the residual variance attributed to model error: "
                         + ", ".join(f"{k} {v:.5f}" for k, v in (ad.get("model_error_share") or {}).items()))
            for test in ad.get("tests", []):
                lines.append(f"  - {test['name']} ({test['output']}): statistic {test['statistic']:.4g}, p-value "
                             f"{test['p_value']:.3g}, {'passed' if test['passed'] else 'failed'}; {test['detail']}")
        lines.append(f"- flagged: {', '.join(doc.get('flagged') or []) or 'none'}; wall time "
                     f"{r['wall_seconds']:.1f} s (obsnl's own count {doc.get('seconds', float('nan')):.1f} s); "
                     f"`{r['folder']}/` holds identify.json and obsnl's figures")
        lines += ["", "obsnl's summary:", "", "```", r["summary"].rstrip("\n"), "```", ""]
    syn = res.get("synthetic")
    if syn:
        lines += ["## The closed-loop model file against the digital loop it stands for", "",
                  ("The same run of `emps_closed_loop.toml` on a record whose truth is known: the digital loop's "
                   "response (scipy, the benchmark's controller, saturation and FIR velocity) to the same reference "
                   "over the same samples at the IDIM-LS values, from the first measured position at rest, the "
                   f"position rounded to the encoder's step ({ENCODER:g} m)."), ""]
        if "identify" not in syn:
            lines += [f"obsnl did not run it: `{syn.get('refused') or syn.get('crashed')}`", ""]
        else:
            doc = syn["identify"]
            lines += ["| parameter | truth (IDIM-LS) | estimate (std) | 95 % interval | error |",
                      "|---|---:|---:|---|---:|"]
            for p in doc["parameters"]:
                truth = PUBLISHED[p["name"]][0]
                lines.append(f"| {p['name']} | {truth} | {p['estimate']:.5g} ({_f(p['std'], 2)}) | "
                             f"{_interval_text(p)} | {100 * (p['estimate'] - truth) / abs(truth):+.3f} % |")
            ad = doc.get("adequacy") or {}
            tests_said = "; ".join(f"{t['name']} {'passed' if t['passed'] else 'failed'}" for t in ad.get("tests", []))
            lines += ["", (f"Converged: {doc.get('converged')}; adequacy "
                           f"{'passed' if ad.get('passed') else 'FAILED' if ad else 'not reported'} ({tests_said}); "
                           f"NRMSE {_f(doc['fit'].get('q_m'), 3)} %; wall time {syn['wall_seconds']:.1f} s; "
                           f"`{syn['folder']}/`. The errors are what writing the digital loop as this continuous model "
                           f"costs on these data."), ""]
    lines += ["## Test record (the held-out fourth period)", "",
              ("Each parameter set simulated the same way by scipy (the digital loop with the benchmark's "
              "controller, or the measured force held over each sample), from the same initial state. Ratio: "
              "RMSE over that of the IDIM-LS values simulated the same way."), "",
              "| simulation | parameters | RMSE (m) | NRMSE | fit % | dB | ratio to IDIM-LS |",
              "|---|---|---:|---:|---:|---:|---:|"]
    for loop in ("closed", "open"):
        base = tests[loop]["IDIM-LS"]["rmse"]
        for who, m in tests[loop].items():
            lines.append(f"| {loop} loop | {who} | {m['rmse']:.4g} | {m['nrmse']:.3g} | {m['fit_percent']:.3f} | "
                         f"{m['db']:.1f} | {m['rmse'] / base:.3f} |")
    if res["obsnl_simulate"]:
        who = list(next(iter(res["obsnl_simulate"].values())))
        lines += ["", (f"obsnl's own simulator on the same test record (`obsnl.simulate` of each model file, the "
                       f"initial state estimated on the first {WARMUP} samples with the parameters fixed; RMSE of q_m "
                       f"in m; the closed-loop file is the Pade-delay model, not the digital loop):"), "",
                  "| model file | " + " | ".join(who) + " |", "|---|" + "---:|" * len(who)]
        for name, row in res["obsnl_simulate"].items():
            cells = [f"{row[w]:.4g}" if isinstance(row[w], float) else f"failed: {row[w]}" for w in who]
            lines.append(f"| {RUNS[name][0]} | " + " | ".join(cells) + " |")
    lines += ["", "Published beside it (other test records, so not comparable number for number): dynoNet "
              "(Forgione and Piga 2021), open-loop simulation of the benchmark's own test record, RMS error 2.64e-3 m, "
              "fit 96.8 %. The authors' reference simulation of the training record at the IDIM-LS values "
              "(Simulink) reports relative errors position 0.013752 %, velocity 0.22911 %, acceleration 8.6036 %, "
              "force 5.848 %; the scipy digital loop here gives "
              + ", ".join(f"{k} {v:.4g} %" for k, v in res["reference_simulation"].items())
              + " on the same record and in the same measure (the Simulink file is not distributed with the data; "
              "its exact blocks are not known here). Figures: `test_closed_loop.png` (the tracking error "
              "q - qref, where the information is), `test_open_loop.png`.", "",
              "## Goals (issue 40)", ""]
    for g in res["goals"]:
        lines.append(f"- {g['goal']}: **{'met' if g['met'] else 'NOT met'}** ({g['measured']})")
    lines += ["", f"Machine: {res['machine']}.", ""]
    return "\n".join(lines)


def goals(runs: dict, tests: dict) -> list[dict]:
    out = []
    for name, r in runs.items():
        est = estimates(r)
        if est is None:
            out.append({"goal": f"{LABEL[name]}: obsnl gives estimates", "met": False,
                        "measured": r.get("refused", "no estimates")})
            continue
        dev = {k: 100 * (est[k] - PUBLISHED[k][0]) / abs(PUBLISHED[k][0]) for k in ("M", "Fv", "Fc")}
        out.append({"goal": f"{LABEL[name]}: M, Fv, Fc within {GOAL_PERCENT:g} % of IDIM-LS",
                    "met": all(abs(v) <= GOAL_PERCENT for v in dev.values()),
                    "measured": ", ".join(f"{k} {v:+.2f} %" for k, v in dev.items())})
        ratio = tests["open"][f"obsnl {LABEL[name]}"]["rmse"] / tests["open"]["IDIM-LS"]["rmse"]
        out.append({"goal": f"{LABEL[name]}: open-loop test RMSE within {GOAL_RMSE_RATIO:g}x that of IDIM-LS",
                    "met": ratio <= GOAL_RMSE_RATIO, "measured": f"ratio {ratio:.3f}"})
        out.append({"goal": f"{LABEL[name]}: the run under {GOAL_SECONDS:g} s", "met": r["wall_seconds"] < GOAL_SECONDS,
                    "measured": f"{r['wall_seconds']:.1f} s wall"})
    return out


def _commit() -> tuple[str, int]:
    """The newest of the last 50 commits whose obsnl/ is the imported obsnl package file for file, and 0; else
    HEAD's short hash and how many files differ from it (-1: unknown)."""
    import subprocess

    run = lambda *a, **k: subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True, check=True, **k)
    try:
        package = Path(obsnl.__file__).resolve().parent
        here = sorted(str(f.relative_to(package.parent)) for f in package.rglob("*") if f.is_file()
                      and "__pycache__" not in f.parts)
        hashes = dict(zip(here, run("hash-object", "--stdin-paths",
                                    input="\n".join(str(package.parent / f) for f in here)).stdout.split()))
        best = None
        for commit in run("rev-list", "-n", "50", "HEAD").stdout.split():
            committed = dict(line.split(" ", 2)[2].split("\t")[::-1] for line in
                             run("ls-tree", "-r", commit, "obsnl").stdout.splitlines())
            differ = sum(committed.get(f) != h for f, h in hashes.items()) + len(set(committed) - set(hashes))
            best = best or (commit[:7], differ)
            if differ == 0:
                return commit[:7], 0
    except (OSError, subprocess.CalledProcessError):
        return "unknown", -1
    return best or ("unknown", -1)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(OUT))
    ap.add_argument("--force", action="store_true", help="replace the files of an earlier run")
    ap.add_argument("--only", choices=sorted(RUNS), help="identify with one model only")
    args = ap.parse_args(argv)
    out = Path(args.out)
    chosen = [args.only] if args.only else list(RUNS)
    check_folder(out, FILES, force=args.force)
    load0 = os.getloadavg()
    d = read_data()
    n, split = len(d["q_m"]), test_start(d)
    idim = idim_ls(d)
    with OutputFolder(out, list(dict.fromkeys(RUNS[k][0] for k in RUNS)), force=args.force) as folder:
        for file, text in dict((f, t) for f, t, _, _ in RUNS.values()).items():
            folder.write_text(file, text)
        folder.commit()
    runs = {name: identify(name, d, split, out, args.force) for name in chosen}
    # the closed-loop model file against the loop it stands for: its fit to the digital loop's response to the
    # same reference at the IDIM-LS values (scipy, from the first measured position at rest, the position rounded
    # to the encoder's 5e-8 m), whose truth is known
    x_syn = simulate({k: PUBLISHED[k][0] for k in PARAMS}, d, 0, split, (float(d["q_m"][0]), 0.0), "closed")[0]
    synthetic = identify("closed", d, split, out, args.force, synthetic=np.round(x_syn[:, 0] / ENCODER) * ENCODER,
                         tag="synthetic") if "closed" in chosen else None

    tic = time.perf_counter()
    x0 = initial_state(d, split)
    sets = {"IDIM-LS": {k: PUBLISHED[k][0] for k in PARAMS}}
    sets.update({f"obsnl {LABEL[name]}": est for name, r in runs.items() if (est := estimates(r)) is not None})
    tests, sims = {}, {}
    for loop in ("closed", "open"):
        sims[loop] = {who: simulate(p, d, split, n, x0, loop)[0][:, 0] for who, p in sets.items()}
        tests[loop] = {who: merit(q, d["q_m"][split:]) for who, q in sims[loop].items()}
    # the authors' check of their reference simulation (Simulation_EMPS.m), in their measure: the simulated
    # position, velocity, acceleration and force against the filtered measurement and its central differences
    x_ref, u_ref = simulate(sets["IDIM-LS"], d, 0, n, (0.0, 0.0), "closed")
    q_ref = x_ref[:, 0]
    b, a = signal.butter(4, 0.2)
    qf = _filtfilt(b, a, d["q_m"])
    dq = _diffcent(qf, DT)
    rel = lambda m, s: float(100 * np.linalg.norm((m - s)[49:]) / np.linalg.norm(m[49:]))
    reference = {"position": rel(qf, q_ref), "velocity": rel(dq, x_ref[:, 1]),
                 "acceleration": rel(_diffcent(dq, DT), x_ref[:, 2]), "force": rel(d["force_N"], u_ref)}
    rms = lambda e: float(np.sqrt(np.mean(e ** 2)))
    q_file = simulate_model_file(sets["IDIM-LS"], d)
    q_nodelay = simulate_model_file(sets["IDIM-LS"], d, th=None, tv=None)
    pade = {"with_delays": rms(q_file - q_ref), "without_delays": rms(q_nodelay - q_ref)}
    sim_seconds = time.perf_counter() - tic
    tic = time.perf_counter()
    validate = obsnl_validate(out, d, split, sets) if hasattr(obsnl, "simulate") else {}
    validate_seconds = time.perf_counter() - tic

    commit, differ = _commit()
    res: dict[str, Any] = {"commit": commit, "differ": differ, "samples": n, "split": split, "warmup": WARMUP,
           "clock_deviation": float(np.max(np.abs(d["time_s"] - np.arange(n) * DT))),
           "control_law_rms": control_law_rms(d), "max_vir": float(np.max(np.abs(d["vir_V"]))),
           "idim_ls": {k: v for k, v in idim.items() if k not in ("force", "force_fit")},
           "published": {k: {"value": v, "std": s} for k, (v, s) in PUBLISHED.items()},
           "guess": GUESS, "runs": runs, "synthetic": synthetic, "test": tests, "reference_simulation": reference,
           "pade_check": pade,
           "scipy_seconds": sim_seconds, "obsnl_simulate": validate, "obsnl_simulate_seconds": validate_seconds,
           "machine": f"{os.cpu_count()} cores, load average {load0[0]:.1f} at the start and "
                      f"{os.getloadavg()[0]:.1f} at the end, Python {platform.python_version()}"}
    res["goals"] = goals(runs, tests)
    with OutputFolder(out, ["README.md", "results.json", "test_closed_loop.png", "test_open_loop.png",
                            "idim_ls.png"], force=args.force) as folder:
        figure_idim(idim, folder.path("idim_ls.png"))
        for loop in ("closed", "open"):
            figure_test(d, split, sims[loop], loop, folder.path(f"test_{loop}_loop.png"))
        folder.write_text("results.json", json.dumps(res, indent=1, allow_nan=False) + "\n")
        folder.write_text("README.md", readme(res))
        folder.commit()
    print(readme(res))
    return 0 if all(g["met"] for g in res["goals"]) else 1


if __name__ == "__main__":
    sys.exit(main())
