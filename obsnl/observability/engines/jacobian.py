"""The observability Jacobian of a smooth model at one random point mod p, kept for reuse.

The engine (:mod:`obsnl.observability.engines.sedoglavic`) turns the Jacobian into verdicts. The symmetry search, the
identifiable functions and the reparametrization (:mod:`obsnl.observability.certificates.symmetry`, :mod:`obsnl.recombination.identifiable`,
:mod:`obsnl.recombination.reparametrize`) need the Jacobian itself: its columns, rows, rank and kernel, the point, the
prime and the values of the non-rational atoms, and gradients of further expressions at that same
point. :func:`observability_jacobian` computes it with the engine's own power series
(:func:`obsnl.algebra.series.run_series`: the same prepared problem, order bound and arithmetic), and
:meth:`ModularJacobian.gradients` evaluates expressions over the model's symbols at its point, their
non-rational terms rewritten over the model's atoms (:meth:`obsnl.algebra.atoms.Rewriter.extend`) so that
they take the Jacobian's stand-ins (new atoms draw new ones, kept for later calls).

The function test (algorithms.md §1.6): ``g`` is locally identifiable iff ``grad g . k = 0`` for every
kernel vector ``k``. Rank and kernel are exact unless the prime or the point is special; the
probability of that is at most :attr:`ModularJacobian.failure`, Sedoglavic's Prop. 3.3 bound for one
run (:mod:`obsnl.algebra.bounds`, where the argument is).
"""

from __future__ import annotations

import random
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from obsnl.algebra.atom_table import Atom
from obsnl.algebra.atoms import Rewriter
from obsnl.algebra.augment import rationalize
from obsnl.algebra.bounds import bound_sizes, failure_bound
from obsnl.algebra.jets import (
    AtomJet,
    atom_deps,
    atom_expressions,
    atom_roots,
    evaluate,
    topological_order,
)
from obsnl.algebra.modp import Field, Resample, nullspace_mod_p
from obsnl.algebra.problem import make_problem
from obsnl.algebra.series import SeriesRun, run_series
from obsnl.algebra.slp import compile_program
from obsnl.errors import AnalysisError, NotSupportedError
from obsnl.model.core import Model

__all__ = ["ModularJacobian", "observability_jacobian"]

Jet = tuple[int, list[int]]


class _AtPoint:
    """Jets of expressions at the point of one run: the model's leaves and atoms, and atoms added later."""

    def __init__(self, model: Model, atoms: Sequence[Atom], run: SeriesRun, M: int, seed: object) -> None:
        self.F, self.M = Field(run.p), M
        self.symbols = frozenset(model.symbols.values())
        self.rewriter = Rewriter(self.symbols, set(model.states) | set(model.inputs), unit=True)
        self.rewriter.seed(atoms)
        self.known: dict[sp.Symbol, Jet] = {s: (int(v), [int(x) for x in g]) for s, (v, g) in run.init.items()}
        self.rng = random.Random(f"jacobian-atoms:{seed}")

    def jets(self, exprs: Sequence[sp.Expr]) -> list[Jet]:
        missing = sorted(set().union(*(e.free_symbols for e in exprs)) - self.symbols, key=lambda s: s.name)
        if missing:
            raise AnalysisError(f"{missing[0]} is not a symbol of the model")
        rational = self.rewriter.extend(exprs)
        new = [a for a in self.rewriter.ordered_atoms() if a.symbol not in self.known]
        prog = compile_program(rational + atom_expressions(new), tuple(self.known) + tuple(a.symbol for a in new))
        leaf = prog.leaves
        arg, den = atom_roots(new, prog.roots[len(rational) :])
        topo = topological_order(prog.ops, atom_deps(new, leaf, arg, den))
        p = self.F.p
        atoms = {
            leaf[a.symbol]: AtomJet(
                a.kind,
                arg.get(a.symbol, -1),
                den.get(a.symbol, -1),
                leaf[a.partner] if a.partner is not None else -1,
                a.q,
                value=self.rng.randrange(1, p),
                tau=self.rng.randrange(p) if a.kind == "sin" else 0,
            )
            for a in new
        }
        try:
            V, G = evaluate(prog.ops, topo, self.F, self.M, {leaf[s]: j for s, j in self.known.items()}, atoms)
        except Resample as exc:
            raise AnalysisError(
                f"{exc} at the point of this Jacobian (in {', '.join(map(str, exprs))}); use another seed"
            ) from None
        for a in new:
            self.known[a.symbol] = (V[leaf[a.symbol]], G[leaf[a.symbol]])
        return [(V[r], G[r]) for r in prog.roots[: len(rational)]]


