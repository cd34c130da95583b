"""The atoms of one rewriting: each augmented function made once, grouped, ordered.

:class:`AtomTable` holds what the walk of :class:`obsnl.algebra.atoms.Rewriter` (a subclass, which adds
the rules for each non-rational term) has made: the atoms keyed by kind and argument (one symbol per
function), the provisional exponentials and sine-cosine pairs of the first pass, and the second pass that
groups them by monomial into atoms (one ``exp(u m)`` per monomial ``m``, ``u`` the gcd of its coefficients,
every other ``exp(c m)`` a power or a root of it; one sine-cosine pair likewise, multiple angles through
``expand_trig``). It also knows which atoms vary in time, gives the atoms in an order in which each argument
uses earlier atoms only, and can start from the atoms of an earlier rewriting (:meth:`AtomTable.seed`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import sympy as sp

from obsnl.errors import NotSupportedError

__all__ = ["Atom", "AtomTable"]


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
        if self.kind == "log":  # a real logarithm of either sign of its argument (obsnl.algebra.augment)
            return f"log|{self.arg}|"
        return f"{self.kind}({self.arg})"


class AtomTable:
    """The atoms made so far and the provisional symbols of the first pass.

    Parameters
    ----------
    time_symbols : iterable of sympy.Symbol
        The symbols that vary in time (states and inputs); an atom depending on one varies too.
    unit : bool
        Make the atom of a monomial ``m`` ``exp(u m)`` (``sin(u m)``) with ``u`` dividing 1 as well as
        every coefficient met (see :class:`obsnl.algebra.atoms.Rewriter`). Default: ``u`` the gcd of the
        coefficients.

    Examples
    --------
    >>> import sympy as sp
    >>> x, t = sp.symbols("x t")
    >>> table = AtomTable([t])
    >>> e = table._new("exp", t * x)
    >>> table._new("exp", t * x) is e, [a.text for a in table.ordered_atoms()], table.atoms[e].time_varying
    (True, ['exp(t*x)'], True)
    """

    def __init__(self, time_symbols: Iterable[sp.Symbol] = (), unit: bool = False) -> None:
        self.unit = unit
        self.time_symbols = set(time_symbols)
        self.atoms: dict[sp.Symbol, Atom] = {}
        self.by_key: dict[tuple, sp.Symbol] = {}
        self.counter = 0
        # provisional exponentials / trig functions keyed by (monomial, coefficient)
        self.prov_exp: dict[tuple[sp.Expr, sp.Rational], sp.Symbol] = {}
        self.orientation: set[sp.Expr] = set()
        self.prov_exp_inv: dict[sp.Symbol, tuple[sp.Expr, sp.Rational]] = {}
        self.prov_trig: dict[tuple[str, sp.Expr, sp.Rational], sp.Symbol] = {}
        # monomials whose exponential / sine-cosine pair exists: m -> (u, exp(u m)) / (u, sin, cos)
        self.fixed_exp: dict[sp.Expr, tuple[sp.Rational, sp.Symbol]] = {}
        self.fixed_trig: dict[sp.Expr, tuple[sp.Rational, sp.Symbol, sp.Symbol]] = {}
        self.subs: dict[sp.Symbol, sp.Expr] = {}  # provisional symbols -> expressions over atoms

    # ----------------------------------------------------------------- atoms
    def user_form(self, e: sp.Expr) -> sp.Expr:
        """``e`` with the provisional and atom symbols (``_pexp0``, ``_log1``, ...) swapped back for what they stand
        for: how a message shows the user's own expression.

        Parameters
        ----------
        e : sympy.Expr
            An expression of the rewriting.

        Returns
        -------
        sympy.Expr

        Examples
        --------
        >>> x = sp.Symbol("x")
        >>> table = AtomTable([x])
        >>> table.user_form(table._new("exp", 2 * x) + 1)
        exp(2*x) + 1
        """
        back: dict[sp.Symbol, sp.Expr] = {s: sp.exp(c * m) for s, (m, c) in self.prov_exp_inv.items()}
        for (kind, m, c), s in self.prov_trig.items():
            back[s] = (sp.sin if kind == "sin" else sp.cos)(c * m)
        for s, a in self.atoms.items():
            back[s] = (
                a.arg ** sp.Rational(1, a.q)
                if a.kind == "root"
                else a.arg
                if a.kind == "const"
                else sp.log(a.arg)
                if a.kind == "log"
                else getattr(sp, a.kind)(a.arg)
            )
        for _ in range(len(back) + 1):  # an atom's argument may hold earlier atoms
            if not e.free_symbols & set(back):
                break
            e = e.xreplace(back)
        return e

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

    def _root(self, base: sp.Expr, ex: sp.Rational) -> sp.Expr:
        """``base**ex`` over the atom ``base**(1/q)`` (``ex = p/q``): ``base**s * (base**(1/q))**t``."""
        s, t = divmod(int(ex.p), int(ex.q))
        return base**s * self._new("root", base, q=int(ex.q)) ** t

    # ----------------------------------------------------------------- second pass
    def finalize(self) -> dict[sp.Symbol, sp.Expr]:
        """Group provisional exponentials and trig functions by monomial; the substitution map."""
        subs = self._substitute_arguments(self._group(list(self.prov_exp), list(self.prov_trig)))
        # time variation after substitution (arguments may now reference other atoms)
        for _ in range(len(self.atoms) + 1):
            for sym, a in list(self.atoms.items()):
                if a.kind == "const":
                    continue
                tv = self._varies(a.arg)
                if tv != a.time_varying:
                    self.atoms[sym] = Atom(sym, a.kind, a.arg, q=a.q, partner=a.partner, time_varying=tv)
        self.subs = subs
        return subs

    def _group(self, exp_keys: Sequence[tuple], trig_keys: Sequence[tuple]) -> dict[sp.Symbol, sp.Expr]:
        """One exponential ``exp(u m)`` per monomial ``m`` (``u`` the gcd of the coefficients), one
        sine-cosine pair likewise; a monomial that already has its atom keeps it (:meth:`seed`)."""
        subs: dict[sp.Symbol, sp.Expr] = {}
        groups: dict[sp.Expr, list[sp.Rational]] = {}
        for m, c in exp_keys:
            groups.setdefault(m, []).append(c)
        for m, cs in groups.items():
            if m not in self.fixed_exp:
                u = _rational_gcd(cs + [sp.Integer(1)] if self.unit else cs)
                e = self._new("exp", u * m)
                self.fixed_exp[m] = (u, e)
                self.prov_exp_inv[e] = (m, u)
            u, e = self.fixed_exp[m]
            for c in cs:  # exp(c m) = exp(u m)**(c/u): a power, or a root of the existing atom
                r = c / u
                subs[self.prov_exp[(m, c)]] = e ** int(r) if r.is_Integer else self._root(e, r)
        tgroups: dict[sp.Expr, list[sp.Rational]] = {}
        for _, m, c in trig_keys:
            tgroups.setdefault(m, []).append(c)
        X = sp.Dummy("X")
        for m, cs in tgroups.items():
            if m not in self.fixed_trig:
                u = _rational_gcd(cs + [sp.Integer(1)] if self.unit else cs)
                s = self._new("sin", u * m)
                co = self._new("cos", u * m)
                self.atoms[s] = Atom(s, "sin", u * m, partner=co, time_varying=self.atoms[s].time_varying)
                self.atoms[co] = Atom(co, "cos", u * m, partner=s, time_varying=self.atoms[co].time_varying)
                self.fixed_trig[m] = (u, s, co)
            u, s, co = self.fixed_trig[m]
            for key in trig_keys:
                k, mm, c = key
                if mm != m:
                    continue
                n = c / u
                if not n.is_Integer:
                    raise NotSupportedError(
                        f"{k}({c * m}) is a fraction of the angle {u * m} of an existing "
                        f"sine-cosine pair; not supported"
                    )
                expr = sp.expand_trig((sp.sin if k == "sin" else sp.cos)(int(n) * X))
                subs[self.prov_trig[key]] = expr.xreplace({sp.sin(X): s, sp.cos(X): co})
        return subs

    def _substitute_arguments(self, subs: dict[sp.Symbol, sp.Expr]) -> dict[sp.Symbol, sp.Expr]:
        """Atom arguments may hold provisional symbols: substitute until stable."""
        for _ in range(len(self.atoms) + 2):
            changed = False
            for sym, a in list(self.atoms.items()):
                new_arg = a.arg.xreplace(subs) if a.kind != "const" else a.arg
                if new_arg != a.arg:
                    changed = True
                    self.atoms[sym] = Atom(sym, a.kind, new_arg, q=a.q, partner=a.partner, time_varying=a.time_varying)
            subs = {k: v.xreplace(subs) for k, v in subs.items()}
            if not changed:
                break
        return subs

    # ----------------------------------------------------------------- the atoms of an earlier rewriting
    def seed(self, atoms: Iterable[Atom]) -> None:
        """Start from the atoms of an earlier rewriting: later expressions reuse them, never regroup them."""
        top = -1
        for a in atoms:
            self.atoms[a.symbol] = a
            self.by_key[(a.kind, a.arg, a.q)] = a.symbol
            if a.kind == "log":
                self.orientation.add(a.arg)
            elif a.kind == "exp":
                u, m = a.arg.as_coeff_Mul()
                self.fixed_exp[m] = (u, a.symbol)
                self.prov_exp_inv[a.symbol] = (m, u)
            elif a.kind == "sin":
                u, m = a.arg.as_coeff_Mul()
                self.fixed_trig[m] = (u, a.symbol, a.partner)
            digits = re.search(r"(\d+)$", a.symbol.name)
            top = max(top, int(digits.group(1)) if digits else -1)
        self.counter = max(self.counter, top + 1)

    def ordered_atoms(self) -> tuple[Atom, ...]:
        """The atoms in an order in which each one's argument uses earlier atoms only (a pair counts as one)."""
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
