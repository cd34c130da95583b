"""Splitting non-smooth models into smooth branches."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import obsnl
from obsnl import Model
from obsnl.model.branching.branches import split_branches, switching_functions
from obsnl.model.branching.jumps import field_jumps
from obsnl.model.core import NONSMOOTH_FUNCTIONS

from .conftest import MODEL_FILES, MODELS


def _rel(model, text):
    return sp.sympify(text, locals=model.symbols)


def test_seed_model_has_exactly_the_papers_four_branches():
    m = obsnl.read_model(MODELS / "damage_healing.toml")
    branches = split_branches(m)
    assert [b.label for b in branches] == ["a", "b", "c", "d"]
    # seed paper §3.2: (a) sigma-eta > 0, x2 > 0; (b) sigma-eta > 0, x2 < 0;
    #                  (c) sigma-eta < 0, x2 < 0; (d) sigma-eta < 0, x2 > 0
    paper = {"a": (1, 1), "b": (1, -1), "c": (-1, -1), "d": (-1, 1)}
    sw = [_rel(m, "sigma - eta"), _rel(m, "x2")]
    for b in branches:
        assert list(b.switching) == sw
        assert b.signs == paper[b.label]
        assert b.model.is_smooth
    assert branches[0].guard_text == "(sigma - eta > 0) & (x2 > 0)"


def test_products_of_switching_functions_are_resolved_from_factors():
    m = obsnl.read_model(MODELS / "damage_healing.toml")
    # sign((sigma - eta)*x2) and sign(sigma - eta) appear; only the two factors switch
    assert len(switching_functions(m)) == 2
    m2 = Model(name="p", states=["x", "y"], parameters=["a"],
               equations={"x": "sign(x*y**3) + sign(-2*x)", "y": "Abs(x*y)*sign(x**2*y) - Heaviside(y/x)"},
               outputs={"o": "x"})
    assert set(switching_functions(m2)) == {m2.symbol("x"), m2.symbol("y")}
    for b in split_branches(m2):
        sx, sy = b.signs
        x, y = m2.symbol("x"), m2.symbol("y")
        assert b.model.equations[x] == sx * sy - sx
        assert b.model.equations[y] == sp.expand(sx * sy * x * y * sy - (1 if sx * sy > 0 else 0))


def test_contradictory_sign_patterns_are_dropped():
    m = Model(name="c", states=["x", "y"], parameters=[],
              equations={"x": "sign(x) + sign(y)", "y": "sign(x + y)"}, outputs={"o": "x"})
    branches, dropped = split_branches(m, with_dropped=True)
    assert len(branches) == 6 and len(dropped) == 2  # x>0,y>0 forbids x+y<0, and the mirror image
    for d in dropped:
        sx, sy, sxy = d.signs
        assert sx == sy and sxy == -sx
    for b in branches:
        assert b.contains(b.witness)


def test_smooth_model_is_one_branch():
    m = Model(name="s", states=["x"], parameters=["k"], equations={"x": "-k*x"}, outputs={"y": "x"})
    (b,) = split_branches(m)
    assert b.label == "smooth" and b.guard_text == "true" and b.model == m.replace(switching=())


def test_piecewise_max_min_and_nested():
    m = Model(name="pw", states=["x", "v"], parameters=["k", "d"],
              equations={"x": "v", "v": "Piecewise((-k*x, x > d), (0, True)) + Max(x, 0) - Min(v, -x)"},
              outputs={"y": "Abs(x - Abs(d))"})
    branches = split_branches(m)
    for b in branches:
        assert b.model.is_smooth
    # nested Abs inside Abs: the inner switching function (d) and then the outer (x - |d|)
    texts = " ".join(b.guard_text for b in branches)
    assert "d > 0" in texts and "d < 0" in texts


def test_equality_conditions_are_refused():
    m = Model(name="e", states=["x"], parameters=[], equations={"x": "Piecewise((1, Eq(x, 0)), (0, True))"},
              outputs={"y": "x"})
    with pytest.raises(obsnl.NotSupportedError, match="equality"):
        split_branches(m)


def _sample(model, rng, n):
    """Random points: states and inputs ~ N(0,1) times a random scale, parameters log-uniform > 0."""
    pts = {}
    for s in model.states + model.inputs + model.unknown_inputs:
        pts[s.name] = rng.standard_normal(n) * 10.0 ** rng.uniform(-1, 1, n)
    for s in model.parameters + model.known_constants:
        pts[s.name] = 10.0 ** rng.uniform(-1, 1, n)
    return pts


@pytest.mark.parametrize("path", MODEL_FILES, ids=lambda p: p.stem)
def test_branch_fields_equal_the_nonsmooth_model_inside_each_branch(path):
    """Each branch's smooth field equals the non-smooth model at random points inside that branch."""
    model = obsnl.read_model(path)
    branches = split_branches(model)
    rng = np.random.default_rng(20261122)
    n = 4000
    pts = _sample(model, rng, n)
    syms = list(model.symbols.values())
    args = [pts[s.name] for s in syms]
    exprs = list(model.rhs) + list(model.output_exprs)
    full = [np.broadcast_to(np.asarray(v, float), (n,)) for v in sp.lambdify(syms, exprs, "numpy")(*args)]
    hits = 0
    for b in branches:
        inside = np.ones(n, bool)
        for g, s in zip(b.switching, b.signs):
            inside &= s * np.broadcast_to(sp.lambdify(syms, g, "numpy")(*args), (n,)) > 0
        assert inside.sum() > 20, f"too few random points fell inside branch {b.label}"
        hits += inside.sum()
        smooth_exprs = list(b.model.rhs) + list(b.model.output_exprs)
        assert not any(e.has(*NONSMOOTH_FUNCTIONS) for e in smooth_exprs)
        with np.errstate(invalid="ignore"):  # a branch's field off its region may be NaN (z**n, z < 0): masked below
            sm = [np.broadcast_to(np.asarray(v, float), (n,))
                  for v in sp.lambdify(syms, smooth_exprs, "numpy")(*args)]
        for i, (f, g) in enumerate(zip(full, sm)):
            ok = np.isfinite(f[inside])
            np.testing.assert_allclose(g[inside][ok], f[inside][ok], rtol=1e-9, atol=1e-12,
                                       err_msg=f"{path.stem} branch {b.label} expression {i}")
    assert hits == n or hits > 0.99 * n  # the branches cover the space (up to switching surfaces)


