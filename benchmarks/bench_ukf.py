"""One UKF run over the 20 s Northridge record, three implementations of the same filter, same run.

* obsnl: the compiled casadi step (`mapaccum` over the record), with and without JIT;
* numpy: the same filter written with plain vectorised numpy (all sigma points as one matrix, the
  model by sympy `lambdify`, RK4 with the same substeps and the same refinement of a substep in
  which a switching function across which the vector field jumps changes sign, the same redraw
  before the update);
* filterpy: `UnscentedKalmanFilter` with `MerweScaledSigmaPoints` (same alpha, beta, kappa), the
  model as scalar Python functions (`math`) called once per sigma point.

Same model (damage-healing oscillator, log parameter coordinates, scaled states), same data (noise
seed 0), same Q, R, P0 (the tuned one-pass configuration), same initial guess. The final estimates
are compared to check that the three really are one filter. Times exclude compilation and are the
best of a few repeats (the machine is shared); ratios matter more than seconds.

Run: python benchmarks/bench_ukf.py [--repeats 3] [--out reports/benchmarks/ukf.md]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

import obsnl
from obsnl.estimation.codegen import numpy_model
from obsnl.identification.experiments import Tuning, _noise, make_data, make_filter
from obsnl.studies.seed_experiment import seed_model_path, seed_setup

TUNING = Tuning(0.1, 0.0, 1.0)


def _setting(samples: int | None):
    setup = seed_setup(samples=samples)
    data = make_data(setup, 0)
    filt = make_filter(setup, "ukf")
    Q, R = _noise(setup, filt, data, TUNING)
    nx = setup.model.nx
    P0 = np.diag(np.r_[np.full(nx, 1e-8), np.full(filt.size - nx, TUNING.s0 ** 2)])
    z0 = filt.to_z(setup.x0, setup.theta_guess)
    return setup, data, filt.with_options(Q=Q, R=R), P0, z0


def _sigma(z, P, alpha, beta, kappa):
    L = len(z)
    lam = alpha ** 2 * (L + kappa) - L
    S = np.linalg.cholesky(P)
    g = np.sqrt(L + lam)
    X = np.hstack([z[:, None], z[:, None] + g * S, z[:, None] - g * S])
    w = np.full(2 * L, 1 / (2 * (L + lam)))
    Wm = np.r_[lam / (L + lam), w]
    Wc = np.r_[lam / (L + lam) + 1 - alpha ** 2 + beta, w]
    return X, Wm, Wc


def numpy_ukf(setup, data, filt, P0, z0):
    """The same filter as obsnl's UKF, vectorised over sigma points with numpy."""
    fns = numpy_model(obsnl.read_model(seed_model_path()))
    f, gfun, nx, dt, n, r = fns["f"], fns["g"], setup.model.nx, setup.record.dt, filt.substeps, filt.refine
    scale = filt.state_scale
    signs = np.sign(setup.theta_guess)[:, None]
    z, P = z0.copy(), P0.copy()
    Q, R = filt.Q, filt.R
    u, y = data.u, data.y
    out = [z]

    def rhs(x, th, uu):
        return np.array(np.broadcast_arrays(*f(list(x), list(th), [uu])), float)

    watch = [i for i, j in enumerate(setup.model.jumps) if j]  # switching functions where f can jump

    def g(x, th, uu):
        return np.array(np.broadcast_arrays(*gfun(list(x), list(th), [uu])), float)[watch]

    def rk4(x, th, ua, ub, h):
        um = 0.5 * (ua + ub)
        k1 = rhs(x, th, ua)
        k2 = rhs(x + 0.5 * h * k1, th, um)
        k3 = rhs(x + 0.5 * h * k2, th, um)
        k4 = rhs(x + h * k3, th, ub)
        return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    for k in range(len(u) - 1):
        X, Wm, Wc = _sigma(z, P, filt.alpha, filt.beta, filt.kappa)
        x, th = X[:nx] * scale[:, None], signs * np.exp(X[nx:])
        h = dt / n
        for i in range(n):
            ua = u[k] + (u[k + 1] - u[k]) * i / n
            ub = u[k] + (u[k + 1] - u[k]) * (i + 1) / n
            xb = rk4(x, th, ua, ub, h)
            crossed = np.any(g(x, th, ua) * g(xb, th, ub) < 0, axis=0)  # a switching inside: refine
            if crossed.any():
                xf, thf = x[:, crossed], th[:, crossed]
                for j in range(r):
                    va, vb = ua + (ub - ua) * j / r, ua + (ub - ua) * (j + 1) / r
                    xf = rk4(xf, thf, va, vb, h / r)
                xb[:, crossed] = xf
            x = xb
        Xp = np.vstack([x / scale[:, None], X[nx:]])
        m = Xp @ Wm
        D = Xp - m[:, None]
        Pp = (D * Wc) @ D.T + Q
        X2, _, _ = _sigma(m, Pp, filt.alpha, filt.beta, filt.kappa)
        Y = X2[:1] * scale[0]
        yh = Y @ Wm
        dY = Y - yh[:, None]
        Pyy = (dY * Wc) @ dY.T + R
        Pzy = ((X2 - m[:, None]) * Wc) @ dY.T
        K = np.linalg.solve(Pyy, Pzy.T).T
        z = m + K @ (y[k + 1] - yh)
        P = Pp - K @ Pyy @ K.T
        P = 0.5 * (P + P.T)
        out.append(z)
    return np.array(out)


