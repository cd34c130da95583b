"""Multi-storey shear buildings with a hysteretic element per storey: the standard case of structural
identification, as obsnl models.

:func:`bouc_wen_building` writes the model of an ``n``-storey shear building under a ground
acceleration ``ag``: floor ``i`` has displacement ``x_i`` and velocity ``v_i`` relative to the ground,
storey ``i`` (between floors ``i-1`` and ``i``, floor 0 the ground) has a viscous damper ``c_i``, a linear
spring ``k_i`` and a Bouc-Wen hysteretic force ``kh_i z_i`` with::

    z_i' = A d_i - beta_i |d_i| |z_i|^(n-1) z_i - gamma_i d_i |z_i|^n,    d_i = v_i - v_{i-1},

``A = 1`` and ``n = 2`` known (so ``|z|^(n-1) z = |z| z`` and ``|z|^n = z**2``). Masses are given numbers
(unit masses by default). Every floor's absolute acceleration ``a_i = v_i' + ag`` is measured.
Per storey: 3 states, 5 parameters, 2 switching functions (``d_i`` and ``z_i``).
"""

from __future__ import annotations

from collections.abc import Sequence

from obsnl.errors import OptionError
from obsnl.model.core import Model

__all__ = ["bouc_wen_building"]


def bouc_wen_building(n: int, *, masses: Sequence[float] | None = None, measured: Sequence[int] | None = None) -> Model:
    """The ``n``-storey Bouc-Wen shear building (module docstring).

    Parameters
    ----------
    n : int
        Number of storeys (at least 1).
    masses : sequence of float or None
        Floor masses (default: all 1).
    measured : sequence of int or None
        Floors whose absolute acceleration is measured (1-based; default: every floor).

    Returns
    -------
    Model
        States ``x_i, v_i, z_i``; parameters ``c_i, k_i, kh_i, beta_i, gamma_i``; input ``ag``.

    Raises
    ------
    OptionError
        ``n < 1``, masses of the wrong length or not positive, an unknown floor.

    References
    ----------
    .. [1] R. Bouc, "Forced vibrations of mechanical systems with hysteresis", Proc. 4th Conference on Nonlinear
       Oscillations, Prague, 1967.
    .. [2] Y.-K. Wen, "Method for random vibration of hysteretic systems", J. Engineering Mechanics Division (ASCE)
       102(2), 249-263, 1976. doi:10.1061/JMCEA3.0002106

    Examples
    --------
    >>> m = bouc_wen_building(2)
    >>> len(m.states), len(m.parameters), m.output_names
    (6, 10, ('a_1', 'a_2'))
    """
    if not isinstance(n, int) or isinstance(n, bool) or n < 1:
        raise OptionError(f"a building needs at least one storey, got {n!r}")
    mass = [1.0] * n if masses is None else [float(x) for x in masses]
    if len(mass) != n or any(not x > 0 for x in mass):
        raise OptionError(f"give {n} positive floor masses, got {masses!r}")
    floors = list(range(1, n + 1)) if measured is None else list(measured)
    if not floors or any(f not in range(1, n + 1) for f in floors):
        raise OptionError(f"measured floors must lie in 1..{n}, got {measured!r}")

    def drift(i: int) -> str:
        return f"x{i}" if i == 1 else f"(x{i} - x{i - 1})"

    def rate(i: int) -> str:
        return f"v{i}" if i == 1 else f"(v{i} - v{i - 1})"

    def force(i: int) -> str:  # the storey-i force on floor i (restoring, positive up the drift)
        return f"(c{i}*{rate(i)} + k{i}*{drift(i)} + kh{i}*z{i})"

    states, eqs, outs = [], {}, {}
    for i in range(1, n + 1):
        states += [f"x{i}", f"v{i}", f"z{i}"]
        above = f" + {force(i + 1)}" if i < n else ""
        rel = f"(-{force(i)}{above})/{mass[i - 1]!r}"
        eqs[f"x{i}"] = f"v{i}"
        eqs[f"v{i}"] = f"{rel} - ag"
        eqs[f"z{i}"] = f"{rate(i)} - beta{i}*Abs({rate(i)})*Abs(z{i})*z{i} - gamma{i}*{rate(i)}*z{i}**2"
        if i in floors:
            outs[f"a_{i}"] = rel
    params = [f"{p}{i}" for i in range(1, n + 1) for p in ("c", "k", "kh", "beta", "gamma")]
    return Model(
        name=f"bouc_wen_building_{n}",
        description=f"{n}-storey Bouc-Wen shear building, floor accelerations measured",
        source="obsnl.studies.buildings",
        states=states,
        parameters=params,
        inputs=["ag"],
        equations=eqs,
        outputs=outs,
    )
