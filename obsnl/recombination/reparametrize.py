"""Identifiable reparametrizations from the symmetry generators, branch by branch, merged.

Algorithm (algorithms.md §4.2, step C, extended to non-smooth models):

1. Split the model into branches and find the generators of each (:func:`obsnl.symmetries`).
2. The scalings shared by *every* branch form a group whose Hubert-Labahn invariants are the new
   coordinates (:func:`obsnl.recombination.scalings.scaling_section`; exponents may depend on ``N``).
3. Every other generator is pushed forward to these coordinates; a translation there is kept.
   Translations common to all branches are divided out (linear invariants); those of some branches
   only are kept as *branch-adapted* coordinates: ``Delta1 = beta' + gamma'`` (identifiable in the
   branches where only ``beta + gamma`` acts) next to ``Delta2 = beta' - gamma'``. Thus a
   combination identifiable in one branch and another identifiable in another both survive.
4. The new model is the old one on the section (pivots = 1, translation pivots = 0), the equation
   of a new state ``s = phi(z)`` being ``L_f(phi)`` there. It is verified symbolically, branch by
   branch, and its observability is checked independently by the engine (``analyze_smooth``).

Pivots are divided by: the section assumes them positive (as physical moduli, lengths and masses are).
A smooth model whose generators are not all translations and scalings, or that has directions with
no closed form, gets its identifiable functions from :func:`obsnl.recombination.identifiable.identifiable_functions`.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import flint
import sympy as sp

from obsnl.errors import ModelError
from obsnl.model.branching.branches import Branch, split_branches
from obsnl.model.core import Model
from obsnl.model.files import as_model
from obsnl.model.reading.parse import make_symbol
from obsnl.observability.analyze import analyze
from obsnl.observability.certificates.generators import Symmetries, Symmetry
from obsnl.observability.certificates.proofs import verify_reparametrization
from obsnl.observability.certificates.symmetry import check_search, symmetries_of
from obsnl.observability.engines.smooth import analyze_smooth
from obsnl.observability.limits import check_analysis_limits
from obsnl.recombination.invariants import (
    adapted_forms,
    coordinates,
    pushforward,
    span_intersection,
    translation_invariants,
)
from obsnl.recombination.reparametrization import Reparametrization
from obsnl.recombination.scalings import ScalingSection, scaling_section, section_map

__all__ = ["reparametrize"]


# --------------------------------------------------------------------------- helpers
def _numeric_rows(
    rows: Sequence[Sequence[sp.Expr]], V: Sequence[sp.Symbol], exps: Sequence[sp.Symbol]
) -> flint.fmpq_mat | None:
    """Weight rows at a random integer value of the exponent parameters (for span membership)."""
    at = {e: 1009 + 2 * i for i, e in enumerate(exps)}
    try:
        vals = [[sp.Rational(sp.sympify(x).subs(at)) for x in r] for r in rows]
    except TypeError:
        return None
    return flint.fmpq_mat(len(vals), len(V), [flint.fmpq(int(x.p), int(x.q)) for r in vals for x in r])


def _piecewise_tidy(e: sp.Expr) -> sp.Expr:
    """``a + b*sign(g)`` -> ``Piecewise((a + b, g > 0), (a - b, True))`` when that reads shorter."""

    def fix(node: sp.Basic) -> sp.Basic:
        if not isinstance(node, sp.Add):
            return node
        signs = [s for s in node.atoms(sp.sign) if node.coeff(s) != 0]
        for s in signs:
            coll = sp.collect(node, s, evaluate=False)
            if set(coll) - {s, sp.Integer(1)} or s not in coll:
                continue
            a, b = coll.get(sp.Integer(1), 0), coll[s]
            if not (sp.sympify(a).free_symbols and sp.sympify(b).free_symbols):
                continue
            pw = sp.Piecewise((sp.factor_terms(a + b), s.args[0] > 0), (sp.factor_terms(a - b), True))
            if sp.count_ops(pw) < sp.count_ops(node):
                return pw
        return node

    return e.replace(lambda n: isinstance(n, sp.Add), fix)


def _value_of(expr: sp.Expr, values: Mapping[str, float]) -> float | None:
    """``expr`` at ``values`` (every symbol of it given), written as the user would: the shortest number that
    is the same to 12 significant digits (``-300.0``, not ``-300.00000000000006``); None when it has no real
    finite value there.

    Examples
    --------
    >>> k, m = sp.symbols("k m", real=True)
    >>> _value_of(-k / m, {"k": 30.0, "m": 0.1}), _value_of(k / m, {"k": 1.0}), _value_of(k / m, {"k": 1.0, "m": 0})
    (-300.0, None, None)
    """
    if not all(s.name in values for s in expr.free_symbols):
        return None
    try:
        v = complex(expr.subs({s: sp.Float(values[s.name], 30) for s in expr.free_symbols}).evalf(30))
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    if not (abs(v.imag) < 1e-12 * max(1.0, abs(v.real)) and math.isfinite(v.real)):
        return None
    return float(f"{v.real:.12g}")


def _positive(expr: sp.Expr, bounds: Mapping[str, tuple[float, float]]) -> bool:
    """Whether ``expr`` is positive wherever each of its symbols is, all declared non-negative in ``bounds`` (sympy's
    sign rules over positive symbols: a product of powers of them is, a difference is not)."""
    syms = expr.free_symbols
    if not syms or not all(s.name in bounds and bounds[s.name][0] >= 0 for s in syms):
        return False
    return bool(expr.xreplace({s: sp.Dummy(s.name, positive=True) for s in syms}).is_positive)


# --------------------------------------------------------------------------- the proposal
def reparametrize(
    model: Model | str | os.PathLike[str],
    *,
    keep: Sequence[str] = (),
    eliminate: Sequence[str] = (),
    names: Mapping[str, str] | None = None,
    seed: int = 0,
    degree: int = 1,
) -> Reparametrization:
    """Propose identifiable combinations and write the model in them.

    Parameters
    ----------
    model : Model, str or os.PathLike
        Any model (smooth or non-smooth; unknown inputs are not supported), or its file.
    keep : sequence of str
        Parameters that must not be pivots (they stay, possibly rescaled).
    eliminate : sequence of str
        Parameters to use as scaling pivots (normalised to 1), e.g. ``["E", "L", "sigma_y"]``.
    names : mapping of str to str or None
        Renaming of the proposed symbols, e.g. ``{"sigma_p": "r", "A_m_p": "k_m"}``.
    seed : int
        Seed of every random point (error probabilities: see :func:`obsnl.symmetries`).
    degree : int
        Ansatz degree of the symmetry search (1 affine, 2 quadratic).

    Returns
    -------
    Reparametrization

    References
    ----------
    .. [1] E. Hubert and G. Labahn, "Scaling invariants and symmetry reduction of dynamical systems", Foundations of
       Computational Mathematics 13(4), 479-516, 2013. doi:10.1007/s10208-013-9165-9

    Examples
    --------
    >>> from obsnl import Model, reparametrize
    >>> m = Model(name="scaled", states=["x"], parameters=["a", "b", "c"], inputs=["u"],
    ...           equations={"x": "a*x + b*u"}, outputs={"y": "c*x"})
    >>> {k: str(v) for k, v in reparametrize(m).mapping.items()}
    {'x_p': 'x/b', 'a': 'a', 'c_p': 'b*c'}
    """
    t0 = time.perf_counter()
    model = as_model(model)  # a Model, or read from its file (anything else refused in one line)
    check_search(seed, degree)
    check_analysis_limits(model)  # before any work: the analyses below hold dense arrays of this size
    names = dict(names or {})
    keep_s = [model.symbol(k) for k in keep]
    elim_s = [model.symbol(k) for k in eliminate]
    work = _Proposal.start(model, seed, degree)  # 1. the branches and the generators of each
    sec, common = work.common_section(keep_s, elim_s)  # 2. the common scalings and their section
    coords = [(v, sec.invariants.get(v, v)) for v in work.V if v not in sec.pivots]
    moves = work.translations(common, coords)  # 3. the other generators pushed forward
    new, section, built = work.new_model(coords, moves, sec, names)  # 4. the new coordinates, section and model
    check = work.check(built, new)  # 4. the new model verified, and analysed by the engine
    mapping = {nm: phi for nm, phi, _ in new}  # the new symbols, then the states of known initial condition
    mapping.update({x.name: x for x in model.known_initial_conditions})
    functions, method, complete = work.functions(new, tuple(mapping.values()), check.nowhere, moves.unmerged)
    return Reparametrization(
        built,
        model.name,
        mapping,
        {k.name: v for k, v in section.items()},
        tuple(p.name for p in list(sec.pivots) + list(moves.pivots)),
        functions,
        complete,
        not check.nowhere,
        method,
        work.per,
        check.unobservable,
        check.verified,
        tuple(work.notes),
        time.perf_counter() - t0,
        _divided(sec, moves),
        identifiable=not check.remaining and not check.pending,
        remaining=check.remaining,
        undecided=check.pending,
    )


# --------------------------------------------------------------------------- its steps
@dataclass(frozen=True)
class _Translations:
    """Step 3's answer: the translations in the coordinates of the scaling section.

    ``unmerged`` counts the generators that are neither translations nor scalings there; ``ys`` are the coordinates
    of the section; ``common`` the translation rows every branch shares, divided out with ``pivots`` (set to 0) and
    ``invariants`` (``{y_j: y_j - sum c y_piv}``); ``rest`` the coordinates left; ``forms`` the linear forms on them
    adapted to each branch (:func:`~obsnl.recombination.invariants.adapted_forms`).
    """

    unmerged: int
    ys: list[sp.Symbol]
    common: list[list[sp.Expr]]
    pivots: list[sp.Symbol]
    invariants: dict[sp.Symbol, sp.Expr]
    rest: list[sp.Symbol]
    forms: list[tuple[dict[sp.Symbol, sp.Rational], tuple[int, ...]]]


@dataclass(frozen=True)
class _Check:
    """The new model checked: ``verified`` symbolically against the old branches; per branch of it, the coordinates
    the engine finds unobservable or undecided (``unobservable``), and those in every branch (``nowhere``); its
    joint verdict's ``remaining`` (not identifiable) and ``pending`` (inconclusive) coordinates."""

    verified: bool
    unobservable: dict[str, tuple[str, ...]]
    nowhere: set[str]
    remaining: tuple[str, ...]
    pending: tuple[str, ...]


