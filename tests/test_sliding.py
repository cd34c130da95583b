"""Stick-slip: the maximum-likelihood fit's step follows a sliding mode (a mass that sticks under dry friction).

The packaged ``coulomb_friction`` oscillator ``m x'' + c x' + k x + F_c sign(x') = u`` driven weakly (RMS 0.7 N
against ``F_c = 0.5`` N), so that the mass sticks eight times in 6 s, for 0.9 s in all. Expected answers come
from scipy: each slip phase integrated by ``solve_ivp`` with its own friction sign until the located reversal
``v = 0``; there the mass sticks when the spring and the force cannot overcome friction (``|u - k x| <= F_c``,
Coulomb's law), and stays at rest until ``|u - k x|`` reaches ``F_c`` (found exactly, the force being linear
between samples), then slips the way the net force pushes. That is Filippov's solution of the model, built
here from the physics, never from obsnl's integrator.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.estimation.codegen import to_casadi

from .test_crossing import DT, TRUTH, fits_over_seeds, multisine, slip


def stick_slip(p: dict, t: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, int, float]:
    """States at the times ``t`` from rest at ``x = 0`` (the input linear between samples); the number of stick
    phases and their total length."""
    k, fc = p["k"], p["F_c"]
    X = np.full((len(t), 2), np.nan)
    t0, state, forced, sticks, stuck = float(t[0]), np.zeros(2), 0.0, 0, 0.0
    while t0 < t[-1]:
        if state[1] == 0.0 and not forced and abs(np.interp(t0, t, u) - k * state[0]) <= fc:
            # stuck: until |u - k x| reaches F_c; u is linear between samples, so the time is exact
            r = u - k * state[0]
            end, forced = t[-1], 0.0
            i = int(np.searchsorted(t, t0, side="right"))
            lo, r_lo = t0, float(np.interp(t0, t, u)) - k * state[0]
            for j in range(i, len(t)):
                hits = [(lo + (t[j] - lo) * (b - r_lo) / (r[j] - r_lo), np.sign(b)) for b in (fc, -fc)
                        if (r_lo - b) * (r[j] - b) < 0 or (r[j] == b != r_lo)]
                if hits:
                    end, forced = min(hits)
                    break
                lo, r_lo = t[j], r[j]
            idx = np.nonzero((t >= t0) & (t <= end))[0]
            X[idx] = [state[0], 0.0]
            sticks, stuck = sticks + 1, stuck + (end - t0)
            if not forced:
                break
            t0 = end
            continue
        s = forced if forced else float(np.sign(state[1]) or np.sign(np.interp(t0, t, u) - k * state[0]))
        forced = 0.0
        sol = slip(p, t, u, t0, state, s, X)
        if sol.status != 1:
            break
        t0, state = float(sol.t_events[0][0]), np.array([sol.y_events[0][0][0], 0.0])
    return X, sticks, stuck


def stick_record(T: int, rms: float = 0.7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A random-phase multisine force (0.05-2.95 Hz, RMS ``rms`` N) and scipy's stick-slip response from rest."""
    t, u = multisine(T, rms)
    X, sticks, stuck = stick_slip(TRUTH, t, u)
    assert not np.isnan(X).any()
    return t, u, X


def _run(step, p, u) -> np.ndarray:
    x, out = np.zeros(2), [np.zeros(2)]
    for i in range(len(u) - 1):
        x = np.array(step(x, p, u[i], u[i + 1])[0]).ravel()
        out.append(x)
    return np.array(out)


def test_the_record_sticks_and_the_fits_step_follows_scipys_stick_slip_solution():
    t, u, X = stick_record(600)
    _, sticks, stuck = stick_slip(TRUTH, t, u)
    assert sticks >= 6 and stuck > 0.5  # the mass really sticks, often and for long
    num = to_casadi(obsnl.read_model("obsnl:coulomb_friction"))
    assert num.jumps == (True,) and num.slides == (True,)  # the jump -2 F_c / m is across v = 0
    p = np.array([TRUTH[n] for n in num.parameters])
    rms = float(np.sqrt(np.mean(X[:, 0] ** 2)))
    located = _run(num.step(DT, substeps=8, refine=8, locate=True), p, u)
    # the sliding rule holds the mass at v = 0 (to rounding) wherever scipy has it stuck
    stuck_samples = np.nonzero(X[:, 1] == 0.0)[0][1:]
    assert np.max(np.abs(located[stuck_samples, 1])) < 1e-12
    assert np.max(np.abs(located[:, 0] - X[:, 0])) < 1e-6 * rms
    # the filters' step (no located crossing, no sliding rule) chatters across v = 0 while the mass is stuck
    plain = _run(num.step(DT, substeps=8, refine=8), p, u)
    assert np.max(np.abs(plain[:, 0] - X[:, 0])) > 100 * np.max(np.abs(located[:, 0] - X[:, 0]))


