"""What an experiment visits between its samples (issues 41 and 40, the ``design`` part): ``obsnl design`` reads the
branches along the continuous trajectory (:mod:`obsnl.design.continuous`), not at the sample times.

Every expected answer is derived here, not read from obsnl:

* **the sampling rate.** A first-order system ``x' = -a x + u`` with a stop at ``x = g`` (``kc*Max(x - g, 0)``) is
  linear until it first reaches the stop, and under ``u = sin(pi t)`` from rest its response is, in closed form,
  ``x1(t) = (a sin(w t) - w cos(w t) + w exp(-a t)) / (a^2 + w^2)``: the smallest scale that reaches the stop
  (where ``kc`` and ``g`` act) is ``g / max x1``, the maximum over the record taken on a dense grid and polished
  with ``scipy.optimize.minimize_scalar``. The input is a whole number of periods of one sine below the Nyquist
  frequency, read as band-limited: the same signal at 8 and at 20 samples per period. At 8 the peak falls between
  samples (the largest sample is 1.9 % lower), so a reading at the samples moved the threshold by that much.
* **sticking.** A mass on a spring with Coulomb friction (``obsnl:coulomb_friction``: ``m v' = u - c v - k x - F_c
  sign(v)``, ``F_c = 0.5``) at rest at ``x = 0`` under ``u = s sin t``: while ``|u - k x| <= F_c`` the friction
  holds it (Filippov's sliding solution is rest), so below ``s = F_c`` it never moves and visits no branch of
  ``sign(v)``; above, it breaks loose at ``sin t = F_c / s`` into ``v > 0``. :func:`stick_slip` integrates the
  same law phase by phase with ``scipy.integrate.solve_ivp`` (events at ``v = 0``, breakaway by ``brentq``): the
  slips and their directions, with no reference to obsnl. On a slip branch ``m v' = u - c v - k x - F_c`` is
  linear in ``1/m, c/m, k/m, F_c/m`` with the known regressors ``u, v, x, 1``: one slip makes the four parameters
  identifiable, so the smallest sufficient scale is ``F_c`` itself.
* **known initial conditions.** The same mass released from a known ``x(0) = 0.05`` under no force: ``k x(0) = 2 >
  F_c``, it slips back (``v < 0``), then forward (:func:`stick_slip` says so), although the input is zero.
* **the input between samples.** ``x' = u - kc*Max(x - g, 0)`` from rest under the samples ``u = 1`` for ``K`` samples
  and 0 after: held (``zoh``), ``x`` reaches ``K dt`` before the stop acts; linear, the last unit sample ramps to 0
  over one interval, so ``x`` reaches ``(K - 1/2) dt`` and stops there. With ``g = (K - 1/4) dt`` the held input
  reaches the stop (a visit of the contact branch, sign -1 of ``g - x``), the linear one does not.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

import obsnl
from obsnl import Model
from obsnl.cli import main
from obsnl.design.continuous import continuous_visits
from obsnl.design.experiment import design
from obsnl.errors import DataError, OptionError

# --------------------------------------------------------------------------- the sampling rate
STOP = {"a": 1.0, "kc": 5.0, "g": 0.5}
W = np.pi  # the input's angular frequency: a period of 2 s


def stop_model() -> Model:
    return Model(name="stop", states=["x"], parameters=list(STOP), inputs=["u"],
                 equations={"x": "-a*x + u - kc*Max(x - g, 0)"}, outputs={"y": "x"}, values=dict(STOP))


def free_response(t: np.ndarray | float) -> np.ndarray | float:
    """``x1``: the response of ``x' = -a x + u`` to ``u = sin(W t)`` from rest (a = 1)."""
    return (np.sin(W * t) - W * np.cos(W * t) + W * np.exp(-t)) / (1 + W * W)


def sine_record(per_period: int) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(3 * per_period) * (2.0 / per_period)  # three whole periods: periodic, band-limited
    return t, np.sin(W * t)


