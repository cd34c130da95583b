"""A substep split at the located crossing of a switching surface across which the vector field jumps.

Where the field jumps (Coulomb friction's ``sign(v)``, the healing switch of the seed model), a fixed-step
RK4 substep that straddles the crossing is only first-order accurate, and, worse for an optimizer, its
derivative with respect to the parameters is the derivative along the branches the stages happened to
sample: the crossing time moves with the parameters, and that motion (the saltation term of the
sensitivity, Aizerman and Gantmacher 1958; Hiskens and Pai, IEEE Trans. Circuits Syst. I 47(2):204-220,
2000) is missing. On a friction oscillator it halved ``d v / d F_c`` across a reversal, so the
maximum-likelihood fit ended with an inconsistent gradient ("not converged") on about half the records.

:func:`located_substep` splits the substep at the crossing instead. Up to the crossing it uses Heun's
third-order method, whose stages lie strictly before the end of the interval, so every stage samples
the old branch even when the end sits on the surface; the crossing time solves ``g(x(t)) = 0`` along that
method by secant iterations started at the linear interpolation of ``g`` over the plain RK4 substep; from
the crossing, RK4 with its first stage taken a hair across the surface (along ``grad g``), so that it
samples the new branch. Everything is one casadi expression of ``(x, p, u)``: its derivative, by casadi's
automatic differentiation through the secant iterations, includes the motion of the crossing time (the
derivative of the converged iteration is the implicit one). Only the earliest crossing of a watched
switching function in the substep is located; a sliding mode (the field pushing back on both sides, a
mass that sticks) is not resolved by it and ends where the plain refinement ends.
"""

from __future__ import annotations

from typing import Any

import casadi as ca

__all__ = ["located_substep", "heun3"]


def heun3(f: Any, x: Any, p: Any, ua: Any, ub: Any, s: Any, h: float) -> Any:
    """Heun's third-order step of length ``s`` from ``x`` (input linear from ``ua`` to ``ub`` over ``h``):
    its stages lie at ``0, s/3, 2s/3``, none at the end, so up to a crossing it samples the old branch only, and
    past one it extrapolates the old branch (which is how a crossing late in a substep is seen).

    Parameters
    ----------
    f : casadi.Function
        The vector field ``(x, p, u) -> x'``.
    x, p, ua, ub : casadi.SX
        The start, the parameters, the input at the start and at the end of the substep.
    s : float or casadi.SX
        The length of the step (at most ``h``).
    h : float
        The substep's length, over which the input is linear.

    Returns
    -------
    casadi.SX
    """
    def u_at(t: Any) -> Any:
        return ua + (ub - ua) * (t / h)
    k1 = f(x, p, ua)
    k3 = f(x + 2 * s / 3 * f(x + s / 3 * k1, p, u_at(s / 3)), p, u_at(2 * s / 3))
    return x + s / 4 * (k1 + 3 * k3)