def filterpy_ukf(setup, data, filt, P0, z0):
    """filterpy's UKF with a scalar-Python model called per sigma point."""
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    fns = numpy_model(obsnl.read_model(seed_model_path()), scalar=True)
    f, gfun = fns["f"], fns["g"]
    watch = [i for i, j in enumerate(setup.model.jumps) if j]  # switching functions where f can jump

    def g(x, th, uu):
        vals = gfun(x, th, uu)
        return [vals[i] for i in watch]
    nx, dt, n, r, scale = setup.model.nx, setup.record.dt, filt.substeps, filt.refine, filt.state_scale
    signs = np.sign(setup.theta_guess)

    def rk4(x, th, ua, ub, h):
        um = 0.5 * (ua + ub)
        k1 = f(x, th, [ua])
        k2 = f([a + 0.5 * h * b for a, b in zip(x, k1)], th, [um])
        k3 = f([a + 0.5 * h * b for a, b in zip(x, k2)], th, [um])
        k4 = f([a + h * b for a, b in zip(x, k3)], th, [ub])
        return [a + h / 6 * (b + 2 * c + 2 * d + e) for a, b, c, d, e in zip(x, k1, k2, k3, k4)]

    def fx(z, dt_, u0=0.0, u1=0.0):
        x = list(z[:nx] * scale)
        th = list(signs * np.exp(z[nx:]))
        h = dt_ / n
        for i in range(n):
            ua = u0 + (u1 - u0) * i / n
            ub = u0 + (u1 - u0) * (i + 1) / n
            xb = rk4(x, th, ua, ub, h)
            if any(a * b < 0 for a, b in zip(g(x, th, [ua]), g(xb, th, [ub]))):  # a switching inside: refine
                for j in range(r):
                    x = rk4(x, th, ua + (ub - ua) * j / r, ua + (ub - ua) * (j + 1) / r, h / r)
            else:
                x = xb
        return np.r_[np.array(x, float) / scale, z[nx:]]

    pts = MerweScaledSigmaPoints(len(z0), alpha=filt.alpha, beta=filt.beta, kappa=filt.kappa)
    ukf = UnscentedKalmanFilter(dim_x=len(z0), dim_z=1, dt=dt, fx=fx, hx=lambda z: z[:1] * scale[0], points=pts)
    ukf.x, ukf.P, ukf.Q, ukf.R = z0.copy(), P0.copy(), filt.Q.copy(), filt.R.copy()
    out = [z0]
    for k in range(len(data.u) - 1):
        ukf.predict(u0=data.u[k], u1=data.u[k + 1])
        ukf.update(data.y[k + 1])
        out.append(ukf.x.copy())
    return np.array(out)


