"""Truncated power series of first-order jets modulo a prime (the arithmetic of the randomized test).

A *jet* is a value with its gradient with respect to the unknowns ``z`` (unknown initial states,
parameters, coefficients of unknown inputs). Every node of a straight-line program
(:mod:`obsnl.slp`) holds a truncated power series in ``t`` of jets: an array ``V[k]`` of values
and ``G[k, j]`` of gradients, in GF(p). The solution of ``x' = f(x)`` is built in Taylor mode:
at step ``k`` every node gets its coefficient ``k`` and then ``x[k+1] = f[k]/(k+1)``
(algorithms.md §3.5). Products of series are convolutions, quotients the usual recursion,
and the atoms of :mod:`obsnl.augment` have their own recursions (``E' = E g'``, ``g l' = g'``,
Miller's recurrence for roots, the ``sin``/``cos`` pair).

Arithmetic is exact: residues are int64 in ``[0, p)`` with ``p < 2**50`` and products are reduced
with a floating-point quotient estimate corrected in integers (the int64 product wraps modulo
``2**64`` and the remainder is small, so the result is exact). No float ever decides a rank.
"""

from __future__ import annotations

import math
import random
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from .augment import Rationalized
from .errors import AnalysisError, NotSupportedError
from .model import Model
from .slp import Program, compile_program

__all__ = ["Problem", "make_problem", "Field", "random_prime", "Point", "SeriesRun", "run_series", "Resample"]

PRIME_BITS = 50


class Resample(Exception):
    """The random point (or prime) hit a zero denominator or a non-residue; draw another."""


class TimeUp(Exception):
    """The time limit was reached."""


