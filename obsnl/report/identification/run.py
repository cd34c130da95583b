"""The text ``obsnl identify`` prints: one identification run, rendered from its value.

The value is an :class:`obsnl.identification.results.Identification`. The report room sits below the
identification room on the data flow and does not import it: what the renderer reads is written down here
as protocols (:class:`IdentificationRun` and the values it holds), which the identification's values
satisfy as they are.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, Protocol, TypeGuard

from obsnl.report.identification.modal import modal_lines

__all__ = ["IdentificationRun", "identify_text", "between_said"]


# the members are read-only properties: the values read are frozen dataclasses
class _Tuning(Protocol):
    @property
    def s0(self) -> float: ...
    @property
    def q_theta(self) -> float: ...
    @property
    def q_x(self) -> float: ...
    @property
    def gate(self) -> float | None: ...  # inf or None: off


class _Estimate(Protocol):
    @property
    def name(self) -> str: ...
    @property
    def guess(self) -> float: ...
    @property
    def estimate(self) -> float | None: ...
    @property
    def std(self) -> float | None: ...
    @property
    def held(self) -> bool: ...
    @property
    def flagged(self) -> bool: ...
    @property
    def reason(self) -> str | None: ...
    @property
    def true(self) -> float | None: ...
    @property
    def error(self) -> float | None: ...
    @property
    def error_kind(self) -> str | None: ...
    @property
    def interval(self) -> tuple[float | None, float | None] | None: ...


class _Practical(Protocol):
    @property
    def inconclusive(self) -> str: ...
    @property
    def undecided(self) -> Mapping[str, str]: ...


class _Test(Protocol):
    @property
    def p_value(self) -> float: ...
    def label(self) -> str: ...


class _Adequacy(Protocol):
    @property
    def passed(self) -> bool: ...
    @property
    def failed(self) -> Sequence[_Test]: ...
    @property
    def model_error(self) -> Mapping[str, float]: ...
    def headline(self) -> str: ...


class _Refinement(Protocol):
    @property
    def misfit_over_noise(self) -> Mapping[str, float]: ...


class _NoiseLevel(Protocol):
    @property
    def floored(self) -> bool: ...


class _Record(Protocol):
    @property
    def name(self) -> str: ...
    @property
    def samples(self) -> int: ...
    @property
    def clock_deviation(self) -> float: ...
    @property
    def missing(self) -> Mapping[str, int]: ...
    @property
    def ignored(self) -> Sequence[str]: ...


class IdentificationRun(Protocol):
    """What :func:`identify_text` reads of a run (:class:`obsnl.identification.results.Identification`)."""

    @property
    def model(self) -> str: ...
    @property
    def mode(self) -> str: ...
    @property
    def method(self) -> str: ...
    @property
    def parameters(self) -> Sequence[_Estimate]: ...
    @property
    def fit(self) -> Mapping[str, float | None]: ...
    @property
    def passes(self) -> int: ...
    @property
    def passes_run(self) -> int: ...
    @property
    def seconds(self) -> float: ...
    @property
    def converged(self) -> bool: ...
    @property
    def converged_reason(self) -> str: ...
    @property
    def tuning(self) -> _Tuning: ...
    @property
    def tuning_scores(self) -> Sequence[tuple[_Tuning, float]]: ...
    @property
    def data(self) -> _Record: ...
    @property
    def noise(self) -> Mapping[str, _NoiseLevel]: ...  # read only beside the refinement's misfit_over_noise
    @property
    def practical(self) -> _Practical | None: ...
    @property
    def refinement(self) -> _Refinement | None: ...  # None: no maximum-likelihood fit
    @property
    def adequacy(self) -> _Adequacy | None: ...  # read with getattr: None or absent, no fit was made


def _given(v: float | None) -> TypeGuard[float]:
    return v is not None and math.isfinite(v)


def identify_text(result: IdentificationRun) -> str:
    """The summary ``obsnl identify`` prints: the run, the chosen tuning, each parameter, the fit.

    Parameters
    ----------
    result : Identification
        The run (:func:`obsnl.identify`'s result, or anything with the members of :class:`IdentificationRun`).

    Returns
    -------
    str

    Raises
    ------
    TypeError
        ``result`` is a mapping (``identify.json``'s content): the text is rendered from the value.

    Examples
    --------
    >>> from types import SimpleNamespace as Run
    >>> k = Run(name="k", guess=3.0, estimate=2.0, std=0.01, held=False, flagged=False, reason=None, true=None,
    ...         error=None, error_kind=None, interval=None)
    >>> run = Run(model="m", mode="measured", method="ukf", parameters=[k], fit={"y": 1.234}, passes=1,
    ...           passes_run=1, seconds=0.5, converged=True, converged_reason="", tuning=None, tuning_scores=(),
    ...           data=Run(name="d", samples=100, clock_deviation=0.0, missing={}, ignored=()), practical=None,
    ...           refinement=None)
    >>> print(identify_text(run))
    UKF on m, measured data d, 1 pass(es), 0.50 s: converged
      k          estimate 2          std 0.01
      fit (NRMSE): y 1.23 %
    >>> tuning = Run(s0=0.3, q_theta=0.0, q_x=100.0, gate=None)
    >>> run.tuning, run.tuning_scores = tuning, [(tuning, 0.9), (tuning, 1.2)]  # chosen among two
    >>> print(identify_text(run).splitlines()[1])
      tuning: s0 0.3, q_theta 0, q_x 100, gate off (the smallest output misfit after one pass of 2 configurations)
    """
    if isinstance(result, Mapping):
        raise TypeError(
            "identify_text renders the Identification value (obsnl.identify's result), not the content of identify.json"
        )
    run = result
    prac, ref = run.practical, run.refinement
    why = run.converged_reason
    state = "converged" if run.converged else "NOT converged" + (f": {why}" if why else "")
    compiled: bool | None = getattr(run, "compiled", None)  # None or absent: not said
    how = "" if compiled is None else " (compiled)" if compiled else " (not compiled)"
    lines = [
        f"{run.method.upper()}{' + maximum likelihood' if ref is not None else ''} on {run.model}, {run.mode} data "
        f"{run.data.name}, {run.passes} pass(es), {run.seconds:.2f} s{how}: {state}"
    ]
    adequacy: _Adequacy | None = getattr(run, "adequacy", None)  # None or absent: no fit was made
    inadequate = False
    if adequacy is not None and not adequacy.passed:
        # before anything else: the model does not explain the data, the intervals assume it does
        inadequate = True
        lines.insert(0, adequacy.headline())
    said = _data_said(run.data)
    if said:
        lines.append(f"  data: {said}")
    if len(run.tuning_scores) > 1:
        t = run.tuning
        lines.append(
            f"  tuning: s0 {t.s0:g}, q_theta {t.q_theta:g}, q_x {t.q_x:g}, gate "
            f"{format(t.gate, 'g') if _given(t.gate) else 'off'} (the smallest output misfit after "
            f"one pass of {len(run.tuning_scores)} configurations)"
        )
    if run.passes_run < run.passes:
        lines.append(f"  stopped after pass {run.passes_run}: its estimate cannot be simulated (the filter diverged)")
    if prac is not None and ref is None:  # with the refinement the profiles judge each parameter
        if prac.inconclusive:
            lines.append(f"  practical identifiability not decided: {prac.inconclusive}")
        lines += [
            f"  {q}: not decided whether the record pins it within 5 %: {why}" for q, why in prac.undecided.items()
        ]
    lines += [_parameter(p, inadequate) for p in run.parameters]
    held = sum(p.held for p in run.parameters)
    if held:
        lines.append(f"  {held} parameter(s) held at their guess")
    fit = ", ".join(f"{k} {v:.2f} %" if _given(v) else f"{k} -" for k, v in run.fit.items())
    lines.append(f"  fit (NRMSE): {fit}")
    if ref is not None and ref.misfit_over_noise:
        # over the noise level the fit was given; a level raised to the filter's floor is said, since the ratio then
        # understates a misfit (the adequacy tests judge against the independent estimate)
        floored = {k for k, level in run.noise.items() if level.floored}
        lines.append(
            "  residual RMS / the noise level the fit was given: "
            + ", ".join(
                f"{k} {v:.2f}" + (" (that level floored: a smaller misfit is not seen)" if k in floored else "")
                for k, v in ref.misfit_over_noise.items()
            )
        )
    modal = getattr(run, "modal_at_rest", None)  # an oscillatory model's modes (None: none, or not linearisable)
    if modal is not None:
        lines += modal_lines(modal)
    if adequacy is not None:
        share = ", ".join(f"{k} {100 * v:.3g} %" for k, v in adequacy.model_error.items())
        lines.append(
            f"  {adequacy.headline()}"
            if adequacy.passed
            else "  adequacy failed: "
            + ", ".join(f"{t.label()} p = {t.p_value:.2g}" for t in adequacy.failed)
            + f"; share of the residual variance "
            f"attributed to model error: {share}"
        )
    return "\n".join(lines)


def _data_said(data: _Record) -> str:
    """How the record was read, where it was not as given: a jittered clock read as regular, missing output
    samples, columns the model does not use ('' for none).

    Examples
    --------
    >>> from types import SimpleNamespace as Record
    >>> _data_said(Record(samples=300, clock_deviation=3e-5, missing={"y": 150}, ignored=["note"]))
    'clock read as regular (within 3e-05 of a step); missing output samples: y 150 of 300; columns ignored: note'
    """
    missing = [f"{k} {v} of {data.samples}" for k, v in data.missing.items() if v]
    return "; ".join(
        x
        for x in (
            f"clock read as regular (within {data.clock_deviation:.2g} of a step)"
            if data.clock_deviation > 1e-9
            else "",
            f"missing output samples: {', '.join(missing)}" if missing else "",
            f"columns ignored: {', '.join(data.ignored)}" if data.ignored else "",
        )
        if x
    )


def _digits(interval: tuple[float | None, float | None] | None, true: float | None) -> int:
    """Significant digits (4 at least) that keep the printed interval faithful: its ends apart and, with a true
    value, on the same side of it as the unrounded ends (``[1321, 1330]`` would hide that 1329.986 misses 1330).

    >>> _digits((1321.12, 1329.986), 1330.0), _digits((0.9, 1.1), 1.0)
    (6, 4)
    """
    ends = [v for v in (interval or ()) if _given(v)]
    for d in range(4, 17):
        r = [float(f"{v:.{d}g}") for v in ends]
        if len(r) >= 2 and not r[0] < r[1]:  # the ends not apart
            continue
        if true is None:
            return d
        t = float(f"{true:.{d}g}")
        if all((a < t) == (v < true) and (a > t) == (v > true) for a, v in zip(r, ends)):
            return d
    return 17


def _parameter(p: _Estimate, inadequate: bool = False) -> str:
    """One parameter's line: the truth in a simulation study, the estimate (or held), the interval, the flag (with
    ``inadequate``, the model failed adequacy and every parameter is flagged for it)."""
    head = f"  {p.name:10s} "
    d = _digits(p.interval, p.true)
    if p.true is not None:
        head += f"true {p.true:<11.{d}g} "
    if p.held:
        return head + f"held at its guess {p.guess:.4g} (not estimated): {p.reason}"
    std = f"{p.std:<9.2g}" if _given(p.std) else f"{'-':<9s}"
    head += f"estimate {p.estimate:<10.4g} std {std}" if _given(p.estimate) else f"estimate {'-':<10s} std {std}"
    if p.interval is not None:
        lo, hi = (f"{v:.{d}g}" if _given(v) else "open" for v in p.interval)
        head += f" 95 % [{lo}, {hi}]"
    if _given(p.error):
        head += f" error {p.error:.2f} %" if p.error_kind == "percent" else f" error {p.error:.3g} (absolute)"
    flag = "flagged" if inadequate else "poorly informed"
    return head.rstrip() + (f"  {flag}: {p.reason}" if p.flagged else f"  {p.reason}" if p.reason else "")


def between_said(b: Any) -> str:
    """What a run assumed of an input between samples (:class:`obsnl.estimation.intersample.InputBetween`), and
    whether the choice matters for this record."""
    how = {
        "held": "held (zero-order hold)",
        "linear": "linear between samples",
        "fft": "band-limited, interpolated by FFT (the record read as periodic)",
        "sinc": "band-limited, interpolated by a windowed sinc (the record not periodic: its ends reflected, the "
        "first and last samples' in-between values approximate)",
    }
    text = f"input {b.input} {how[b.route]}"
    if b.kind == "bandlimited":
        return text + (
            f"; {100 * b.discrepancy:.2g} % of its power lies above 0.45 of the sampling rate: it may "
            "not be band-limited (aliased)"
            if b.matters
            else ""
        )
    if not b.matters:
        return text
    return text + (
        f"; if it was band-limited, this kind is off by {100 * b.discrepancy:.2g} % RMS between samples "
        f"(judged from its Welch spectrum): the choice matters (intersample {b.input}=bandlimited if it "
        f"was band-limited, zoh if it was held by a DAC)"
    )