def located_substep(model: Any, h: float, *, iterations: int = 4) -> ca.Function:
    """``(x, p, ua, ub) -> x_next``: one substep of length ``h``, split at a located crossing of a jump.

    Parameters
    ----------
    model : NumericModel
        Its ``f``, ``g``, ``jumps`` (the switching functions across which the field may jump; only
        these are located) and sizes.
    h : float
        The substep's length; the input is linear from ``ua`` to ``ub`` over it.
    iterations : int
        Secant iterations for the crossing time (from the linear interpolation; 4 reach rounding on
        the substeps of obsnl's steps).

    Returns
    -------
    casadi.Function
        A plain RK4 substep where no watched switching function changes sign over it.

    Examples
    --------
    A bang-bang oscillator ``x'' = -sign(x)`` crossing ``x = 0`` at speed 1: the exact end state is a
    parabola to the crossing time ``t* = sqrt(1 - 2 x0) - 1`` and another after it.

    >>> import math
    >>> import obsnl
    >>> from obsnl.estimation.codegen import to_casadi
    >>> bang = to_casadi(obsnl.Model(name="bang", states=["x", "v"], parameters=["a"], inputs=["u"],
    ...                              equations={"x": "v", "v": "-a*sign(x) + u"}, outputs={"y": "x"}))
    >>> x0, h = -0.005, 0.01
    >>> ts = math.sqrt(1 - 2 * x0) - 1            # x0 + t + t^2 / 2 = 0
    >>> vs, r = 1 + ts, h - ts
    >>> exact = [vs * r - r * r / 2, vs - r]
    >>> out = located_substep(bang, h)([x0, 1.0], 1.0, 0.0, 0.0)
    >>> max(abs(float(out[i]) - exact[i]) for i in range(2)) < 1e-12
    True
    >>> plain = bang.step(h, method="rk4", substeps=1)([x0, 1.0], 1.0, 0.0, 0.0)[0]  # RK4 across the jump
    >>> abs(float(plain[1]) - exact[1]) > 1e-4
    True
    """
    x, p = ca.SX.sym("x", model.nx), ca.SX.sym("p", model.np)
    ua, ub = ca.SX.sym("ua", model.nu), ca.SX.sym("ub", model.nu)
    f = model.f

    def u_at(s: Any) -> Any:
        return ua + (ub - ua) * (s / h)

    def rk4(x0: Any, t0: Any, r: Any, first: Any = None) -> Any:
        k1 = f(x0, p, u_at(t0)) if first is None else first
        k2 = f(x0 + 0.5 * r * k1, p, u_at(t0 + r / 2))
        k3 = f(x0 + 0.5 * r * k2, p, u_at(t0 + r / 2))
        k4 = f(x0 + r * k3, p, u_at(t0 + r))
        return x0 + r / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)

    def old(s: Any) -> Any:
        return heun3(f, x, p, ua, ub, s, h)

    xb = rk4(x, 0.0, h)
    watch = [i for i in range(len(model.switching)) if not model.jumps or model.jumps[i]]
    if not watch:
        return ca.Function("located", [x, p, ua, ub], [xb], ["x", "p", "ua", "ub"], ["x_next"])
    ga, gb, ge = model.g(x, p, ua)[watch], model.g(xb, p, ub)[watch], model.g(old(h), p, ub)[watch]
    # the earliest sign change, seen at the RK4 end or at the old branch's extrapolated end (a crossing late in
    # the substep, which the RK4 end may not show), by linear interpolation; piecewise constant in (x, p)
    frac = [ca.if_else(ga[j] * gb[j] < 0, ga[j] / (ga[j] - gb[j]),
                       ca.if_else(ga[j] * ge[j] < 0, ga[j] / (ga[j] - ge[j]), 2.0)) for j in range(len(watch))]
    first = frac[0]
    for fj in frac[1:]:
        first = ca.fmin(first, fj)
    crossed = first < 2.0
    pick = [ca.logic_and(frac[j] == first, crossed) for j in range(len(watch))]

    def gamma(xx: Any, s: Any) -> Any:  # the chosen switching function
        gs = model.g(xx, p, u_at(s))
        return sum(pick[j] * gs[watch[j]] for j in range(len(watch)))

    g_start = sum(pick[j] * ga[j] for j in range(len(watch)))
    t_prev, g_prev = ca.SX(0.0), g_start
    t_cur = ca.if_else(crossed, first, 0.5) * h
    g_cur = gamma(old(t_cur), t_cur)
    for _ in range(int(iterations)):
        den = g_cur - g_prev
        ok = ca.fabs(den) > 1e-300
        t_new = ca.fmin(ca.fmax(ca.if_else(ok, t_cur - g_cur * (t_cur - t_prev) / ca.if_else(ok, den, 1.0), t_cur),
                                0.0), h)
        t_prev, g_prev, t_cur = t_cur, g_cur, t_new
        g_cur = gamma(old(t_cur), t_cur)
    xs = old(t_cur)
    # the first stage after the crossing: the state pushed across along grad g by a hair (1e-9 of the change
    # of g over the substep, plus what the iteration left), so that it samples the new branch
    xx, pp, uu = ca.SX.sym("xx", model.nx), ca.SX.sym("pp", model.np), ca.SX.sym("uu", model.nu)
    dg = ca.Function("dg", [xx, pp, uu], [ca.jacobian(model.g(xx, pp, uu), xx)])(xs, p, u_at(t_cur))
    grad = sum(pick[j] * dg[watch[j], :].T for j in range(len(watch)))
    g_end = sum(pick[j] * gb[j] for j in range(len(watch)))
    eta = 1e-9 * (ca.fabs(g_start) + ca.fabs(g_end)) + ca.fabs(g_cur) + 1e-300
    across = xs + eta * ca.sign(g_end) * grad / (ca.sumsqr(grad) + 1e-300)
    xl = rk4(xs, t_cur, h - t_cur, first=f(across, p, u_at(t_cur)))
    return ca.Function("located", [x, p, ua, ub], [ca.if_else(crossed, xl, xb)], ["x", "p", "ua", "ub"], ["x_next"])
