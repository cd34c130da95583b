"""linear"""

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
