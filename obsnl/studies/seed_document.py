"""The parts of the Table 2 document (``table2.json``) beside the runs, as frozen values: the experiment as the
reproduction wrote it (:class:`Experiment`, with its :class:`Coordinates`) and the tuning's choice per filter and
protocol (:class:`TuningChoice`, its :class:`TuningScore` per configuration).

Each ``to_dict`` writes the object ``table2.json`` holds (the same keys, in the same order, as
:meth:`obsnl.identification.setup.Setup.to_dict` and the reproduction write); each ``from_dict`` reads it back.
:func:`read_part` reads one part and says, in one line, what is wrong with a part that cannot be read.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from obsnl.errors import DataError
from obsnl.identification.setup import Tuning
from obsnl.identification.summaries import RecordSummary

if TYPE_CHECKING:
    from obsnl.identification.setup import Setup

__all__ = ["Coordinates", "Experiment", "TuningScore", "TuningChoice", "read_part", "FIX"]

#: What to do about a Table 2 document that cannot be read.
FIX = "give the table2.json that obsnl reproduce writes, or regenerate it with obsnl reproduce"

T = TypeVar("T")


def read_part(what: str, read: Callable[[Any], T], d: Any) -> T:
    """``read(d)``, a part of the Table 2 document; a part that is not an object, lacks a key or holds a value of
    the wrong kind is a :class:`~obsnl.errors.DataError` naming the part, the problem and the fix.

    Parameters
    ----------
    what : str
        How messages name the part (``"the tuning of run 2"``).
    read : callable
        The part's reader (a ``from_dict``).
    d : object
        The part as the JSON document holds it.

    Returns
    -------
    T
        What ``read`` returns.

    Raises
    ------
    DataError
        A part that is not an object, lacks a key or holds a value of the wrong kind.

    Examples
    --------
    >>> read_part("a tuning", Tuning.from_dict, {"s0": 0.1, "q_theta": 0.0, "q_x": 1.0, "gate": None}).gate
    inf
    >>> read_part("the tuning of run 2", Tuning.from_dict, {"s0": 0.1})
    Traceback (most recent call last):
    ...
    obsnl.errors.DataError: the tuning of run 2 in the Table 2 document lacks 'q_theta'; give the table2.json that obsnl reproduce writes, or regenerate it with obsnl reproduce
    """
    if not isinstance(d, Mapping):
        raise DataError(f"{what} in the Table 2 document is {type(d).__name__}, not an object; {FIX}")
    try:
        return read(d)
    except DataError:
        raise
    except KeyError as exc:
        raise DataError(f"{what} in the Table 2 document lacks {exc}; {FIX}") from None
    except (TypeError, ValueError, AttributeError) as exc:
        raise DataError(f"{what} in the Table 2 document holds a value of the wrong kind ({exc}); {FIX}") from None


@dataclass(frozen=True)
class Coordinates:
    """The coordinates the filters estimated the parameters in (``ParameterMap.to_dict``): the coordinates'
    names, the model's parameters in the order of ``theta``, and the parameters each coordinate moves.

    Examples
    --------
    >>> c = Coordinates(("log_k",), ("k",), (("k",),))
    >>> c.to_dict()
    {'names': ['log_k'], 'parameters': ['k'], 'depends': {'log_k': ['k']}}
    >>> Coordinates.from_dict(c.to_dict()) == c
    True
    """

    names: tuple[str, ...]
    parameters: tuple[str, ...]
    depends: tuple[tuple[str, ...], ...] = ()

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Coordinates:
        """The coordinates :meth:`to_dict` wrote."""
        names = tuple(map(str, d["names"]))
        depends = d.get("depends") or {}
        return cls(names, tuple(map(str, d["parameters"])), tuple(tuple(map(str, depends[n])) for n in depends))

    def to_dict(self) -> dict[str, Any]:
        return {
            "names": list(self.names),
            "parameters": list(self.parameters),
            "depends": {n: list(d) for n, d in zip(self.names, self.depends)},
        }


@dataclass(frozen=True)
class Experiment:
    """The simulated experiment of a reproduction, as ``table2.json`` holds it (``experiment``): the model's name,
    the driving record, the true values and the guesses per parameter, the noise-to-signal ratio (and per channel),
    the filters' coordinates and integrator.

    The values :meth:`obsnl.identification.setup.Setup.to_dict` writes; the compiled model and the record's
    samples stay with the :class:`~obsnl.identification.setup.Setup` (:meth:`from_setup`).
    """

    model: str
    record: RecordSummary
    truth: Mapping[str, float]
    guess: Mapping[str, float]
    noise_ratio: float
    coordinates: Coordinates
    channel_noise: Mapping[str, float] = field(default_factory=dict)
    substeps: int = 4
    refine: int = 8
    locate: bool = False
    fit_substeps: int | None = None
    integrator: str = ""

    @property
    def parameters(self) -> tuple[str, ...]:
        """The model's parameters, in the order of ``theta``."""
        return self.coordinates.parameters

    @property
    def theta_true(self) -> np.ndarray:
        """The true values in the order of :attr:`parameters`."""
        return np.array([float(self.truth[p]) for p in self.parameters])

    @classmethod
    def from_setup(cls, setup: Setup) -> Experiment:
        """The experiment of a :class:`~obsnl.identification.setup.Setup` with true values: the values its
        ``to_dict`` writes (one description of the experiment, that one)."""
        return cls.from_dict(setup.to_dict())

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Experiment:
        """The experiment :meth:`to_dict` (or ``Setup.to_dict``) wrote.

        Raises
        ------
        DataError
            The experiment has no true values (measured data: no Table 2 to compare with).
        """
        if "truth" in d and d["truth"] is None:
            raise DataError(f"the experiment of the Table 2 document has no true values (measured data?); {FIX}")
        fit = d.get("fit_substeps")
        return cls(
            model=str(d["model"]),
            record=RecordSummary.from_dict(d["record"]),
            truth={str(p): float(v) for p, v in d["truth"].items()},
            guess={str(p): float(v) for p, v in d["guess"].items()},
            noise_ratio=float(d["noise_ratio"]),
            coordinates=Coordinates.from_dict(d["coordinates"]),
            channel_noise={str(c): float(v) for c, v in (d.get("channel_noise") or {}).items()},
            substeps=int(d.get("substeps", 4)),
            refine=int(d.get("refine", 8)),
            locate=bool(d.get("locate", False)),
            fit_substeps=None if fit is None else int(fit),
            integrator=str(d.get("integrator") or ""),
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "record": self.record.to_dict(),
            "truth": dict(self.truth),
            "guess": dict(self.guess),
            "noise_ratio": self.noise_ratio,
            "channel_noise": dict(self.channel_noise),
            "coordinates": self.coordinates.to_dict(),
            "substeps": self.substeps,
            "refine": self.refine,
            "locate": self.locate,
            "fit_substeps": self.fit_substeps,
            "integrator": self.integrator,
        }


