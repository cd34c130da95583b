"""The observability-identifiability Jacobian of a smooth model by power series mod p.

Sedoglavic's construction (algorithms.md §3.5): at a random point of GF(p) the initial states and
parameters become first-order jets (value + gradient), the inputs random truncated series; the
state series is obtained by Picard steps ``x_{k+1} = x0 + integral f(x)`` (one correct coefficient
per step) and the rows of the Jacobian are the gradients of the output coefficients. Its kernel at
the point is the tangent space of the unobservable directions.

Kept small on purpose: it serves the symmetry search and the function test of
:mod:`obsnl.symmetry` and :mod:`obsnl.reparam` (which need the point, the rows and the atom values,
not only the verdict of an engine).
"""

from __future__ import annotations

import random
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import flint
import sympy as sp

from .errors import AnalysisError, NotSupportedError
from .fields import PRIME, Program, Redraw, compile_program, eval_dual, nullspace_mod_p, rank_mod_p, _inv, _root
from .model import Model

__all__ = ["ModularJacobian", "observability_jacobian"]


@dataclass(frozen=True)
class ModularJacobian:
    """The Jacobian of the output series at one random point mod p, with everything needed to reuse it.

    Attributes
    ----------
    variables
        The unknowns (states with unknown initial value, then parameters): the columns.
    rows
        Gradients of the output coefficients.
    rank, kernel
        Rank and a kernel basis (vectors over the columns).
    point
        The value of every symbol at the point (unknowns, known states, constants, inputs at t=0).
    atoms
        Random values of the non-rational atoms (shared with later evaluations at the same point).
    """

    variables: tuple[sp.Symbol, ...]
    rows: tuple[tuple[int, ...], ...]
    rank: int
    kernel: tuple[tuple[int, ...], ...]
    point: Mapping[sp.Symbol, int]
    atoms: dict = field(compare=False, repr=False)

    @property
    def unobservable(self) -> tuple[sp.Symbol, ...]:
        """Unknowns with a nonzero kernel row (the kernel test of algorithms.md §1.6)."""
        return tuple(v for j, v in enumerate(self.variables) if any(k[j] for k in self.kernel))

    def gradients(self, exprs: list[sp.Expr]) -> list[list[int]]:
        """Gradients of ``exprs`` (functions of the unknowns and constants) at the point."""
        return [g for _, g in self.jets(exprs)]

    def jets(self, exprs: list[sp.Expr]) -> list[tuple[int, list[int]]]:
        """Values and gradients of ``exprs`` at the point."""
        syms = sorted(set(self.point) | set().union(*(sp.sympify(e).free_symbols for e in exprs)),
                      key=lambda s: s.name)
        missing = [s for s in syms if s not in self.point]
        if missing:
            raise AnalysisError(f"{missing[0]} is not a symbol of the model")
        prog = compile_program(exprs, syms)
        return eval_dual(prog, self.point, list(self.variables), random.Random(len(self.atoms)), self.atoms)

    def identifiable(self, exprs: list[sp.Expr]) -> list[bool]:
        """Function test: ``grad g . K == 0`` for each expression."""
        out = []
        for g in self.gradients(exprs):
            out.append(all(sum(a * b for a, b in zip(g, k)) % PRIME == 0 for k in self.kernel))
        return out


# --------------------------------------------------------------------------- series helpers
def _P(coeffs) -> flint.nmod_poly:
    return flint.nmod_poly(list(coeffs), PRIME)


def _exps(s: flint.nmod_poly, prec: int) -> flint.nmod_poly:
    """exp(s) for a series with s(0) = 0, by e' = s' e."""
    c = [int(x) for x in s.coeffs()] + [0] * prec
    e = [1] + [0] * (prec - 1)
    for k in range(1, prec):
        e[k] = sum(j * c[j] * e[k - j] for j in range(1, k + 1)) % PRIME * _inv(k) % PRIME
    return _P(e)


