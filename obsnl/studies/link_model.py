"""Reading a link model file (the observer-bank benchmark's numbers) into a checked :class:`LinkSpec`.

The file is untrusted TOML (the packaged one is ``models/cantilever_link.toml``,
``obsnl:cantilever_link``): every table and key is read with its type and range checked
(:class:`LinkTable`), and every refusal is one line naming the file, table, key and value and the fix,
before anything is computed. :mod:`obsnl.studies.cantilever` builds the finite-element model from it.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from obsnl._types import FileValue
from obsnl.errors import ModelError
from obsnl.model.files import PACKAGED, catalogue_path, parse_text

__all__ = [
    "DEFAULT_LINK_FILE",
    "LinkSpec",
    "read_link_spec",
    "MAX_ELEMENTS",
    "MAX_FILE_BYTES",
    "OPENS_WHEN",
    "DOF_NAME",
    "LinkTable",
]

#: The benchmark's data file (packaged with obsnl).
DEFAULT_LINK_FILE = catalogue_path("cantilever_link")

#: A free DOF's name, ``w<k>`` (deflection) or ``theta<k>`` (rotation) at node ``k``: group 1 the kind, group 2
#: the node (its range is the model's to check: 1..n_elements, node 0 clamped).
DOF_NAME = re.compile(r"^(w|theta)(\d+)$")


@dataclass(frozen=True)
class LinkSpec:
    """The benchmark's numbers, as read from the model file (SI units).

    ``sensors`` maps a sensor-set name to DOF names (``"theta3"``, ``"w6"``); ``bank`` holds the ``[bank]`` table
    as written, its TOML values unchecked (:func:`obsnl.studies.link_study.check_bank_settings` checks them);
    ``opens_when`` is one of :data:`OPENS_WHEN`; ``file`` names the file read.
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
    bank: Mapping[str, FileValue] = field(default_factory=dict)
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
_SEE = "see the packaged models/cantilever_link.toml"
_KEYS = {
    "": ("name", "description", "source", "structure", "damping", "excitation", "sensors", "crack", "bank"),
    "structure": ("youngs_modulus", "density", "length", "width", "height", "n_elements"),
    "damping": ("zeta", "modes"),
    "crack": ("severity", "opens_when"),
    "excitation": ("actuator_nodes", "driven_node", "amplitude", "frequency"),
}


