"""Validation on new data (issue 40 item 4): ``obsnl.simulate``, ``Identification.simulate`` and ``obsnl validate``.

Expected answers come from scipy (``solve_ivp`` with tight tolerances and the input linear between samples, as
obsnl's default assumes; the figures of merit computed here from its output) or from a derivation written in the
test, never from obsnl's own simulator. Every noisy record is drawn from a fixed seed, so each test is
deterministic (no error probability to state).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.cli import main
from obsnl.errors import DataError, OptionError
from obsnl.identification.validation.merit import figures_of_merit

from .conftest import ROOT
from .radau_data import SDOF_TRUE, noisy, write_csv

SDOF = ROOT / "tests" / "data" / "bouc_wen_force.toml"
OSC = obsnl.Model(name="osc", states=["x", "v"], parameters=["c", "k"], inputs=["u"],
                  equations={"x": "v", "v": "u - c*v - k*x"}, outputs={"y": "x"})
DUFFING = obsnl.Model(name="duffing", states=["x", "v"], parameters=["c", "k", "a"], inputs=["u"],
                      equations={"x": "v", "v": "u - c*v - k*x - a*x**3"}, outputs={"y": "x", "vel": "v"})


def _input(T, dt, seed):
    """A smooth random input (white noise through a 5-sample moving average), and its times."""
    t = np.arange(T) * dt
    return t, 2.0 * np.convolve(np.random.default_rng(seed).standard_normal(T), np.ones(5) / 5, mode="same")


def _scipy(rhs, t, u, x0):
    """States at the sample times, the input linear between samples (``np.interp``)."""
    sol = solve_ivp(lambda s, z: rhs(z, np.interp(s, t, u)), (0, t[-1]), x0, t_eval=t, method="DOP853",
                    rtol=1e-12, atol=1e-14, max_step=(t[1] - t[0]) / 4)
    assert sol.success
    return sol.y.T


def _merit(y, s):
    """RMSE, NRMSE, fit % and dB written out from their definitions (MATLAB compare's fit)."""
    e = y - s
    rmse = math.sqrt(np.mean(e ** 2))
    return (rmse, rmse / np.std(y), 100 * (1 - np.linalg.norm(e) / np.linalg.norm(y - np.mean(y))),
            20 * math.log10(rmse / math.sqrt(np.mean(y ** 2))))


def _check_against_scipy(v, y_meas, y_scipy, warmup=0):
    for j, name in enumerate(v.outputs):
        want = _merit(y_meas[warmup:, j], y_scipy[warmup:, j])
        got = v.outputs[name]
        assert got.rmse == pytest.approx(want[0], rel=1e-6)
        assert got.nrmse == pytest.approx(want[1], rel=1e-6)
        assert got.fit_percent == pytest.approx(want[2], rel=1e-6)
        assert got.db == pytest.approx(want[3], abs=1e-5)  # 1e-6 relative in RMSE is 1e-5 dB


def test_linear_oscillator_rmse_equals_scipy():
    c, k = 0.3, 20.0
    t, u = _input(1500, 0.02, seed=1)
    X = _scipy(lambda z, f: [z[1], f - c * z[1] - k * z[0]], t, u, [0.0, 0.0])
    y = noisy(X[:, 0], 0.02, np.random.default_rng(2))[:, None]
    v = obsnl.simulate(OSC, {"c": c, "k": k}, {"t": t, "u": u, "y": y[:, 0]})
    _check_against_scipy(v, y, X[:, :1])
    assert v.start == "rest" and v.warmup == 0 and v.scored == 1500 and v.intersample == {"u": "linear"}
    d = v.to_dict()
    assert set(d["outputs"]["y"]) == {"rmse", "nrmse", "fit_percent", "db"}
    assert d["start"] == "rest" and d["warmup"] == 0 and d["intersample"] == {"u": "linear"}
    assert any("starts from rest" in a for a in d["assumptions"])
    assert json.loads(json.dumps(d, allow_nan=False)) == d
    assert "\n" not in repr(v) and repr(v).startswith("Validation(model='osc'") and "fit 9" in repr(v)
    with pytest.raises(dataclasses.FrozenInstanceError):
        v.warmup = 3  # type: ignore[misc]


def test_a_validation_without_its_arrays_is_refused_before_any_file(tmp_path):
    # the arrays default to None (the JSON has none); write_validation says so instead of failing inside matplotlib
    from obsnl.identification.validation.job import write_validation

    t, u = _input(200, 0.02, seed=1)
    v = obsnl.simulate(OSC, {"c": 0.3, "k": 20.0}, {"t": t, "u": u, "y": np.zeros(200)})
    with pytest.raises(DataError, match="carries no arrays"):
        write_validation(dataclasses.replace(v, y_simulated=None), tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_duffing_two_outputs_rmse_equals_scipy():
    p = {"c": 0.4, "k": 10.0, "a": 300.0}
    t, u = _input(1200, 0.02, seed=3)
    X = _scipy(lambda z, f: [z[1], f - p["c"] * z[1] - p["k"] * z[0] - p["a"] * z[0] ** 3], t, u, [0.0, 0.0])
    assert np.max(np.abs(p["a"] * X[:, 0] ** 3)) > 0.2 * np.max(np.abs(p["k"] * X[:, 0]))  # the cubic term acts
    rng = np.random.default_rng(4)
    y = np.column_stack([noisy(X[:, 0], 0.01, rng), noisy(X[:, 1], 0.01, rng)])
    v = obsnl.simulate(DUFFING, p, {"t": t, "u": u, "y": y[:, 0], "vel": y[:, 1]})
    _check_against_scipy(v, y, X)
    assert list(v.outputs) == ["y", "vel"]


def test_bouc_wen_through_the_command_line(tmp_path, capsys):
    # the CLI reads the parameters from an identify.json (written here in that file's layout), and writes
    # validate.json, the figures and, for the hysteretic state z, the restoring-force loop
    p = SDOF_TRUE
    t, F = _input(1000, 0.02, seed=5)
    F = 20 * F

    def rhs(z, f):
        x, vel, h = z
        return [vel, (f - p["c"] * vel - p["k"] * x - p["kh"] * h) / p["m"],
                vel * (1 - (p["beta"] * np.sign(vel * h) + p["gamma"]) * h ** 2)]

    X = _scipy(rhs, t, F, [0.0, 0.0, 0.0])
    y = noisy(X[:, 0], 0.01, np.random.default_rng(6))
    data = write_csv(tmp_path / "test.csv", {"time_s": t, "F": F, "x_meas": y})
    params = tmp_path / "fit" / "identify.json"
    params.parent.mkdir()
    params.write_text(json.dumps({"schema": "obsnl.identify/1", "model": "bouc_wen_force", "parameters": [
        {"name": n, "estimate": v, "held": False, "held_at": None} for n, v in p.items()]}))
    out = tmp_path / "val"
    args = ["validate", str(SDOF), "--params", str(params), "--data", str(data), "--out", str(out)]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "validate bouc_wen_force" in text and "from rest" in text and "wrote 3 files" in text
    doc = json.loads((out / "validate.json").read_text())
    want = _merit(y, X[:, 0])
    got = doc["outputs"]["x_meas"]
    assert [got["rmse"], got["nrmse"], got["fit_percent"]] == pytest.approx(want[:3], rel=1e-6)
    assert got["db"] == pytest.approx(want[3], abs=1e-5)
    assert doc["parameters_from"] == str(params) and doc["parameters"] == pytest.approx(p)
    assert all((out / f).stat().st_size > 1000 for f in ("validation.png", "loop.png"))
    assert main(args) == 2  # never overwritten without --force
    assert "--force" in capsys.readouterr().err
    assert main([*args, "--force"]) == 0
    assert main([*args[:3], str(params.parent), *args[4:], "--force"]) == 0  # the folder of the identify.json


def test_figures_of_merit_against_their_derivation():
    # y = A sin over whole periods: mean 0, RMS A / sqrt(2) (exact for >= 3 samples a period). A simulation
    # (1 - eps) y leaves e = eps y: RMSE eps A / sqrt(2), NRMSE eps, fit 100 (1 - eps), 20 log10(eps) dB.
    A, eps = 3.0, 0.05
    y = A * np.sin(2 * np.pi * np.arange(400) / 40)
    rmse, nrmse, fit, db = figures_of_merit(y, (1 - eps) * y)
    assert (rmse, nrmse, fit, db) == pytest.approx((eps * A / math.sqrt(2), eps, 100 * (1 - eps), 20 * math.log10(eps)))
    # an offset: y = 1 + sin, simulated by its mean 1. e = sin: RMSE 1/sqrt(2) = RMS(y - mean), so NRMSE 1 and
    # fit 0 %; RMS(y) = sqrt(1 + 1/2), so dB = 20 log10(sqrt(1/2) / sqrt(3/2)) = -10 log10(3)
    s = np.sin(2 * np.pi * np.arange(400) / 40)
    assert figures_of_merit(1 + s, np.ones(400)) == pytest.approx((math.sqrt(0.5), 1.0, 0.0, -10 * math.log10(3)))
    # a gap (NaN) is left out: the same figures as without those samples
    gappy = (1 + s).copy()
    gappy[::7] = np.nan
    keep = ~np.isnan(gappy)
    assert figures_of_merit(gappy, np.ones(400)) == pytest.approx(figures_of_merit((1 + s)[keep], np.ones(keep.sum())))
    # a constant measurement has no NRMSE and no fit; a zero one no dB either
    assert figures_of_merit([2.0, 2.0, 2.0], [2.0, 1.0, 2.0])[1:] == (None, None, 20 * math.log10(math.sqrt(1 / 3) / 2))
    assert figures_of_merit([0.0, 0.0], [0.0, 1.0])[1:] == (None, None, None)


def test_warmup_recovers_a_nonzero_initial_state():
    c, k, x0 = 0.3, 20.0, [0.02, -0.15]
    t, u = _input(1500, 0.02, seed=7)
    X = _scipy(lambda z, f: [z[1], f - c * z[1] - k * z[0]], t, u, x0)
    y = noisy(X[:, 0], 0.01, np.random.default_rng(8))
    rec = {"t": t, "u": u, "y": y}
    rest = obsnl.simulate(OSC, {"c": c, "k": k}, rec)
    warm = obsnl.simulate(OSC, {"c": c, "k": k}, rec, warmup=150)
    assert warm.start == "estimated" and warm.warmup == 150 and warm.scored == 1350
    # 150 samples (about 2 periods) at 1 % noise pin the state to a few parts in a thousand of its size
    assert [warm.x0["x"], warm.x0["v"]] == pytest.approx(x0, rel=0.01)
    assert "not scored" in warm.summary() and "met its tolerances" in warm.start_note
    # scored over the samples after the warm-up: the score of the true initial state (scipy), to the noise's
    # share of the error that the estimated state leaves
    want = _merit(y[150:], X[150:, 0])[0]
    assert warm.outputs["y"].rmse == pytest.approx(want, rel=0.01)
    assert rest.outputs["y"].rmse > 2 * warm.outputs["y"].rmse  # from rest, the free response is missed
    given = obsnl.simulate(OSC, {"c": c, "k": k}, rec, x0={"x": x0[0], "v": x0[1]})
    assert given.start == "given" and given.outputs["y"].rmse == pytest.approx(_merit(y, X[:, 0])[0], rel=1e-6)


def test_python_refusals_name_the_problem(tmp_path):
    t, u = _input(50, 0.02, seed=9)
    rec = {"t": t, "u": u, "y": np.sin(t)}
    with pytest.raises(OptionError, match="no value for k"):
        obsnl.simulate(OSC, {"c": 1.0}, rec)
    with pytest.raises(OptionError, match="'kk', which is not a parameter"):
        obsnl.simulate(OSC, {"c": 1.0, "k": 1.0, "kk": 2.0}, rec)
    with pytest.raises(OptionError, match="finite number"):
        obsnl.simulate(OSC, {"c": 1.0, "k": float("nan")}, rec)
    with pytest.raises(OptionError, match="warm-up shorter than the record"):
        obsnl.simulate(OSC, {"c": 1.0, "k": 1.0}, rec, warmup=49)
    with pytest.raises(OptionError, match="whole number"):
        obsnl.simulate(OSC, {"c": 1.0, "k": 1.0}, rec, warmup=2.5)
    with pytest.raises(DataError, match="no column for 'y'"):
        obsnl.simulate(OSC, {"c": 1.0, "k": 1.0}, {"t": t, "u": u})
    with pytest.raises(OptionError, match="x0= names 'w'"):
        obsnl.simulate(OSC, {"c": 1.0, "k": 1.0}, rec, x0={"w": 1.0, "v": 0.0})
    other = tmp_path / "identify.json"
    other.write_text(json.dumps({"schema": "obsnl.identify/1", "model": "duffing", "parameters": []}))
    with pytest.raises(DataError, match="of model 'duffing', not of 'osc'"):
        obsnl.simulate(OSC, other, rec)


@pytest.fixture
def cli_case(tmp_path):
    t, u = _input(60, 0.02, seed=10)
    data = str(write_csv(tmp_path / "test.csv", {"time_s": t, "u": u, "y": np.sin(t)}))
    params = tmp_path / "identify.json"
    params.write_text(json.dumps({"schema": "obsnl.identify/1", "model": "osc", "parameters": [
        {"name": "c", "estimate": 0.3, "held": False}, {"name": "k", "estimate": 20.0, "held": False}]}))
    model = tmp_path / "osc.toml"
    model.write_text('name = "osc"\nstates = ["x", "v"]\nparameters = ["c", "k"]\ninputs = ["u"]\n[outputs]\ny = "x"\n'
                     '[equations]\nx = "v"\nv = "u - c*v - k*x"\n')
    return tmp_path, str(model), str(params), data


@pytest.mark.parametrize("change, message", [
    ({"data": "drop y"}, "no column for 'y'"),
    ({"--warmup": "59"}, "warm-up shorter than the record"),
    ({"params": "not json"}, "is not JSON, so not an identify.json"),
    ({"params": "other json"}, "is not an identify.json"),
    ({"params": "missing"}, "does not exist"),
    ({"params": "fifo"}, "is not a regular file"),  # read as a file it would never end
    ({"params": "text value"}, "gives c = '0.3'; give a finite number"),  # the file's path may be shortened
])
def test_command_line_refusals_are_one_line_with_exit_code_2(cli_case, change, message, capsys):
    tmp, model, params, data = cli_case
    if change.get("data") == "drop y":
        t, u = _input(60, 0.02, seed=10)
        data = str(write_csv(tmp / "short.csv", {"time_s": t, "u": u}))
    if change.get("params") == "not json":
        (tmp / "bad.json").write_text("name = 'toml, not json'\n")
        params = str(tmp / "bad.json")
    elif change.get("params") == "other json":
        (tmp / "other.json").write_text(json.dumps({"schema": "obsnl.branch-table/1", "parameters": []}))
        params = str(tmp / "other.json")
    elif change.get("params") == "missing":
        params = str(tmp / "nowhere.json")
    elif change.get("params") == "text value":
        (tmp / "identify.json").write_text(json.dumps({"schema": "obsnl.identify/1", "model": "osc", "parameters": [
            {"name": "c", "estimate": "0.3", "held": False}, {"name": "k", "estimate": 20.0, "held": False}]}))
    elif change.get("params") == "fifo":
        os.mkfifo(tmp / "fifo.json")
        params = str(tmp / "fifo.json")
    args = ["validate", model, "--params", params, "--data", data, "--out", str(tmp / "out")]
    args += [x for k, v in change.items() if k.startswith("--") for x in (k, v)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and message in err, err
    assert err.startswith("obsnl validate: error:")
    assert not (tmp / "out").exists()  # refused before anything was written


def test_the_integrator_is_the_fits():
    from obsnl.identification.runs import FIT_SUBSTEPS
    from obsnl.identification.validation.run import SUBSTEPS

    assert SUBSTEPS == FIT_SUBSTEPS


def test_zoh_input_rmse_equals_scipy():
    # a DAC holds each sample for one step: scipy integrates sample by sample with the input constant
    c, k = 0.3, 20.0
    t, u = _input(600, 0.02, seed=11)
    X, z = [np.zeros(2)], np.zeros(2)
    for i in range(len(t) - 1):
        z = solve_ivp(lambda s, w, f=u[i]: [w[1], f - c * w[1] - k * w[0]], (t[i], t[i + 1]), z, method="DOP853",
                      rtol=1e-12, atol=1e-14).y[:, -1]
        X.append(z)
    X = np.array(X)
    y = noisy(X[:, 0], 0.02, np.random.default_rng(12))[:, None]
    v = obsnl.simulate(OSC, {"c": c, "k": k}, {"t": t, "u": u, "y": y[:, 0]}, intersample="zoh")
    _check_against_scipy(v, y, X[:, :1])
    assert v.intersample == {"u": "zoh"} and any("u held (zero-order hold)" in a for a in v.assumptions)


def test_bandlimited_input_follows_a_multisine_between_samples():
    # a periodic multisine up to a fifth of the sampling rate, applied band-limited: scipy integrates it exactly
    # (the sines evaluated at any time). Linear interpolation misses it between samples by a few per cent of the
    # input; the band-limited kind (FFT, the record periodic) comes within the resolution of its 8 points a sample.
    T, dt, c, k = 1024, 0.02, 0.3, 20.0
    lines = np.arange(3, 205, 3)
    phase = np.random.default_rng(13).uniform(0, 2 * np.pi, lines.size)
    drive = lambda s: np.sum(np.sin(2 * np.pi * np.outer(s, lines) / (T * dt) + phase), axis=-1) / 6  # noqa: E731
    t = np.arange(T) * dt
    sol = solve_ivp(lambda s, w: [w[1], drive(np.atleast_1d(s))[0] - c * w[1] - k * w[0]], (0, t[-1]), [0.0, 0.0],
                    t_eval=t, method="DOP853", rtol=1e-11, atol=1e-13, max_step=dt / 8)
    rec = {"t": t, "u": drive(t), "y": sol.y[0]}
    lin = obsnl.simulate(OSC, {"c": c, "k": k}, rec, intersample="linear")
    band = obsnl.simulate(OSC, {"c": c, "k": k}, rec, intersample="u=bandlimited")
    assert band.intersample == {"u": "bandlimited"} and any("by FFT" in a for a in band.assumptions)
    assert band.outputs["y"].rmse < lin.outputs["y"].rmse / 10


def test_an_identification_runs_its_model_on_a_new_record():
    # identify on one record (a short run: the filter alone), then validate on another: the score is that of a
    # scipy simulation at the estimates, and the fit's intersample kind (zoh here) is kept
    c, k = 0.3, 20.0
    m = obsnl.Model(name="osc", states=["x", "v"], parameters=["c", "k"], inputs=["u"],
                    equations={"x": "v", "v": "u - c*v - k*x"}, outputs={"y": "x"}, guess={"c": 0.4, "k": 18.0})
    t, u = _input(600, 0.02, seed=14)
    X = _scipy(lambda z, f: [z[1], f - c * z[1] - k * z[0]], t, u, [0.0, 0.0])
    rng = np.random.default_rng(15)
    res = obsnl.identify(m, {"t": t, "u": u, "y": noisy(X[:, 0], 0.01, rng)}, passes=1, refine=False,
                         progress=False, jit=False)
    est = res.estimates()
    t2, u2 = _input(800, 0.02, seed=16)
    X2 = _scipy(lambda z, f: [z[1], f - est["c"] * z[1] - est["k"] * z[0]], t2, u2, [0.0, 0.0])
    y2 = noisy(X2[:, 0], 0.01, rng)[:, None]
    v = res.simulate({"t": t2, "u": u2, "y": y2[:, 0]})
    _check_against_scipy(v, y2, X2[:, :1])
    assert v.parameters == est and v.intersample == {"u": "linear"}
    held = obsnl.identify(m, {"t": t, "u": u, "y": noisy(X[:, 0], 0.01, rng)}, passes=1, refine=False,
                          progress=False, jit=False, intersample="zoh")
    assert held.simulate({"t": t2, "u": u2, "y": y2[:, 0]}).intersample == {"u": "zoh"}
    with pytest.raises(OptionError, match="keeps no model"):
        dataclasses.replace(res, fitted_model=None).simulate({"t": t2, "u": u2, "y": y2[:, 0]})


def test_command_line_intersample_option(cli_case, capsys):
    tmp, model, params, data = cli_case
    out = tmp / "held"
    assert main(["validate", model, "--params", params, "--data", data, "--out", str(out), "--intersample", "u=zoh"]) == 0
    assert "input u held (zero-order hold)" in capsys.readouterr().out
    assert json.loads((out / "validate.json").read_text())["intersample"] == {"u": "zoh"}
    assert main(["validate", model, "--params", params, "--data", data, "--out", str(tmp / "x"), "--intersample",
                 "u=cubic"]) == 2
    assert "kind 'cubic' for u is unknown" in capsys.readouterr().err
