"""The fast paths of the randomized test against plain references.

- :mod:`obsnl.algebra.modp` (products, matrix products, incremental echelon form) against Python integers
  and python-flint.
- :class:`obsnl.algebra.taylor.Stepper` (every order of every node at once through the tangent map)
  against a plain per-node, per-order Taylor recursion written here, on random models with every
  kind of operation and atom, known and unknown inputs and given initial values.
- :func:`obsnl.model.branching.branches.derived_model` (branches and blocks without re-parsing) against the
  validated construction, field by field.
"""

from __future__ import annotations

import dataclasses
import random

import numpy as np
import pytest
import sympy as sp
from flint import nmod_mat

from obsnl import Model, read_model
from obsnl.model import split_branches
from obsnl.observability import decompose
from obsnl.algebra.augment import rationalize
from obsnl.algebra.bounds import classify
from obsnl.algebra.modp import Echelon, MatMod, mulmod
from obsnl.algebra.series import Field, Resample, _initial_jets, _random_point, make_problem, random_prime, run_series
from tests.conftest import MODELS, PEER_CASES

P50 = int(sp.prevprime(2**50))


# --------------------------------------------------------------------------- modp
def test_mulmod_and_matmod_are_exact_at_the_extremes() -> None:
    rng = np.random.default_rng(0)
    for p in (P50, int(sp.nextprime(2**40)), 101):
        a = np.concatenate([rng.integers(0, p, 500), [0, 1, p - 1, p - 2]])
        b = np.concatenate([rng.integers(0, p, 500), [p - 1, p - 1, p - 1, p - 2]])
        assert mulmod(a, b, p).tolist() == [int(x) * int(y) % p for x, y in zip(a, b)]
        A = rng.integers(0, p, (9, 40))
        A[0] = p - 1
        B = rng.integers(0, p, (40, 5))
        B[:, 0] = p - 1
        ref = [[sum(int(A[i, k]) * int(B[k, j]) for k in range(40)) % p for j in range(5)] for i in range(9)]
        assert (MatMod(A, p) @ B).tolist() == ref
        assert (MatMod(A, p) @ B[:, 1]).tolist() == [r[1] for r in ref]


@pytest.mark.parametrize("p", [7, 101, P50])
def test_echelon_rank_and_classes_match_flint(p) -> None:
    rng = random.Random(p)
    nprng = np.random.default_rng(p % 1000)
    for _ in range(150):
        M, R = rng.randint(1, 9), rng.randint(1, 12)
        J = nprng.integers(0, p, (R, M))
        if rng.random() < 0.5:
            J[:, rng.randrange(M)] = 0
        if R > 2 and rng.random() < 0.5:
            J[-1] = (J[0] * 3 + J[1]) % p
        e = Echelon(M, p)
        grew = [e.add(r) for r in J]
        rank, unobs = classify(J, p)
        assert (e.rank, e.unobservable()) == (rank, unobs)
        assert sum(grew) == rank
        assert nmod_mat([[int(x) for x in r] for r in J], p).rank() == rank