class LinkTable:
    """One table of a link model file with typed, range-checked reads; errors name file, table, key and value.

    Parameters
    ----------
    doc : mapping
        The parsed file, or the mapping that holds the table (``{"": doc}`` reads the file's top level).
    name : str
        The table's name (``"structure"``, ``"bank"``; ``""`` for the top level).
    where : str
        The file's name, the start of every refusal.
    keys : sequence of str or None
        The keys the table may have (None: any).

    Raises
    ------
    ModelError
        The table is missing or not a table, or it has a key not in ``keys``.

    Examples
    --------
    >>> t = LinkTable({"damping": {"zeta": 0.02}}, "damping", "my.toml", ("zeta", "modes"))
    >>> t.number("zeta", 0.0, 1.0)
    0.02
    >>> t.whole("zeta")
    Traceback (most recent call last):
    ...
    obsnl.errors.ModelError: my.toml: [damping] zeta = 0.02 is not a whole number; write an integer such as 6
    """

    def __init__(self, doc: Mapping[str, Any], name: str, where: str, keys: Sequence[str] | None = None) -> None:
        if not isinstance(doc.get(name), Mapping):
            raise ModelError(f"{where}: {'missing table' if name not in doc else 'expected a table'} [{name}]; {_SEE}")
        self.data, self.name, self.where = doc[name], name, where
        extra = [k for k in self.data if keys is not None and k not in keys]
        if extra:
            raise ModelError(
                f"{where}: unknown key {extra[0]!r} in {f'[{name}]' if name else 'the file'}; the keys "
                f"there are {', '.join(keys or ())}"
            )

    def fail(self, key: str, problem: str) -> ModelError:
        """The refusal of ``key``'s value: one line naming the file, the table, the key and the value (cut at 60
        characters), then ``problem``.

        Parameters
        ----------
        key : str
            The key refused.
        problem : str
            What is wrong, and the fix.

        Returns
        -------
        ModelError
            To raise.
        """
        s = repr(self.data.get(key)).replace("\n", " ")
        return ModelError(f"{self.where}: [{self.name}] {key} = {s if len(s) <= 60 else s[:57] + '...'} {problem}")

    def raw(self, key: str) -> Any:
        """``key``'s value as written.

        Parameters
        ----------
        key : str
            The key.

        Returns
        -------
        Any

        Raises
        ------
        ModelError
            The table lacks the key.
        """
        if key in self.data:
            return self.data[key]
        raise ModelError(f"{self.where}: [{self.name}] lacks the key '{key}'; add it ({_SEE})")

    def number(self, key: str, lo: float = 0.0, hi: float = math.inf, *, closed: bool = False) -> float:
        """A finite number in ``(lo, hi)`` (``[lo, hi]`` with ``closed``), not a string or a boolean.

        Parameters
        ----------
        key : str
            The key.
        lo : float
            The lower bound (default 0).
        hi : float
            The upper bound (default none).
        closed : bool
            The bounds are allowed.

        Returns
        -------
        float

        Raises
        ------
        ModelError
            A missing key, not a finite number, or out of range.
        """
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
        """A whole number (``6`` or ``6.0``; not ``6.7``, ``"6"`` or ``true``) in ``lo..hi``.

        Parameters
        ----------
        key : str
            The key.
        v : Any
            An item of ``key``'s list to check (None: ``key``'s value).
        lo : int or None
            The smallest number allowed (None: no bound).
        hi : int or None
            The largest number allowed (None: no bound).
        what : str
            Added to an out-of-range refusal (e.g. which numbers are nodes).

        Returns
        -------
        int

        Raises
        ------
        ModelError
            Not a whole number, or out of range.
        """
        one = v is None
        v = self.raw(key) if one else v
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (isinstance(v, int) or v.is_integer()):
            raise self.fail(
                key,
                "is not a whole number; write an integer such as 6"
                if one
                else f"must hold whole numbers; {v!r} is not one",
            )
        if (lo is not None and int(v) < lo) or (hi is not None and int(v) > hi):
            raise self.fail(
                key,
                (f"is outside {lo}..{hi}" if one else f"contains {int(v)}, outside {lo}..{hi}") + what
                if hi is not None
                else f"must be at least {lo}",
            )
        return int(v)

    def items(
        self,
        key: str,
        kind: str,
        *,
        lo: int = 1,
        hi: int = 0,
        what: str = "",
        choices: Sequence[str] | None = None,
        empty: bool = False,
    ) -> tuple[Any, ...]:
        """A list of distinct ``kind``: ``"whole numbers"`` (in ``lo..hi``) or ``"strings"``.

        Parameters
        ----------
        key : str
            The key.
        kind : str
            ``"whole numbers"`` or ``"strings"``.
        lo : int
            The smallest whole number allowed.
        hi : int
            The largest whole number allowed.
        what : str
            Added to an out-of-range refusal.
        choices : sequence of str or None
            The values allowed (None: any).
        empty : bool
            An empty list is allowed.

        Returns
        -------
        tuple

        Raises
        ------
        ModelError
            Not a list (or an empty one without ``empty``), an item of the wrong kind, out of range or not one of
            ``choices``, or an item listed twice.
        """
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


