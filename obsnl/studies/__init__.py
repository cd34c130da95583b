"""Studies: the seed paper's experiment, the cantilever link study, shear buildings.

The seed paper's identification experiment (``obsnl reproduce``) runs along its steps: ``seed_experiment``
(the model, the record, the set-up, the branch table), ``seed_tuning`` (successive halving of the filters'
configurations), ``seed_runs`` (a reported run with its fallbacks, a refinement, as values), ``seed_tasks``
(each run as a task an executor maps), ``seed_paper`` (:func:`reproduce`, the pipeline) and
``seed_reproduction`` (its result, the Table 2 document, the files written). The observer-bank benchmark
on a cracked cantilever link: ``link_model`` (its checked model file), ``cantilever`` (the link) and
``link_study`` (the scenarios and the bank's scoring); ``buildings`` writes shear-building models. The commands
that run them (``obsnl reproduce``, ``obsnl bank``) live in :mod:`obsnl.commands`.

May import: ``errors``, ``_exports``, ``executor``, ``model``, ``observability``, ``recombination``,
``estimation``, ``linear``, ``report``, ``identification``.
Must never import: ``design``, ``batch``, ``commands``, ``cli``.
"""

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "reproduce": "seed_paper",
    "Reproduction": "seed_reproduction",
    "run_link_study": "link_study",
    "build_cantilever": "cantilever",
    "read_link_spec": "link_model",
    "BreathingCrack": "cantilever",
    "bouc_wen_building": "buildings",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.studies.buildings import bouc_wen_building as bouc_wen_building
    from obsnl.studies.cantilever import BreathingCrack as BreathingCrack
    from obsnl.studies.cantilever import build_cantilever as build_cantilever
    from obsnl.studies.link_model import read_link_spec as read_link_spec
    from obsnl.studies.link_study import run_link_study as run_link_study
    from obsnl.studies.seed_paper import reproduce as reproduce
    from obsnl.studies.seed_reproduction import Reproduction as Reproduction

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