class _Jets:
    """Arithmetic on (series, {column: series}) pairs truncated at ``prec`` terms."""

    def __init__(self, prec: int, atoms: dict, rng: random.Random) -> None:
        self.prec, self.atoms, self.rng = prec, atoms, rng

    def atom(self, key: Any) -> int:
        if key not in self.atoms:
            self.atoms[key] = self.rng.randrange(1, PRIME)
        return self.atoms[key]

    def mul(self, a, b):
        (av, ag), (bv, bg) = a, b
        n = self.prec
        g = {j: av.mul_low(p, n) for j, p in bg.items()}
        for j, p in ag.items():
            q = bv.mul_low(p, n)
            g[j] = g[j] + q if j in g else q
        return av.mul_low(bv, n), g

    def inv(self, a):
        av, ag = a
        if int(av[0]) == 0:
            raise Redraw("zero denominator")
        iv = av.inverse_series_trunc(self.prec)
        m2 = -iv.mul_low(iv, self.prec)
        return iv, {j: m2.mul_low(p, self.prec) for j, p in ag.items()}

    def log_series(self, f, key):
        """log f = log f(0) + integral f'/f, with log f(0) an atom; gradient df/f."""
        fi = self.inv(f)
        body = f[0].derivative().mul_low(fi[0], self.prec).integral().truncate(self.prec)
        return body + self.atom(("log", key)), {j: p.mul_low(fi[0], self.prec) for j, p in f[1].items()}

    def run(self, prog: Program, regs: list) -> list:
        n = self.prec
        for ins in prog.instructions:
            op = ins[0]
            if op == "const":
                regs.append((_P([ins[1] * _inv(ins[2]) % PRIME]), {}))
            elif op == "add":
                v, g = _P([]), {}
                for a in ins[1]:
                    av, ag = regs[a]
                    v += av
                    for j, p in ag.items():
                        g[j] = g[j] + p if j in g else p
                regs.append((v, g))
            elif op == "mul":
                acc = regs[ins[1][0]]
                for a in ins[1][1:]:
                    acc = self.mul(acc, regs[a])
                regs.append(acc)
            elif op == "powi":
                base, k = regs[ins[1]], ins[2]
                if k < 0:
                    base, k = self.inv(base), -k
                acc, sq = None, base
                while k:
                    if k & 1:
                        acc = sq if acc is None else self.mul(acc, sq)
                    k >>= 1
                    if k:
                        sq = self.mul(sq, sq)
                regs.append(acc)
            elif op in ("tpow", "texp"):
                if op == "tpow":
                    f, m, key, rat = regs[ins[1]], regs[ins[2]], ins[3], ins[4]
                    lv, lg = self.log_series(f, key[0])
                    hv = m[0].mul_low(lv, n)
                    hg = self.mul(m, (lv, lg))[1]
                    if rat is not None:
                        f0 = int(f[0][0])
                        w0 = _root(pow(f0, rat[0], PRIME) if rat[0] >= 0 else pow(_inv(f0), -rat[0], PRIME), rat[1])
                    else:
                        w0 = self.atom(("pow", key))
                else:
                    hv, hg = regs[ins[1]]
                    w0 = self.atom(("exp", ins[2]))
                wv = _exps(hv - int(hv[0]), n) * w0
                regs.append((wv, {j: wv.mul_low(p, n) for j, p in hg.items()}))
            elif op == "tlog":
                regs.append(self.log_series(regs[ins[1]], ins[2]))
            else:  # pragma: no cover
                raise NotSupportedError(op)
        return regs


# --------------------------------------------------------------------------- the Jacobian
def observability_jacobian(model: Model, *, seed: int = 0, order: int | None = None) -> ModularJacobian:
    """The observability-identifiability Jacobian of a smooth ``model`` at a random point mod p.

    Parameters
    ----------
    model
        A smooth model (one branch); unknown inputs are not supported here.
    seed
        Seed of the random point and input series.
    order
        Number of series coefficients per output (default: number of unknowns + 1; twice that plus the
        number of states when some initial value is a specific number).
    """
    if not model.is_smooth:
        raise NotSupportedError(f"model {model.name!r} is not smooth; pass a branch (obsnl.split_branches)")
    if model.unknown_inputs:
        raise NotSupportedError("unknown inputs are not supported by the symmetry search; "
                                "declare them as parameters or known inputs")
    if not model.outputs:
        raise AnalysisError(f"model {model.name!r} has no outputs; nothing is observable")
    kic = set(model.known_initial_conditions)
    unknown_states = [s for s in model.states if s not in kic]
    variables = tuple(unknown_states) + tuple(model.parameters)
    col = {v: j for j, v in enumerate(variables)}
    # with specific known initial values the rank may stall and grow again (algorithms.md §1.4): more terms
    specific = any(not v.free_symbols for v in model.initial_condition_values.values())
    K = order or (2 * len(variables) + len(model.states) if specific else len(variables) + 1)
    syms = tuple(model.states) + tuple(model.parameters) + tuple(model.inputs) + tuple(model.known_constants)
    prog = compile_program(list(model.rhs) + list(model.output_exprs), syms)
    ic_prog = compile_program([model.initial_condition_values.get(s, s) for s in model.states], syms)
    ns = len(model.states)
    rng = random.Random(seed)
    for _ in range(20):
        atoms: dict = {}
        try:
            point = {s: rng.randrange(1, PRIME) for s in syms}
            x0 = eval_dual(ic_prog, point, list(variables), rng, atoms)
            for s, (v, _) in zip(model.states, x0):
                point[s] = v
            jets = _Jets(K, atoms, rng)
            inputs = {u: _P([point[u]] + [rng.randrange(PRIME) for _ in range(K - 1)]) for u in model.inputs}
            base = []
            for s in syms:
                if s in inputs:
                    base.append((inputs[s], {}))
                elif s in col and s not in model.states:
                    base.append((_P([point[s]]), {col[s]: _P([1])}))
                else:
                    base.append((_P([point[s]]), {}))
            init = [(_P([v]), {j: _P([gj]) for j, gj in enumerate(g) if gj}) for v, g in x0]
            states = list(init)
            for step in range(1, K):
                jets.prec = step
                regs = jets.run(prog, states + base[ns:])
                states = []
                for i in range(ns):
                    fv, fg = regs[prog.outputs[i]]
                    v = init[i][0] + fv.integral().truncate(step + 1)
                    g = dict(init[i][1])
                    for j, p in fg.items():
                        q = p.integral().truncate(step + 1)
                        g[j] = g[j] + q if j in g else q
                    states.append((v, g))
            jets.prec = K
            regs = jets.run(prog, states + base[ns:])
            rows = []
            for o in prog.outputs[ns:]:
                _, g = regs[o]
                for i in range(K):
                    rows.append(tuple(int(g[j][i]) if j in g and i < g[j].length() else 0
                                      for j in range(len(variables))))
            rank = rank_mod_p(rows, len(variables))
            kernel = tuple(tuple(k) for k in nullspace_mod_p(rows, len(variables)))
            return ModularJacobian(variables, tuple(rows), rank, kernel, point, atoms)
        except Redraw:
            continue
    raise AnalysisError(f"model {model.name!r}: every random point hit a zero denominator")