@dataclass(eq=False)
class _Proposal:
    """What the steps of :func:`reparametrize` share: the model, its branches (``every``, and ``branches`` those
    whose feasibility is decided) with the generators of each (``per``), the variables the groups act on (``V``:
    the states without a known initial condition, then the parameters), the exponent parameters the scaling weights
    may hold (``exps``), and the notes, in the order the steps write them."""

    model: Model
    seed: int
    syms: dict[str, sp.Symbol]
    every: tuple[Branch, ...]
    branches: list[Branch]
    per: tuple[Symmetries, ...]
    notes: list[str]
    kic: tuple[sp.Symbol, ...]
    V: list[sp.Symbol]
    exps: list[sp.Symbol]

    @classmethod
    def start(cls, model: Model, seed: int, degree: int) -> _Proposal:
        """Step 1: split the model into branches and find the generators of each (branch ``i`` searched with seed
        ``seed + i``). A branch whose feasibility is undecided is not used; a note says so, since the new
        coordinates are then not checked there."""
        syms = model.symbols
        every = split_branches(model, seed=seed, undecided=True)
        branches = [b for b in every if not b.undecided]
        per = tuple(symmetries_of(b.model, seed=seed + i, degree=degree) for i, b in enumerate(branches))
        notes = [
            f"branch {b.label} ({b.guard_text}) not used, its feasibility is undecided (the new coordinates "
            f"are not checked there): {b.undecided}"
            for b in every
            if b.undecided
        ]
        kic = tuple(model.known_initial_conditions)  # in the model's order: the section lists them so, on every run
        V = [s for s in model.states if s not in kic] + list(model.parameters)
        exps = sorted({syms[e] for s in per for e in s.exponents}, key=lambda s: s.name)
        return cls(model, seed, syms, every, branches, per, notes, kic, V, exps)

    # ----------------------------------------------------------------------- 2. common scalings
    def common_section(
        self, keep: Sequence[sp.Symbol], eliminate: Sequence[sp.Symbol]
    ) -> tuple[ScalingSection, list[list[sp.Expr]]]:
        """Step 2: the section of the scalings shared by every branch (their Hubert-Labahn invariants, reference [1]
        of :func:`reparametrize`, with the pivots set to 1), and the weight rows of that group (over ``V``).

        The pivots avoid the parameters of the measured part of the model where another choice exists. When no
        section can be made, and no pivot was asked for (``keep``, ``eliminate``), the scalings are not divided
        out and a note says why; with pivots asked for, the refusal stands.
        """
        common = None
        for s in self.per:
            rows = [[sp.cancel(g.components.get(v.name, 0) / v) for v in self.V] for g in s.of_kind("scaling")]
            common = rows if common is None else span_intersection(common, rows)
        measured = self._measured()
        try:
            sec = scaling_section(
                [dict(zip(self.V, r)) for r in (common or [])],
                self.V,
                self.model.parameters,
                exponents=self.exps,
                keep=keep,
                eliminate=eliminate,
                avoid=[p for p in self.model.parameters if p in measured],
            )
        except ModelError as exc:
            if eliminate or keep:
                raise
            self.notes.append(f"the common scalings were not divided out: {exc}")
            common, sec = [], scaling_section([], self.V, self.model.parameters)
        return sec, common or []

    def _measured(self) -> set[sp.Symbol]:
        """The symbols of the measured part of the model: those of the outputs, and of the equation of every state
        that no branch leaves unobservable."""
        hidden = set().union(*(set(s.unobservable) for s in self.per)) if self.per else set()
        measured = set().union(*(e.free_symbols for e in self.model.output_exprs))
        for x in self.model.states:
            if x.name not in hidden:
                measured |= self.model.equations[x].free_symbols
        return measured

    # ----------------------------------------------------------------------- 3. other generators
    def translations(self, common: list[list[sp.Expr]], coords: list[tuple[sp.Symbol, sp.Expr]]) -> _Translations:
        """Step 3: every other generator pushed forward to the coordinates of the section, where a translation is
        kept. Translations common to all branches are divided out (linear invariants; not when one moves states
        only, which a note says); those of some branches only become forms adapted to each branch, so that a
        combination identifiable in one branch and another identifiable in another both survive."""
        branch_vecs, unmerged = self._pushed_forward(common, coords)
        common_t = None
        for vecs in branch_vecs:
            rows = [[v.get(y, 0) for y, _ in coords] for v in vecs]
            common_t = rows if common_t is None else span_intersection(common_t, rows)
        ys = [y for y, _ in coords]
        states = self.model.states
        unit_states = [y for y in ys if y in states and [int(y == z) for z in ys] in (common_t or [])]
        tpiv, tinv = translation_invariants(
            [dict(zip(ys, r)) for r in (common_t or [])], ys, list(self.model.parameters) + unit_states
        )
        if any(p in states and p not in unit_states for p in tpiv):
            self.notes.append("a common translation moves states only; it was not divided out")
            tpiv, tinv = [], {}
        rest = [y for y in ys if y not in tpiv]
        forms = adapted_forms(_remaining_translations(branch_vecs, ys, rest, tinv), rest)
        return _Translations(unmerged, ys, common_t or [], tpiv, tinv, rest, forms)

    def _pushed_forward(
        self, common: list[list[sp.Expr]], coords: list[tuple[sp.Symbol, sp.Expr]]
    ) -> tuple[list[list[dict[sp.Symbol, sp.Rational]]], int]:
        """Per branch, the translation vector in ``coords`` of each of its generators that moves them (a scaling of
        the divided group, tested at a random integer value of the exponents, does not); and how many generators
        are not translations there."""
        branch_vecs: list[list[dict[sp.Symbol, sp.Rational]]] = []
        unmerged = 0
        common_num = _numeric_rows(common, self.V, self.exps)
        for s in self.per:
            vecs = []
            for g in s.generators:
                comp = {self.syms[k]: c for k, c in g.components.items()}
                if g.kind == "scaling" and common_num is not None:
                    row = _numeric_rows([[sp.cancel(comp.get(v, 0) / v) for v in self.V]], self.V, self.exps)
                    if (
                        common_num.nrows()
                        and row is not None
                        and flint.fmpq_mat(common_num.tolist() + row.tolist()).rank() == common_num.rank()
                    ):
                        continue  # in the divided group: it does not move the invariants
                pf = pushforward(comp, coords)
                if pf is None:
                    unmerged += 1
                elif pf:
                    vecs.append(pf)
            branch_vecs.append(vecs)
        return branch_vecs, unmerged

    # ----------------------------------------------------------------------- 4. the new model
    def new_model(
        self,
        coords: list[tuple[sp.Symbol, sp.Expr]],
        moves: _Translations,
        sec: ScalingSection,
        names: Mapping[str, str],
    ) -> tuple[list[tuple[str, sp.Expr, sp.Expr]], dict[sp.Symbol, sp.Expr], Model]:
        """Step 4: the new coordinates ``(name, phi, linear form)`` renamed by ``names``, the old symbols on the
        section (pivots 1, translation pivots 0), and the new model, the equation of a new state ``s = phi(z)`` being
        ``L_f(phi)`` there.

        A ``Delta`` that enters the new model's Piecewise values only negated is flipped, and the model built once
        more. ``names`` renaming a symbol that is not proposed is refused. A note says when generators that are
        neither translations nor scalings leave their directions in the new model.
        """
        flips: set[str] = set()
        for _ in range(2):
            internal = coordinates(coords, moves.rest, moves.invariants, moves.forms, self.V, flips)
            unknown = set(names) - {nm for nm, _, _ in internal}
            if unknown:
                raise ModelError(
                    f"names= renames {sorted(unknown)[0]!r}, which is not a proposed symbol; proposed: "
                    f"{', '.join(nm for nm, _, _ in internal)}"
                )
            new = [(names.get(nm, nm), phi, lin) for nm, phi, lin in internal]
            section = section_map(new, moves.rest, moves.pivots, sec, self.V, self.kic)
            built = _build(self.model, new, section, self.notes)
            deltas = {names.get(nm, nm): nm for nm, _, _ in internal if nm.startswith("Delta")}
            neg = _negated_only(built, list(deltas))
            if not neg:
                break
            flips |= {deltas[n] for n in neg}
        if moves.unmerged:
            self.notes.append(
                f"{moves.unmerged} generator(s) are neither translations nor scalings in the invariant "
                f"coordinates; their directions remain in the new model"
            )
        return new, section, built

    def check(self, built: Model, new: Sequence[tuple[str, sp.Expr, sp.Expr]]) -> _Check:
        """The new model verified symbolically, branch by branch, against the old one, and its observability checked
        independently by the engine (:func:`~obsnl.observability.engines.smooth.analyze_smooth`) in each of its
        branches; a note for each branch the engine leaves with a reason.

        Whether the new model is identifiable is its joint verdict (:func:`obsnl.analyze`, its branches together: a
        coordinate unobservable in each branch alone may be revealed by the branches together), never the
        proposal's own bookkeeping; a note when no branch of it could be analysed.
        """
        new_branches = split_branches(built, seed=self.seed)
        verified = verify_reparametrization(built, {nm: phi for nm, phi, _ in new}, self.branches, new_branches)
        unobs = {}
        for b in new_branches:  # the engine checks our proposal independently (obsnl.analyze_smooth)
            res = analyze_smooth(b.model, method="sedoglavic", seed=self.seed)
            unobs[b.label] = tuple(res.unobservable) + tuple(res.undecided)
            if res.reason:
                self.notes.append(f"branch {b.label} of the new model: {res.reason}")
        nowhere = set.intersection(*(set(v) for v in unobs.values())) if unobs else set()
        joint = analyze(built, seed=self.seed, per_branch=False).joint
        remaining: tuple[str, ...]
        if joint is None:
            remaining, pending = (), tuple(s.name for s in built.states + built.parameters)
            self.notes.append("the joint verdict of the new model could not be made: no branch of it was analysed")
        else:
            remaining, pending = tuple(joint.unobservable), tuple(joint.inconclusive)
        return _Check(verified, unobs, nowhere, remaining, pending)

    def functions(
        self,
        new: Sequence[tuple[str, sp.Expr, sp.Expr]],
        proposed: tuple[sp.Expr, ...],
        nowhere: set[str],
        unmerged: int,
    ) -> tuple[tuple[sp.Expr, ...], str, bool]:
        """The identifiable functions, how they were found, and whether they generate the whole field, with the
        notes on what is left.

        They are the ``proposed`` coordinates, complete when every unobservable direction of every branch got a
        closed form that is a translation or a scaling there and no coordinate is unobservable in every branch of
        the new model. A model of one branch (a smooth one) for which that falls short gets its functions from
        :func:`~obsnl.recombination.identifiable.identifiable_functions`. A branch left undecided is not checked,
        so the answer is then not complete.
        """
        missing = sum(s.missing for s in self.per)
        complete = not nowhere and not missing and not unmerged
        functions = proposed
        method = "symmetries"
        if len(self.branches) == 1 and not complete:
            from obsnl.recombination.identifiable import identifiable_functions

            idf = identifiable_functions(
                self.model, seed=self.seed, symmetries=self.per[0], invariants=[phi for _, phi, _ in new]
            )
            functions, method, complete = idf.functions, idf.method, idf.complete
            self.notes.extend(idf.notes)
        complete = complete and len(self.every) == len(self.branches)  # an undecided branch is not checked
        for b, s in zip(self.branches, self.per):
            if s.missing:
                self.notes.append(
                    f"branch {b.label}: {s.missing} unobservable direction(s) without a closed form remain"
                )
        if nowhere:
            self.notes.append(f"unobservable in every branch of the new model: {', '.join(sorted(nowhere))}")
        return functions, method, complete


