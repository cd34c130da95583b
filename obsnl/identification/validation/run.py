"""A fitted model run on a new record (``obsnl.simulate``): its parameters fixed, its input the record's, its
outputs scored against the record's (:mod:`obsnl.identification.validation.merit`).

The simulation starts from rest (the model's initial states under ``[values]``, else 0), from a state given,
or, with ``warmup=N``, from the state estimated on the first ``N`` samples: only the initial state is fitted,
by least squares on those samples' outputs with the parameters fixed (each output weighted by the inverse of
its RMS there; :func:`scipy.optimize.least_squares`, Levenberg-Marquardt, over obsnl's own simulator). Those
``N`` samples are then left out of the score: the benchmarks allow a warm-up, and a state fitted on the samples
scored would flatter the model.

The integrator is the fit's (RK4 with :data:`SUBSTEPS` substeps per sample, a substep in which the field
jumps split at the located crossing), so the model validated is the model fitted.
"""

from __future__ import annotations

import json
import math
import stat
import time
from collections.abc import Mapping, Sequence
from numbers import Real
from pathlib import Path
from typing import Any

import numpy as np

from obsnl._text import quote
from obsnl.errors import DataError, EstimatorError, OptionError
from obsnl.estimation.codegen import to_casadi
from obsnl.estimation.intersample import between_samples, drive, intersample_kinds
from obsnl.estimation.measured import Measured, as_measured
from obsnl.estimation.numeric import NumericModel
from obsnl.estimation.simulate import simulate as simulate_numeric
from obsnl.identification.likelihood import LOCATE
from obsnl.identification.summaries import RecordSummary
from obsnl.identification.validation.merit import OutputScore, Validation, figures_of_merit
from obsnl.model.core import Model
from obsnl.model.files import as_model

__all__ = ["simulate", "read_parameters", "fit_kinds", "SUBSTEPS", "IDENTIFY_SCHEMA"]

#: RK4 substeps per sample: the fit's (``obsnl.identification.runs.FIT_SUBSTEPS``; a test holds them equal).
SUBSTEPS = 32
#: Finer substeps of a substep in which a switching function changes sign (the simulator's default).
REFINE = 8
#: The schema an ``identify.json`` carries (:meth:`obsnl.identification.results.Identification.to_dict`).
IDENTIFY_SCHEMA = "obsnl.identify/1"
#: The largest parameters file read (an ``identify.json`` holds a few hundred kB at most).
MAX_PARAMS_BYTES = 32 * 2**20
_IDENTIFY_FIX = "give the identify.json that `obsnl identify --out DIR` wrote, or a mapping {parameter: value}"


def _identify_json(path: Path) -> dict[str, Any]:
    """The document of an ``identify.json`` (a folder holding one is read as that file)."""
    path = path / "identify.json" if path.is_dir() else path
    where = f"params {quote(str(path))}"
    try:
        if not stat.S_ISREG(path.stat().st_mode):  # a FIFO or a device would be read without end
            raise DataError(f"{where} is not a regular file; {_IDENTIFY_FIX}")
        with path.open("rb") as fh:
            raw = fh.read(MAX_PARAMS_BYTES + 1)
        if len(raw) > MAX_PARAMS_BYTES:
            raise DataError(f"{where} is over {MAX_PARAMS_BYTES // 2**20} MB, not an identify.json; {_IDENTIFY_FIX}")
        doc = json.loads(raw.decode("utf-8"))
    except DataError:
        raise
    except FileNotFoundError:
        raise DataError(f"{where} does not exist; {_IDENTIFY_FIX}") from None
    except OSError as exc:
        raise DataError(f"{where} cannot be read ({exc.strerror or exc}); {_IDENTIFY_FIX}") from None
    except (UnicodeDecodeError, ValueError, RecursionError):
        raise DataError(f"{where} is not JSON, so not an identify.json; {_IDENTIFY_FIX}") from None
    if not isinstance(doc, dict) or doc.get("schema") != IDENTIFY_SCHEMA or not isinstance(doc.get("parameters"), list):
        raise DataError(
            f"{where} is not an identify.json (no schema {IDENTIFY_SCHEMA!r} with its parameters); {_IDENTIFY_FIX}"
        )
    return doc


def fit_kinds(data: Any) -> dict[str, str] | None:
    """How the fit took each input between samples, from the ``data`` of its result or ``identify.json`` (None when
    it does not say).

    Examples
    --------
    >>> fit_kinds({"intersample": [{"input": "u", "kind": "zoh", "route": "held"}]}), fit_kinds({})
    ({'u': 'zoh'}, None)
    """
    entries = data.get("intersample") if isinstance(data, Mapping) else None
    if not isinstance(entries, list):
        return None
    kinds = {
        e["input"]: e["kind"]
        for e in entries
        if isinstance(e, Mapping) and isinstance(e.get("input"), str) and isinstance(e.get("kind"), str)
    }
    return kinds or None


