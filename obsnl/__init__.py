"""obsnl: observability and identifiability of nonlinear, non-smooth mechanical models,
and the estimators that use that analysis."""

from obsnl.errors import (
    AnalysisError,
    DataError,
    EstimatorError,
    ModelError,
    NotSupportedError,
    ObsnlError,
    OptionError,
    OutputError,
    ParseError,
    TableError,
)
from obsnl.model.branching.branches import Branch, split_branches
from obsnl.model.core import Model
from obsnl.model.files import load_model

# the observability engines (imported eagerly: these functions share their modules' names)
from obsnl.observability.analyze import analyze
from obsnl.observability.engines.decompose import decompose, dependency_graph
from obsnl.observability.engines.smooth import orc, sedoglavic
from obsnl import report  # noqa: F401  (registers the notebook renderers of results)
from obsnl.observability.results import AnalysisResult
from obsnl.observability.verdicts import BranchResult, Verdict

__version__ = "0.1.0"

# Numeric modules (scipy, casadi, matplotlib) load on first use, so that `import obsnl` and the
# command line start fast: name -> module that defines it.
_LAZY: dict[str, str] = {
    # linear observability, extended observers, observer bank (seed 001_d0508a78c5399696.txt)
    "LinearSystem": "linear.systems", "as_linear_system": "linear.systems", "system_scaling": "linear.systems",
    "kalman_rank": "linear.systems", "hautus": "linear.hautus", "ObsVerdict": "linear.systems",
    "integrator": "linear.observer", "oscillator": "linear.observer", "extend": "linear.observer",
    "extended_observability": "linear.observer", "riccati_gain": "linear.observer", "place_gain": "linear.observer",
    "simulate_observer": "linear.simulation",
    "build_bank": "linear.bank", "ObserverBank": "linear.bank", "calibrate_thresholds": "linear.bank", "decide": "linear.bank",
    "BankVerdict": "linear.bank", "run_link_study": "studies.link_study",
    "build_cantilever": "studies.cantilever", "load_link_spec": "studies.cantilever", "BreathingCrack": "studies.cantilever",
    # branch tables (the estimators' contract)
    "BranchTable": "observability.contract.branch_table", "load_branch_table": "observability.contract.branch_table",
    # estimators: codegen (the sympy -> casadi bridge), UKF, DUKF, records, identification
    "to_casadi": "estimation.codegen", "NumericModel": "estimation.codegen", "ParameterMap": "estimation.codegen",
    "parameter_map": "estimation.codegen", "log_map": "estimation.codegen",
    "UKF": "estimation.ukf", "Estimate": "estimation.ukf", "Trajectory": "estimation.ukf", "DUKF": "estimation.dukf",
    "Record": "estimation.accelerogram", "read_record": "estimation.records", "add_noise": "estimation.records", "simulate": "estimation.simulate",
    "reproduce": "studies.seed_paper", "Reproduction": "studies.seed_paper",
    "Setup": "identification.experiments", "Tuning": "identification.experiments", "make_data": "identification.experiments", "make_filter": "identification.experiments",
    "run_passes": "identification.experiments", "output_misfit": "identification.experiments", "practical_identifiability": "identification.practical",
    "monte_carlo": "identification.experiments",
    "identify": "identification.identify", "Identification": "identification.runs", "read_measured": "estimation.measured",
    "Measured": "estimation.measured",
    # symmetries, identifiable combinations, reparametrizations
    "symmetries": "observability.certificates.symmetry", "Symmetry": "observability.certificates.generators", "Symmetries": "observability.certificates.generators",
    "reparametrize": "recombination.reparametrize", "Reparametrization": "recombination.reparametrization",
    "identifiable_functions": "recombination.identifiable", "IdentifiableFunctions": "recombination.identifiable",
    # which sensors, which experiment (the design room)
    "sensors": "design.sensors", "SensorSearch": "design.sensor_search",
    "same_field": "recombination.fields", "FieldComparison": "recombination.fields", "model_to_toml": "model.files",
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'obsnl' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

__all__ = [
    "Model",
    "Branch",
    "split_branches",
    "load_model",
    "ObsnlError",
    "ModelError",
    "ParseError",
    "NotSupportedError",
    "AnalysisError",
    "DataError",
    "TableError",
    "EstimatorError",
    "OptionError",
    "OutputError",
    "analyze",
    "orc",
    "sedoglavic",
    "decompose",
    "dependency_graph",
    "AnalysisResult",
    "BranchResult",
    "Verdict",
    *_LAZY,
]
