"""Answers that say what they assume: unknown inputs (arbitrary or K non-zero derivatives), roots of
numbers, inconclusive branches in every format (issue 17).

Every expected answer is derived in the comments from the model equations (or cited). The randomized
verdicts use fixed seeds; each asserts the reported bound P(all verdicts right) >= 0.99 (Sedoglavic's
Prop. 3.3, obsnl.algebra.bounds), so a spurious failure has probability below 1e-2 per call, and in
practice far below (a full-rank Jacobian is a certificate; an unobservable verdict is confirmed by a
second independent run).
"""

from __future__ import annotations

import json

import pytest

import obsnl
from obsnl import Model, analyze
from obsnl.cli import main
from obsnl.model.files import model_to_toml
from obsnl.report.tables import render
from tests.conftest import PEER_CASES, ROOT

ALL = ("x1", "v1", "x2", "v2", "m1", "m2", "c", "k")


def _two_mass(outputs: dict[str, str], *, shaker: bool = True) -> Model:
    # m1 x1'' = u - k (x1 - x2) - c (v1 - v2);  m2 x2'' = k (x1 - x2) + c (v1 - v2) + w
    # (coupling spring k and damper c, a measured force u on mass 1, an unmeasured force w on mass 2)
    u = "u - " if shaker else "-"
    return Model(
        name="two_mass", states=["x1", "v1", "x2", "v2"], parameters=["m1", "m2", "c", "k"],
        inputs=["u"] if shaker else [], unknown_inputs=["w"],
        equations={"x1": "v1", "v1": f"({u}k*(x1 - x2) - c*(v1 - v2))/m1", "x2": "v2",
                   "v2": "(k*(x1 - x2) + c*(v1 - v2) + w)/m2"},
        outputs=outputs,
    )


def _classes(model: Model, K, *, method: str = "sedoglavic", seed: int = 7):
    r = analyze(model, method=method, seed=seed, unknown_input_derivatives=K)
    assert r.probability >= 0.99 and r.verdict.value != "inconclusive"
    return set(r.overall_observable), set(r.overall_unobservable), r.unknown_inputs


@pytest.mark.parametrize("method", ["sedoglavic", "orc"])
def test_two_mass_oscillator_force_on_the_second_mass(method) -> None:
    # y = x1. Write d = x1 - x2, L = c D + k (D = d/dt). Mass 1: L d = u - m1 y''. Mass 2:
    # m2 (y'' - d'') = L d + w. Applying L to mass 2 and using mass 1:
    #   m2 L y'' - m2 D^2 (u - m1 y'') = L (u - m1 y'') + L w.
    # K = 1 (w = w0 + w1 t): L w is linear in t, so D^2 removes it:
    #   m1 m2 y^(6) + c (m1 + m2) y^(5) + k (m1 + m2) y^(4) = m2 u^(4) + c u''' + k u''.
    # For a generic u its coefficients up to a common factor are known: m1, c/m2 + c m1/m2, k/m2 +
    # k m1/m2, c/m2, k/m2 (dividing by m2); so m1, then c (= c(m1+m2)/m2 - m1 c/m2), m2, k: all
    # identifiable. d(0) too: another d(0) adds C e^(-k t/c) to d, and w changes by
    # -m2 (k/c)^2 C e^(-k t/c), not a polynomial of degree 1 unless C = 0; so x2, v2 and w observable.
    model = _two_mass({"y": "x1"})
    obs, unobs, ui = _classes(model, 1, method=method)
    assert obs == set(ALL) and unobs == set()
    assert ui == {"observable": ("w",), "unobservable": ()}
    # arbitrary w: any x2(t) is reached (w = m2 x2'' - L d), so mass 1 sees x2 as an arbitrary input:
    # for any (m1', c', k') solve c' x2' + k' x2 = u - m1' y'' + c' y' + k' y (first order, any
    # x2(0)) and set w accordingly, with any m2'. Only x1 = y and v1 = y' are determined; the mass
    # carrying the force (m2), the force, and here also m1, c, k, x2, v2 are not.
    obs, unobs, ui = _classes(model, "arbitrary", method=method)
    assert obs == {"x1", "v1"} and unobs == set(ALL) - {"x1", "v1"}
    assert ui == {"observable": (), "unobservable": ("w",)}


