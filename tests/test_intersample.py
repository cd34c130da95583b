"""Inputs between samples: zero-order hold, linear and band-limited (obsnl.estimation.intersample).

Expected answers come from numpy's own sinusoids, closed-form integrals and scipy's solve_ivp, never from obsnl.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.errors import ModelError, OptionError
from obsnl.estimation.codegen import to_casadi
from obsnl.estimation.intersample import between_samples, blocks, drive, intersample_kinds, is_periodic, upsample
from obsnl.estimation.simulate import simulate


def multisine(T: int, lines: range, seed: int) -> tuple[np.ndarray, callable]:
    """A periodic random-phase multisine of period ``T`` samples and its continuous-time form."""
    phases = np.random.default_rng(seed).uniform(0, 2 * np.pi, len(lines))

    def at(t: np.ndarray) -> np.ndarray:
        return sum(np.cos(2 * np.pi * k * t / T + ph) for k, ph in zip(lines, phases))

    return at(np.arange(T, dtype=float)), at


@pytest.mark.parametrize("T", [512, 511])
def test_bandlimited_is_exact_on_a_periodic_multisine(T):
    # lines up to 0.45 of the sampling rate, the Nyquist bin included for an even length: zero-padding the FFT
    # reproduces the continuous multisine at every point in between (to rounding)
    top = T // 2
    u, at = multisine(T, range(3, top + 1, 7), seed=1)
    if T % 2 == 0:  # a Nyquist line, cos(pi t) through the samples, is real: its band-limited form is cos(pi t)
        u = u + np.cos(np.pi * np.arange(T))
        exact = at(np.arange(4 * T) / 4) + np.cos(np.pi * np.arange(4 * T) / 4)
    else:
        exact = at(np.arange(4 * T) / 4)
    assert is_periodic(u)
    fine = upsample(u, 4)
    assert np.abs(fine - exact).max() < 1e-9 * np.abs(exact).max()


def test_bandlimited_sinc_for_a_record_that_is_not_periodic():
    # a sine at 0.131 of the sampling rate over 400 samples (not an integer number of periods): the windowed sinc
    # is accurate to 1e-4 away from the ends; the ends (reflected) are approximate
    t = np.arange(400)
    u = np.sin(2 * np.pi * 0.131 * t + 0.3)
    assert not is_periodic(u)
    fine = upsample(u, 8)
    exact = np.sin(2 * np.pi * 0.131 * np.arange(400 * 8) / 8 + 0.3)
    inner = slice(8 * 16, 8 * (400 - 17))
    assert np.abs(fine - exact)[inner].max() < 1e-4
    assert np.array_equal(fine[::8], u)  # the samples themselves are kept


def test_blocks_layout_for_each_kind():
    u = np.array([[1.0, 10.0], [3.0, 30.0], [5.0, 50.0]])
    B, m = blocks(u, ["zoh", "linear"])
    assert m == 1
    # row k: [u(t_k) of both inputs, u(t_{k+1}^-) of both]; zoh holds, linear reaches the next sample
    assert B.tolist() == [[1.0, 10.0, 1.0, 30.0], [3.0, 30.0, 3.0, 50.0], [5.0, 50.0, 5.0, 50.0]]
    assert blocks(u, ["linear", "linear"])[1] == 0  # all linear: the classic pair, no blocks


def test_kinds_parsing_and_refusals():
    assert intersample_kinds("bandlimited", ["u"]) == {"u": "bandlimited"}
    assert intersample_kinds(["u=zoh"], ["u", "v"]) == {"u": "zoh", "v": "linear"}
    assert intersample_kinds(None, ["u", "v"], table={"v": "zoh"}) == {"u": "linear", "v": "zoh"}
    assert intersample_kinds("bandlimited", ["u", "v"], table={"v": "zoh"}) == {"u": "bandlimited", "v": "bandlimited"}
    with pytest.raises(OptionError, match="not an input"):
        intersample_kinds(["w=zoh"], ["u"])
    with pytest.raises(OptionError, match="unknown"):
        intersample_kinds("foh", ["u"])
    with pytest.raises(OptionError, match="not 5"):
        intersample_kinds([5], ["u"])


def test_model_file_intersample_table(tmp_path):
    text = """name = "held"
