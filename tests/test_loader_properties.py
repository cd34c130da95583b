"""Property test of the loader: random garbage and random well-formed models.

The loader must return a Model or raise obsnl's own error (ObsnlError), nothing else.

Two hypothesis profiles: ``ci`` (the default; 150 examples, derandomized, so CI is reproducible and
fast) and ``random`` (fresh random examples each run, ``OBSNL_HYPOTHESIS_EXAMPLES`` of them, default
10 000; hypothesis prints the seed of a failure, ``--hypothesis-seed=N`` replays it). Select with
``OBSNL_HYPOTHESIS_PROFILE=random``. A run that finds nothing is evidence, not proof: a bug hit by a
fraction q of the examples is missed with probability (1 - q)**n (below 1e-4 for q = 1e-3 and n = 10 000).
"""

from __future__ import annotations

import json
import os

import pytest
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import obsnl
from obsnl import Model, ObsnlError
from obsnl.model.core import MODEL_KEYS

_HEALTH = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much]
settings.register_profile("ci", max_examples=150, deadline=None, derandomize=True, database=None,
                          suppress_health_check=_HEALTH)
settings.register_profile("random", max_examples=int(os.environ.get("OBSNL_HYPOTHESIS_EXAMPLES", "10000")),
                          deadline=None, derandomize=False, database=None, suppress_health_check=_HEALTH)
PROFILE = os.environ.get("OBSNL_HYPOTHESIS_PROFILE", "ci")
SETTINGS = settings(settings.get_profile(PROFILE))

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


#: Strings that broke the loader once (hostile-input review, issue 18), mixed into the garbage.
HOSTILE = ["9**9**9", "2**2**2**2**2**2", "x**(10**10)", "1" * 4400, "+".join(["x"] * 5000), "\uff58", "\u2113",
           "\u00b5", "log(-2)", "x # y", "__import__('os')", "\\input{/etc/passwd}", "m\ud800", "1e999999",
           "sign(exp(x) - 2)", "((((((((((x))))))))))" * 30]
garbage_value = json_values | garbage_text | st.sampled_from(HOSTILE) | st.lists(st.sampled_from(HOSTILE), max_size=3) \
    | st.dictionaries(st.sampled_from(["x", "v", "k", "y", "\uff58"]), st.sampled_from(HOSTILE) | json_values, max_size=3)
OPTIONAL_KEYS = [k for k in MODEL_KEYS if k not in ("name", "states", "equations")]


@pytest.mark.slow
@pytest.mark.parametrize("key", OPTIONAL_KEYS)
@SETTINGS
@given(value=garbage_value)
def test_garbage_in_each_optional_key_gives_model_or_obsnl_error(key, value):
    d = {"name": "g", "states": ["x", "v"], "parameters": ["k"], "equations": {"x": "v", "v": "-k*x"},
         "outputs": {"y": "x"}, key: value}
    _load_or_own_error(Model.from_dict, d)


@SETTINGS
@given(raw=st.binary(max_size=200), suffix=st.sampled_from([".toml", ".json"]))
def test_garbage_files_give_model_or_obsnl_error(tmp_path_factory, raw, suffix):
    p = tmp_path_factory.mktemp("g") / f"m{suffix}"
    p.write_bytes(raw)
    _load_or_own_error(obsnl.read_model, p)


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
        m = obsnl.read_model(p)
    except ObsnlError as exc:
        # the only refusals a well-formed model may get: an expression that evaluates to an
        # infinity, e.g. log((x) - (x)) = log(0), or to a complex number, e.g. log(1/3 - 2)
        assert "infinity" in str(exc) or "complex-valued" in str(exc), str(exc)
        return
    loc = {n: sp.Symbol(n, real=True) for n in d["states"] + d["parameters"]}
    funcs = {"sign": sp.sign, "Abs": sp.Abs, "Heaviside": sp.Heaviside}
    for s, e in d["equations"].items():
        ref = sp.sympify(e, locals={**loc, **funcs}, rational=True)
        assert sp.simplify(m.equations[m.symbol(s)] - ref) == 0