def _remaining_translations(
    branch_vecs: Sequence[Sequence[Mapping[sp.Symbol, sp.Rational]]],
    ys: Sequence[sp.Symbol],
    rest: Sequence[sp.Symbol],
    tinv: Mapping[sp.Symbol, sp.Expr],
) -> list[list[dict[sp.Symbol, sp.Expr]]]:
    """Per branch, its translations in the remaining coordinates (``y_j - sum c y_piv`` where a common translation
    was divided out), without those that no longer move anything."""
    rvecs = []
    for vecs in branch_vecs:
        rv = []
        for v in vecs:
            w = {
                y: sp.expand(tinv[y].xreplace({q: v.get(q, 0) for q in ys}) if y in tinv else v.get(y, 0)) for y in rest
            }
            if any(w.values()):
                rv.append(w)
        rvecs.append(rv)
    return rvecs


def _divided(sec: ScalingSection, moves: _Translations) -> tuple[str, ...]:
    """The group divided out, one generator per pivot, as text: the scalings in rref form over their pivots, then
    the common translations (when some were divided out)."""
    divided = [str(Symmetry("scaling", {v.name: w * v for v, w in row.items()})) for row in sec.weights]
    divided += [
        str(Symmetry("translation", {y.name: c for y, c in zip(moves.ys, r) if c != 0}))
        for r in moves.common
        if moves.pivots
    ]
    return tuple(divided)


