"""Noise on the measured input in the refinement's std and intervals (issue 27: intervals that cover the truth).

The output-error fit simulates the model under the measured input; when that input is noisy the estimate moves
with its noise too, which the Fisher information of the outputs alone does not see. Expected answers come from
scipy: ``least_squares`` on the exact (matrix exponential, first-order hold) discretisation for the shift, and
the true values of data made with ``solve_ivp`` for the coverage.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

from obsnl.estimation.accelerogram import Record
from obsnl.estimation.codegen import to_casadi
from obsnl.identification.profile import THRESHOLD, profiles
from obsnl.identification.refine import refine
from obsnl.identification.setup import Data, Setup
from tests.test_likelihood import C, K, MSD, exact_outputs, msd_data

DT = 0.02


def noisy_input_case(seed: int, input_ratio: float, T: int = 250):
    """The msd record of test_likelihood (scipy, clean input, 1 % noise on the displacement) with Gaussian
    noise of ``input_ratio`` x RMS(u) added to the input the fit is given; returns the setup, the data, the
    clean and the measured inputs, the displacement and the two noise std."""
    u, y, sigma = msd_data(seed=seed, T=T)
    su = input_ratio * float(np.sqrt(np.mean(u ** 2)))
    measured = u + su * np.random.default_rng([seed, 1]).standard_normal(len(u))
    noise = {"y": sigma / float(np.sqrt(np.mean(y ** 2))), "u": input_ratio}
    setup = Setup(model=to_casadi(MSD), record=Record("d", measured, DT, channels=("u",)), truth=None,
                  guess={"k": 18.0, "c": 1.2}, y_true=y.reshape(-1, 1), channel_noise=noise)
    return setup, Data(seed=None, u=measured.reshape(-1, 1), y=y.reshape(-1, 1)), u, measured, y, sigma


def test_the_input_sensitivity_predicts_how_the_estimate_moves_with_the_inputs_noise():
    # The same output data fitted twice by scipy on the exact discretisation: under the clean input and under
    # the noisy one. The difference of the two estimates (log k, log c) is what the input covariance is the
    # variance of: to first order -C J' G e, computed by obsnl from its own objective's exact input sensitivity.
    setup, data, u, measured, y, sigma = noisy_input_case(seed=3, input_ratio=0.02)
    fits = {}
    for name, inp in (("clean", u), ("measured", measured)):
        ls = least_squares(lambda p: (exact_outputs(np.exp(p[0]), np.exp(p[1]), p[2:], inp, DT) - y) / sigma,
                           [np.log(18.0), np.log(1.2), 0.0, 0.0], xtol=1e-15, ftol=1e-15, gtol=1e-15, method="lm")
        fits[name] = ls.x[:2]
    observed = fits["measured"] - fits["clean"]
    ref = refine(setup, data, setup.theta_guess)
    assert ref.converged, ref.reason
    obj = ref.objective
    # the predicted shift for this draw e of the input's noise: -C A' e, A = G' J from the objective's exact
    # input sensitivity (the input covariance is sigma_u^2 C A' A C, the variance of this shift)
    _, J = obj.evaluate(ref.fit.z)
    A = obj.input_effect(ref.fit.z, J)
    shift = -(ref.cov @ (A.T @ (measured - u)))[:2]
    # second-order terms (the noise is 2 % of the input) leave a few per cent of the shift
    assert shift == pytest.approx(observed, rel=0.05), (shift, observed)
    # and the shift is not small against the output noise's std (on this draw k moves by several of them)
    assert np.max(np.abs(observed) / np.sqrt(np.diag(ref.cov)[:2])) > 2.0


@pytest.mark.slow
def test_with_two_percent_noise_on_the_input_the_intervals_cover_the_truth_over_20_seeds():
    """Coverage with a noisy measured input: over 20 seeds (0..19) the 95 % profile intervals of k and c each
    contain the truth at least 17 times. For calibrated intervals the count is Binomial(20, 0.95): P(<= 16) =
    0.016 per parameter, so a calibrated method fails with probability below 0.032 for a random choice of seeds
    (the seeds are fixed: the test is deterministic). The intervals of the output noise alone (threshold 3.84,
    the Fisher std) are shown to fail on the same runs: the input's noise dominates here."""
    covered = {"k": 0, "c": 0}
    fisher_only = {"k": 0, "c": 0}
    for seed in range(20):
        setup, data, *_ = noisy_input_case(seed, input_ratio=0.02)
        ref = refine(setup, data, setup.theta_guess)
        assert ref.converged, ref.reason
        for i, pr in enumerate(profiles(ref)):
            truth = {"k": K, "c": C}[pr.name]
            lo, hi = pr.interval
            covered[pr.name] += bool(lo <= truth <= hi)
            assert pr.threshold == pytest.approx(THRESHOLD * ref.widening(i) ** 2)
            # the interval of the output noise alone: |log theta - log truth| within 1.96 Fisher std
            fisher_only[pr.name] += bool(abs(np.log(ref.theta[i] / truth)) <= 1.96 * np.sqrt(ref.cov[i, i]))
    assert covered["k"] >= 17 and covered["c"] >= 17, covered
    assert fisher_only["k"] < 17 and fisher_only["c"] < 17, fisher_only


def test_exact_inputs_change_nothing():
    # an input given as exact (noise 0): no input covariance, widening 1, the threshold of Raue et al.
    setup, data, *_ = noisy_input_case(seed=5, input_ratio=0.0)
    ref = refine(setup, data, setup.theta_guess)
    assert not np.any(ref.input_cov)
    assert [ref.widening(i) for i in range(2)] == [1.0, 1.0]
    assert all(pr.threshold == THRESHOLD for pr in profiles(ref))
    assert ref.std == pytest.approx(np.abs(ref.theta) * np.sqrt(np.diag(ref.cov)[:2]))


def test_identify_counts_an_inputs_noise_given_or_estimated_but_not_an_upper_bound():
    # measured data: the input's noise is counted at its given level, or at its estimate from the data when the
    # channel is oversampled (the estimate is then the noise: white noise dominates the differences); a clean,
    # smooth input's estimate is only an upper bound (differences of orders 2-4 disagree): taken as exact, said so
    import obsnl

    _, _, u, measured, y, _ = noisy_input_case(seed=2, input_ratio=0.02)
    t = np.arange(len(u)) * DT
    runs = {}
    for name, inp, noise in (("given", measured, {"u": 0.02}), ("estimated", measured, None), ("clean", u, None)):
        runs[name] = obsnl.identify(MSD, {"time_s": t, "u": inp, "y": y}, guess={"k": 18.0, "c": 1.2}, noise=noise,
                                    passes=1, progress=False)
    widen = {n: r.refinement.input_noise_widening for n, r in runs.items()}
    assert widen["given"]["k"] > 1.5 and widen["given"]["c"] > 1.5, widen
    # the input covariance is proportional to the input's noise variance (the same data, the same estimate): the
    # widening's excess follows the estimated level (this draw: 1.55 % where 2 % was added)
    r = runs["estimated"].noise["u"].estimate
    assert not runs["estimated"].noise["u"].upper_bound and 0.01 < r < 0.03
    for p in ("k", "c"):
        assert (widen["estimated"][p] ** 2 - 1) / (widen["given"][p] ** 2 - 1) == pytest.approx((r / 0.02) ** 2,
                                                                                                rel=0.02)
    assert widen["clean"] == {"k": 1.0, "c": 1.0}
    assert any("input u: taken as exact" in a for a in runs["clean"].assumptions)
    assert not any("taken as exact" in a for a in runs["given"].assumptions)