def stop_threshold(t_end: float) -> float:
    """``g / max x1`` over ``[0, t_end]``."""
    dense = np.linspace(0.0, t_end, 200_001)
    k = int(np.argmax(free_response(dense)))
    best = minimize_scalar(lambda s: -free_response(s), bounds=(dense[max(k - 1, 0)], dense[min(k + 1, 200_000)]),
                           method="bounded", options={"xatol": 1e-12})
    return STOP["g"] / float(free_response(best.x))


def test_the_smallest_scale_does_not_move_with_the_sampling_rate() -> None:
    found = []
    for per in (8, 20):
        t, u = sine_record(per)
        threshold = stop_threshold(t[-1])
        if per == 8:  # the premise: at the samples alone the peak is clearly lower
            assert STOP["g"] / float(np.max(free_response(t))) > threshold * 1.01
        d = design(stop_model(), [("sine", t, {"u": u})], intersample="bandlimited")
        assert d.status == "found", d.reason
        lo, hi = d.bracket
        assert (hi - lo) / hi <= d.tol
        assert lo <= threshold * (1 + 1e-5) and threshold * (1 - 1e-5) <= hi, (per, threshold, d.bracket)
        assert d.assumptions.between_samples == {"u": "bandlimited"}
        found.append(d.min_scale)
    assert abs(found[0] - found[1]) <= 1e-3 * max(found)  # within the relative width design claims


def test_a_contact_between_two_samples_is_a_visit() -> None:
    """``x = sin t`` from ``v(0) = 1``, sampled every 0.35 s: the samples at 1.4 and 1.75 s are below ``g = 0.995``,
    the motion between them above it for ``|t - pi/2| < acos(0.995) = 0.1`` s (before the contact acts)."""
    m = Model(name="touch", states=["x", "v"], parameters=["kc", "g"], inputs=["u"],
              equations={"x": "v", "v": "u - x - kc*Max(x - g, 0)"}, outputs={"y": "x"},
              values={"kc": 10.0, "g": 0.995, "x": 0.0, "v": 1.0})
    t = 0.35 * np.arange(10)
    assert np.max(np.sin(t)) < 0.995 < 1.0
    vis = continuous_visits(m, t, {"u": np.zeros_like(t)})
    assert set(vis.patterns) == {(1,), (-1,)} and vis.crossings == {"g - x": 2}
    assert 0.0 < vis.patterns[(-1,)] < 0.35  # in contact between two samples, for less than one interval


# --------------------------------------------------------------------------- sticking
FRICTION = {"m": 1.0, "c": 0.2, "k": 40.0, "F_c": 0.5}


def stick_slip(force, x0: float, t_end: float) -> list[int]:
    """The directions of the slips of ``m x'' + c x' + k x + F_c sign(x') = force(t)`` from rest at ``x0``."""
    m, c, k, fc = FRICTION.values()
    t, x, slips = 0.0, x0, []
    while t < t_end:
        def excess(s: float, x: float = x) -> float:  # > 0: the force overcomes friction at rest
            return abs(force(s) - k * x) - fc
        if excess(t) <= 0:  # stuck: wait for the breakaway
            grid = np.arange(t, t_end, 1e-3)
            above = np.flatnonzero([excess(s) > 0 for s in grid])
            if not len(above):
                return slips
            t = brentq(excess, grid[above[0] - 1], grid[above[0]], xtol=1e-14) + 1e-12
        d = 1 if force(t) - k * x > 0 else -1
        slips.append(d)

        def halt(s: float, z: np.ndarray, d: int = d, start: float = t) -> float:
            return z[1] if s > start else d  # v returns to 0
        halt.terminal = True  # type: ignore[attr-defined]
        sol = solve_ivp(lambda s, z, d=d: [z[1], (force(s) - c * z[1] - k * z[0] - fc * d) / m], (t, t_end),
                        [x, 0.0], events=halt, rtol=1e-10, atol=1e-13)
        if not len(sol.t_events[0]):
            return slips
        t, x = float(sol.t_events[0][0]), float(sol.y_events[0][0][0])
    return slips


