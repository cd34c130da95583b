"""The frozen Model: construction, validation at the door, round trips."""

from __future__ import annotations

import json

import pytest
import sympy as sp

import obsnl
from obsnl import Model, ModelError, ParseError
from obsnl.model.reading.parse import make_symbol, parse_expression

from .conftest import MODEL_FILES, PEER_CASE_FILES


def msd(**over):
    d = dict(name="msd", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
             equations={"x": "v", "v": "u - k*x - c*v"}, outputs={"y": "x"})
    d.update(over)
    return Model(**d)


def test_basic_model_and_views():
    m = msd()
    x, v, k, c, u = (make_symbol(n) for n in "x v k c u".split())
    assert m.states == (x, v) and m.parameters == (k, c) and m.inputs == (u,)
    assert m.rhs == (v, u - k * x - c * v)
    assert m.outputs["y"] == x
    assert m.variables == (x, v, k, c)
    assert m.is_smooth
    assert m.role("k") == "parameter" and m.role("u") == "input"


def test_model_is_frozen():
    m = msd()
    with pytest.raises(AttributeError):
        m.name = "other"  # type: ignore[misc]
    with pytest.raises(TypeError):
        m.equations[m.states[0]] = sp.Integer(0)  # type: ignore[index]


def test_sympy_builtin_names_are_plain_symbols():
    m = Model(name="b", states=["S", "I", "E", "N"], parameters=["beta", "gamma", "Q", "C"],
              equations={"S": "-beta*S*I/N", "I": "beta*S*I/N - gamma*I", "E": "Q*E - C", "N": "0"},
              outputs={"y": "I + E"})
    S, I = m.symbol("S"), m.symbol("I")
    assert m.equations[S] == -m.symbol("beta") * S * I / m.symbol("N")
    assert all(isinstance(s, sp.Symbol) for s in m.variables)


def test_sympy_expressions_are_adopted_by_name():
    x, v, k = sp.symbols("x v k")  # plain user symbols, no assumptions
    m = Model(name="s", states=[x, v], parameters=[k], equations={x: v, v: -k * x}, outputs={"y": x})
    assert m.equations[m.symbol("v")] == -m.symbol("k") * m.symbol("x")


def test_floats_become_exact_rationals():
    m = msd(equations={"x": "v", "v": "u - 0.1*k*x - 9.81*c*v"})
    e = m.equations[m.symbol("v")]
    assert all(a.is_Rational for a in e.atoms(sp.Number))
    assert sp.Rational(981, 100) in e.atoms(sp.Number) or sp.Rational(-981, 100) in e.atoms(sp.Number)


def test_caret_is_power():
    syms = {"x": make_symbol("x")}
    assert parse_expression("x^2", syms) == syms["x"] ** 2


@pytest.mark.parametrize(
    "over, match",
    [
        ({"equations": {"x": "v", "v": "u - kk*x"}}, r"undeclared symbol 'kk'.*did you mean 'k'"),
        ({"outputs": {"y": "x + z"}}, r"output y: undeclared symbol 'z'"),
        ({"parameters": ["k", "c", "k"]}, r"declared twice"),
        ({"parameters": ["k", "c", "u"]}, r"'u' is declared both as a parameter and as a input"),
        ({"equations": {"x": "v"}}, r"state 'v' has no equation"),
        ({"equations": {"x": "v", "v": "-k*x", "w": "x"}}, r"equation for undeclared state 'w'"),
        ({"equations": {"x": "v", "v": "-k*x", "k": "x"}}, r"'k'.*is a parameter, not a state"),
        ({"equations": {"x": "v", "v": "foo(x)"}}, r"unknown function 'foo'"),
        ({"equations": {"x": "v", "v": "gamma(x)"}}, r"unknown function 'gamma'"),
        ({"equations": {"x": "v", "v": "erf(x)"}}, r"unknown function 'erf'"),
        ({"equations": {"x": "v", "v": "(k*x"}}, r"syntax error in '\(k\*x'"),
        ({"equations": {"x": "v", "v": "k*x +"}}, r"syntax error in 'k\*x \+'"),
        ({"equations": {"x": "v", "v": "-k*y"}}, r"output 'y' appears on a right-hand side"),
        ({"equations": {"x": "v", "v": "x.func"}}, r"unexpected '\.'"),
        ({"equations": {"x": "v", "v": "__import__('os')"}}, r"not allowed"),
        ({"equations": {"x": "v", "v": "1/(x - x)"}}, r"division by zero"),
        ({"equations": {"x": "v", "v": ""}}, r"empty"),
        ({"outputs": {"k": "x"}}, r"output 'k' has the name of a parameter"),
        ({"states": []}, r"no states"),
        ({"states": ["x", "lambda"], "equations": {"x": "v", "lambda": "0"}}, r"Python keyword"),
        ({"states": ["x", "2v"]}, r"not a valid name"),
        ({"known_initial_conditions": ["k"]}, r"known initial condition 'k' is not a state"),
        ({"initial_condition_values": {"x": 0}}, r"not in known_initial_conditions"),
        ({"values": {"kk": 1.0}}, r"undeclared symbol 'kk'"),
        ({"values": {"k": "abc"}}, r"must be a number"),
        ({"latex": {"q": "q"}}, r"undeclared symbol 'q'"),
        ({"name": ""}, r"non-empty 'name'"),
    ],
)
def test_validation_names_the_culprit(over, match):
    with pytest.raises(ModelError, match=match):
        msd(**over)