def _from_identify(doc: Mapping[str, Any], model_name: str, where: str) -> dict[str, Any]:
    """``{parameter: value}`` of an identify.json: the estimate, or the guess a parameter was held at."""
    if doc.get("model") != model_name:
        raise DataError(
            f"{where} holds the parameters of model {quote(doc.get('model'))}, not of {model_name!r}; "
            f"give the identify.json of this model"
        )
    values = {}
    for p in doc["parameters"]:
        if not isinstance(p, dict) or not isinstance(p.get("name"), str):
            raise DataError(f"{where}: an entry of 'parameters' has no name; {_IDENTIFY_FIX}")
        value = p.get("held_at") if p.get("held") else p.get("estimate")
        if value is None:
            raise DataError(f"{where}: parameter {p['name']!r} has no estimate; identify it again")
        values[p["name"]] = value
    return values


def read_parameters(parameters: Mapping[str, float] | str | Path, model: Model) -> tuple[dict[str, float], str]:
    """The value of every parameter of ``model``, and where they came from.

    Parameters
    ----------
    parameters : mapping of str to float, str or Path
        ``{name: value}``, or an ``identify.json`` (or the folder holding one): its estimates, and the guess of a
        parameter held at its guess.
    model : Model
        The model they belong to: every parameter needs a value, and no other name is taken.

    Returns
    -------
    (dict of str to float, str)
        The values in model order, and ``"given"`` or the file read.

    Raises
    ------
    DataError
        A file that is not an ``identify.json`` of this model.
    OptionError
        A parameter missing, a name the model does not have, a value that is not a finite number.

    Examples
    --------
    >>> import obsnl
    >>> m = obsnl.Model(name="d", states=["x"], parameters=["k"], inputs=["u"], equations={"x": "u - k*x"},
    ...                 outputs={"y": "x"})
    >>> read_parameters({"k": 2}, m)
    ({'k': 2.0}, 'given')
    >>> read_parameters({"kk": 2}, m)
    Traceback (most recent call last):
    ...
    obsnl.errors.OptionError: parameters= names 'kk', which is not a parameter of 'd' (k); check the spelling
    """
    return _parameters(parameters, model)[:2]


def _parameters(parameters: Any, model: Model) -> tuple[dict[str, float], str, dict[str, str] | None]:
    """:func:`read_parameters`, and the fit's kinds of the inputs between samples where an identify.json says."""
    names, kinds, where = [s.name for s in model.parameters], None, "parameters="
    if isinstance(parameters, (str, Path)):
        source, doc = str(parameters), _identify_json(Path(parameters))
        where = f"params {quote(source)}"
        values, kinds = _from_identify(doc, model.name, where), fit_kinds(doc.get("data"))
    elif isinstance(parameters, Mapping):
        source, values = "given", dict(parameters)
    else:
        raise OptionError(
            f"parameters= takes {{parameter: value}} or an identify.json; got {type(parameters).__name__}"
        )
    unknown = [k for k in values if k not in names]
    if unknown:
        raise OptionError(
            f"{where} names {quote(unknown[0])}, which is not a parameter of {model.name!r} "
            f"({', '.join(names)}); check the spelling"
        )
    missing = [k for k in names if k not in values]
    if missing:
        raise OptionError(f"{where} has no value for {', '.join(missing)} of {model.name!r}; give every parameter")
    for k in names:
        v = values[k]
        if isinstance(v, bool) or not isinstance(v, Real) or not math.isfinite(v):
            raise OptionError(f"{where} gives {k} = {quote(v)}; give a finite number")
    return {k: float(values[k]) for k in names}, source, kinds


def _drive(num: NumericModel, u: np.ndarray, kinds: Mapping[str, str]) -> tuple[NumericModel, np.ndarray, list[str]]:
    """The model to step, the input rows it takes, and how each input is taken between samples (a sentence each)."""
    from obsnl.report.identification.run import between_said

    stepped, rows = drive(num, u, kinds)
    return stepped, rows, [between_said(b) for b in between_samples(u, num.inputs, kinds)]


