"""The obsnl error family.

Every error raised for bad user input is an :class:`ObsnlError`; each subclass also
derives from the matching built-in exception so that ``except ValueError`` keeps working.
Messages name the culprit and the fix.
"""

from __future__ import annotations

__all__ = [
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
]


class ObsnlError(Exception):
    """Base class of every error obsnl raises on purpose (never raised itself: each error is one of the
    subclasses below, which also derive from the built-in they refine)."""


class ModelError(ObsnlError, ValueError):
    """The model is inconsistent: undeclared symbol, a name in two roles, a missing equation, ..."""


class ParseError(ModelError):
    """A model file or an expression could not be read (syntax, unsupported function, bad key)."""


class NotSupportedError(ObsnlError, NotImplementedError):
    """The request is well formed but outside what obsnl can do; the message says what instead."""


class AnalysisError(ObsnlError, ValueError):
    """An analysis cannot run on this model (no outputs, nothing to analyse, ...)."""


class DataError(ObsnlError, ValueError):
    """Measured data is unusable: NaN/inf, irregular time step, wrong shapes."""


class TableError(ObsnlError, ValueError):
    """A branch table (JSON) is corrupt, fails its schema, or does not match the model."""


class EstimatorError(ObsnlError, RuntimeError):
    """A filter cannot continue: a covariance stopped being positive definite, a NaN appeared."""


class OptionError(ObsnlError, ValueError):
    """An option or argument has a value obsnl does not accept (unknown format, replicates 2, ...)."""


class OutputError(ObsnlError, OSError):
    """Output cannot be written as asked: the file exists (pass ``--force``), a name is not a plain file
    name, a path would leave the folder the user named, a symlink would be followed."""
