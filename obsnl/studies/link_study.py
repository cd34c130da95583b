"""The observer-bank benchmark on the 6-element cantilever link (research notes observer_bank.md §2;
seed ``001_d0508a78c5399696.txt``): healthy and cracked scenarios, calibration seeds, the bank's
decisions and the honest scoring, as one frozen :class:`LinkStudy` value."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from obsnl.errors import DataError
from obsnl.linear.bank import (BankDecision, Thresholds, build_bank,
                               calibrate_thresholds, decide, _f)
from obsnl.linear.observer import ExtendedObservability, extended_observability, integrator
from obsnl.studies.cantilever import BreathingCrack, LinkSpec, build_cantilever

__all__ = ["ScenarioRun", "GateCheck", "LinkStudy", "run_link_study"]


@dataclass(frozen=True)
class ScenarioRun:
    """One scenario with one noise seed: the crack (None = healthy), the truth and the decision."""

    scenario: str
    crack_element: int | None
    seed: int
    truth_rms: float
    decision: BankDecision

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "crack_element": self.crack_element, "seed": self.seed,
                "truth_rms": _f(self.truth_rms), **self.decision.to_dict()}


@dataclass(frozen=True)
class GateCheck:
    """Extended-system test of one sensor set / channel set / observer element (observer_bank.md 2.6.6)."""

    sensors: str
    channels: tuple[str, ...]
    element: int
    check: ExtendedObservability

    def to_dict(self) -> dict:
        ch = [c.condition for c in self.check.channels]
        return {"sensors": self.sensors, "channels": list(self.channels), "element": self.element,
                "verdict": self.check.verdict.value, "reason": self.check.reason,
                "n_outputs": self.check.n_outputs, "n_channels": self.check.n_channels,
                "static_gain_singular_values": list(self.check.channels[0].singular_values),
                "condition": _f(max(ch)) if ch else None}


@dataclass(frozen=True, eq=False)
class LinkStudy:
    """Result of :func:`run_link_study`. ``traces`` (first evaluation seed per scenario:
    ``(t, nhat, n_true)``) are kept for plots and left out of :meth:`to_dict`."""

    settings: Mapping[str, Any]
    thresholds: Thresholds
    gates: tuple[GateCheck, ...]
    runs: tuple[ScenarioRun, ...]
    observers: tuple[Mapping[str, Any], ...]
    traces: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False)

    def to_dict(self) -> dict:
        return {"settings": dict(self.settings), "thresholds": self.thresholds.to_dict(),
                "observers": [dict(o) for o in self.observers], "gates": [g.to_dict() for g in self.gates],
                "runs": [r.to_dict() for r in self.runs]}


def run_link_study(*, seeds: int | Sequence[int] = 3, calibration_seeds: Sequence[int] | None = None,
                   spec: LinkSpec | None = None, gates: bool = True) -> LinkStudy:
    """Run the scenarios of observer_bank.md section 2.5 on the cantilever link.

    A healthy link and a breathing crack in each element listed in the model file's
    ``[bank] crack_elements``, each with every evaluation noise seed; thresholds come from
    healthy runs with the ``calibration_seeds`` (default ``1000, 1001, ...``, one per
    evaluation seed), which must differ from the evaluation seeds.

    Parameters
    ----------
    seeds
        Number of evaluation seeds (``0..K-1``) or the seeds themselves.
    calibration_seeds
        Noise seeds of the healthy calibration runs.
    spec
        A :class:`obsnl.studies.cantilever.LinkSpec` (default: the model file ``cantilever_link.toml``).
    gates
        Also run the observability gate of section 2.6.6 (S4 with s = 2, S1 with s = 1 and 2).
    """
    beam = build_cantilever(spec)
    cfg = beam.spec.bank
    ev = list(range(int(seeds))) if isinstance(seeds, (int, np.integer)) else [int(s) for s in seeds]
    if not ev or (isinstance(seeds, (int, np.integer)) and seeds < 1):
        raise DataError(f"need at least one evaluation seed, got {seeds!r}")
    cal = [1000 + i for i in range(len(ev))] if calibration_seeds is None else [int(s) for s in calibration_seeds]
    if not cal or set(cal) & set(ev):
        raise DataError(f"calibration seeds {cal} must be non-empty and differ from the evaluation seeds {ev}")
    try:
        dt, T, onset = float(cfg["dt"]), float(cfg["duration"]), float(cfg["onset"])
        elements, chans = [int(e) for e in cfg["observer_elements"]], tuple(cfg["channels"])
        sensors, cracks = str(cfg["sensor_set"]), [int(c) for c in cfg["crack_elements"]]
        win_det, win_ev = float(cfg["detection_window"]), float(cfg["evaluation_window"])
        factor, band, q_x, q_v = (float(cfg[k]) for k in ("threshold_factor", "ratio_band", "q_x", "q_v"))
    except KeyError as exc:
        raise DataError(f"the model file's [bank] table lacks {exc}; see models/cantilever_link.toml") from exc
    plant = beam.system(sensors)
    healthy = beam.simulate(dt=dt, duration=T)
    y0 = healthy.x @ plant.C.T
    rms = np.sqrt(np.mean(y0**2, axis=0))
    sigma = beam.spec.noise * rms
    bank = build_bank(plant, {str(e): beam.crack_distribution(e, chans) for e in elements}, integrator(len(chans)),
                      dt=dt, R=np.var(y0, axis=0), q_x=q_x, q_v=q_v, output_scale=sigma)

    def noisy(x: np.ndarray, seed_list: Sequence[int]) -> list[np.ndarray]:
        y = x @ plant.C.T
        return [y + np.random.default_rng(s).standard_normal(y.shape) * sigma for s in seed_list]

    sims = {"healthy": (None, healthy)}
    for c in cracks:
        sims[f"crack{c}"] = (c, beam.simulate(dt=dt, duration=T, crack=BreathingCrack(c, beam.spec.severity, onset)))
    records = noisy(healthy.x, cal) + [y for _, sim in sims.values() for y in noisy(sim.x, ev)]
    outs = bank.run_many(healthy.u, records)  # one vectorised pass over all runs
    thr = calibrate_thresholds(outs[: len(cal)], window=win_det, factor=factor, seeds=cal)
    runs, traces = [], {}
    w = healthy.t >= T - win_ev + 0.5 * dt
    for i, (name, (c, sim)) in enumerate(sims.items()):
        truth = float(np.sqrt(np.mean(sim.n_true[w] ** 2)))
        for k, s in enumerate(ev):
            out = outs[len(cal) + i * len(ev) + k]
            dec = decide(out, thr, evaluation_window=win_ev, onset=None if c is None else onset, ratio_band=band)
            runs.append(ScenarioRun(name, c, s, truth, dec))
            traces.setdefault(name, (out.t, out.nhat, sim.n_true))
    gate_list = []
    if gates:
        for sset, ch in (("S4", ("moment", "shear")), ("S1", ("moment",)), ("S1", ("moment", "shear"))):
            for e in elements:
                chk = extended_observability(beam.system(sset), beam.crack_distribution(e, ch), integrator(len(ch)))
                gate_list.append(GateCheck(sset, ch, e, chk))
    settings = {"model": beam.spec.source, "sensors": sensors, "channels": list(chans), "severity": beam.spec.severity,
                "noise": beam.spec.noise, "dt": dt, "duration": T, "onset": onset, "detection_window": win_det,
                "evaluation_window": win_ev, "threshold_factor": factor, "ratio_band": band, "q_x": q_x, "q_v": q_v,
                "fictitious_model": "integrator", "evaluation_seeds": ev, "calibration_seeds": cal}
    observers = tuple({"label": lab, "element": int(lab), "check": chk.verdict.value, "design": d.to_dict()}
                      for lab, chk, d in zip(bank.labels, bank.checks, bank.designs))
    return LinkStudy(settings, thr, tuple(gate_list), tuple(runs), observers, traces)
