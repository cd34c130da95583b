"""Non-rational terms rewritten over augmented functions ("atoms"): the rewriting itself.

:class:`Rewriter` walks sympy expressions and replaces every symbolic or fractional power, ``exp``,
``log``, ``sin``/``cos``, ``atan`` (``tan``, ``tanh``, ``sinh``, ``cosh`` through them) by an atom
symbol, so that the expressions become rational over the variables and the atoms. The rules, the
table of derivative rules and initial values, and why the answer is exact (Ax's theorem) are in
:mod:`obsnl.algebra.augment`, which applies the rewriting to a model (:func:`obsnl.algebra.augment.rationalize`).
:func:`rewrite` applies it to free expressions (the random-point evaluations of
:mod:`obsnl.algebra.jets`), and :meth:`Rewriter.extend` to further expressions over the atoms of an
earlier rewriting, so that, e.g., ``x**N`` in a candidate function is the square root of the atom
``x**(2*N)`` of the model rather than an unrelated one. What the walk makes (the atoms, the provisional
exponentials and sine-cosine pairs, and the second pass that groups them by monomial) is kept by the
base class :class:`obsnl.algebra.atom_table.AtomTable`.
"""

from __future__ import annotations

from collections.abc import Iterable

import sympy as sp

from obsnl.algebra.atom_table import Atom, AtomTable
from obsnl.errors import ModelError, NotSupportedError
from obsnl.model.bounds.textsize import shorten
from obsnl.model.bounds.work import MAX_EXPANDED_TERMS, can_expand, can_factor
from obsnl.model.core import NONSMOOTH_FUNCTIONS

__all__ = ["Rewriter", "rewrite"]


#: A numerator's or denominator's constant and factors with their multiplicities.
_Factored = tuple[sp.Rational, tuple[tuple[sp.Expr, int], ...]]


