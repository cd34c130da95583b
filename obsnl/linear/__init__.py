"""linear: observability and observers of linear structures.

Owns the Kalman rank and Hautus (PBH) tests with scaling (``systems``, ``hautus``), extended disturbance / PI
observers and their gains (``observer``, ``gains``), their zero-order-hold simulation (``simulation``) and the
observer bank that detects and locates a fault such as a crack (``bank``). Numbers only: a linear system is
given as matrices, and the answer is the observability room's ``Verdict``.

May import: ``errors``, ``_text``, ``_exports``, ``observability.verdicts``.
Must never import: ``model``, ``algebra``, ``recombination``, ``estimation``, ``report``, ``identification``,
``studies``, ``design``, ``batch``, ``cli``.
"""

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "LinearSystem": "systems",
    "as_linear_system": "systems",
    "system_scaling": "systems",
    "kalman_rank": "systems",
    "KalmanRankResult": "systems",
    "HautusResult": "hautus",
    "integrator": "observer",
    "oscillator": "observer",
    "extend": "observer",
    "extended_observability": "observer",
    "riccati_gain": "gains",
    "place_gain": "gains",
    "simulate_observer": "simulation",
    "build_bank": "bank",
    "ObserverBank": "bank",
    "calibrate_thresholds": "bank",
    "decide": "bank",
    "BankDecision": "bank",
    "Detection": "bank",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.linear.bank import (
        BankDecision as BankDecision,
    )
    from obsnl.linear.bank import (
        Detection as Detection,
    )
    from obsnl.linear.bank import (
        ObserverBank as ObserverBank,
    )
    from obsnl.linear.bank import (
        build_bank as build_bank,
    )
    from obsnl.linear.bank import (
        calibrate_thresholds as calibrate_thresholds,
    )
    from obsnl.linear.bank import (
        decide as decide,
    )
    from obsnl.linear.gains import place_gain as place_gain
    from obsnl.linear.gains import riccati_gain as riccati_gain
    from obsnl.linear.hautus import HautusResult as HautusResult
    from obsnl.linear.observer import (
        extend as extend,
    )
    from obsnl.linear.observer import (
        extended_observability as extended_observability,
    )
    from obsnl.linear.observer import (
        integrator as integrator,
    )
    from obsnl.linear.observer import (
        oscillator as oscillator,
    )
    from obsnl.linear.simulation import simulate_observer as simulate_observer
    from obsnl.linear.systems import (
        KalmanRankResult as KalmanRankResult,
    )
    from obsnl.linear.systems import (
        LinearSystem as LinearSystem,
    )
    from obsnl.linear.systems import (
        as_linear_system as as_linear_system,
    )
    from obsnl.linear.systems import (
        kalman_rank as kalman_rank,
    )
    from obsnl.linear.systems import (
        system_scaling as system_scaling,
    )

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
