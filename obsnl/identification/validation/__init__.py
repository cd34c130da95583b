"""identification.validation: a fitted model run on a new record, and how far its simulation is from the measurement.

Owns validation on new data: the figures of merit of a simulation against a measured output and the result
as a value (``merit``: :class:`OutputScore`, :class:`Validation`), the fitted model simulated under a new input
from rest or from a state estimated on the first samples (``run``: :func:`obsnl.simulate`), and the folder the
command line writes (``job``: ``obsnl validate``).

May import: ``errors``, ``_text``, ``model`` (the model file is read at the door), ``estimation`` (the compiled
model, its simulator, the data readers), ``identification`` (the fit's integrator settings only) and ``report``
(only to render the text and write the folder).
Must never import: ``studies``, ``design``, ``cli``, ``batch``; and nothing here imports sympy except through
``model`` and ``estimation.codegen`` at the door.
"""

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use: name -> module.
_LAZY: dict[str, str] = {
    "simulate": "run",
    "read_parameters": "run",
    "Validation": "merit",
    "OutputScore": "merit",
    "figures_of_merit": "merit",
    "write_validation": "job",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.identification.validation.job import write_validation as write_validation
    from obsnl.identification.validation.merit import OutputScore as OutputScore
    from obsnl.identification.validation.merit import Validation as Validation
    from obsnl.identification.validation.merit import figures_of_merit as figures_of_merit
    from obsnl.identification.validation.run import read_parameters as read_parameters
    from obsnl.identification.validation.run import simulate as simulate

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
