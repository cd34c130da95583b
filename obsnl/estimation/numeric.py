"""The numeric model: casadi Functions of a model and its discrete steps (no sympy here).

:class:`NumericModel` holds the vector field, outputs and switching functions of a model as casadi
``SX`` Functions (built by :func:`obsnl.estimation.codegen.to_casadi`, the only sympy -> casadi bridge) and
makes discrete steps from them. :class:`ParameterMap` holds the coordinates in which a filter
estimates the parameters (built by :func:`obsnl.estimation.codegen.parameter_map`).

Discrete step (:meth:`NumericModel.step`). The input is interpolated linearly between samples.
``method="auto"`` (default) is classical RK4 with substeps; where one step is stiff for RK4 (the
scaled Jacobian at its end point beyond RK4's stability bound, or a non-finite result) the step is
redone with ROS2, the two-stage L-stable Rosenbrock method of Verwer, Spee, Blom and Hundsdorfer
(SIAM J. Sci. Comput. 20, 1999), order 2 for *any* matrix in place of the Jacobian (a W-method).
For the hysteretic spring a sigma point with a large Delta and a small N has a tiny yield
displacement and an eigenvalue of order ``-2N x2 / r_y``: explicit RK4 overflows there. ROS2 takes
its matrix at the explicit predictor (so a stiffness onset inside the substep is seen) and replaces
non-finite entries (``|0|**(2N-1)`` with ``N < 1/2``) by 0, which the W-method allows.

Switching inside a step. Where a switching function changes sign between two substeps, the vector field
may jump (the seed model's healing term, when ``r - eta'`` crosses 0 while moving) and RK4 drops to order 1
across the jump: on the seed experiment these crossings make almost all of the discretisation error (8 plain
substeps: 2.5e-4 of the output RMS, a quarter of the 0.1 % noise level, enough to bias the identified Deltas
by a few percent). ``method="auto"`` therefore redoes the substep in which such a crossing happens with
``refine`` substeps, watching only the switching functions across which the field is not proved continuous
(:func:`obsnl.model.branching.jumps.field_jumps`: ``r - eta'``, not ``x2``, for the seed model). 4 substeps
with the crossing one refined 8x stay within 6e-5 of the output RMS, as fine as 32 plain substeps.
A step that is stiff uses ROS2 with ``refine * substeps``; in the filters both fallbacks run only for
the sigma points that need them, and are counted.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np
from numpy import ndarray  # the class's own ``np`` (its number of parameters) hides the module inside it

from obsnl.errors import ModelError
from obsnl.estimation.crossing import heun3, located_substep, surface_start
from obsnl.estimation.jitcache import jit_compile
from obsnl.model.branching.signature import ModelSignature

if TYPE_CHECKING:  # the symbolic model is named, not imported: sympy stays out of the estimators
    from obsnl.model.core import Model

__all__ = ["NumericModel", "ParameterMap", "GAMMA_ROS2"]

GAMMA_ROS2 = 1.0 + 1.0 / np.sqrt(2.0)


@dataclass(frozen=True, eq=False)
class NumericModel:
    """A model as casadi Functions of ``(x, p, u)`` (states, parameters, inputs, in model order).

    Attributes
    ----------
    f, h, g
        Vector field ``x' = f(x, p, u)``, outputs ``y = h(x, p, u)`` and switching functions
        ``g(x, p, u)`` (in the order and orientation of ``switching``).
    jac_x, jac_u, jac_g
        ``df/dx``, ``df/du`` (derivatives of ``sign`` are 0), for implicit steps; ``dg/dx``, for crossings.
    signature
        The model's identity (:class:`~obsnl.model.branching.signature.ModelSignature`: name, fingerprint,
        names in order, switching functions as text); the branch table must carry the same.
        ``name``, ``fingerprint``, ``states``, ... read it.
    values
        The model's nominal values.
    jumps
        For each switching function, whether the vector field may jump where it crosses 0
        (:func:`obsnl.model.branching.jumps.field_jumps`; empty: all may). Only these crossings are refined.
    slides
        For each switching function, whether a trajectory may slide along it, which the located substep then
        follows (:func:`obsnl.model.branching.jumps.field_slides`; empty: every jump may).
    output_jumps
        For each output, whether it may jump where the field does (:func:`obsnl.model.branching.jumps.output_jumps`;
        empty: none is known to).
    source
        ``(model, switching, constants)`` (a :class:`~obsnl.model.core.Model`, the switching functions as text or
        None, the known constants' numbers or None) as given to :func:`obsnl.estimation.codegen.to_casadi` (None when built
        otherwise): the specification a worker compiles again (:mod:`obsnl.identification.replicates`).
    points
        0: the input of a step is the pair of samples ``(u0, u1)``, linear in between (the classic form). ``m > 0``:
        the model is driven by input *blocks* (:meth:`driven`): the input of sample ``k`` is the row
        ``[u(t_k), u(t_k + dt/m), ..., u(t_k + (m-1) dt/m), u(t_{k+1}^-)]`` of ``nu_inputs * (m + 1)`` values
        (:mod:`obsnl.estimation.intersample` makes it from a record), linear between those points; ``f``, ``h``,
        ``g`` and their Jacobians then take a block and read ``u(t_k)``, its first ``nu_inputs`` entries.
    base
        The classic model a driven one was made from (None for a classic model).
    """

    signature: ModelSignature
    values: Mapping[str, float]
    f: ca.Function = field(repr=False)
    h: ca.Function = field(repr=False)
    g: ca.Function = field(repr=False)
    jac_x: ca.Function = field(repr=False)
    jac_u: ca.Function = field(repr=False)
    jac_g: ca.Function = field(repr=False)
    jumps: tuple[bool, ...] = ()
    slides: tuple[bool, ...] = ()
    output_jumps: tuple[bool, ...] = ()
    source: tuple[Model, tuple[str, ...] | None, Mapping[str, float] | None] | None = field(
        default=None, repr=False, compare=False
    )
    points: int = 0
    base: NumericModel | None = field(default=None, repr=False, compare=False)
    _steps: dict = field(default_factory=dict, init=False, repr=False, compare=False)  # built steps, by options

    @property
    def name(self) -> str:
        return self.signature.name

    @property
    def fingerprint(self) -> str:
        return self.signature.fingerprint

    @property
    def states(self) -> tuple[str, ...]:
        return self.signature.states

    @property
    def parameters(self) -> tuple[str, ...]:
        return self.signature.parameters

    @property
    def inputs(self) -> tuple[str, ...]:
        return self.signature.inputs

    @property
    def outputs(self) -> tuple[str, ...]:
        return self.signature.outputs

    @property
    def switching(self) -> tuple[str, ...]:
        return self.signature.switching

    @property
    def nx(self) -> int:
        return len(self.states)

    @property
    def np(self) -> int:
        return len(self.parameters)

    @property
    def nu(self) -> int:
        """The width of the input a compiled function takes: one value per input, or a block per input
        (``len(inputs) * (points + 1)``) for a driven model."""
        return len(self.inputs) * (self.points + 1)

    def driven(self, points: int) -> NumericModel:
        """This model driven by input blocks of ``points + 1`` values per input and sample (see ``points``).

        A step over one sample is ``points`` steps of the classic model over ``dt / points``, each with the input
        linear between two points of the block; the substeps of a step are shared among them (at least one each).
        ``points = 1`` with a block ``[u_k, u_k]`` is a zero-order hold; ``[u_k, u_{k+1}]`` the classic linear
        input.

        Examples
        --------
        >>> import obsnl
        >>> from obsnl.estimation.codegen import to_casadi
        >>> num = to_casadi(obsnl.Model(name="i", states=["x"], parameters=["a"], inputs=["u"],
        ...                             equations={"x": "a*u"}, outputs={"y": "x"}))
        >>> held, lin = num.driven(1), num.driven(4)
        >>> held.nu, lin.nu
        (2, 5)
        >>> float(held.step(0.5, substeps=2)(0.0, 1.0, [1.0, 1.0], [3.0, 3.0])[0])  # u held at 1 over the step
        0.5
        >>> float(lin.step(0.5, substeps=4)(0.0, 1.0, [0, 1, 4, 9, 16], [16] * 5)[0])  # linear through 0, 1, 4, 9, 16
        2.75
        """
        if self.points:
            raise ModelError(f"model {self.name!r} is already driven by input blocks")
        if int(points) < 1:
            raise ModelError(f"points must be at least 1, got {points!r}")
        nu0, nx = len(self.inputs), self.nx
        x, p, U = ca.SX.sym("x", nx), ca.SX.sym("p", self.np), ca.SX.sym("u", nu0 * (int(points) + 1))
        u = U[:nu0]

        def at_sample(fn: ca.Function, pad: int = 0) -> ca.Function:
            out = fn(x, p, u)
            if pad:
                out = ca.horzcat(out, ca.SX.zeros(out.shape[0], pad))
            return ca.Function(fn.name(), [x, p, U], [out], [fn.name_in(i) for i in range(3)], [fn.name_out(0)])

        return replace(
            self,
            f=at_sample(self.f),
            h=at_sample(self.h),
            g=at_sample(self.g),
            jac_x=at_sample(self.jac_x),
            jac_u=at_sample(self.jac_u, nu0 * int(points)),
            jac_g=at_sample(self.jac_g),
            points=int(points),
            base=self,
        )

    @property
    def ny(self) -> int:
        return len(self.outputs)

    def nominal(self, names: Sequence[str]) -> ndarray:
        """The nominal values of ``names`` (from the model file); error naming a missing one."""
        missing = [n for n in names if n not in self.values]
        if missing:
            raise ModelError(f"model {self.name!r} has no value for {missing}; add them to [values]")
        return np.array([float(self.values[n]) for n in names])

    def step(
        self,
        dt: float,
        *,
        method: str = "auto",
        substeps: int = 8,
        scale: Any = None,
        threshold: float = 2.0,
        jit: bool = False,
        refine: int = 8,
        locate: bool = False,
    ) -> ca.Function:
        """The discrete step ``(x, p, u0, u1) -> (x_next, implicit, refined)`` over ``dt`` (input linear
        in time).

        Parameters
        ----------
        dt : float
            Sampling interval.
        method : str
            ``"auto"`` (default): RK4, redone with ROS2 when the step is stiff for RK4, that is when
            ``h * rho`` exceeds ``threshold``, with ``rho`` an upper bound of the spectral radius of
            ``J = df/dx`` at the RK4 end point (the Collatz-Wielandt bound of ``|D^-1 J D|``,
            ``D = diag(scale)``, after a few power iterations: it starts at ``||D^-1 J D||_inf`` and
            tightens towards the Perron root of ``|J|``, which no scaling changes; ``h = dt /
            substeps``), or the RK4 result is not finite (an RK4 step
            that went unstable ends where the model is stiff or overflowed); ROS2 is evaluated only
            then (``implicit`` is 1), with ``refine * substeps`` substeps; otherwise, where a switching
            function across which the field can jump (``jumps``) changed sign between two substeps,
            RK4 again with that substep split into ``refine`` (``refined`` is 1). ``"rk4"`` or
            ``"ros2"``: always that one, no refinement.
        substeps : int
            Equal substeps per interval.
        refine : int
            Substep factor of the fallbacks of ``"auto"`` (1: no refinement).
        scale : Any
            Typical magnitude of each state: the start of the stiffness estimate (default 1).
        threshold : float
            Stiffness bound for RK4 (its real stability interval is ``[-2.785, 0]``).
        jit : bool
            Compile the inner functions to C.
        locate : bool
            Split a refined substep at the located crossing, follow a sliding mode, and also refine where a
            crossing is late in a substep or its start lies on a surface it may slide along
            (:func:`obsnl.estimation.crossing.located_substep`; the maximum-likelihood fit uses it).

        References
        ----------
        .. [1] J. G. Verwer, E. J. Spee, J. G. Blom and W. Hundsdorfer, "A second-order Rosenbrock method applied to
           photochemical dispersion problems", SIAM J. Sci. Comput. 20(4), 1456-1480, 1999.
           doi:10.1137/S1064827597326651
        """
        if not (np.isfinite(dt) and dt > 0):
            raise ModelError(f"dt must be a positive number, got {dt!r}")
        if int(substeps) < 1:
            raise ModelError(f"substeps must be at least 1, got {substeps!r}")
        if method not in ("auto", "ros2", "rk4"):
            raise ModelError(f"unknown integration method {method!r}; use 'auto', 'rk4' or 'ros2'")
        if int(refine) < 1:
            raise ModelError(f"refine must be at least 1, got {refine!r}")
        n = int(substeps)
        key = (
            float(dt),
            method,
            n,
            None if scale is None else np.asarray(scale, float).tobytes(),
            float(threshold),
            bool(jit),
            int(refine),
            bool(locate),
        )
        if key not in self._steps:  # building the integrators takes about 50 ms; a step is reused many times
            self._steps[key] = self._build_step(dt, method, n, scale, threshold, jit, int(refine), bool(locate))
        return self._steps[key]

    def _build_step(
        self, dt: float, method: str, n: int, scale: Any, threshold: float, jit: bool, refine: int, locate: bool = False
    ) -> ca.Function:
        fns = self.integrators(dt, substeps=n, jit=jit, refine=refine, locate=locate)
        x, p = ca.SX.sym("x", self.nx), ca.SX.sym("p", self.np)
        u0, u1 = ca.SX.sym("u0", self.nu), ca.SX.sym("u1", self.nu)
        names_in, names_out = ["x", "p", "u0", "u1"], ["x_next", "implicit", "refined"]
        if method != "auto":
            flag = 1.0 if method == "ros2" else 0.0
            return ca.Function(
                f"step_{method}{n}",
                [x, p, u0, u1],
                [fns[method](x, p, u0, u1), ca.SX(flag), ca.SX(0.0)],
                names_in,
                names_out,
            )
        X, P = ca.MX.sym("x", self.nx), ca.MX.sym("p", self.np)
        U0, U1 = ca.MX.sym("u0", self.nu), ca.MX.sym("u1", self.nu)
        d = ca.DM(np.ones(self.nx) if scale is None else np.asarray(scale, float))
        xr, stiff, refined = fns["probe"](X, P, U0, U1, threshold, d)
        xn = ca.if_else(ca.logic_or(stiff, refined), fns["fine"](X, P, U0, U1, stiff), xr, True)
        return ca.Function(f"step_auto{n}", [X, P, U0, U1], [xn, stiff, refined], names_in, names_out)

    def integrators(
        self, dt: float, *, substeps: int, jit: bool = False, refine: int = 8, locate: bool = False
    ) -> dict[str, ca.Function]:
        """The pieces of :meth:`step`: ``rk4`` and ``ros2`` ``(x, p, u0, u1) -> x_next`` with
        ``substeps``; ``rk4_fine``, RK4 with every substep in which a watched switching function
        (``jumps``) changes sign split into ``refine`` (with ``locate``, located); ``ros2_fine``, ROS2 with
        ``refine * substeps``; ``rk4_track`` ``(x, p, u0, u1) -> (x_next, crossed)`` (RK4 that also says
        whether a switching function changed sign between two substeps; with ``locate``, as ``step`` says) and
        ``stiff(x, x_rk4, p, u0, u1, threshold, scale) -> 0/1``
        (``scale``: the typical magnitude of each state, the start of the stiffness estimate of :meth:`step`;
        an input, so that the code, and the key of its compiled library, do not depend on it).

        The rule of ``method="auto"``, shared by :meth:`step` and the filters' step: ``probe(x, p, u0,
        u1, threshold, scale) -> (x_rk4, stiff, refine)`` (``refine``: a watched crossing and not stiff) and,
        only where one of the two flags is set, ``fine(x, p, u0, u1, stiff) -> x_next`` (ROS2 with
        ``refine * substeps`` if stiff, else RK4 with the crossing substep refined).

        A driven model (``points > 0``) chains the classic model's pieces over the points of the block
        (:meth:`driven`)."""
        if self.points:
            return self._chained(dt, substeps=substeps, jit=jit, refine=refine, locate=locate)
        n, nf = int(substeps), int(substeps) * int(refine)
        opts = {"jit": True} if jit else {}  # marker: compiled through the disk cache (jitcache)
        c = jit_compile if jit else (lambda f: f)  # noqa: E731
        x, xr, p = ca.SX.sym("x", self.nx), ca.SX.sym("xr", self.nx), ca.SX.sym("p", self.np)
        u0, u1, thr = ca.SX.sym("u0", self.nu), ca.SX.sym("u1", self.nu), ca.SX.sym("threshold")
        names_in = ["x", "p", "u0", "u1"]
        out = {
            m: c(
                ca.Function(
                    f"{m}{n}", [x, p, u0, u1], [self._integrate(m, x, p, u0, u1, dt, n)[0]], names_in, ["x_next"]
                )
            )
            for m in ("rk4", "ros2")
        }
        out["rk4_fine"] = self._refined(dt, n, int(refine), opts, locate)
        out["ros2_fine"] = self._looped("ros2", dt, nf, opts)
        xt, crossed = self._integrate("rk4", x, p, u0, u1, dt, n, track=True, wide=locate)
        out["rk4_track"] = c(
            ca.Function(f"rk4_track{n}", [x, p, u0, u1], [xt, crossed], names_in, ["x_next", "crossed"])
        )
        d = ca.SX.sym("scale", self.nx)  # an input, not a constant: the code is the same for every scale
        ratio = ca.repmat(1.0 / d, 1, self.nx) * ca.repmat(d.T, self.nx, 1)  # (1/d_i) d_j, as numpy's outer
        Js = self.jac_x(xr, p, u1) * ratio
        Js = ca.if_else(ca.fabs(Js) < 1e300, ca.fabs(Js), 1e300)
        rho = dt / n * _perron_bound(Js, self.nx)
        stiff = ca.logic_or(rho > thr, ca.logic_not(ca.mmax(ca.fabs(xr)) < 1e150))
        out["stiff"] = c(ca.Function("stiff", [x, xr, p, u0, u1, thr, d], [stiff]))
        x_rk4, crossed = out["rk4_track"](x, p, u0, u1)
        is_stiff = out["stiff"](x, x_rk4, p, u0, u1, thr, d)
        out["probe"] = c(
            ca.Function(
                "probe",
                [x, p, u0, u1, thr, d],
                [x_rk4, is_stiff, ca.logic_and(crossed, ca.logic_not(is_stiff))],
                names_in + ["threshold", "scale"],
                ["x_rk4", "stiff", "refine"],
            )
        )
        X, P = ca.MX.sym("x", self.nx), ca.MX.sym("p", self.np)
        U0, U1, S = ca.MX.sym("u0", self.nu), ca.MX.sym("u1", self.nu), ca.MX.sym("stiff")
        out["fine"] = ca.Function(
            "fine",
            [X, P, U0, U1, S],  # MX: only the chosen integrator runs
            [ca.if_else(S, out["ros2_fine"](X, P, U0, U1), out["rk4_fine"](X, P, U0, U1), True)],
            names_in + ["stiff"],
            ["x_next"],
        )
        return out

    def _chained(self, dt: float, *, substeps: int, jit: bool, refine: int, locate: bool) -> dict[str, ca.Function]:
        """The pieces of :meth:`integrators` of a driven model: the classic model's pieces over ``dt / points`` (with
        ``ceil(substeps / points)`` substeps each), applied from point to point of the block. A step is crossed
        where one of its pieces is; it is stiff as the classic step is judged, once, at its end point (the last
        piece's Jacobian, with the last piece's substep; a piece that overflowed leaves the end non-finite, which
        is stiff too), so that the probe costs one stiffness bound per sample, not one per piece."""
        assert self.base is not None
        m, nu0 = self.points, len(self.inputs)
        parts = self.base.integrators(
            dt / m, substeps=max(1, -(-int(substeps) // m)), jit=jit, refine=refine, locate=locate
        )
        out = {}
        for name, fn in parts.items():
            sym: Any = ca.SX if fn.is_a("SXFunction") else ca.MX  # the piece's own kind: its symbols are SX or MX
            first = 2 if name == "stiff" else 1  # stiff(x, x_rk4, p, u0, u1, ...): the input after two states
            head = [sym.sym(fn.name_in(i), fn.size_in(i)) for i in range(first + 1)]
            U0, U1 = sym.sym("u0", self.nu), sym.sym("u1", self.nu)
            tail = [sym.sym(fn.name_in(i), fn.size_in(i)) for i in range(first + 3, fn.n_in())]
            pts = [U0[j * nu0 : (j + 1) * nu0] for j in range(m + 1)]
            if name == "stiff":  # judged on the last piece, at the step's end point
                outs = fn.call([*head, pts[m - 1], pts[m], *tail])
            elif name == "probe":  # the RK4 pieces tracked, the stiffness judged once at the end (as "stiff")
                x, start, crossed = head[0], head[0], sym(0.0)
                for j in range(m):
                    start = x
                    x, c = parts["rk4_track"].call([x, *head[1:], pts[j], pts[j + 1]])
                    crossed = ca.logic_or(crossed, c)
                stiff = parts["stiff"].call([start, x, *head[1:], pts[m - 1], pts[m], *tail])[0]
                outs = [x, stiff, ca.logic_and(crossed, ca.logic_not(stiff))]
            else:
                x, flags = head[0], None
                for j in range(m):
                    res = fn.call([x, *head[1:], pts[j], pts[j + 1], *tail])
                    x = res[0]
                    flags = res[1:] if flags is None else [ca.logic_or(a, b) for a, b in zip(flags, res[1:])]
                assert flags is not None  # a driven model's step has m >= 1 pieces
                outs = [x, *(flags or [])]
            out[name] = ca.Function(
                name,
                [*head, U0, U1, *tail],
                outs,
                [fn.name_in(i) for i in range(fn.n_in())],
                [fn.name_out(i) for i in range(fn.n_out())],
            )
        return out

    def _refined(self, dt: float, n: int, refine: int, opts: Mapping[str, Any], locate: bool = False) -> ca.Function:
        """``(x, p, u0, u1) -> x_next``: ``n`` RK4 substeps, each redone with ``refine`` substeps where a
        watched switching function changed sign over it (the crossing substep carries the error)."""
        x, p = ca.SX.sym("x", self.nx), ca.SX.sym("p", self.np)
        ua, ub = ca.SX.sym("ua", self.nu), ca.SX.sym("ub", self.nu)
        one = ca.Function(
            "substep", [x, p, ua, ub], list(self._integrate("rk4", x, p, ua, ub, dt / n, 1, track=True, wide=locate))
        )
        fine = (
            self._over_substeps(located_substep(self, dt / n / refine), refine, f"located{refine}", {})
            if locate
            else self._looped("rk4", dt / n, refine, {})
        )
        xm, pm = ca.MX.sym("x", self.nx), ca.MX.sym("p", self.np)
        uam, ubm = ca.MX.sym("ua", self.nu), ca.MX.sym("ub", self.nu)
        xb, crossed = one(xm, pm, uam, ubm)
        cell = ca.Function(
            "refined_substep", [xm, pm, uam, ubm], [ca.if_else(crossed, fine(xm, pm, uam, ubm), xb, True)]
        )
        return self._over_substeps(cell, n, f"rk4_refined{n}x{refine}", opts)

    def _looped(self, method: str, dt: float, n: int, opts: Mapping[str, Any]) -> ca.Function:
        """``(x, p, u0, u1) -> x_next``: ``n`` substeps as a loop over one substep (not unrolled, so
        that a fine fallback stays small to build and to compile)."""
        x, p = ca.SX.sym("x", self.nx), ca.SX.sym("p", self.np)
        ua, ub = ca.SX.sym("ua", self.nu), ca.SX.sym("ub", self.nu)
        one = ca.Function("substep", [x, p, ua, ub], [self._integrate(method, x, p, ua, ub, dt / n, 1)[0]])
        return self._over_substeps(one, n, f"{method}{n}", opts)

    def _over_substeps(self, cell: ca.Function, n: int, name: str, opts: Mapping[str, Any]) -> ca.Function:
        """``(x, p, u0, u1) -> x_next``: ``cell(x, p, ua, ub) -> x`` applied over ``n`` equal substeps
        (a ``mapaccum`` loop, the input linear from ``u0`` to ``u1``)."""
        loop = cell.mapaccum(f"{name}_loop", n)
        X, P = ca.MX.sym("x", self.nx), ca.MX.sym("p", self.np)
        U0, U1 = ca.MX.sym("u0", self.nu), ca.MX.sym("u1", self.nu)
        frac = ca.DM(np.arange(n + 1)[None, :] / n)
        us = ca.mtimes(U0, 1 - frac) + ca.mtimes(U1, frac)
        xs = loop(X, P, us[:, :n], us[:, 1:])
        f = ca.Function(name, [X, P, U0, U1], [xs[:, n - 1]], ["x", "p", "u0", "u1"], ["x_next"])
        return jit_compile(f) if opts.get("jit") else f

    def _integrate(
        self,
        method: str,
        x: ca.SX,
        p: ca.SX,
        u0: ca.SX,
        u1: ca.SX,
        dt: float,
        n: int,
        track: bool = False,
        wide: bool = False,
    ) -> tuple[ca.SX, ca.SX]:
        """``(x_next, crossed)``: ``n`` substeps of ``method``; with ``track``, ``crossed`` is 1 where a
        switching function changed sign (strictly) between two substep ends (else always 0); with ``wide``
        also where it changed sign at the old branch's extrapolated end of a substep (Heun's third-order
        method, :func:`obsnl.estimation.crossing.heun3`) or where its start lies on a surface it may slide along."""
        h = dt / n
        du = (u1 - u0) / dt
        xi = x
        crossed = ca.SX(0.0)
        watch = [i for i in range(len(self.switching)) if not self.jumps or self.jumps[i]]
        track = track and len(watch) > 0
        g_sel = lambda xx, uu: self.g(xx, p, uu)[watch]  # noqa: E731 - called only when tracking
        g_prev = g_sel(x, u0) if track else ca.SX()  # unused without tracking
        for i in range(n):
            ua = u0 + du * (i * h)
            ub = u0 + du * ((i + 1) * h)
            x_start = xi
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
            if track:
                g_i = g_sel(xi, ub)
                crossed = ca.logic_or(crossed, ca.mmin(g_prev * g_i) < 0)
                if wide:  # also a crossing late in the substep, which the RK4 end may not show
                    g_old = g_sel(heun3(self.f, x_start, p, ua, ub, h, h), ub)
                    crossed = ca.logic_or(crossed, ca.mmin(g_prev * g_old) < 0)
                    on, tangent = surface_start(self, x_start, p, ua, h)  # where it may slide: on it, or heading in
                    crossed = ca.logic_or(
                        crossed,
                        ca.mmax(
                            ca.vertcat(
                                0,
                                *[
                                    ca.logic_or(on[i], tangent[i] < 2)
                                    for i in watch
                                    if not self.slides or self.slides[i]
                                ],
                            )
                        ),
                    )
                g_prev = g_i
        return xi, crossed

    def to_dict(self) -> dict[str, Any]:
        return self.signature.to_dict()


def _perron_bound(A: ca.SX, n: int, iterations: int = 3) -> ca.SX:
    """An upper bound of the spectral radius of the non-negative ``n x n`` matrix ``A``.

    Collatz-Wielandt: ``rho(A) <= max_i (A v)_i / v_i`` for every positive ``v``; ``v`` starts at
    ones (the bound is then the infinity norm) and follows a few power iterations of
    ``A + eps * ones`` (``eps`` a millionth of the largest entry keeps ``v`` positive), which can
    only lower the bound. Never below ``rho(A)``: a stiff step is never missed, fewer are flagged.

    The same bound is also taken on ``A`` balanced (:func:`_balanced`, a diagonal similarity: the same
    spectrum), and the lower of the two is returned. Unbalanced, a few power iterations may stay far above
    ``rho(A)``: where the states' magnitudes differ by orders (a displacement in metres, a force in newtons)
    and the coupling is a two-cycle (``y' = v``, ``v' = -k y``), the iterates alternate instead of converging.
    On the Bouc-Wen benchmark's Jacobians the bound unbalanced reached 43 times ``rho(|J|)`` (up to 3 where
    ``rho(|J|)`` is 0.16, in units of the substep: RK4 redone with ROS2 where it was stable), balanced at most
    1.4 times.
    """
    plain = _collatz_wielandt(A, n, iterations)
    balanced = _collatz_wielandt(_balanced(A, n), n, iterations)
    return ca.if_else(balanced < plain, balanced, plain)  # a NaN (an overflow in balancing) keeps the plain bound


def _collatz_wielandt(A: ca.SX, n: int, iterations: int) -> ca.SX:
    """``max_i (B v)_i / v_i`` with ``B = A + eps * ones`` and ``v`` after ``iterations`` power iterations from
    ones (:func:`_perron_bound`)."""
    E = 1e-6 * ca.mmax(A) * ca.SX.ones(n, n) + 1e-300
    B = A + E
    v = ca.SX.ones(n, 1)
    for _ in range(iterations):
        w = ca.mtimes(B, v)
        v = w / ca.mmax(w)
    return ca.mmax(ca.mtimes(B, v) / v)


def _balanced(A: ca.SX, n: int, sweeps: int = 2) -> ca.SX:
    """``D^-1 A D`` for the non-negative ``A``, ``D`` diagonal from ``sweeps`` sweeps of Osborne's balancing
    (E. E. Osborne, "On pre-conditioning of matrices", J. ACM 7(4):338-345, 1960): each index in turn is
    scaled by ``sqrt(c_i / r_i)``, its off-diagonal column over its row sum (left alone where either is 0),
    which equalises the two. A diagonal similarity keeps the eigenvalues, so ``rho`` is unchanged."""
    M = [[A[i, j] for j in range(n)] for i in range(n)]
    for _ in range(sweeps):
        for i in range(n):
            r = sum((M[i][j] for j in range(n) if j != i), ca.SX(0.0))
            c = sum((M[j][i] for j in range(n) if j != i), ca.SX(0.0))
            ok = ca.logic_and(r > 0, c > 0)
            f = ca.fmin(ca.fmax(ca.if_else(ok, ca.sqrt(c / ca.if_else(ok, r, 1.0)), 1.0), 1e-150), 1e150)
            for j in range(n):
                if j != i:
                    M[i][j] = M[i][j] * f
                    M[j][i] = M[j][i] / f
    return ca.vertcat(*[ca.horzcat(*row) for row in M])


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
        return {
            "names": list(self.names),
            "parameters": list(self.parameters),
            "depends": {n: list(d) for n, d in zip(self.names, self.depends)},
        }
