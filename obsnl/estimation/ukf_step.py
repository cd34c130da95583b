"""The symbolic UKF/DUKF step: one casadi Function per filter configuration (used by :mod:`obsnl.estimation.ukf`).

Sigma points (the scaled unscented transform: Julier, Proc. American Control Conference 2002,
doi:10.1109/ACC.2002.1025369) from a Cholesky factor over the *active* coordinates, every sigma point through
the full non-smooth discrete model (``Function.map``; RK4,
with the implicit ROS2 fallback only for the sigma points where RK4 is unstable, see
:mod:`obsnl.estimation.codegen`; the two sigma points of a frozen coordinate are the mean point bit
for bit and get its propagation without computing it again), unscented mean and covariance, the DUKF's frozen-active covariance rule
(:mod:`obsnl.estimation.dukf`), sigma points redrawn from the predicted mean and covariance for the update (so
that ``Q`` reaches ``P_yy``; on a linear model the filter is then exactly the Kalman filter), a gain
with the Joseph-like covariance ``P+ = P- - K P_zy^T - P_zy K^T + K P_yy K^T`` (PSD for *any* gain),
symmetrisation.

Missing output samples: a channel whose ``y`` is NaN is not measured at that sample; the update uses the
channels present (a missing channel's row and column of ``P_yy`` decoupled, its column of ``P_zy`` and its
innovation set to 0, so its gain column is 0 and the others are the gain of the present channels alone); with
none present the step keeps the prediction. The NaN is only selected away, never computed with; the reported
innovation is NaN there.

Interventions, in this order, each counted per step (``INTERVENTIONS``); none is silent:

``pivot``
    A Cholesky pivot below ``1e-12`` times its diagonal entry is raised to that floor.
``sigma``
    A sigma point whose propagated state is not finite or beyond ``1e6`` typical magnitudes
    (``state_scale``) is replaced by the propagated mean point.
``gated``
    Innovation gate (Huber-type, algorithms.md §5.2 trick 7): with the Mahalanobis distance
    ``d = sqrt(nu^T P_yy^-1 nu)`` beyond ``gate``, the gain is scaled by ``gate / d``, so that one
    measurement moves the mean by at most what a ``gate``-sigma innovation would (Huber's psi on the
    normalised innovation). The covariance follows from the Joseph-like form with the scaled gain,
    so it stays PSD and is larger than the optimal one. ``gate = inf`` switches it off.
``rejected``
    Guard (trick 2): an update whose mean or covariance is not finite, or whose covariance is
    clearly indefinite (a Cholesky pivot of its active block below ``-1e-9`` times its diagonal
    entry: more than round-off), is rejected; the step keeps the prediction ``(m, P-)``.
``held``
    When the prediction itself is not finite, the step keeps the previous estimate with ``P + Q``.
    The previous estimate is finite (by induction from a checked initial estimate), so no step can
    produce NaN or inf.
``clamped``
    A mean component outside the valid region ``[lo, hi]`` is put back on its edge.
``capped``
    Covariance ceiling: a standard deviation beyond ``cap`` (per filter coordinate) is scaled down
    by the congruence ``P <- D P D``, ``D = diag(min(1, cap_i / sqrt(P_ii)))``, which keeps ``P``
    PSD and its correlations. ``cap = inf`` switches it off.
"""

from __future__ import annotations

import casadi as ca

from obsnl.errors import EstimatorError
from obsnl.estimation.numeric import NumericModel, ParameterMap

__all__ = ["INTERVENTIONS", "REPAIRS", "build_step"]

#: Kinds of intervention counted per step, in the order of the step's ``interventions`` output.
INTERVENTIONS = ("pivot", "sigma", "gated", "rejected", "held", "clamped", "capped")
#: The interventions that repair a broken state (all but the innovation gate, which is part of the update rule).
REPAIRS = tuple(k for k in INTERVENTIONS if k != "gated")

_PIVOT_FLOOR = 1e-12
_INDEFINITE = -1e-9
_BIG = 1e6  # scaled states: a million times their typical magnitude
_FINITE = 1e300


def _chol(A: ca.SX, n: int, *, floor: float) -> tuple[ca.SX, ca.SX]:
    """Lower Cholesky factor of ``A``; pivots below ``floor * A_jj`` are raised to it (and counted)."""
    L = ca.SX.zeros(n, n)
    low = ca.SX(0)
    for j in range(n):
        s = A[j, j] - sum((L[j, k] ** 2 for k in range(j)), ca.SX(0))
        lim = floor * ca.fmax(ca.fabs(A[j, j]), 1e-300)
        bad = ca.logic_not(s >= lim)  # NaN counts as bad
        low += bad
        d = ca.sqrt(ca.if_else(bad, ca.fmax(lim, 1e-300), s))
        L[j, j] = d
        for i in range(j + 1, n):
            L[i, j] = (A[i, j] - sum((L[i, k] * L[j, k] for k in range(j)), ca.SX(0))) / d
    return L, low