def _negated_only(model: Model, deltas: Sequence[str]) -> set[str]:
    """Delta symbols that appear only as ``-Delta`` in the Piecewise values of ``model``."""
    out = set()
    pieces = [a for e in list(model.rhs) + list(model.output_exprs) for pw in e.atoms(sp.Piecewise) for a, _ in pw.args]
    for nm in deltas:
        s = make_symbol(nm)
        if any(a == -s for a in pieces) and not any(a == s for a in pieces):
            out.add(nm)
    return out


def _latex_of(model: Model, nm: str) -> str | None:
    if nm in model.latex:
        return model.latex[nm]
    if nm.endswith("_p") and nm[:-2] in model.latex:
        return model.latex[nm[:-2]] + "'"
    if nm.startswith("Delta") and nm[5:].isdigit():
        return f"\\Delta_{{{nm[5:]}}}"
    return None


def _build(model: Model, new: list, section: Mapping[sp.Symbol, sp.Expr], notes: list[str]) -> Model:
    kic = list(model.known_initial_conditions)
    states_set = set(model.states)
    eqs: dict[str, sp.Expr] = {}
    params: list[str] = []
    defs: dict[str, str] = {}
    for nm, phi, _ in new:
        defs[nm] = sp.sstr(phi)
        if phi.free_symbols & states_set:
            rhs = sp.Add(*[sp.diff(phi, x) * model.equations[x] for x in model.states if phi.has(x)])
            eqs[nm] = _piecewise_tidy(rhs.xreplace(section))
        else:
            params.append(nm)
    for x in kic:
        eqs[x.name] = _piecewise_tidy(model.equations[x].xreplace(section))
        defs[x.name] = x.name
    order = [x.name for x in model.states]
    state_names = sorted(eqs, key=lambda n: order.index(n) if n in order else len(order))
    outs = {k: _piecewise_tidy(v.xreplace(section)) for k, v in model.outputs.items()}
    switching = [g.xreplace(section) for g in model.switching]
    switching = [g for g in switching if g.free_symbols]
    latex = {
        nm: t
        for nm in list(eqs) + params + [s.name for s in model.inputs + model.known_constants]
        if (t := _latex_of(model, nm)) is not None
    }
    values: dict[str, float] = {}
    guess: dict[str, float] = {}  # each new parameter's guess: its definition at the old guesses
    bounds: dict[str, str | tuple[float, float]] = {}
    for nm, phi, _ in new:
        v = _value_of(phi, model.values)
        if v is not None:
            values[nm] = v
        if nm in params and (g := _value_of(phi, model.guess)) is not None and g != 0:
            guess[nm] = g
        if nm in params and _positive(phi, model.bounds):
            bounds[nm] = "positive"
    for s in list(model.inputs) + list(model.known_constants) + kic:
        if s.name in model.values:
            values[s.name] = model.values[s.name]
    for s in model.known_constants:  # known constants keep their names, and their bounds
        if s.name in model.bounds:
            bounds[s.name] = model.bounds[s.name]
    if model.guess and (lost := [nm for nm in params if nm not in guess]):
        notes.append(
            f"no guess for {', '.join(lost)}: its definition needs a guess of every old symbol in it "
            f"(a state, or a parameter without one), or is 0 there"
        )
    icv = {s.name: v.xreplace(section) for s, v in model.initial_condition_values.items()}
    pivots = [k.name for k, v in section.items() if v == 1 and k in model.parameters]
    desc = (
        f"Reparametrization of '{model.name}' proposed by obsnl.reparametrize: scaling pivots "
        f"{', '.join(pivots) or 'none'} set to 1 (assumed positive); every new symbol is defined in "
        f"[definitions] in terms of the symbols of '{model.name}'."
    )
    return Model(
        name=f"{model.name}_reparam",
        states=state_names,
        parameters=params,
        inputs=[s.name for s in model.inputs],
        known_constants=[s.name for s in model.known_constants],
        equations=eqs,
        outputs=outs,
        switching=switching,
        known_initial_conditions=[s.name for s in kic],
        initial_condition_values=icv,
        description=desc,
        source=model.source,
        latex=latex,
        values=values,
        guess=guess,
        definitions=defs,
        bounds=bounds,
        intersample=dict(model.intersample),
    )