# --------------------------------------------------------------------------- the field
@dataclass(frozen=True)
class Field:
    """GF(p) with exact vectorised products for p < 2**50."""

    p: int

    def __post_init__(self) -> None:
        if not 2 < self.p < 2**PRIME_BITS:
            raise ValueError(f"prime must be below 2**{PRIME_BITS}")

    @property
    def pinv(self) -> float:
        return 1.0 / self.p

    def mul(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Elementwise ``a*b mod p`` (broadcasting), exact."""
        q = (a.astype(np.float64) * b.astype(np.float64) * self.pinv).astype(np.int64)
        r = a * b - q * self.p
        return r % self.p

    def inv(self, x: int) -> int:
        x = int(x) % self.p
        if x == 0:
            raise Resample("division by zero")
        return pow(x, -1, self.p)

    def el(self, c: sp.Rational) -> int:
        c = sp.Rational(c)
        return int(c.p) % self.p * self.inv(int(c.q)) % self.p

    def root(self, x: int, q: int) -> int:
        """A q-th root of x in GF(p) (Resample when there is none)."""
        x = int(x) % self.p
        if x == 0:
            raise Resample("root of zero")
        g = math.gcd(q, self.p - 1)
        if g == 1:
            return pow(x, pow(q, -1, self.p - 1), self.p)
        if q == 2:
            from flint import nmod

            if pow(x, (self.p - 1) // 2, self.p) != 1:
                raise Resample("non-residue")
            return int(nmod(x, self.p).sqrt())
        from sympy.ntheory import nthroot_mod

        r = nthroot_mod(x, q, self.p)
        if r is None:
            raise Resample("non-residue")
        return int(r)


def random_prime(rng: random.Random, bits: int = PRIME_BITS) -> int:
    """A random prime in [2**(bits-1), 2**bits)."""
    lo = 2 ** (bits - 1)
    start = rng.randrange(lo, 2**bits - 2**20)
    return int(sp.nextprime(start))


# --------------------------------------------------------------------------- the problem
@dataclass(frozen=True)
class Problem:
    """A smooth model prepared for the exact engines.

    Attributes
    ----------
    rational
        The rationalized model (:func:`obsnl.augment.rationalize`).
    columns
        Names of the unknowns (Jacobian columns): states with unknown initial value, parameters,
        then the Taylor coefficients of the unknown inputs (``w``, ``w_d1``, ...).
    variables
        The state and parameter names among ``columns``.
    input_columns
        ``{unknown input: (column indices of w, w_d1, ...)}``.
    specific
        True when some known initial condition has a specific value (the stabilisation bound on the
        number of derivatives does not hold there; see :func:`order_bound`).
    dim
        Dimension of the augmented system (states, parameters, atoms, unknown-input derivatives).
    """

    rational: Rationalized
    columns: tuple[str, ...]
    variables: tuple[str, ...]
    input_columns: Mapping[str, tuple[int, ...]]
    specific: bool
    dim: int
    unknown_input_derivatives: int
    input_derivatives: int | None
    program: Program = field(repr=False, compare=False, default=None)  # type: ignore[assignment]
    leaves: tuple[sp.Symbol, ...] = field(repr=False, compare=False, default=())

    @property
    def model(self) -> Model:
        return self.rational.model

    @property
    def size(self) -> int:
        return len(self.columns)

    def order_bound(self) -> int:
        """Number of series terms (derivative orders 0..K-1) used.

        With generic initial values the rank of the observability matrix grows at every order until
        it stops, so ``dim`` terms suffice (algorithms.md §1.4). With specific initial values that
        argument fails (the rank may stall and grow again); obsnl then uses ``2*dim + n`` terms and
        says so in the notes.
        """
        if self.specific:
            return 2 * self.dim + len(self.model.states)
        return self.dim


def make_problem(
    rational: Rationalized, *, unknown_input_derivatives: int = 1, input_derivatives: int | None = None
) -> Problem:
    """Columns, order bound and compiled program of a rationalized smooth model."""
    model = rational.model
    known = set(model.known_initial_conditions)
    cols: list[str] = [s.name for s in model.states if s not in known]
    cols += [s.name for s in model.parameters]
    variables = tuple(cols)
    inp_cols: dict[str, tuple[int, ...]] = {}
    for w in model.unknown_inputs:
        idx = []
        for j in range(unknown_input_derivatives + 1):
            idx.append(len(cols))
            cols.append(w.name if j == 0 else f"{w.name}_d{j}")
        inp_cols[w.name] = tuple(idx)
    specific = any(v.is_Rational for v in rational.ic_values.values())
    dim = (len(model.states) + len(model.parameters) + len(rational.atoms)
           + len(model.unknown_inputs) * (unknown_input_derivatives + 1))
    leaves = (tuple(model.states) + tuple(model.parameters) + tuple(model.known_constants)
              + tuple(model.inputs) + tuple(model.unknown_inputs) + rational.atom_symbols)
    exprs: list[sp.Expr] = [rational.rhs[s] for s in model.states]
    exprs += list(rational.outputs.values())
    exprs += [a.arg for a in rational.atoms if a.kind not in ("const",)]
    exprs += [1 + a.arg**2 for a in rational.atoms if a.kind == "atan"]
    exprs += list(rational.ic_values.values())
    exprs += list(rational.initial.values())
    program = compile_program(exprs, leaves)
    return Problem(rational=rational, columns=tuple(cols), variables=variables, input_columns=inp_cols,
                   specific=specific, dim=dim, unknown_input_derivatives=unknown_input_derivatives,
                   input_derivatives=input_derivatives, program=program, leaves=leaves)


# --------------------------------------------------------------------------- evaluation
@dataclass
class Point:
    """The random choices of one run (for reproducibility and for the ORC's initial jets)."""

    p: int
    values: dict[sp.Symbol, int]
    input_series: dict[sp.Symbol, list[int]]
    unknown_inputs: dict[sp.Symbol, list[int]] = field(default_factory=dict)


@dataclass
class SeriesRun:
    """Output of :func:`run_series`: Jacobian rows per order, and the initial jets."""

    p: int
    rows: list[np.ndarray]  # rows[k] has shape (n_outputs, M): gradient of coefficient k of each output
    init: dict[sp.Symbol, tuple[int, np.ndarray]]  # t^0 jet of every leaf (states, atoms, ...)
    point: Point
    orders: int
    full_rank_at: int | None = None


class _Series:
    """Coefficient arrays of one node."""

    __slots__ = ("V", "G", "tv")

    def __init__(self, K: int, M: int, grad: bool, tv: bool) -> None:
        self.V = np.zeros(K, dtype=np.int64)
        self.G = np.zeros((K, M), dtype=np.int64) if grad else None
        self.tv = tv


def run_series(
    problem: Problem,
    rng: random.Random,
    *,
    K: int,
    p: int | None = None,
    deadline: float | None = None,
    stop: Callable[[list[np.ndarray], int], bool] | None = None,
    max_resample: int = 12,
    fixed: Mapping[sp.Symbol, int] | None = None,
) -> SeriesRun:
    """Evaluate the output series of ``problem`` to ``K`` terms at a random point.

    ``stop(rows, p)`` is called after each order and may end the computation early (full rank).
    ``fixed`` forces the values of some parameters or known constants (the ORC's second point).
    Raises :class:`AnalysisError` when every point makes a denominator vanish.
    """
    last: Exception | None = None
    for _ in range(max_resample):
        prime = p if p is not None else random_prime(rng)
        try:
            return _run_once(problem, Field(prime), rng, K, deadline, stop, fixed or {})
        except Resample as exc:
            last = exc
            if _ >= 2:  # a non-residue of a fixed number needs another prime
                p = None
            continue
    raise AnalysisError(
        f"model {problem.model.name!r}: a denominator (or the argument of a root/log) vanishes at every "
        f"random point tried ({last}); check the model and the given initial conditions"
    )


def _run_once(
    problem: Problem, F: Field, rng: random.Random, K: int, deadline: float | None,
    stop: Callable[[list[np.ndarray], int], bool] | None,
    fixed: Mapping[sp.Symbol, int],
) -> SeriesRun:
    model = problem.model
    rat = problem.rational
    prog = problem.program
    p = F.p
    M = problem.size
    col = {name: j for j, name in enumerate(problem.columns)}
    known = set(model.known_initial_conditions)
    atoms = {a.symbol: a for a in rat.atoms}
    state_set = set(model.states)
    n_states = len(model.states)
    n_out = len(rat.outputs)
    rhs_roots = prog.roots[:n_states]
    out_roots = prog.roots[n_states:n_states + n_out]
    pos = n_states + n_out
    atom_arg_root: dict[sp.Symbol, int] = {}
    for a in rat.atoms:
        if a.kind != "const":
            atom_arg_root[a.symbol] = prog.roots[pos]
            pos += 1
    atan_q_root: dict[sp.Symbol, int] = {}
    for a in rat.atoms:
        if a.kind == "atan":
            atan_q_root[a.symbol] = prog.roots[pos]
            pos += 1
    ic_root = dict(zip(rat.ic_values, prog.roots[pos:pos + len(rat.ic_values)]))
    pos += len(rat.ic_values)
    init_root = dict(zip(rat.initial, prog.roots[pos:pos + len(rat.initial)]))

    # time variation and gradient flags per node
    ops = prog.ops
    n = len(ops)
    tv = [False] * n
    grad = [False] * n
    unknown_syms = {s for s in model.states if s not in known} | set(model.parameters) | set(model.unknown_inputs)
    for i, op in enumerate(ops):
        if op.kind == "leaf":
            s = op.arg
            if s in state_set or s in model.inputs or s in model.unknown_inputs:
                tv[i] = True
                grad[i] = s in state_set or s in model.unknown_inputs
            elif s in atoms:
                tv[i] = atoms[s].time_varying
                grad[i] = atoms[s].kind != "const"
            else:
                grad[i] = s in unknown_syms
        elif op.kind == "const":
            pass
        else:
            tv[i] = tv[op.a] or (op.b >= 0 and tv[op.b])
            grad[i] = grad[op.a] or (op.b >= 0 and grad[op.b])
    # state ICs given by expressions in parameters carry gradients; states always may
    series = [_Series(K + 1, M, grad[i] or ops[i].kind == "leaf" and ops[i].arg in state_set, tv[i])
              for i in range(n)]
    leaf_node = prog.leaves

    # ---------------------------------------------------------------- random choices
    values: dict[sp.Symbol, int] = {}
    inputs_series: dict[sp.Symbol, list[int]] = {}
    for s in model.parameters + model.known_constants:
        values[s] = rng.randrange(p)
        if s in fixed:
            values[s] = fixed[s] % p
    for s in model.states:
        if s not in rat.ic_values:
            values[s] = rng.randrange(p)
    for u in model.inputs:
        nz = K + 1 if problem.input_derivatives is None else min(K + 1, problem.input_derivatives + 1)
        coeffs = [rng.randrange(p) for _ in range(nz)] + [0] * (K + 1 - nz)
        inputs_series[u] = coeffs
    w_coeffs: dict[sp.Symbol, list[int]] = {w: [rng.randrange(p) for _ in range(problem.unknown_input_derivatives + 1)]
                                            for w in model.unknown_inputs}
    stand_in: dict[sp.Symbol, int] = {a.symbol: rng.randrange(p) for a in rat.atoms}
    tau: dict[sp.Symbol, int] = {a.symbol: rng.randrange(p) for a in rat.atoms if a.kind == "sin"}

    # factorials
    inv_int = [0] + [F.inv(i) for i in range(1, K + 2)]

    def conv(aV, aG, bV, bG, M=M):
        """sum_i a[i] (x) b[rev i] for equally long slices; returns (value, gradient)."""
        v = int(F.mul(aV, bV).sum() % p)
        g = None
        if bG is not None:
            g = F.mul(aV[:, None], bG).sum(axis=0)
        if aG is not None:
            t = F.mul(bV[:, None], aG).sum(axis=0)
            g = t if g is None else g + t
        if g is not None:
            g %= p
        return v, g

    def set_leaf_k0(i: int, s: sp.Symbol) -> None:
        S = series[i]
        if s in model.parameters:
            S.V[0] = values[s]
            S.G[0, col[s.name]] = 1
        elif s in model.known_constants:
            S.V[0] = values[s]
        elif s in model.inputs:
            S.V[: K + 1] = inputs_series[s]
        elif s in model.unknown_inputs:
            cs = w_coeffs[s]
            fact = 1
            for j, c in enumerate(cs):
                if j:
                    fact = fact * j % p
                ifact = F.inv(fact)
                S.V[j] = c * ifact % p
                S.G[j, problem.input_columns[s.name][j]] = ifact

    def state_k0(i: int, s: sp.Symbol) -> None:
        S = series[i]
        if s in rat.ic_values:
            src = series[ic_root[s]]
            S.V[0] = src.V[0]
            if src.G is not None:
                S.G[0] = src.G[0]
        else:
            S.V[0] = values[s]
            if s not in known:
                S.G[0, col[s.name]] = 1

    def atom_k0(i: int, a) -> None:
        S = series[i]
        if a.kind == "const":
            S.V[0] = stand_in[a.symbol]
            return
        g = series[atom_arg_root[a.symbol]]
        g0 = int(g.V[0])
        dg = g.G[0] if g.G is not None else np.zeros(M, dtype=np.int64)
        fixed = init_root.get(a.symbol)
        if a.kind == "exp":
            v = int(series[fixed].V[0]) if fixed is not None else stand_in[a.symbol]
            S.V[0] = v
            S.G[0] = F.mul(np.int64(v), dg)
        elif a.kind == "log":
            v = int(series[fixed].V[0]) if fixed is not None else stand_in[a.symbol]
            S.V[0] = v
            S.G[0] = F.mul(np.int64(F.inv(g0)), dg)
        elif a.kind == "atan":
            q0 = int(series[atan_q_root[a.symbol]].V[0])
            v = int(series[fixed].V[0]) if fixed is not None else stand_in[a.symbol]
            S.V[0] = v
            S.G[0] = F.mul(np.int64(F.inv(q0)), dg)
        elif a.kind == "root":
            if fixed is not None and fixed != i:
                v = int(series[fixed].V[0])
            else:
                v = F.root(g0, a.q)
            S.V[0] = v
            S.G[0] = F.mul(np.int64(v * F.inv(a.q * g0 % p) % p), dg)
        elif a.kind == "sin":
            c_node = leaf_node[a.partner]
            if fixed is not None:  # sin(0) = 0, cos(0) = 1
                s0, c0 = 0, 1
            else:
                t = tau[a.symbol]
                d = F.inv((1 + t * t) % p)
                s0 = 2 * t * d % p
                c0 = (1 - t * t) * d % p
            S.V[0] = s0
            C = series[c_node]
            C.V[0] = c0
            S.G[0] = F.mul(np.int64(c0), dg)
            C.G[0] = F.mul(np.int64((p - s0) % p), dg)
        elif a.kind == "cos":
            pass  # set together with its sine
        else:  # pragma: no cover
            raise NotSupportedError(f"atom kind {a.kind}")

    # order of evaluation: a topological order (atoms after their arguments, states after their
    # initial-value expressions, cosines after their sines); time-invariant nodes first
    deps: list[list[int]] = [[] for _ in range(n)]
    for i, op in enumerate(ops):
        if op.kind == "leaf":
            s = op.arg
            if s in ic_root:
                deps[i].append(ic_root[s])
            if s in atoms:
                a = atoms[s]
                for table in (atom_arg_root, atan_q_root, init_root):
                    if s in table and table[s] != i:
                        deps[i].append(table[s])
                if a.kind == "cos":
                    deps[i].append(leaf_node[a.partner])
        else:
            deps[i] = [j for j in (op.a, op.b) if j >= 0]
    topo: list[int] = []
    mark = [0] * n
    for start in range(n):
        if mark[start]:
            continue
        stack = [(start, 0)]
        while stack:
            node, it = stack.pop()
            if it == 0:
                if mark[node] == 2:
                    continue
                mark[node] = 1
            if it < len(deps[node]):
                stack.append((node, it + 1))
                d = deps[node][it]
                if mark[d] == 0:
                    stack.append((d, 0))
                elif mark[d] == 1:  # pragma: no cover - programs are acyclic
                    raise NotSupportedError("internal: cyclic program")
            else:
                mark[node] = 2
                topo.append(node)
    order_ti = [i for i in topo if not tv[i]]
    order_tv = [i for i in topo if tv[i]]

    def compute(i: int, k: int) -> None:
        op = ops[i]
        S = series[i]
        kind = op.kind
        if kind == "leaf":
            s = op.arg
            if k == 0:
                if s in state_set:
                    state_k0(i, s)
                elif s in atoms:
                    atom_k0(i, atoms[s])
                else:
                    set_leaf_k0(i, s)
            elif s in atoms and atoms[s].time_varying:
                atom_k(i, atoms[s], k)
            return
        if kind == "const":
            if k == 0:
                S.V[0] = F.el(op.arg)
            return
        A = series[op.a]
        if kind in ("neg", "scale", "shift"):
            if kind == "neg":
                S.V[k] = (p - A.V[k]) % p
                if A.G is not None:
                    S.G[k] = (p - A.G[k]) % p
            elif kind == "scale":
                c = np.int64(F.el(op.arg))
                S.V[k] = int(F.mul(c, A.V[k:k + 1])[0])
                if A.G is not None:
                    S.G[k] = F.mul(c, A.G[k])
            else:
                S.V[k] = (A.V[k] + (F.el(op.arg) if k == 0 else 0)) % p
                if A.G is not None:
                    S.G[k] = A.G[k]
            return
        B = series[op.b]
        if kind in ("add", "sub"):
            if kind == "add":
                S.V[k] = (A.V[k] + B.V[k]) % p
            else:
                S.V[k] = (A.V[k] - B.V[k]) % p
            if S.G is not None:
                ga = A.G[k] if A.G is not None else 0
                gb = B.G[k] if B.G is not None else 0
                S.G[k] = ((ga + gb) if kind == "add" else (ga - gb)) % p
            return
        if kind == "mul":
            if A.tv and B.tv:
                v, g = conv(A.V[: k + 1], A.G[: k + 1] if A.G is not None else None,
                            B.V[k::-1], B.G[k::-1] if B.G is not None else None)
            else:
                if not A.tv:
                    A, B = B, A  # now B is constant
                # c[k] = a[k] (x) b[0]
                v, g = conv(A.V[k:k + 1], A.G[k:k + 1] if A.G is not None else None,
                            B.V[0:1], B.G[0:1] if B.G is not None else None)
            S.V[k] = v
            if g is not None:
                S.G[k] = g
            return
        if kind == "div":
            b0 = int(B.V[0])
            binv = F.inv(b0)
            # numerator: a[k] - sum_{j=1..k} b[j] (x) c[k-j]
            nv = int(A.V[k])
            ng = A.G[k].copy() if A.G is not None else (np.zeros(M, dtype=np.int64) if S.G is not None else None)
            if B.tv and k > 0:
                v, g = conv(B.V[1:k + 1], B.G[1:k + 1] if B.G is not None else None,
                            S.V[k - 1::-1], S.G[k - 1::-1] if S.G is not None else None)
                nv = (nv - v) % p
                if g is not None:
                    ng = (ng - g) % p
            cv = nv * binv % p
            S.V[k] = cv
            if S.G is not None:
                if B.G is not None:
                    ng = (ng - F.mul(np.int64(cv), B.G[0])) % p
                S.G[k] = F.mul(np.int64(binv), ng)
            return
        raise NotSupportedError(f"internal: op {kind}")  # pragma: no cover

    def atom_k(i: int, a, k: int) -> None:
        S = series[i]
        if a.kind == "cos":
            return
        g = series[atom_arg_root[a.symbol]]
        jv = (np.arange(1, k + 1, dtype=np.int64)) % p
        ik = inv_int[k]
        if a.kind == "exp":
            # E[k] = (1/k) sum_{j=1..k} j g[j] (x) E[k-j]
            gv = F.mul(jv, g.V[1:k + 1])
            gg = F.mul(jv[:, None], g.G[1:k + 1]) if g.G is not None else None
            v, gr = conv(gv, gg, S.V[k - 1::-1], S.G[k - 1::-1])
            S.V[k] = v * ik % p
            S.G[k] = F.mul(np.int64(ik), gr)
        elif a.kind in ("log", "atan"):
            # den * a' = g' :  a[k] = (g[k] - (1/k) sum_{j=1..k-1} j a[j] (x) den[k-j]) / den[0]
            den = g if a.kind == "log" else series[atan_q_root[a.symbol]]
            nv = int(g.V[k])
            ng = g.G[k].copy() if g.G is not None else np.zeros(M, dtype=np.int64)
            if k > 1:
                av = F.mul(jv[:-1], S.V[1:k])
                ag = F.mul(jv[:-1, None], S.G[1:k])
                v, gr = conv(av, ag, den.V[k - 1:0:-1], den.G[k - 1:0:-1] if den.G is not None else None)
                nv = (nv - v * ik) % p
                ng = (ng - F.mul(np.int64(ik), gr)) % p
            _divide_into(S, k, nv, ng, den)
        elif a.kind == "root":
            # w[k] = 1/(k g0) sum_{j=1..k} ((r+1) j - k) g[j] (x) w[k-j],  r = 1/q
            r1 = (1 + F.inv(a.q)) % p
            coef = (F.mul(np.int64(r1), jv) - k) % p
            gv = F.mul(coef, g.V[1:k + 1])
            gg = F.mul(coef[:, None], g.G[1:k + 1]) if g.G is not None else None
            v, gr = conv(gv, gg, S.V[k - 1::-1], S.G[k - 1::-1])
            _divide_into(S, k, v * ik % p, F.mul(np.int64(ik), gr), g)
        elif a.kind == "sin":
            C = series[leaf_node[a.partner]]
            gv = F.mul(jv, g.V[1:k + 1])
            gg = F.mul(jv[:, None], g.G[1:k + 1]) if g.G is not None else None
            sv, sg = conv(gv, gg, C.V[k - 1::-1], C.G[k - 1::-1])
            cv, cg = conv(gv, gg, S.V[k - 1::-1], S.G[k - 1::-1])
            S.V[k] = sv * ik % p
            S.G[k] = F.mul(np.int64(ik), sg)
            C.V[k] = (p - cv * ik % p) % p
            C.G[k] = (p - F.mul(np.int64(ik), cg)) % p

    def _divide_into(S: _Series, k: int, nv: int, ng: np.ndarray, den: _Series) -> None:
        binv = F.inv(int(den.V[0]))
        cv = nv * binv % p
        S.V[k] = cv
        if den.G is not None:
            ng = (ng - F.mul(np.int64(cv), den.G[0])) % p
        S.G[k] = F.mul(np.int64(binv), ng)

    # ---------------------------------------------------------------- step 0
    for i in order_ti:
        compute(i, 0)
    for i in order_tv:
        compute(i, 0)
    init: dict[sp.Symbol, tuple[int, np.ndarray]] = {}
    for s, i in leaf_node.items():
        G0 = series[i].G[0].copy() if series[i].G is not None else np.zeros(M, dtype=np.int64)
        init[s] = (int(series[i].V[0]), G0)
    rows: list[np.ndarray] = []

    def out_row(k: int) -> np.ndarray:
        R = np.zeros((n_out, M), dtype=np.int64)
        for r, idx in enumerate(out_roots):
            if series[idx].G is not None:
                R[r] = series[idx].G[k]
        return R

    state_nodes = [leaf_node[s] for s in model.states]
    rows.append(out_row(0))
    point = Point(p=p, values=values, input_series=inputs_series, unknown_inputs=w_coeffs)
    full_at = None
    if stop is not None and stop(rows, p):
        return SeriesRun(p, rows, init, point, 1, full_rank_at=1)
    for k in range(1, K):
        if deadline is not None and time.perf_counter() > deadline:
            raise TimeUp(f"time limit reached after {k} of {K} series terms")
        # x[k] = f[k-1] / k
        for s_node, f_node in zip(state_nodes, rhs_roots):
            Fs = series[f_node]
            S = series[s_node]
            S.V[k] = int(Fs.V[k - 1]) * inv_int[k] % p
            if Fs.G is not None:
                S.G[k] = F.mul(np.int64(inv_int[k]), Fs.G[k - 1])
        for i in order_tv:
            if ops[i].kind == "leaf" and ops[i].arg in state_set:
                continue
            compute(i, k)
        rows.append(out_row(k))
        if stop is not None and stop(rows, p):
            full_at = k + 1
            break
    return SeriesRun(p, rows, init, point, len(rows), full_rank_at=full_at)
