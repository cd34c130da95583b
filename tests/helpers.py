"""Helpers shared by several test files: the command line as a function, one-line refusals, small model files,
and the hypothesis settings and checks of the property tests of hostile input.

Not a test module (pytest collects only ``test_*.py``); the test files import from it (``from .helpers import
...``). Fixtures live in ``tests/conftest.py``.
"""

from __future__ import annotations

import functools
import json
import os
import time
from datetime import timedelta
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

import obsnl
from obsnl import ObsnlError
from obsnl.cli import main

# --------------------------------------------------------------------------- the command line and model files
#: A harmonic oscillator with one parameter: the model file the probes edit.
BASE = {"name": "m", "states": ["x", "v"], "parameters": ["k"], "equations": {"x": "v", "v": "-k*x"},
        "outputs": {"y": "x"}}


def model_file(tmp_path: Path, fname: str = "m.json", **changes) -> Path:
    """:data:`BASE` with ``changes``, written as JSON to ``tmp_path / fname``."""
    p = tmp_path / fname
    p.write_text(json.dumps({**BASE, **changes}), encoding="utf-8")
    return p


def run(capsys, *argv: str) -> tuple[int, str]:
    """``obsnl`` with ``argv`` in this process: its exit code and its stripped stderr."""
    code = main(list(argv))
    err = capsys.readouterr().err.strip()
    return code, err


def one_line_refusal(code: int, err: str, *words: str) -> None:
    """Exit code 2 without a traceback, ``words`` in the last line of stderr (lines before it may be progress)."""
    assert code == 2, err
    assert "Traceback" not in err
    last = err.splitlines()[-1]
    for w in words:
        assert w in last, last


#: The shipped Northridge ground-motion record.
REC = Path(obsnl.__file__).parent / "studies" / "data" / "northridge1994_LOS270_ngawest2_accel.csv"
#: A short identification of the seed model from :data:`REC` (100 samples, one pass).
FAST_STUDY = ("identify", "obsnl:damage_healing_reparam", "--record", str(REC), "--samples", "100", "--passes", "1",
              "--s0", "0.2", "--no-refine")


def refused_in_one_line(code: int, err: str, *words: str) -> str:
    """Exit code 2 and stderr of exactly one line, without a traceback, holding ``words``; returns that line."""
    assert code == 2, err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    for w in words:
        assert w in err, err
    return err


def sine_record(path: Path, amplitude: float = 0.1, n: int = 1000) -> Path:
    """A ground-acceleration CSV of ``n`` samples of a sine at 1.3 rad/s, step 0.01 s."""
    t = np.arange(n) * 0.01
    path.write_text("time_s,accel_m_s2\n" + "".join(f"{a:.6f},{amplitude * np.sin(1.3 * a):.9f}\n" for a in t),
                    encoding="utf-8")
    return path


# --------------------------------------------------------------------------- property tests of hostile input
#: Examples per property (the ``ci`` profile); ``OBSNL_HYPOTHESIS_EXAMPLES`` overrides it.
EXAMPLES = int(os.environ.get("OBSNL_HYPOTHESIS_EXAMPLES", "60"))
#: Longest an example may take: a refusal is a fraction of a second, heavy work is not.
DEADLINE = timedelta(seconds=8)
#: Longest refusal message: echoed user text is cut to 80 characters, so a message stays short.
MAX_MESSAGE = 1000

_HEALTH = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much,
           HealthCheck.data_too_large]
settings.register_profile("hostile-ci", max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                          suppress_health_check=_HEALTH)
settings.register_profile("hostile-random", max_examples=EXAMPLES, deadline=None, derandomize=False,
                          database=None, suppress_health_check=_HEALTH)
SETTINGS = settings(settings.get_profile(
    "hostile-random" if os.environ.get("OBSNL_HYPOTHESIS_PROFILE") == "random" else "hostile-ci"))


def cpu_bounded(test):
    """``test`` failing when one example takes more than :data:`DEADLINE` of this process's CPU time (other
    processes on the machine do not count, unlike hypothesis's wall-clock deadline)."""
    @functools.wraps(test)
    def bounded(*args, **kwargs):
        t0 = time.process_time()
        test(*args, **kwargs)
        took = time.process_time() - t0
        assert took < DEADLINE.total_seconds(), f"one example took {took:.1f} s of CPU: heavy work before a refusal"
    return bounded


def _check_message(exc: BaseException) -> None:
    """An obsnl refusal: its own error type, one line, bounded."""
    assert isinstance(exc, ObsnlError), f"{type(exc).__name__}: {exc}"
    text = str(exc)
    assert text.strip(), "an empty message"
    assert "\n" not in text and "\r" not in text, f"a message of several lines: {text[:300]!r}"
    assert len(text) <= MAX_MESSAGE, f"a message of {len(text)} characters: {text[:200]!r}..."


def _error_lines(err: str) -> list[str]:
    """The lines of stderr that are not argparse's usage (``usage: ...`` and its indented continuation)."""
    return [line for line in err.splitlines() if not (line.startswith("usage:") or line.startswith(" "))]


def _check_cli_refusal(code: int, out: str, err: str) -> None:
    """Exit code 2, no traceback, exactly one ``obsnl ... error:`` line (argparse's usage aside), bounded."""
    assert "Traceback" not in err, err[-2000:]
    assert code == 2, f"exit {code}; stderr: {err[-500:]!r}; stdout: {out[-300:]!r}"
    lines = _error_lines(err)
    assert len(lines) == 1, f"{len(lines)} error lines: {lines[:5]!r}"
    assert lines[0].startswith("obsnl") and "error:" in lines[0], lines[0][:300]
    assert len(lines[0]) <= MAX_MESSAGE, f"an error line of {len(lines[0])} characters: {lines[0][:200]!r}..."


def _digits(n: int) -> str:
    return "9" * n


junk = st.text(max_size=12).filter(lambda s: s.strip() not in ("",)) | st.sampled_from(
    ["abc", "1.5", "1e3", "0x10", "1_0", "\u0661", " ", "", "--", "3 4", "nan", "inf", "-inf", "1,5", "\x00"])
bad_int = st.integers(-(10 ** 6), -1).map(str) | junk.filter(lambda s: not s.strip().isdigit()) | st.sampled_from(
    ["-" + _digits(30), "1.0", "2.", "1e2"])
bad_float = junk.filter(lambda s: _not_float(s)) | st.sampled_from(["1e", "e3", "1..2", "++1"])


def _not_float(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return True
    return False


# --------------------------------------------------------------------------- the readers' probes
#: A mass-spring-damper driven by a force ``f``: the model of the readers' probes.
MSD_BASE = {"name": "msd", "states": ["x", "v"], "parameters": ["k", "c"], "inputs": ["f"],
            "equations": {"x": "v", "v": "f - k*x - c*v"}, "outputs": {"y": "x"}, "guess": {"k": 1.5, "c": 0.2}}


def msd_file(tmp_path: Path, name: str = "m.json", **changes) -> Path:
    """:data:`MSD_BASE` with ``changes``, written as JSON to ``tmp_path / name``."""
    p = tmp_path / name
    p.write_text(json.dumps({**MSD_BASE, **changes}), encoding="utf-8")
    return p


#: A 10 kB text, which no message may echo whole.
LONG_TEXT = "z" * 10_000