@pytest.mark.slow
def test_stick_slip_fits_converge_and_their_intervals_cover_the_truth_over_20_seeds():
    """Over 20 noise seeds (1 % noise on the displacement, 6 s of stick-slip record) the maximum-likelihood fit of
    m, c, k, F_c, started 3 % off as the filter leaves it, converges at least 18 times (a run that does not says
    why), and each parameter's 95 % profile interval contains the truth at least 17 times. For calibrated
    intervals each count is Binomial(20, 0.95), P(<= 16) = 0.016, so a calibrated method fails the coverage part
    with probability below 0.065 for a random choice of seeds (the seeds are fixed: the test is deterministic).
    Measured over seeds 0-59 (``benchmarks/bench_stick_slip.py``): 60 of 60 converge (57 before the step after a
    located crossing started on the side opposite the start), and the intervals cover m, c, k, F_c 58, 54, 59, 54
    times (c and F_c at 90 %, RMS error / std 1.11 and 1.13). Before the sliding rule, the fit of such a record
    ended "not converged" with every profile at its evaluation cap."""
    t, u, X = stick_record(600)
    converged, covered, reasons = fits_over_seeds(u, X[:, 0], range(20))
    assert all("first-order condition not met" in r for r in reasons)
    assert converged >= 18, converged
    assert min(covered.values()) >= 17, covered


@pytest.mark.parametrize("u0", [0.3, -0.3, 0.7, -0.7])
def test_from_rest_the_mass_stays_unless_the_force_beats_friction(u0):
    # one substep from rest under a constant force: stuck when |u| <= F_c (x, v stay 0), else the slip of
    # m v' = u - F_c sign(u) - k x - c v, whose exact state after h is scipy's
    from obsnl.estimation.crossing import located_substep

    num = to_casadi(obsnl.read_model("obsnl:coulomb_friction"))
    p = np.array([TRUTH[n] for n in num.parameters])
    h = DT / 64
    end = np.array(located_substep(num, h)([0.0, 0.0], p, u0, u0)).ravel()
    if abs(u0) <= TRUTH["F_c"]:
        assert np.max(np.abs(end)) < 1e-15
    else:
        s = np.sign(u0)
        ref = solve_ivp(lambda tt, z: [z[1], u0 - 0.2 * z[1] - 40.0 * z[0] - 0.5 * s], (0, h), [0.0, 0.0],
                        rtol=1e-12, atol=1e-16).y[:, -1]
        assert end == pytest.approx(ref, rel=1e-9, abs=1e-16)


def test_the_filter_with_the_located_step_follows_the_sticking_mass():
    """The UKF alone (three passes, s0 0.3, guesses 30-40 % off) on the stick-slip record, 1 % noise, seeds 0-7.
    With ``Setup(locate=True)`` its step locates the reversal and follows the sliding mode as the fit's does: every
    estimate lies within 4 posterior std of the truth (a right std misses by that with probability 6e-5 per parameter,
    2e-3 over the 32) and c is within 2.5 % on average (measured: -0.95 %, worst |error / std| 2.8). With the refined
    step (the default) the stages chatter across v = 0 while the mass sticks: c is biased by -3 to -9 % (measured
    mean -6.1 %, worst |error / std| 5.9), which the test requires to stay visible (below -4 %)."""
    from obsnl.estimation.accelerogram import Record
    from obsnl.identification import Setup, Tuning, make_filter, run_passes
    from obsnl.identification.setup import Data

    t, u, X = stick_record(600)
    x = X[:, 0]
    sigma = 0.01 * float(np.sqrt(np.mean(x ** 2)))
    num = to_casadi(obsnl.read_model("obsnl:coulomb_friction"))
    truth = np.array([TRUTH[n] for n in num.parameters])
    guess = {"m": 1.3, "c": 0.14, "k": 28.0, "F_c": 0.65}
    c_mean = {}
    for locate in (True, False):
        c_errors = []
        for seed in range(8):
            y = x + sigma * np.random.default_rng(seed).standard_normal(len(t))
            setup = Setup(model=num, record=Record("d", u, DT, channels=("u",)), truth=None, guess=guess,
                          y_true=y.reshape(-1, 1), channel_noise={"y": 0.01, "u": 1e-6}, locate=locate)
            trs, _ = run_passes(setup, make_filter(setup, "ukf"), Data(seed=None, u=u.reshape(-1, 1),
                                                                       y=y.reshape(-1, 1)),
                                Tuning(s0=0.3, q_theta=0.0, q_x=1.0), passes=3)
            theta, P = trs[-1].theta[-1], trs[-1].P[-1]
            z = (np.log(theta) - np.log(truth)) / np.sqrt(np.diag(P)[num.nx:])  # the filter's log coordinates
            if locate:
                assert np.all(np.abs(z) <= 4), (seed, z)
            c_errors.append(theta[1] / truth[1] - 1)
        c_mean[locate] = float(np.mean(c_errors))
    assert abs(c_mean[True]) < 0.025 and c_mean[False] < -0.04, c_mean
