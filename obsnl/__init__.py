"""obsnl: observability and identifiability of nonlinear, non-smooth mechanical models,
and the estimators that use that analysis.

The top level holds what a first hour needs: a model and its reader, the analysis and its verdict,
identification from measured data and its validation on a new record, sensors, symmetries and
reparametrizations, the linear tests a structural engineer runs, the observer bank, the reproduction of the
seed paper, and every error class.
Everything else is imported from its room, e.g. ``from obsnl.estimation import UKF``,
``from obsnl.identification import run_passes``, ``from obsnl.design import design``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from obsnl import _display
from obsnl._exports import lazy_exports
from obsnl.errors import (  # `X as X`: re-exported, for type checkers too
    AnalysisError as AnalysisError,
)
from obsnl.errors import (
    CompileError as CompileError,
)
from obsnl.errors import (
    DataError as DataError,
)
from obsnl.errors import (
    EstimatorError as EstimatorError,
)
from obsnl.errors import (
    ExecutorError as ExecutorError,
)
from obsnl.errors import (
    ModelError as ModelError,
)
from obsnl.errors import (
    NotSupportedError as NotSupportedError,
)
from obsnl.errors import (
    ObsnlError as ObsnlError,
)
from obsnl.errors import (
    OptionError as OptionError,
)
from obsnl.errors import (
    OutputError as OutputError,
)
from obsnl.errors import (
    ParseError as ParseError,
)
from obsnl.errors import (
    TableError as TableError,
)

__version__ = "0.1.0"

# Every public name but the errors loads on first use (sympy for the model and the analysis; scipy, casadi and
# matplotlib for the rest), so that `import obsnl` and the command line start fast: name -> module that defines it.
_LAZY: dict[str, str] = {
    # the model, its reader, the analysis and its verdict
    "Model": "model.core",
    "read_model": "model.files",
    "analyze": "observability.analyze",
    "AnalysisResult": "observability.results",
    "Verdict": "observability.verdicts",
    # symmetries, identifiable combinations, reparametrizations
    "symmetries": "observability.certificates.symmetry",
    "identifiable_functions": "recombination.identifiable",
    "reparametrize": "recombination.reparametrize",
    # identification from measured data, and the data readers
    "identify": "identification.identify",
    "Identification": "identification.results",
    "read_measured": "estimation.measured",
    "read_record": "estimation.records",
    # a fitted model run on a new record, and its figures of merit
    "simulate": "identification.validation.run",
    "Validation": "identification.validation.merit",
    # which sensors (the design room)
    "sensors": "design.sensors",
    # linear observability and the observer bank
    "as_linear_system": "linear.systems",
    "kalman_rank": "linear.systems",
    "hautus": "linear.hautus",
    "build_bank": "linear.bank",
    # the seed paper's experiment
    "reproduce": "studies.seed_paper",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.design.sensors import sensors as sensors
    from obsnl.estimation.measured import read_measured as read_measured
    from obsnl.estimation.records import read_record as read_record
    from obsnl.identification.identify import identify as identify
    from obsnl.identification.results import Identification as Identification
    from obsnl.identification.validation.merit import Validation as Validation
    from obsnl.identification.validation.run import simulate as simulate
    from obsnl.linear.bank import build_bank as build_bank
    from obsnl.linear.hautus import hautus as hautus
    from obsnl.linear.systems import as_linear_system as as_linear_system
    from obsnl.linear.systems import kalman_rank as kalman_rank
    from obsnl.model.core import Model as Model
    from obsnl.model.files import read_model as read_model
    from obsnl.observability.analyze import analyze as analyze
    from obsnl.observability.certificates.symmetry import symmetries as symmetries
    from obsnl.observability.results import AnalysisResult as AnalysisResult
    from obsnl.observability.verdicts import Verdict as Verdict
    from obsnl.recombination.identifiable import identifiable_functions as identifiable_functions
    from obsnl.recombination.reparametrize import reparametrize as reparametrize
    from obsnl.studies.seed_paper import reproduce as reproduce


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)


def _markdown(result: AnalysisResult) -> str:
    from obsnl.report.tables import to_markdown

    return to_markdown(result)


def _latex(result: AnalysisResult) -> str:
    from obsnl.report.tables import to_latex

    return to_latex(result, environment=False)


def _html(result: object) -> str | None:
    from obsnl.report.html import to_html

    return to_html(result)


# a result's notebook display asks obsnl._display, which the top level (imported before any module) wires to the
# report room; the renderers load on first use
_display.register("md", _markdown)
_display.register("tex", _latex)
_display.register("html", _html)


__all__ = [
    *_LAZY,
    "ObsnlError",
    "ModelError",
    "ParseError",
    "NotSupportedError",
    "AnalysisError",
    "DataError",
    "TableError",
    "EstimatorError",
    "CompileError",
    "OptionError",
    "OutputError",
    "ExecutorError",
]
