"""Taylor mode on a straight-line program, one order for all nodes at once (the hot loop of the test).

Every node of a program (:mod:`obsnl.algebra.slp`) holds a truncated power series in ``t`` whose
coefficients are first-order *jets* (a value and its gradient with respect to the ``M`` unknowns),
stored as one int64 row ``[value, gradient]`` of length ``M + 1`` mod ``p``. Jets form the ring
``R = GF(p)[e_1..e_M]/(e)^2``.

**Why this is fast.** For ``k >= 1`` the coefficient ``k`` of every operation is *linear* in the
coefficients ``k`` of its operands, with constant jets taken from order 0, plus a *history* term
that uses only coefficients ``1..k-1``:

=====================  =======================================================  ====================
node                   coefficient k                                            history ``H``
=====================  =======================================================  ====================
``a*b``                ``b0 a[k] + a0 b[k] + H``                                ``sum a[j] b[k-j]``
``a/b``                ``(a[k] - c0 b[k] - H) / b0``                            ``sum b[j] c[k-j]``
``E = exp(g)``         ``E0 g[k] + H``                                          ``sum j/k g[j] E[k-j]``
``l = log(g)``         ``(g[k] - H) / g0``  (``atan``: ``/ (1+g^2)0``)          ``sum j/k l[j] g[k-j]``
``w = g^(1/q)``        ``(r w0 g[k] + H) / g0``,  ``r = 1/q``                   ``sum ((r+1)j-k)/k g[j] w[k-j]``
``s, c = sin, cos g``  ``c0 g[k] + H``, ``-s0 g[k] - H'``                       ``sum j/k g[j] c[k-j]``
=====================  =======================================================  ====================

(sums over ``j = 1..k-1``; products and quotients of jets throughout). So the new coefficients
``X[k]`` of all nodes solve ``X = L X + r`` with ``L`` strictly triangular and *the same at every
order*: ``X[k] = T r[k]`` with ``T = (I - L)^-1`` over ``R``, the tangent map of the program at
``t = 0``. ``r[k]`` holds the sources (state coefficients ``x[k] = f[k-1]/k``, input coefficients)
and the history terms. One order is then a few array operations whatever the program size: a
batched convolution for all history terms at once and one exact modular matrix product
(:class:`obsnl.algebra.modp.MatMod`), instead of one interpreted step per node (algorithms.md §3.5: only
coefficient ``k`` of every node is computed at step ``k``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from obsnl.algebra.modp import MatMod, mulmod

__all__ = ["Plan", "make_plan", "Stepper"]


@dataclass(frozen=True)
class Plan:
    """Point-independent structure of the batched Taylor step of one program.

    Attributes
    ----------
    edges
        For every time-varying node, in topological order: ``(node, ((operand, mu), ...))`` where
        ``mu`` says how the constant jet multiplying the operand's coefficient ``k`` is formed from
        order-0 jets: ``("s", +-1)``, ``("r", num, den)`` a rational, ``("j", i)`` the jet of node
        ``i``, ``("-j", i)`` its negative, ``("inv", i)`` its inverse, ``("-inv", i)``,
        ``("-cb", c, b)`` for ``-c0/b0``, ``("root", w, g, q)`` for ``w0/(q g0)``.
    conv
        History terms: ``(node, kind, u, v, lam, q)`` with ``H = sum_j w_j u[j] v[k-j]``, the weights
        ``w_j`` given by ``kind`` (and ``q`` for roots) and the constant jet ``lam`` (same codes as
        ``mu``) multiplying ``H``.
    sources
        Source leaves (states, then known and unknown inputs) whose coefficients are given.
    cols
        Columns of ``T``: the sources, then the nodes with a history term.
    rows
        Rows of ``T``: the nodes whose series are kept (history operands, wanted roots).
    """

    edges: tuple[tuple[int, tuple[tuple[int, tuple], ...]], ...]
    conv: tuple[tuple[int, str, int, int, tuple, int], ...]
    sources: tuple[int, ...]
    cols: tuple[int, ...]
    rows: tuple[int, ...]


def make_plan(
    ops: Sequence,
    tv: Sequence[bool],
    topo: Sequence[int],
    atoms: Mapping[int, tuple[str, int, int, int, int]],
    sources: Sequence[int],
    wanted: Sequence[int],
) -> Plan:
    """Build the :class:`Plan` of a program.

    Parameters
    ----------
    ops : sequence
        The program's operations (:class:`obsnl.algebra.slp.Op`).
    tv : sequence of bool
        Per node: True when it varies in time (its coefficients ``k >= 1`` may be nonzero).
    topo : sequence of int
        A topological order of all nodes (atoms after their arguments, cosines after sines).
    atoms : mapping of int to tuple (str, int, int, int, int)
        Time-varying atom leaves: ``{node: (kind, argument node, denominator node (atan) or -1,
        partner node (sin/cos) or -1, q (roots) or 0)}``.
    sources : sequence of int
        Leaves whose coefficients ``k >= 1`` are given (states first, then inputs).
    wanted : sequence of int
        Nodes whose series are needed besides the history operands (right-hand sides, outputs).
    """
    edges: list[tuple[int, tuple[tuple[int, tuple], ...]]] = []
    conv: list[tuple[int, str, int, int, tuple, int]] = []
    src = set(sources)
    for i in topo:
        if not tv[i] or i in src:
            continue
        op = ops[i]
        e: list[tuple[int, tuple]] = []
        kind = op.kind
        if kind == "leaf":
            akind, g, den, partner, q = atoms[i]
            if akind == "exp":
                e.append((g, ("j", i)))
                conv.append((i, "exp", g, i, ("s", 1), 0))
            elif akind in ("log", "atan"):
                d = g if akind == "log" else den
                e.append((g, ("inv", d)))
                conv.append((i, akind, i, d, ("-inv", d), 0))
            elif akind == "root":
                e.append((g, ("root", i, g, q)))
                conv.append((i, "root", g, i, ("inv", g), q))
            elif akind == "sin":
                e.append((g, ("j", partner)))
                conv.append((i, "sin", g, partner, ("s", 1), 0))
            elif akind == "cos":
                e.append((g, ("-j", partner)))
                conv.append((i, "cos", g, partner, ("s", -1), 0))
            else:  # pragma: no cover - guarded by the caller
                raise ValueError(f"atom kind {akind}")
        elif kind in ("neg", "shift"):
            e.append((op.a, ("s", -1 if kind == "neg" else 1)))
        elif kind == "scale":
            e.append((op.a, ("r", int(op.arg.p), int(op.arg.q))))
        elif kind in ("add", "sub"):
            if tv[op.a]:
                e.append((op.a, ("s", 1)))
            if tv[op.b]:
                e.append((op.b, ("s", 1 if kind == "add" else -1)))
        elif kind == "mul":
            if tv[op.a]:
                e.append((op.a, ("j", op.b)))
            if tv[op.b]:
                e.append((op.b, ("j", op.a)))
            if tv[op.a] and tv[op.b]:
                conv.append((i, "mul", op.a, op.b, ("s", 1), 0))
        elif kind == "div":
            if tv[op.a]:
                e.append((op.a, ("inv", op.b)))
            if tv[op.b]:
                e.append((op.b, ("-cb", i, op.b)))
                conv.append((i, "div", op.b, i, ("-inv", op.b), 0))
        else:  # pragma: no cover - constants and leaves are not time-varying non-sources
            raise ValueError(f"internal: time-varying {kind}")
        edges.append((i, tuple(e)))
    cols = tuple(sources) + tuple(c[0] for c in conv)
    need: list[int] = []
    for c in conv:
        for x in (c[2], c[3]):
            if x not in need:
                need.append(x)
    for x in wanted:
        if tv[x] and x not in need:
            need.append(x)
    return Plan(edges=tuple(edges), conv=tuple(conv), sources=tuple(sources), cols=cols, rows=tuple(need))


class Stepper:
    """The series of the plan's rows at one random point, order by order.

    Parameters
    ----------
    plan : Plan
        The :class:`Plan`.
    X0 : ndarray
        Order-0 jets of all nodes, int64 array ``(n_nodes, M + 1)`` (column 0 the value).
    p : int
        The prime.
    K : int
        Number of orders to allocate.
    state_rhs : sequence of int
        For each state source (the first ones of ``plan.sources``): its right-hand side node.
    given : callable
        ``given(k)`` returns the coefficients ``k`` of the other sources, ``(n_other, M + 1)``.
    tv : sequence of bool
        Time variation per node (a time-invariant right-hand side has no coefficients ``k >= 1``).
    """

    def __init__(
        self,
        plan: Plan,
        X0: np.ndarray,
        p: int,
        K: int,
        state_rhs: Sequence[int],
        given: Callable[[int], np.ndarray],
        tv: Sequence[bool],
    ) -> None:
        self.plan, self.X0, self.p, self.K = plan, X0, p, K
        self.given = given
        M1 = X0.shape[1]
        self.M1 = M1
        self.rpos = {x: r for r, x in enumerate(plan.rows)}
        self.n_state = len(state_rhs)
        self.state_rhs = np.asarray(state_rhs, dtype=np.int64)
        self.rhs_tv = [r for r, f in enumerate(state_rhs) if tv[f]]
        self.rhs_tv_rows = [self.rpos[state_rhs[r]] for r in self.rhs_tv]
        self._tangent()
        conv = plan.conv
        nr = len(plan.rows)
        # history terms sum_j u'[j] v[k-j]: u' is u (products, quotients) or j*u[j] (atoms: the
        # weights j/k are j*u[j] summed, then 1/k); a root has both, ((r+1) j - k)/k
        t_u, t_v, t_c, t_fac, t_byk = [], [], [], [], []
        for ci, c in enumerate(conv):
            u, v = self.rpos[c[2]], self.rpos[c[3]]
            if c[1] in ("mul", "div"):
                terms = [(u, 1, False)]
            elif c[1] == "root":
                terms = [(nr + u, (1 + pow(c[5], -1, p)) % p, True), (u, p - 1, False)]
            else:
                terms = [(nr + u, 1, True)]
            for uu, fac, byk in terms:
                t_u.append(uu)
                t_v.append(v)
                t_c.append(ci)
                t_fac.append(fac)
                t_byk.append(byk)
        self.t_u, self.t_v = t_u, t_v
        self.t_c = np.array(t_c, dtype=np.int64)
        self.t_fac = np.array(t_fac, dtype=np.int64)[:, None]
        self.t_byk = np.array(t_byk, dtype=bool)[:, None]
        self.weighted = bool(any(t_byk))
        self.plain_terms = not self.weighted and all(f == 1 for f in t_fac)
        self.n_conv = len(conv)
        # the kept series, order by order: SS[k, :nr] coefficient k of each row, SS[k, nr:] k times it
        self.SS = np.zeros((K, 2 * nr if self.weighted else nr, M1), dtype=np.int64)
        if nr:
            self.SS[0, :nr] = X0[list(plan.rows)]
        lam = np.array([self._jet(c[4]) for c in conv], dtype=np.int64).reshape(len(conv), M1)
        self.lam_v = lam[:, :1].copy()
        self.lam_g = lam[:, 1:].copy()
        self.lam_trivial = bool(np.all(lam[:, 1:] == 0) and np.all(lam[:, 0] == 1))

    # ------------------------------------------------------------------ constant jets
    def _inv(self, i: int) -> np.ndarray:
        p = self.p
        v, g = int(self.X0[i, 0]), self.X0[i, 1:]
        iv = pow(v, -1, p)
        out = np.empty(self.M1, dtype=np.int64)
        out[0] = iv
        out[1:] = mulmod(g, np.int64((p - iv * iv % p) % p), p)
        return out

    def _mul(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        p = self.p
        out = mulmod(a, b[0], p)
        out[1:] = (out[1:] + mulmod(b[1:], a[0], p)) % p
        return out

    def _jet(self, spec: tuple) -> np.ndarray:
        """The constant jet coded by ``spec`` (see :class:`Plan`)."""
        p = self.p
        kind = spec[0]
        if kind in ("s", "r"):
            out = np.zeros(self.M1, dtype=np.int64)
            out[0] = spec[1] % p if kind == "s" else spec[1] % p * pow(spec[2], -1, p) % p
            return out
        if kind == "j":
            return self.X0[spec[1]].copy()
        if kind == "-j":
            return (p - self.X0[spec[1]]) % p
        if kind == "inv":
            return self._inv(spec[1])
        if kind == "-inv":
            return (p - self._inv(spec[1])) % p
        if kind == "-cb":
            return (p - self._mul(self.X0[spec[1]], self._inv(spec[2]))) % p
        if kind == "root":
            _, w, g, q = spec
            out = self._mul(self.X0[w], self._inv(g))
            return mulmod(out, np.int64(pow(q, -1, p)), p)
        raise ValueError(f"internal: jet code {kind}")  # pragma: no cover

    # ------------------------------------------------------------------ the tangent map
    def _tangent(self) -> None:
        """``T = (I - L)^-1`` restricted to the plan's rows and columns, by forward substitution."""
        plan, p, M1 = self.plan, self.p, self.M1
        nc = len(plan.cols)
        cpos = {x: c for c, x in enumerate(plan.cols)}
        T: dict[int, np.ndarray] = {}
        for s in plan.sources:
            t = np.zeros((nc, M1), dtype=np.int64)
            t[cpos[s], 0] = 1
            T[s] = t
        for node, edges in plan.edges:
            t = np.zeros((nc, M1), dtype=np.int64)
            if node in cpos:
                t[cpos[node], 0] = 1
            for b, spec in edges:
                tb = T[b]
                if spec[0] == "s":  # +1 or -1
                    t = t + tb if spec[1] == 1 else t - tb
                    continue
                mu = self._jet(spec)
                prod = mulmod(tb, mu[0], p)
                if mu[1:].any():
                    prod[:, 1:] += mulmod(tb[:, :1], mu[None, 1:], p)
                t = t + prod
            T[node] = t % p
        rows = np.array([T[x] for x in plan.rows], dtype=np.int64).reshape(len(plan.rows), nc, M1)
        nr = len(plan.rows)
        self.T0 = MatMod(rows[:, :, 0], p)
        # gradient part: (nr*M, nc) acting on the source values
        self.TG = MatMod(rows[:, :, 1:].transpose(0, 2, 1).reshape(nr * (M1 - 1), nc), p)
        self.nc = nc

    # ------------------------------------------------------------------ one order
    def step(self, k: int) -> None:
        """Compute coefficient ``k >= 1`` of every row."""
        p, SS, M1 = self.p, self.SS, self.M1
        R = np.zeros((self.nc, M1), dtype=np.int64)
        ns = self.n_state
        inv_k = np.int64(pow(k, -1, p))
        if k == 1:
            F = self.X0[self.state_rhs]
        else:
            F = np.zeros((ns, M1), dtype=np.int64)
            if self.rhs_tv:
                F[self.rhs_tv] = SS[k - 1, self.rhs_tv_rows]
        R[:ns] = mulmod(F, inv_k, p)
        n_src = len(self.plan.sources)
        if n_src > ns:
            R[ns:n_src] = self.given(k)
        if k >= 2 and self.n_conv:
            U = SS[1:k][:, self.t_u]  # (k-1, terms, M+1): u'[j], j = 1..k-1
            V = SS[k - 1 : 0 : -1][:, self.t_v]  # v[k-j]
            P = mulmod(U[:, :, :1], V, p)
            P[:, :, 1:] += mulmod(V[:, :, :1], U[:, :, 1:], p)
            H = P.sum(axis=0) % p
            if not self.plain_terms:
                fac = np.where(self.t_byk, mulmod(self.t_fac, inv_k, p), self.t_fac)
                H = mulmod(H, fac, p)
                if len(self.t_u) > self.n_conv:  # roots: two terms into one history
                    Hc = np.zeros((self.n_conv, M1), dtype=np.int64)
                    np.add.at(Hc, self.t_c, H)
                    H = Hc % p
            if not self.lam_trivial:
                rho = mulmod(H, self.lam_v, p)
                rho[:, 1:] = (rho[:, 1:] + mulmod(H[:, :1], self.lam_g, p)) % p
                H = rho
            R[n_src:] = H
        X = self.T0 @ R
        if M1 > 1:
            X[:, 1:] = (X[:, 1:] + (self.TG @ R[:, 0]).reshape(-1, M1 - 1)) % p
        nr = X.shape[0]
        SS[k, :nr] = X
        if self.weighted:
            SS[k, nr:] = mulmod(X, np.int64(k), p)

    def gradients(self, nodes: Sequence[int], k: int) -> np.ndarray:
        """Gradient part of coefficient ``k`` of ``nodes`` (time-invariant nodes: 0 for ``k >= 1``)."""
        out = np.zeros((len(nodes), self.M1 - 1), dtype=np.int64)
        for r, x in enumerate(nodes):
            if k == 0:
                out[r] = self.X0[x, 1:]
            elif x in self.rpos:
                out[r] = self.SS[k, self.rpos[x], 1:]
        return out

    def values(self, nodes: Sequence[int], k: int) -> np.ndarray:
        """Value part of coefficient ``k`` of ``nodes`` (time-invariant nodes: 0 for ``k >= 1``)."""
        out = np.zeros(len(nodes), dtype=np.int64)
        for r, x in enumerate(nodes):
            if k == 0:
                out[r] = self.X0[x, 0]
            elif x in self.rpos:
                out[r] = self.SS[k, self.rpos[x], 0]
        return out