@dataclass(frozen=True)
class ModularJacobian:
    """The Jacobian of the output series at one random point mod p, with everything needed to reuse it.

    Attributes
    ----------
    variables
        The unknowns (states with unknown initial value, then parameters): the columns.
    rows
        Gradients of the output coefficients (orders ``0..order-1``, outputs in turn).
    rank, kernel
        Rank and a kernel basis (vectors over the columns) modulo ``p``.
    point
        The value of every symbol of the model at ``t = 0`` (known initial values applied).
    p
        The prime.
    order
        Number of series terms (the engine's order bound, :meth:`obsnl.algebra.problem.Problem.order_bound`).
    failure
        Upper bound on the probability that rank or kernel differ from the generic ones.
    """

    variables: tuple[sp.Symbol, ...]
    rows: tuple[tuple[int, ...], ...]
    rank: int
    kernel: tuple[tuple[int, ...], ...]
    point: Mapping[sp.Symbol, int]
    p: int
    order: int
    failure: float
    _at: _AtPoint = field(compare=False, repr=False)

    @property
    def atoms(self) -> dict[Atom, int]:
        """Values at the point of the non-rational atoms (the model's, and those added by evaluations)."""
        table = self._at.rewriter.atoms
        return {table[s]: v for s, (v, _) in self._at.known.items() if s in table}

    @property
    def unobservable(self) -> tuple[sp.Symbol, ...]:
        """Unknowns with a nonzero kernel row (the kernel test of algorithms.md §1.6)."""
        return tuple(v for j, v in enumerate(self.variables) if any(k[j] for k in self.kernel))

    def jets(self, exprs: Iterable[sp.Expr]) -> list[tuple[int, list[int]]]:
        """Values and gradients (over :attr:`variables`) of ``exprs`` (in the model's symbols) at the point."""
        return self._at.jets([sp.sympify(e) for e in exprs])

    def gradients(self, exprs: Iterable[sp.Expr]) -> list[list[int]]:
        """Gradients of ``exprs`` at the point."""
        return [g for _, g in self.jets(exprs)]

    def values(self, exprs: Iterable[sp.Expr]) -> list[int]:
        """Values of ``exprs`` at the point."""
        return [v for v, _ in self.jets(exprs)]

    def identifiable(self, exprs: Iterable[sp.Expr]) -> list[bool]:
        """Function test: ``grad g . k == 0`` for every kernel vector ``k``, for each expression."""
        return [all(sum(a * b for a, b in zip(g, k)) % self.p == 0 for k in self.kernel) for g in self.gradients(exprs)]


def observability_jacobian(model: Model, *, seed: int = 0, p: int | None = None) -> ModularJacobian:
    """The observability-identifiability Jacobian of a smooth ``model`` at a random point mod p.

    Parameters
    ----------
    model : Model
        A smooth model (one branch); unknown inputs are not supported here.
    seed : int
        Seed of the random prime, point and input series.
    p : int or None
        A prime below ``2**50`` to use instead of a random one (several Jacobians in one field).

    Returns
    -------
    ModularJacobian

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="decay", states=["x"], parameters=["a", "b"],
    ...           equations={"x": "-a*b*x"}, outputs={"y": "x"})
    >>> J = observability_jacobian(m)
    >>> J.rank, [v.name for v in J.unobservable], J.identifiable([m.symbol("a") * m.symbol("b")])
    (2, ['a', 'b'], [True])
    """
    if not model.is_smooth:
        raise NotSupportedError(f"model {model.name!r} is not smooth; pass a branch (obsnl.model.split_branches)")
    if model.unknown_inputs:
        raise NotSupportedError(
            "unknown inputs are not supported by the symmetry search; declare them as parameters or known inputs"
        )
    if not model.outputs:
        raise AnalysisError(f"model {model.name!r} has no outputs; nothing is observable")
    problem = make_problem(rationalize(model, unit=True))  # exp(N log x) for x**(2*N): x**N needs no root
    run = run_series(problem, random.Random(f"jacobian:{seed}"), K=problem.order_bound(), p=p)
    if p is not None and run.p != p:
        raise AnalysisError(f"model {model.name!r}: no usable point modulo {p}; use another prime or seed")
    M = problem.size
    rows = np.vstack(run.rows)
    kernel = nullspace_mod_p(rows, M, run.p)
    syms = model.symbols
    point = {s: run.init[s][0] for s in syms.values() if s in run.init}
    return ModularJacobian(
        variables=tuple(syms[c] for c in problem.columns),
        rows=tuple(map(tuple, rows.tolist())),
        rank=M - len(kernel),
        kernel=tuple(map(tuple, kernel)),
        point=point,
        p=run.p,
        order=run.orders,
        failure=failure_bound(run.p, nfuncs=M, **bound_sizes(problem)),
        _at=_AtPoint(model, problem.rational.atoms, run, M, seed),
    )
