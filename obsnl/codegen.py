"""The only bridge from symbols to numbers: a :class:`~obsnl.Model` becomes casadi Functions.

:func:`to_casadi` turns the sympy vector field, outputs and switching functions of a model into
casadi ``SX`` Functions (``sign``/``Abs``/``Heaviside``/``Piecewise``/``Max``/``Min`` become
``sign``/``fabs``/``if_else``/``fmax``/``fmin``, so every evaluation uses the full non-smooth
model) and builds discrete steps from them. The estimators (:mod:`obsnl.ukf`, :mod:`obsnl.dukf`)
work with the resulting :class:`NumericModel` and never import sympy.

Discrete step (:meth:`NumericModel.step`). The input is interpolated linearly between samples.
``method="auto"`` (default) is classical RK4 with substeps; where one step is stiff for RK4 (the
scaled Jacobian at its end point beyond RK4's stability bound, or a non-finite result) the step is
redone with ROS2, the two-stage L-stable Rosenbrock method of Verwer, Spee, Blom and Hundsdorfer
(SIAM J. Sci. Comput. 20, 1999), order 2 for *any* matrix in place of the Jacobian (a W-method).
For the hysteretic spring a sigma point with a large Delta and a small N has a tiny yield
displacement and an eigenvalue of order ``-2N x2 / r_y``: explicit RK4 overflows there. ROS2 takes
its matrix at the explicit predictor (so a stiffness onset inside the substep is seen) and replaces
non-finite entries (``|0|**(2N-1)`` with ``N < 1/2``) by 0, which the W-method allows. In the
filters the fallback is evaluated only for the sigma points that need it, and counted.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import casadi as ca
import numpy as np
import sympy as sp

from .branches import expr_text, switching_functions
from .errors import ModelError, NotSupportedError, TableError
from .model import Model
from .parse import make_symbol, parse_expression

__all__ = ["NumericModel", "ParameterMap", "to_casadi", "parameter_map", "log_map", "numpy_model", "jit_options"]

_UNARY = {
    sp.exp: ca.exp, sp.log: ca.log, sp.sin: ca.sin, sp.cos: ca.cos, sp.tan: ca.tan, sp.tanh: ca.tanh,
    sp.sinh: ca.sinh, sp.cosh: ca.cosh, sp.atan: ca.atan, sp.sign: ca.sign, sp.Abs: ca.fabs,
}
GAMMA_ROS2 = 1.0 + 1.0 / np.sqrt(2.0)


def jit_options() -> dict[str, Any]:
    """casadi options that compile a Function to C with the system compiler.

    ``-O3 -march=native``: the code is compiled on the machine that runs it; on the UKF step of the
    seed model this is about 1.8x faster than ``-O1`` for the same compile time (no fast-math: the
    NaN/inf guards must keep their meaning).
    """
    return {"jit": True, "compiler": "shell", "jit_options": {"flags": ["-O3", "-march=native"], "verbose": False}}


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
            if p == sp.Rational(1, 2):
                return ca.sqrt(c(b))
            if p.is_Integer:
                return c(b) ** int(p)
            return ca.power(c(b), c(p))
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
        rel = {sp.StrictGreaterThan: ca.gt, sp.StrictLessThan: ca.lt, sp.GreaterThan: ca.ge,
               sp.LessThan: ca.le, sp.Eq: ca.eq, sp.Ne: ca.ne}
        if type(e) in rel:
            return rel[type(e)](c(e.lhs), c(e.rhs))
        if isinstance(e, (sp.And, sp.Or)):
            return self._fold(ca.logic_and if isinstance(e, sp.And) else ca.logic_or, e.args)
        if isinstance(e, sp.Not):
            return ca.logic_not(c(e.args[0]))
        raise NotSupportedError(f"cannot translate {type(e).__name__} ({e}) to casadi")


@dataclass(frozen=True, eq=False)
class NumericModel:
    """A model as casadi Functions of ``(x, p, u)`` (states, parameters, inputs, in model order).

    Attributes
    ----------
    f, h, g
        Vector field ``x' = f(x, p, u)``, outputs ``y = h(x, p, u)`` and switching functions
        ``g(x, p, u)`` (in the order and orientation of ``switching``).
    jac_x, jac_u
        ``df/dx`` and ``df/du`` (derivatives of ``sign`` are 0), for implicit steps.
    fingerprint, name, states, parameters, inputs, outputs, switching, values
        The model's identity (the branch table must carry the same fingerprint), names,
        switching functions as text, and its nominal values.
    """

    name: str
    fingerprint: str
    states: tuple[str, ...]
    parameters: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    switching: tuple[str, ...]
    values: Mapping[str, float]
    f: ca.Function = field(repr=False)
    h: ca.Function = field(repr=False)
    g: ca.Function = field(repr=False)
    jac_x: ca.Function = field(repr=False)
    jac_u: ca.Function = field(repr=False)

    @property
    def nx(self) -> int:
        return len(self.states)

    @property
    def np(self) -> int:
        return len(self.parameters)

    @property
    def nu(self) -> int:
        return len(self.inputs)

    @property
    def ny(self) -> int:
        return len(self.outputs)

    def nominal(self, names: Sequence[str]) -> np.ndarray:
        """The nominal values of ``names`` (from the model file); error naming a missing one."""
        missing = [n for n in names if n not in self.values]
        if missing:
            raise ModelError(f"model {self.name!r} has no value for {missing}; add them to [values]")
        return np.array([float(self.values[n]) for n in names])

    def step(self, dt: float, *, method: str = "auto", substeps: int = 8, scale: Any = None,
             threshold: float = 2.0, jit: bool = False) -> ca.Function:
        """The discrete step ``(x, p, u0, u1) -> (x_next, implicit)`` over ``dt`` (input linear in time).

        Parameters
        ----------
        dt
            Sampling interval.
        method
            ``"auto"`` (default): RK4, redone with ROS2 when the step is stiff for RK4, that is when
            ``h * ||D^-1 J D||_inf`` (``J = df/dx`` at the RK4 end point, ``D = diag(scale)``,
            ``h = dt / substeps``) exceeds ``threshold``, or the RK4 result is not finite (an RK4 step
            that went unstable ends where the model is stiff or overflowed); ROS2 is evaluated only
            then (``implicit`` is 1). ``"rk4"`` or ``"ros2"``: always that one.
        substeps
            Equal substeps per interval.
        scale
            Typical magnitude of each state, for the stiffness estimate (default 1).
        threshold
            Stiffness bound for RK4 (its real stability interval is ``[-2.785, 0]``).
        jit
            Compile the inner functions to C.
        """
        if not (np.isfinite(dt) and dt > 0):
            raise ModelError(f"dt must be a positive number, got {dt!r}")
        if int(substeps) < 1:
            raise ModelError(f"substeps must be at least 1, got {substeps!r}")
        if method not in ("auto", "ros2", "rk4"):
            raise ModelError(f"unknown integration method {method!r}; use 'auto', 'rk4' or 'ros2'")
        n = int(substeps)
        fns = self.integrators(dt, substeps=n, scale=scale, jit=jit)
        x, p = ca.SX.sym("x", self.nx), ca.SX.sym("p", self.np)
        u0, u1 = ca.SX.sym("u0", self.nu), ca.SX.sym("u1", self.nu)
        names_in = ["x", "p", "u0", "u1"]
        if method != "auto":
            flag = 1.0 if method == "ros2" else 0.0
            return ca.Function(f"step_{method}{n}", [x, p, u0, u1], [fns[method](x, p, u0, u1), ca.SX(flag)],
                               names_in, ["x_next", "implicit"])
        X, P = ca.MX.sym("x", self.nx), ca.MX.sym("p", self.np)
        U0, U1 = ca.MX.sym("u0", self.nu), ca.MX.sym("u1", self.nu)
        xr = fns["rk4"](X, P, U0, U1)
        stiff = fns["stiff"](X, xr, P, U0, U1, threshold)
        xn = ca.if_else(stiff, fns["ros2"](X, P, U0, U1), xr, True)
        return ca.Function(f"step_auto{n}", [X, P, U0, U1], [xn, stiff], names_in, ["x_next", "implicit"])

    def integrators(self, dt: float, *, substeps: int, scale: Any = None, jit: bool = False) -> dict[str, ca.Function]:
        """The pieces of :meth:`step`: ``rk4`` and ``ros2`` ``(x, p, u0, u1) -> x_next`` and
        ``stiff(x, x_rk4, p, u0, u1, threshold) -> 0/1`` (the test of ``method="auto"``)."""
        n = int(substeps)
        opts = jit_options() if jit else {}
        x, xr, p = ca.SX.sym("x", self.nx), ca.SX.sym("xr", self.nx), ca.SX.sym("p", self.np)
        u0, u1, thr = ca.SX.sym("u0", self.nu), ca.SX.sym("u1", self.nu), ca.SX.sym("threshold")
        names_in = ["x", "p", "u0", "u1"]
        out = {m: ca.Function(f"{m}{n}", [x, p, u0, u1], [self._integrate(m, x, p, u0, u1, dt, n)], names_in,
                              ["x_next"], opts) for m in ("rk4", "ros2")}
        d = np.ones(self.nx) if scale is None else np.asarray(scale, float)

        ratio = ca.DM(np.outer(1.0 / d, d) if scale is not None else np.ones((self.nx, self.nx)))
        Js = self.jac_x(xr, p, u1) * ratio
        Js = ca.if_else(ca.fabs(Js) < 1e300, ca.fabs(Js), 1e300)
        rho = dt / n * ca.mmax(ca.sum2(Js))
        stiff = ca.logic_or(rho > thr, ca.logic_not(ca.mmax(ca.fabs(xr)) < 1e150))
        out["stiff"] = ca.Function("stiff", [x, xr, p, u0, u1, thr], [stiff], opts)
        return out

    def _integrate(self, method: str, x: ca.SX, p: ca.SX, u0: ca.SX, u1: ca.SX, dt: float, n: int) -> ca.SX:
        h = dt / n
        du = (u1 - u0) / dt
        xi = x
        for i in range(n):
            ua = u0 + du * (i * h)
            ub = u0 + du * ((i + 1) * h)
            if method == "rk4":
                um = 0.5 * (ua + ub)
                k1 = self.f(xi, p, ua)
                k2 = self.f(xi + 0.5 * h * k1, p, um)
                k3 = self.f(xi + 0.5 * h * k2, p, um)
                k4 = self.f(xi + h * k3, p, ub)
                xi = xi + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
            else:
                f0 = self.f(xi, p, ua)
                pred = xi + h * f0  # the Jacobian at the explicit predictor sees a stiffness onset
                pred = ca.if_else(ca.fabs(pred) < 1e150, pred, xi)
                J = self.jac_x(pred, p, ub)
                J = ca.if_else(ca.fabs(J) < 1e300, J, 0.0)  # W-method: any finite matrix will do
                ft = ca.mtimes(self.jac_u(xi, p, ua), du) if self.nu else ca.SX.zeros(self.nx)
                ft = ca.if_else(ca.fabs(ft) < 1e300, ft, 0.0)
                W = ca.SX.eye(self.nx) - GAMMA_ROS2 * h * J
                k1 = ca.solve(W, f0 + GAMMA_ROS2 * h * ft)
                k2 = ca.solve(W, self.f(xi + h * k1, p, ub) - 2.0 * k1 - GAMMA_ROS2 * h * ft)
                xi = xi + h * (1.5 * k1 + 0.5 * k2)
        return xi

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "fingerprint": self.fingerprint, "states": list(self.states),
                "parameters": list(self.parameters), "inputs": list(self.inputs),
                "outputs": list(self.outputs), "switching": list(self.switching)}


def _constant_values(model: Model, constants: Mapping[str, float] | None) -> dict[sp.Symbol, ca.SX]:
    vals = dict(model.values or {})
    vals.update(constants or {})
    out = {}
    for s in model.known_constants:
        if s.name not in vals:
            raise ModelError(f"known constant {s.name!r} needs a value: pass constants={{{s.name!r}: ...}}")
        out[s] = ca.SX(float(vals[s.name]))
    return out


def to_casadi(model: Model, *, switching: Sequence[str] | None = None,
              constants: Mapping[str, float] | None = None) -> NumericModel:
    """Compile ``model`` into casadi Functions.

    Parameters
    ----------
    model
        The model (non-smooth functions allowed; unknown inputs are not).
    switching
        Switching functions as text, e.g. a branch table's ``switching``; each must be one of the
        model's switching functions (up to sign) and is compiled in the orientation given.
        Default: the model's own (:func:`obsnl.branches.switching_functions`).
    constants
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
    >>> from obsnl.codegen import to_casadi
    >>> m = Model(name="osc", states=["x", "v"], parameters=["k"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x"}, outputs={"y": "x"})
    >>> float(to_casadi(m).f([1.0, 0.0], [4.0], [0.0])[1])
    -4.0
    """
    if model.unknown_inputs:
        raise NotSupportedError(f"model {model.name!r} has unknown inputs {[s.name for s in model.unknown_inputs]}; "
                                f"the filters need them known or modelled as states")
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
                raise TableError(f"switching function {text!r} is not one of model {model.name!r}'s "
                                 f"{[expr_text(s) for s in own]}")
            gs.append(g)
    fx = ca.vertcat(*[conv(e) for e in model.rhs]) if model.states else ca.SX.zeros(0)
    hx = ca.vertcat(*[conv(e) for e in model.output_exprs]) if model.outputs else ca.SX.zeros(0)
    gx = ca.vertcat(*[conv(e) for e in gs]) if gs else ca.SX.zeros(0)
    args, names = [xs, ps, us], ["x", "p", "u"]
    values = {k: float(v) for k, v in (model.values or {}).items()}
    return NumericModel(
        name=model.name, fingerprint=model.fingerprint,
        states=tuple(s.name for s in model.states), parameters=tuple(s.name for s in model.parameters),
        inputs=tuple(s.name for s in model.inputs), outputs=tuple(model.outputs),
        switching=tuple(expr_text(g) if isinstance(g, sp.Basic) else str(g) for g in
                        (gs if switching is None else switching)),
        values=MappingProxyType(values),
        f=ca.Function("f", args, [fx], names, ["xdot"]),
        h=ca.Function("h", args, [hx], names, ["y"]),
        g=ca.Function("g", args, [gx], names, ["g"]),
        jac_x=ca.Function("jac_x", args, [ca.jacobian(fx, xs)], names, ["J"]),
        jac_u=ca.Function("jac_u", args, [ca.jacobian(fx, us)], names, ["Ju"]),
    )


# --------------------------------------------------------------------------- parameter coordinates
@dataclass(frozen=True, eq=False)
class ParameterMap:
    """Coordinates in which a filter estimates the parameters: ``theta = forward(phi)``.

    Attributes
    ----------
    names
        Names of the coordinates ``phi``.
    parameters
        Model parameter names (the order of ``theta``).
    forward, inverse
        casadi Functions ``phi -> theta`` and ``theta -> phi``.
    depends
        For each coordinate, the model parameters whose expression involves it (used by the DUKF
        to freeze a coordinate when every parameter it moves is unidentifiable in a branch).
    """

    names: tuple[str, ...]
    parameters: tuple[str, ...]
    forward: ca.Function = field(repr=False)
    inverse: ca.Function = field(repr=False)
    depends: tuple[tuple[str, ...], ...] = ()

    def to_theta(self, phi: Any) -> np.ndarray:
        return np.asarray(self.forward(np.asarray(phi, float))).ravel()

    def to_phi(self, theta: Any) -> np.ndarray:
        return np.asarray(self.inverse(np.asarray(theta, float))).ravel()

    def to_dict(self) -> dict[str, Any]:
        return {"names": list(self.names), "parameters": list(self.parameters),
                "depends": {n: list(d) for n, d in zip(self.names, self.depends)}}


def parameter_map(parameters: Sequence[str], forward: Mapping[str, str], inverse: Mapping[str, str],
                  *, check: Mapping[str, float] | None = None) -> ParameterMap:
    """Build a :class:`ParameterMap` from expressions.

    Parameters
    ----------
    parameters
        The model's parameter names, in order.
    forward
        ``{parameter: expression in the new coordinates}``, one per parameter.
    inverse
        ``{coordinate: expression in the parameters}``, in the order of the new coordinates.
    check
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
        names=names, parameters=tuple(parameters),
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


def log_map(parameters: Sequence[str], *, signs: Mapping[str, int] | None = None,
            linear: Sequence[str] = ()) -> ParameterMap:
    """Log coordinates ``theta = sign * exp(phi)`` (``phi`` named ``log_<p>``); ``linear`` ones kept as is."""
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
    """NumPy callables ``f(x, p, u)``, ``h(x, p, u)``, ``jac_x(x, p, u)`` by sympy ``lambdify``.

    An independent path from symbols to numbers, used by the numpy/filterpy baselines of
    ``benchmarks/bench_ukf.py`` and to check :func:`to_casadi`. Arguments may be arrays with the
    sigma points along the last axis; ``jac_x`` drops the Dirac deltas of ``d sign/dx``.
    ``scalar=True`` gives plain-Python functions of floats (``math``), for per-point loops.
    """
    vals = dict(model.values or {})
    vals.update(constants or {})
    subs = {s: sp.Float(vals[s.name]) for s in model.known_constants if s.name in vals}
    rhs = [sp.sympify(e).xreplace(subs) for e in model.rhs]
    outs = [sp.sympify(e).xreplace(subs) for e in model.output_exprs]
    jac = [[sp.diff(e, s).replace(sp.DiracDelta, lambda *a: sp.S.Zero) for s in model.states] for e in rhs]
    args = [list(model.states), list(model.parameters), list(model.inputs)]
    mods: Any = [{"sign": lambda v: float((v > 0) - (v < 0))}, "math"] if scalar else "numpy"
    lam = lambda exprs: sp.lambdify(args, exprs, modules=mods)  # noqa: E731
    return {"f": lam(rhs), "h": lam(outs), "jac_x": lam(jac)}