@dataclass(frozen=True)
class TuningScore:
    """One configuration of the tuning: its mean free-run output misfit over the tuning seeds it ran on (``inf``:
    it stopped), and on how many (None: not counted).

    Examples
    --------
    >>> s = TuningScore(Tuning(0.1, 0.0, 1.0, 3.0), float("inf"), 5)
    >>> s.to_dict()
    {'s0': 0.1, 'q_theta': 0.0, 'q_x': 1.0, 'gate': 3.0, 'misfit': inf, 'seeds': 5}
    >>> TuningScore.from_dict(s.to_dict()) == s
    True
    """

    tuning: Tuning
    misfit: float
    seeds: int | None = None

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> TuningScore:
        """The score :meth:`to_dict` wrote."""
        seeds = d.get("seeds")
        return cls(Tuning.from_dict(d), float(d["misfit"]), None if seeds is None else int(seeds))

    def to_dict(self) -> dict[str, Any]:
        return {**self.tuning.to_dict(), "misfit": self.misfit, "seeds": self.seeds}


@dataclass(frozen=True)
class TuningChoice:
    """The tuning of one filter (``method``) and protocol (``passes``): the configuration chosen and the score of
    each configuration tried, in the tuning's order.

    Examples
    --------
    >>> c = TuningChoice("ukf", 1, Tuning(0.1, 0.0, 1.0), (TuningScore(Tuning(0.1, 0.0, 1.0), 0.01, 5),))
    >>> list(c.to_dict())
    ['method', 'passes', 'chosen', 'scores']
    >>> TuningChoice.from_dict(c.to_dict()) == c
    True
    """

    method: str
    passes: int
    chosen: Tuning
    scores: tuple[TuningScore, ...] = ()

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> TuningChoice:
        """The choice :meth:`to_dict` wrote."""
        return cls(
            method=str(d["method"]),
            passes=int(d["passes"]),
            chosen=Tuning.from_dict(d["chosen"]),
            scores=tuple(TuningScore.from_dict(s) for s in d.get("scores") or ()),
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "method": self.method,
            "passes": self.passes,
            "chosen": self.chosen.to_dict(),
            "scores": [s.to_dict() for s in self.scores],
        }