def test_guard_text_reads_back_as_the_guard():
    m = obsnl.read_model(MODELS / "damage_healing.toml")
    for b in split_branches(m):
        assert sp.sympify(b.guard_text, locals=m.symbols) == b.guard


def test_field_jumps_only_where_the_vector_field_is_discontinuous():
    # seed model (16): across x2 = 0 every switched term carries a factor x2 (continuous); across
    # r = eta' the healing factor (1 + w_h c'_eta E'_h (1 + sign((r - eta')x2))/2) switches while x2 != 0
    seed = obsnl.read_model(next(p for p in MODEL_FILES if p.stem == "damage_healing_reparam"))
    gs = switching_functions(seed)
    assert [str(g) for g in gs] == ["-eta_p + r", "x2"]
    assert field_jumps(seed, gs) == (True, False)
    coulomb = Model(name="c", states=["x", "v"], parameters=["k", "mu"], inputs=["u"],
                    equations={"x": "v", "v": "u - k*x - mu*sign(v)"}, outputs={"y": "x"})
    assert field_jumps(coulomb, switching_functions(coulomb)) == (True,)
    kink = Model(name="k", states=["x"], parameters=["a"], inputs=[], equations={"x": "-a*Abs(x)"},
                 outputs={"y": "x"})
    assert field_jumps(kink, switching_functions(kink)) == (False,)


def test_representatives_refuse_nested_nonsmooth_functions():
    # sign(x + Abs(y)) switches on y first, then on x + y or x - y: representatives that resolved only the
    # inner Abs would hand on a "smooth" field that still holds sign(x + y); the enumeration resolves both levels
    from obsnl.errors import NotSupportedError
    from obsnl.model.branching.representatives import representative_branches, switching_groups

    m = Model(name="nested", states=["x", "y"], parameters=["a"], equations={"x": "-a*sign(x + Abs(y))", "y": "-y"},
              outputs={"o": "x"})
    for refuse in (switching_groups, representative_branches):
        with pytest.raises(NotSupportedError, match="nested"):
            refuse(m)
    branches = split_branches(m)
    assert len(branches) == 4 and not any(e.has(sp.sign, sp.Abs) for b in branches for e in b.model.rhs)
