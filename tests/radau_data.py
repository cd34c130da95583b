"""Measured records for the identification tests, made by an independent integrator (scipy's Radau
with tight tolerances and the input linear between samples, as the filters assume), never by obsnl's
simulator. Noise: Gaussian, ``ratio`` x the channel's RMS, seeded."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

#: True values of tests/data/bouc_wen_force.toml (its [values] table, repeated here on purpose).
SDOF_TRUE = {"m": 2.0, "c": 0.6, "k": 50.0, "kh": 40.0, "beta": 150.0, "gamma": 250.0}


def sdof_force(p=SDOF_TRUE, *, T=500, dt=0.02):
    """Time, force and displacement of the SDOF Bouc-Wen under a swept two-tone force."""
    t = np.arange(T) * dt
    F = (1 + 0.1 * t) * (1.0 * np.sin(2 * np.pi * 0.9 * t) + 0.8 * np.sin(2 * np.pi * 1.7 * t + 0.5))

    def rhs(tt, s):
        x, v, z = s
        f = np.interp(tt, t, F)
        return [v, (f - p["c"] * v - p["k"] * x - p["kh"] * z) / p["m"],
                v * (1 - (p["beta"] * np.sign(v * z) + p["gamma"]) * z ** 2)]

    sol = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0, 0.0], method="Radau", t_eval=t, rtol=1e-9, atol=1e-11,
                    max_step=dt)
    assert sol.success
    return t, F, sol.y.T


def noisy(x, ratio, rng):
    x = np.asarray(x, float)
    return x + ratio * np.sqrt(np.mean(x ** 2)) * rng.standard_normal(x.shape)


def write_csv(path, columns):
    names = list(columns)
    rows = np.column_stack([columns[n] for n in names])
    np.savetxt(path, rows, delimiter=",", header=",".join(names), comments="", fmt="%.10g")
    return path
