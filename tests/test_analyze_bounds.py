"""Bounded analyses: a huge ``--unknown-input-derivatives`` or a model too large for the engines'
dense arrays is refused with one line before any heavy work, and a MemoryError inside an analysis
ends as one line too (never a traceback, an out-of-memory kill or an unbounded run).

Every refusal test replaces the first heavy step (the split into branches) by a tripwire, so a
missing refusal fails at once instead of allocating terabytes.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import obsnl
import obsnl.observability.analyze as analyze_module
import obsnl.observability.engines.smooth as smooth_module
from obsnl import Model, analyze
from obsnl.observability import sedoglavic
from obsnl.cli import main
from obsnl.errors import AnalysisError, ModelError, OptionError
from obsnl.observability.limits import MAX_UNKNOWNS

CATALOGUE = Path(obsnl.__file__).resolve().parents[1] / "models"

UI_TOML = """name = "ui"
states = ["x", "v"]
parameters = ["c", "k"]
unknown_inputs = ["w"]
{extra}
[equations]
x = "v"
v = "-c*v - k*x + w"

[outputs]
y = "x"
"""


def _ui_file(tmp_path: Path, extra: str = "") -> Path:
    path = tmp_path / "ui.toml"
    path.write_text(UI_TOML.format(extra=extra), encoding="utf-8")
    return path


def _chain_file(tmp_path: Path, n: int) -> Path:
    """The linear chain s_i' = -k s_i + u (i < n), y = s_0, written like the catalogue's TOML files."""
    lines = [f'name = "chain{n}"', "states = [" + ", ".join(f'"s{i}"' for i in range(n)) + "]",
             'parameters = ["k"]', 'inputs = ["u"]', "", "[outputs]", 'y = "s0"', "", "[equations]"]
    lines += [f's{i} = "-k*s{i} + u"' for i in range(n)]
    path = tmp_path / f"chain{n}.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _ui_model(**changes) -> Model:
    return Model(name="ui", states=["x", "v"], parameters=["c", "k"], unknown_inputs=["w"],
                 equations={"x": "v", "v": "-c*v - k*x + w"}, outputs={"y": "x"}, **changes)


@pytest.fixture
def tripwire(monkeypatch: pytest.MonkeyPatch) -> pytest.MonkeyPatch:
    """Make the first heavy step of an analysis fail loudly (no refusal came before it)."""

    def heavy(*args, **kwargs):
        raise AssertionError("the analysis started: the refusal must come before any heavy work")

    monkeypatch.setattr(analyze_module, "select_branches", heavy)
    monkeypatch.setattr(smooth_module, "_branch_result", heavy)
    return monkeypatch


def _one_line(capsys: pytest.CaptureFixture, code: int, *words: str) -> str:
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and err.count("\n") == 1, err
    for w in words:
        assert w in err, err
    return err


# ----------------------------------------------------------------------------- 1 unknown-input derivatives
@pytest.mark.parametrize("k", ["999999", "5000", "21"])
def test_cli_refuses_more_unknown_input_derivatives_than_the_model_can_use(tmp_path, capsys, tripwire, k) -> None:
    # 999999 was a 7.28 TiB _ArrayMemoryError traceback, 5000 ran for minutes; the bound for
    # 2 states + 2 parameters is 2 + 2 + 16 = 20, so 21 is the first value refused
    code = main(["analyze", str(_ui_file(tmp_path)), "--unknown-input-derivatives", k])
    _one_line(capsys, code, "obsnl analyze: error:", f"--unknown-input-derivatives {k}", "at most 20",
              "'arbitrary'")


def test_the_bound_is_in_the_help_text(capsys) -> None:
    assert main(["analyze", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "K is at most the model's states + parameters + 16" in out
    assert f"more than {MAX_UNKNOWNS} unknowns" in out


def test_api_and_model_key_refuse_it_too(tmp_path, capsys, tripwire) -> None:
    with pytest.raises(OptionError, match="at most 20"):
        analyze(_ui_model(), seed=0, unknown_input_derivatives=21)
    with pytest.raises(OptionError, match="at most 20"):
        sedoglavic(_ui_model(), seed=0, unknown_input_derivatives=10**6)
    # the model file's key: named as such, refused by analyze and by the command line
    with pytest.raises(ModelError, match="the model's unknown_input_derivatives key = 999999"):
        analyze(_ui_model(unknown_input_derivatives=999999), seed=0)
    code = main(["analyze", str(_ui_file(tmp_path, "unknown_input_derivatives = 5000\n"))])
    _one_line(capsys, code, "unknown_input_derivatives key = 5000", "at most 20")
    tripwire.undo()  # the bound itself is still analysed
    r = analyze(_ui_model(), seed=0, unknown_input_derivatives=20)
    assert r.assumptions.unknown_input_derivatives == 20 and r.verdict.value == "observable"


# ----------------------------------------------------------------------------- 2 model size
def test_cli_refuses_the_3000_state_model_before_any_work(tmp_path, capsys, tripwire) -> None:
    # was killed for memory after ~95 s (24 GiB), or an _ArrayMemoryError traceback under an 8 GB cap
    code = main(["analyze", str(_chain_file(tmp_path, 3000)), "--max-seconds", "10"])
    _one_line(capsys, code, "obsnl analyze: error:", "'chain3000' has 3001 unknowns",
              "3000 states + 1 parameter", f"more than the {MAX_UNKNOWNS}", "GiB", "reduced model")


def test_report_refuses_it_before_analysing_any_model(tmp_path, capsys, tripwire) -> None:
    out = tmp_path / "out"
    code = main(["report", str(CATALOGUE / "coulomb_friction.toml"), str(_chain_file(tmp_path, MAX_UNKNOWNS)),
                 "--out", str(out)])
    _one_line(capsys, code, "obsnl report: error:", f"'chain{MAX_UNKNOWNS}' has {MAX_UNKNOWNS + 1} unknowns")
    assert not out.exists()


def test_api_counts_unknown_input_coefficients(tripwire) -> None:
    # 2 states + 2 parameters and 60 unknown inputs: K = 3 gives 4 + 60 * 4 = 244 unknowns (accepted
    # by the size check, reaching the tripwire); arbitrary ones 4 + 60 * 5 = 304, refused
    ws = [f"w{i}" for i in range(60)]
    m = Model(name="many_w", states=["x", "v"], parameters=["c", "k"], unknown_inputs=ws,
              equations={"x": "v", "v": "-c*v - k*x + " + " + ".join(ws)}, outputs={"y": "x"})
    with pytest.raises(AnalysisError, match="304 unknowns .2 states . 2 parameters . 300 unknown-input coefficients"):
        analyze(m, seed=0)
    with pytest.raises(AssertionError, match="the analysis started"):
        analyze(m, seed=0, unknown_input_derivatives=3)


# ----------------------------------------------------------------------------- MemoryError inside
def _memory_error(*args, **kwargs):
    try:
        from numpy._core._exceptions import _ArrayMemoryError
    except ImportError:  # pragma: no cover - older numpy
        raise MemoryError("Unable to allocate 7.28 TiB") from None
    import numpy as np

    raise _ArrayMemoryError((10**6, 10**6), np.dtype(np.int64))


def test_a_memory_error_inside_the_analysis_is_one_line(tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.setattr(analyze_module, "select_branches", _memory_error)
    monkeypatch.setattr(smooth_module, "_branch_result", _memory_error)
    with pytest.raises(AnalysisError, match="ran out of memory analysing model 'ui'"):
        analyze(_ui_model(), seed=0)
    with pytest.raises(AnalysisError, match="ran out of memory"):
        sedoglavic(_ui_model(), seed=0)
    path = _ui_file(tmp_path)
    _one_line(capsys, main(["analyze", str(path)]), "obsnl analyze: error: ran out of memory", "more memory")
    _one_line(capsys, main(["report", str(path), "--out", str(tmp_path / "out")]),
              "obsnl report: error: ran out of memory")


@pytest.mark.parametrize("entry", ["symmetries", "reparametrize", "joint_verdict"])
def test_the_other_entry_points_refuse_a_model_too_large_before_any_work(monkeypatch, entry):
    import obsnl.observability.joint.verdict as joint_module
    import obsnl.observability.certificates.symmetry as symmetry_module
    import obsnl.recombination.reparametrize as reparametrize_module
    from obsnl.observability.joint.verdict import joint_verdict
    from obsnl.observability.certificates.symmetry import symmetries
    from obsnl.recombination.reparametrize import reparametrize

    def tripwire(*args, **kwargs):  # the first heavy step of each entry point; never reached
        raise AssertionError("the heavy work started")

    monkeypatch.setattr(symmetry_module, "observability_jacobian", tripwire)
    monkeypatch.setattr(reparametrize_module, "split_branches", tripwire)
    monkeypatch.setattr(joint_module, "split_branches", tripwire)
    n = MAX_UNKNOWNS + 20
    eqs = {f"s{i}": f"-k*s{i} + u" for i in range(n)}
    m = Model(name="chain", states=list(eqs), parameters=["k"], inputs=["u"], equations=eqs, outputs={"y": "s0"})
    fn = {"symmetries": symmetries, "reparametrize": reparametrize, "joint_verdict": joint_verdict}[entry]
    with pytest.raises(AnalysisError, match=f"{n + 1} unknowns .* more than the {MAX_UNKNOWNS}"):
        fn(m)