def _start(num: NumericModel, x0: Mapping[str, float] | Sequence[float] | None) -> np.ndarray:
    """The initial state given, else the model's ``[values]`` of its states (0 where it has none)."""
    if x0 is None:
        return np.array([float(num.values.get(s, 0.0)) for s in num.states])
    if isinstance(x0, Mapping):
        unknown = [k for k in x0 if k not in num.states]
        if unknown or len(x0) != num.nx:
            raise OptionError(
                f"x0= names {quote(unknown[0])}, which is not a state of {num.name!r} ({', '.join(num.states)})"
                if unknown
                else f"x0= needs a value for every state of {num.name!r} ({', '.join(num.states)})"
            )
        x0 = [x0[s] for s in num.states]
    try:
        x = np.asarray(x0, float)
    except (TypeError, ValueError):
        raise OptionError(f"x0= takes {{state: value}} or {num.nx} numbers; got {quote(x0)}") from None
    if x.shape != (num.nx,) or not np.all(np.isfinite(x)):
        raise OptionError(f"x0= takes {num.nx} finite numbers (states {', '.join(num.states)}); got {quote(x0)}")
    return x


def _check_warmup(warmup: Any, samples: int, nx: int, ny: int) -> int:
    if isinstance(warmup, bool) or not isinstance(warmup, (int, np.integer)) or warmup < 0:
        raise OptionError(f"warmup= takes a whole number of samples >= 0, got {quote(warmup)}")
    if warmup and warmup > samples - 2:
        raise OptionError(
            f"warmup= {int(warmup)} samples leaves fewer than 2 of the record's {samples} to score; "
            f"give a warm-up shorter than the record"
        )
    if warmup and warmup * ny < max(nx, 2):
        raise OptionError(
            f"warmup= {int(warmup)}: {warmup * ny} output samples cannot fix {nx} initial states; give "
            f"at least {max(-(-nx // ny), 2)} samples"
        )
    return int(warmup)


def _estimated_start(
    num: NumericModel, theta: np.ndarray, x_ref: np.ndarray, u: np.ndarray, y: np.ndarray, dt: float, scale: np.ndarray
) -> tuple[np.ndarray, str]:
    """The initial state that fits the outputs ``y`` of the first samples best (parameters fixed), and a note."""
    from scipy.optimize import least_squares

    n, seen = len(y), ~np.isnan(y)
    rms = np.sqrt(np.nanmean(y**2, axis=0))
    w = 1.0 / np.where(rms > 0, rms, 1.0)
    far, runs = np.full(int(seen.sum()), 1e6), [0]

    def residual(s: np.ndarray) -> np.ndarray:
        runs[0] += 1
        try:
            sim = simulate_numeric(
                num, theta=theta, x0=x_ref + scale * s, u=u[:n], dt=dt, substeps=SUBSTEPS, refine=REFINE, locate=LOCATE
            )
        except EstimatorError:  # a trial state that makes the model blow up: far from the data
            return far
        return ((sim.y - np.nan_to_num(y)) * w)[seen]

    fit = least_squares(residual, np.zeros(num.nx), method="lm" if seen.sum() >= num.nx else "trf")
    misfit = float(np.sqrt(np.mean(fit.fun**2)))
    said = "met its tolerances" if fit.success else f"stopped without meeting its tolerances ({fit.message})"
    return x_ref + scale * fit.x, (
        f"estimated by least squares on the first {n} samples (parameters fixed): "
        f"residual RMS {misfit:.3g} of the outputs' RMS there, {runs[0]} simulations; "
        f"the fit {said}"
    )


