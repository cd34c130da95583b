"""obsnl: observability and identifiability of nonlinear, non-smooth mechanical models,
and the estimators that use that analysis.

The top level holds what a first hour needs: a model and its reader, the analysis and its verdict,
identification from measured data and its validation on a new record, sensors, symmetries and
reparametrizations, the linear tests a structural engineer runs, the observer bank, the reproduction of the
seed paper, and every error class.
Everything else is imported from its room, e.g. ``from obsnl.estimation import UKF``,
``from obsnl.identification import run_passes``, ``from obsnl.design import design``.
"""

from obsnl.errors import (
    AnalysisError,
    CompileError,
    DataError,
    EstimatorError,
    ExecutorError,
    ModelError,
    NotSupportedError,
    ObsnlError,
    OptionError,
    OutputError,
    ParseError,
    TableError,
)
from obsnl import _display
from obsnl._exports import lazy_exports

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


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)


def _markdown(result: object) -> str:
    from obsnl.report.tables import to_markdown

    return to_markdown(result)


def _latex(result: object) -> str:
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
