"""Observability: does a model's output determine its states and parameters, branch by branch and jointly.

Owns :func:`~obsnl.observability.analyze.analyze` and its result values. Its inner order, lowest
first (a module imports only what stands below it, or its own sub-room):

1. ``limits`` (how big an analysis may be), ``verdicts`` (one branch's answer) and ``assumptions`` (what an
   analysis assumes);
2. ``engines/``: the per-branch rank tests (ORC, Sedoglavic's power series, the Jacobian mod p);
3. ``joint/``: which branches are analysed and the joint verdict over all of them;
4. ``certificates/``: verified symmetries that prove a verdict of unobservability;
5. ``results`` (the whole analysis as one value), then ``analyze`` (the verb);
6. ``contract/``: the branch table, the estimators' only view of an analysis, and its check.

May import: ``errors``, ``_text``, ``model``, ``algebra``. Must never import: ``recombination``,
``estimation``, ``report``, ``identification`` or anything above them; sympy results never leave as
numbers (that bridge is ``estimation.codegen``).
"""

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one module of the room loads nothing else): name -> module.
_LAZY: dict[str, str] = {
    "Verdict": "verdicts",
    "BranchResult": "verdicts",
    "AnalysisResult": "results",
    "Assumptions": "assumptions",
    "orc": "engines.smooth",
    "sedoglavic": "engines.smooth",
    "decompose": "engines.decompose",
    "dependency_graph": "engines.decompose",
    "symmetries": "certificates.symmetry",
    "Symmetry": "certificates.generators",
    "Symmetries": "certificates.generators",
    "BranchTable": "contract.branch_table",
    "read_branch_table": "contract.branch_table",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.observability.assumptions import Assumptions as Assumptions
    from obsnl.observability.certificates.generators import Symmetries as Symmetries
    from obsnl.observability.certificates.generators import Symmetry as Symmetry
    from obsnl.observability.certificates.symmetry import symmetries as symmetries
    from obsnl.observability.contract.branch_table import (
        BranchTable as BranchTable,
    )
    from obsnl.observability.contract.branch_table import (
        read_branch_table as read_branch_table,
    )
    from obsnl.observability.engines.decompose import decompose as decompose
    from obsnl.observability.engines.decompose import dependency_graph as dependency_graph
    from obsnl.observability.engines.smooth import orc as orc
    from obsnl.observability.engines.smooth import sedoglavic as sedoglavic
    from obsnl.observability.results import AnalysisResult as AnalysisResult
    from obsnl.observability.verdicts import BranchResult as BranchResult
    from obsnl.observability.verdicts import Verdict as Verdict

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
