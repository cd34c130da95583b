"""Non-rational terms of a smooth model, rewritten over augmented functions ("atoms").

Both exact engines (:mod:`obsnl.lie`, :mod:`obsnl.sedoglavic`) work with rational functions
modulo a prime. A smooth branch of a mechanical model may also contain symbolic powers
(``|sigma - eta|**(2*N)``, ``x3**p3``), ``exp``, ``log``, ``sqrt``, ``sin``, ``cos``, ``atan``
(``tanh``, ``sinh``, ``cosh``, ``tan`` are rewritten through ``exp``, ``sin`` and ``cos``).
:func:`rationalize` replaces each of them by a new symbol, an *atom*, with a rational
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
it would wrongly make ``Delta1`` look unidentifiable); obsnl never does that.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import sympy as sp

from .errors import ModelError, NotSupportedError
from .model import NONSMOOTH_FUNCTIONS, Model

__all__ = ["Atom", "Rationalized", "rationalize", "atom_rates"]

_KINDS = ("exp", "log", "atan", "root", "sin", "cos", "const")


@dataclass(frozen=True)
class Atom:
    """One augmented function.

    Attributes
    ----------
    symbol
        The stand-in symbol used in the rational system.
    kind
        ``"exp"``, ``"log"``, ``"atan"``, ``"root"``, ``"sin"``, ``"cos"`` or ``"const"`` (a
        transcendental number such as ``log(2)`` or ``pi``).
    arg
        The argument ``g`` (rational in the model's symbols and earlier atoms); the base for a
        root; the number itself for a constant.
    q
        Degree of a root (``g**(1/q)``), else 0.
    partner
        For ``sin``/``cos``: the symbol of the other function of the pair.
    time_varying
        True when the atom depends on a state or an input.
    """

    symbol: sp.Symbol
    kind: str
    arg: sp.Expr
    q: int = 0
    partner: sp.Symbol | None = None
    time_varying: bool = True

    @property
    def text(self) -> str:
        if self.kind == "root":
            return f"({self.arg})**(1/{self.q})"
        if self.kind == "const":
            return str(self.arg)
        if self.kind == "log":  # a real logarithm of either sign of its argument (module docstring)
            return f"log|{self.arg}|"
        return f"{self.kind}({self.arg})"


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


# --------------------------------------------------------------------------- helpers
def _factor_fraction(g: sp.Expr):
    """``g`` as a rational number, or ((c, factors) of the numerator, (c, factors) of the denominator)."""
    g = sp.together(g)
    if g == 0:
        raise ModelError("log(0) in the model")
    if g.is_Rational:
        return sp.Rational(g)
    out = []
    for part in sp.fraction(g):
        try:
            c, factors = sp.factor_list(sp.expand(part))
        except (sp.PolynomialError, NotImplementedError):  # pragma: no cover - defensive
            c, factors = sp.Integer(1), [(part, 1)]
        out.append((sp.Rational(c), tuple(factors)))
    return tuple(out)


def _rational_gcd(values: Sequence[sp.Rational]) -> sp.Rational:
    nums = [abs(int(v.p)) for v in values]
    dens = [int(v.q) for v in values]
    g = 0
    for n in nums:
        g = math.gcd(g, n)
    lcm = 1
    for d in dens:
        lcm = lcm * d // math.gcd(lcm, d)
    return sp.Rational(g, lcm)


def _to_exact(e: sp.Expr) -> sp.Expr:
    if e.has(sp.Float):
        return e.xreplace({f: sp.nsimplify(f, rational=True) for f in e.atoms(sp.Float)})
    return e


class _Builder:
    """Walks the expressions of one model, creating atoms (two passes, see :func:`rationalize`)."""

    def __init__(self, model: Model, factor_cache: dict | None = None) -> None:
        self.model = model
        self.factor_cache = {} if factor_cache is None else factor_cache
        self.declared = set(model.symbols.values())
        self.time_symbols = set(model.states) | set(model.inputs) | set(model.unknown_inputs)
        self.atoms: dict[sp.Symbol, Atom] = {}
        self.by_key: dict[tuple, sp.Symbol] = {}
        self.counter = 0
        # provisional exponentials / trig functions keyed by (monomial, coefficient)
        self.prov_exp: dict[tuple[sp.Expr, sp.Rational], sp.Symbol] = {}
        self.orientation: set[sp.Expr] = set()
        self.prov_exp_inv: dict[sp.Symbol, tuple[sp.Expr, sp.Rational]] = {}
        self.prov_trig: dict[tuple[str, sp.Expr, sp.Rational], sp.Symbol] = {}
        self.used_terms: list[object] = []  # sympy terms or (base, exponent); printed once, in the notes
        self.memo: dict[sp.Expr, sp.Expr] = {}
        self.log_memo: dict[sp.Expr, sp.Expr] = {}

    # ----------------------------------------------------------------- atoms
    def _new(self, kind: str, arg: sp.Expr, *, q: int = 0, name: str | None = None) -> sp.Symbol:
        key = (kind, arg, q)
        if key in self.by_key:
            return self.by_key[key]
        sym = sp.Symbol(f"_{name or kind}{self.counter}", real=True)
        self.counter += 1
        self.by_key[key] = sym
        self.atoms[sym] = Atom(sym, kind, arg, q=q, time_varying=self._varies(arg) if kind != "const" else False)
        return sym

    def _varies(self, e: sp.Expr) -> bool:
        for s in e.free_symbols:
            if s in self.time_symbols:
                return True
            if s in self.atoms and self.atoms[s].time_varying:
                return True
        return False

    def const(self, value: sp.Expr) -> sp.Symbol:
        return self._new("const", value, name="c")

    # ----------------------------------------------------------------- walk
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
                f"{type(e).__name__} in {e} is not smooth; split the model into smooth branches first "
                f"(obsnl.split_branches, or obsnl.analyze which does it)"
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
            raise NotSupportedError(f"the irrational exponent in ({base})**({ex}) is not supported; use a rational number")
        self.used_terms.append((base, ex))
        # b**(c0 + e') = b**c0 * exp(e' log b): the rational part stays algebraic in b itself
        c0, rest = self.rat(ex).as_coeff_Add()
        out = base**c0 if c0.is_Integer else self.root_power(base, c0)
        return out * self.exp_of(rest * self.log_of(base))

    def root_power(self, base: sp.Expr, ex: sp.Rational) -> sp.Expr:
        p, q = int(ex.p), int(ex.q)
        s, t = divmod(p, q)  # base**(p/q) = base**s * (base**(1/q))**t
        if base.is_Rational and base >= 0:
            root = sp.Integer(int(base.p)) ** sp.Rational(1, q) / sp.Integer(int(base.q)) ** sp.Rational(1, q)
            if root.is_Rational:
                return base**s * root**t
        w = self._new("root", base, q=q)
        return base**s * w**t

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

    def _terms(self, g: sp.Expr, what: str) -> list[tuple[sp.Rational, sp.Expr]]:
        out: list[tuple[sp.Rational, sp.Expr]] = []
        for term in sp.Add.make_args(sp.expand(g)):
            c, m = term.as_coeff_Mul()
            if not c.is_Rational:  # pragma: no cover - numbers are exact here
                raise NotSupportedError(f"the coefficient {c} in {what} is not rational")
            for b, k in m.as_powers_dict().items():
                if m == 1:
                    break
                if not (b.is_Symbol and (b in self.declared or b in self.atoms)) or not sp.sympify(k).is_Integer:
                    raise NotSupportedError(
                        f"the term {term} of {what} is not a monomial in the model's variables; obsnl needs "
                        f"exponent and angle arguments that are sums of monomials (e.g. -E_a/(R*T), N*log(x)); "
                        f"introduce a state for this quantity instead"
                    )
            out.append((sp.Rational(c), m))
        return out

    def exp_of(self, g: sp.Expr) -> sp.Expr:
        out = sp.Integer(1)
        for c, m in self._terms(g, f"exp({g})"):
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
        terms = self._terms(g, f"{kind}({g})")
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

    # ----------------------------------------------------------------- second pass
    def finalize(self) -> dict[sp.Symbol, sp.Expr]:
        """Group provisional exponentials and trig functions by monomial; the substitution map."""
        subs: dict[sp.Symbol, sp.Expr] = {}
        groups: dict[sp.Expr, list[sp.Rational]] = {}
        for (m, c) in self.prov_exp:
            groups.setdefault(m, []).append(c)
        for m, cs in groups.items():
            u = _rational_gcd(cs)
            e = self._new("exp", u * m)
            for c in cs:
                subs[self.prov_exp[(m, c)]] = e ** int(c / u)
        tgroups: dict[sp.Expr, list[sp.Rational]] = {}
        for (_, m, c) in self.prov_trig:
            tgroups.setdefault(m, []).append(c)
        X = sp.Dummy("X")
        for m, cs in tgroups.items():
            u = _rational_gcd(cs)
            s = self._new("sin", u * m)
            co = self._new("cos", u * m)
            self.atoms[s] = Atom(s, "sin", u * m, partner=co, time_varying=self.atoms[s].time_varying)
            self.atoms[co] = Atom(co, "cos", u * m, partner=s, time_varying=self.atoms[co].time_varying)
            for (k, mm, c), sym in self.prov_trig.items():
                if mm != m:
                    continue
                n = int(c / u)
                expr = sp.expand_trig((sp.sin if k == "sin" else sp.cos)(n * X))
                subs[sym] = expr.xreplace({sp.sin(X): s, sp.cos(X): co})
        # atom arguments may hold provisional symbols: substitute until stable
        for _ in range(len(self.atoms) + 2):
            changed = False
            for sym, a in list(self.atoms.items()):
                new_arg = a.arg.xreplace(subs) if a.kind != "const" else a.arg
                if new_arg != a.arg:
                    changed = True
                    self.atoms[sym] = Atom(sym, a.kind, new_arg, q=a.q, partner=a.partner,
                                           time_varying=a.time_varying)
            subs = {k: v.xreplace(subs) for k, v in subs.items()}
            if not changed:
                break
        # time variation after substitution (arguments may now reference other atoms)
        for _ in range(len(self.atoms) + 1):
            for sym, a in list(self.atoms.items()):
                if a.kind == "const":
                    continue
                tv = self._varies(a.arg)
                if tv != a.time_varying:
                    self.atoms[sym] = Atom(sym, a.kind, a.arg, q=a.q, partner=a.partner, time_varying=tv)
        return subs

    def ordered_atoms(self) -> tuple[Atom, ...]:
        done: list[Atom] = []
        placed: set[sp.Symbol] = set()
        pending = dict(self.atoms)
        while pending:
            progress = False
            for sym, a in list(pending.items()):
                deps = {s for s in a.arg.free_symbols if s in self.atoms} if a.kind != "const" else set()
                deps.discard(sym)
                if a.partner is not None:
                    deps.discard(a.partner)
                if deps <= placed:
                    done.append(a)
                    placed.add(sym)
                    del pending[sym]
                    progress = True
            if not progress:  # pragma: no cover - arguments are built bottom-up
                raise NotSupportedError("circular definition among non-rational terms")
        return tuple(done)


def rationalize(model: Model, *, factor_cache: dict | None = None) -> Rationalized:
    """Rewrite the non-rational terms of a smooth ``model`` over atoms (see the module docstring).

    Parameters
    ----------
    model
        A smooth model (no ``sign``/``Abs``/``Heaviside``/``Piecewise``/``Max``/``Min``).
    factor_cache
        A dictionary shared by several calls (the branches of one analysis) that remembers the
        factorizations of logarithm arguments; None: one for this call.

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
    b = _Builder(model, factor_cache)
    rhs = {s: b.rat(_to_exact(model.equations[s])) for s in model.states}
    outs = {k: b.rat(_to_exact(v)) for k, v in model.outputs.items()}
    icv = {s: b.rat(_to_exact(v)) for s, v in model.initial_condition_values.items()}
    subs = b.finalize()
    if subs:
        rhs = {s: e.xreplace(subs) for s, e in rhs.items()}
        outs = {k: e.xreplace(subs) for k, e in outs.items()}
        icv = {s: e.xreplace(subs) for s, e in icv.items()}
    initial = _specific_initial_values(model, b.ordered_atoms(), icv, b)
    atoms = b.ordered_atoms()  # the initial values may have added constants and roots of numbers
    notes = _notes(atoms, b.used_terms, initial)
    return Rationalized(model=model, rhs=rhs, outputs=outs, atoms=atoms, ic_values=icv, initial=initial,
                        notes=notes)


def _specific_initial_values(
    model: Model, atoms: Sequence[Atom], icv: Mapping[sp.Symbol, sp.Expr], b: _Builder
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
            out[a.symbol] = b._new("root", g0, q=a.q)  # the root of a number, taken mod p
    return out


def _notes(atoms: Sequence[Atom], used: Sequence[object], initial: Mapping[sp.Symbol, sp.Expr]) -> tuple[str, ...]:
    if not atoms:
        return ()
    dyn = [a for a in atoms if a.kind != "const"]
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
            "augmented functions: " + ", ".join(f"{a.symbol.name} = {a.text}" for a in dyn)
            + ". Their initial values are the functions of the unknowns they stand for (not new unknowns): "
            "gradients follow the chain rule and only the values are random stand-ins in GF(p); exact "
            "generically by Ax's theorem (algebraic relations of roots and sin/cos are kept)"
        )
    if consts:
        lines.append(
            "transcendental constants replaced by random stand-ins: " + ", ".join(a.text for a in consts)
            + (" (more than one: exact under Schanuel's conjecture)" if len(consts) > 1 else " (exact)")
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