# --------------------------------------------------------------------------- Taylor mode
def _reference_rows(problem, seed: str, K: int, p: int = P50):
    """Output-gradient rows of orders 0..K-1 by the plain recursion (one node, one order at a time),
    at the point ``run_series(problem, random.Random(seed), K=K, p=p)`` draws."""
    rng = random.Random(seed)
    fixed_p: int | None = p
    for attempt in range(12):  # as run_series: a point where a denominator vanishes (or a root of a
        p = fixed_p if fixed_p is not None else random_prime(rng)  # non-residue) is drawn again,
        F = Field(p)  # after three tries with another prime
        drawn = _random_point(problem, F, rng, K, {})
        try:
            X0 = _initial_jets(problem, F, drawn)
            break
        except Resample:
            if attempt >= 2:
                fixed_p = None
    _, inputs, w_coeffs, _, _ = drawn
    lay, prog, model, rat = problem.layout, problem.program, problem.model, problem.rational
    M = problem.size
    S = {i: [[int(x) for x in X0[i]]] + [[0] * (M + 1) for _ in range(K - 1)] for i in range(len(prog.ops))}
    atoms = {prog.leaves[a.symbol]: a for a in rat.atoms}

    def jmul(a, b):
        return [a[0] * b[0] % p] + [(a[0] * y + b[0] * x) % p for x, y in zip(a[1:], b[1:])]

    def jadd(a, b, s=1):
        return [(x + s * y) % p for x, y in zip(a, b)]

    def jscale(c, a):
        return [c * x % p for x in a]

    def jinv(a):
        iv = pow(a[0], -1, p)
        return [iv] + [(-x * iv * iv) % p for x in a[1:]]

    def conv(u, v, k, lo, hi, w=lambda j: 1):
        acc = [0] * (M + 1)
        for j in range(lo, hi + 1):
            acc = jadd(acc, jscale(w(j) % p, jmul(S[u][j], S[v][k - j])))
        return acc

    state_of = dict(zip(lay.state_nodes, model.states))
    rows = [X0[list(lay.out_roots), 1:].tolist()]
    for k in range(1, K):
        ik = pow(k, -1, p)
        for i in lay.topo:
            if not lay.tv[i]:
                continue
            op = prog.ops[i]
            if i in state_of:
                S[i][k] = jscale(ik, S[lay.rhs_roots[lay.state_nodes.index(i)]][k - 1])
            elif op.kind == "leaf" and op.arg in model.inputs:
                S[i][k] = [inputs[op.arg][k]] + [0] * M
            elif op.kind == "leaf" and op.arg in model.unknown_inputs:
                cs = w_coeffs[op.arg]
                if k < len(cs):
                    f = pow(int(sp.factorial(k)) % p, -1, p)
                    S[i][k] = [cs[k] * f % p] + [0] * M
                    S[i][k][1 + problem.input_columns[op.arg.name][k]] = f
            elif op.kind == "leaf":
                a = atoms[i]
                g = lay.atom_arg_root[a.symbol]
                if a.kind == "exp":
                    S[i][k] = jscale(ik, conv(g, i, k, 1, k, lambda j: j))
                elif a.kind in ("log", "atan"):
                    d = g if a.kind == "log" else lay.atan_q_root[a.symbol]
                    num = jadd(S[g][k], jscale(ik, conv(i, d, k, 1, k - 1, lambda j: j)), -1)
                    S[i][k] = jmul(num, jinv(S[d][0]))
                elif a.kind == "root":
                    r1 = (1 + pow(a.q, -1, p)) % p
                    s = conv(g, i, k, 1, k, lambda j: r1 * j - k)
                    S[i][k] = jmul(jscale(ik, s), jinv(S[g][0]))
                elif a.kind == "sin":
                    c = prog.leaves[a.partner]
                    S[i][k] = jscale(ik, conv(g, c, k, 1, k, lambda j: j))
                    S[c][k] = jscale(p - ik, conv(g, i, k, 1, k, lambda j: j))
            elif op.kind == "neg":
                S[i][k] = jscale(p - 1, S[op.a][k])
            elif op.kind == "scale":
                S[i][k] = jscale(F.el(op.arg), S[op.a][k])
            elif op.kind == "shift":
                S[i][k] = list(S[op.a][k])
            elif op.kind in ("add", "sub"):
                S[i][k] = jadd(S[op.a][k], S[op.b][k], 1 if op.kind == "add" else -1)
            elif op.kind == "mul":
                S[i][k] = conv(op.a, op.b, k, 0, k)
            elif op.kind == "div":
                num = jadd(S[op.a][k], conv(op.b, i, k, 1, k), -1)
                S[i][k] = jmul(num, jinv(S[op.b][0]))
        rows.append([S[o][k][1:] for o in lay.out_roots])
    return p, rows


def _random_model(rng: random.Random) -> Model:
    x = ["x0", "x1", "x2"]
    terms = [
        "a*{x}", "b*{x}*{y}", "{x}/(c + {y}**2)", "exp(a*{x})", "log({x}**2 + b)", "sqrt({x}**2 + c)",
        "sin(b*{x})", "cos({x})", "atan({x})", "{x}**N", "u*{x}", "w*{y}", "-{x}**3/3 + c", "2*{x} - {y}/5",
    ]

    def rhs() -> str:
        out = []
        for _ in range(rng.randint(1, 3)):
            t = rng.choice(terms)
            out.append(t.format(x=rng.choice(x), y=rng.choice(x)))
        return " + ".join(out)

    kic = ["x2"] if rng.random() < 0.3 else []
    return Model(
        name="random", states=x, parameters=["a", "b", "c", "N"], inputs=["u"], unknown_inputs=["w"],
        equations={s: rhs() for s in x}, outputs={"y": "x0 + x1*a", "y2": "x2**2"},
        known_initial_conditions=kic, initial_condition_values={"x2": "a + 1"} if kic and rng.random() < 0.5 else {},
    )