def test_two_mass_oscillator_both_positions_measured() -> None:
    # y1 = x1, y2 = x2: d = y1 - y2 is measured, and mass 1 (m1 y1'' = u - k d - c d') is a linear
    # regression in (m1, c, k) with generic regressors: identifiable for any w. Mass 2:
    # m2 y2'' = k d + c d' + w. Arbitrary w: (m2, w) -> (m2', w + (m2' - m2) y2'') keeps everything:
    # exactly the mass carrying the force and the force are lost. K = 1: D^2 of
    # m2 y2'' - k d - c d' = w0 + w1 t gives m2 y2'''' = k d'' + c d''' (generic: m2 identifiable),
    # then w = m2 y2'' - k d - c d' is observable.
    model = _two_mass({"y1": "x1", "y2": "x2"})
    obs, unobs, ui = _classes(model, 1)
    assert obs == set(ALL) and unobs == set() and ui["observable"] == ("w",)
    obs, unobs, ui = _classes(model, "arbitrary")
    assert unobs == {"m2"} and obs == set(ALL) - {"m2"}
    assert ui == {"observable": (), "unobservable": ("w",)}


def test_two_mass_oscillator_without_a_known_force_has_no_scale() -> None:
    # Without u: y'' = -(k/m1) d - (c/m1) d' and, from mass 2 with F = -m1 y'',
    # w/m2 = (1 + r) y'' - d'' (r = m1/m2). Scaling (m1, m2, c, k, w) together changes nothing, so
    # no mass, stiffness, damping or force is identifiable. K = 1 (w/m2 = o0 + o1 t): d = (1 + r) y
    # - o0 t^2/2 - o1 t^3/6 + e0 + e1 t, and mass 1 becomes y'' + b (1 + r) y' + a (1 + r) y = a cubic
    # in t (a = k/m1, b = c/m1): its 2 + 4 coefficients are all y fixes, for the 7 unknowns a, b, r,
    # o0, o1, e0, e1. One family is left, in which d(0) = (1 + r) y(0) + e0 moves: x2, v2 are not
    # observable either; x1 = y, v1 = y' are. Arbitrary w: as in the test above, everything but x1, v1.
    model = _two_mass({"y": "x1"}, shaker=False)
    for K in (1, "arbitrary"):
        for method in ("sedoglavic", "orc"):
            obs, unobs, ui = _classes(model, K, method=method)
            assert obs == {"x1", "v1"} and unobs == set(ALL) - {"x1", "v1"}
            assert ui == {"observable": (), "unobservable": ("w",)}


def test_one_state_constant_versus_arbitrary_unknown_input() -> None:
    # x' = -a x + w, y = x. K = 0 (w constant): y' = -a y + w and y'' = -a y', so a = -y''/y' and
    # w = y' + a y: a identifiable, w observable. Arbitrary w: any a' fits with w' = y' + a' y, so
    # a is not identifiable and w not observable; x = y is observable in both.
    m = Model(name="decay_w", states=["x"], parameters=["a"], unknown_inputs=["w"],
              equations={"x": "-a*x + w"}, outputs={"y": "x"})
    for method in ("sedoglavic", "orc"):
        assert _classes(m, 0, method=method) == ({"x", "a"}, set(), {"observable": ("w",), "unobservable": ()})
        assert _classes(m, "arbitrary", method=method) == ({"x"}, {"a"}, {"observable": (), "unobservable": ("w",)})


def test_default_is_arbitrary_and_the_model_key_overrides_it(tmp_path) -> None:
    m = Model(name="decay_w", states=["x"], parameters=["a"], unknown_inputs=["w"],
              equations={"x": "-a*x + w"}, outputs={"y": "x"})
    assert analyze(m, seed=1).assumptions.unknown_input_derivatives == "arbitrary"
    assert analyze(m, seed=1).overall_unobservable == ("a",)  # as derived above for arbitrary w
    m0 = m.replace(unknown_input_derivatives=0)
    assert analyze(m0, seed=1).overall_unobservable == ()
    assert analyze(m0, seed=1, unknown_input_derivatives="arbitrary").overall_unobservable == ("a",)
    # the key round-trips through a model file
    path = tmp_path / "m.toml"
    path.write_text(model_to_toml(m0))
    assert obsnl.read_model(path).unknown_input_derivatives == 0


def test_bad_unknown_input_derivatives_is_a_clear_error(capsys) -> None:
    with pytest.raises(obsnl.ObsnlError, match="arbitrary"):
        Model(name="m", states=["x"], parameters=["a"], unknown_inputs=["w"], equations={"x": "-a*x + w"},
              outputs={"y": "x"}, unknown_input_derivatives=-1)
    code = main(["analyze", str(PEER_CASES / "sg_pk_unknown_input.json"), "--unknown-input-derivatives", "two"])
    err = capsys.readouterr().err
    assert code == 2 and "unknown_input_derivatives" in err and err.count("\n") == 1


