"""same_field and the modular Jacobian helpers (obsnl.recombination.fields)."""

from __future__ import annotations

import json

import pytest
import sympy as sp

from obsnl.errors import NotSupportedError, ObsnlError
from obsnl.recombination.fields import PRIME, jacobian_mod_p, rank_mod_p, rational_reconstruction, same_field


def test_textbook_groups_generate_the_same_field_as_m_c_k():
    cmp = same_field(["k/m", "c/m", "1/m"], ["m", "c", "k"], ["m", "c", "k"])
    assert cmp and cmp.same and (cmp.rank_a, cmp.rank_b, cmp.rank_joint) == (3, 3, 3)


def test_a_proper_subfield_is_detected_with_containment():
    cmp = same_field(["a*b"], ["a", "b"], ["a", "b"])
    assert not cmp
    assert cmp.b_contains_a and not cmp.a_contains_b
    assert (cmp.rank_a, cmp.rank_b) == (1, 2)


def test_the_test_is_local_a_swap_is_invisible():
    # a and b are roots of t^2 - (a+b) t + ab: algebraic over Q(a+b, ab), so locally the same field
    assert same_field(["a*b", "a + b"], ["a", "b"], ["a", "b"])


def test_symbolic_exponents_written_differently_agree():
    v = ["beta", "gamma", "sigma_y", "L", "E", "N"]
    paper = ["(beta + gamma)/(sigma_y*L/E)**(2*N)", "N"]
    expanded = ["(beta + gamma)*E**(2*N)/(sigma_y**(2*N)*L**(2*N))", "N"]
    wrong = ["(beta + gamma)*E**(2*N)/(sigma_y**(2*N)*L**(3*N))", "N"]
    assert same_field(paper, expanded, v)
    assert not same_field(paper, wrong, v)


@pytest.mark.parametrize("a, b, same", [
    (["exp(a)"], ["a"], True),
    (["log(a) + log(b)"], ["a*b"], True),
    (["log(a) + log(b)"], ["a + b"], False),
    (["sqrt(a)", "b"], ["a", "b"], True),
    (["a**b"], ["a", "b"], False),
])
def test_non_rational_terms(a, b, same):
    assert bool(same_field(a, b, ["a", "b"])) is same


def test_constants_are_held_fixed():
    # with the gain g known, g/m and k/m determine m and k; with g unknown they do not
    assert same_field(["g/m", "k/m"], ["m", "k"], ["m", "k"], constants=["g"])
    cmp = same_field(["g/m", "k/m"], ["m", "k", "g"], ["m", "k", "g"])
    assert not cmp and (cmp.rank_a, cmp.rank_b) == (2, 3)


def test_error_bound_and_seed_are_reported():
    cmp = same_field(["x*y"], ["x", "y"], ["x", "y"], seed=7)
    d = cmp.to_dict()
    json.dumps(d)
    assert d["seed"] == 7 and 0 < d["error_bound"] < 1e-12


def test_sympy_input_and_undeclared_names():
    x, y = sp.symbols("x y", real=True)
    assert same_field([x * y, x + y], [x, y], [x, y])
    with pytest.raises(ObsnlError, match="undeclared symbol 'z'"):
        same_field(["x*z"], ["x"], ["x"])


def test_nonsmooth_expressions_are_refused_with_the_fix():
    with pytest.raises(NotSupportedError, match="split the model into branches"):
        same_field(["sign(x)*x"], ["x"], ["x"])


def test_rational_reconstruction_roundtrip():
    for q in (sp.Rational(3, 7), sp.Rational(-22, 5), sp.Integer(12345), sp.Rational(1, 2**20)):
        a = int(q.p) * pow(int(q.q), -1, PRIME) % PRIME
        assert rational_reconstruction(a) == q


def test_jacobian_mod_p_matches_a_hand_computation():
    x, y = sp.symbols("x y", real=True)
    pt = {x: 5, y: 11}
    J = jacobian_mod_p([x**2 * y, x / y], [x, y], point=pt)
    inv11 = pow(11, -1, PRIME)
    assert J[0] == [2 * 5 * 11 % PRIME, 25]
    assert J[1] == [inv11, (-5 * inv11 * inv11) % PRIME]
    assert rank_mod_p(J, 2) == 2


def test_exported_from_its_room():
    from obsnl.recombination import same_field as exported

    assert exported is same_field


@pytest.mark.parametrize("module", ["obsnl.recombination.fields", "obsnl.model.files", "obsnl.observability.certificates.symmetry", "obsnl.recombination.reparametrize",
                                    "obsnl.recombination.identifiable"])
def test_docstring_examples(module):
    import doctest
    import importlib

    result = doctest.testmod(importlib.import_module(module))
    assert result.attempted > 0 and result.failed == 0
