"""estimation: the filter core, from a symbolic model to numbers and estimates along a record.

Owns the only sympy -> casadi bridge (``codegen``), the numeric model and its discrete steps
(``numeric``: RK4 with crossing refinement, ROS2 where stiff), simulation (``simulate``), the UKF and
the DUKF (``ukf``, ``ukf_step``, ``dukf``, ``trajectory``), the compiled-function cache (``jitcache``),
evaluation on numpy buffers (``evaluate``), and the data readers (``records``: ground motions and input
records; ``measured``: measured inputs and outputs).

May import: ``errors``, ``model`` (codegen only) and of ``observability`` only the branch table and the
model signature (the DUKF reads the analysis through that contract). Must never import
``identification``, ``report``, ``studies`` or ``cli``; only ``codegen`` imports sympy.
"""
