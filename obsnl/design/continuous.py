"""The branches an experiment visits along its continuous trajectory, not only at its samples.

:func:`obsnl.observability.joint.visited.visited_patterns` reads the sign of every switching function at the
record's sample times: a contact that opens and closes between two samples is no visit there, so the smallest
sufficient scale of :func:`obsnl.design.experiment.design` moved with the sampling rate of the same input, and a
mass held by dry friction chattered across ``v = 0`` (its fixed RK4 steps have no sliding mode) and was counted as
moving both ways. This module is what the design (and ``analyze --record``) simulate instead:

**The simulation** is the fit's own discrete step (:meth:`obsnl.estimation.numeric.NumericModel.step` with
``locate=True``): RK4, :data:`SUBSTEPS` substeps per fine interval of :data:`GRID` per sample, a substep in which
the field jumps split at the located crossing, and a trajectory that both sides of a surface push towards stays on
it with Filippov's field (:func:`obsnl.estimation.crossing.located_substep`): a mass that friction holds stays
held. It starts at the model's initial state: a known initial condition (``known_initial_conditions`` with its
``initial_condition_values``) where the model declares one, else the state's number in ``[values]``, else 0.

**The input between samples** is the kind the model's ``[intersample]`` table or ``intersample=`` gives each input
(:func:`obsnl.estimation.intersample.intersample_kinds`): held (``zoh``), linear, or band-limited (interpolated at
:data:`~obsnl.estimation.intersample.POINTS` points per sample, :func:`obsnl.estimation.intersample.blocks`).

**A visit** is a sign pattern of the switching functions held over a stretch of the trajectory. The signs are read
at every point of the fine grid; a point where the state rests on a surface (``|g| <= 1e-6 h |g'|``, a millionth of
what the field moves ``g`` in one fine interval ``h``, or ``g = 0``: a mass stuck by friction, sliding) belongs to
no branch. Between two grid points on the same side of a surface, ``g`` along the trajectory is interpolated by the
cubic through its values and its derivatives ``g' = grad g . f + dg/du u'`` at the two ends (Hermite); where that
cubic crosses 0, or comes within half of its smaller end value of 0 (a near graze), or where two surfaces change
sign in one interval (the branch between them may be missed), the interval is simulated again on a grid
:data:`SPLIT` times finer, up to :data:`DEPTH` times; at the last level the cubic decides. A contact that opens and
closes between two samples is so located: the visited set no longer depends on the sampling rate beyond the
discretisation's own error (:data:`SUBSTEPS` RK4 substeps per fine interval).

What it does not see: a slip from a stuck state back to sticking within one fine interval (1/:data:`GRID` of a
sample; the points on both sides rest on the surface); motion along a sliding surface (no branch: the joint
verdict reads branches only).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from obsnl.errors import DataError
from obsnl.estimation.accelerogram import check_increasing
from obsnl.estimation.intersample import intersample_kinds, upsample
from obsnl.estimation.measured import CLOCK_TOLERANCE
from obsnl.model.bounds.budget import check_time
from obsnl.model.core import NONSMOOTH_FUNCTIONS, Model
from obsnl.observability.joint.visited import BlewUp, Visits, checked_record

__all__ = [
    "GRID",
    "FINE",
    "SUBSTEPS",
    "SPLIT",
    "DEPTH",
    "Drive",
    "TrajectoryVisits",
    "continuous_visits",
    "initial_state",
]

#: Fine intervals per sample at which the signs are read.
GRID = 8
#: Fine intervals per sample where an input is band-limited: it is interpolated at their ends, linear in between
#: (at a fifth of the sampling rate the linear step's error is 2e-4 of the amplitude at most).
FINE = 32
#: RK4 substeps per sample, shared among its fine intervals (a substep in which the field jumps is split at its
#: located crossing).
SUBSTEPS = 32
#: How much finer the grid of an interval simulated again is (one level).
SPLIT = 8
#: Levels of refinement of an interval where a crossing is suspected (``SPLIT**DEPTH`` finer at most).
DEPTH = 3
#: Fine intervals per compiled call (the time limit is checked between calls).
CHUNK = 4096
#: Points of the Hermite cubic at which an interval's closest approach to a surface is read.
_PROBE = np.linspace(0.0, 1.0, 33)


def initial_state(model: Model, values: Mapping[str, float]) -> tuple[np.ndarray, dict[str, str]]:
    """The initial state of a simulation, and where each state's number came from.

    A known initial condition with a value (``initial_condition_values``, its expression evaluated with ``values``)
    comes first, then the state's number in ``values``, then 0.

    Parameters
    ----------
    model : Model
        The model.
    values : mapping of str to float
        Numbers of the parameters, known constants and (optionally) states.

    Returns
    -------
    tuple
        The state (model order) and ``{state: "0.1 (known initial condition)"}`` for every state.

    Examples
    --------
    >>> m = Model(name="d", states=["x", "v"], parameters=["k"], equations={"x": "v", "v": "-k*x"},
    ...           outputs={"y": "x"}, known_initial_conditions=["x"], initial_condition_values={"x": 0.1},
    ...           values={"k": 4.0})
    >>> x0, said = initial_state(m, m.values)
    >>> x0.tolist(), said["x"], said["v"]
    ([0.1, 0.0], '0.1 (known initial condition)', '0 (no number given)')
    """
    numbers = {s: float(values[s.name]) for s in model.symbols.values() if s.name in values} if values else {}
    x0, said = [], {}
    for s in model.states:
        expr = model.initial_condition_values.get(s) if s in model.known_initial_conditions else None
        value = math.nan
        if expr is not None:
            try:
                value = float(expr.subs(numbers))
            except TypeError:  # a symbol without a number
                value = math.nan
        if math.isfinite(value):
            said[s.name] = f"{value:g} (known initial condition)"
        elif s.name in values:
            value = float(values[s.name])
            said[s.name] = f"{value:g} ([values])"
        else:
            value = 0.0
            said[s.name] = "0 (no number given)"
        x0.append(value)
    return np.array(x0, float), said


@dataclass(frozen=True)
class Drive:
    """A record as the fine intervals the simulation steps over: each one's input at its start and at its end.

    Attributes
    ----------
    t0, h
        The first sample time and the length of a fine interval (a sample interval over :data:`GRID`).
    ua, ub
        ``(N, nu)``: the input at the start (right limit) and at the end (left limit) of each fine interval, linear
        in between; a held input jumps between two intervals.
    duration
        The record's length (s).
    substeps
        RK4 substeps per fine interval.
    """

    t0: float
    h: float
    ua: np.ndarray
    ub: np.ndarray
    duration: float
    substeps: int = 1

    def scaled(self, scale: float) -> Drive:
        """The same record with every input multiplied by ``scale``."""
        with np.errstate(over="ignore"):
            return Drive(self.t0, self.h, scale * self.ua, scale * self.ub, self.duration, self.substeps)


def _drive(t: np.ndarray, signals: Sequence[np.ndarray], kinds: Sequence[str], where: str) -> Drive:
    """The fine intervals of a record sampled at ``t`` (a regular clock) with the input kinds ``kinds``."""
    rounding = check_increasing(t, where)
    T = len(t)
    dt = float(t[-1] - t[0]) / (T - 1)
    off = np.abs((t - t[0]) - np.arange(T) * dt)
    k = int(np.argmax(off))
    if off[k] > CLOCK_TOLERANCE * dt + 2 * rounding:
        raise DataError(
            f"{where}: irregular time step: sample {k} (t = {float(t[k]):.10g} s) is {off[k] / dt:.3g} of a step off "
            f"k*dt (dt = {dt:.6g} s); the input between samples needs a regular clock: resample the record first"
        )
    per = FINE if "bandlimited" in kinds else GRID  # fine intervals per sample
    frac = np.arange(per + 1) / per  # the positions of their ends in a sample interval
    ua, ub = np.empty(((T - 1) * per, len(signals))), np.empty(((T - 1) * per, len(signals)))
    for j, (u, kind) in enumerate(zip(signals, kinds)):
        if kind == "zoh":  # the sample held to the next one
            ua[:, j] = ub[:, j] = np.repeat(u[:-1], per)
        elif kind == "linear":
            ends = u[:-1, None] * (1 - frac) + u[1:, None] * frac  # (T - 1, per + 1)
            ua[:, j], ub[:, j] = ends[:, :-1].ravel(), ends[:, 1:].ravel()
        else:  # at the fine points themselves, linear between them
            up = np.append(upsample(u, per), u[-1])[: (T - 1) * per + 1]
            ua[:, j], ub[:, j] = up[:-1], up[1:]
    return Drive(float(t[0]), dt / per, ua, ub, float(t[-1] - t[0]), max(1, SUBSTEPS // per))


class TrajectoryVisits:
    """The visits of one model (its numbers, initial state and input kinds fixed) under records, compiled once.

    Parameters
    ----------
    model : Model
        The model; every input known.
    values : mapping of str to float or None
        Numbers instead of the model's ``[values]``.
    intersample : None, str, mapping or sequence of str
        How the inputs behave between samples (:func:`obsnl.estimation.intersample.intersample_kinds`; default: the
        model's ``[intersample]`` table, else linear).

    Attributes
    ----------
    kinds
        ``{input: kind}``.
    initial
        ``{state: where its initial number came from}`` (:func:`initial_state`).
    """

    def __init__(self, model: Model, *, values: Mapping[str, float] | None = None, intersample: Any = None) -> None:
        self.model = model
        self.values = dict(model.values if values is None else values)
        self.kinds = intersample_kinds(intersample, [u.name for u in model.inputs], table=model.intersample)
        self.x0, self.initial = initial_state(model, self.values)
        exprs = list(model.rhs) + list(model.output_exprs)
        self.smooth = not any(e.has(*NONSMOOTH_FUNCTIONS) for e in exprs)
        self._num: Any = None
        self._runs: dict[tuple[float, int, int], ca.Function] = {}

    def drive(self, t: np.ndarray, inputs: Mapping[str, np.ndarray], *, where: str = "the record") -> Drive:
        """The record ``(t, inputs)`` as fine intervals, checked (:func:`~obsnl.observability.joint.visited.checked_record`,
        a regular clock)."""
        _, t, signals = checked_record(self.model, t, inputs, self.values)
        return _drive(t, signals, [self.kinds[u.name] for u in self.model.inputs], where)

    def _compiled(self) -> Any:
        if self._num is None:
            from obsnl.estimation.codegen import to_casadi

            m = self.model
            missing = [s.name for s in list(m.parameters) + list(m.known_constants) if s.name not in self.values]
            if missing:  # checked_record refuses it first; kept for a direct call
                raise DataError(f"give a number for {', '.join(missing)}")
            num = to_casadi(m, constants={c.name: float(self.values[c.name]) for c in m.known_constants})
            self._p = np.array([float(self.values[n]) for n in num.parameters])
            x, p = ca.SX.sym("x", num.nx), ca.SX.sym("p", num.np)
            u, du = ca.SX.sym("u", num.nu), ca.SX.sym("du", num.nu)
            g = num.g(x, p, u)
            rate = ca.mtimes(ca.jacobian(g, x), num.f(x, p, u)) + ca.mtimes(ca.jacobian(g, u), du)
            self._g = ca.Function("g_rate", [x, p, u, du], [g, rate])
            self._num = num
        return self._num

    def _run(self, x0: np.ndarray, ua: np.ndarray, ub: np.ndarray, h: float, substeps: int) -> np.ndarray:
        """The states at the ends of the fine intervals ``(ua, ub)`` of length ``h`` from ``x0``: ``(N + 1, nx)``."""
        num, N = self._compiled(), len(ua)
        key = (float(h), N, int(substeps))
        if key not in self._runs:
            step = num.step(h, substeps=substeps, refine=8, locate=True)
            self._runs[key] = step.mapaccum("run", N)
        with np.errstate(all="ignore"):
            X = np.array(self._runs[key](x0, self._p, ua.T, ub.T)[0], dtype=float).reshape(num.nx, N)
        return np.vstack([x0, X.T])

    def _rates(self, X: np.ndarray, u: np.ndarray, du: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``g`` and ``g'`` at the states ``X`` (rows) with the inputs ``u`` and their rates ``du``."""
        N = len(X)
        fn = self._g.map(N)
        with np.errstate(all="ignore"):
            g, r = fn(X.T, self._p, u.T, du.T)
        ns = self._num.g.size1_out(0)
        return np.asarray(g, float).reshape(ns, N).T, np.asarray(r, float).reshape(ns, N).T

    def _scan(
        self, X: np.ndarray, ua: np.ndarray, ub: np.ndarray, h: float, depth: int, substeps: int
    ) -> tuple[Any, Any]:
        """``(signs, seconds)`` at the points of a grid (rows of ``X``) with hidden crossings spliced in."""
        du = (ub - ua) / h
        ga, ra = self._rates(X[:-1], ua, du)  # each interval's start (right limit)
        gb, rb = self._rates(X[1:], ub, du)  # its end (left limit)

        def side(g: np.ndarray, r: np.ndarray) -> np.ndarray:
            on = (g == 0) | (np.abs(g) <= 1e-6 * h * np.abs(r)) | ~np.isfinite(g)  # not a number: on no branch
            return np.where(on, 0, np.sign(np.nan_to_num(g))).astype(int)

        sa, sb = side(ga, ra), side(gb, rb)
        signs = np.vstack([sa, sb[-1:]])
        seconds = np.full(len(X), h)
        seconds[0] = seconds[-1] = h / 2
        # the cubic through g and g' at both ends of every interval that stays on one side, read at _PROBE
        s = _PROBE[None, None, :]
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        cubic = ga[..., None] * h00 + h * ra[..., None] * h10 + gb[..., None] * h01 + h * rb[..., None] * h11
        same = (sa == sb) & (sa != 0)
        q = np.where(same[..., None], sa[..., None] * cubic, np.inf)  # > 0 where the cubic stays on the ends' side
        closest = q.min(axis=2)
        ends = np.minimum(np.abs(ga), np.abs(gb))
        near = same & (closest < 0.5 * ends)
        several = ((sa != sb) & (sa != 0) & (sb != 0)).sum(axis=1) >= 2
        suspects = np.flatnonzero(near.any(axis=1) | several)
        inserts: list[tuple[int, Any, Any]] = []
        for i in map(int, suspects):
            if depth < DEPTH:
                frac = np.arange(SPLIT + 1)[:, None] / SPLIT
                us = ua[i] * (1 - frac) + ub[i] * frac
                sub = self._run(X[i], us[:-1], us[1:], h / SPLIT, substeps)
                if not np.all(np.isfinite(sub)):
                    continue  # left as the coarse grid reads it (a blow-up shows at the coarse points)
                sg, sec = self._scan(sub, us[:-1], us[1:], h / SPLIT, depth + 1, substeps)
                seconds[i] += sec[0] - h / 2
                seconds[i + 1] += sec[-1] - h / 2
                inserts.append((i, sg[1:-1], sec[1:-1]))
            else:  # the cubic decides: the functions it takes across, for the share of the interval it is there
                across = closest[i] < 0
                if across.any():
                    share = float(np.mean(q[i][across].min(axis=0) < 0))
                    flipped = sa[i].copy()
                    flipped[across] = -flipped[across]
                    seconds[i] -= share * h / 2
                    seconds[i + 1] -= share * h / 2
                    inserts.append((i, flipped[None, :], np.array([share * h])))
        if not inserts:
            return signs, seconds
        out_s: list[np.ndarray] = []
        out_t: list[np.ndarray] = []
        last = 0
        for i, sg, sec in inserts:
            out_s += [signs[last : i + 1], sg]
            out_t += [seconds[last : i + 1], sec]
            last = i + 1
        out_s.append(signs[last:])
        out_t.append(seconds[last:])
        return np.vstack(out_s), np.concatenate(out_t)

    def visits(self, drive: Drive, *, scale: float = 1.0) -> Visits:
        """The visited sign patterns of the record ``drive`` (its input multiplied by ``scale``).

        Parameters
        ----------
        drive : Drive
            The record (:meth:`drive`).
        scale : float
            The factor on its input (the initial state is not scaled).

        Returns
        -------
        Visits

        Raises
        ------
        BlewUp
            The state left the finite numbers (the exact fine-grid time it did so).
        """
        if self.smooth:
            return Visits((), {(): drive.duration}, {})
        num = self._compiled()
        d = drive.scaled(scale) if scale != 1.0 else drive
        signs: list[np.ndarray] = []
        seconds: list[np.ndarray] = []
        x = self.x0
        N = len(d.ua)
        for start in range(0, N, CHUNK):
            check_time(
                f"simulating the model under the record (fine interval {start} of {N})",
                "raise max_seconds=, or give a shorter record",
            )
            ua, ub = d.ua[start : start + CHUNK], d.ub[start : start + CHUNK]
            X = self._run(x, ua, ub, d.h, d.substeps)
            bad = ~np.all(np.isfinite(X), axis=1)
            if bad.any():
                raise BlewUp(d.t0 + (start + int(np.flatnonzero(bad)[0])) * d.h)
            sg, sec = self._scan(X, ua, ub, d.h, 0, d.substeps)
            if signs:  # the chunk's first point is the previous chunk's last
                seconds[-1][-1] += sec[0]
                sg, sec = sg[1:], sec[1:]
            signs.append(sg)
            seconds.append(sec)
            x = X[-1]
        S, W = np.vstack(signs), np.concatenate(seconds)
        patterns: dict[tuple[int, ...], float] = {}
        for row, w in zip(map(tuple, S.tolist()), W):
            if 0 not in row:
                patterns[row] = patterns.get(row, 0.0) + float(w)
        crossings = {}
        for j, name in enumerate(num.switching):
            col = S[:, j][S[:, j] != 0]
            crossings[name] = int(np.count_nonzero(np.diff(col)))
        return Visits(tuple(num.switching), patterns, crossings)


def continuous_visits(
    model: Model,
    t: np.ndarray,
    inputs: Mapping[str, np.ndarray],
    *,
    values: Mapping[str, float] | None = None,
    intersample: Any = None,
) -> Visits:
    """The sign patterns a simulation of ``model`` under a record visits along its continuous trajectory.

    Parameters
    ----------
    model : Model
        A model with numbers for every parameter and known constant in ``values`` (default: its ``[values]``).
    t : ndarray
        Sample times (a regular clock).
    inputs : mapping of str to ndarray
        One array per model input, sampled at ``t``.
    values : mapping of str to float or None
        Numbers instead of the model's ``[values]``.
    intersample : None, str, mapping or sequence of str
        How the inputs behave between samples (default: the model's ``[intersample]`` table, else linear).

    Returns
    -------
    Visits

    Raises
    ------
    AnalysisError
        A missing number or input; :class:`~obsnl.observability.joint.visited.BlewUp` where the simulation blows up.
    DataError
        An irregular clock.
    OptionError
        An unknown input kind.

    Examples
    --------
    A free oscillation ``x = sin t`` that touches a stop at ``g = 0.995`` for ``|t - pi/2| < 0.1`` only, sampled
    every 0.35 s (``sin 1.4 = 0.985``, ``sin 1.75 = 0.984``): the contact lies between two samples, and is a visit
    (sign -1 of ``g - x``), entered and left once:

    >>> import numpy as np
    >>> from obsnl import Model
    >>> m = Model(name="touch", states=["x", "v"], parameters=["kc", "g"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - x - kc*Max(x - g, 0)"}, outputs={"y": "x"},
    ...           values={"kc": 10.0, "g": 0.995, "x": 0.0, "v": 1.0})
    >>> t = 0.35 * np.arange(10)
    >>> vis = continuous_visits(m, t, {"u": np.zeros_like(t)})
    >>> vis.switching, sorted(vis.patterns), vis.crossings
    (('g - x',), [(-1,), (1,)], {'g - x': 2})
    """
    run = TrajectoryVisits(model, values=values, intersample=intersample)
    return run.visits(run.drive(t, inputs))