class Rewriter(AtomTable):
    """Walks expressions, creating atoms: :meth:`rat` per expression, then :meth:`finalize` once.

    Parameters
    ----------
    declared : iterable of sympy.Symbol
        The symbols the expressions may use (monomials of exponents and angles are products of them).
    time_symbols : iterable of sympy.Symbol
        The symbols that vary in time (states and inputs); an atom depending on one varies too.
    factor_cache : dict or None
        Factorizations of logarithm arguments shared with other rewritings (one analysis).
    unit : bool
        Make the atom of a monomial ``m`` ``exp(u m)`` (``sin(u m)``) with ``u`` dividing 1 as well as
        every coefficient met, so that expressions rewritten later (:meth:`extend`) with integer
        coefficients are powers of it (``x**(2*N)`` becomes ``exp(N log x)**2``). Default: ``u`` the
        gcd of the coefficients (fewer, lower-degree atoms for the engines).
    """

    def __init__(
        self,
        declared: Iterable[sp.Symbol],
        time_symbols: Iterable[sp.Symbol] = (),
        factor_cache: dict | None = None,
        unit: bool = False,
    ) -> None:
        super().__init__(time_symbols, unit)
        self.factor_cache = {} if factor_cache is None else factor_cache
        self.declared = set(declared)
        self.used_terms: list[object] = []  # sympy terms or (base, exponent); printed once, in the notes
        self.memo: dict[sp.Expr, sp.Expr] = {}
        self.log_memo: dict[sp.Expr, sp.Expr] = {}

    # ----------------------------------------------------------------- walk
    def add(self, e: sp.Expr) -> sp.Expr:
        """Rewrite one expression (floats made exact); provisional symbols remain until :meth:`finalize`."""
        return self.rat(_to_exact(sp.sympify(e)))

    def rat(self, e: sp.Expr) -> sp.Expr:
        if e.is_Symbol or e.is_Rational:
            return e
        if e not in self.memo:  # subexpressions recur (the seed model has |sigma - eta|**(2N) thrice)
            self.memo[e] = self._rat(e)
        return self.memo[e]

    def _rat(self, e: sp.Expr) -> sp.Expr:
        if e.is_Number:  # Float
            return _to_exact(e)
        if e is sp.pi:
            return self.const(sp.pi)
        if e.is_NumberSymbol or e is sp.I or e.has(sp.I):
            raise NotSupportedError(f"the constant {e} is not supported; write its value as a rational number")
        if isinstance(e, (sp.Add, sp.Mul)):
            return e.func(*[self.rat(a) for a in e.args])
        if isinstance(e, sp.Pow):
            return self.power(self.rat(e.base), _to_exact(e.exp))
        if isinstance(e, sp.exp):
            return self.exp_of(self.rat(e.args[0]))
        if isinstance(e, sp.log):
            if len(e.args) != 1:
                return self.rat(sp.log(e.args[0]) / sp.log(e.args[1]))
            return self.log_of(self.rat(e.args[0]))
        if isinstance(e, (sp.sin, sp.cos)):
            return self.trig(type(e).__name__, self.rat(e.args[0]))
        if isinstance(e, sp.tan):
            return self.trig("sin", self.rat(e.args[0])) / self.trig("cos", self.rat(e.args[0]))
        if isinstance(e, (sp.tanh, sp.sinh, sp.cosh)):
            return self.rat(e.rewrite(sp.exp))
        if isinstance(e, sp.atan):
            g = self.rat(e.args[0])
            self.used_terms.append(e)
            return self._new("atan", g)
        if isinstance(e, NONSMOOTH_FUNCTIONS):
            raise NotSupportedError(
                f"{type(e).__name__} in {e} is not smooth; split the model into branches first "
                f"(obsnl.model.split_branches, or obsnl.observability.analyze which does it)"
            )
        name = getattr(e.func, "__name__", type(e).__name__)
        raise NotSupportedError(
            f"the function {name} (in {e}) is not supported by the exact engines; supported are rational "
            f"functions, powers, exp, log, sqrt, sin, cos, tan, tanh, sinh, cosh, atan"
        )

    def power(self, base: sp.Expr, ex: sp.Expr) -> sp.Expr:
        if ex.is_Integer:
            return base**ex
        if ex.is_Rational:
            self.used_terms.append((base, ex))
            return self.root_power(base, ex)
        if not ex.free_symbols:
            raise NotSupportedError(
                f"the irrational exponent in ({base})**({ex}) is not supported; use a rational number"
            )
        self.used_terms.append((base, ex))
        # b**(c0 + e') = b**c0 * exp(e' log b): the rational part stays algebraic in b itself
        c0, rest = self.rat(ex).as_coeff_Add()
        out = base**c0 if c0.is_Integer else self.root_power(base, c0)
        return out * self.exp_of(rest * self.log_of(base))

    def root_power(self, base: sp.Expr, ex: sp.Rational) -> sp.Expr:
        """``base**ex`` over roots of primes for a positive number, else over the atom ``base**(1/q)``."""
        if base.is_Rational and base > 0:
            return self.number_power(sp.Rational(base), ex)
        return self._root(base, ex)

    def number_power(self, base: sp.Rational, ex: sp.Rational) -> sp.Expr:
        """``base**ex`` of a positive rational number, over roots of prime numbers.

        ``(42/5)**(17/10) = 2**(17/10) 3**(17/10) 7**(17/10) / 5**(17/10)``: each prime ``r`` with a
        fractional exponent ``a/b`` gives the atom ``r**(1/b)`` to the power ``a`` (integer parts stay
        rational). The roots of distinct primes satisfy no relation but their defining equations
        (Besicovitch), so the engines may evaluate them modulo any prime in which they exist
        (:func:`obsnl.algebra.series.draw_prime`): the computation is exact in their number field.
        """
        out: sp.Expr = sp.Integer(1)
        parts = [(r, e) for r, e in sp.factorint(int(base.p)).items()]
        parts += [(r, -e) for r, e in sp.factorint(int(base.q)).items()]
        for r, e in parts:
            ee = sp.Rational(e) * ex
            whole = sp.floor(ee)
            frac = ee - whole
            out *= sp.Integer(r) ** whole
            if frac:
                out *= self._new("root", sp.Integer(r), q=int(frac.q)) ** int(frac.p)
        return out

    def log_of(self, g: sp.Expr) -> sp.Expr:
        """``log|g|`` over log atoms of irreducible factors and logarithms of primes."""
        if g not in self.log_memo:
            self.log_memo[g] = self._log_of(g)
        return self.log_memo[g]

    def _log_of(self, g: sp.Expr) -> sp.Expr:
        if g not in self.factor_cache:  # shared by the branches of one analysis
            self.factor_cache[g] = _factor_fraction(g)
        parts = self.factor_cache[g]
        if not isinstance(parts, tuple):
            return self.log_number(parts)
        out = sp.Integer(0)
        for (c, factors), sign in zip(parts, (1, -1)):
            for f, k in factors:
                # one atom per factor up to sign, the orientation first seen (log|-f| = log|f|)
                if (-f) in self.orientation and f not in self.orientation:
                    f = -f
                self.orientation.add(f)
                if f in self.prov_exp_inv:  # log(exp(c*m)) = c*m
                    m, cc = self.prov_exp_inv[f]
                    out += sign * k * cc * m
                    continue
                out += sign * k * self._new("log", f)
            out += sign * self.log_number(c)
        return out

    def log_number(self, c: sp.Rational) -> sp.Expr:
        """``log|c|`` as a combination of logarithms of primes (random stand-ins)."""
        c = abs(sp.Rational(c))
        if c == 1:
            return sp.Integer(0)
        out = sp.Integer(0)
        for prime, e in sp.factorint(int(c.p)).items():
            out += e * self.const(sp.log(prime, evaluate=False))
        for prime, e in sp.factorint(int(c.q)).items():
            out -= e * self.const(sp.log(prime, evaluate=False))
        return out

    def _terms(self, g: sp.Expr, func: type) -> list[tuple[sp.Rational, sp.Expr]]:
        """The terms ``c * m`` of the argument ``g`` of ``func`` (exp, sin or cos), ``g`` expanded."""

        def what() -> str:  # the user's expression, for a message
            return shorten(str(func(self.user_form(g), evaluate=False)), 60)

        if not can_expand(g):
            raise NotSupportedError(
                f"the argument of {what()} expands to too many terms (over "
                f"{MAX_EXPANDED_TERMS}); introduce a state for this quantity instead"
            )
        out: list[tuple[sp.Rational, sp.Expr]] = []
        for term in sp.Add.make_args(sp.expand(g)):
            c, m = term.as_coeff_Mul()
            if not c.is_Rational:  # pragma: no cover - numbers are exact here
                raise NotSupportedError(f"the coefficient {c} in {what()} is not rational")
            for b, k in m.as_powers_dict().items():
                if m == 1:
                    break
                if not (b.is_Symbol and (b in self.declared or b in self.atoms)) or not sp.sympify(k).is_Integer:
                    raise NotSupportedError(
                        f"the term {shorten(str(self.user_form(term)), 60)} of {what()} is not a monomial in the "
                        f"model's variables; obsnl needs exponent and angle arguments that are sums of monomials (e.g. -E_a/(R*T), N*log(x)); "
                        f"introduce a state for this quantity instead"
                    )
            out.append((sp.Rational(c), m))
        return out

    def exp_of(self, g: sp.Expr) -> sp.Expr:
        out = sp.Integer(1)
        for c, m in self._terms(g, sp.exp):
            if c == 0:
                continue
            if m in self.atoms and self.atoms[m].kind == "log":  # exp(c*log f) = f**c
                out *= self.power(self.atoms[m].arg, c) if not c.is_Integer else self.atoms[m].arg ** c
                continue
            key = (m, c)
            if key not in self.prov_exp:
                self.prov_exp[key] = sp.Symbol(f"_pexp{len(self.prov_exp)}", real=True)
                self.prov_exp_inv[self.prov_exp[key]] = key
            out *= self.prov_exp[key]
        return out

    def trig(self, kind: str, g: sp.Expr) -> sp.Expr:
        terms = self._terms(g, sp.sin if kind == "sin" else sp.cos)
        if not terms:
            return sp.Integer(0) if kind == "sin" else sp.Integer(1)

        def one(k: str, c: sp.Rational, m: sp.Expr) -> sp.Symbol:
            key = (k, m, c)
            if key not in self.prov_trig:
                self.prov_trig[key] = sp.Symbol(f"_p{k}{len(self.prov_trig)}", real=True)
            return self.prov_trig[key]

        s, co = one("sin", *terms[0]), one("cos", *terms[0])
        for c, m in terms[1:]:  # addition formulas
            s2, c2 = one("sin", c, m), one("cos", c, m)
            s, co = s * c2 + co * s2, co * c2 - s * s2
        return s if kind == "sin" else co

    # ----------------------------------------------------------------- more expressions, same atoms
    def extend(self, exprs: Iterable[sp.Expr]) -> list[sp.Expr]:
        """Rewrite further expressions; atoms already made keep their meaning (and their values).

        An exponential of a monomial that already has one becomes a power or a root of it, so that
        the values drawn for the first stay consistent; new monomials and factors get new atoms.
        """
        n_exp, n_trig = len(self.prov_exp), len(self.prov_trig)
        out = [self.add(e) for e in exprs]
        subs = self._group(list(self.prov_exp)[n_exp:], list(self.prov_trig)[n_trig:])
        self.subs = self._substitute_arguments({**self.subs, **subs})
        return [e.xreplace(self.subs) for e in out]


