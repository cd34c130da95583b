"""Records as they come: a jittered clock, outputs with gaps, columns the model does not use, a gap in an input.

Expected answers come from derivations written here (a clock's deviation from ``k * dt``, the Kalman filter's
equations with a partial measurement vector) and from scipy (``solve_ivp`` simulates the oscillator whose
parameters the fits must recover), never from obsnl's own output.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.errors import DataError
from obsnl.estimation import UKF, to_casadi
from obsnl.estimation.measured import CLOCK_TOLERANCE, estimate_noise, measured, read_measured
from obsnl.identification.experiments import Tuning
from obsnl.report.identification.run import identify_text

from .conftest import needs_cc


# --------------------------------------------------------------------------- the clock
def _alternating_clock(n: int, dt: float, a: float) -> np.ndarray:
    """``k * dt + e_k`` with ``e_k = -a`` at even ``k`` and ``+a`` at odd ``k`` (``n`` odd: the first and the last
    sample are both at ``-a``, so the mean step is exactly ``dt`` and every odd sample is ``2a`` off ``k * dt``
    counted from the first)."""
    k = np.arange(n)
    return k * dt + np.where(k % 2, a, -a)


def test_a_jittered_clock_within_the_tolerance_is_read_as_regular_and_its_deviation_reported():
    dt, n = 0.01, 51
    a = 0.3e-3 * dt  # odd samples 6e-4 of a step off: within the 1e-3 tolerance
    t = _alternating_clock(n, dt, a)
    cols = {"time_s": t, "f": np.sin(np.arange(n) * 0.3), "x": np.cos(np.arange(n) * 0.3)}
    m = measured(cols, inputs=["f"], outputs=["x"])
    assert m.dt == pytest.approx(dt, rel=1e-12)
    assert m.clock_deviation == pytest.approx(2 * a / dt, rel=1e-6)
    assert m.to_dict()["clock_deviation"] == pytest.approx(6e-4, rel=1e-6)
    assert "within 0.0006 of a step" in m.summary() and "tolerance 0.001" in m.summary()
    assert CLOCK_TOLERANCE == 1e-3


def test_a_jittered_clock_beyond_the_tolerance_is_refused_naming_the_worst_sample_and_the_fix():
    dt, n = 0.01, 51
    t = _alternating_clock(n, dt, 0.6e-3 * dt)  # 1.2e-3 of a step: beyond
    t[31] += 0.2e-3 * dt  # the worst sample (odd: 2a off before): 1.4e-3 of a step off
    with pytest.raises(DataError) as err:
        measured({"t": t, "f": np.ones(n), "x": np.arange(n, dtype=float)}, inputs=["f"], outputs=["x"])
    text = str(err.value)
    assert "\n" not in text
    assert "sample 31" in text and "0.0014 of a step" in text and "resample the record onto a regular clock" in text


def test_a_logger_clock_in_a_file_is_read_as_regular(tmp_path):
    # a 1 kHz logger whose times are off k * 1 ms by up to 3.2e-8 s (the pattern of a recorded drive's clock:
    # 0, +2.4e-8, +0.8e-8, +3.2e-8, +1.6e-8 s, repeating every 5 samples)
    n = 200
    k = np.arange(n)
    t = k * 1e-3 + np.array([0.0, 2.4e-8, 0.8e-8, 3.2e-8, 1.6e-8])[k % 5]
    t[-1] = (n - 1) * 1e-3  # the last sample on the clock: the mean step is exactly 1 ms
    rows = "".join(f"{float(ti)!r},{np.sin(i / 9):.17g},{np.cos(i / 9):.17g},{i},{-i}\n" for i, ti in enumerate(t))
    p = tmp_path / "drive.csv"
    p.write_text("time_s,force_N,q_m,vir_V,qref_m\n" + rows)
    m = read_measured(p, inputs=["force_N"], outputs=["q_m"])
    assert m.dt == pytest.approx(1e-3, rel=1e-12)
    assert m.clock_deviation == pytest.approx(3.2e-5, rel=1e-6)
    assert m.ignored == ("vir_V", "qref_m")
    assert "columns ignored (the model does not use them): vir_V, qref_m" in m.summary()


def test_a_missing_sample_of_the_clock_is_refused():
    t = np.r_[np.arange(10), np.arange(11, 31)] * 0.01  # sample 10 lost: the rest is a step late
    with pytest.raises(DataError, match="irregular time step: sample .* of a step off k\\*dt"):
        measured({"t": t, "f": np.ones(30), "x": np.arange(30.0)}, inputs=["f"], outputs=["x"])


# --------------------------------------------------------------------------- gaps in the inputs: refused
def test_a_gap_in_an_input_is_refused_naming_the_column_and_row(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("time_s,f,x\n0,1,0\n0.1,,0.5\n0.2,3,\n0.3,1,0.2\n")
    with pytest.raises(DataError) as err:
        read_measured(p, inputs=["f"], outputs=["x"])
    text = str(err.value)
    assert "\n" not in text and "line 3" in text and "'f' is empty" in text and "only the outputs" in text
    with pytest.raises(DataError) as err:
        measured({"t": [0, 0.1, 0.2, 0.3], "f": [1, np.nan, 3, 1], "x": [0, np.nan, 0.1, 0.2]},
                 inputs=["f"], outputs=["x"])
    text = str(err.value)
    assert "\n" not in text and "'f' has NaN/inf at sample 1" in text and "only outputs may have gaps" in text


def test_gaps_in_an_output_are_read_as_missing_samples(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("time_s,f,x\n0,1,0\n0.1,2,\n0.2,3,0.5\n0.3,1,\n")
    m = read_measured(p, inputs=["f"], outputs=["x"])
    assert np.isnan(m.y[[1, 3], 0]).all() and m.y[2, 0] == 0.5 and m.missing == {"x": 2}
    assert "x 2 of 4" in m.summary()
    with pytest.raises(DataError, match="'x' has no sample"):
        measured({"t": [0, 0.1, 0.2], "f": [1, 2, 3], "x": [np.nan] * 3}, inputs=["f"], outputs=["x"])
    with pytest.raises(DataError, match="'x' has NaN/inf at sample 1"):  # inf is not a gap
        measured({"t": [0, 0.1, 0.2], "f": [1, 2, 3], "x": [0, np.inf, 1]}, inputs=["f"], outputs=["x"])


# --------------------------------------------------------------------------- the noise of a gappy channel
@pytest.mark.parametrize("gaps", ["every other", "random 30 %", "every 10th"])
def test_the_noise_of_a_gappy_channel_is_estimated_from_the_samples_measured(gaps):
    # white noise of std 0.01 on a slow sine: k-th differences of evenly spaced samples have variance
    # C(2k, k) s^2 whatever their spacing (every 10th: an output sampled 10 times more slowly than the input).
    # Seeded; the estimate's relative spread is about 1.3 / sqrt(n) (a MAD over n >= 1900 differences: under 3 %),
    # so 15 % is over 5 of its std (error probability below 1e-6).
    rng = np.random.default_rng(7)
    t = np.arange(20000) * 0.002
    x = np.sin(2 * np.pi * 0.2 * t) + 0.01 * rng.standard_normal(t.size)
    rms = np.sqrt(np.mean(np.sin(2 * np.pi * 0.2 * t) ** 2))
    missing = {"every other": np.arange(t.size) % 2 == 1, "random 30 %": rng.random(t.size) < 0.3,
               "every 10th": np.arange(t.size) % 10 != 0}[gaps]
    x[missing] = np.nan
    ratio, note = estimate_noise(x)
    assert ratio * np.sqrt(np.nanmean(x ** 2)) == pytest.approx(0.01, rel=0.15)
    assert ratio == pytest.approx(0.01 / rms, rel=0.15)
    assert "samples missing" in note


# --------------------------------------------------------------------------- the filter: a partial update
@pytest.mark.parametrize("jit", [False, pytest.param(True, marks=needs_cc)])
def test_the_filter_with_a_partial_measurement_vector_is_the_kalman_filter(jit, tmp_path, monkeypatch):
    # x'' = k u with k held at 1 (fixed): RK4 integrates it exactly (a cubic in t under an input linear between
    # samples), and the unscented filter on a linear model is the Kalman filter. The Kalman filter below updates
    # with the rows of H of the outputs present (none: the prediction is kept). Compiled to C, the step must
    # select the NaN of a missing sample away as casadi's virtual machine does.
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "cache"))
    m = obsnl.Model(name="double", states=["x", "v"], parameters=["k"], inputs=["u"],
                    equations={"x": "v", "v": "k*u"}, outputs={"y1": "x", "y2": "v"})
    dt, T = 0.1, 60
    rng = np.random.default_rng(1)
    u = rng.normal(size=T)
    Q, R = np.diag([1e-4, 2e-4, 0.0]), np.diag([0.01, 0.04])
    f = UKF(to_casadi(m), dt=dt, Q=Q, R=R, fixed=("k",), jit=jit)
    x0, P0 = np.array([0.3, -0.2]), np.diag([0.5, 0.4, 1e-2])
    y = rng.normal(size=(T, 2))
    y[rng.random((T, 2)) < 0.4] = np.nan
    y[7] = np.nan  # a sample with no output at all
    tr = f.run(f.initial(x0=x0, theta0=[1.0], P0=P0), y, u[:, None])
    A = np.array([[1.0, dt], [0.0, 1.0]])
    xm, P = x0.copy(), P0[:2, :2].copy()
    for k in range(1, T):
        xm = A @ xm + np.array([dt ** 2 * (u[k - 1] / 3 + u[k] / 6), dt * (u[k - 1] + u[k]) / 2])
        P = A @ P @ A.T + Q[:2, :2]
        seen = ~np.isnan(y[k])
        if seen.any():
            H = np.eye(2)[seen]
            S = H @ P @ H.T + R[np.ix_(seen, seen)]
            K = P @ H.T @ np.linalg.inv(S)
            xm, P = xm + K @ (y[k, seen] - H @ xm), P - K @ S @ K.T
        np.testing.assert_allclose(tr.x[k], xm, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(tr.P[k][:2, :2], P, rtol=1e-9, atol=1e-13)
    assert np.array_equal(np.isnan(tr.innovations[1:]), np.isnan(y[1:]))  # no innovation where nothing was measured


# --------------------------------------------------------------------------- identification from gappy outputs
TRUE = {"k": 25.0, "c": 0.8}
GUESS = {"k": 20.0, "c": 1.0}
DT, T = 0.05, 400
NOISE = 0.02  # of the output's RMS
OSC = obsnl.Model(name="osc", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
                  equations={"x": "v", "v": "u - k*x - c*v"}, outputs={"y": "x"})
RUN = {"guess": GUESS, "tuning": Tuning(0.3, 0.0, 1.0), "passes": 2, "jit": False, "progress": False}


def _oscillator() -> dict[str, np.ndarray]:
    """The oscillator under a multisine sampled every 2 * DT and linear in between (so the record at DT and the
    record decimated to 2 * DT carry the same input), simulated by scipy from rest, 2 % output noise (seed 11)."""
    tc = np.arange(0, T * DT, 2 * DT)
    uc = np.sin(2 * np.pi * 0.5 * tc) + 0.6 * np.sin(2 * np.pi * 1.1 * tc + 1.0) + 0.4 * np.sin(2 * np.pi * 0.23 * tc)
    t = np.arange(T) * DT
    u = np.interp(t, tc, uc)
    k, c = TRUE["k"], TRUE["c"]
    sol = solve_ivp(lambda s, z: [z[1], np.interp(s, tc, uc) - k * z[0] - c * z[1]], (0, t[-1]), [0.0, 0.0],
                    t_eval=t, method="DOP853", rtol=1e-11, atol=1e-13, max_step=DT / 4)
    x = sol.y[0]
    y = x + NOISE * np.sqrt(np.mean(x ** 2)) * np.random.default_rng(11).standard_normal(T)
    return {"time_s": t, "u": u, "y": y}


@pytest.fixture(scope="module")
def record() -> dict[str, np.ndarray]:
    return _oscillator()


def _within(res: obsnl.identification.runs.Identification, sigmas: float) -> None:
    for p in res.parameters:
        assert p.std is not None and abs(p.estimate - TRUE[p.name]) <= sigmas * p.std, (p.name, p.estimate, p.std)


@pytest.fixture(scope="module")
def every_other(record):
    cols = dict(record, y=np.where(np.arange(T) % 2, np.nan, record["y"]))
    return obsnl.identify(OSC, cols, **RUN)


def test_every_other_output_sample_missing_recovers_the_parameters(every_other):
    # 4 std: a correct std misses by more with probability 6e-5 per parameter
    _within(every_other, 4.0)
    assert every_other.data.missing == {"y": T // 2}
    assert every_other.refinement.samples == T // 2


def test_every_other_sample_missing_is_the_fit_of_the_record_decimated(record, every_other):
    # The same measured samples, the same input (linear between the samples kept), so the same likelihood: the
    # estimates agree far within their std (the fits differ only by their integrator's substeps per second), and
    # so does the noise re-estimated over the samples measured (N = T / 2 in both; counting the gaps in N would
    # make the gappy one sqrt(2) smaller).
    decimated = obsnl.identify(OSC, {c: v[::2] for c, v in record.items()}, **RUN)
    assert decimated.refinement.samples == T // 2
    for a, b in zip(every_other.parameters, decimated.parameters):
        assert abs(a.estimate - b.estimate) <= 0.02 * b.std, (a.name, a.estimate, b.estimate, b.std)
        assert a.std == pytest.approx(b.std, rel=0.02)
    assert every_other.refinement.noise_std["y"] == pytest.approx(decimated.refinement.noise_std["y"], rel=0.01)


def test_random_gaps_recover_the_parameters_and_the_ignored_columns_are_named(record):
    # 30 % of the output samples missing at random (seed 5), and two columns the model does not use
    rng = np.random.default_rng(5)
    gaps = rng.random(T) < 0.3
    gaps[0] = False
    cols = dict(record, y=np.where(gaps, np.nan, record["y"]), vir_V=np.ones(T), qref_m=np.zeros(T))
    res = obsnl.identify(OSC, cols, **RUN)
    _within(res, 4.0)
    assert res.refinement.samples == T - gaps.sum()
    # the noise std re-estimated over the samples measured: the true one (2 % of the RMS) within 20 % (its
    # relative sampling error is about 1 / sqrt(2 N) = 5.5 % for N = 280: over 3.5 of its std; error probability
    # below 1e-3). Counting the gaps in N would make it sqrt(0.7) = 0.84 of it.
    x_rms = np.sqrt(np.mean((record["y"]) ** 2))
    assert res.refinement.noise_std["y"] == pytest.approx(NOISE * x_rms, rel=0.2)
    assert res.data.ignored == ("vir_V", "qref_m")
    text = identify_text(res)
    assert "columns ignored: vir_V, qref_m" in text and f"missing output samples: y {gaps.sum()} of {T}" in text
    assert any("columns ignored" in a for a in res.assumptions)
    assert all(np.isfinite(v) for v in res.fit.values())