states = ["x"]
parameters = ["a"]
inputs = ["u"]
[outputs]
y = "x"
[equations]
x = "-a*x + u"
[intersample]
u = "zoh"
"""
    (tmp_path / "held.toml").write_text(text)
    model = obsnl.read_model(tmp_path / "held.toml")
    assert dict(model.intersample) == {"u": "zoh"}
    assert model.to_dict()["intersample"] == {"u": "zoh"}
    with pytest.raises(ModelError, match="not an input"):
        obsnl.Model(name="h", states=["x"], parameters=["a"], inputs=["u"], equations={"x": "-a*x + u"},
                    outputs={"y": "x"}, intersample={"w": "zoh"})
    with pytest.raises(ModelError, match="use one of"):
        obsnl.Model(name="h", states=["x"], parameters=["a"], inputs=["u"], equations={"x": "-a*x + u"},
                    outputs={"y": "x"}, intersample={"u": "cubic"})


OSC = obsnl.Model(name="osc", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
                  equations={"x": "v", "v": "-k*x - c*v + u"}, outputs={"y": "x"}, values={"k": 400.0, "c": 2.0})


@pytest.mark.parametrize("kind", ["zoh", "linear", "bandlimited"])
def test_simulation_matches_scipy_under_each_kind(kind):
    # an oscillator at 3.2 Hz driven by a periodic multisine sampled at 50 Hz (lines up to 12 Hz): scipy integrates
    # the continuous input each kind describes (held, linear, or the multisine itself); obsnl's driven step agrees
    dt, T = 0.02, 250
    u, at = multisine(T, range(2, 61, 3), seed=3)
    t = np.arange(T) * dt
    if kind == "zoh":
        def force(s):
            return u[min(int(np.floor(s / dt + 1e-12)), T - 1)]
    elif kind == "linear":
        def force(s):
            return np.interp(s, t, u)
    else:  # the multisine at 8 points per sample (exact there, by the FFT), linear between them (POINTS = 8)
        fine_t = np.arange(8 * T) * dt / 8
        fine_u = at(fine_t / dt)

        def force(s):
            return np.interp(s, fine_t, fine_u)
    k, c = 400.0, 2.0
    sol = solve_ivp(lambda s, z: [z[1], -k * z[0] - c * z[1] + force(s)], (0, t[-1]), [0.0, 0.0], t_eval=t,
                    rtol=1e-10, atol=1e-12, max_step=dt / 8)
    num = to_casadi(OSC)
    stepped, U = drive(num, u[:, None], {"u": kind})
    sim = simulate(stepped, theta=[k, c], x0=[0.0, 0.0], u=U, dt=dt, substeps=64)
    err = np.abs(sim.y[:, 0] - sol.y[0]).max() / np.abs(sol.y[0]).max()
    assert err < 1e-5, err
    if kind == "bandlimited":
        # against the continuous multisine itself: linear between 8 points per sample errs by at most
        # (2 pi f / 8)^2 / 8 of a line's amplitude, 4.4e-3 for the top line at f = 0.24 cycles per sample, and far
        # less in the response of an oscillator tuned to 0.064 cycles per sample
        sol = solve_ivp(lambda s, z: [z[1], -k * z[0] - c * z[1] + at(s / dt)], (0, t[-1]), [0.0, 0.0], t_eval=t,
                        rtol=1e-10, atol=1e-12, max_step=dt / 8)
        assert np.abs(sim.y[:, 0] - sol.y[0]).max() / np.abs(sol.y[0]).max() < 1e-3


def test_between_samples_says_when_the_choice_matters():
    # a multisine up to 0.4 of the sampling rate: linear and held inputs differ from its band-limited form by
    # several per cent between samples; one up to 0.02 of the sampling rate: by less than 1 %
    fast, _ = multisine(4096, range(20, 1640, 16), seed=4)
    slow, _ = multisine(4096, range(2, 80, 4), seed=5)
    for kind in ("linear", "zoh"):
        assert between_samples(fast, ["u"], {"u": kind})[0].matters
    assert not between_samples(slow, ["u"], {"u": "linear"})[0].matters
    bl = between_samples(fast, ["u"], {"u": "bandlimited"})[0]
    assert bl.route == "fft" and not bl.matters


def test_driven_model_refuses_misuse():
    num = to_casadi(OSC)
    with pytest.raises(ModelError, match="at least 1"):
        num.driven(0)
    with pytest.raises(ModelError, match="already driven"):
        num.driven(2).driven(2)


def test_identify_takes_intersample_repeated_and_a_study_is_not_refused_without_it():
    """``--intersample`` given twice keeps both (it kept only the last); not given, a record study runs as before."""
    from obsnl.cli import build_parser

    args = build_parser().parse_args(
        ["identify", "m.toml", "--data", "d.csv", "--intersample", "u=zoh", "--intersample", "w=linear"]
    )
    assert args.intersample == ["u=zoh", "w=linear"]
    assert build_parser().parse_args(["identify", "m.toml", "--record", "r.csv"]).intersample == []
