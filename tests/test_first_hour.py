"""A new user's first hour (issue 43 item 6): what was tried and what it must give."""

from __future__ import annotations

import json
import shutil

import obsnl
from obsnl.cli import build_parser
from obsnl.identification.results import ParameterEstimate

from .conftest import ROOT


def test_guess_takes_several_assignments_at_once():
    a = build_parser().parse_args(["identify", "m.toml", "--data", "d.csv", "--guess", "k=3", "c=0.5",
                                   "--guess", "m=2"])
    assert a.guess == [["k=3", "c=0.5"], ["m=2"]]


def test_identify_reads_the_guesses_given_at_once(monkeypatch, tmp_path):
    from obsnl.commands import identify

    seen = {}

    def fake_check(model, data, *, guess, **options):
        seen.update(guess)
        raise SystemExit(0)

    monkeypatch.setattr("obsnl.identification.identify.check_identify", fake_check)
    model = obsnl.Model(name="m", states=["x"], parameters=["k", "c"], inputs=["u"],
                        equations={"x": "-k*x - c*x + u"}, outputs={"y": "x"})
    try:
        identify.IdentifyRequest(model=model, data="d.csv", guess=[["k=3", "c=0.5"]])
    except SystemExit:
        pass
    assert seen == {"k": 3.0, "c": 0.5}


def test_the_quick_form_says_what_it_found(monkeypatch, tmp_path):
    # the reproduction's table2.json (here the committed one) read back: one line per filter and protocol, the ML
    # column among them, before the files
    from obsnl.commands import reproduce

    shutil.copy(ROOT / "reports" / "identification" / "table2.json", tmp_path / "table2.json")
    text, _ = reproduce.reproduce_printed(reproduce.ReproduceResult(tmp_path, (tmp_path / "table2.json",)))
    doc = json.loads((tmp_path / "table2.json").read_text())
    first = text.splitlines()[0]
    assert first.startswith("UKF, one pass") and "5 % goal" in first
    assert any(line.startswith("maximum likelihood") for line in text.splitlines()) == bool(doc.get("refinements"))
    assert text.rstrip().splitlines()[-1].startswith("wrote")


def test_summary_shows_the_interval_and_says_an_open_end():
    p = ParameterEstimate("k", guess=2.0, estimate=2.5, std=0.1, held=False, flagged=False, interval=(2.3, None))
    assert "95 % [2.3, open]" in p.summary()
    held = ParameterEstimate("c", guess=0.3, estimate=None, std=None, held=True, flagged=True, reason="flat")
    assert "95 %" not in held.summary()


def test_analyze_is_reproducible_by_default():
    m = obsnl.Model(name="osc", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
                    equations={"x": "v", "v": "-k*x - c*v + u"}, outputs={"y": "x"})
    a, b = obsnl.analyze(m), obsnl.analyze(m)

    def untimed(x):  # the answer without its wall times
        if isinstance(x, dict):
            return {k: untimed(v) for k, v in x.items() if "second" not in k}
        return [untimed(v) for v in x] if isinstance(x, list) else x

    assert a.seed == b.seed == 0 and untimed(a.to_dict()) == untimed(b.to_dict())
