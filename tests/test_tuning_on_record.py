"""The main job's tuning decisions are taken on the record at hand (issue 40, item 7).

``obsnl reproduce`` ranks the filter configurations on tuning noise seeds of the record it is given, then each
reported run confirms the first choice on its own data or, where it leaves the output misfit above the noise
floor, runs the next configurations of the ranking on those data and reports the smallest misfit
(:func:`obsnl.studies.seed_runs.reported_with_fallbacks`). Expected answers are derived in each test: from a
table of misfits written here, or from how the two records below are made.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import obsnl.studies.seed_runs as seed_runs
from obsnl.estimation.records import Record
from obsnl.identification.experiments import Tuning, make_filter
from obsnl.studies.seed_experiment import seed_setup
from obsnl.studies.seed_runs import FLOOR, RunResult, reported_with_fallbacks

# Two configurations. FROZEN has a prior std of 1e-6 on every log-parameter: its estimate cannot leave the guesses
# (1e-6 relative, a thousandth of the 0.1 % noise). FREE is a configuration the main job's grid holds.
FROZEN = Tuning(1e-6, 0.0, 1.0)
FREE = Tuning(0.2, 0.0, 1.0)


@pytest.fixture(scope="module")
def short():
    """The seed experiment on the first 300 samples of Northridge LOS270 (uncompiled: no compiler needed)."""
    return seed_setup(samples=300)


def test_two_records_favour_different_configurations_and_each_run_takes_its_own(short):
    # Record 1: the seed paper's structure (k_m = 1330 against a guess of 5000). FROZEN stays at the guesses, whose
    # response is another structure's, far above the noise floor there: FREE, second in the ranking, is run on the
    # same data and reported. Record 2: the same input, the structure AT the guesses (truth = guess). FROZEN's
    # estimate is then the structure itself and its misfit the noise alone (1x the noise level, plus what the
    # 0.1 % input noise adds: well under FLOOR = 2x), so it is kept and FREE never runs. The ranking is the same
    # for both: the records decide.
    at_guess = replace(short, truth=dict(short.guess), y_true=None)  # y_true: simulated again, at the guesses
    ukf = make_filter(short, "ukf")
    ranking = (FROZEN, FREE)
    on_truth, _ = reported_with_fallbacks(short, ukf, "ukf", 1, 0, ranking)
    on_guess, _ = reported_with_fallbacks(at_guess, make_filter(at_guess, "ukf"), "ukf", 1, 0, ranking)

    assert on_guess.tuning == FROZEN and on_guess.redone == ()
    assert on_guess.misfit <= FLOOR * at_guess.noise
    np.testing.assert_allclose(on_guess.theta, at_guess.theta_guess, rtol=1e-4)

    assert on_truth.tuning == FREE
    assert [a.tuning for a in on_truth.redone] == [FROZEN]
    assert on_truth.redone[0].misfit > FLOOR * short.noise  # the guesses do not explain record 1
    assert on_truth.misfit < on_truth.redone[0].misfit
    assert on_truth.practical is not None and on_guess.practical is not None  # the reported runs are judged


def _fake_runs(monkeypatch, table: dict[int, list[float]], noise: float) -> list[tuple[int, int]]:
    """``_reported_run`` replaced: configuration j on the data of seed s ends with misfit ``table[s][j]`` x the
    noise level (NaN: the run stopped). Returns the (seed, configuration) pairs run, in order."""
    ran: list[tuple[int, int]] = []

    def fake(setup, f, data, name, k, seed, tuning):
        j = int(tuning.s0)
        ran.append((seed, j))
        m = table[seed][j] * noise
        stopped = bool(np.isnan(m))
        return RunResult(
            method=name,
            passes=k,
            seed=seed,
            tuning=tuning,
            theta=(float(j),),
            seconds=0.0,
            repairs=0,
            implicit=0,
            misfit=m,
            practical=None,
            error="stopped" if stopped else "",
        ), None

    monkeypatch.setattr(seed_runs, "_reported_run", fake)
    monkeypatch.setattr(seed_runs, "make_data", lambda setup, seed: seed)
    return ran


def test_the_choice_on_each_seed_follows_that_seed_s_misfits(monkeypatch):
    # Misfits in times the noise level, configuration j (the ranking's j-th) on seed s, written here:
    # seed 0: the first is at the floor (1.1x <= 2x): kept, nothing else runs.
    # seed 1: none reaches the floor; the fourth (index 3) is the smallest of the 4 allowed (fallbacks=3).
    # seed 2: the first two stop (NaN), the third is at the floor: kept, the fourth never runs.
    # seed 3: every run stops: the last one tried is reported, as a failed run.
    # seed 4: a tie at 3x between 1 and 2: the earlier of the ranking wins.
    nan = float("nan")
    table = {
        0: [1.1, 0.5, 0.5, 0.5, 0.5],
        1: [9.0, 4.0, 700.0, 2.5, 1.0],
        2: [nan, nan, 1.5, 0.1, 0.1],
        3: [nan, nan, nan, nan, 0.1],
        4: [5.0, 3.0, 3.0, 8.0, 0.1],
    }
    noise = 1e-3
    ran = _fake_runs(monkeypatch, table, noise)
    setup = type("S", (), {"noise": noise})()
    ranking = tuple(Tuning(float(j), 0.0, 1.0) for j in range(5))
    chosen = {s: reported_with_fallbacks(setup, None, "ukf", 3, s, ranking, fallbacks=3)[0] for s in table}

    assert [int(chosen[s].tuning.s0) for s in range(5)] == [0, 3, 2, 3, 1]
    assert [j for s, j in ran if s == 0] == [0]
    assert [j for s, j in ran if s == 1] == [0, 1, 2, 3]  # at most 1 + fallbacks
    assert [j for s, j in ran if s == 2] == [0, 1, 2]
    assert chosen[3].failed and len(chosen[3].redone) == 3
    assert chosen[1].misfit == pytest.approx(2.5 * noise)
    assert [a.misfit for a in chosen[1].redone] == pytest.approx([9 * noise, 4 * noise, 700 * noise])
    assert chosen[0].redone == () and chosen[4].misfit == pytest.approx(3 * noise)


def test_the_tuning_runs_on_the_record_the_job_is_given(monkeypatch):
    # A tuning task of `obsnl reproduce --record R` must score its configuration on R's data: here R is a made-up
    # record (a 2 Hz sine of 0.5 m/s^2), and the data the tuning sees must be R plus its 0.1 % noise, not Northridge.
    import obsnl.studies.seed_tasks as tasks
    from obsnl.studies.seed_experiment import seed_branch_table

    t = np.arange(200) * 0.01
    record = Record(name="sine_2hz", accel=0.5 * np.sin(2 * np.pi * 2.0 * t), dt=0.01)
    seen = {}

    def spy(setup, filt, data, tuning, *, passes):
        seen["u"], seen["tuning"] = np.asarray(data.u), tuning
        return {1: 0.0, passes: 0.0}

    monkeypatch.setattr(tasks, "tune_one", spy)
    table, _ = seed_branch_table()
    spec = tasks.Spec(record=record, samples=None, jit=False, table_json=table.to_json())
    tasks.tuning_task((spec, "ukf", FREE, 1000, 1))
    assert seen["tuning"] == FREE and seen["u"].shape == (200,)
    # the data's input is the record's own samples with 0.1 % noise (RMS): within 1 % of the record's RMS
    rms = np.sqrt(np.mean(record.accel**2))
    assert np.sqrt(np.mean((seen["u"] - record.accel) ** 2)) < 0.01 * rms


def test_table2_names_the_runs_left_above_the_noise_floor_and_points_to_the_ml_column():
    # Made-up runs at a noise ratio of 1e-3 and a floor of 2x: misfits 0.0015 (1.5x, at the floor), 0.0031 (3.1x),
    # NaN (stopped), and an ablation run at 9x (never named: it is not a column one reads for the result).
    from types import SimpleNamespace as Values  # the fields _above_floor reads of a reproduction and its runs

    from obsnl.report.identification.table2 import _above_floor

    def run(method, passes, seed, misfit):
        return Values(method=method, passes=passes, seed=seed, misfit=misfit)

    doc = Values(
        noise_floor_factor=2.0,
        experiment=Values(noise_ratio=1e-3),
        runs=[
            run("ukf", 3, 0, 0.0015),
            run("dukf", 3, 0, 0.0031),
            run("dukf", 3, 1, float("nan")),
            run("ukf", 1, 1, 0.0019),
            run("dukf-zero", 3, 0, 0.009),
        ],
    )
    (text, blank) = _above_floor(doc, with_ml=True)
    named = text.split("configuration it tried): ")[1].split(". Such")[0]
    assert named == "DUKF, 3 pass(es): seed(s) 0, 1"  # the UKF's runs are at or under the floor
    assert "maximum-likelihood column" in text and blank == ""
    assert _above_floor(Values(**{**vars(doc), "runs": doc.runs[:1]}), with_ml=True) == []
    assert _above_floor(Values(**{**vars(doc), "noise_floor_factor": None}), with_ml=True) == []


def test_no_configuration_to_run_is_refused_in_one_line():
    from obsnl.errors import OptionError

    for ranking, fallbacks in (((), 2), ((FREE, FROZEN), -2)):
        with pytest.raises(OptionError, match="no tuning to run"):
            reported_with_fallbacks(None, None, "ukf", 1, 0, ranking, fallbacks=fallbacks)
