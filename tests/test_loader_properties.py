"""Property test of the loader: random garbage and random well-formed models.

The loader must return a Model or raise obsnl's own error (ObsnlError), nothing else.
Hypothesis runs with a fixed database-free profile so CI is reproducible (derandomize=True).
"""

from __future__ import annotations

import json

import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import obsnl
from obsnl import Model, ObsnlError

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

NAMES = ["x", "v", "S", "I", "E", "N", "Q", "C", "beta", "gamma", "k", "m", "theta", "pi_", "lam", "zeta"]
FUNCS = ["sign", "Abs", "exp", "log", "sqrt", "sin", "cos", "tanh", "Heaviside"]

garbage_text = st.text(alphabet=st.characters(codec="utf-8"), max_size=60) | st.text(
    alphabet="xvkSIENbetagm()*+-/^.,<>=![]{}'\"0123456789 _eE", max_size=60)


def _load_or_own_error(loader, *args):
    try:
        out = loader(*args)
    except ObsnlError:
        return None
    assert isinstance(out, Model)
    return out


@SETTINGS
@given(expr=garbage_text)
def test_garbage_expressions_give_model_or_obsnl_error(expr):
    d = {"name": "g", "states": ["x", "v"], "parameters": ["k", "E", "N"],
         "equations": {"x": "v", "v": expr}, "outputs": {"y": "x"}}
    _load_or_own_error(Model.from_dict, d)


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=True) | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)


@SETTINGS
@given(data=st.dictionaries(
    st.sampled_from(["name", "states", "parameters", "inputs", "outputs", "equations", "known_initial_conditions",
                     "initial_condition_values", "values", "latex", "switching", "unknown_inputs", "bogus"]),
    json_values, max_size=8))
def test_garbage_dicts_give_model_or_obsnl_error(data):
    _load_or_own_error(Model.from_dict, data)


@SETTINGS
@given(raw=st.binary(max_size=200), suffix=st.sampled_from([".toml", ".json"]))
def test_garbage_files_give_model_or_obsnl_error(tmp_path_factory, raw, suffix):
    p = tmp_path_factory.mktemp("g") / f"m{suffix}"
    p.write_bytes(raw)
    _load_or_own_error(obsnl.load_model, p)


@st.composite
def well_formed_models(draw):
    names = draw(st.lists(st.sampled_from(NAMES), min_size=2, max_size=7, unique=True))
    n_states = draw(st.integers(1, len(names) - 1))
    states, params = names[:n_states], names[n_states:]

    def expr(depth):
        if depth == 0:
            return draw(st.sampled_from(names + ["2", "1/3", "0.5"]))
        kind = draw(st.sampled_from(["bin", "fun", "leaf", "pow"]))
        if kind == "leaf":
            return expr(0)
        if kind == "fun":
            return f"{draw(st.sampled_from(FUNCS))}({expr(depth - 1)})"
        if kind == "pow":
            return f"({expr(depth - 1)})**{draw(st.sampled_from(['2', '3', params[0] if params else '2']))}"
        op = draw(st.sampled_from(["+", "-", "*"]))
        return f"({expr(depth - 1)}) {op} ({expr(depth - 1)})"

    eqs = {s: expr(draw(st.integers(0, 3))) for s in states}
    outs = {"y": expr(1)}
    return {"name": "w", "states": states, "parameters": params, "equations": eqs, "outputs": outs}


@SETTINGS
@given(d=well_formed_models(), as_json=st.booleans())
def test_well_formed_models_load_and_mean_what_they_say(tmp_path_factory, d, as_json):
    p = tmp_path_factory.mktemp("w") / ("m.json" if as_json else "m.toml")
    if as_json:
        p.write_text(json.dumps(d))
    else:
        lines = [f'name = "{d["name"]}"', f"states = {json.dumps(d['states'])}",
                 f"parameters = {json.dumps(d['parameters'])}", "[equations]"]
        lines += [f'{k} = "{v}"' for k, v in d["equations"].items()]
        lines += ["[outputs]"] + [f'{k} = "{v}"' for k, v in d["outputs"].items()]
        p.write_text("\n".join(lines))
    try:
        m = obsnl.load_model(p)
    except ObsnlError as exc:
        # the only refusal a well-formed model may get: an expression that evaluates to an
        # infinity, e.g. log((x) - (x)) = log(0)
        assert "infinity" in str(exc), str(exc)
        return
    loc = {n: sp.Symbol(n, real=True) for n in d["states"] + d["parameters"]}
    funcs = {"sign": sp.sign, "Abs": sp.Abs, "Heaviside": sp.Heaviside}
    for s, e in d["equations"].items():
        ref = sp.sympify(e, locals={**loc, **funcs}, rational=True)
        assert sp.simplify(m.equations[m.symbol(s)] - ref) == 0
