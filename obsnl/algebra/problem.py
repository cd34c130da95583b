"""A smooth model prepared for the exact engines: unknowns, order bound, program and its layout.

:func:`make_problem` fixes the Jacobian columns (unknown initial states, parameters, Taylor
coefficients of unknown inputs), compiles the rationalized right-hand sides, outputs, atom arguments
and given initial values into one straight-line program (:mod:`obsnl.algebra.slp`), and derives its
point-independent :class:`Layout`: which node varies in time, a topological order, and the plan of
the batched Taylor step (:func:`obsnl.algebra.taylor.make_plan`). Both engines (:mod:`obsnl.observability.engines.sedoglavic`,
:mod:`obsnl.observability.engines.orc`) start from a :class:`Problem`; the series are evaluated by :mod:`obsnl.algebra.series`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import sympy as sp

from obsnl.algebra.augment import Rationalized
from obsnl.algebra.jets import atom_deps, atom_expressions, atom_roots, topological_order
from obsnl.algebra.slp import Program, compile_program
from obsnl.algebra.taylor import Plan, make_plan
from obsnl.model.core import Model
from obsnl.model.reading.unknown_inputs import ARBITRARY

__all__ = ["Problem", "make_problem", "arbitrary_terms", "Layout"]


@dataclass(frozen=True)
class Problem:
    """A smooth model prepared for the exact engines.

    Attributes
    ----------
    rational
        The rationalized model (:func:`obsnl.algebra.augment.rationalize`).
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
    arbitrary: bool = False  # unknown inputs are any function of time (see make_problem)
    program: Program = field(repr=False, compare=False, default=None)  # type: ignore[assignment]
    leaves: tuple[sp.Symbol, ...] = field(repr=False, compare=False, default=())
    layout: Layout = field(repr=False, compare=False, default=None)  # type: ignore[assignment]

    @property
    def model(self) -> Model:
        return self.rational.model

    @property
    def size(self) -> int:
        return len(self.columns)

    def order_bound(self) -> int:
        """Number of series terms (derivative orders 0..K-1) used.

        With generic initial values the rank of the observability matrix grows at every order until
        it stops, so ``dim`` terms suffice (algorithms.md §1.4). When moreover every initial state
        is an unknown (no known initial conditions), the rank of the Jacobian with respect to the
        ``M`` unknowns itself grows at every order until it stops for good (if all outputs' ``j``-th
        derivatives are algebraic over the lower ones, differentiating the relation along the flow
        gives the same for ``j + 1``; the set of initial points, with the augmented functions'
        values, is invariant under the flow, and the input coefficients form a differential
        field). That rank is at most ``M``, so ``min(dim, M)`` terms suffice. This is a fixed number
        of terms, so the probability bound is unchanged (lower orders only lower the degrees). A
        known initial condition breaks the invariance (the rank may stall and grow again), and with
        specific initial values even the ``dim`` argument fails; obsnl then uses ``2*dim + n``
        terms and says so in the notes.
        """
        if self.arbitrary:  # the inputs' coefficients were sized to this number of terms (make_problem)
            return self.unknown_input_derivatives + 1
        if self.specific:
            return 2 * self.dim + len(self.model.states)
        if not self.model.known_initial_conditions:
            return min(self.dim, self.size)
        return self.dim


def arbitrary_terms(rational: Rationalized) -> int:
    """Number ``N`` of series terms (and of unknown Taylor coefficients per unknown input) used when
    the unknown inputs are arbitrary functions of time.

    The output coefficients of orders ``0..N-1`` depend on an input's Taylor coefficients of orders
    ``0..N-1`` only, so taking these ``N`` coefficients as unknowns (and the later ones as zero) is,
    for a test that reads ``N`` terms, the same as an arbitrary analytic input: the truncation is
    invisible. ``N = n + 1`` with ``n`` the dimension of the augmented system without the inputs
    (states, parameters, augmented functions), ``2 n + n_x + 1`` with specific initial values.

    Why this ``N``: an observable (identifiable) verdict is a certificate at any ``N`` (a nonzero
    minor). An unobservable one needs enough terms. For a linear model ``N = n + 1`` is the classical
    bound: the information the outputs give about the state modulo the unknown inputs is a chain of
    subspaces (the weakly unobservable subspace recursion) that grows by one output derivative per
    step until it stops for good, after at most ``n`` steps. For a nonlinear model obsnl applies the
    same count to the augmented system at the generic point; the reports name ``N`` (this is an
    assumption there, not a theorem: the generic-known-input argument of :meth:`Problem.order_bound`
    does not carry over, because each new output derivative also brings a new input coefficient).
    """
    model = rational.model
    n = len(model.states) + len(model.parameters) + len(rational.atoms)
    specific = any(v.is_Rational for v in rational.ic_values.values())
    return (2 * n + len(model.states) + 1) if specific else n + 1


