"""The modal summary as text: one line per mode (frequency, damping ratio, each with its std, and the shape at the
measured outputs), as ``obsnl identify`` prints it for an oscillatory model.

The value is a :class:`obsnl.identification.modal.Modal`, read through the protocol :class:`ModalSummary` (the
report room does not import the identification room).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Protocol

__all__ = ["ModalSummary", "modal_lines"]


class ModalSummary(Protocol):
    """What :func:`modal_lines` reads of a :class:`~obsnl.identification.modal.Modal`."""

    @property
    def frequency_hz(self) -> Sequence[float]: ...
    @property
    def frequency_hz_std(self) -> Sequence[float | None]: ...
    @property
    def damping_ratio(self) -> Sequence[float]: ...
    @property
    def damping_ratio_std(self) -> Sequence[float | None]: ...
    @property
    def shapes(self) -> Sequence[Mapping[str, float]]: ...
    @property
    def real_poles(self) -> Sequence[float]: ...


def _std(v: float | None, scale: float = 1.0) -> str:
    return "-" if v is None else f"{scale * v:.2g}"


def modal_lines(modal: ModalSummary, *, indent: str = "  ") -> list[str]:
    """The modes as lines of text: a heading, then per mode its frequency and damping ratio with their std and its
    shape (largest entry 1).

    Parameters
    ----------
    modal : Modal
        The modal summary.
    indent : str
        Put before every line.

    Returns
    -------
    list of str

    Examples
    --------
    >>> from types import SimpleNamespace as M
    >>> m = M(frequency_hz=[1.8794], frequency_hz_std=[4.2e-6], damping_ratio=[0.01181], damping_ratio_std=[2.4e-6],
    ...       shapes=[{"y1": 0.535, "y2": 1.0}], real_poles=[])
    >>> print("\\n".join(modal_lines(m)))
      modes of the model linearised at rest (std from the estimates' covariance):
        mode 1   1.879 Hz (std 4.2e-06)   damping 1.181 % (std 0.00024)   shape y1 +0.535, y2 +1
    """
    lines = [f"{indent}modes of the model linearised at rest (std from the estimates' covariance):"]
    for i, (f, fs, z, zs, sh) in enumerate(
        zip(modal.frequency_hz, modal.frequency_hz_std, modal.damping_ratio, modal.damping_ratio_std, modal.shapes)
    ):
        shape = ", ".join(f"{o} {a:+.3g}" for o, a in sh.items())
        lines.append(
            f"{indent}  mode {i + 1:<3d} {f:.4g} Hz (std {_std(fs)})   damping {100 * z:.4g} % "
            f"(std {_std(zs, 100)})   shape {shape}"
        )
    if modal.real_poles:
        lines.append(f"{indent}  real poles (1/s, no oscillation): " + ", ".join(f"{p:.4g}" for p in modal.real_poles))
    return lines
