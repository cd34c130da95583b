"""Non-rational terms of a smooth model, rewritten over augmented functions ("atoms").

Both exact engines (:mod:`obsnl.observability.engines.orc`, :mod:`obsnl.observability.engines.sedoglavic`) and every evaluation at a random
point (:mod:`obsnl.algebra.jets`: the symmetry search, identifiable functions, ``same_field``) work with
rational functions modulo a prime. A smooth branch of a mechanical model may also contain symbolic
powers (``|sigma - eta|**(2*N)``, ``x3**p3``), ``exp``, ``log``, ``sqrt``, ``sin``, ``cos``, ``atan``
(``tanh``, ``sinh``, ``cosh``, ``tan`` are rewritten through ``exp``, ``sin`` and ``cos``).
:func:`rationalize` replaces each of them by a new symbol, an *atom* (the walk is
:class:`obsnl.algebra.atoms.Rewriter`; this module applies it to a model), with a rational
derivative rule, so that the model becomes a rational system over the variables and the atoms:

========  ======================  ===========================  ==================================
atom      derivative              initial value a0             gradient of a0 w.r.t. unknowns z
========  ======================  ===========================  ==================================
exp(g)    E' = E g'               random in GF(p)              E0 * dg0
log|g|    l' = g'/g               random in GF(p)              dg0 / g0
atan(g)   a' = g'/(1 + g^2)       random in GF(p)              dg0 / (1 + g0^2)
g^(1/q)   w' = w g'/(q g)         a q-th root of g0 in GF(p)   w0 dg0 / (q g0)
sin, cos  s' = c g', c' = -s g'   (2t, 1 - t^2)/(1 + t^2)      c0 dg0, -s0 dg0
========  ======================  ===========================  ==================================

A symbolic power is ``b**e = b**c0 * exp((e - c0)*log(b))`` (``c0`` the rational part of ``e``);
the base is factored into irreducible polynomials and ``log`` of a product is split, so
``log(sigma - eta)``, ``log(sigma_y)`` and ``exp(2*N*log(sigma - eta))`` are the atoms of the seed
model. Logarithms are real: a log atom stands for ``log|f|`` (same derivative ``f'/f`` for either
sign of ``f``), so a factor and its negative share one atom and no ``log(-1)`` ever appears (in a
real model the argument of ``log`` and the base of a symbolic power are positive in the branch,
so ``log b = log|c| + sum k log|f|`` for ``b = c prod f**k``). Exponent arguments are split
into terms ``c*m`` (``c`` rational, ``m`` a monomial); all terms with the same monomial share
one atom ``exp(u*m)`` (``u`` the gcd of their coefficients), so that ``x**N`` and ``x**(2*N)``
become ``E`` and ``E**2``. The same is done for ``sin``/``cos`` (multiple angles through
``expand_trig``).

**What the answer means.** The initial value of an exponential or logarithm atom is *not* a new
unknown: it is the transcendental function of the unknowns it stands for (``w0 = b0**(2N)``),
and its gradient is that function's gradient, ``dw0 = w0 (2N/b0) db0 + 2 w0 log(b0) dN``. Only
the *values* ``w0`` and ``log(b0)`` are replaced by random elements of GF(p). This is exact
generically: by Ax's theorem (the functional Schanuel conjecture, proved) the unknowns, the
logarithms of multiplicatively independent irreducible polynomials and the exponentials of
Q-linearly independent monomials are algebraically independent functions, so a Jacobian minor
that is a nonzero polynomial in the unknowns and the stand-ins is a nonzero function of the
unknowns, and the Schwartz-Zippel argument counts the stand-ins as further random variables.
Algebraic atoms (``q``-th roots, the pair ``sin``/``cos``) keep their algebraic relation
(``w0**q = g0``, ``s0**2 + c0**2 = 1``). When a known initial condition makes an argument a
specific number (``x3(0) = 13/10`` in ``x3**p3``), ``log(13/10) = log 13 - log 2 - log 5`` is a
fixed transcendental number and the logs of primes are random stand-ins; independence of the
logarithms of several primes (or of ``pi``) is Schanuel's conjecture, which the notes state.
Plain augmentation with a *free* initial value would only be conservative (on the seed model
it would wrongly make ``Delta1`` look unidentifiable); obsnl never does that. Expressions evaluated
later at the same point (a candidate identifiable function, :mod:`obsnl.observability.engines.jacobian`) are rewritten
over the same atoms (:meth:`obsnl.algebra.atoms.Rewriter.extend`): an exponential of a monomial that has an
atom becomes a power or a root of it, so that the stand-ins keep their relations.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import sympy as sp

from obsnl.algebra.atom_table import Atom
from obsnl.algebra.atoms import Rewriter
from obsnl.errors import ModelError, NotSupportedError
from obsnl.model.core import Model

__all__ = ["Atom", "Rationalized", "rationalize", "atom_rates"]


@dataclass(frozen=True)
class Rationalized:
    """A smooth model as a rational system over its variables and atoms.

    Attributes
    ----------
    model
        The original smooth model.
    rhs
        ``{state: rational expression}``.
    outputs
        ``{output name: rational expression}``.
    atoms
        The atoms in dependency order (an atom's argument uses only earlier atoms).
    ic_values
        ``{state: rational expression}`` for known initial conditions with a value.
    initial
        ``{atom symbol: expression}`` for atoms whose initial value is a specific number or a
        combination of constant atoms (``log(x3)(0) = log 13 - log 2 - log 5``).
    notes
        Plain-text notes on what was augmented and what the answer means.
    """

    model: Model
    rhs: Mapping[sp.Symbol, sp.Expr]
    outputs: Mapping[str, sp.Expr]
    atoms: tuple[Atom, ...] = ()
    ic_values: Mapping[sp.Symbol, sp.Expr] = field(default_factory=dict)
    initial: Mapping[sp.Symbol, sp.Expr] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    @property
    def atom_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(a.symbol for a in self.atoms)

    def atom(self, symbol: sp.Symbol) -> Atom:
        for a in self.atoms:
            if a.symbol == symbol:
                return a
        raise KeyError(symbol)


def rationalize(model: Model, *, factor_cache: dict | None = None, unit: bool = False) -> Rationalized:
    """Rewrite the non-rational terms of a smooth ``model`` over atoms (see the module docstring).

    Parameters
    ----------
    model : Model
        A smooth model (no ``sign``/``Abs``/``Heaviside``/``Piecewise``/``Max``/``Min``).
    factor_cache : dict or None
        A dictionary shared by several calls (the branches of one analysis) that remembers the
        factorizations of logarithm arguments; None: one for this call.
    unit : bool
        Exponentials (and sines) of a monomial ``m`` as powers of ``exp(u m)`` with ``u`` dividing 1, so
        that later expressions over the same atoms need no roots (:class:`obsnl.algebra.atoms.Rewriter`).

    Returns
    -------
    Rationalized
        Rational right-hand sides and outputs over the model's symbols and the atoms.

    Raises
    ------
    NotSupportedError
        For a non-smooth model, an unsupported function, or an exponent/angle argument that is
        not a sum of monomials.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="hill", states=["x"], parameters=["k", "n"],
    ...           equations={"x": "-k*x**n"}, outputs={"y": "x"})
    >>> r = rationalize(m)
    >>> [a.kind for a in r.atoms]
    ['log', 'exp']
    """
    b = Rewriter(
        model.symbols.values(), set(model.states) | set(model.inputs) | set(model.unknown_inputs), factor_cache, unit
    )
    rhs = {s: b.add(model.equations[s]) for s in model.states}
    outs = {k: b.add(v) for k, v in model.outputs.items()}
    icv = {s: b.add(v) for s, v in model.initial_condition_values.items()}
    subs = b.finalize()
    if subs:
        rhs = {s: e.xreplace(subs) for s, e in rhs.items()}
        outs = {k: e.xreplace(subs) for k, e in outs.items()}
        icv = {s: e.xreplace(subs) for s, e in icv.items()}
    initial = _specific_initial_values(model, b.ordered_atoms(), icv, b)
    atoms = b.ordered_atoms()  # the initial values may have added constants and roots of numbers
    notes = _notes(atoms, b.used_terms, initial)
    return Rationalized(model=model, rhs=rhs, outputs=outs, atoms=atoms, ic_values=icv, initial=initial, notes=notes)


def _specific_initial_values(
    model: Model, atoms: Sequence[Atom], icv: Mapping[sp.Symbol, sp.Expr], b: Rewriter
) -> dict[sp.Symbol, sp.Expr]:
    """Atoms whose initial value is fixed by specific initial conditions (numbers only)."""
    numeric_ic = {s: v for s, v in icv.items() if v.is_Rational}
    if not numeric_ic:
        return {}
    out: dict[sp.Symbol, sp.Expr] = {}
    for a in atoms:
        if a.kind == "const":
            continue
        g0 = a.arg.xreplace(numeric_ic).xreplace(out)
        if not g0.is_Rational:
            continue
        g0 = sp.Rational(g0)
        if a.kind == "exp":
            if g0 == 0:
                out[a.symbol] = sp.Integer(1)
        elif a.kind == "log":
            if g0 == 0:
                raise ModelError(f"log({a.arg}) is log(0) at the given initial conditions")
            out[a.symbol] = b.log_number(g0)
        elif a.kind == "atan":
            if g0 == 0:
                out[a.symbol] = sp.Integer(0)
        elif a.kind in ("sin", "cos"):
            if g0 == 0:
                out[a.symbol] = sp.Integer(0 if a.kind == "sin" else 1)
        elif a.kind == "root":
            if g0 == 0:
                raise ModelError(f"({a.arg})**(1/{a.q}) is 0 at the given initial conditions (not differentiable)")
            out[a.symbol] = (
                b.number_power(g0, sp.Rational(1, a.q))
                if g0 > 0  # roots of primes, exact
                else b._new("root", g0, q=a.q)
            )
    return out


def _notes(atoms: Sequence[Atom], used: Sequence[object], initial: Mapping[sp.Symbol, sp.Expr]) -> tuple[str, ...]:
    if not atoms:
        return ()
    numbers = [a for a in atoms if a.kind == "root" and a.arg.is_Integer]
    dyn = [a for a in atoms if a.kind != "const" and a not in numbers]
    consts = [a for a in atoms if a.kind == "const"]
    lines = []
    seen: list[str] = []
    for u in dict.fromkeys(used):
        t = f"({u[0]})**({u[1]})" if isinstance(u, tuple) else str(u)
        if t not in seen:
            seen.append(t)
    if seen:
        lines.append("non-rational terms: " + "; ".join(seen))
    if dyn:
        lines.append(
            "augmented functions: "
            + ", ".join(f"{a.symbol.name} = {a.text}" for a in dyn)
            + ". Their initial values are the functions of the unknowns they stand for (not new unknowns): "
            "gradients follow the chain rule and only the values are random stand-ins in GF(p); exact "
            "generically by Ax's theorem (algebraic relations of roots and sin/cos are kept)"
        )
    if consts:
        lines.append(
            "transcendental constants replaced by random stand-ins: "
            + ", ".join(a.text for a in consts)
            + (" (more than one: exact under Schanuel's conjecture)" if len(consts) > 1 else " (exact)")
        )
    if numbers:
        lines.append(
            "roots of numbers, exact: " + ", ".join(a.text for a in numbers) + " (roots of primes, "
            "computed modulo primes p = 3 mod 4 in which each exists, as the root that is a square mod p, so "
            "that roots of one number with different degrees agree; the probability bound is divided by the "
            "density of such primes)"
        )
    if initial:
        lines.append(
            "initial values fixed by the given initial conditions: "
            + ", ".join(f"{s.name}(0) = {v}" for s, v in initial.items())
        )
    return tuple(lines)


def atom_rates(rational: Rationalized, input_rates: Mapping[sp.Symbol, sp.Expr]) -> dict[sp.Symbol, sp.Expr]:
    """Time derivatives of the atoms along the flow (rational in states, atoms and ``input_rates``).

    ``input_rates`` maps each (known or unknown) input symbol to the symbol of its derivative.

    Parameters
    ----------
    rational : Rationalized
        The model rewritten over atoms.
    input_rates : mapping of sympy.Symbol to sympy.Expr
        Derivative symbol of each input.

    Returns
    -------
    dict of sympy.Symbol to sympy.Expr
        The time derivative of each atom (0 for constant ones).

    Raises
    ------
    NotSupportedError
        For an atom kind without a rate rule.
    """
    rates: dict[sp.Symbol, sp.Expr] = dict(rational.rhs)
    rates.update(input_rates)
    out: dict[sp.Symbol, sp.Expr] = {}

    def flow(g: sp.Expr) -> sp.Expr:
        return sp.Add(*[sp.diff(g, v) * rates[v] for v in g.free_symbols if v in rates])

    for a in rational.atoms:
        if a.kind == "const" or not a.time_varying:
            out[a.symbol] = sp.Integer(0)
            rates[a.symbol] = sp.Integer(0)
            continue
        if a.kind == "cos":
            continue  # set with its sine
        dg = flow(a.arg)
        if a.kind == "exp":
            r = a.symbol * dg
        elif a.kind == "log":
            r = dg / a.arg
        elif a.kind == "atan":
            r = dg / (1 + a.arg**2)
        elif a.kind == "root":
            r = a.symbol * dg / (a.q * a.arg)
        elif a.kind == "sin":
            out[a.partner] = -a.symbol * dg
            rates[a.partner] = out[a.partner]
            r = a.partner * dg
        else:  # pragma: no cover
            raise NotSupportedError(f"atom kind {a.kind}")
        out[a.symbol] = r
        rates[a.symbol] = r
    return out
