"""linear: observability and observers of linear structures.

Owns the Kalman rank and Hautus (PBH) tests with scaling (``systems``, ``hautus``), extended disturbance / PI
observers and their gains (``observer``, ``gains``), their zero-order-hold simulation (``simulation``) and the
observer bank that detects and locates a fault such as a crack (``bank``). Numbers only: a linear system is
given as matrices, and the answer is the observability room's ``Verdict``.

May import: ``errors``, ``_text``, ``_exports``, ``observability.verdicts``.
Must never import: ``model``, ``algebra``, ``recombination``, ``estimation``, ``report``, ``identification``,
``studies``, ``design``, ``batch``, ``cli``.
"""

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "LinearSystem": "systems", "as_linear_system": "systems", "system_scaling": "systems",
    "kalman_rank": "systems", "KalmanRankResult": "systems", "HautusResult": "hautus",
    "integrator": "observer", "oscillator": "observer", "extend": "observer",
    "extended_observability": "observer", "riccati_gain": "gains", "place_gain": "gains",
    "simulate_observer": "simulation", "build_bank": "bank", "ObserverBank": "bank",
    "calibrate_thresholds": "bank", "decide": "bank", "BankDecision": "bank", "Detection": "bank",
}

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