def _finite(x: ca.SX) -> ca.SX:
    """1 when every entry is finite: their sum is (a NaN or inf entry makes it NaN or inf; comparisons
    with NaN are false; no fast-math in the JIT). Entries so large that the sum passes 1e300 count
    as not finite too, which only rejects an update that is absurd anyway."""
    return ca.fabs(ca.sum1(ca.vec(x))) < _FINITE


def _sym_outer(D: ca.SX, w: ca.SX, n: int) -> ca.SX:
    """``D diag(w) D^T`` computing only the lower triangle (symmetric result)."""
    low = ca.mac(D * ca.repmat(w.T, n, 1), D.T, ca.SX.zeros(ca.Sparsity.lower(n)))
    return low + ca.tril(low, False).T


def _lower_solve(L: ca.SX, B: ca.SX, n: int) -> ca.SX:
    """``L^{-1} B`` by forward substitution (``L`` lower triangular)."""
    X = ca.SX.zeros(B.shape)
    for i in range(n):
        X[i, :] = (B[i, :] - ca.mtimes(L[i, :i], X[:i, :])) / L[i, i] if i else B[i, :] / L[i, i]
    return X


def _sigma_block(
    model: NumericModel, coords: ParameterMap, fns: dict[str, ca.Function], method: str
) -> tuple[ca.Function, ca.Function]:
    """``(z, P, active, hyp) -> (X, S, pivots)`` (sigma points) and ``(zc, u0, u1, scale) -> (zc+, stiff,
    crossed)`` (RK4 propagation of one sigma point, with the tests of the fallbacks: stiff for RK4,
    a switching function crossed inside the step).

    The propagation stays one Function mapped over the sigma points (one copy of its code called in
    a loop, not 2L+1 inlined copies: the compiled step is several times smaller and faster)."""
    nx, L, nu_ = model.nx, model.nx + len(coords.names), model.nu
    z, P, a, hyp = ca.SX.sym("z", L), ca.SX.sym("P", L, L), ca.SX.sym("active", L), ca.SX.sym("hyp", 4)
    A, U = ca.diag(a), ca.diag(1 - a)
    nA = ca.sum1(a)
    lam = hyp[0] ** 2 * (nA + hyp[2]) - nA
    S, pivots = _chol(ca.mtimes([A, P, A]) + U, L, floor=_PIVOT_FLOOR)
    Sm = ca.sqrt(nA + lam) * ca.mtimes(A, S)
    X = ca.horzcat(z, ca.repmat(z, 1, L) + Sm, ca.repmat(z, 1, L) - Sm)
    sig = ca.Function("sigma_points", [z, P, a, hyp], [X, S, pivots])
    zc, u0, u1, sc = ca.SX.sym("zc", L), ca.SX.sym("u0", nu_), ca.SX.sym("u1", nu_), ca.SX.sym("scale", nx)
    xc, th = zc[:nx] * sc, coords.forward(zc[nx:])
    if method == "auto":
        xr, stiff, crossed = fns["probe"](xc, th, u0, u1, 2.0, sc)
    else:
        xr, stiff, crossed = fns[method](xc, th, u0, u1), ca.SX(0), ca.SX(0)
    prop = ca.Function("prop", [zc, u0, u1, sc], [ca.vertcat(xr / sc, zc[nx:]), stiff, crossed])
    return sig, prop


