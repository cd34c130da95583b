"""The modal summary of an identified model (issue 43 item 4): a two-storey linear shear frame identified from the
floor displacements that scipy's solve_ivp made (never obsnl's simulator). The expected modes are the eigenvalues
of the true frame's state matrix, written out here from its mass, stiffness and damping matrices; the Monte-Carlo
spread draws the parameters from their reported covariance through that same eigen-analysis, written here."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.errors import OptionError

TRUE = {"k1": 400.0, "k2": 300.0, "c1": 0.8, "c2": 0.6}  # unit floor masses: N/m, N s/m
FRAME = obsnl.Model(
    name="frame2", states=["x1", "x2", "v1", "v2"], parameters=["k1", "k2", "c1", "c2"], inputs=["F"],
    equations={"x1": "v1", "x2": "v2", "v1": "F - k1*x1 - c1*v1 + k2*(x2 - x1) + c2*(v2 - v1)",
               "v2": "-k2*(x2 - x1) - c2*(v2 - v1)"},
    outputs={"y1": "x1", "y2": "x2"}, guess={"k1": 300.0, "k2": 350.0, "c1": 1.0, "c2": 0.5})


def state_matrix(k1, k2, c1, c2):
    """The shear frame's first-order form: M = I, K and C of two storeys in series."""
    K = np.array([[k1 + k2, -k2], [-k2, k2]])
    C = np.array([[c1 + c2, -c2], [-c2, c2]])
    return np.block([[np.zeros((2, 2)), np.eye(2)], [-K, -C]])


def modes(A):
    """Frequencies (Hz) and damping ratios of the complex pairs of A, lowest first."""
    w = np.linalg.eigvals(A)
    w = w[w.imag > 0]
    w = w[np.argsort(np.abs(w))]
    return np.abs(w) / (2 * np.pi), -w.real / np.abs(w)


@pytest.fixture(scope="module")
def run():
    dt, n = 0.01, 3000
    t = np.arange(n) * dt
    rng = np.random.default_rng(1)
    freqs = np.linspace(0.3, 8.0, 40)  # a broadband force over both modes (1.9 and 4.7 Hz)
    phase = rng.uniform(0, 2 * np.pi, freqs.size)
    F = np.sum(np.sin(2 * np.pi * freqs[:, None] * t[None, :] + phase[:, None]), axis=0)

    def rhs(s, z):
        return state_matrix(**TRUE) @ z + np.array([0.0, 0.0, np.interp(s, t, F), 0.0])

    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(4), t_eval=t, rtol=1e-10, atol=1e-12, max_step=dt)
    assert sol.success
    X = sol.y.T
    y1 = X[:, 0] + 0.01 * np.std(X[:, 0]) * rng.standard_normal(n)  # 1 % noise, fixed seed: deterministic
    y2 = X[:, 1] + 0.01 * np.std(X[:, 1]) * rng.standard_normal(n)
    return obsnl.identify(FRAME, {"t": t, "F": F, "y1": y1, "y2": y2}, jit=False, intersample="linear",
                          progress=False)


def covariance_of(res):
    """The estimates' covariance as identify.json reports it: each std, and the fit's correlations."""
    doc = res.to_dict()
    names = [p["name"] for p in doc["parameters"]]
    d = np.array([p["std"] for p in doc["parameters"]])
    R = np.array([[doc["refinement"]["correlation"][a][b] for b in names] for a in names])
    return names, np.array([p["estimate"] for p in doc["parameters"]]), R * np.outer(d, d)


