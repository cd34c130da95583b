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
switching function in the substep is located.

Sliding (Filippov 1960; Filippov, *Differential Equations with Discontinuous Righthand Sides*, Kluwer
1988). Where both sides' fields push towards the surface (a mass under dry friction that the spring and
the force cannot move: ``|u - k x| <= F_c`` at ``v = 0``), the solution stays on it with the convex
combination ``alpha f+ + (1 - alpha) f-`` that keeps ``g`` constant, until ``alpha`` reaches 0 or 1
(the mass breaks away, its field continuous there). Past a located crossing whose two sides attract,
the rest of the substep integrates that field by RK4 (each side's field taken a hair to its side along
``grad g``); a substep that starts on such a surface (to a millionth of what the field moves ``g`` in
it) counts as crossing at its start, and the iterations that locate a crossing keep the old branch's
field even at a stage beyond it. Only switching functions whose jump may have a component across the
surface (:func:`obsnl.model.branching.jumps.field_slides`) get this rule; without it the plain stages
chatter across the surface, first-order at best and silently wrong where the chatter stays inside a
substep.
"""

from __future__ import annotations

from typing import Any

import casadi as ca

__all__ = ["located_substep", "heun3", "surface_start"]


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


def surface_start(model: Any, x: Any, p: Any, u: Any, h: float) -> tuple[Any, Any]:
    """Per switching function: whether ``x`` lies on its surface, and where the field's tangent crosses it.

    On the surface: ``|g| <= 1e-6 h |g'|``, a millionth of what the field moves ``g`` in ``h`` (exactly 0
    included), ``g' = grad g . f(x)``. A step that starts so counts as crossing at its start, whichever way
    the field points: pushed towards the surface, the stages of a plain step would chatter across it unseen;
    pushed away (a mass breaking loose), the side it sits on is the sign of a rounding error, which must not
    decide how the step is taken. The tangent's crossing, ``-g / (h g')`` where it lies in ``(0, 1)`` (else 2),
    shows a crossing into a sliding mode that neither end of a plain step may show (its stages past the
    crossing are pushed back).

    Parameters
    ----------
    model : NumericModel
        Its ``f``, ``g`` and ``jac_g``.
    x, p, u : casadi.SX or array_like
        The state, the parameters, the input.
    h : float
        The step's length.

    Returns
    -------
    on, tangent : casadi.SX or casadi.DM
        One 0/1 per switching function; one fraction of ``h`` per switching function (2: none).

    Examples
    --------
    A mass held by dry friction (``v`` at rounding level, the force -0.3 within ``F_c = 0.5``), the same mass
    moving at 1 mm/s, and at 0.1 mm/s (the force, friction and damping, ``v' = -0.3 - 0.5 - 0.2e-4``, stop it
    in ``1e-4 / 0.80002`` s, 0.124997 of ``h``):

    >>> import obsnl
    >>> from obsnl.estimation.codegen import to_casadi
    >>> num = to_casadi(obsnl.read_model("obsnl:coulomb_friction"))
    >>> p = [1.0, 0.2, 40.0, 0.5]
    >>> [[round(float(z), 6) for z in surface_start(num, [0.0, v], p, [-0.3], 1e-3)] for v in (1e-19, 1e-3, 1e-4)]
    [[1.0, 0.0], [0.0, 2.0], [0.0, 0.124997]]
    """
    g = model.g(x, p, u)
    gdot = ca.mtimes(model.jac_g(x, p, u), model.f(x, p, u))
    lin = g + h * gdot
    return (
        ca.fabs(g) <= 1e-6 * h * ca.fabs(gdot),
        ca.if_else(g * lin < 0, g / ca.if_else(g * lin < 0, g - lin, 1.0), 2.0),
    )


def _rk4_with(field: Any, x0: Any, t0: Any, r: Any, first: Any) -> Any:
    """Classical RK4 of ``x' = field(x, t)`` over ``[t0, t0 + r]`` from ``x0``, its first stage given."""
    k2 = field(x0 + 0.5 * r * first, t0 + r / 2)
    k3 = field(x0 + 0.5 * r * k2, t0 + r / 2)
    k4 = field(x0 + r * k3, t0 + r)
    return x0 + r / 6.0 * (first + 2 * k2 + 2 * k3 + k4)


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

    A mass under dry friction (``m v' = u - k x - F_c sign(v)``) reaching ``v = 0`` where the spring cannot
    overcome friction (``|u - k x| = 0.4 < F_c``) sticks there for the rest of the substep:

    >>> fric = to_casadi(obsnl.read_model("obsnl:coulomb_friction"))
    >>> end = located_substep(fric, h)([0.01, 1e-3], [1.0, 0.2, 40.0, 0.5], 0.0, 0.0)
    >>> t_s = 1e-3 / (0.4 + 0.5)                 # v falls at (k x + F_c) / m = 0.9 until it is 0 (c v: 2e-4 of it)
    >>> abs(float(end[1])) < 1e-15, abs(float(end[0]) - (0.01 + 1e-3 * t_s / 2)) < 1e-9
    (True, True)

    References
    ----------
    .. [1] A. F. Filippov, *Differential Equations with Discontinuous Righthand Sides*, Kluwer, Dordrecht,
       1988, doi:10.1007/978-94-015-7793-9 (the sliding field).
    .. [2] I. A. Hiskens and M. A. Pai, Trajectory sensitivity analysis of hybrid systems, IEEE Trans.
       Circuits Syst. I 47(2):204-220, 2000, doi:10.1109/81.828574 (the crossing time's motion in the
       derivative).
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
    may_slide = [j for j in range(len(watch)) if not model.slides or model.slides[watch[j]]]
    ga, gb, ge = model.g(x, p, ua)[watch], model.g(xb, p, ub)[watch], model.g(old(h), p, ub)[watch]
    # the earliest sign change, seen at the RK4 end or at the old branch's extrapolated end (a crossing late in
    # the substep, which the RK4 end may not show), by linear interpolation; piecewise constant in (x, p)
    frac = [
        ca.if_else(
            ga[j] * gb[j] < 0, ga[j] / (ga[j] - gb[j]), ca.if_else(ga[j] * ge[j] < 0, ga[j] / (ga[j] - ge[j]), 2.0)
        )
        for j in range(len(watch))
    ]
    # where the trajectory may slide: a start on the surface (at rest on a friction surface, or where the previous
    # substep's sliding left g at rounding level) is a crossing at the start, so that the sliding rule below
    # decides; and the crossing that the old field's tangent shows counts too (into a sliding mode the stages past
    # the crossing are pushed back, so that neither end may show it), kept only if the iterations find a root
    tangent_only = ca.SX(0.0)
    if may_slide:
        on, tangent = surface_start(model, x, p, ua, h)
        for j in may_slide:
            i = watch[j]
            tangent_only = ca.logic_or(
                tangent_only, ca.logic_and(ca.logic_and(frac[j] >= 2.0, tangent[i] < 2.0), ca.logic_not(on[i]))
            )
            frac[j] = ca.if_else(on[i], 0.0, ca.fmin(frac[j], tangent[i]))
    first = frac[0]
    for fj in frac[1:]:
        first = ca.fmin(first, fj)
    crossed = first < 2.0
    pick = [ca.logic_and(frac[j] == first, crossed) for j in range(len(watch))]

    g_start = sum(pick[j] * ga[j] for j in range(len(watch)))
    dg = model.jac_g

    def normal(xq: Any, uq: Any) -> Any:  # grad g of the chosen switching function
        d = dg(xq, p, uq)
        return sum(pick[j] * d[watch[j], :].T for j in range(len(watch)))

    def chosen(xq: Any, uq: Any) -> Any:
        gs = model.g(xq, p, uq)
        return sum(pick[j] * gs[watch[j]] for j in range(len(watch)))

    if may_slide:
        # the old branch's field even where a stage of an iterate past the crossing lies beyond it (there the
        # new side may push back, and the old branch's extrapolation, whose root the iterations seek, is lost):
        # such a stage is evaluated a hair back on the old side, along grad g
        hair = 1e-9 * (ca.fabs(g_start) + ca.fabs(sum(pick[j] * gb[j] for j in range(len(watch))))) + 1e-300

        def f_old(xq: Any, pq: Any, uq: Any) -> Any:
            gq, n = chosen(xq, uq), normal(xq, uq)
            back = ca.if_else(gq * g_start < 0, (ca.fabs(gq) + hair) * ca.sign(g_start), 0.0)
            return f(xq + back * n / (ca.sumsqr(n) + 1e-300), pq, uq)

        def kept(s: Any) -> Any:  # the old branch, kept on its side
            return heun3(f_old, x, p, ua, ub, s, h)
    else:
        kept = old

    t_prev, g_prev = ca.SX(0.0), g_start
    t_cur = ca.if_else(crossed, first, 0.5) * h
    g_cur = chosen(kept(t_cur), u_at(t_cur))
    for _ in range(int(iterations)):
        den = g_cur - g_prev
        ok = ca.fabs(den) > 1e-300
        t_new = ca.fmin(
            ca.fmax(ca.if_else(ok, t_cur - g_cur * (t_cur - t_prev) / ca.if_else(ok, den, 1.0), t_cur), 0.0), h
        )
        t_prev, g_prev, t_cur = t_cur, g_cur, t_new
        g_cur = chosen(kept(t_cur), u_at(t_cur))
    xs = kept(t_cur)
    crossed = ca.logic_and(
        crossed, ca.logic_or(ca.logic_not(tangent_only), ca.fabs(g_cur) <= 1e-3 * ca.fabs(g_start))
    )  # a root, not a guess
    # the first stage after the crossing: the state pushed across along grad g by a hair (1e-9 of the change
    # of g over the substep, plus what the iteration left), so that it samples the new branch. The new side is
    # the one opposite the start; the plain RK4 end may still lie on the old side (a crossing late in the
    # substep, seen by the extrapolation or the tangent), and where it lies within rounding of the surface its
    # sign must not decide the step. Only from a start on the surface, where the start's side is rounding, is
    # the new side the one the plain end moved to.
    grad = normal(xs, u_at(t_cur))
    g_end = sum(pick[j] * gb[j] for j in range(len(watch)))
    start_on = sum(pick[j] * on[watch[j]] for j in may_slide) if may_slide else ca.SX(0.0)
    towards = ca.if_else(ca.logic_or(start_on > 0, g_start == 0), ca.sign(g_end), -ca.sign(g_start))
    eta = 1e-9 * (ca.fabs(g_start) + ca.fabs(g_end)) + ca.fabs(g_cur) + 1e-300
    across = xs + eta * towards * grad / (ca.sumsqr(grad) + 1e-300)
    xl = rk4(xs, t_cur, h - t_cur, first=f(across, p, u_at(t_cur)))
    if may_slide:
        # Filippov: where both sides push towards the surface, the trajectory stays on it, with the convex
        # combination of the two sides' fields that keeps g = 0, until one side lets go
        def filippov(xq: Any, s: Any) -> tuple[Any, Any]:
            n, gq = normal(xq, u_at(s)), chosen(xq, u_at(s))
            off = (ca.fabs(gq) + eta) * n / (ca.sumsqr(n) + 1e-300)  # a hair to each side
            fp, fm = f(xq + off, p, u_at(s)), f(xq - off, p, u_at(s))
            ap, am = ca.dot(n, fp), ca.dot(n, fm)
            den = am - ap
            side = ca.if_else(gq > 0, 1.0, ca.if_else(gq < 0, 0.0, ap + am > 0))
            alpha = ca.if_else(den > 0, ca.fmin(ca.fmax(am / ca.if_else(den > 0, den, 1.0), 0.0), 1.0), side)
            return alpha * fp + (1 - alpha) * fm, ca.logic_and(ap < 0, am > 0)

        f_s, attracts = filippov(xs, t_cur)
        sticks = ca.logic_and(sum(pick[j] for j in may_slide) > 0, attracts)
        # the entry, completed along the old field to the surface (x + (f_old - f_s) t*, t* = -g / g'): its
        # derivative is the saltation of an entry into sliding (the sensitivity of g removed), also where the
        # substep starts on the surface and the crossing time is no function of the state
        f_in = f_old(xs, p, u_at(t_cur))
        rate = ca.dot(grad, f_in)
        t_in = ca.if_else(ca.fabs(rate) > 1e-300, -chosen(xs, u_at(t_cur)) / ca.if_else(rate == 0, 1.0, rate), 0.0)
        t_in = ca.fmin(ca.fmax(t_in, -1e-6 * h), 1e-6 * h)  # a grazing entry (g' near 0) is not stretched
        x_in = xs + (f_in - f_s) * t_in
        slid = _rk4_with(lambda xq, s: filippov(xq, s)[0], x_in, t_cur, h - t_cur, filippov(x_in, t_cur)[0])
        xl = ca.if_else(sticks, slid, xl)
    return ca.Function("located", [x, p, ua, ub], [ca.if_else(crossed, xl, xb)], ["x", "p", "ua", "ub"], ["x_next"])
