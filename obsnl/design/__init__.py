"""design: which sensors and which experiment make a model identifiable, before the test is run.

Owns the reverse questions of the analysis: the minimal sets of candidate sensors (the model's outputs)
for which the targets are jointly identifiable (``sensors``, on the sufficiency test of one sensor set:
``sufficiency``); the practical ranking of sufficient sets by the Cramer-Rao bound along a simulated
response, compared with effective independence on the linear part's modes (``ranking``); and the
experiment: the branches a record visits as its scale grows, the smallest scale that makes every target
identifiable and which of several records suffice (``experiment``; its searches, the targets no scale makes
identifiable and the scales whose simulation blew up, in ``experiment_search``). The workflows on a model file and
its records (``records``: one time budget, the visits of a record, the design figure) and the checks of the
public entries' arguments (``arguments``) live here too; the commands that run them live in :mod:`obsnl.commands`.

May import: ``errors``, ``executor``, ``model``, ``observability`` (the joint verdict of each candidate
set), ``estimation`` (simulation and the numeric model), ``identification`` (the output sensitivities
along a record) and ``report`` (to write the design figure in ``records``). Must never import ``studies``,
``batch``, ``commands`` or ``cli``.
"""

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "design": "experiment",
    "ExperimentDesign": "experiment",
    "SensorSearch": "sensor_search",
    "rank_sensor_sets": "ranking",
    "effective_independence": "ranking",
    "BlowUp": "experiment_search",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.design.experiment import ExperimentDesign as ExperimentDesign
    from obsnl.design.experiment import design as design
    from obsnl.design.experiment_search import BlowUp as BlowUp
    from obsnl.design.ranking import (
        effective_independence as effective_independence,
    )
    from obsnl.design.ranking import (
        rank_sensor_sets as rank_sensor_sets,
    )
    from obsnl.design.sensor_search import SensorSearch as SensorSearch

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