@pytest.mark.slow
def test_frequencies_and_damping_against_the_true_frame(run):
    assert run.adequacy is not None and run.adequacy.passed and run.converged
    m = run.modal()
    f_true, z_true = modes(state_matrix(**TRUE))
    assert len(m.frequency_hz) == 2 and m.oscillatory and m.real_poles == ()
    for f, ft in zip(m.frequency_hz, f_true):
        assert f == pytest.approx(ft, rel=0.01)
    for z, zs, zt in zip(m.damping_ratio, m.damping_ratio_std, z_true):
        assert abs(z - zt) <= max(0.01 * zt, 3 * zs), (z, zs, zt)
    # mode shapes at the outputs: the true eigenvectors' displacement entries, largest 1
    w, V = np.linalg.eig(state_matrix(**TRUE))
    order = np.argsort(np.abs(w[w.imag > 0]))
    for k, shape in zip(order, m.shapes):
        v = V[:2, w.imag > 0][:, k]
        v = (v / v[np.argmax(np.abs(v))]).real
        assert [shape["y1"], shape["y2"]] == pytest.approx(v.tolist(), abs=0.01)


@pytest.mark.slow
def test_reported_std_matches_a_monte_carlo_spread(run):
    # 4000 draws: the sample std has a relative error of about 1/sqrt(2 * 4000) = 1.1 %, so a 20 % miss by chance
    # is beyond 15 sigma (probability below 1e-40); the seed fixes the draws anyway
    m = run.modal()
    names, theta, S = covariance_of(run)
    draws = np.random.default_rng(7).multivariate_normal(theta, S, size=4000)
    figures = np.array([np.concatenate(modes(state_matrix(**dict(zip(names, d))))) for d in draws])
    spread = figures.std(axis=0, ddof=1)
    reported = np.array([*m.frequency_hz_std, *m.damping_ratio_std], float)
    assert reported == pytest.approx(spread, rel=0.2)


@pytest.mark.slow
def test_python_control_export_has_the_linearisation_poles(run):
    sys = run.state_space()
    est = {p.name: p.estimate for p in run.parameters}
    expected = np.sort_complex(np.linalg.eigvals(state_matrix(**est)))
    assert np.sort_complex(np.asarray(sys.poles())) == pytest.approx(expected, rel=1e-9)
    assert list(sys.input_labels) == ["F"] and list(sys.output_labels) == ["y1", "y2"]
    # the steady gain of x1 under a unit static force: 1/k1 (both storeys carry it; the top moves with it)
    assert np.real(sys.dcgain())[0, 0] == pytest.approx(1 / est["k1"], rel=1e-9)


@pytest.mark.slow
def test_identify_json_and_the_printed_summary_hold_the_modes(run, tmp_path):
    from obsnl.report.identification import identify_text

    doc = json.loads(json.dumps(run.to_dict(), allow_nan=False))
    modal = doc["modal"]
    assert [round(x["frequency_hz"], 9) for x in modal["modes"]] == [round(f, 9) for f in run.modal().frequency_hz]
    assert set(modal["modes"][0]) >= {"frequency_hz", "frequency_hz_std", "damping_ratio", "damping_ratio_std",
                                      "shape", "shape_std"}
    text = identify_text(run)
    assert "mode 1" in text and "mode 2" in text and "Hz" in text


@pytest.mark.slow
def test_a_state_that_does_not_name_the_states_is_refused(run):
    with pytest.raises(OptionError, match="x1"):
        run.modal(state={"x": 0.0})
    with pytest.raises(OptionError, match="4 states"):
        run.modal(state=[0.0, 0.0])
    # a state given: the linear frame has the same modes anywhere
    m = run.modal(state={"x1": 0.01, "x2": 0.02, "v1": 0.0, "v2": 0.0})
    assert m.frequency_hz == pytest.approx(run.modal().frequency_hz, rel=1e-12)
    assert any("no equilibrium" in a for a in m.assumptions)


def test_a_first_order_model_has_real_poles_and_no_mode():
    from obsnl.identification.modal import eigen_modes

    # x' = -2 x + u, plus an undamped oscillator w = 3: one real pole -2, one mode of 3 / (2 pi) Hz
    A = np.array([[-2.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -9.0, 0.0]])
    lam, shapes, real = eigen_modes(A[:1, :1], np.eye(1))
    assert lam.size == 0 and shapes.shape == (0, 1) and real.tolist() == [-2.0]
    lam, shapes, real = eigen_modes(A, np.eye(3)[:2])
    assert np.abs(lam) == pytest.approx([3.0]) and real.tolist() == [-2.0]