def _point_block(
    model: NumericModel, coords: ParameterMap, fns: dict[str, ca.Function], prop: ca.Function
) -> tuple[ca.Function, ca.Function]:
    """``(zc, u0, u1, scale) -> (zc+, stiff, crossed)``: one sigma point through ``prop`` (RK4 and the probe),
    then ROS2 (``refine * substeps``) where RK4 was stiff, or RK4 with the crossing substep refined
    where a watched switching function changed sign; each fallback is evaluated only where needed.
    And the same with ``(skip, xp0, stiff0, crossed0)`` appended: ``skip = 1`` means the point is the
    mean point (its coordinate is frozen, so the sigma point equals the mean bit for bit), whose
    result ``(xp0, stiff0, crossed0)`` is copied instead of computed again."""
    nx, L, nu_ = model.nx, model.nx + len(coords.names), model.nu
    zM, u0M, u1M, sc = ca.MX.sym("zc", L), ca.MX.sym("u0", nu_), ca.MX.sym("u1", nu_), ca.MX.sym("scale", nx)
    xr, sM, cM = prop(zM, u0M, u1M, sc)
    fine = ca.vertcat(fns["fine"](zM[:nx] * sc, coords.forward(zM[nx:]), u0M, u1M, sM) / sc, zM[nx:])
    point = ca.Function("point", [zM, u0M, u1M, sc], [ca.if_else(ca.logic_or(sM, cM), fine, xr, True), sM, cM])
    skip, x0M, s0M, c0M = ca.MX.sym("skip"), ca.MX.sym("xp0", L), ca.MX.sym("stiff0"), ca.MX.sym("crossed0")
    done = ca.vertcat(x0M, s0M, c0M)
    out = ca.if_else(skip, done, ca.vertcat(*point(zM, u0M, u1M, sc)), True)
    return point, ca.Function("sigma_point", [zM, u0M, u1M, sc, skip, x0M, s0M, c0M], [out[:L], out[L], out[L + 1]])


