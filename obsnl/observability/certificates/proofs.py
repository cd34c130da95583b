"""Symbolic proofs: generators of symmetries and reparametrized models, checked with sympy.

* A **scaling** is proved by weighted homogeneity (:func:`weight`): every term of every equation
  has the weight of its state and the outputs have weight 0, so ``f(lambda^w z) = lambda^w_i f(z)``.
* Any other identity is proved in the canonical form of :func:`canonical`, where powers with
  symbolic exponents, ``exp`` and ``log`` are atoms (algebraically independent by Ax's theorem) and
  every expression is a rational function: ``cancel`` then decides zero exactly.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence

import sympy as sp

from obsnl.errors import NotSupportedError
from obsnl.model.bounds.work import can_expand
from obsnl.model.branching.branches import Branch
from obsnl.model.core import NONSMOOTH_FUNCTIONS, Model
from obsnl.model.reading.parse import make_symbol

__all__ = ["ANY", "weight", "is_zero", "same", "canonical", "verify_generator", "verify_reparametrization"]


class _Any:
    """Weight of 0: any weight fits."""


ANY = _Any()


def weight(expr: sp.Expr, weights: Mapping[sp.Symbol, sp.Expr]) -> sp.Expr | _Any | None:
    """The weight of ``expr`` under ``z_j -> lambda**w_j z_j`` (lambda > 0), or None if not homogeneous.

    A proof, term by term, that ``expr(lambda^w z) = lambda^weight expr(z)``; ``sign`` and ``Abs``
    keep the weight of their argument (``lambda > 0``).

    Parameters
    ----------
    expr : sympy.Expr
        The expression.
    weights : mapping of sympy.Symbol to sympy.Expr
        Weight ``w_j`` of each scaled symbol (others 0).

    Returns
    -------
    sympy.Expr, ANY or None
        ``ANY`` for 0 (any weight).
    """
    moved = {s for s, w in weights.items() if w != 0}

    def same(a: sp.Expr, b: sp.Expr) -> bool:
        return sp.expand(a - b) == 0

    def w(e: sp.Basic) -> sp.Expr | _Any | None:
        if e.is_Number:
            return ANY if e == 0 else sp.Integer(0)
        if isinstance(e, sp.Symbol):
            return weights.get(e, sp.Integer(0))
        if isinstance(e, sp.Add):
            out = ANY
            for a in e.args:
                wa = w(a)
                if wa is None:
                    return None
                if wa is ANY:
                    continue
                if out is ANY:
                    out = wa
                elif not same(out, wa):
                    return None
            return out
        if isinstance(e, sp.Mul):
            tot = sp.Integer(0)
            for a in e.args:
                wa = w(a)
                if wa is None:
                    return None
                if wa is ANY:
                    return ANY
                tot += wa
            return tot
        if isinstance(e, sp.Pow):
            if e.exp.free_symbols & moved:
                return None
            wb = w(e.base)
            return wb if wb is None or wb is ANY else sp.expand(wb * e.exp)
        if isinstance(e, (sp.Abs, sp.sign)):
            wa = w(e.args[0])
            return wa if isinstance(e, sp.Abs) or wa is None else (ANY if wa is ANY else sp.Integer(0))
        if isinstance(e, sp.Function) and not (e.free_symbols & moved):
            return sp.Integer(0)
        return None

    return w(sp.sympify(expr))


# --------------------------------------------------------------------------- canonical form
_TPow = sp.Function("_tpow")  # _tpow(f, m) = f**m, f a factor, m a monomial exponent (or a rational)
_TExp = sp.Function("_texp")  # _texp(m) = exp(m)
_TLog = sp.Function("_tlog")  # _tlog(f) = log(f)


def canonical(expr: sp.Expr) -> sp.Expr:
    """Rewrite non-integer powers, ``exp`` and ``log`` into independent atoms (see module doc).

    A normal form per expression (cached; ``f**m``, ``exp(m)`` and ``log f`` become the functions
    ``_tpow``, ``_texp``, ``_tlog`` of factors and monomials), never identifying ``f`` with ``-f``:
    only true identities cancel. The evaluator's atoms (:mod:`obsnl.algebra.atoms`, real logarithms
    ``log|f|``, stand-ins and derivative rules) serve the computations mod p, not these proofs.
    """
    return _canonical(sp.sympify(expr))


@functools.lru_cache(maxsize=8192)
def _canonical(expr: sp.Expr) -> sp.Expr:
    if expr.has(*NONSMOOTH_FUNCTIONS):
        raise NotSupportedError(
            f"{expr} is not smooth; split the model into branches first (obsnl.model.split_branches)"
        )

    def walk(e: sp.Basic) -> sp.Basic:
        if e.is_Atom:
            return e
        args = [walk(a) for a in e.args]
        if isinstance(e, sp.Pow):
            b, x = args
            if x.is_Integer:
                return b**x
            return _power(b, x)
        if isinstance(e, sp.exp):
            return _exponential(args[0])
        if isinstance(e, sp.log):
            return _logarithm(args[0])
        if isinstance(e, (sp.tanh, sp.sinh, sp.cosh)):
            return walk(e.rewrite(sp.exp))
        if isinstance(e, sp.Function) and not isinstance(e, sp.core.function.AppliedUndef):
            raise NotSupportedError(
                f"{type(e).__name__} is not supported by the modular evaluator; rewrite it with exp/log or powers"
            )
        return e.func(*args)

    return walk(expr)


@functools.lru_cache(maxsize=8192)
def _factors(b: sp.Expr) -> tuple[tuple[sp.Expr, int], ...]:
    """``b = prod f**k`` with numeric content and irreducible (or atom) factors ``f``."""
    out: list[tuple[sp.Expr, int]] = []
    for part, sign in zip(sp.fraction(sp.together(b)), (1, -1)):
        try:
            c, fl = sp.factor_list(part)
        except sp.PolynomialError:
            c, fl = 1, [(f, 1) for f in sp.Mul.make_args(part)]
        c = sp.Rational(c)
        out += [(sp.Integer(c.p), sign), (sp.Integer(c.q), -sign)]
        out += [(f, sign * int(k)) for f, k in fl]
    return tuple((f, k) for f, k in out if f != 1)


def _power(b: sp.Expr, x: sp.Expr) -> sp.Expr:
    out = sp.Integer(1)
    terms = sp.Add.make_args(sp.expand(x))
    for f, k in _factors(b):
        for t in terms:
            c, m = t.as_coeff_Mul()
            if m == 1:  # numeric part of the exponent
                kc = k * c
                out *= f**kc if kc.is_Integer else _TPow(f, kc)
            elif (k * c).is_Integer:
                out *= _TPow(f, m) ** (k * c)
            else:
                out *= _TPow(f, k * c * m)
    return out


def _exponential(g: sp.Expr) -> sp.Expr:
    out = sp.Integer(1)
    for t in sp.Add.make_args(sp.expand(g)):
        c, m = t.as_coeff_Mul()
        if m == 1:
            out *= _TExp(c)
        else:
            out *= _TExp(m) ** c if c.is_Integer else _TExp(c * m)
    return out


def _logarithm(g: sp.Expr) -> sp.Expr:
    return sp.Add(*[k * _TLog(f) for f, k in _factors(g)])


def is_zero(e: sp.Expr) -> bool:
    """Exact zero test: in the canonical form of :func:`canonical` (powers with symbolic
    exponents and exp/log as independent atoms, by Ax's theorem) ``e`` is a rational function."""
    if e == 0:
        return True
    if not can_expand(e):  # deciding it would expand a huge expression: not proved zero (callers verify)
        return False
    try:
        return sp.cancel(sp.together(canonical(e))) == 0
    except (sp.PolynomialError, NotSupportedError):
        return sp.simplify(e) == 0


def same(a: sp.Expr, b: sp.Expr) -> bool:
    """Symbolic equality through the canonical (atom) form, which makes both rational.

    Parameters
    ----------
    a, b : sympy.Expr
        The expressions to compare.

    Returns
    -------
    bool
    """
    if a == b:
        return True
    if not (can_expand(a) and can_expand(b)):  # too large to compare cheaply: not proved equal
        return False
    d = canonical(a) - canonical(b)
    return d == 0 or sp.cancel(sp.together(d)) == 0


def verify_generator(model: Model, kind: str, comp: Mapping[sp.Symbol, sp.Expr]) -> bool:
    """Symbolic check of the determining equations of one generator.

    Parameters
    ----------
    model : Model
        A smooth model.
    kind : str
        ``"scaling"``, ``"translation"`` or another kind (general Lie symmetry).
    comp : mapping of sympy.Symbol to sympy.Expr
        The generator's component per symbol.

    Returns
    -------
    bool
        True when the equations hold symbolically.
    """
    f = dict(model.equations)
    h = list(model.output_exprs)
    if kind == "scaling":
        ws = {s: sp.cancel(c / s) for s, c in comp.items()}
        for s, fs in f.items():
            wf = weight(fs, ws)
            if wf is None or (wf is not ANY and not sp.expand(wf - ws.get(s, 0)) == 0):
                return False
        return all((wh := weight(e, ws)) is ANY or (wh is not None and sp.expand(wh) == 0) for e in h)
    if kind == "translation":
        eps = sp.Dummy("eps")
        shift = {s: s + c * eps for s, c in comp.items()}
        return all(e.xreplace(shift) == e or is_zero(e.xreplace(shift) - e) for e in list(f.values()) + h)
    for s, fs in f.items():
        lhs = sum(c * sp.diff(fs, v) for v, c in comp.items())
        rhs = sum(fk * sp.diff(comp.get(s, 0), xk) for xk, fk in f.items())
        if not is_zero(lhs - rhs):
            return False
    for s, c in comp.items():
        if s not in f and not is_zero(sum(fk * sp.diff(c, xk) for xk, fk in f.items())):
            return False
    return all(is_zero(sum(c * sp.diff(e, v) for v, c in comp.items())) for e in h)


def verify_reparametrization(
    new: Model, mapping: Mapping[str, sp.Expr], old_branches: Sequence[Branch], new_branches: Sequence[Branch]
) -> bool:
    """Branch by branch: ``L_f(phi_s) == f~_s(phi)`` for every new state and ``h == h~(phi)``.

    Parameters
    ----------
    new : Model
        The reparametrized model.
    mapping : mapping of str to sympy.Expr
        New state name to its expression ``phi`` in the old symbols.
    old_branches, new_branches : sequence of Branch
        Branches of the old and new model, in corresponding order.

    Returns
    -------
    bool
    """
    back = {make_symbol(nm): phi for nm, phi in mapping.items()}
    if len(new_branches) != len(old_branches):
        return False
    for ob, nb in zip(old_branches, new_branches):
        f = ob.model.equations
        for s in nb.model.states:
            phi = mapping.get(s.name, s)
            lhs = sp.Add(*[sp.diff(phi, x) * f[x] for x in ob.model.states if phi.has(x)])
            if not same(lhs, nb.model.equations[s].xreplace(back)):
                return False
        for k, h in ob.model.outputs.items():
            if not same(h, nb.model.outputs[k].xreplace(back)):
                return False
    return True