def make_problem(
    rational: Rationalized, *, unknown_input_derivatives: int | str = 1, input_derivatives: int | None = None
) -> Problem:
    """Columns, order bound and compiled program of a rationalized smooth model.

    ``unknown_input_derivatives`` is ``K`` (each unknown input a polynomial with K non-zero
    derivatives: K + 1 unknown coefficients) or ``"arbitrary"`` (:func:`arbitrary_terms` coefficients
    and as many series terms).

    Parameters
    ----------
    rational : Rationalized
        The smooth model rewritten over atoms (:mod:`obsnl.algebra.augment`).
    unknown_input_derivatives : int or "arbitrary"
        Polynomial model of the unknown inputs, as above.
    input_derivatives : int or None
        Degree of the known inputs as polynomials (None: generic inputs).

    Returns
    -------
    Problem
    """
    model = rational.model
    arbitrary = unknown_input_derivatives == ARBITRARY
    if arbitrary:
        unknown_input_derivatives = arbitrary_terms(rational) - 1 if model.unknown_inputs else 0
    assert isinstance(unknown_input_derivatives, int)
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
    dim = (
        len(model.states)
        + len(model.parameters)
        + len(rational.atoms)
        + len(model.unknown_inputs) * (unknown_input_derivatives + 1)
    )
    leaves = (
        tuple(model.states)
        + tuple(model.parameters)
        + tuple(model.known_constants)
        + tuple(model.inputs)
        + tuple(model.unknown_inputs)
        + rational.atom_symbols
    )
    exprs: list[sp.Expr] = [rational.rhs[s] for s in model.states]
    exprs += list(rational.outputs.values())
    exprs += atom_expressions(rational.atoms)
    exprs += list(rational.ic_values.values())
    exprs += list(rational.initial.values())
    program = compile_program(exprs, leaves)
    return Problem(
        rational=rational,
        columns=tuple(cols),
        variables=variables,
        input_columns=inp_cols,
        specific=specific,
        dim=dim,
        unknown_input_derivatives=unknown_input_derivatives,
        input_derivatives=input_derivatives,
        arbitrary=arbitrary and bool(model.unknown_inputs),
        program=program,
        leaves=leaves,
        layout=_layout(rational, program),
    )


# --------------------------------------------------------------------------- layout
@dataclass(frozen=True)
class Layout:
    """Point-independent structure of a problem's program (built once by :func:`make_problem`)."""

    rhs_roots: tuple[int, ...]
    out_roots: tuple[int, ...]
    atom_arg_root: Mapping[sp.Symbol, int]
    atan_q_root: Mapping[sp.Symbol, int]
    ic_root: Mapping[sp.Symbol, int]
    init_root: Mapping[sp.Symbol, int]
    tv: tuple[bool, ...]
    topo: tuple[int, ...]
    state_nodes: tuple[int, ...]
    input_nodes: tuple[int, ...]  # time-varying known inputs
    winput_nodes: tuple[int, ...]  # unknown inputs
    plan: Plan


def _layout(rational: Rationalized, program: Program) -> Layout:
    model = rational.model
    ops = program.ops
    leaf = program.leaves
    roots = program.roots
    n_states, n_out = len(model.states), len(rational.outputs)
    pos = n_states + n_out
    atom_arg_root, atan_q_root = atom_roots(rational.atoms, roots[pos:])
    pos += len(atom_arg_root) + len(atan_q_root)
    ic_root = dict(zip(rational.ic_values, roots[pos : pos + len(rational.ic_values)]))
    pos += len(rational.ic_values)
    init_root = dict(zip(rational.initial, roots[pos : pos + len(rational.initial)]))
    atoms = {a.symbol: a for a in rational.atoms}
    tv_leaf = set(model.states) | set(model.inputs) | set(model.unknown_inputs)
    tv = [False] * len(ops)
    for i, op in enumerate(ops):
        if op.kind == "leaf":
            s = op.arg
            tv[i] = s in tv_leaf or (s in atoms and atoms[s].time_varying)
        elif op.kind != "const":
            tv[i] = tv[op.a] or (op.b >= 0 and tv[op.b])
    # topological order: atoms after their arguments (and fixed initial values), states after their
    # initial-value expressions, cosines after their sines
    deps = atom_deps(rational.atoms, leaf, atom_arg_root, atan_q_root)
    for s, r in init_root.items():
        if r != leaf[s]:
            deps[leaf[s]].append(r)
    for s, r in ic_root.items():
        deps[leaf[s]] = [r]
    topo = topological_order(ops, deps)
    state_nodes = tuple(leaf[s] for s in model.states)
    input_nodes = tuple(leaf[u] for u in model.inputs)
    winput_nodes = tuple(leaf[w] for w in model.unknown_inputs)
    atom_info = {}
    for a in rational.atoms:
        i = leaf[a.symbol]
        if a.kind == "const" or not tv[i]:
            continue
        atom_info[i] = (
            a.kind,
            atom_arg_root[a.symbol],
            atan_q_root.get(a.symbol, -1),
            leaf[a.partner] if a.partner is not None else -1,
            a.q,
        )
    rhs_roots = tuple(roots[:n_states])
    out_roots = tuple(roots[n_states : n_states + n_out])
    plan = make_plan(ops, tv, topo, atom_info, state_nodes + input_nodes + winput_nodes, rhs_roots + out_roots)
    return Layout(
        rhs_roots=rhs_roots,
        out_roots=out_roots,
        atom_arg_root=atom_arg_root,
        atan_q_root=atan_q_root,
        ic_root=ic_root,
        init_root=init_root,
        tv=tuple(tv),
        topo=tuple(topo),
        state_nodes=state_nodes,
        input_nodes=input_nodes,
        winput_nodes=winput_nodes,
        plan=plan,
    )
