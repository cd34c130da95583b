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

__version__ = "0.1.0"

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
]
