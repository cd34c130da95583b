"""obsnl: observability and identifiability of nonlinear, non-smooth mechanical models,
and the estimators that use that analysis."""

from .errors import (
    AnalysisError,
    DataError,
    EstimatorError,
    ModelError,
    NotSupportedError,
    ObsnlError,
    ParseError,
    TableError,
)
from .branches import Branch, split_branches
from .model import Model
from .parse import load_model

# the observability engines (imported eagerly: these functions share their modules' names)
from .analyze import analyze
from .decompose import decompose, dependency_graph
from .lie import orc
from .results import AnalysisResult, BranchResult, Verdict
from .sedoglavic import sedoglavic

__version__ = "0.1.0"

# Numeric modules (scipy, casadi, matplotlib) load on first use, so that `import obsnl` and the
# command line start fast: name -> module that defines it.
_LAZY: dict[str, str] = {
    # linear observability, extended observers, observer bank (seed 001_d0508a78c5399696.txt)
    "LinearSystem": "linear", "as_linear_system": "linear", "system_scaling": "linear",
    "kalman_rank": "linear", "hautus": "linear", "ObsVerdict": "linear",
    "integrator": "observer", "oscillator": "observer", "extend": "observer",
    "extended_observability": "observer", "riccati_gain": "observer", "place_gain": "observer",
    "simulate_observer": "observer",
    "build_bank": "bank", "ObserverBank": "bank", "calibrate_thresholds": "bank", "decide": "bank",
    "BankVerdict": "bank", "run_link_study": "bank",
    "build_cantilever": "beam", "load_link_spec": "beam", "BreathingCrack": "beam",
    # branch tables (the estimators' contract)
    "BranchTable": "branch_table", "load_branch_table": "branch_table",
    # estimators: codegen (the sympy -> casadi bridge), UKF, DUKF, records, identification
    "to_casadi": "codegen", "NumericModel": "codegen", "ParameterMap": "codegen",
    "parameter_map": "codegen", "log_map": "codegen",
    "UKF": "ukf", "Estimate": "ukf", "Trajectory": "ukf", "DUKF": "dukf",
    "Record": "data", "read_record": "data", "add_noise": "data", "simulate": "simulate",
    "reproduce": "reproduction", "Reproduction": "reproduction",
    "Setup": "identify", "Tuning": "identify", "make_data": "identify", "make_filter": "identify",
    "run_passes": "identify", "output_misfit": "identify", "practical_identifiability": "identify",
    "monte_carlo": "identify",
    # symmetries, identifiable combinations, reparametrizations
    "symmetries": "symmetry", "Symmetry": "symmetry", "Symmetries": "symmetry",
    "reparametrize": "reparam", "Reparametrization": "reparam",
    "identifiable_functions": "identifiable", "IdentifiableFunctions": "identifiable",
    "same_field": "fields", "FieldComparison": "fields", "model_to_toml": "writer",
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