@pytest.mark.parametrize("case", range(12))
def test_batched_taylor_steps_equal_the_plain_recursion(case) -> None:
    rng = random.Random(case)
    model = _random_model(rng)
    problem = make_problem(rationalize(model), unknown_input_derivatives=rng.choice([0, 1, 3]),
                           input_derivatives=rng.choice([None, 2]))
    K = min(problem.order_bound(), 9)
    seed = f"taylor:{case}"
    run = run_series(problem, random.Random(seed), K=K, p=P50)
    assert len(run.rows) == K
    assert (run.p, [r.tolist() for r in run.rows]) == _reference_rows(problem, seed, K)


@pytest.mark.parametrize("name", ["damage_healing.toml", "bouc_wen.toml"])
def test_batched_taylor_steps_on_the_mechanical_models(name) -> None:
    for br in split_branches(read_model(MODELS / name)):
        problem = make_problem(rationalize(decompose(br.model).blocks[0]))
        K = min(problem.order_bound(), 8)
        run = run_series(problem, random.Random(br.label), K=K, p=P50)
        assert (run.p, [r.tolist() for r in run.rows]) == _reference_rows(problem, br.label, K)


# --------------------------------------------------------------------------- derived models
def _validated(m: Model) -> Model:
    d = {f.name: getattr(m, f.name) for f in dataclasses.fields(Model)}
    d["equations"] = {s.name: e for s, e in m.equations.items()}
    d["initial_condition_values"] = {s.name: e for s, e in m.initial_condition_values.items()}
    return Model(**d)


@pytest.mark.parametrize("path", [MODELS / "damage_healing.toml", MODELS / "bouc_wen.toml",
                                  PEER_CASES / "si_bench_seir34.json", PEER_CASES / "si_knownic_quadratic.json",
                                  PEER_CASES / "sg_pk_unknown_input.json"])
def test_branches_and_blocks_equal_their_validated_construction(path) -> None:
    for br in split_branches(read_model(path)):
        for m in [br.model, *decompose(br.model).blocks]:
            v = _validated(m)
            for f in dataclasses.fields(Model):
                a, b = getattr(m, f.name), getattr(v, f.name)
                assert a == b and type(a) is type(b), f.name


def test_seed_model_has_no_log_of_minus_one() -> None:
    """Real logarithms: log|eta - sigma| serves both orientations; no log(-1) stand-in, no exp of it."""
    kinds = []
    for br in split_branches(read_model(MODELS / "damage_healing.toml")):
        rat = rationalize(br.model)
        assert all("-1" not in a.text for a in rat.atoms)
        kinds.append(sorted(a.kind for a in rat.atoms))
    assert kinds == [["exp", "exp", "log", "log"]] * 4


# --------------------------------------------------------------------------- order bound, real logarithms
def test_order_bound_is_min_dim_m_only_without_known_initial_conditions() -> None:
    kw = dict(name="m", states=["x", "v"], parameters=["k", "c", "N"], inputs=["u"],
              equations={"x": "v", "v": "u - k*x - c*v*x**N"}, outputs={"y": "x"})
    free = make_problem(rationalize(Model(**kw)))
    assert free.dim == 2 + 3 + 2 and free.size == 5 and free.order_bound() == 5  # min(dim, M)
    known = make_problem(rationalize(Model(**kw, known_initial_conditions=["v"])))
    assert known.order_bound() == known.dim == 7  # a known initial value breaks the argument
    given = make_problem(rationalize(Model(**kw, known_initial_conditions=["v"], initial_condition_values={"v": 0})))
    assert given.specific and given.order_bound() == 2 * given.dim + 2


def test_a_factor_and_its_negative_share_one_real_logarithm() -> None:
    m = Model(name="m", states=["x", "z"], parameters=["a", "N"],
              equations={"x": "-a*(x - z)**N", "z": "(z - x)**(2*N) + (x - z)**(N + 1)"}, outputs={"y": "x"})
    rat = rationalize(m)
    logs = [a for a in rat.atoms if a.kind == "log"]
    assert len(logs) == 1 and not any(a.kind == "const" for a in rat.atoms)
    # (x - z)**(N + 1) keeps its integer part algebraic: (x - z) * exp(N log|x - z|)
    assert sp.Poly(rat.rhs[m.states[1]].subs({a.symbol: 1 for a in rat.atoms}), *m.states).total_degree() == 1
