"""The engineer's figures of an identification (issue 43 item 5): the SDOF Bouc-Wen oscillator identified from the
force and the displacement that scipy's Radau made (tests/radau_data.py, never obsnl's simulator). The restoring
force the figures read from the record is checked against the true one, ``c v + k x + kh z`` along the Radau
solution; the FRF and the correlations against formulas written here. The noise has a fixed seed (deterministic)."""

from __future__ import annotations

import numpy as np
import pytest

import obsnl
from obsnl.identification.engineering import figure_files, restoring_force
from obsnl.identification.identify import write_identification
from obsnl.report.identification.diagnostics import (
    HysteresisLoop,
    NoHysteresisLoop,
    correlation_bounds,
    h1_estimate,
    model_frf,
)

from .conftest import ROOT
from .radau_data import SDOF_TRUE, noisy, sdof_force

SDOF = ROOT / "tests" / "data" / "bouc_wen_force.toml"


@pytest.fixture(scope="module")
def bouc_wen():
    t, F, X = sdof_force(T=750)
    rng = np.random.default_rng(0)
    data = {"time_s": t, "F": noisy(F, 0.01, rng), "x_meas": noisy(X[:, 0], 0.01, rng)}
    return obsnl.identify(SDOF, data, jit=False, progress=False), X, F


@pytest.mark.slow
def test_the_folder_holds_the_residual_frf_and_hysteresis_figures(bouc_wen, tmp_path):
    res, _, _ = bouc_wen
    assert figure_files(res) == ("residuals.png", "frf.png", "hysteresis.png")
    written = {p.name for p in write_identification(res, tmp_path / "run")}
    assert written >= {"identify.json", "fit.png", "residuals.png", "frf.png", "hysteresis.png"}
    assert all((tmp_path / "run" / n).stat().st_size > 10_000 for n in written if n.endswith(".png"))


@pytest.mark.slow
def test_the_measured_and_model_restoring_force_follow_the_true_one(bouc_wen):
    res, X, F = bouc_wen
    loop = restoring_force(res)
    assert isinstance(loop, HysteresisLoop), loop
    p = SDOF_TRUE
    true = p["c"] * X[:, 1] + p["k"] * X[:, 0] + p["kh"] * X[:, 2]  # F - m x'' along the Radau solution
    rms = np.sqrt(np.mean(true ** 2))
    inner = slice(20, -20)  # the Savitzky-Golay ends are extrapolated
    measured = loop.force_measured[inner] - true[inner]
    model = loop.force_model[inner] - true[inner]
    # measured: the 1 % noise of F and x passed through F - m x'' (a second derivative): within 10 % RMS;
    # the model at the estimate: within 3 %
    assert np.sqrt(np.mean(measured ** 2)) < 0.10 * rms
    assert np.sqrt(np.mean(model ** 2)) < 0.03 * rms
    assert "Savitzky-Golay" in loop.note
    # the displacement drawn: the measured x (1 % RMS noise, seeded: within 5 % of the RMS at every sample), and the
    # model's x along its simulation at the estimate (within 5 % RMS of the Radau solution)
    x_rms = np.sqrt(np.mean(X[:, 0] ** 2))
    assert loop.displacement_measured == pytest.approx(X[:, 0], abs=0.05 * x_rms)
    assert np.sqrt(np.mean((loop.displacement_model - X[:, 0]) ** 2)) < 0.05 * x_rms


def test_a_run_without_a_loop_says_why_and_the_figure_says_it(tmp_path):
    from types import SimpleNamespace

    from obsnl.report.identification.diagnostics import plot_hysteresis

    loop = restoring_force(SimpleNamespace(linear_at_rest=None, u_measured=None))
    assert loop == NoHysteresisLoop("the model does not linearise at rest, or the run kept no inputs")
    assert loop.note == "no loop drawn: the model does not linearise at rest, or the run kept no inputs"
    assert plot_hysteresis(tmp_path / "h.png", loop).stat().st_size > 1000


def test_the_frf_and_the_h1_estimate_agree_with_their_formulas():
    # H(f) of m x'' + c x' + k x = F, written out: 1 / (k - m w^2 + i c w)
    m, c, k = 2.0, 0.6, 50.0
    f = np.array([0.1, 0.8, 2.0])
    w = 2 * np.pi * f
    H = model_frf([[0, 1], [-k / m, -c / m]], [[0], [1 / m]], [[1, 0]], [[0]], f)[:, 0, 0]
    assert H == pytest.approx(1 / (k - m * w ** 2 + 1j * c * w), rel=1e-12)
    # H1 of a pure delay of one sample, y(k) = u(k - 1): exp(-i w dt), coherence 1 (the mean, 0 Hz, detrended away)
    u = np.random.default_rng(5).standard_normal(8192)
    fr, H1, coh = h1_estimate(u[1:], u[:-1], 100.0)
    band = (fr > 0) & (fr < 40)
    assert H1[band] == pytest.approx(np.exp(-2j * np.pi * fr[band] / 100.0), abs=0.02)
    assert np.all(coh[band] > 0.99)
    # the bound of a correlation of n white samples: z_{0.995} / sqrt(n)
    assert correlation_bounds(10_000, 0.01) == pytest.approx(2.5758293 / 100, rel=1e-6)