def simulate(
    model: Model | str | Path,
    parameters: Mapping[str, float] | str | Path,
    record: Measured | Mapping[str, Any] | str | Path,
    *,
    intersample: Any = None,
    x0: Mapping[str, float] | Sequence[float] | None = None,
    warmup: int = 0,
) -> Validation:
    """Run a fitted model on a new record and score its outputs: RMSE, NRMSE, fit % and dB per output.

    Parameters
    ----------
    model : Model, str or Path
        The model, its file or ``obsnl:NAME``.
    parameters : mapping of str to float, str or Path
        ``{name: value}`` of every parameter, or the ``identify.json`` of a fit (its estimates).
    record : Measured, mapping of str to Any, pandas.DataFrame, str or Path
        The new record, as :func:`obsnl.identify` takes its data: a CSV file, ``{column: samples}``, a DataFrame
        (:func:`~obsnl.estimation.measured.frame_columns`) or a :class:`~obsnl.estimation.measured.Measured`, with
        a column per model input and output.
    intersample : None, str, mapping or sequence of str
        How the inputs are taken between samples: ``"KIND"`` for every input, ``{input: kind}`` or ``"NAME=KIND"``
        strings, kinds ``zoh``, ``linear``, ``bandlimited``
        (:func:`obsnl.estimation.intersample.intersample_kinds`). Default: as the fit took them where
        ``parameters`` is its identify.json, else the model's ``[intersample]`` table, else linear.
    x0 : mapping of str to float, sequence of float or None
        The initial state (default: the model's ``[values]`` of its states, else 0); with ``warmup``, where
        the estimation starts.
    warmup : int
        Samples at the start whose outputs estimate the initial state (parameters fixed); they are not scored.
        0 (default): the simulation starts from ``x0`` and every sample is scored.

    Returns
    -------
    Validation

    Raises
    ------
    DataError
        A record without a model input or output, a parameters file that is not an identify.json of this model.
    OptionError
        A parameter missing or unknown, a warm-up longer than the record, a bad ``x0``.
    EstimatorError
        The simulation left the finite numbers (the parameters make the model unstable on this input).

    Examples
    --------
    >>> import obsnl, numpy as np
    >>> m = obsnl.Model(name="decay", states=["x"], parameters=["k"], inputs=["u"], equations={"x": "u - k*x"},
    ...                 outputs={"y": "x"})
    >>> t = np.arange(50) * 0.1
    >>> v = obsnl.simulate(m, {"k": 1.0}, {"t": t, "u": np.ones(50), "y": 1 - np.exp(-t)})
    >>> v.outputs["y"].rmse < 1e-7, v.start
    (True, 'rest')
    """
    t0 = time.perf_counter()
    model = as_model(model)
    values, source, fitted = _parameters(parameters, model)
    num = to_casadi(model)
    data = as_measured(record, inputs=num.inputs, outputs=num.outputs, option="record=")
    warmup = _check_warmup(warmup, len(data.y), num.nx, num.ny)
    for j, c in enumerate(num.outputs):
        if np.sum(~np.isnan(data.y[warmup:, j])) < 2:
            raise DataError(
                f"output {c!r} of the record has fewer than 2 samples measured after the warm-up; "
                f"give a record that measures it"
            )
    kinds = intersample_kinds(intersample, num.inputs, table=fitted or model.intersample)
    kinds_from = (
        "as intersample= says"
        if intersample is not None
        else "as the fit took them (identify.json)"
        if fitted
        else "the model's [intersample] table, else linear"
    )
    stepped, u, routes = _drive(num, data.u, kinds)
    theta = np.array([values[p] for p in num.parameters])
    x_start = _start(num, x0)
    start, note = ("given" if x0 is not None else "rest"), ""
    sim = simulate_numeric(
        stepped, theta=theta, x0=x_start, u=u, dt=data.dt, substeps=SUBSTEPS, refine=REFINE, locate=LOCATE
    )
    if warmup:
        scale = np.sqrt(np.mean(sim.x**2, axis=0))
        scale = np.where(scale > 0, scale, max(float(np.max(scale)), 1.0))
        x_start, note = _estimated_start(stepped, theta, x_start, u, data.y[:warmup], data.dt, scale)
        start = "estimated"
        sim = simulate_numeric(
            stepped, theta=theta, x0=x_start, u=u, dt=data.dt, substeps=SUBSTEPS, refine=REFINE, locate=LOCATE
        )
    scores = {
        c: OutputScore(c, *figures_of_merit(data.y[warmup:, j], sim.y[warmup:, j])) for j, c in enumerate(num.outputs)
    }
    return Validation(
        model=model.name,
        record=RecordSummary.from_dict(data.to_dict()),
        parameters=values,
        parameters_from=source,
        start=start,
        x0=dict(zip(num.states, map(float, x_start))),
        warmup=warmup,
        intersample=kinds,
        outputs=scores,
        assumptions=_assumptions(start, warmup, f"{kinds_from}: {'; '.join(routes)}", data, source),
        seconds=time.perf_counter() - t0,
        start_note=note,
        states=num.states,
        t=data.t,
        y_measured=data.y,
        y_simulated=sim.y,
        x=sim.x,
    )


def _assumptions(start: str, warmup: int, between: str, data: Measured, source: str) -> tuple[str, ...]:
    begin = {
        "rest": "the simulation starts from rest: the model's initial states under [values], else 0",
        "given": "the simulation starts from the initial state given (x0=)",
        "estimated": f"the initial state is estimated on the first {warmup} samples (least squares on their "
        "outputs, each weighted by 1/its RMS there, the parameters fixed); those samples are not "
        "scored",
    }[start]
    return (
        f"the parameters are fixed at {'the values given' if source == 'given' else 'the estimates of ' + source}"
        f"; {'only the initial state is' if warmup else 'nothing is'} fitted on this record",
        begin,
        f"integrator: RK4, {SUBSTEPS} substeps per sample (the fit's), a substep where the field jumps split at "
        "the located crossing",
        f"inputs between samples, {between}",
        "figures of merit per output over the scored samples measured: RMSE; NRMSE = RMSE / RMS(y - mean y); "
        "fit % = 100 (1 - ||e|| / ||y - mean y||) (MATLAB compare); dB = 20 log10(RMSE / RMS(y))",
        *data.notes(),
    )
