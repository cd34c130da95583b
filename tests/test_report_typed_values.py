"""The renderers of obsnl.report read the typed result values (issue 42, "typed results end to end"): each is given a
small value built here by hand and its text is compared with the rows written out below (never with obsnl's own output
captured at run time)."""

from __future__ import annotations

import math

from obsnl.design.ranking import RankedSet, Ranking
from obsnl.design.sensor_search import SensorSearch
from obsnl.report.sensors import render_sensors


# ----------------------------------------------------------------------------- the sensor ranking
def _ranked_search() -> SensorSearch:
    rows = (
        RankedSet(
            sensors=("x", "v"), worst_relative_std=0.0123, worst="k", log_det_fim=12.345, relative_std=(0.0123, 0.001)
        ),
        RankedSet(
            sensors=("x",), worst_relative_std=math.inf, worst="c", log_det_fim=-math.inf, relative_std=(0.5, math.inf)
        ),
    )
    ranking = Ranking(
        rows=rows,
        parameters=("k", "c"),
        nuisance=(),
        noise_level={"x": 0.01, "v": 0.01},
        noise_std={"x": 0.1, "v": 0.2},
        samples=10,
        dt=0.1,
        seconds=0.0,
    )
    return SensorSearch(
        model="m",
        candidates=("x", "v"),
        targets=("k", "c"),
        max_size=2,
        minimal_sets=(),
        ranking=ranking,
        effective_independence=("v", "x"),
    )


def test_the_sensor_ranking_is_rendered_from_its_ranked_sets():
    search = _ranked_search()
    text = render_sensors(search, "text").splitlines()
    start = text.index("ranking along the record (Cramer-Rao bound, best first):")
    # 3 significant digits; an infinity keeps its sign; the set effective independence chose (the same sensors in
    # another order) is marked
    assert text[start + 1 : start + 3] == [
        "  {x, v}: worst relative std 0.0123 (k), log det FIM 12.3  <- effective independence",
        "  {x}: worst relative std inf (c), log det FIM -inf",
    ]
    md = render_sensors(search, "md").splitlines()
    assert "| 1 | {x, v} | 0.0123 | k | 12.3 | chosen |" in md
    assert "| 2 | {x} | inf | c | -inf |  |" in md
    tex = render_sensors(search, "tex").splitlines()
    assert r"1 & \{\texttt{x}, \texttt{v}\} & 0.0123 & 12.3 \\" in tex
    assert r"2 & \{\texttt{x}\} & inf & -inf \\" in tex


def test_no_set_is_marked_without_an_effective_independence_choice():
    search = _ranked_search()
    plain = SensorSearch(
        model=search.model,
        candidates=search.candidates,
        targets=search.targets,
        max_size=2,
        minimal_sets=(),
        ranking=search.ranking,
    )
    text = render_sensors(plain, "text")
    assert "  {x, v}: worst relative std 0.0123 (k), log det FIM 12.3\n" in text
    assert "effective independence" not in text
    assert "| 1 | {x, v} | 0.0123 | k | 12.3 |  |" in render_sensors(plain, "md").splitlines()


# ----------------------------------------------------------------------------- the validation figure's titles
def test_the_validation_panels_are_titled_from_the_typed_scores():
    from obsnl.identification.validation.merit import OutputScore
    from obsnl.report.identification.validation import _title

    # RMSE in 4 significant digits, fit % with 2 decimals; a constant measured output has no fit (None), an output
    # without a score gets n/a for both
    assert _title("y", OutputScore("y", 0.012345, 0.1, 90.0, -20.0)) == "y: RMSE 0.01235, fit 90.00 %"
    assert _title("y", OutputScore("y", 2.0, None, None, 6.0)) == "y: RMSE 2, fit n/a %"
    assert _title("y", None) == "y: RMSE n/a, fit n/a %"


# ----------------------------------------------------------------------------- the observer-bank table
def _decision(labels, *, detected, ttd, magnitude, residual, margin, forces, outcome):
    from obsnl.linear.bank import BankDecision

    t_detect = None if ttd is None else 3.0 + ttd
    return BankDecision(
        labels=labels,
        detected=detected,
        false_alarm=False,
        t_detect=t_detect,
        time_to_detection=ttd,
        by_magnitude=magnitude,
        by_residual=residual,
        margin=margin,
        rms_force=forces,
        rms_residual=(1.0,) * len(labels),
        outcome=outcome,
        reason="",
    )


def _gate(sensors, channels, element, p, singular_values, condition, verdict, reason):
    from obsnl.linear.hautus import HautusResult
    from obsnl.linear.observer import ChannelTest, ExtendedObservability
    from obsnl.studies.link_study import GateCheck

    test = ChannelTest(eigenvalue=0j, method="G", singular_values=singular_values, deficiency=0, condition=condition)
    plant = HautusResult(n=4, tests=(), rtol=1e-9, weak_rtol=1e-6, scaling="none")
    check = ExtendedObservability(
        n_outputs=p,
        n_channels=len(channels),
        plant=plant,
        channels=(test,),
        verdict=verdict,
        detectable=True,
        reason=reason,
        weak_cond=1e6,
    )
    return GateCheck(sensors, channels, element, check)