def _best(fn, repeats):
    times, res = [], None
    for _ in range(repeats):
        tic = time.perf_counter()
        res = fn()
        times.append(time.perf_counter() - tic)
    return min(times), res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--samples", type=int, default=None, help="shorter record (quick check)")
    ap.add_argument("--skip-filterpy", action="store_true")
    ap.add_argument("--out", default="reports/benchmarks/ukf.md")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    setup, data, filt, P0, z0 = _settings = _setting(args.samples)
    rows, finals = [], {}
    for label, jit in (("obsnl casadi, JIT", True), ("obsnl casadi, no JIT", False)):
        f = filt.with_options(jit=jit)
        tic = time.perf_counter()
        f._compiled()
        build = time.perf_counter() - tic
        est0 = f.initial(x0=setup.x0, theta0=setup.theta_guess, P0=P0)
        secs = []
        for _ in range(args.repeats):
            tr = f.run(est0, data.y, data.u)
            secs.append(tr.seconds)
        rows.append((label, min(secs), build))
        finals[label] = tr.z[-1]
        implicit, refined, counts = int(tr.implicit.sum()), int(tr.refined.sum()), tr.counts()
    t_np, z_np = _best(lambda: numpy_ukf(*_settings), args.repeats)
    rows.append(("numpy, vectorised sigma points", t_np, 0.0))
    finals["numpy"] = z_np[-1]
    if not args.skip_filterpy:
        t_fp, z_fp = _best(lambda: filterpy_ukf(*_settings), 1)
        rows.append(("filterpy, scalar-Python model", t_fp, 0.0))
        finals["filterpy"] = z_fp[-1]
    ref = finals["obsnl casadi, JIT"]
    T = len(data.u)
    lines = ["# UKF benchmark: one filter run over the record", "",
             f"{setup.model.name}, {setup.record.name}, {T} samples ({(T - 1) * setup.record.dt:.2f} s), "
             f"L = {filt.size} (5 states + 9 log-parameters), {2 * filt.size + 1} sigma points, RK4 with "
             f"{filt.substeps} substeps per sample and a substep in which a switching function across which the "
             f"vector field jumps ({', '.join(sw for sw, j in zip(setup.model.switching, setup.model.jumps) if j)}) "
             f"changes sign redone "
             f"with {filt.refine} finer ones, in every implementation ({refined} of {(T - 1) * (2 * filt.size + 1)} "
             f"sigma-point steps were refined in this run). {implicit} sigma-point steps needed the implicit fallback and the robust step "
             f"made no intervention ({sum(counts.values())} counted), so all compute the same numbers. "
             f"Everything on one thread. Noise seed 0, one pass, tuning s0={TUNING.s0}, q_theta={TUNING.q_theta}, q_x={TUNING.q_x}, no gate.", "",
             f"Machine: {platform.machine()}, {platform.python_version()}, shared 2 cores (absolute times +-2x); "
             f"load average (1 min) {load0:.2f} at the start, {os.getloadavg()[0]:.2f} at the end (other jobs of "
             f"the machine: ratios matter more than seconds); best of {args.repeats} repeats, filterpy once. "
             f"Generated by `python benchmarks/bench_ukf.py`.", "",
             "| implementation | s per run | compile s | speed-up of obsnl (JIT) | max abs diff of the final mean vs obsnl |",
             "|---|---|---|---|---|"]
    key = {"obsnl casadi, JIT": "obsnl casadi, JIT", "obsnl casadi, no JIT": "obsnl casadi, no JIT",
           "numpy, vectorised sigma points": "numpy", "filterpy, scalar-Python model": "filterpy"}
    for label, t, build in rows:
        diff = float(np.max(np.abs(finals[key[label]] - ref)))
        lines.append(f"| {label} | {t:.3f} | {build:.1f} | {t / rows[0][1]:.1f}x | {diff:.1e} |")
    lines += ["", "Targets (issue 7): under 0.3 s per run and at least 20x faster than the filterpy version."]
    t_jit = rows[0][1]
    fp = [t for label, t, _ in rows if label.startswith("filterpy")]
    lines.append(f"Here: {t_jit:.3f} s per run ({'met' if t_jit < 0.3 else 'not met'}); "
                 + (f"filterpy / obsnl = {fp[0] / t_jit:.0f}x ({'met' if fp[0] / t_jit >= 20 else 'not met'})."
                    if fp else "filterpy skipped."))
    text = "\n".join(lines) + "\n"
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