def read_link_spec(path: str | Path | None = None) -> LinkSpec:
    """Read the benchmark's numbers from a TOML file, checking every value (the ``[bank]`` table is kept as
    written; :func:`obsnl.studies.link_study.check_bank_settings` checks it).

    Parameters
    ----------
    path : str or Path or None
        A link model file, ``obsnl:cantilever_link`` or None (the packaged ``models/cantilever_link.toml``).

    Raises
    ------
    ModelError
        One line naming the file (missing, a folder, over :data:`MAX_FILE_BYTES`, not TOML), or the table,
        key and value that is missing, of the wrong type or out of range.
    """
    if isinstance(path, str) and path.startswith(PACKAGED):
        path = catalogue_path(path[len(PACKAGED) :])
    p = Path(path) if path is not None else DEFAULT_LINK_FILE
    if not p.is_file():
        why = "is a folder" if p.is_dir() else "is not a regular file" if p.exists() else "not found"
        raise ModelError(
            f"link model file {str(p)!r} {why}; give a .toml file such as the packaged "
            f"models/cantilever_link.toml, or obsnl:cantilever_link"
        )
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
    if "equations" in doc and "structure" not in doc:  # a model file of the analyses (obsnl:bouc_wen, ...)
        raise ModelError(
            f"{where} is a model of equations, not a link model; bank reads a link model such as "
            f"obsnl:cantilever_link ({_SEE[4:]})"
        )
    LinkTable({"": doc}, "", where, _KEYS[""])
    st = LinkTable(doc, "structure", where, _KEYS["structure"])
    dims = {k: st.number(k) for k in _KEYS["structure"][:5]}
    ne = st.whole("n_elements", lo=2)
    if ne > MAX_ELEMENTS:
        raise st.fail(
            "n_elements",
            f"is over the limit of {MAX_ELEMENTS} elements (the benchmark has 6; memory grows "
            f"with the square and time with the cube); use at most {MAX_ELEMENTS}",
        )
    nodes = f" (free nodes are 1..{ne}; node 0 is clamped)"
    dm = LinkTable(doc, "damping", where, _KEYS["damping"])
    zeta, modes = dm.number("zeta", 0.0, 1.0), dm.items("modes", "whole numbers", hi=2 * ne)
    if len(modes) != 2:
        raise dm.fail("modes", "must name two different modes, e.g. [1, 3]")
    ex = LinkTable(doc, "excitation", where, _KEYS["excitation"])
    actuators, driven = ex.items("actuator_nodes", "whole numbers", hi=ne, what=nodes), ex.whole("driven_node", lo=None)
    if driven not in actuators:
        raise ex.fail("driven_node", f"is not one of the actuator_nodes {list(actuators)}; drive one of them")
    se = LinkTable(doc, "sensors", where)
    sensors = {k: se.items(k, "strings") for k in se.data if k != "noise"}
    bad = [(k, d) for k, v in sensors.items() for d in v if not ((m := DOF_NAME.match(d)) and 0 < int(m[2]) <= ne)]
    if bad:
        raise se.fail(bad[0][0], f"contains {bad[0][1]!r}, not a free DOF; use 'w<k>' or 'theta<k>'{nodes}")
    if not sensors:
        raise ModelError(f'{where}: [sensors] defines no sensor set; add one, e.g. S1 = ["theta1", "w6"]')
    cr = LinkTable(doc, "crack", where, _KEYS["crack"])
    if (opens := cr.data.get("opens_when", OPENS_WHEN[0])) not in OPENS_WHEN:
        raise cr.fail("opens_when", f"is not a crack-opening rule obsnl simulates; use {_choices(OPENS_WHEN)}")
    bank = LinkTable(doc, "bank", where).data if "bank" in doc else {}
    return LinkSpec(
        **dims,
        n_elements=ne,
        zeta=zeta,
        damping_modes=modes,
        actuator_nodes=actuators,
        driven_node=driven,
        amplitude=ex.number("amplitude"),
        frequency=ex.number("frequency"),
        sensors=MappingProxyType(sensors),
        noise=se.number("noise", 0, 10),
        severity=cr.number("severity", 0, 1),
        bank=MappingProxyType(dict(bank)),
        source=str(doc.get("source", "")),
        opens_when=opens,
        file=where,
    )