def test_a_mass_that_friction_holds_visits_no_branch() -> None:
    f = obsnl.read_model("obsnl:coulomb_friction")
    assert {n: f.values[n] for n in FRICTION} == FRICTION and (f.values["x"], f.values["v"]) == (0.0, 0.0)
    t = np.arange(0.0, 4 * np.pi, 0.05)
    for scale in (0.001, 0.45, 0.499):
        assert stick_slip(lambda s, a=scale: a * np.sin(s), 0.0, t[-1]) == []
        vis = continuous_visits(f, t, {"u": scale * np.sin(t)})
        assert vis.patterns == {} and vis.crossings == {"v": 0}, scale  # stuck is stuck: no chatter across v = 0
    slips = stick_slip(lambda s: 0.55 * np.sin(s), 0.0, t[-1])
    assert slips[0] == 1
    vis = continuous_visits(f, t, {"u": 0.55 * np.sin(t)})
    assert list(vis.patterns)[0] == (1,) and set(vis.patterns) == {(d,) for d in slips}


def test_design_finds_the_breakaway_force() -> None:
    f = obsnl.read_model("obsnl:coulomb_friction")
    t = np.arange(0.0, 4 * np.pi, 0.05)
    d = design(f, [("sine", t, {"u": np.sin(t)})], target="parameters", scales=[0.001, 0.25, 0.45, 0.55, 1.0])
    fc = FRICTION["F_c"]
    assert d.status == "found", d.reason
    lo, hi = d.bracket
    assert lo <= fc * (1 + 1e-4) and fc <= hi <= fc * (1 + 2e-3)
    for v in d.visits:
        assert (v.branches == ()) is (v.scale <= fc), v.scale  # below F_c: held, no branch, insufficient
        if v.scale <= fc:
            assert v.sufficient is False and set(v.missing) == set(FRICTION)


# --------------------------------------------------------------------------- known initial conditions
def test_a_free_decay_from_a_known_displacement_visits_branches() -> None:
    f = obsnl.read_model("obsnl:coulomb_friction")
    known = f.replace(known_initial_conditions=["x", "v"], initial_condition_values={"x": 0.05, "v": 0.0})
    t = np.arange(0.0, 3.0, 0.05)
    zero = np.zeros_like(t)
    slips = stick_slip(lambda s: 0.0, 0.05, t[-1])
    assert slips[:2] == [-1, 1]
    vis = continuous_visits(known, t, {"u": zero})
    assert list(vis.patterns)[:2] == [(-1,), (1,)] and vis.crossings == {"v": len(slips) - 1}
    assert continuous_visits(f, t, {"u": zero}).patterns == {}  # from the [values]' rest, nothing moves
    d = design(known, [("rest", t, {"u": zero})], target="parameters", scales=[0.5, 1.0])
    assert d.assumptions.initial_state == {"x": "0.05 (known initial condition)", "v": "0 (known initial condition)"}
    assert all({b.signs for b in v.branches} == {(-1,), (1,)} for v in d.visits)  # the input's scale changes nothing
    assert d.status == "smallest_suffices"


# --------------------------------------------------------------------------- the input between samples
DT, K = 0.1, 10
PULSE_T = DT * np.arange(30)
PULSE_U = (np.arange(30) < K).astype(float)
GAP = (K - 0.25) * DT


def pulse_model(**intersample: str) -> Model:
    return Model(name="pulse", states=["x"], parameters=["kc", "g"], inputs=["u"],
                 equations={"x": "u - kc*Max(x - g, 0)"}, outputs={"y": "x"}, values={"kc": 5.0, "g": GAP},
                 intersample=intersample)


def visited_at_one(model: Model, **options) -> set:
    d = design(model, [("pulse", PULSE_T, {"u": PULSE_U})], scales=[1.0], target="parameters", **options)
    (v,) = d.visits
    return {b.pattern for b in v.branches}


def test_a_held_input_and_a_linear_one_visit_different_branches() -> None:
    assert K * DT > GAP > (K - 0.5) * DT  # the premise: only the held input reaches the stop
    assert visited_at_one(pulse_model(), intersample="zoh") == {"+", "-"}
    assert visited_at_one(pulse_model(), intersample="linear") == {"+"}
    assert visited_at_one(pulse_model()) == {"+"}  # linear by default
    assert visited_at_one(pulse_model(u="zoh")) == {"+", "-"}  # the model's [intersample] table
    assert visited_at_one(pulse_model(u="zoh"), intersample="u=linear") == {"+"}  # the option wins


