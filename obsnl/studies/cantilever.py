"""The observer-bank benchmark: a clamped Euler-Bernoulli link with a breathing crack.

The link is the flexible arm of the seed paper ``001_d0508a78c5399696.txt`` (N = 6 finite
sub-links, an observer bank at sub-links 2, 4 and 6). Its numbers are read from the packaged
``models/cantilever_link.toml`` (``obsnl:cantilever_link``; :mod:`obsnl.studies.link_model`
reads and checks it), which copies them from the research notes
``docs/observer_bank.md`` (sections 2.1-2.5): 6 Hermite-cubic beam elements, node 0 clamped,
DOFs ``[w_k, theta_k]`` at nodes 1..6 (12 DOF, 24 states ``x = [q; dq/dt]``), consistent
mass and stiffness matrices, Rayleigh damping.

The breathing crack in element ``c`` removes a fraction ``severity`` of the element's
bending stiffness while it is open; it is open when the element's midpoint curvature
``(theta_c - theta_{c-1}) / L_e`` is negative (crack on the upper face). Equivalently it
adds the force ``-severity * K_e q_e`` on the element DOFs while open.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from obsnl.errors import DataError, ModelError
from obsnl.linear.simulation import zoh
from obsnl.linear.systems import LinearSystem
from obsnl.studies.link_model import DEFAULT_LINK_FILE, DOF_NAME, LinkSpec, read_link_spec

# DEFAULT_LINK_FILE, LinkSpec and read_link_spec live in obsnl.studies.link_model; named here as before
__all__ = [
    "DEFAULT_LINK_FILE",
    "LinkSpec",
    "Cantilever",
    "BreathingCrack",
    "LinkSimulation",
    "read_link_spec",
    "build_cantilever",
    "element_channels",
]


def element_channels(le: float, channels: Sequence[str] = ("moment",)) -> np.ndarray:
    """Unit force patterns on an element's DOFs ``[w1, theta1, w2, theta2]``, one column each.

    ``"moment"`` is the moment dipole ``[0, -1, 0, 1]/sqrt(2)`` (the load of a uniform
    curvature change, an eigenvector of ``K_e``); ``"shear"`` is ``[2, L, -2, L]`` normalised
    (``K_e [0, 1, 0, 1]`` up to scale). Together they span ``range(K_e)``.

    Parameters
    ----------
    le : float
        Element length (m).
    channels : sequence of str
        ``"moment"`` and/or ``"shear"``.

    Returns
    -------
    numpy.ndarray
        ``(4, len(channels))``.

    Raises
    ------
    ModelError
        An unknown or no channel.
    """
    cols = []
    for ch in channels:
        if ch == "moment":
            h = np.array([0.0, -1.0, 0.0, 1.0])
        elif ch == "shear":
            h = np.array([2.0, le, -2.0, le])
        else:
            raise ModelError(f"unknown force channel {ch!r}; use 'moment' and/or 'shear'")
        cols.append(h / np.linalg.norm(h))
    if not cols:
        raise ModelError("give at least one force channel ('moment' and/or 'shear')")
    return np.column_stack(cols)


@dataclass(frozen=True)
class BreathingCrack:
    """A crack in ``element`` (1 = root) that breathes from time ``onset`` on.

    While open (negative element curvature) the element loses the fraction ``severity`` of its
    bending stiffness.
    """

    element: int
    severity: float
    onset: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 < self.severity < 1.0:
            raise ModelError(f"crack severity must lie in (0, 1), got {self.severity}")


@dataclass(frozen=True, eq=False)
class LinkSimulation:
    """A noiseless simulated run: time ``t`` (N,), states ``x`` (N, 24), inputs ``u`` (N, m),
    the true crack force projected on the moment dipole ``n_true`` (N,; zero without a crack)
    and the fraction of the post-onset time the crack was open."""

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    n_true: np.ndarray
    open_fraction: float


@dataclass(frozen=True, eq=False)
class Cantilever:
    """Assembled FE model of the clamped link (build it with :func:`build_cantilever`).

    Attributes
    ----------
    spec : LinkSpec
    M, K, D : ndarray
        Mass, stiffness and Rayleigh damping matrices of the free DOFs (12 x 12 for 6 elements),
        ordered ``[w1, theta1, w2, theta2, ...]``.
    Me, Ke : ndarray
        Element mass and stiffness matrices (4 x 4).
    rayleigh : tuple of float
        ``(alpha, beta)`` with ``D = alpha M + beta K``.
    """

    spec: LinkSpec
    M: np.ndarray
    K: np.ndarray
    D: np.ndarray
    Me: np.ndarray
    Ke: np.ndarray
    rayleigh: tuple[float, float]

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    @property
    def element_length(self) -> float:
        return self.spec.length / self.spec.n_elements

    def dof(self, name: str) -> int:
        """Index of a free DOF named ``"w<k>"`` or ``"theta<k>"`` (k = 1..n_elements)."""
        m = DOF_NAME.match(name.strip())
        if not m:
            raise ModelError(f"bad DOF name {name!r}; use 'w<node>' or 'theta<node>', e.g. 'theta3'")
        node = int(m.group(2))
        if not 1 <= node <= self.spec.n_elements:
            raise ModelError(f"{name!r}: node {node} is not a free node (1..{self.spec.n_elements}; node 0 is clamped)")
        return 2 * (node - 1) + (m.group(1) == "theta")

    def gather(self, element: int) -> np.ndarray:
        """``T_e`` (n_dof x 4): maps element DOFs ``[w, theta]`` of its two nodes to free DOFs."""
        ne = self.spec.n_elements
        if not 1 <= int(element) <= ne:
            raise ModelError(f"element {element} does not exist; elements are 1..{ne} (1 = root)")
        T = np.zeros((self.n_dof, 4))
        for local, glob in enumerate(range(2 * (element - 1) - 2, 2 * (element - 1) + 2)):
            if glob >= 0:  # the clamped DOFs of node 0 are dropped
                T[glob, local] = 1.0
        return T

    def modal_frequencies(self) -> np.ndarray:
        """Undamped natural frequencies in Hz, ascending."""
        w2 = sla.eigh(self.K, self.M, eigvals_only=True)
        return np.sqrt(np.abs(w2)) / (2.0 * math.pi)

    def state_matrix(self, K: np.ndarray | None = None) -> np.ndarray:
        """``A = [[0, I], [-M^-1 K, -M^-1 D]]`` (with the given stiffness, default the healthy one)."""
        n = self.n_dof
        K = self.K if K is None else K
        MinvK = np.linalg.solve(self.M, K)
        MinvD = np.linalg.solve(self.M, self.D)
        return np.block([[np.zeros((n, n)), np.eye(n)], [-MinvK, -MinvD]])

    def load_matrix(self, forces: np.ndarray) -> np.ndarray:
        """``[0; M^-1 F]`` for force patterns ``F`` on the free DOFs (n_dof x k)."""
        F = np.atleast_2d(np.asarray(forces, dtype=float).T).T
        return np.vstack([np.zeros_like(F), np.linalg.solve(self.M, F)])

    def output_matrix(self, sensors: str | Sequence[str]) -> np.ndarray:
        """``C`` (p x 2 n_dof) of a sensor set name (``"S1"``) or a list of DOF names."""
        names = self.sensor_names(sensors)
        C = np.zeros((len(names), 2 * self.n_dof))
        for i, nm in enumerate(names):
            C[i, self.dof(nm)] = 1.0
        return C

    def sensor_names(self, sensors: str | Sequence[str]) -> tuple[str, ...]:
        if isinstance(sensors, str):
            if sensors not in self.spec.sensors:
                raise ModelError(f"unknown sensor set {sensors!r}; the model file defines {sorted(self.spec.sensors)}")
            sensors = self.spec.sensors[sensors]
        names = tuple(sensors)
        if not names:
            raise ModelError("a sensor set needs at least one DOF name")
        return names

    def system(self, sensors: str | Sequence[str] = "S1") -> LinearSystem:
        """The healthy link as a :class:`~obsnl.linear.systems.LinearSystem` (inputs: the actuator moments)."""
        nodes = self.spec.actuator_nodes
        F = np.zeros((self.n_dof, len(nodes)))
        for j, k in enumerate(nodes):
            F[self.dof(f"theta{k}"), j] = 1.0
        return LinearSystem(self.state_matrix(), self.load_matrix(F), self.output_matrix(sensors))

    def crack_distribution(self, element: int, channels: Sequence[str] = ("moment",)) -> np.ndarray:
        """``N_R = [0; M^-1 T_e h]`` of the force channels of one element (2 n_dof x s)."""
        return self.load_matrix(self.gather(element) @ element_channels(self.element_length, channels))

    def excitation(self, t: np.ndarray) -> np.ndarray:
        """Actuator moments ``u(t)`` (N x m): the driven node gets ``amplitude sin(2 pi f t)``."""
        t = np.asarray(t, dtype=float)
        u = np.zeros((t.size, len(self.spec.actuator_nodes)))
        j = self.spec.actuator_nodes.index(self.spec.driven_node)
        u[:, j] = self.spec.amplitude * np.sin(2.0 * math.pi * self.spec.frequency * t)
        return u

    def simulate(self, *, dt: float, duration: float, crack: BreathingCrack | None = None) -> LinkSimulation:
        """Simulate the link from rest under :meth:`excitation` with exact zero-order-hold steps.

        With a crack, each step uses the open or closed dynamics according to the sign of the
        crack element's curvature at the start of the step (a bilinear oscillator).
        """
        if not (dt > 0 and duration > dt):
            raise DataError(f"need 0 < dt < duration, got dt={dt}, duration={duration}")
        t = np.arange(int(round(duration / dt)) + 1) * dt
        u = self.excitation(t)
        sysm = self.system()
        n = sysm.A.shape[0]
        phi_c, gam_c = zoh(sysm.A, sysm.B, dt)
        gu_c = u @ gam_c.T
        x = np.zeros((t.size, n))
        n_true = np.zeros(t.size)
        if crack is None:
            for k in range(t.size - 1):
                x[k + 1] = phi_c @ x[k] + gu_c[k]
            return LinkSimulation(t, x, u, n_true, 0.0)
        T = self.gather(crack.element)
        Kc = crack.severity * (T @ self.Ke @ T.T)
        phi_o, gam_o = zoh(self.state_matrix(self.K - Kc), sysm.B, dt)
        gu_o = u @ gam_o.T
        i1, i0 = (
            self.dof(f"theta{crack.element}"),
            (self.dof(f"theta{crack.element - 1}") if crack.element > 1 else None),
        )
        h = element_channels(self.element_length)[:, 0]
        proj = -crack.severity * (h @ self.Ke @ T.T)  # true force on the dipole per unit open state
        is_open = np.zeros(t.size, dtype=bool)
        for k in range(t.size - 1):
            xk = x[k]
            kappa = xk[i1] - (xk[i0] if i0 is not None else 0.0)
            if t[k] >= crack.onset and kappa < 0.0:
                is_open[k] = True
                x[k + 1] = phi_o @ xk + gu_o[k]
            else:
                x[k + 1] = phi_c @ xk + gu_c[k]
        n_true = np.where(is_open, x[:, : self.n_dof] @ proj, 0.0)
        after = t[:-1] >= crack.onset
        frac = float(is_open[:-1][after].mean()) if after.any() else 0.0
        return LinkSimulation(t, x, u, n_true, frac)


def _rayleigh(w_i: float, w_j: float, zeta: float) -> tuple[float, float]:
    """``(alpha, beta)`` giving damping ratio ``zeta`` at circular frequencies ``w_i`` and ``w_j``."""
    sol = np.linalg.solve(np.array([[1.0, w_i**2], [1.0, w_j**2]]), 2.0 * zeta * np.array([w_i, w_j]))
    return float(sol[0]), float(sol[1])


def build_cantilever(spec: LinkSpec | None = None) -> Cantilever:
    """Assemble the clamped link from its spec (default: :func:`read_link_spec` of the model file).

    Examples
    --------
    >>> beam = build_cantilever()
    >>> beam.n_dof, round(float(beam.modal_frequencies()[0]), 2)
    (12, 5.8)
    """
    spec = read_link_spec() if spec is None else spec
    ne, (i, j) = spec.n_elements, spec.damping_modes
    if ne < 2:
        raise ModelError(f"n_elements must be at least 2, got {ne}")
    le = spec.length / ne
    try:  # absurd numbers (SI units) overflow or give no positive frequencies: refused below
        with np.errstate(over="raise", divide="raise", invalid="raise"):
            ei, rho_a = spec.bending_stiffness, spec.mass_per_length
            Ke = (
                ei
                / le**3
                * np.array(
                    [
                        [12, 6 * le, -12, 6 * le],
                        [6 * le, 4 * le**2, -6 * le, 2 * le**2],
                        [-12, -6 * le, 12, -6 * le],
                        [6 * le, 2 * le**2, -6 * le, 4 * le**2],
                    ]
                )
            )
            Me = (
                rho_a
                * le
                / 420.0
                * np.array(
                    [
                        [156, 22 * le, 54, -13 * le],
                        [22 * le, 4 * le**2, 13 * le, -3 * le**2],
                        [54, 13 * le, 156, -22 * le],
                        [-13 * le, -3 * le**2, -22 * le, 4 * le**2],
                    ]
                )
            )
            nfull = 2 * (ne + 1)
            Mf, Kf = np.zeros((nfull, nfull)), np.zeros((nfull, nfull))
            for e in range(ne):
                s = slice(2 * e, 2 * e + 4)
                Mf[s, s] += Me
                Kf[s, s] += Ke
            M, K = Mf[2:, 2:], Kf[2:, 2:]
            w = np.sqrt(sla.eigh(K, M, eigvals_only=True))
            alpha, beta = _rayleigh(w[i - 1], w[j - 1], spec.zeta)
    except (ArithmeticError, ValueError, IndexError, np.linalg.LinAlgError):
        alpha = beta = math.nan
    if not (math.isfinite(alpha) and math.isfinite(beta) and np.all(np.isfinite(w)) and w[0] > 0):
        raise ModelError(
            "the [structure] and [damping] numbers give a link without finite positive natural "
            "frequencies; check youngs_modulus, density, the dimensions (SI units) and modes"
        )
    return Cantilever(spec, M, K, alpha * M + beta * K, Me, Ke, (alpha, beta))
