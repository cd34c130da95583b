"""Identifiable reparametrizations from the symmetry generators, branch by branch, merged.

Algorithm (algorithms.md §4.2, step C, extended to non-smooth models):

1. Split the model into branches and find the generators of each (:func:`obsnl.symmetries`).
2. The scalings shared by *every* branch form a group whose Hubert-Labahn invariants are the new
   coordinates (:func:`obsnl.invariants.scaling_section`; exponents may depend on ``N``).
3. Every other generator is pushed forward to these coordinates; a translation there is kept.
   Translations common to all branches are divided out (linear invariants); those of some branches
   only are kept as *branch-adapted* coordinates: ``Delta1 = beta' + gamma'`` (identifiable in the
   branches where only ``beta + gamma`` acts) next to ``Delta2 = beta' - gamma'``. Thus a
   combination identifiable in one branch and another identifiable in another both survive.
4. The new model is the old one on the section (pivots = 1, translation pivots = 0), the equation
   of a new state ``s = phi(z)`` being ``L_f(phi)`` there. It is verified symbolically, branch by
   branch, and its identifiability is checked with the power-series Jacobian of every branch.

Pivots are divided by: the section assumes them positive (as physical moduli, lengths and masses are).
A smooth model whose generators are not all translations and scalings, or that has directions with
no closed form, gets its identifiable functions from :func:`obsnl.identifiable.identifiable_functions`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import sympy as sp

from .branches import split_branches
from .errors import ModelError
from .fields import canonical
from .invariants import adapted_forms, scaling_section, span_intersection, translation_invariants
from .jets import observability_jacobian
from .model import Model
from .parse import make_symbol
from .symmetry import Symmetries, symmetries
from .writer import model_to_toml

__all__ = ["Reparametrization", "reparametrize"]


@dataclass(frozen=True)
class Reparametrization:
    """A proposed identifiable reparametrization.

    Attributes
    ----------
    model
        The new model (states and parameters are the new coordinates; ``definitions`` holds each
        new symbol in the old ones).
    mapping
        ``{new name: expression in the old symbols}``.
    section
        ``{old name: expression in the new symbols}`` on the section (pivots 1, translation pivots 0).
    pivots
        Old parameters normalised away (scaling pivots set to 1, translation pivots to 0).
    functions
        Identifiable functions of the old symbols that generate the field of identifiable functions
        (smooth models; for a non-smooth model the coordinates identifiable in at least one branch).
    complete
        True when ``functions`` generate the whole field of identifiable functions (checked again at
        an independent random point for a smooth model; for a non-smooth model: every unobservable
        direction of every branch got a closed form and the new model is observable).
    observable
        Every coordinate of the new model is observable in at least one of its branches.
    method
        How ``functions`` were obtained: ``"symmetries"`` or ``"symmetries+..."`` (see
        :func:`obsnl.identifiable.identifiable_functions`).
    branches
        The :class:`obsnl.Symmetries` of each branch of the original model.
    unobservable
        Per branch of the new model, its unobservable coordinates.
    verified
        The new model's equations and outputs were checked symbolically against the old ones.
    """

    model: Model
    original: str
    mapping: Mapping[str, sp.Expr]
    section: Mapping[str, sp.Expr]
    pivots: tuple[str, ...]
    functions: tuple[sp.Expr, ...]
    complete: bool
    observable: bool
    method: str
    branches: tuple[Symmetries, ...]
    unobservable: Mapping[str, tuple[str, ...]]
    verified: bool
    notes: tuple[str, ...] = ()
    seconds: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        return {"original": self.original, "model": self.model.name,
                "mapping": {k: sp.sstr(v) for k, v in self.mapping.items()},
                "section": {k: sp.sstr(v) for k, v in self.section.items()}, "pivots": list(self.pivots),
                "functions": [sp.sstr(f) for f in self.functions], "complete": self.complete,
                "observable": self.observable,
                "method": self.method, "verified": self.verified,
                "unobservable": {k: list(v) for k, v in self.unobservable.items()},
                "branches": [b.to_dict() for b in self.branches], "notes": list(self.notes),
                "seconds": self.seconds}

    def to_toml(self) -> str:
        """The new model as a model file (loads with :func:`obsnl.load_model`)."""
        return model_to_toml(self.model, header=f"Identifiable reparametrization of '{self.original}' "
                                                f"(obsnl.reparametrize). New symbols are defined in [definitions].")


# --------------------------------------------------------------------------- helpers
def _pushforward(comp: Mapping[sp.Symbol, sp.Expr], coords: Sequence[tuple[sp.Symbol, sp.Expr]]):
    """The translation vector of generator ``comp`` in ``coords`` (None if it is not a translation there).

    Returns ``{}`` when the generator does not move the coordinates (it lies in the divided group).
    """
    vals = []
    for y, phi in coords:
        vals.append(sp.Add(*[c * sp.diff(phi, v) for v, c in comp.items()]))
    vals = [sp.expand(v) for v in vals]
    nz = [(y, v) for (y, _), v in zip(coords, vals) if v != 0 and sp.cancel(sp.together(canonical(v))) != 0]
    if not nz:
        return {}
    ref = nz[0][1]
    out = {}
    for y, v in nz:
        r = v / ref
        if not r.is_Rational:
            r = sp.cancel(sp.together(canonical(v) / canonical(ref)))
        if not r.is_Rational:
            return None
        if r != 0:
            out[y] = r
    return out


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


def _same(a: sp.Expr, b: sp.Expr) -> bool:
    """Symbolic equality through the canonical (atom) form, which makes both rational."""
    d = canonical(a) - canonical(b)
    return d == 0 or sp.cancel(sp.together(d)) == 0


def _value_of(expr: sp.Expr, values: Mapping[str, float]) -> float | None:
    if not all(s.name in values for s in expr.free_symbols):
        return None
    try:
        v = complex(expr.subs({s: sp.Float(values[s.name], 30) for s in expr.free_symbols}).evalf(30))
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    return float(v.real) if abs(v.imag) < 1e-12 * max(1.0, abs(v.real)) and v.real == v.real else None


# --------------------------------------------------------------------------- the proposal
def reparametrize(model: Model, *, keep: Sequence[str] = (), eliminate: Sequence[str] = (),
                  names: Mapping[str, str] | None = None, seed: int = 0, degree: int = 1) -> Reparametrization:
    """Propose identifiable combinations and write the model in them.

    Parameters
    ----------
    model
        Any model (smooth or non-smooth; unknown inputs are not supported).
    keep
        Parameters that must not be pivots (they stay, possibly rescaled).
    eliminate
        Parameters to use as scaling pivots (normalised to 1), e.g. ``["E", "L", "sigma_y"]``.
    names
        Renaming of the proposed symbols, e.g. ``{"sigma_p": "r", "A_m_p": "k_m"}``.
    seed
        Seed of every random point (error probabilities: see :func:`obsnl.symmetries`).
    degree
        Ansatz degree of the symmetry search (1 affine, 2 quadratic).

    Returns
    -------
    Reparametrization

    Examples
    --------
    >>> from obsnl import Model, reparametrize
    >>> m = Model(name="scaled", states=["x"], parameters=["a", "b", "c"], inputs=["u"],
    ...           equations={"x": "a*x + b*u"}, outputs={"y": "c*x"})
    >>> {k: str(v) for k, v in reparametrize(m).mapping.items()}
    {'x_p': 'c*x', 'a': 'a', 'b_p': 'b*c'}
    """
    t0 = time.perf_counter()
    names = dict(names or {})
    syms = model.symbols
    keep_s = [model.symbol(k) for k in keep]
    elim_s = [model.symbol(k) for k in eliminate]
    branches = split_branches(model, seed=seed)
    per = tuple(symmetries(b.model, seed=seed + i, degree=degree) for i, b in enumerate(branches))
    notes: list[str] = []
    kic = set(model.known_initial_conditions)
    V = [s for s in model.states if s not in kic] + list(model.parameters)
    exps = sorted({syms[e] for s in per for e in s.exponents}, key=lambda s: s.name)

    # 2. common scalings and their section
    common = None
    for s in per:
        rows = [[sp.cancel(g.components.get(v.name, 0) / v) for v in V] for g in s.of_kind("scaling")]
        common = rows if common is None else span_intersection(common, rows)
    hidden = set().union(*(set(s.unobservable) for s in per)) if per else set()
    measured = set().union(*(e.free_symbols for e in model.output_exprs))
    for x in model.states:
        if x.name not in hidden:
            measured |= model.equations[x].free_symbols
    sec = scaling_section([dict(zip(V, r)) for r in (common or [])], V, model.parameters, exponents=exps,
                          keep=keep_s, eliminate=elim_s, avoid=[p for p in model.parameters if p in measured])
    coords = [(v, sec.invariants.get(v, v)) for v in V if v not in sec.pivots]

    # 3. other generators pushed forward
    branch_vecs: list[list[dict]] = []
    unmerged = 0
    for s in per:
        vecs = []
        for g in s.generators:
            comp = {syms[k]: c for k, c in g.components.items()}
            pf = _pushforward(comp, coords)
            if pf is None:
                unmerged += 1
            elif pf:
                vecs.append(pf)
        branch_vecs.append(vecs)
    common_t = None
    for vecs in branch_vecs:
        rows = [[v.get(y, 0) for y, _ in coords] for v in vecs]
        common_t = rows if common_t is None else span_intersection(common_t, rows)
    ys = [y for y, _ in coords]
    unit_states = [y for y in ys if y in model.states and [int(y == z) for z in ys] in (common_t or [])]
    tpiv, tinv = translation_invariants([dict(zip(ys, r)) for r in (common_t or [])], ys,
                                        list(model.parameters) + unit_states)
    if any(p in model.states and p not in unit_states for p in tpiv):
        notes.append("a common translation moves states only; it was not divided out")
        tpiv, tinv = [], {}
    rest = [y for y in ys if y not in tpiv]
    rvecs = []  # branch translations in the remaining coordinates (y_j - sum c y_piv)
    for vecs in branch_vecs:
        rv = []
        for v in vecs:
            w = {y: sp.expand(tinv[y].xreplace({q: v.get(q, 0) for q in ys}) if y in tinv else v.get(y, 0))
                 for y in rest}
            if any(w.values()):
                rv.append(w)
        rvecs.append(rv)
    forms = adapted_forms(rvecs, rest)

    # 4. new coordinates, the section, the new model (a Delta that enters only negated is flipped)
    flips: set[str] = set()
    for _ in range(2):
        new = _coordinates(coords, rest, tinv, forms, V, names, flips)
        section = _section(new, rest, tpiv, sec, V, kic)
        built = _build(model, new, section, notes)
        neg = _negated_only(built, [nm for nm, _, _ in new if nm.startswith("Delta")])
        if not neg:
            break
        flips |= neg
    if unmerged:
        notes.append(f"{unmerged} generator(s) are neither translations nor scalings in the invariant "
                     f"coordinates; their directions remain in the new model")
    new_branches = split_branches(built, seed=seed)
    verified = _verify_model(built, {nm: phi for nm, phi, _ in new}, branches, new_branches)
    unobs = {}
    for b in new_branches:
        J = observability_jacobian(b.model, seed=seed)
        unobs[b.label] = tuple(v.name for v in J.unobservable)
    nowhere = set.intersection(*(set(v) for v in unobs.values())) if unobs else set()
    missing = sum(s.missing for s in per)
    complete = not nowhere and not missing and not unmerged
    mapping = {nm: phi for nm, phi, _ in new}
    mapping.update({x.name: x for x in model.known_initial_conditions})
    functions = tuple(mapping.values())
    method = "symmetries"
    if len(branches) == 1 and not complete:
        from .identifiable import identifiable_functions

        idf = identifiable_functions(model, seed=seed, symmetries=per[0], invariants=[phi for _, phi, _ in new])
        functions, method, complete = idf.functions, idf.method, idf.complete
        notes.extend(idf.notes)
    if nowhere:
        notes.append(f"unobservable in every branch of the new model: {', '.join(sorted(nowhere))}")
    return Reparametrization(built, model.name, mapping, {k.name: v for k, v in section.items()},
                             tuple(p.name for p in list(sec.pivots) + list(tpiv)), functions, complete,
                             not nowhere, method, per, unobs, verified, tuple(notes), time.perf_counter() - t0)


def _coordinates(coords, rest, tinv, forms, V, names, flips) -> list[tuple[str, sp.Expr, sp.Expr]]:
    """The new coordinates ``(name, expression in the old symbols, linear expression in the y)``."""
    phi_y = dict(coords)
    formed = set().union(*(set(f) for f, _ in forms)) if forms else set()
    y_of_new: dict[str, sp.Expr] = {}
    k_delta = 0
    for y in rest:
        if y not in formed:
            y_of_new[y.name if phi_y[y] == y else f"{y.name}_p"] = tinv.get(y, y)
    for f, _ in forms:
        lin = sp.Add(*[c * tinv.get(y, y) for y, c in f.items()])
        if len(f) == 1 and list(f.values())[0] == 1:
            y = list(f)[0]
            nm = y.name if phi_y[y] == y else f"{y.name}_p"
        else:
            k_delta += 1
            nm = f"Delta{k_delta}"
            lin = -lin if nm in flips else lin
        y_of_new[nm] = lin
    order = {v: i for i, v in enumerate(V)}
    new = []
    for nm in sorted(y_of_new, key=lambda n: min(order[y] for y in y_of_new[n].free_symbols)):
        phi = sp.expand(y_of_new[nm].xreplace(phi_y))
        phi = sp.powsimp(sp.factor_terms(phi)) if isinstance(phi, sp.Add) else phi
        new.append((names.get(nm, nm), phi, y_of_new[nm]))
    return new


def _section(new, rest, tpiv, sec, V, kic) -> dict[sp.Symbol, sp.Expr]:
    """Old symbols in terms of the new ones on the section (pivots 1, translation pivots 0)."""
    unknown_y = [sp.Dummy(y.name) for y in rest + tpiv]
    to_dummy = dict(zip(rest + tpiv, unknown_y))
    eqs_lin = [lin.xreplace(to_dummy) - make_symbol(nm) for nm, _, lin in new] + [to_dummy[p] for p in tpiv]
    sol = sp.solve(eqs_lin, unknown_y, dict=True)
    if len(sol) != 1:
        raise ModelError("internal: the linear coordinates are not invertible")  # pragma: no cover
    ysec = {y: sol[0][to_dummy[y]] for y in rest + tpiv}
    section: dict[sp.Symbol, sp.Expr] = {p: sp.Integer(1) for p in sec.pivots}
    for v in V:
        if v not in sec.pivots:
            val = ysec.get(v, sp.Integer(0))
            section[v] = val ** sp.Rational(1, sec.powers[v]) if sec.powers.get(v, 1) != 1 else val
    for v in kic:
        section[v] = v
    return section


def _negated_only(model: Model, deltas: Sequence[str]) -> set[str]:
    """Delta symbols that appear only as ``-Delta`` in the Piecewise values of ``model``."""
    out = set()
    pieces = [a for e in list(model.rhs) + list(model.output_exprs) for pw in e.atoms(sp.Piecewise)
              for a, _ in pw.args]
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
    latex = {nm: t for nm in list(eqs) + params + [s.name for s in model.inputs + model.known_constants]
             if (t := _latex_of(model, nm)) is not None}
    values: dict[str, float] = {}
    for nm, phi, _ in new:
        v = _value_of(phi, model.values)
        if v is not None:
            values[nm] = v
    for s in list(model.inputs) + list(model.known_constants) + kic:
        if s.name in model.values:
            values[s.name] = model.values[s.name]
    icv = {s.name: v.xreplace(section) for s, v in model.initial_condition_values.items()}
    pivots = [k.name for k, v in section.items() if v == 1 and k in model.parameters]
    desc = (f"Identifiable reparametrization of '{model.name}' proposed by obsnl.reparametrize: scaling pivots "
            f"{', '.join(pivots) or 'none'} set to 1 (assumed positive); every new symbol is defined in "
            f"[definitions] in terms of the symbols of '{model.name}'.")
    return Model(name=f"{model.name}_reparam", states=state_names, parameters=params,
                 inputs=[s.name for s in model.inputs], known_constants=[s.name for s in model.known_constants],
                 equations=eqs, outputs=outs, switching=switching, known_initial_conditions=[s.name for s in kic],
                 initial_condition_values=icv, description=desc, source=model.source, latex=latex,
                 values=values, definitions=defs)


def _verify_model(new: Model, mapping: Mapping[str, sp.Expr], old_branches, new_branches) -> bool:
    """Branch by branch: ``L_f(phi_s) == f~_s(phi)`` for every new state and ``h == h~(phi)``."""
    back = {make_symbol(nm): phi for nm, phi in mapping.items()}
    if len(new_branches) != len(old_branches):
        return False
    for ob, nb in zip(old_branches, new_branches):
        f = ob.model.equations
        for s in nb.model.states:
            phi = mapping.get(s.name, s)
            lhs = sp.Add(*[sp.diff(phi, x) * f[x] for x in ob.model.states if phi.has(x)])
            if not _same(lhs, nb.model.equations[s].xreplace(back)):
                return False
        for k, h in ob.model.outputs.items():
            if not _same(h, nb.model.outputs[k].xreplace(back)):
                return False
    return True