def test_undeclared_builtin_name_is_an_error_not_a_constant():
    # E is Euler's number in sympy; undeclared it must be an error, not 2.718...
    with pytest.raises(ParseError, match="undeclared symbol 'E'"):
        msd(equations={"x": "v", "v": "-E*x"})
    with pytest.raises(ParseError, match="undeclared symbol 'N'"):
        msd(equations={"x": "v", "v": "-N*x"})


def test_round_trip_through_dict_and_json():
    m = obsnl.read_model(MODEL_FILES[0])
    d = json.loads(json.dumps(m.to_dict()))
    again = Model.from_dict(d)
    assert again == m
    assert again.latex == m.latex and again.values == m.values


def test_unknown_key_is_an_error_with_suggestion():
    d = msd().to_dict()
    d["ouputs"] = d.pop("outputs")
    with pytest.raises(ParseError, match=r"unknown key 'ouputs'.*did you mean 'outputs'"):
        Model.from_dict(d)


def test_with_outputs_and_replace_return_new_models():
    m = msd()
    m2 = m.with_outputs({"y2": "v"})
    assert m2.output_names == ("y", "y2") and m.output_names == ("y",)
    with pytest.raises(ModelError, match="exists already"):
        m.with_outputs({"y": "v"})


@pytest.mark.parametrize("path", PEER_CASE_FILES, ids=lambda p: p.stem)
def test_every_peer_case_loads_unchanged(path):
    m = obsnl.read_model(path)
    raw = json.loads(path.read_text())
    assert [s.name for s in m.states] == raw["states"]
    assert [s.name for s in m.parameters] == raw["parameters"]
    assert list(m.outputs) == list(raw["outputs"])
    assert m.metadata["expected"] == raw["expected"]
    # the equations mean what the file says: compare with a direct sympify over the same names
    names = raw["states"] + raw["parameters"] + raw.get("inputs", []) + raw.get("unknown_inputs", []) \
        + raw.get("known_constants", [])
    loc = {n: sp.Symbol(n, real=True) for n in names}
    for s, e in raw["equations"].items():
        assert sp.simplify(m.equations[m.symbol(s)] - sp.sympify(e, locals=loc, rational=True)) == 0


@pytest.mark.parametrize("path", MODEL_FILES, ids=lambda p: p.stem)
def test_catalogue_models_load_and_cite_a_source(path):
    m = obsnl.read_model(path)
    assert m.source.strip(), f"{path.name} must cite its source"


def test_file_errors(tmp_path):
    with pytest.raises(ParseError, match="does not exist"):
        obsnl.read_model(tmp_path / "nope.toml")
    bad = tmp_path / "m.yaml"
    bad.write_text("name: x")
    with pytest.raises(ParseError, match="unknown model file type"):
        obsnl.read_model(bad)
    bad = tmp_path / "m.toml"
    bad.write_text("name = [")
    with pytest.raises(ParseError, match="not valid TOML"):
        obsnl.read_model(bad)
    bad = tmp_path / "m.json"
    bad.write_text("[1, 2]")
    with pytest.raises(ParseError, match="top level"):
        obsnl.read_model(bad)
    bad.write_text('{"name": "m", "states": ["x"], "equations": {"x": "-k*x"}}')
    with pytest.raises(ParseError, match=r"m.json: equation of x: undeclared symbol 'k'"):
        obsnl.read_model(bad)