def _bank_study(*, gates: bool):
    from obsnl.linear.bank import Detection, Thresholds
    from obsnl.observability.verdicts import Verdict
    from obsnl.studies.link_study import LinkSettings, LinkStudy, ScenarioRun

    labels = ("2", "4")
    settings = LinkSettings(
        model="m",
        sensors="S1",
        channels=("moment",),
        severity=0.3,
        noise=0.01,
        dt=2e-4,
        duration=6.0,
        onset=3.0,
        detection_window=0.1,
        evaluation_window=3.0,
        threshold_factor=3.0,
        ratio_band=1.5,
        q_x=1.0,
        q_v=1e8,
        fictitious_model="integrator",
        evaluation_seeds=(0, 1),
        calibration_seeds=(1000, 1001),
    )
    thr = Thresholds(labels=labels, tau=(0.3, 0.6), floor=(0.1, 0.2), factor=3.0, window=0.1, seeds=(1000, 1001))
    quiet = dict(detected=False, ttd=None, magnitude=None, residual=None, outcome=Detection.NOT_DETECTED)
    located = dict(detected=True, magnitude="2", residual="2", outcome=Detection.LOCATED)
    split = dict(detected=True, magnitude="2", residual="4", outcome=Detection.INCONCLUSIVE)  # the rules disagree
    runs = (
        ScenarioRun("healthy", None, 0, 0.0, _decision(labels, margin=1.2, forces=(0.05, 0.07), **quiet)),
        ScenarioRun("healthy", None, 1, 0.0, _decision(labels, margin=1.4, forces=(0.07, 0.09), **quiet)),
        ScenarioRun("crack1", 1, 0, 0.75, _decision(labels, ttd=0.02, margin=5.0, forces=(0.6, 0.1), **located)),
        # an infinite margin (the second force is 0) is null in bank.json and left out of the span
        ScenarioRun("crack1", 1, 1, 0.75, _decision(labels, ttd=0.05, margin=math.inf, forces=(0.8, 0.0), **split)),
    )
    checks = (
        _gate("S1", ("moment",), 2, 7, (4.87e-4,), 1.0, Verdict.OBSERVABLE, ""),
        # a singular static gain: an infinite condition number, shown as "–"
        _gate("S4", ("moment", "shear"), 4, 1, (1.01e-4, 0.0), math.inf, Verdict.UNOBSERVABLE, "p = 1 < s = 2"),
    )
    return LinkStudy(settings, thr, checks if gates else (), runs, ())


def test_the_bank_table_is_rendered_from_the_typed_study():
    from obsnl.report.bank import bank_table_markdown

    lines = bank_table_markdown(_bank_study(gates=True)).splitlines()
    assert lines[2] == (
        "Scenarios of docs/observer_bank.md section 2.5 (source: m). Sensors S1, force channels moment (integrator "
        "model, q_x = 1, q_v = 1e+08), crack severity 0.3, noise 1 % of the healthy RMS, dt = 0.0002 s, T = 6 s, "
        "crack onset at 3 s."
    )
    assert lines[4].startswith(
        "Evaluation seeds 0, 1; thresholds from healthy runs with the other seeds 1000, 1001: tau = 3 × the largest "
        "0.1-s sliding RMS. Location: RMS over the last 3 s; 'inconclusive' when the two largest forces are within a "
        "ratio of 1.5 or the rules disagree."
    )
    assert "the bank has observers at elements 2, 4 only" in lines[4]
    # thresholds: floor and tau in 4 decimals
    assert lines[8:10] == ["| 2 | 0.1000 | 0.3000 |", "| 4 | 0.2000 | 0.6000 |"]
    # per scenario: the mean RMS force over the seeds (0.06 = (0.05 + 0.07) / 2 ...), the span of the times to
    # detection and margins, each rule's and outcome's counts over the 2 seeds
    assert lines[13:17] == [
        "| scenario | crack element | truth RMS [N·m] | RMS n̂ obs 2 [N·m] | RMS n̂ obs 4 [N·m] | detected | "
        "time to detection [s] | magnitude rule | residual rule | margin | verdict |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
        "| healthy | – | 0.000 | 0.060 | 0.080 | 0/2 | – | – | – | 1.20–1.40 | not detected (2/2) |",
        "| crack1 | 1 | 0.750 | 0.700 | 0.050 | 2/2 | 0.020–0.050 | 2 (2/2) | 2 (1/2), 4 (1/2) | 5.00 | "
        "located (1/2), inconclusive (1/2) |",
    ]
    assert lines[18:] == [
        "## Observability gate of the extended system (section 2.6.6)",
        "",
        "| sensors | channels | element | p | s | verdict | static-gain singular values | condition | reason |",
        "|---|---|---|---|---|---|---|---|---|",
        "| S1 | moment | 2 | 7 | 1 | observable | 4.87e-04 | 1 | – |",
        "| S4 | moment+shear | 4 | 1 | 2 | unobservable | 1.01e-04, 0.00e+00 | – | p = 1 < s = 2 |",
    ]


def test_a_bank_study_without_gates_has_no_gate_table():
    from obsnl.report.bank import bank_table_markdown

    text = bank_table_markdown(_bank_study(gates=False))
    assert "Observability gate" not in text
    assert text.endswith("| 5.00 | located (1/2), inconclusive (1/2) |\n")