def test_the_command_takes_intersample(tmp_path, capsys) -> None:
    model = tmp_path / "pulse.toml"
    model.write_text('name = "pulse"\nstates = ["x"]\nparameters = ["kc", "g"]\ninputs = ["u"]\n'
                     '[equations]\nx = "u - kc*Max(x - g, 0)"\n[outputs]\ny = "x"\n'
                     f'[values]\nkc = 5.0\ng = {GAP!r}\n')
    rec = tmp_path / "pulse.csv"
    rec.write_text("time_s,accel_m_s2\n" + "\n".join(f"{a:.17g},{b:g}" for a, b in zip(PULSE_T, PULSE_U)) + "\n")
    seen = {}
    for kind in ("zoh", "linear"):
        args = ["design", str(model), "--record", str(rec), "--scales", "1", "--target", "parameters",
                "--format", "json", "--intersample", kind]
        main(args)  # exit 2 where nothing suffices (said on stderr); the visits are printed all the same
        doc = json.loads(capsys.readouterr().out)
        seen[kind] = {p["pattern"] for p in doc["visited"][0]["patterns"]}
        assert doc["assumptions"]["between samples"] == {"u": kind}
    assert seen == {"zoh": {"+", "-"}, "linear": {"+"}}
    main(["design", str(model), "--record", str(rec), "--scales", "1", "--intersample", "u=zoh"])
    out = capsys.readouterr().out
    assert "simulated: along the continuous trajectory; input between samples: u zoh; from x = 0" in out
    assert main(["design", str(model), "--record", str(rec), "--intersample", "cubic"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "'cubic'" in err and "zoh, linear or bandlimited" in err


def test_an_irregular_clock_is_refused_in_one_line() -> None:
    t = np.array([0.0, 0.1, 0.25, 0.3, 0.4])
    with pytest.raises(DataError, match="irregular time step") as err:
        design(stop_model(), [("r", t, {"u": np.sin(t)})], scales=[1.0])
    assert "\n" not in str(err.value)


# --------------------------------------------------------------------------- hostile values of the new option
_HEALTH = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much]
KINDS = {"zoh", "linear", "bandlimited"}


def _bad_kind(text: str) -> bool:
    name, _, kind = text.rpartition("=")
    return kind.strip() not in KINDS or (bool(name) and name.strip() != "u") or "=" in name


@pytest.fixture(scope="module")
def pulse_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pulse")
    (folder / "pulse.toml").write_text('name = "pulse"\nstates = ["x"]\nparameters = ["kc", "g"]\ninputs = ["u"]\n'
                                       '[equations]\nx = "u - kc*Max(x - g, 0)"\n[outputs]\ny = "x"\n'
                                       f'[values]\nkc = 5.0\ng = {GAP!r}\n')
    (folder / "pulse.csv").write_text("time_s,accel_m_s2\n" + "\n".join(f"{a:.17g},{b:g}" for a, b in
                                                                        zip(PULSE_T, PULSE_U)) + "\n")
    return folder


# derandomized: the same examples on every run (no error probability); each example is refused before any simulation
@settings(max_examples=60, deadline=None, derandomize=True, database=None, suppress_health_check=_HEALTH)
@given(st.one_of(st.text(max_size=40), st.sampled_from(["", "=", "u=", "=zoh", "v=zoh", "ZOH", "zoh ", "u==zoh",
                                                         "u=cubic", "x" * 10_000, "bandlimited,zoh"])))
def test_a_bad_intersample_value_is_one_line_error(pulse_files, capsys, text: str) -> None:
    if not _bad_kind(text):
        return
    with pytest.raises(OptionError) as err:
        design(pulse_model(), [("pulse", PULSE_T, {"u": PULSE_U})], scales=[1.0], intersample=text)
    assert "\n" not in str(err.value) and len(str(err.value)) < 400
    code = main(["design", str(pulse_files / "pulse.toml"), "--record", str(pulse_files / "pulse.csv"),
                 f"--intersample={text}"])
    out, err_text = capsys.readouterr()
    assert code == 2 and out == "" and err_text.count("\n") == 1 and len(err_text) < 500, err_text
