"""Guards that can never hold are proved empty before any random search (issue 41), and declared bounds prune the
sign patterns that cannot occur.

Every expected answer is derived here: the completed squares are checked with sympy's ``expand`` (an identity, not
obsnl's output), and the bounds' consequences follow from the sign of a product. A feasibility call that must not
search is given no random source at all (``rng=None``): reaching the random search would raise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from obsnl import Model
from obsnl.cli import main
from obsnl.model.branching.branches import split_branches
from obsnl.model.branching.definite import never_positive
from obsnl.model.branching.feasibility import feasible

X, V, K = sp.symbols("x v k", real=True)

#: (x - v)**2 + v**2 + 1 expanded: sympy no longer sees its sign, so the switching function reaches the split.
SOS = X**2 - 2 * X * V + 2 * V**2 + 1


def test_the_sum_of_squares_is_what_the_tests_say_it_is():
    assert sp.expand((X - V) ** 2 + V**2 + 1 - SOS) == 0
    assert sp.expand((X + V / 2) ** 2 + 3 * V**2 / 4 - (X**2 + X * V + V**2)) == 0
    assert sp.expand((X**2 - V) ** 2 + 1 - (X**4 - 2 * X**2 * V + V**2 + 1)) == 0


@pytest.mark.parametrize("g", [SOS, X**2 + X * V + V**2, X**4 - 2 * X**2 * V + V**2 + 1,
                               sp.sin(X) ** 2 - 2 * sp.sin(X) * V + 2 * V**2 + sp.Rational(1, 10)])
def test_a_function_that_is_never_negative_has_no_negative_branch_and_no_search_is_run(g):
    # each g is a sum of squares (plus a positive constant), identities checked above; sin(x) is one more real unknown
    point, reason, proved = feasible([(g, -1)], None)  # type: ignore[arg-type]  # no rng: a search would raise
    assert point is None and proved
    assert "holds nowhere" in reason and "negative semidefinite" in reason


def test_an_indefinite_quadratic_is_not_proved_empty():
    # x**2 - 3*x*v + 2*v**2 + 1 = (x - v)*(x - 2*v) + 1 is -0.17 at (3.5, 2.2): the negative side is not empty
    g = X**2 - 3 * X * V + 2 * V**2 + 1
    assert float(g.subs({X: 3.5, V: 2.2})) < 0
    assert never_positive(-g) == ""
    point, _, proved = feasible([(g, -1)], np.random.default_rng(1))
    assert proved and point is not None and float(g.subs({X: point["x"], V: point["v"]})) < 0


def test_a_definite_form_keeps_its_one_side():
    # x**2 + x*v + v**2 > 0 everywhere but the origin: that side has a point, the other none
    g = X**2 + X * V + V**2
    assert feasible([(g, 1)], np.random.default_rng(0))[0] is not None
    assert feasible([(g, -1)], None)[2]  # type: ignore[arg-type]


def _sos_file(folder):
    path = folder / "sos.toml"
    path.write_text('name = "sos"\nstates = ["x", "v"]\nparameters = ["k"]\ninputs = ["u"]\n[outputs]\ny = "x"\n'
                    '[equations]\nx = "v"\nv = "u - k*x - x*Heaviside(-(x**2 - 2*x*v + 2*v**2 + 1))"\n',
                    encoding="utf-8")
    return path


def test_analyze_decides_the_empty_guard_and_exits_0(tmp_path, capsys):
    # the Heaviside is 0 everywhere ((x - v)**2 + v**2 + 1 >= 1): one branch, the oscillator x'' = u - k x
    assert main(["analyze", str(_sos_file(tmp_path)), "--seed", "1"]) == 0
    out = capsys.readouterr()
    assert "inconclusive" not in out.out.lower() and "undecided" not in out.out.lower()
    assert "error" not in out.err
    branches, dropped = split_branches(Model.from_dict({
        "name": "sos", "states": ["x", "v"], "parameters": ["k"], "inputs": ["u"], "outputs": {"y": "x"},
        "equations": {"x": "v", "v": "u - k*x - x*Heaviside(-(x**2 - 2*x*v + 2*v**2 + 1))"}}), with_dropped=True)
    assert len(branches) == 1 and sp.expand(branches[0].model.equations[V] - (sp.Symbol("u", real=True) - K * X)) == 0
    assert [d.proved for d in dropped] == [True]


# --------------------------------------------------------------------------- declared bounds prune branches
def _friction(**extra):
    return Model(name="relay", states=["x", "v"], parameters=["k", "fy"], inputs=["u"],
                 equations={"x": "v", "v": "u - k*x - fy*sign(fy*v)"}, outputs={"y": "x"}, **extra)


def test_a_positive_parameter_halves_the_branches_of_its_sign():
    # sign(fy*v) switches on fy and on v: four sign patterns; with fy > 0 only the two with fy > 0 can occur
    free = split_branches(_friction())
    assert sorted(b.signs for b in free) == [(-1, -1), (-1, 1), (1, -1), (1, 1)]
    bounded, dropped = split_branches(_friction(bounds={"fy": "positive"}), with_dropped=True)
    assert sorted(b.signs for b in bounded) == [(1, -1), (1, 1)]
    assert all(d.proved and "declared bounds" in d.reason for d in dropped)
    assert all(b.witness["fy"] > 0 for b in bounded)


def test_finite_bounds_prune_a_gap_that_cannot_close():
    # a contact at x > g with the gap declared in [1, 2] and the displacement bounded by nothing: both sides occur;
    # the switching function g - 3 (a guard on the known constant alone) cannot be positive with g <= 2
    m = Model(name="gap", states=["x", "v"], parameters=["k"], known_constants=["g"], inputs=["u"],
              equations={"x": "v", "v": "u - k*x - Heaviside(x - g) - Heaviside(g - 3)*x"}, outputs={"y": "x"},
              bounds={"g": [1, 2]})
    branches = split_branches(m)
    assert {b.signs[_index(b, "g - 3")] for b in branches} == {-1}
    assert {b.signs[_index(b, "-g + x")] for b in branches} == {-1, 1}
    assert all(1 <= b.witness["g"] <= 2 for b in branches)


def _index(branch, text):
    target = sp.sympify(text, locals={"g": sp.Symbol("g", real=True), "x": X})
    return next(i for i, f in enumerate(branch.switching) if sp.expand(f - target) == 0 or sp.expand(f + target) == 0)


def test_the_bounds_table_round_trips_through_a_model_file(tmp_path):
    from obsnl import read_model
    from obsnl.model.files import model_to_toml

    m = _friction(bounds={"fy": "positive", "k": [0.5, "inf"]})
    path = tmp_path / "relay.toml"
    path.write_text(model_to_toml(m), encoding="utf-8")
    back = read_model(path)
    assert dict(back.bounds) == {"fy": (0.0, math.inf), "k": (0.5, math.inf)} and back == m
    assert back.fingerprint != _friction().fingerprint  # a table made without the bounds is not this model's
    assert _friction().fingerprint == Model.from_dict(_friction().to_dict()).fingerprint


def test_every_answer_states_the_bounds_it_assumed(capsys, tmp_path):
    from obsnl import analyze
    from obsnl.design.sensors import sensors
    from obsnl.model.files import model_to_toml
    from obsnl.report.sensors import render_sensors

    m = _friction(bounds={"fy": "positive"})
    res = analyze(m, seed=1)
    assert res.assumptions.to_dict()["bounds"] == {"fy": [0.0, "inf"]}
    assert {b.label for b in res.branches} == {"a", "b"}  # the two sides of v, fy > 0 in both
    path = tmp_path / "relay.toml"
    path.write_text(model_to_toml(m), encoding="utf-8")
    assert main(["analyze", str(path), "--seed", "1"]) == 0
    assert "assumes: declared bounds fy > 0" in capsys.readouterr().out
    assert "declared bounds fy > 0" in render_sensors(sensors(m, target="k"))
    assert "bounds" not in analyze(_friction(), seed=1).to_dict()["assumptions"]  # nothing declared, nothing said
