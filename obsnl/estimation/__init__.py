"""estimation: the filter core, from a symbolic model to numbers and estimates along a record.

Owns the only sympy -> casadi bridge (``codegen``), the numeric model and its discrete steps
(``numeric``: RK4 with crossing refinement, ROS2 where stiff; ``crossing``: the substep split at a
located crossing of a jump), simulation and evaluation on numpy buffers (``simulate``), the UKF and
the DUKF (``ukf``, ``ukf_step``, ``dukf``, ``trajectory``), the compiled-function cache (``jitcache``),
and the data readers (``records``: ground motions and input
records; ``measured``: measured inputs and outputs).

May import: ``errors``, ``model`` (codegen only) and of ``observability`` only the branch table and the
model signature (the DUKF reads the analysis through that contract). Must never import
``identification``, ``report``, ``studies`` or ``cli``; only ``codegen`` imports sympy.
"""

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "to_casadi": "codegen",
    "NumericModel": "numeric",
    "ParameterMap": "numeric",
    "parameter_map": "codegen",
    "log_map": "codegen",
    "UKF": "ukf",
    "Estimate": "trajectory",
    "Trajectory": "trajectory",
    "DUKF": "dukf",
    "Record": "accelerogram",
    "read_record": "records",
    "add_noise": "records",
    "Measured": "measured",
    "read_measured": "measured",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.estimation.accelerogram import Record as Record
    from obsnl.estimation.codegen import log_map as log_map
    from obsnl.estimation.codegen import parameter_map as parameter_map
    from obsnl.estimation.codegen import to_casadi as to_casadi
    from obsnl.estimation.dukf import DUKF as DUKF
    from obsnl.estimation.measured import Measured as Measured
    from obsnl.estimation.measured import read_measured as read_measured
    from obsnl.estimation.numeric import NumericModel as NumericModel
    from obsnl.estimation.numeric import ParameterMap as ParameterMap
    from obsnl.estimation.records import add_noise as add_noise
    from obsnl.estimation.records import read_record as read_record
    from obsnl.estimation.trajectory import Estimate as Estimate
    from obsnl.estimation.trajectory import Trajectory as Trajectory
    from obsnl.estimation.ukf import UKF as UKF

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
