"""The only bridge from symbols to numbers: a :class:`~obsnl.Model` becomes casadi Functions.

:func:`to_casadi` turns the sympy vector field, outputs and switching functions of a model into
casadi ``SX`` Functions (``sign``/``Abs``/``Heaviside``/``Piecewise``/``Max``/``Min`` become
``sign``/``fabs``/``if_else``/``fmax``/``fmin``, so every evaluation uses the full non-smooth
model) and builds discrete steps from them. The estimators (:mod:`obsnl.estimation.ukf`, :mod:`obsnl.estimation.dukf`)
work with the resulting :class:`NumericModel` and never import sympy.

The resulting :class:`~obsnl.estimation.numeric.NumericModel` (re-exported here) makes the discrete steps
(RK4 with the implicit ROS2 fallback where stiff; see :mod:`obsnl.estimation.numeric`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

import casadi as ca
import numpy as np
import sympy as sp

from obsnl.errors import ModelError, NotSupportedError, TableError
from obsnl.estimation.jitcache import jit_options
from obsnl.estimation.numeric import NumericModel, ParameterMap
from obsnl.model.branching.jumps import Discontinuities, discontinuities
from obsnl.model.branching.signature import ModelSignature
from obsnl.model.branching.switching import expr_text, switching_functions
from obsnl.model.core import Model
from obsnl.model.reading.parse import make_symbol, parse_expression

__all__ = [
    "NumericModel",
    "ParameterMap",
    "to_casadi",
    "parameter_map",
    "log_map",
    "numpy_model",
    "jit_options",
]

_UNARY = {
    sp.exp: ca.exp,
    sp.log: ca.log,
    sp.sin: ca.sin,
    sp.cos: ca.cos,
    sp.tan: ca.tan,
    sp.tanh: ca.tanh,
    sp.sinh: ca.sinh,
    sp.cosh: ca.cosh,
    sp.atan: ca.atan,
    sp.sign: ca.sign,
    sp.Abs: ca.fabs,
}


class _ToCasadi:
    """sympy expression -> casadi SX, sharing repeated subtrees."""

    def __init__(self, table: Mapping[sp.Symbol, ca.SX]) -> None:
        self.memo: dict[sp.Basic, ca.SX] = dict(table)

    def __call__(self, e: sp.Basic) -> ca.SX:
        if e in self.memo:
            return self.memo[e]
        out = self._convert(e)
        self.memo[e] = out
        return out

    def _fold(self, fn: Any, args: Sequence[sp.Basic]) -> ca.SX:
        out = self(args[0])
        for a in args[1:]:
            out = fn(out, self(a))
        return out

    def _convert(self, e: sp.Basic) -> ca.SX:
        c = self
        if e is sp.true:
            return ca.SX(1.0)
        if e is sp.false:
            return ca.SX(0.0)
        if e.is_Number or e is sp.pi or e is sp.E:
            return ca.SX(float(e))
        if isinstance(e, sp.Symbol):
            raise ModelError(f"symbol {e.name!r} has no numeric role (give a value for known constants)")
        if isinstance(e, sp.Add):
            return sum((c(a) for a in e.args[1:]), c(e.args[0]))
        if isinstance(e, sp.Mul):
            out = c(e.args[0])
            for a in e.args[1:]:
                out = out * c(a)
            return out
        if isinstance(e, sp.Pow):
            b, p = e.args
            if p.is_Integer:
                return c(b) ** int(p)
            return _power(c(b), c(p))
        if e.func in _UNARY:
            return _UNARY[e.func](c(e.args[0]))
        if isinstance(e, sp.Heaviside):
            x = c(e.args[0])
            return ca.if_else(x > 0, 1.0, ca.if_else(x < 0, 0.0, 0.5))
        if isinstance(e, (sp.Max, sp.Min)):
            return self._fold(ca.fmax if isinstance(e, sp.Max) else ca.fmin, e.args)
        if isinstance(e, sp.Piecewise):
            out = ca.SX(np.nan)  # undefined where no condition holds
            for expr, cond in reversed(e.args):
                out = c(expr) if cond is sp.true else ca.if_else(c(cond), c(expr), out)
            return out
        rel = {
            sp.StrictGreaterThan: ca.gt,
            sp.StrictLessThan: ca.lt,
            sp.GreaterThan: ca.ge,
            sp.LessThan: ca.le,
            sp.Eq: ca.eq,
            sp.Ne: ca.ne,
        }
        if type(e) in rel:
            return rel[type(e)](c(e.lhs), c(e.rhs))
        if isinstance(e, (sp.And, sp.Or)):
            return self._fold(ca.logic_and if isinstance(e, sp.And) else ca.logic_or, e.args)
        if isinstance(e, sp.Not):
            return ca.logic_not(c(e.args[0]))
        raise NotSupportedError(f"cannot translate {type(e).__name__} ({e}) to casadi")


def _power(base: ca.SX, exponent: ca.SX) -> ca.SX:
    """``base ** exponent`` (non-integer exponent) whose derivatives are finite where ``base`` is 0.

    The value is casadi's own everywhere (``0 ** p`` is 0, 1 or inf for ``p`` above, at or below 0), but at
    a zero base the branch taken is a constant: ``d/dp 0**p = log(0) * 0`` would be NaN, and a model that
    starts at rest (``|r - eta'|**(2N)`` at ``r = eta' = 0``) would carry that NaN through every exact
    derivative of a simulation (:mod:`obsnl.identification.likelihood`). There the derivative is taken as 0,
    the one-sided limit for exponents above 1 (the hysteretic powers ``|z|**n`` of a yielding spring).
    """
    at_zero = ca.if_else(exponent > 0, 0.0, ca.if_else(exponent == 0, 1.0, ca.inf))
    half = exponent.is_constant() and float(exponent) == 0.5
    value = ca.sqrt(base) if half else ca.power(base, exponent)
    return ca.if_else(base == 0, at_zero, value)


def _constant_values(model: Model, constants: Mapping[str, float] | None) -> dict[sp.Symbol, ca.SX]:
    vals = dict(model.values or {})
    vals.update(constants or {})
    out = {}
    for s in model.known_constants:
        if s.name not in vals:
            raise ModelError(f"known constant {s.name!r} needs a value: pass constants={{{s.name!r}: ...}}")
        out[s] = ca.SX(float(vals[s.name]))
    return out


def to_casadi(
    model: Model, *, switching: Sequence[str] | None = None, constants: Mapping[str, float] | None = None
) -> NumericModel:
    """Compile ``model`` into casadi Functions.

    Parameters
    ----------
    model : Model
        The model (non-smooth functions allowed; unknown inputs are not).
    switching : sequence of str or None
        Switching functions as text, e.g. a branch table's ``switching``; each must be one of the
        model's switching functions (up to sign) and is compiled in the orientation given.
        Default: the model's own (:func:`obsnl.model.branching.branches.switching_functions`).
    constants : mapping of str to float or None
        Values of known constants (default: the model's ``values``).

    Returns
    -------
    NumericModel

    Raises
    ------
    NotSupportedError
        The model has unknown inputs.
    TableError
        A given switching function is not one of the model's.

    Examples
    --------
    >>> from obsnl import Model
    >>> from obsnl.estimation.codegen import to_casadi
    >>> m = Model(name="osc", states=["x", "v"], parameters=["k"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x"}, outputs={"y": "x"})
    >>> float(to_casadi(m).f([1.0, 0.0], [4.0], [0.0])[1])
    -4.0
    """
    if not isinstance(model, Model):  # an AttributeError below otherwise
        raise ModelError(
            f"to_casadi takes an obsnl Model, got {type(model).__name__}; read a file with obsnl.read_model"
        )
    if model.unknown_inputs:
        raise NotSupportedError(
            f"model {model.name!r} has unknown inputs {[s.name for s in model.unknown_inputs]}; "
            f"the filters need them known or modelled as states"
        )
    xs = ca.SX.sym("x", len(model.states))
    ps = ca.SX.sym("p", len(model.parameters))
    us = ca.SX.sym("u", len(model.inputs))
    table = {s: xs[i] for i, s in enumerate(model.states)}
    table.update({s: ps[i] for i, s in enumerate(model.parameters)})
    table.update({s: us[i] for i, s in enumerate(model.inputs)})
    table.update(_constant_values(model, constants))
    conv = _ToCasadi(table)
    own = switching_functions(model)
    if switching is None:
        gs = list(own)
    else:
        gs = []
        for text in switching:
            g = parse_expression(text, model.symbols, where="switching function")
            if not any(sp.expand(g - s) == 0 or sp.expand(g + s) == 0 for s in own):
                raise TableError(
                    f"switching function {text!r} is not one of model {model.name!r}'s {[expr_text(s) for s in own]}"
                )
            gs.append(g)
    fx = ca.vertcat(*[conv(e) for e in model.rhs]) if model.states else ca.SX.zeros(0)
    hx = ca.vertcat(*[conv(e) for e in model.output_exprs]) if model.outputs else ca.SX.zeros(0)
    gx = ca.vertcat(*[conv(e) for e in gs]) if gs else ca.SX.zeros(0)
    args, names = [xs, ps, us], ["x", "p", "u"]
    where = discontinuities(model, gs) if gs else Discontinuities((), (), ())  # one proof pass, one split
    values = {k: float(v) for k, v in (model.values or {}).items()}
    return NumericModel(
        signature=ModelSignature(
            name=model.name,
            fingerprint=model.fingerprint,
            states=tuple(s.name for s in model.states),
            parameters=tuple(s.name for s in model.parameters),
            inputs=tuple(s.name for s in model.inputs),
            outputs=tuple(model.outputs),
            switching=tuple(
                expr_text(g) if isinstance(g, sp.Basic) else str(g) for g in (gs if switching is None else switching)
            ),
        ),
        values=MappingProxyType(values),
        jumps=where.jumps,
        slides=where.slides,
        output_jumps=where.output_jumps,
        source=(model, None if switching is None else tuple(switching), None if constants is None else dict(constants)),
        f=ca.Function("f", args, [fx], names, ["xdot"]),
        h=ca.Function("h", args, [hx], names, ["y"]),
        g=ca.Function("g", args, [gx], names, ["g"]),
        jac_x=ca.Function("jac_x", args, [ca.jacobian(fx, xs)], names, ["J"]),
        jac_u=ca.Function("jac_u", args, [ca.jacobian(fx, us)], names, ["Ju"]),
        jac_g=ca.Function("jac_g", args, [ca.jacobian(gx, xs)], names, ["Jg"]),
    )


# --------------------------------------------------------------------------- parameter coordinates
def parameter_map(
    parameters: Sequence[str],
    forward: Mapping[str, str],
    inverse: Mapping[str, str],
    *,
    check: Mapping[str, float] | None = None,
) -> ParameterMap:
    """Build a :class:`ParameterMap` from expressions.

    Parameters
    ----------
    parameters : sequence of str
        The model's parameter names, in order.
    forward : mapping of str to str
        ``{parameter: expression in the new coordinates}``, one per parameter.
    inverse : mapping of str to str
        ``{coordinate: expression in the parameters}``, in the order of the new coordinates.
    check : mapping of str to float or None
        Parameter values at which ``forward(inverse(theta)) == theta`` is verified.

    Examples
    --------
    >>> pm = parameter_map(["k"], {"k": "exp(lk)"}, {"lk": "log(k)"})
    >>> round(float(pm.to_theta([0.0])[0]), 12)
    1.0
    """
    names = tuple(inverse)
    if set(forward) != set(parameters):
        raise ModelError(f"forward must give every parameter {list(parameters)} exactly once, got {list(forward)}")
    clash = set(names) & set(parameters)
    if clash:
        raise ModelError(f"coordinate names {sorted(clash)} clash with parameter names; rename them")
    new_syms = {n: make_symbol(n) for n in names}
    old_syms = {n: make_symbol(n) for n in parameters}
    phi, theta = ca.SX.sym("phi", len(names)), ca.SX.sym("theta", len(parameters))
    to_new = _ToCasadi({new_syms[n]: phi[i] for i, n in enumerate(names)})
    to_old = _ToCasadi({old_syms[n]: theta[i] for i, n in enumerate(parameters)})
    fwd_exprs = [parse_expression(forward[p], new_syms, where=f"coordinates of {p}") for p in parameters]
    inv_exprs = [parse_expression(inverse[n], old_syms, where=f"definition of {n}") for n in names]
    depends = tuple(tuple(p for p, e in zip(parameters, fwd_exprs) if new_syms[n] in e.free_symbols) for n in names)
    pm = ParameterMap(
        names=names,
        parameters=tuple(parameters),
        forward=ca.Function("forward", [phi], [ca.vertcat(*[to_new(e) for e in fwd_exprs])], ["phi"], ["theta"]),
        inverse=ca.Function("inverse", [theta], [ca.vertcat(*[to_old(e) for e in inv_exprs])], ["theta"], ["phi"]),
        depends=depends,
    )
    if check is not None:
        th = np.array([float(check[p]) for p in parameters])
        back = pm.to_theta(pm.to_phi(th))
        if not np.allclose(back, th, rtol=1e-9, atol=0.0):
            raise ModelError(f"forward(inverse(theta)) != theta at {dict(check)}: {back}")
    return pm


def log_map(
    parameters: Sequence[str], *, signs: Mapping[str, int] | None = None, linear: Sequence[str] = ()
) -> ParameterMap:
    """Log coordinates ``theta = sign * exp(phi)`` (``phi`` named ``log_<p>``); ``linear`` ones kept as is.

    Parameters
    ----------
    parameters : sequence of str
        Parameter names.
    signs : mapping of str to int or None
        Sign of each parameter (default +1).
    linear : sequence of str
        Parameters kept linear (``lin_<p>``).

    Returns
    -------
    ParameterMap
    """
    signs = dict(signs or {})
    fwd, inv = {}, {}
    for p in parameters:
        if p in linear:
            fwd[p], inv[f"lin_{p}"] = f"lin_{p}", p
        elif signs.get(p, 1) < 0:
            fwd[p], inv[f"log_{p}"] = f"-exp(log_{p})", f"log(-{p})"
        else:
            fwd[p], inv[f"log_{p}"] = f"exp(log_{p})", f"log({p})"
    return parameter_map(parameters, fwd, inv)


# --------------------------------------------------------------------------- numpy (baselines, checks)
def numpy_model(model: Model, *, constants: Mapping[str, float] | None = None, scalar: bool = False) -> dict[str, Any]:
    """NumPy callables ``f(x, p, u)``, ``h(x, p, u)``, ``g(x, p, u)`` (switching functions, in the
    order of :func:`to_casadi`) and ``jac_x(x, p, u)`` by sympy ``lambdify``.

    An independent path from symbols to numbers, used by the numpy/filterpy baselines of
    ``benchmarks/bench_ukf.py`` and to check :func:`to_casadi`. Arguments may be arrays with the
    sigma points along the last axis; ``jac_x`` drops the Dirac deltas of ``d sign/dx``.
    ``scalar=True`` gives plain-Python functions of floats (``math``), for per-point loops.

    Parameters
    ----------
    model : Model
        The symbolic model.
    constants : mapping of str to float or None
        Values of known constants, over the model's ``[values]``.
    scalar : bool
        Plain-Python functions instead of NumPy ones.

    Returns
    -------
    dict of str to callable
    """
    vals = dict(model.values or {})
    vals.update(constants or {})
    subs = {s: sp.Float(vals[s.name]) for s in model.known_constants if s.name in vals}
    rhs = [sp.sympify(e).xreplace(subs) for e in model.rhs]
    outs = [sp.sympify(e).xreplace(subs) for e in model.output_exprs]
    gs = [sp.sympify(e).xreplace(subs) for e in switching_functions(model)]
    jac = [[sp.diff(e, s).replace(sp.DiracDelta, lambda *a: sp.S.Zero) for s in model.states] for e in rhs]
    args = [list(model.states), list(model.parameters), list(model.inputs)]
    mods: Any = [{"sign": lambda v: float((v > 0) - (v < 0))}, "math"] if scalar else "numpy"
    lam = lambda exprs: sp.lambdify(args, exprs, modules=mods)  # noqa: E731
    return {"f": lam(rhs), "h": lam(outs), "g": lam(gs), "jac_x": lam(jac)}