def _update_block(model: NumericModel, coords: ParameterMap, cross: str) -> ca.Function:
    """Unscented mean and covariance of the propagated sigma points, update, guard, valid region, ceiling."""
    nx, L, ny, nu_ = model.nx, model.nx + len(coords.names), model.ny, model.nu
    npts = 2 * L + 1
    sc = ca.SX.sym("scale", nx)
    z, P, a, hyp = ca.SX.sym("z", L), ca.SX.sym("P", L, L), ca.SX.sym("active", L), ca.SX.sym("hyp", 4)
    Xp, y, Q, R = ca.SX.sym("Xp", L, npts), ca.SX.sym("y", ny), ca.SX.sym("Q", L, L), ca.SX.sym("R", ny, ny)
    S_, u1 = ca.SX.sym("S", L, L), ca.SX.sym("u1", nu_)
    lo, hi, cap = ca.SX.sym("lo", L), ca.SX.sym("hi", L), ca.SX.sym("cap", L)
    alpha, beta, kappa, gate = hyp[0], hyp[1], hyp[2], hyp[3]
    A, U = ca.diag(a), ca.diag(1 - a)
    nA = ca.sum1(a)
    lam = alpha**2 * (nA + kappa) - nA
    gam = ca.sqrt(nA + lam)

    good = ca.SX.ones(1, npts - 1)
    for i in range(nx):
        good = ca.logic_and(good, ca.fabs(Xp[i, 1:]) < _BIG)
    n_sigma = ca.sum2(1 - good)
    Xp_ = ca.horzcat(Xp[:, 0], ca.if_else(ca.repmat(good, L, 1), Xp[:, 1:], ca.repmat(Xp[:, 0], 1, npts - 1)))
    w = a / (2 * (nA + lam))
    Wm = ca.vertcat(lam / (nA + lam), w, w)
    Wc = ca.vertcat(lam / (nA + lam) + 1 - alpha**2 + beta, w, w)
    m = ca.mtimes(A, ca.mtimes(Xp_, Wm)) + ca.mtimes(U, z)  # frozen means kept exactly
    Psig = _sym_outer(Xp_ - ca.repmat(m, 1, npts), Wc, L)
    if cross == "regression":  # frozen block regressed on the prior active block (dukf.py)
        G = _lower_solve(S_, ca.mtimes(P, U), L)  # S^-1 P_{.,U}
        PAU = ca.mtimes([A, gam * (Xp_[:, 1 : L + 1] - Xp_[:, L + 1 :]), ca.diag(w), G])
    else:
        PAU = ca.SX.zeros(L, L)
    Pp = ca.mtimes([A, Psig + Q, A]) + ca.mtimes([U, P, U]) + PAU + PAU.T

    # update: sigma points redrawn from the predicted mean and covariance (so that Q reaches P_yy)
    S2, n_pivot = _chol(ca.mtimes([A, Pp, A]) + U, L, floor=_PIVOT_FLOOR)
    S2m = gam * ca.mtimes(A, S2)
    X2 = ca.horzcat(m, ca.repmat(m, 1, L) + S2m, ca.repmat(m, 1, L) - S2m)
    zx = ca.SX.sym("zx", L)
    hf = ca.Function("hz", [zx, u1, sc], [model.h(zx[:nx] * sc, coords.forward(zx[nx:]), u1)])
    Y = hf.map(npts)(X2, u1, sc)
    yhat = ca.mtimes(Y, Wm)
    dY = Y - ca.repmat(yhat, 1, npts)
    Pyy = ca.mtimes([dY, ca.diag(Wc), dY.T]) + R
    Pzy = ca.mtimes([X2 - ca.repmat(m, 1, npts), ca.diag(Wc), dY.T])
    if cross == "regression":  # P_Uy = P_UA- (P_AA-)^-1 P_A-y through the same sigma points
        G2 = _lower_solve(S2, ca.mtimes(Pp, U), L)
        Pzy_full = Pzy + ca.mtimes([U, gam * G2.T, ca.diag(w), (Y[:, 1 : L + 1] - Y[:, L + 1 :]).T])
    else:
        Pzy_full = Pzy
    # a missing output sample (y NaN) is no measurement: the update uses the channels present. Their innovation,
    # covariance and cross-covariance are kept, a missing channel's decoupled (P_yy's row and column replaced by
    # the identity's, P_zy's column and the innovation by 0): its gain column is then 0 and the rest is the gain of
    # the present channels alone. The NaN is only ever selected away (if_else), never multiplied by 0.
    nu_raw = y - yhat  # the innovation reported: NaN where the sample is missing
    present = ca.fabs(y) < _FINITE
    nu = ca.if_else(present, nu_raw, 0.0)
    Pyy_u = ca.if_else(ca.mtimes(present, present.T), Pyy, ca.SX.eye(ny))
    Pzy_u = ca.if_else(ca.repmat(present.T, L, 1), Pzy, 0.0)
    Pzy_full = ca.if_else(ca.repmat(present.T, L, 1), Pzy_full, 0.0)
    if ny > 1:
        K = ca.mtimes(A, ca.solve(Pyy_u, Pzy_u.T).T)
        d = ca.sqrt(ca.dot(nu, ca.solve(Pyy_u, nu)))
    else:
        K = ca.mtimes(A, Pzy_u / Pyy_u)
        d = ca.fabs(nu) / ca.sqrt(Pyy_u)
    weight = ca.if_else(d > gate, gate / d, 1.0)  # Huber: the step of a gate-sigma innovation at most
    gated = d > gate
    K = weight * K
    zn = m + ca.mtimes(K, nu)
    Pn = Pp - ca.mtimes(K, Pzy_full.T) - ca.mtimes(Pzy_full, K.T) + ca.mtimes([K, Pyy_u, K.T])

    # guard: a non-finite or indefinite update keeps the prediction; a non-finite prediction the previous estimate
    _, n_indef = _chol(ca.mtimes([A, Pn, A]) + U, L, floor=_INDEFINITE)
    ok_update = ca.logic_and(ca.logic_and(_finite(zn), _finite(Pn)), n_indef == 0)
    ok_pred = ca.logic_and(_finite(m), _finite(Pp))
    z_pick = ca.if_else(ok_update, zn, ca.if_else(ok_pred, m, z))
    P_pick = ca.if_else(ok_update, Pn, ca.if_else(ok_pred, Pp, P + ca.mtimes([A, Q, A])))
    rejected = ca.logic_and(ca.logic_not(ok_update), ok_pred)
    held = ca.logic_and(ca.logic_not(ok_update), ca.logic_not(ok_pred))

    clamped = ca.fmin(ca.fmax(z_pick, lo), hi)  # the valid region: a mean outside it is put back on its edge
    n_clamped = ca.sum1(clamped != z_pick)
    P_pick = 0.5 * (P_pick + P_pick.T)
    ratio = cap / ca.sqrt(ca.fmax(ca.diag(P_pick), 1e-300))
    shrink = ca.if_else(ratio < 1, ratio, 1.0)
    n_capped = ca.sum1(ratio < 1)
    P_out = P_pick * ca.mtimes(shrink, shrink.T)
    counts = ca.vertcat(n_sigma, gated, rejected, held, n_clamped, n_capped)
    return ca.Function(
        "update",
        [z, P, a, hyp, S_, Xp, u1, y, Q, R, lo, hi, cap, sc],
        [clamped, P_out, yhat, nu_raw, Pyy, n_pivot, counts],
    )