@pytest.mark.parametrize("name", ["sg_pk_unknown_input", "sg_vajda1989_unknown_input"])
def test_unknown_input_cases_state_the_K_of_their_source(name) -> None:
    # both answer sources list the inputs' unknowns as (u1, u1_d1) / (w, w_d1): nnzDerW = 1
    # (tests/test_engines_catalogue.py checks their published classes under that K)
    assert obsnl.read_model(PEER_CASES / f"{name}.json").unknown_input_derivatives == 1


def test_every_format_states_the_assumptions_and_the_unknown_inputs(capsys) -> None:
    case = str(PEER_CASES / "sg_vajda1989_unknown_input.json")
    assert main(["analyze", case, "--format", "json", "--seed", "3"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["assumptions"]["unknown_input_derivatives"] == 1  # the case file's K
    assert doc["assumptions"]["initial_conditions"]["unknown"] == ["x1", "x2"]
    assert doc["assumptions"]["known_inputs"] is None
    # published: w observable with nnzDerW = 1 (the case file's expected_unknown_inputs)
    assert doc["overall"]["unknown_inputs"] == {"observable": ["w"], "unobservable": []}
    assert doc["branches"][0]["unknown_inputs"] == {"observable": ["w"], "unobservable": []}
    assert doc["verdict"] == doc["branches"][0]["verdict"] == "unobservable"
    for fmt, needle in (("text", "K = 1"), ("md", "K = 1"), ("tex", "K = 1")):
        assert main(["analyze", case, "--format", fmt, "--seed", "3"]) == 0
        out = capsys.readouterr().out
        assert needle in out and "initial conditions unknown" in out
    assert main(["analyze", case, "--format", "md", "--seed", "3", "--unknown-input-derivatives", "arbitrary"]) == 0
    out = capsys.readouterr().out
    assert "unknown inputs arbitrary functions of time" in out and "Unknown inputs observable: none" in out


def test_inconclusive_branch_claims_no_degree_and_no_probability(capsys) -> None:
    code = main(["analyze", str(PEER_CASES / "genssi_hiv.json"), "--method", "orc", "--max-seconds", "0.3",
                 "--format", "json", "--seed", "0"])
    doc = json.loads(capsys.readouterr().out)
    assert code == 2
    (b,) = doc["branches"]
    assert b["verdict"] == "inconclusive" and b["transcendence_degree"] is None and b["reason"] and b["undecided"]
    assert doc["verdict"] == "inconclusive" and doc["probability"] is None
    r = analyze(obsnl.read_model(PEER_CASES / "genssi_hiv.json"), method="orc", max_seconds=0.3, seed=0)
    assert "not decided" in render(r, "md") and "not decided" in render(r, "tex") and "not decided" in render(r, "text")
    assert "inconclusive" in render(r, "md") and "inconclusive" in render(r, "tex")


@pytest.mark.parametrize("seed", range(10))
def test_betaig_with_numeric_fractional_powers_on_ten_seeds(seed) -> None:
    # Published (Villaverde & Banga, PLoS Comput Biol 2017, "Dynamical compensation and structural
    # identifiability of biological models", betaIG model measured through glucose): si cannot be
    # inferred, compensated by p (= p1), with insulin I and beta-cell mass unobservable. Derivation of
    # the full classes: G' = u - (c + si I) G sees I only through si I, I' = p1 beta rho(G) - gamma I,
    # beta' = beta f(G). So (I, si, p1) -> (l I, si/l, l p1) and (beta, p1) -> (m beta, p1/m) leave G
    # unchanged: beta, I, p1, si are not identifiable (2 symmetries: transcendence degree 2); G, c,
    # gamma, alpha are (the invariant si I obeys (si I)' = si p1 beta rho(G) - gamma si I, and with
    # z = si p1 beta, z' = z f(G): G'' gives si I, then gamma and alpha through rho(G), c from G').
    model = obsnl.read_model(ROOT / "tests" / "data" / "sg_big_autorepar.toml")
    r = analyze(model, method="sedoglavic", seed=seed)
    assert r.probability >= 0.99
    assert set(r.overall_observable) == {"G", "gamma", "c", "alpha"}
    assert set(r.overall_unobservable) == {"beta", "I", "p1", "si"}
    assert r.branches[0].transcendence_degree == 2
    assert any("roots of numbers, exact" in n for n in r.branches[0].notes)
