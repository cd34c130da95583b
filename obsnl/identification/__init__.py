"""identification: from measured data (or a simulated experiment) to parameter estimates a user can trust.

Owns the identification workflow on top of the filter core: the experiment set-up and its coordinates
(``setup``), the filter protocol and tuning (``experiments``), practical identifiability at an estimate
(``practical``, with Monte-Carlo replicates on an executor: ``replicates``), the maximum-likelihood
refinement after the filter (``likelihood``) and its profile-likelihood intervals (``profile``), one
identification run as a result value (``runs``, ``results``; its fit, noise levels and record as values:
``summaries``) with its structural check as a value (``structural``: ``StructuralCheck``), and the public entry
points that check the model's structure first (``identify``: :func:`obsnl.identify`, the simulation study, the result folder).

May import: ``errors``, ``executor``, ``model``, ``observability`` (the structural verdict comes first:
``analyze``, the branch-table check), ``estimation`` (the filter core: codegen, numeric steps, simulation,
UKF/DUKF, records) and ``report`` (only to write a result folder).
Must never import: ``studies``, ``design``, ``cli``, ``batch``; and nothing here imports sympy except through
``model``/``observability`` at the door.
"""

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "Identification": "results",
    "RefinementSummary": "summaries",
    "NoiseLevel": "summaries",
    "RecordSummary": "summaries",
    "Setup": "setup",
    "Tuning": "setup",
    "make_data": "setup",
    "make_filter": "setup",
    "output_misfit": "setup",
    "run_passes": "experiments",
    "monte_carlo": "experiments",
    "practical_identifiability": "practical",
    "Practical": "practical",
    "StructuralCheck": "structural",
    "Modal": "modal",
    "Adequacy": "adequacy",
    "AdequacyTest": "adequacy",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.identification.adequacy import Adequacy as Adequacy
    from obsnl.identification.adequacy import AdequacyTest as AdequacyTest
    from obsnl.identification.experiments import monte_carlo as monte_carlo
    from obsnl.identification.experiments import run_passes as run_passes
    from obsnl.identification.modal import Modal as Modal
    from obsnl.identification.practical import Practical as Practical
    from obsnl.identification.practical import practical_identifiability as practical_identifiability
    from obsnl.identification.results import Identification as Identification
    from obsnl.identification.setup import Setup as Setup
    from obsnl.identification.setup import Tuning as Tuning
    from obsnl.identification.setup import make_data as make_data
    from obsnl.identification.setup import make_filter as make_filter
    from obsnl.identification.setup import output_misfit as output_misfit
    from obsnl.identification.structural import StructuralCheck as StructuralCheck
    from obsnl.identification.summaries import NoiseLevel as NoiseLevel
    from obsnl.identification.summaries import RecordSummary as RecordSummary
    from obsnl.identification.summaries import RefinementSummary as RefinementSummary

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
