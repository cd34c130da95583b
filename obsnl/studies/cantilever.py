"""The observer-bank benchmark: a clamped Euler-Bernoulli link with a breathing crack.

The link is the flexible arm of the seed paper ``001_d0508a78c5399696.txt`` (N = 6 finite
sub-links, an observer bank at sub-links 2, 4 and 6). Its numbers are read from the packaged
``obsnl/catalogue/cantilever_link.toml`` (``obsnl:cantilever_link``), which copies them from the research notes
``observer_bank.md`` (sections 2.1-2.5): 6 Hermite-cubic beam elements, node 0 clamped,
DOFs ``[w_k, theta_k]`` at nodes 1..6 (12 DOF, 24 states ``x = [q; dq/dt]``), consistent
mass and stiffness matrices, Rayleigh damping.

The breathing crack in element ``c`` removes a fraction ``severity`` of the element's
bending stiffness while it is open; it is open when the element's midpoint curvature
``(theta_c - theta_{c-1}) / L_e`` is negative (crack on the upper face). Equivalently it
adds the force ``-severity * K_e q_e`` on the element DOFs while open.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import scipy.linalg as sla

from obsnl.errors import DataError, ModelError
from obsnl.model.files import PACKAGED, catalogue_path, parse_text
from obsnl.linear.systems import LinearSystem
from obsnl.linear.observer import zoh

__all__ = ["DEFAULT_LINK_FILE", "LinkSpec", "Cantilever", "BreathingCrack", "LinkSimulation", "load_link_spec",
           "MAX_ELEMENTS", "OPENS_WHEN", "build_cantilever", "element_channels"]

#: The benchmark's data file (packaged with obsnl).
DEFAULT_LINK_FILE = catalogue_path("cantilever_link")

_DOF_NAME = re.compile(r"^(w|theta)(\d+)$")


@dataclass(frozen=True)
class LinkSpec:
    """The benchmark's numbers, as read from the model file (SI units).

    ``sensors`` maps a sensor-set name to DOF names (``"theta3"``, ``"w6"``); ``bank`` holds the ``[bank]`` table
    as written (:func:`obsnl.studies.link_study.check_bank_settings` checks it); ``opens_when`` is one of
    :data:`OPENS_WHEN`; ``file`` names the file read.
    """

    youngs_modulus: float
    density: float
    length: float
    width: float
    height: float
    n_elements: int
    zeta: float
    damping_modes: tuple[int, int]
    actuator_nodes: tuple[int, ...]
    driven_node: int
    amplitude: float
    frequency: float
    sensors: Mapping[str, tuple[str, ...]]
    noise: float
    severity: float
    bank: Mapping[str, Any] = field(default_factory=dict)
    source: str = ""
    opens_when: str = "negative curvature"
    file: str = ""

    @property
    def bending_stiffness(self) -> float:
        """EI in N m^2."""
        return self.youngs_modulus * self.width * self.height**3 / 12.0

    @property
    def mass_per_length(self) -> float:
        """rho A in kg/m."""
        return self.density * self.width * self.height


#: Most elements a link model may have (the benchmark has 6; memory grows with the square, time with the cube).
MAX_ELEMENTS = 50
#: Largest link model file read, in bytes (the packaged one has about 3 kB).
MAX_FILE_BYTES = 1_000_000
#: The crack-opening rules the simulation implements (``[crack] opens_when``).
OPENS_WHEN = ("negative curvature",)
_SEE = "see the packaged obsnl/catalogue/cantilever_link.toml"
_KEYS = {"": ("name", "description", "source", "structure", "damping", "excitation", "sensors", "crack", "bank"),
         "structure": ("youngs_modulus", "density", "length", "width", "height", "n_elements"),
         "damping": ("zeta", "modes"), "crack": ("severity", "opens_when"),
         "excitation": ("actuator_nodes", "driven_node", "amplitude", "frequency")}


class _Table:
    """One table of a link model file with typed, range-checked reads; errors name file, table, key and value."""

    def __init__(self, doc: Mapping[str, Any], name: str, where: str, keys: Sequence[str] | None = None) -> None:
        if not isinstance(doc.get(name), Mapping):
            raise ModelError(f"{where}: {'missing table' if name not in doc else 'expected a table'} [{name}]; {_SEE}")
        self.data, self.name, self.where = doc[name], name, where
        extra = [k for k in self.data if keys is not None and k not in keys]
        if extra:
            raise ModelError(f"{where}: unknown key {extra[0]!r} in {f'[{name}]' if name else 'the file'}; the keys "
                             f"there are {', '.join(keys or ())}")

    def fail(self, key: str, problem: str) -> ModelError:
        s = repr(self.data.get(key)).replace("\n", " ")
        return ModelError(f"{self.where}: [{self.name}] {key} = {s if len(s) <= 60 else s[:57] + '...'} {problem}")

    def raw(self, key: str) -> Any:
        if key in self.data:
            return self.data[key]
        raise ModelError(f"{self.where}: [{self.name}] lacks the key '{key}'; add it ({_SEE})")

    def number(self, key: str, lo: float = 0.0, hi: float = math.inf, *, closed: bool = False) -> float:
        """A finite number in ``(lo, hi)`` (``[lo, hi]`` with ``closed``), not a string or a boolean."""
        v = self.raw(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(key, f"is not a number; write a plain number ({_SEE})")
        x = float(v) if isinstance(v, float) or abs(v) < 2**1000 else math.inf  # no OverflowError
        if not math.isfinite(x):
            raise self.fail(key, "is not a finite number; write a finite number")
        if not ((lo <= x <= hi) if closed else (lo < x < hi)):
            top = f" and {'<=' if closed else '<'} {hi:g}" if hi < math.inf else ""
            raise self.fail(key, f"is out of range; it must be {'>=' if closed else '>'} {lo:g}{top}")
        return x

    def whole(self, key: str, v: Any = None, lo: int | None = 1, hi: int | None = None, what: str = "") -> int:
        """A whole number (``6`` or ``6.0``; not ``6.7``, ``"6"`` or ``true``) in ``lo..hi``."""
        one = v is None
        v = self.raw(key) if one else v
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (isinstance(v, int) or v.is_integer()):
            raise self.fail(key, "is not a whole number; write an integer such as 6" if one else
                            f"must hold whole numbers; {v!r} is not one")
        if (lo is not None and int(v) < lo) or (hi is not None and int(v) > hi):
            raise self.fail(key, (f"is outside {lo}..{hi}" if one else f"contains {int(v)}, outside {lo}..{hi}")
                            + what if hi is not None else f"must be at least {lo}")
        return int(v)

    def items(self, key: str, kind: str, *, lo: int = 1, hi: int = 0, what: str = "",
              choices: Sequence[str] | None = None, empty: bool = False) -> tuple[Any, ...]:
        """A list of distinct ``kind``: ``"whole numbers"`` (in ``lo..hi``) or ``"strings"``."""
        v = self.raw(key)
        if not isinstance(v, list) or not (v or empty):
            raise self.fail(key, f"must be a {'' if empty else 'non-empty '}list of {kind}")
        v = [self.whole(key, x, lo, hi, what) for x in v] if kind == "whole numbers" else v
        for x in v:
            if kind == "strings" and not isinstance(x, str):
                raise self.fail(key, f"must hold strings; {x!r} is not one")
            if choices is not None and x not in choices:
                raise self.fail(key, f"contains {x!r}; use {_choices(choices)}")
            if v.count(x) > 1:
                raise self.fail(key, f"lists {x!r} twice; list each once")
        return tuple(v)


def _choices(choices: Sequence[str]) -> str:
    return f"one of {', '.join(map(repr, choices))}" if len(choices) > 1 else f"{choices[0]!r} (the only one obsnl has)"


def load_link_spec(path: str | Path | None = None) -> LinkSpec:
    """Read the benchmark's numbers from a TOML file, checking every value (the ``[bank]`` table is kept as
    written; :func:`obsnl.studies.link_study.check_bank_settings` checks it).

    Parameters
    ----------
    path
        A link model file, ``obsnl:cantilever_link`` or None (the packaged ``obsnl/catalogue/cantilever_link.toml``).

    Raises
    ------
    ModelError
        One line naming the file (missing, a folder, over :data:`MAX_FILE_BYTES`, not TOML), or the table,
        key and value that is missing, of the wrong type or out of range.
    """
    if isinstance(path, str) and path.startswith(PACKAGED):
        path = catalogue_path(path[len(PACKAGED):])
    p = Path(path) if path is not None else DEFAULT_LINK_FILE
    if not p.is_file():
        why = "is a folder" if p.is_dir() else "is not a regular file" if p.exists() else "not found"
        raise ModelError(f"link model file {str(p)!r} {why}; give a .toml file such as the packaged "
                         f"obsnl/catalogue/cantilever_link.toml, or obsnl:cantilever_link")
    try:
        with p.open("rb") as fh:
            raw = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ModelError(f"cannot read the link model file {str(p)!r}: {exc.strerror or exc}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise ModelError(f"{p.name} is over the limit of {MAX_FILE_BYTES:,} bytes for a link model file ({_SEE})")
    try:
        doc = parse_text(raw.decode("utf-8"), kind="toml", where=p.name)
    except UnicodeDecodeError:
        raise ModelError(f"{p.name} is not UTF-8 text") from None
    return _parse(doc, p.name)


def _parse(doc: dict[str, Any], where: str) -> LinkSpec:
    """A checked :class:`LinkSpec` from the tables of a link model file."""
    _Table({"": doc}, "", where, _KEYS[""])
    st = _Table(doc, "structure", where, _KEYS["structure"])
    dims = {k: st.number(k) for k in _KEYS["structure"][:5]}
    ne = st.whole("n_elements", lo=2)
    if ne > MAX_ELEMENTS:
        raise st.fail("n_elements", f"is over the limit of {MAX_ELEMENTS} elements (the benchmark has 6; memory grows "
                                    f"with the square and time with the cube); use at most {MAX_ELEMENTS}")
    nodes = f" (free nodes are 1..{ne}; node 0 is clamped)"
    dm = _Table(doc, "damping", where, _KEYS["damping"])
    zeta, modes = dm.number("zeta", 0.0, 1.0), dm.items("modes", "whole numbers", hi=2 * ne)
    if len(modes) != 2:
        raise dm.fail("modes", "must name two different modes, e.g. [1, 3]")
    ex = _Table(doc, "excitation", where, _KEYS["excitation"])
    actuators, driven = ex.items("actuator_nodes", "whole numbers", hi=ne, what=nodes), ex.whole("driven_node", lo=None)
    if driven not in actuators:
        raise ex.fail("driven_node", f"is not one of the actuator_nodes {list(actuators)}; drive one of them")
    se = _Table(doc, "sensors", where)
    sensors = {k: se.items(k, "strings") for k in se.data if k != "noise"}
    bad = [(k, d) for k, v in sensors.items() for d in v if not ((m := _DOF_NAME.match(d)) and 0 < int(m[2]) <= ne)]
    if bad:
        raise se.fail(bad[0][0], f"contains {bad[0][1]!r}, not a free DOF; use 'w<k>' or 'theta<k>'{nodes}")
    if not sensors:
        raise ModelError(f"{where}: [sensors] defines no sensor set; add one, e.g. S1 = [\"theta1\", \"w6\"]")
    cr = _Table(doc, "crack", where, _KEYS["crack"])
    if (opens := cr.data.get("opens_when", OPENS_WHEN[0])) not in OPENS_WHEN:
        raise cr.fail("opens_when", f"is not a crack-opening rule obsnl simulates; use {_choices(OPENS_WHEN)}")
    bank = _Table(doc, "bank", where).data if "bank" in doc else {}
    return LinkSpec(
        **dims, n_elements=ne, zeta=zeta, damping_modes=modes, actuator_nodes=actuators, driven_node=driven,
        amplitude=ex.number("amplitude"), frequency=ex.number("frequency"), sensors=MappingProxyType(sensors),
        noise=se.number("noise", 0, 10), severity=cr.number("severity", 0, 1), bank=MappingProxyType(dict(bank)),
        source=str(doc.get("source", "")), opens_when=opens, file=where,
    )


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
        m = _DOF_NAME.match(name.strip())
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
        i1, i0 = self.dof(f"theta{crack.element}"), (self.dof(f"theta{crack.element - 1}") if crack.element > 1 else None)
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
    """Assemble the clamped link from its spec (default: :func:`load_link_spec` of the model file).

    Examples
    --------
    >>> beam = build_cantilever()
    >>> beam.n_dof, round(float(beam.modal_frequencies()[0]), 2)
    (12, 5.8)
    """
    spec = load_link_spec() if spec is None else spec
    ne, (i, j) = spec.n_elements, spec.damping_modes
    if ne < 2:
        raise ModelError(f"n_elements must be at least 2, got {ne}")
    le = spec.length / ne
    try:  # absurd numbers (SI units) overflow or give no positive frequencies: refused below
        with np.errstate(over="raise", divide="raise", invalid="raise"):
            ei, rho_a = spec.bending_stiffness, spec.mass_per_length
            Ke = ei / le**3 * np.array(
                [[12, 6 * le, -12, 6 * le], [6 * le, 4 * le**2, -6 * le, 2 * le**2],
                 [-12, -6 * le, 12, -6 * le], [6 * le, 2 * le**2, -6 * le, 4 * le**2]]
            )
            Me = rho_a * le / 420.0 * np.array(
                [[156, 22 * le, 54, -13 * le], [22 * le, 4 * le**2, 13 * le, -3 * le**2],
                 [54, 13 * le, 156, -22 * le], [-13 * le, -3 * le**2, -22 * le, 4 * le**2]]
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
        raise ModelError("the [structure] and [damping] numbers give a link without finite positive natural "
                         "frequencies; check youngs_modulus, density, the dimensions (SI units) and modes")
    return Cantilever(spec, M, K, alpha * M + beta * K, Me, Ke, (alpha, beta))