def rewrite(exprs: Iterable[sp.Expr], symbols: Iterable[sp.Symbol]) -> tuple[list[sp.Expr], tuple[Atom, ...]]:
    """Free expressions over ``symbols`` as rational expressions over the symbols and new atoms.

    Parameters
    ----------
    exprs : iterable of sympy.Expr
    symbols : iterable of sympy.Symbol
        Expressions to rewrite, and their variables (other free symbols are constants).

    Examples
    --------
    >>> import sympy as sp
    >>> a, b = sp.symbols("a b", real=True)
    >>> exprs, atoms = rewrite([a**b, sp.sqrt(a)], [a, b])
    >>> [x.kind for x in atoms], exprs
    (['log', 'root', 'exp'], [_exp2, _root1])
    """
    rw = Rewriter(symbols)
    out = [rw.add(e) for e in exprs]
    subs = rw.finalize()
    return [e.xreplace(subs) for e in out], rw.ordered_atoms()


def _factor_fraction(g: sp.Expr) -> sp.Rational | tuple[_Factored, ...]:
    """``g`` as a rational number, or ((c, factors) of the numerator, (c, factors) of the denominator).

    A part too large to factor cheaply (:func:`obsnl.model.bounds.work.can_factor`) is kept whole: ``log|part|``
    is then one atom, which is still exact.
    """
    g = sp.together(g)
    if g == 0:
        raise ModelError("log(0) in the model")
    if g.is_Rational:
        return sp.Rational(g)
    out: list[_Factored] = []
    for part in sp.fraction(g):
        if part.is_Rational:
            out.append((sp.Rational(part), ()))
            continue
        if not can_factor(part):
            out.append((sp.Integer(1), ((part, 1),)))
            continue
        try:
            c, factors = sp.factor_list(sp.expand(part))
        except (sp.PolynomialError, NotImplementedError):  # pragma: no cover - defensive
            c, factors = sp.Integer(1), [(part, 1)]
        out.append((sp.Rational(c), tuple(factors)))
    return tuple(out)


def _to_exact(e: sp.Expr) -> sp.Expr:
    if e.has(sp.Float):
        return e.xreplace({f: sp.nsimplify(f, rational=True) for f in e.atoms(sp.Float)})
    return e
