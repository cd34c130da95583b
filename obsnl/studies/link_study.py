"""The observer-bank benchmark on the 6-element cantilever link (docs/observer_bank.md §2;
seed ``001_d0508a78c5399696.txt``): healthy and cracked scenarios, calibration seeds, the bank's
decisions and the honest scoring, as one frozen :class:`LinkStudy` value."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from obsnl.errors import AnalysisError, DataError, ModelError
from obsnl.linear.bank import BankDecision, Thresholds, build_bank, calibrate_thresholds, decide, json_float
from obsnl.linear.gains import ObserverDesign
from obsnl.linear.observer import ExtendedObservability, extended_observability, integrator
from obsnl.observability.verdicts import Verdict
from obsnl.studies.cantilever import BreathingCrack, LinkSimulation, build_cantilever
from obsnl.studies.link_model import LinkSpec, LinkTable, read_link_spec

__all__ = [
    "ScenarioRun",
    "GateCheck",
    "LinkSettings",
    "BankObserver",
    "LinkStudy",
    "run_link_study",
    "BankSettings",
    "check_bank_settings",
    "study_cost",
    "BANK_KEYS",
    "MAX_SAMPLES",
    "MAX_SEEDS",
    "MAX_STUDY_BYTES",
    "MAX_STUDY_WORK",
]

#: The keys of a link model's ``[bank]`` table (all required).
BANK_KEYS = (
    "observer_elements",
    "channels",
    "sensor_set",
    "q_x",
    "q_v",
    "dt",
    "duration",
    "onset",
    "evaluation_window",
    "detection_window",
    "threshold_factor",
    "ratio_band",
    "crack_elements",
)
#: Most time samples (``duration / dt + 1``) of a simulated run (the benchmark has 30 001).
MAX_SAMPLES = 1_000_000

#: Most evaluation (and calibration) noise seeds of one study.
MAX_SEEDS = 1000
#: Largest estimated peak memory of a study, in bytes (the benchmark with 3 seeds needs about 0.4 GiB).
MAX_STUDY_BYTES = 4 * 1024**3
#: Largest estimated work of a study, in multiply-adds (the benchmark with 3 seeds needs about 7e9).
MAX_STUDY_WORK = 5e11
_STEP_COST = 1e4  # a Python-level time step, counted as this many multiply-adds
_CHUNK = 2048  # time steps per block of ObserverBank.run_many


@dataclass(frozen=True)
class ScenarioRun:
    """One scenario with one noise seed: the crack (None = healthy), the truth and the decision."""

    scenario: str
    crack_element: int | None
    seed: int
    truth_rms: float
    decision: BankDecision

    def to_dict(self) -> dict:
        return {
            "scenario": self.scenario,
            "crack_element": self.crack_element,
            "seed": self.seed,
            "truth_rms": json_float(self.truth_rms),
            **self.decision.to_dict(),
        }


@dataclass(frozen=True)
class GateCheck:
    """Extended-system test of one sensor set / channel set / observer element (docs/observer_bank.md 2.6.6)."""

    sensors: str
    channels: tuple[str, ...]
    element: int
    check: ExtendedObservability

    @property
    def condition(self) -> float | None:
        """The largest static-gain condition number over the channels (None without a channel; infinite for a
        singular gain)."""
        return max(c.condition for c in self.check.channels) if self.check.channels else None

    def to_dict(self) -> dict:
        return {
            "sensors": self.sensors,
            "channels": list(self.channels),
            "element": self.element,
            "verdict": self.check.verdict.value,
            "reason": self.check.reason,
            "n_outputs": self.check.n_outputs,
            "n_channels": self.check.n_channels,
            "static_gain_singular_values": list(self.check.channels[0].singular_values),
            "condition": None if self.condition is None else json_float(self.condition),
        }


@dataclass(frozen=True)
class LinkSettings:
    """What a :class:`LinkStudy` ran with (SI units): the model's ``source``, the sensor set and force channels,
    the crack severity and the noise (a fraction of the healthy RMS), the checked ``[bank]`` numbers
    (:func:`check_bank_settings`), the fictitious force model and the evaluation and calibration noise seeds.

    Examples
    --------
    >>> s = LinkSettings(model="m", sensors="S1", channels=("moment",), severity=0.3, noise=0.01, dt=2e-4,
    ...     duration=6.0, onset=3.0, detection_window=0.5, evaluation_window=3.0, threshold_factor=3.0,
    ...     ratio_band=1.5, q_x=1.0, q_v=1e8, fictitious_model="integrator", evaluation_seeds=(0,),
    ...     calibration_seeds=(1000,))
    >>> s.to_dict()["channels"], s.to_dict()["evaluation_seeds"]
    (['moment'], [0])
    """

    model: str
    sensors: str
    channels: tuple[str, ...]
    severity: float
    noise: float
    dt: float
    duration: float
    onset: float
    detection_window: float
    evaluation_window: float
    threshold_factor: float
    ratio_band: float
    q_x: float
    q_v: float
    fictitious_model: str
    evaluation_seeds: tuple[int, ...]
    calibration_seeds: tuple[int, ...]

    def to_dict(self) -> dict[str, Any]:
        """The ``settings`` of ``bank.json``, in this order (tuples as lists)."""
        return {
            "model": self.model,
            "sensors": self.sensors,
            "channels": list(self.channels),
            "severity": self.severity,
            "noise": self.noise,
            "dt": self.dt,
            "duration": self.duration,
            "onset": self.onset,
            "detection_window": self.detection_window,
            "evaluation_window": self.evaluation_window,
            "threshold_factor": self.threshold_factor,
            "ratio_band": self.ratio_band,
            "q_x": self.q_x,
            "q_v": self.q_v,
            "fictitious_model": self.fictitious_model,
            "evaluation_seeds": list(self.evaluation_seeds),
            "calibration_seeds": list(self.calibration_seeds),
        }


@dataclass(frozen=True, eq=False)
class BankObserver:
    """One observer of the bank: its ``label``, the link ``element`` it watches, the ``check`` (verdict) of its
    extended system (:func:`~obsnl.linear.observer.extended_observability`) and its gain ``design``."""

    label: str
    element: int
    check: Verdict
    design: ObserverDesign

    def to_dict(self) -> dict[str, Any]:
        """One entry of ``observers`` in ``bank.json`` (the verdict as its text)."""
        return {
            "label": self.label,
            "element": self.element,
            "check": self.check.value,
            "design": self.design.to_dict(),
        }


@dataclass(frozen=True, eq=False)
class LinkStudy:
    """Result of :func:`run_link_study`. ``traces`` (first evaluation seed per scenario:
    ``(t, nhat, n_true)``) are kept for plots and left out of :meth:`to_dict`."""

    settings: LinkSettings
    thresholds: Thresholds
    gates: tuple[GateCheck, ...]
    runs: tuple[ScenarioRun, ...]
    observers: tuple[BankObserver, ...]
    traces: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False)

    def to_dict(self) -> dict:
        return {
            "settings": self.settings.to_dict(),
            "thresholds": self.thresholds.to_dict(),
            "observers": [o.to_dict() for o in self.observers],
            "gates": [g.to_dict() for g in self.gates],
            "runs": [r.to_dict() for r in self.runs],
        }


def run_link_study(
    *,
    seeds: int | Sequence[int] = 3,
    calibration_seeds: Sequence[int] | None = None,
    spec: LinkSpec | None = None,
    gates: bool = True,
) -> LinkStudy:
    """Run the scenarios of docs/observer_bank.md section 2.5 on the cantilever link.

    A healthy link and a breathing crack in each element listed in the model file's
    ``[bank] crack_elements``, each with every evaluation noise seed; thresholds come from
    healthy runs with the ``calibration_seeds`` (default ``1000, 1001, ...``, one per
    evaluation seed), which must differ from the evaluation seeds.

    Parameters
    ----------
    seeds : int or sequence of int
        Number of evaluation seeds (``0..K-1``) or the seeds themselves.
    calibration_seeds : sequence of int or None
        Noise seeds of the healthy calibration runs.
    spec : LinkSpec or None
        A :class:`obsnl.studies.link_model.LinkSpec` (default: the packaged ``obsnl:cantilever_link``).
    gates : bool
        Also run the observability gate of section 2.6.6 (S4 with s = 2, S1 with s = 1 and 2).

    Returns
    -------
    LinkStudy

    Raises
    ------
    DataError
        No, too many (over :data:`MAX_SEEDS`) or shared evaluation and calibration seeds.
    ModelError
        A bad spec (see :func:`obsnl.studies.link_model.read_link_spec`), or a study whose estimated
        memory or work (:func:`study_cost`) is over :data:`MAX_STUDY_BYTES` or :data:`MAX_STUDY_WORK`;
        checked before any simulation.
    AnalysisError
        An observer is not observable, or a simulation or estimate is not finite.
    """
    ev = _seed_list(seeds, "evaluation")
    cal = (
        [1000 + i for i in range(len(ev))]
        if calibration_seeds is None
        else _seed_list(calibration_seeds, "calibration")
    )
    if set(cal) & set(ev):
        raise DataError(f"calibration seeds {cal} must be non-empty and differ from the evaluation seeds {ev}")
    spec = read_link_spec() if spec is None else spec
    cfg = check_bank_settings(spec)
    size, work = study_cost(spec, n_seeds=len(ev), n_calibration=len(cal), settings=cfg)
    if size > MAX_STUDY_BYTES or work > MAX_STUDY_WORK:
        what = (
            f"about {size / 1024**3:.3g} GiB of memory, over the limit of {MAX_STUDY_BYTES / 1024**3:g} GiB"
            if size > MAX_STUDY_BYTES
            else f"about {work:.2g} multiply-adds, over the limit of {MAX_STUDY_WORK:g}"
        )
        raise ModelError(
            f"this study ({spec.n_elements} elements, {len(cfg.observer_elements)} observers, "
            f"{len(cfg.crack_elements)} crack scenarios, {len(ev)} evaluation and {len(cal)} "
            f"calibration seeds, {cfg.samples:,} time samples) needs {what}; use fewer elements, "
            f"observers, scenarios, seeds or time samples (duration / dt)"
        )
    beam = build_cantilever(spec)
    dt, T, onset = cfg.dt, cfg.duration, cfg.onset
    elements, chans = list(cfg.observer_elements), cfg.channels
    sensors, cracks = cfg.sensor_set, list(cfg.crack_elements)
    win_det, win_ev = cfg.detection_window, cfg.evaluation_window
    factor, band, q_x, q_v = cfg.threshold_factor, cfg.ratio_band, cfg.q_x, cfg.q_v
    f1 = float(beam.modal_frequencies()[0])
    if not f1 < 0.5 / dt:
        raise ModelError(
            f"the link's first natural frequency {f1:.3g} Hz is above the Nyquist frequency "
            f"1 / (2 dt) = {0.5 / dt:g} Hz; check the [structure] numbers (SI units) or lower dt"
        )
    plant = beam.system(sensors)
    healthy = beam.simulate(dt=dt, duration=T)
    _finite(healthy.x, "the simulation of the healthy link")
    y0 = healthy.x @ plant.C.T
    rms = np.sqrt(np.mean(y0**2, axis=0))
    sigma = beam.spec.noise * rms
    bank = build_bank(
        plant,
        {str(e): beam.crack_distribution(e, chans) for e in elements},
        integrator(len(chans)),
        dt=dt,
        R=np.var(y0, axis=0),
        q_x=q_x,
        q_v=q_v,
        output_scale=sigma,
    )

    def noisy(x: np.ndarray, seed_list: Sequence[int]) -> list[np.ndarray]:
        y = x @ plant.C.T
        return [y + np.random.default_rng(s).standard_normal(y.shape) * sigma for s in seed_list]

    sims: dict[str, tuple[int | None, LinkSimulation]] = {"healthy": (None, healthy)}
    for c in cracks:
        sims[f"crack{c}"] = (c, beam.simulate(dt=dt, duration=T, crack=BreathingCrack(c, beam.spec.severity, onset)))
        _finite(sims[f"crack{c}"][1].x, f"the simulation with a crack in element {c}")
    records = noisy(healthy.x, cal) + [y for _, sim in sims.values() for y in noisy(sim.x, ev)]
    outs = bank.run_many(healthy.u, records)  # one vectorised pass over all runs
    for o in outs:
        _finite(o.nhat, "the observer bank's force estimates")
    thr = calibrate_thresholds(outs[: len(cal)], window=win_det, factor=factor, seeds=cal)
    runs: list[ScenarioRun] = []
    traces: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    w = healthy.t >= T - win_ev + 0.5 * dt
    for i, (name, (cracked, sim)) in enumerate(sims.items()):
        truth = float(np.sqrt(np.mean(sim.n_true[w] ** 2)))
        for k, s in enumerate(ev):
            out = outs[len(cal) + i * len(ev) + k]
            dec = decide(out, thr, evaluation_window=win_ev, onset=None if cracked is None else onset, ratio_band=band)
            runs.append(ScenarioRun(name, cracked, s, truth, dec))
            traces.setdefault(name, (out.t, out.nhat, sim.n_true))
    gate_list = []
    if gates:
        for sset, ch in (("S4", ("moment", "shear")), ("S1", ("moment",)), ("S1", ("moment", "shear"))):
            for e in elements:
                chk = extended_observability(beam.system(sset), beam.crack_distribution(e, ch), integrator(len(ch)))
                gate_list.append(GateCheck(sset, ch, e, chk))
    settings = LinkSettings(
        model=beam.spec.source,
        sensors=sensors,
        channels=chans,
        severity=beam.spec.severity,
        noise=beam.spec.noise,
        dt=dt,
        duration=T,
        onset=onset,
        detection_window=win_det,
        evaluation_window=win_ev,
        threshold_factor=factor,
        ratio_band=band,
        q_x=q_x,
        q_v=q_v,
        fictitious_model="integrator",
        evaluation_seeds=tuple(ev),
        calibration_seeds=tuple(cal),
    )
    observers = tuple(
        BankObserver(label=lab, element=int(lab), check=chk.verdict, design=d)
        for lab, chk, d in zip(bank.labels, bank.checks, bank.designs)
    )
    return LinkStudy(settings, thr, tuple(gate_list), tuple(runs), observers, traces)


def _seed_list(seeds: int | Sequence[int], what: str) -> list[int]:
    """Seeds ``0..K-1`` for an int ``K``, else the given ones; 1 to :data:`MAX_SEEDS` distinct whole numbers."""
    if isinstance(seeds, (int, np.integer)) and not isinstance(seeds, bool):
        if not 1 <= seeds <= MAX_SEEDS:
            raise DataError(f"need at least one {what} seed and at most {MAX_SEEDS}, got {seeds!r}")
        return list(range(int(seeds)))
    if isinstance(seeds, (str, bytes)) or not isinstance(seeds, (Sequence, np.ndarray)):
        raise DataError(f"{what} seeds must be a count or a list of whole numbers, got {type(seeds).__name__}")
    if not 1 <= len(seeds) <= MAX_SEEDS:
        raise DataError(f"need at least one {what} seed and at most {MAX_SEEDS}, got {len(seeds)}")
    out = []
    for s in seeds:
        if isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 0:
            raise DataError(f"{what} seed {s!r} is not a whole number >= 0")
        out.append(int(s))
    if len(set(out)) != len(out):
        raise DataError(f"the {what} seeds {out} repeat a seed; give distinct seeds")
    return out


def _finite(x: np.ndarray, what: str) -> None:
    if not np.all(np.isfinite(x)):
        raise AnalysisError(
            f"{what} is not finite (overflow); check the model's [structure], [excitation] and "
            f"[bank] numbers (SI units)"
        )


@dataclass(frozen=True, kw_only=True)
class BankSettings:
    """The ``[bank]`` table of a link model, checked (:func:`check_bank_settings`); one field per key of
    :data:`BANK_KEYS`.

    Attributes
    ----------
    observer_elements : tuple of int
        The elements the bank hypothesises a crack in (one observer each), 1 = root.
    channels : tuple of str
        The crack's force channels (``"moment"``, ``"shear"``).
    sensor_set : str
        The sensor set of ``[sensors]`` measured.
    crack_elements : tuple of int
        The cracked scenarios simulated (may be empty: the healthy link alone).
    q_x, q_v : float
        Process noise of the observers' displacement and velocity states.
    threshold_factor, ratio_band : float
        The detection threshold over the calibrated level, and the band of residual ratios read as a tie.
    dt, duration : float
        Time step and length of a simulated record, in seconds.
    onset, evaluation_window, detection_window : float
        When the crack starts, the window its location is judged over, and the detection window, in seconds.
    """

    observer_elements: tuple[int, ...]
    channels: tuple[str, ...]
    sensor_set: str
    crack_elements: tuple[int, ...]
    q_x: float
    q_v: float
    threshold_factor: float
    ratio_band: float
    dt: float
    duration: float
    onset: float
    evaluation_window: float
    detection_window: float

    @property
    def samples(self) -> int:
        """Time samples of a simulated record, ``duration / dt + 1``."""
        return int(round(self.duration / self.dt)) + 1


def check_bank_settings(spec: LinkSpec) -> BankSettings:
    """Check the ``[bank]`` table of a link model (``spec.bank``) before any work.

    Every key of :data:`BANK_KEYS` must be present and typed; observer and crack elements are distinct
    elements of the link; the record has at most :data:`MAX_SAMPLES` samples and samples the excitation
    above its Nyquist rate; the crack starts inside the record and both windows fit it, the evaluation
    window after the onset.

    Parameters
    ----------
    spec : LinkSpec
        From :func:`obsnl.studies.link_model.read_link_spec`.

    Returns
    -------
    BankSettings

    Raises
    ------
    ModelError
        One line naming the key, its value and the fix.

    Examples
    --------
    >>> check_bank_settings(read_link_spec()).observer_elements
    (2, 4, 6)
    """
    bk = LinkTable({"bank": spec.bank} if spec.bank else {}, "bank", spec.file or "link model", BANK_KEYS)
    ne, el = spec.n_elements, f" (elements are 1..{spec.n_elements}, 1 = root)"
    out: dict[str, Any] = {
        "observer_elements": bk.items("observer_elements", "whole numbers", hi=ne, what=el),
        "channels": bk.items("channels", "strings", choices=("moment", "shear")),
        "sensor_set": bk.raw("sensor_set"),
        "crack_elements": bk.items("crack_elements", "whole numbers", hi=ne, what=el, empty=True),
        **{k: bk.number(k) for k in ("q_x", "q_v", "threshold_factor", "dt", "duration")},
        "ratio_band": bk.number("ratio_band", 1.0, closed=True),
    }
    if not isinstance(out["sensor_set"], str) or out["sensor_set"] not in spec.sensors:
        raise bk.fail("sensor_set", f"is not a sensor set of [sensors]; use one of {', '.join(spec.sensors)}")
    dt, duration = out["dt"], out["duration"]
    if duration / dt > MAX_SAMPLES - 1:
        raise bk.fail(
            "duration",
            f"s with dt = {dt:g} s gives {duration / dt + 1:.3g} time samples, over the limit "
            f"of {MAX_SAMPLES:,} (the benchmark has 30,001); shorten the record or raise dt",
        )
    if duration < 2 * dt:
        raise bk.fail("duration", f"s must span at least two time steps (dt = {dt:g} s)")
    if spec.frequency >= 0.5 / dt:
        raise bk.fail(
            "dt",
            f"s samples the {spec.frequency:g}-Hz excitation at or below its Nyquist rate; "
            f"use dt < {0.5 / spec.frequency:g} s",
        )
    onset = out["onset"] = bk.number("onset", closed=True)
    if onset >= duration:
        raise bk.fail(
            "onset",
            f"s is not before the end of the record (duration = {duration:g} s); a crack must start inside the record",
        )
    ev = out["evaluation_window"] = bk.number("evaluation_window", closed=True)
    if not dt <= ev <= duration - onset + 0.5 * dt:
        raise bk.fail(
            "evaluation_window",
            f"s must lie between one time step (dt = {dt:g} s) and the "
            f"{duration - onset:g} s after the crack onset; the location is "
            f"judged over the last evaluation_window seconds",
        )
    det = out["detection_window"] = bk.number("detection_window", closed=True)
    if not dt <= det <= duration:
        raise bk.fail(
            "detection_window", f"s must lie between one time step (dt = {dt:g} s) and the duration ({duration:g} s)"
        )
    return BankSettings(**{k: out[k] for k in BANK_KEYS})


def study_cost(
    spec: LinkSpec, *, n_seeds: int, n_calibration: int, settings: BankSettings | None = None
) -> tuple[float, float]:
    """Estimated peak memory (bytes) and work (multiply-adds) of :func:`run_link_study`.

    Counts the arrays that grow with the record: the simulated states of every scenario, the noisy
    records, the bank's force estimates and residuals, its block state-transition matrix and the
    time-step loops. Used to refuse a study beyond :data:`MAX_STUDY_BYTES` or :data:`MAX_STUDY_WORK`
    before it starts.

    Parameters
    ----------
    spec : LinkSpec
        From :func:`obsnl.studies.link_model.read_link_spec`.
    n_seeds, n_calibration : int
        Numbers of evaluation and calibration seeds.
    settings : BankSettings or None
        ``spec``'s ``[bank]`` table checked already (:func:`check_bank_settings`), as :func:`run_link_study` has it;
        None: checked here.

    Returns
    -------
    tuple of float
        ``(bytes, multiply_adds)``.

    Examples
    --------
    >>> size, work = study_cost(read_link_spec(), n_seeds=3, n_calibration=3)
    >>> size < MAX_STUDY_BYTES and work < MAX_STUDY_WORK
    True
    """
    cfg = check_bank_settings(spec) if settings is None else settings
    N = cfg.samples
    n, m = 4 * spec.n_elements, len(spec.actuator_nodes)
    p = len(spec.sensors[cfg.sensor_set])
    J, s = len(cfg.observer_elements), len(cfg.channels)
    S = 1 + len(cfg.crack_elements)  # simulated scenarios
    R = n_calibration + S * n_seeds  # records through the bank
    ntot = J * (n + s)  # states of the whole bank
    chunk = min(N, _CHUNK)
    floats = (
        S * N * (n + m + 2)
        + 2 * N * n  # kept simulations, their input terms
        + 2 * R * N * p  # noisy records and their stacked copy
        + 2 * N * R * J
        + N * ntot  # force estimates and residuals, input terms of the bank
        + 2 * chunk * R * ntot
        + 2 * ntot**2
    )  # one block of bank states, the transition matrix
    work = N * (S * (n * n + _STEP_COST) + R * ntot * (ntot + p) + _STEP_COST)
    return 1.5 * 8.0 * floats, float(work)  # 1.5: temporaries