def build_step(
    model: NumericModel,
    coords: ParameterMap,
    dt: float,
    *,
    method: str,
    substeps: int,
    cross: str = "regression",
    refine: int = 8,
    skip_frozen: bool = True,
    locate: bool = False,
) -> ca.Function:
    """The filter step ``(z, P, u0, u1, y, active, Q, R, hyp, lo, hi, cap, scale)
    -> (z+, P+, y_pred, nu, S, interventions, implicit, refined)``.

    ``hyp = [alpha, beta, kappa, gate]``; ``active`` is 1 for estimated coordinates, 0 for frozen
    ones; ``lo, hi`` the valid region and ``cap`` the standard-deviation ceiling (filter coordinates);
    ``scale`` the typical magnitude of each model state (the filter's states are ``x / scale``). Every
    quantity that depends on a record (the scale is measured on one) is an input, so that the code, and
    the key of its compiled library (:mod:`obsnl.estimation.jitcache`), depend on the model and the
    filter's structure only: records of other lengths reuse the library;
    ``cross`` is the DUKF rule for the frozen-active covariance (``"regression"`` or ``"zero"``);
    ``interventions`` counts each kind of ``INTERVENTIONS`` (module docstring); ``implicit`` counts
    the sigma points that needed the implicit fallback of the discrete step, ``refined`` those whose
    crossing substep was redone with ``refine`` finer ones because a switching function across which
    the field can jump changed sign inside the step (:mod:`obsnl.estimation.numeric`). Three SX blocks (sigma points, propagation mapped over the sigma points,
    update) joined in an MX Function, so that the fallbacks are only evaluated where needed.

    Parameters
    ----------
    model : NumericModel
        The compiled model.
    coords : ParameterMap
        Filter coordinates of the parameters.
    dt : float
        Sample step (s).
    method : str
        The discrete step: ``"rk4"``, ``"ros2"`` or ``"auto"`` (probe, then the fallback).
    substeps : int
        Integrator substeps per sample.
    cross : str
        The DUKF cross-covariance rule.
    refine : int
        Finer substeps of a crossing substep.
    locate : bool
        Split it at the located crossing and follow a sliding mode (:meth:`NumericModel.step`'s ``locate``).
    skip_frozen : bool
        The two sigma points of a frozen coordinate are the mean point (bit for bit: their column
        of the Cholesky factor is zeroed by the mask); True copies the mean point's propagation to
        them, False propagates them too (the same numbers, for checking).

    Returns
    -------
    casadi.Function

    Raises
    ------
    EstimatorError
        For an unknown ``cross``.
    """
    if cross not in ("regression", "zero"):
        raise EstimatorError(f"unknown cross-covariance rule {cross!r}; use 'regression' or 'zero'")
    nx, nq, ny, nu_ = model.nx, len(coords.names), model.ny, model.nu
    L = nx + nq
    fns = model.integrators(dt, substeps=substeps, refine=refine, locate=locate)
    sig, prop = _sigma_block(model, coords, fns, method)
    point, or_copy = _point_block(model, coords, fns, prop)
    upd = _update_block(model, coords, cross)

    z, P, a, hyp = ca.MX.sym("z", L), ca.MX.sym("P", L, L), ca.MX.sym("active", L), ca.MX.sym("hyp", 4)
    u0, u1, y = ca.MX.sym("u0", nu_), ca.MX.sym("u1", nu_), ca.MX.sym("y", ny)
    Q, R = ca.MX.sym("Q", L, L), ca.MX.sym("R", ny, ny)
    lo, hi, cap, sc = ca.MX.sym("lo", L), ca.MX.sym("hi", L), ca.MX.sym("cap", L), ca.MX.sym("scale", nx)
    X, S, n_pivot = sig(z, P, a, hyp)
    x0, s0, c0 = point(X[:, 0], u0, u1, sc)  # the mean point
    # the pair of sigma points of a frozen coordinate is the mean point: copied, not propagated again
    skip = ca.repmat((1 - a).T, 1, 2) if skip_frozen else ca.MX.zeros(1, 2 * L)
    Xr, sr, cr = or_copy.map(2 * L)(X[:, 1:], u0, u1, sc, skip, x0, s0, c0)
    Xp, stiff, crossed = ca.horzcat(x0, Xr), ca.horzcat(s0, sr), ca.horzcat(c0, cr)
    n_implicit, n_refined = ca.sum2(stiff), ca.sum2(crossed)
    zn, Pn, yp, nu, Syy, n_pivot2, counts = upd(z, P, a, hyp, S, Xp, u1, y, Q, R, lo, hi, cap, sc)
    interventions = ca.vertcat(n_pivot + n_pivot2, counts)
    return ca.Function(
        "ukf_step",
        [z, P, u0, u1, y, a, Q, R, hyp, lo, hi, cap, sc],
        [zn, Pn, yp, nu, Syy, interventions, n_implicit, n_refined],
        ["z", "P", "u0", "u1", "y", "active", "Q", "R", "hyp", "lo", "hi", "cap", "scale"],
        ["z_next", "P_next", "y_pred", "innovation", "S", "interventions", "implicit", "refined"],
    )
