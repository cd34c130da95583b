"""A profile point that starts at its minimum costs one evaluation, and its chi2 is scipy's re-optimised one.

Data from scipy's ``solve_ivp`` (DOP853 at tight tolerances) with seeded noise; the expected profile values from
``scipy.optimize.least_squares`` re-optimising the other coordinates at each profile point, on the same objective.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

import obsnl
from obsnl.estimation.accelerogram import Record
from obsnl.estimation.codegen import to_casadi
from obsnl.identification.profile import profile
from obsnl.identification.refine import refine
from obsnl.identification.setup import Data, Setup

MSD = obsnl.Model(
    name="msd",
    states=["x", "v"],
    parameters=["k", "c"],
    inputs=["u"],
    equations={"x": "v", "v": "u - k*x - c*v"},
    outputs={"y": "x"},
)


def test_profile_points_near_the_linear_prediction_take_one_evaluation_and_scipys_value():
    # k = 25, c = 0.8 from rest under two sines, 1 % noise (seed 5: deterministic). The profile of a well-informed
    # parameter of a linear system is nearly quadratic, so each prediction along the covariance lands at its
    # re-optimised point to within the stop
    T, dt = 300, 0.02
    t = np.arange(T) * dt
    u = np.sin(3.1 * t) + 0.6 * np.sin(7.3 * t + 1.0)
    sol = solve_ivp(
        lambda tt, s: [s[1], np.interp(tt, t, u) - 25.0 * s[0] - 0.8 * s[1]],
        (0, t[-1]),
        [0.0, 0.0],
        method="DOP853",
        t_eval=t,
        rtol=1e-12,
        atol=1e-14,
        max_step=dt / 4,
    )
    sigma = 0.01 * float(np.sqrt(np.mean(sol.y[0] ** 2)))
    y = (sol.y[0] + sigma * np.random.default_rng(5).standard_normal(T))[:, None]
    rec = Record("d", u, dt, channels=("u",))
    setup = Setup(
        model=to_casadi(MSD),
        record=rec,
        truth=None,
        guess={"k": 20.0, "c": 1.0},
        y_true=y,
        channel_noise={"y": 0.01, "u": 1e-6},
    )
    ref = refine(setup, Data(seed=None, u=u[:, None], y=y), setup.theta_guess)
    pr = profile(ref, "k")
    assert pr.shape == "closed"
    away = [(th, d) for th, d in pr.points if d > 0]
    assert pr.evaluations == len(away)  # one evaluation a point: each prediction was already at its minimum
    z_hat, obj = ref.fit.z, ref.objective
    for th, delta in away:

        def residuals(w: np.ndarray, th: float = th) -> np.ndarray:
            phi = setup.coordinate_map.to_phi(np.r_[th, ref.theta[1:]])[0]  # k's coordinate
            return obj.evaluate(np.r_[phi, w])[0]

        best = least_squares(residuals, z_hat[1:], method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14)
        expected = float(best.fun @ best.fun) - ref.chi2
        assert abs(delta - expected) <= 2e-3  # the points' stop, 1e-3, with rounding to spare
