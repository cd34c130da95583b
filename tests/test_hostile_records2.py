"""Hostile input, records and measured data (round 37): the CSV and AT2 readers in bounded time and memory,
numbers Python reads but a file should not hold, units in a column's name, files that are not regular.

Each test names the old behaviour it excludes.
"""

from __future__ import annotations

import os
import re
import threading
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from obsnl.errors import DataError
from obsnl.estimation import records
from obsnl.estimation.accelerogram import G
from obsnl.estimation.measured import read_measured
from obsnl.estimation.records import read_at2, read_csv, read_record, times_from_text

from .test_hostile_readers import one_line_refusal, run

AT2_HEAD = "PEER NGA STRONG MOTION DATABASE RECORD\ntest\nACCELERATION TIME SERIES IN UNITS OF G\n"


def record_csv(path: Path, rows: list[str], header: str = "time_s,accel_m_s2") -> Path:
    path.write_text(header + "\n" + "".join(r + "\n" for r in rows))
    return path


def data_csv(path: Path, n: int = 50, t0: float = 0.0) -> Path:
    path.write_text("time_s,f,y\n" + "".join(f"{t0 + k / 100:.2f},{np.sin(k):.6f},{np.cos(k):.6f}\n" for k in range(n)))
    return path


def in_time(call, seconds: float = 20.0):
    """``call()``'s result or exception, failing (not hanging) when it does not return within ``seconds``."""
    out: dict = {}

    def target():
        try:
            out["value"] = call()
        except BaseException as exc:  # noqa: BLE001 - handed back to the test
            out["error"] = exc

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(seconds)
    assert not thread.is_alive(), f"still running after {seconds} s (blocked?)"
    if "error" in out:
        raise out["error"]
    return out.get("value")


# ============================================================================ 1 the AT2 header in linear time
def test_a_long_4th_line_of_an_at2_file_is_refused_at_once(tmp_path):
    # used to: minutes in the regex (`\s*,?\s*` backtracking over 200 000 spaces)
    p = tmp_path / "x.AT2"
    p.write_text(AT2_HEAD + "NPTS=1" + " " * 200_000 + "X\n0.1 0.2\n")
    t0 = time.perf_counter()
    with pytest.raises(DataError, match="line 4 has 200,008 characters") as info:
        read_at2(p)
    assert time.perf_counter() - t0 < 5 and len(str(info.value)) < 300


def test_the_at2_header_pattern_is_linear():
    t0 = time.perf_counter()
    assert records._AT2_HEAD.search("NPTS=1" + " " * 200_000 + "X") is None
    assert records._AT2_HEAD.search(("NPTS=" + "1" * 12 + " ") * 20_000) is None
    assert time.perf_counter() - t0 < 2


@pytest.mark.parametrize("line", ["NPTS=   4, DT=   .0100 SEC", "NPTS= 4 DT= .01", "npts=4,dt=0.01",
                                  "  NPTS =4 ,  DT = 1e-2 SEC, 1-column format"])
def test_at2_headers_as_written_are_still_read(tmp_path, line):
    p = tmp_path / "x.AT2"
    p.write_text(AT2_HEAD + line + "\n  .1  .2  .3  .4\n")
    r = read_at2(p)
    assert r.dt == pytest.approx(0.01) and r.accel.tolist() == pytest.approx([0.1 * G, 0.2 * G, 0.3 * G, 0.4 * G])


# ============================================================================ 2 wide headers in linear time
def test_a_header_of_100_000_columns_is_read_in_linear_time(tmp_path):
    # used to: header.count(h) for each column, 30 s for 50 000 columns
    n = 100_000
    p = tmp_path / "d.csv"
    p.write_text("time_s,f,y," + ",".join(f"c{i}" for i in range(n)) + "\n"
                 + "".join(f"{k / 100},{k},{k * k}," + ",".join(["0"] * n) + "\n" for k in range(4)))
    t0 = time.perf_counter()
    m = read_measured(p, inputs=["f"], outputs=["y"])
    assert m.y[:, 0].tolist() == [0, 1, 4, 9] and time.perf_counter() - t0 < 5
    t0 = time.perf_counter()
    with pytest.raises(DataError, match="cannot tell the acceleration column") as info:
        read_csv(p)
    assert time.perf_counter() - t0 < 5 and len(str(info.value)) < 300
    p.write_text("time_s,f,y," + ",".join(["c"] * n) + "\n")
    with pytest.raises(DataError, match=f"column 'c' appears {n} times"):
        in_time(lambda: read_measured(p, inputs=["f"], outputs=["y"]), 5)


# ============================================================================ 3 a time beyond the floats
@pytest.mark.parametrize("cell", ["1e1000000", "-1e400", "9" * 400])
def test_a_time_beyond_the_floats_is_named(tmp_path, cell):
    # used to: decimal.Overflow, a traceback (the exact subtraction of absolute time)
    rows = ["1700000000,0.1", f"{cell},0.2", "1700000000.02,0.3"]
    with pytest.raises(DataError, match=f"line 3: column 'time_s': '{cell[:20]}.* is beyond the range"):
        read_csv(record_csv(tmp_path / "r.csv", rows))
    d = tmp_path / "d.csv"
    d.write_text("time_s,f,y\n" + "".join(r + ",0\n" for r in rows))
    with pytest.raises(DataError, match="line 3: column 'time_s'.* is beyond the range"):
        read_measured(d, inputs=["f"], outputs=["y"])
    t, start = times_from_text(["1700000000", cell])  # the Python function: an infinite time, no exception
    assert start == 1.7e9 and t[0] == 0 and np.isinf(t[1])


def test_a_value_beyond_the_floats_is_named_and_nan_stays_nan(tmp_path):
    with pytest.raises(DataError, match="line 3: column 'accel_m_s2': '1e400' is beyond the range"):
        read_csv(record_csv(tmp_path / "r.csv", ["0,1", "0.01,1e400", "0.02,1"]))
    with pytest.raises(DataError, match=r"line 3: NaN/inf value \(2 bad rows\)"):  # as before
        read_csv(record_csv(tmp_path / "r.csv", ["0,1", "0.01,nan", "0.02,-inf", "0.03,1"]))


def test_a_time_beyond_the_floats_from_the_command_line(tmp_path, capsys):
    rec = record_csv(tmp_path / "r.csv", ["1700000000,0.1", "1e1000000,0.2", "1700000000.02,0.3"])
    code, err = run(capsys, "analyze", "obsnl:coulomb_friction", "--record", str(rec))
    one_line_refusal(code, err, "line 3", "'time_s'", "beyond the range")


# ============================================================================ 4 memory
def test_memory_stays_within_a_few_times_the_file(tmp_path):
    # used to: every line kept as a string, a tuple and a list of cells, 50 bytes of memory per byte of file
    # (100 MB of '0,0,0' lines took 5.2 GB)
    p = tmp_path / "d.csv"
    with p.open("w") as fh:
        fh.write("time_s,f,y\n")
        for block in range(30):
            fh.write("".join(f"{k},0,1\n" for k in range(block * 10_000, (block + 1) * 10_000)))
    size = p.stat().st_size
    tracemalloc.start()
    try:
        m = read_measured(p, inputs=["f"], outputs=["y"])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(m.y) == 300_000 and m.dt == 1.0
    assert peak < 10 * size, (peak, size)


def test_over_the_cap_of_numbers_is_refused_with_one_line(tmp_path, monkeypatch):
    monkeypatch.setattr(records, "MAX_VALUES", 1000)
    p = data_csv(tmp_path / "d.csv", n=600)
    with pytest.raises(DataError, match="over 1,000 numbers to read; obsnl reads at most that many"):
        read_measured(p, inputs=["f"], outputs=["y"])
    p = tmp_path / "x.AT2"
    p.write_text(AT2_HEAD + "NPTS=2000, DT=0.01\n" + "0.1\n" * 2000)
    with pytest.raises(DataError, match="NPTS=2000 is over the 1,000 samples"):
        read_at2(p)


def test_a_line_over_the_limit_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(records, "MAX_LINE", 100)
    p = data_csv(tmp_path / "d.csv", n=30)
    p.write_text(p.read_text() + "0.30," + "1" * 200 + ",0\n")
    with pytest.raises(DataError, match="line 32 is over 100 characters"):
        read_measured(p, inputs=["f"], outputs=["y"])


def test_large_files_keep_their_values(tmp_path):
    # the fast path (numpy, many lines at once) and the line by line one agree, blank lines and NaN included
    n = 250_000
    t = np.arange(n) / 1000
    a = np.sin(t * 7)
    p = tmp_path / "r.csv"
    p.write_text("time_s,accel_m_s2\n" + "".join(f"{x:.3f},{float(y)!r}\n" for x, y in zip(t, a)))
    r = read_csv(p)
    assert len(r) == n and np.array_equal(r.accel, a) and r.dt == pytest.approx(1e-3)
    lines = p.read_text().splitlines()
    lines.insert(100_000, "")  # a blank line: that chunk is read line by line
    lines[200_000] = lines[200_000].split(",")[0] + ",nan"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"line 200001: NaN/inf value \(1 bad rows\)"):
        read_csv(p)
    d = tmp_path / "d.csv"
    d.write_text("time_s,f,y\n" + "".join(f"{1_700_000_000 + k / 1000:.3f},{float(y)!r},{k}\n" for k, y in enumerate(a)))
    m = read_measured(d, inputs=["f"], outputs=["y"])  # absolute time at 1 kHz: exact on the text
    assert m.dt == pytest.approx(1e-3, rel=1e-12) and np.array_equal(m.u[:, 0], a) and m.y[-1, 0] == n - 1


# ============================================================================ 5 units in the column's name
@pytest.mark.parametrize("name, unit", [
    ("accel_g", "g"), ("acc_cm_s2", "cm/s^2"), ("accel_gal", "gal"), ("a_mm_s2", "mm/s^2"),
    ("accel_in_s2", "in/s^2"), ("accel_ft_s2", "ft/s^2"), ("acceleration [cm/s^2]", "cm/s^2"),
    ("Accel (g)", "g"), ("accel_mg", "mg"), ("ag_ft/s/s", "ft/s^2"), ("acc_cms2", "cm/s^2"), ("vel_m_s", "m/s"),
])
def test_an_acceleration_in_other_units_is_refused(tmp_path, capsys, name, unit):
    # used to: accel_g read as m/s^2 (9.81 times too small), silently
    rec = record_csv(tmp_path / "r.csv", ["0,0.1", "0.01,0.2", "0.02,0.3"], header=f"time_s,{name}")
    with pytest.raises(DataError, match=re.escape(f"the acceleration column '{name}' is in {unit}, not m/s^2; convert "
                                                  f"it to m/s^2 and name it 'accel_m_s2'")):
        read_record(rec)
    with pytest.raises(DataError, match=re.escape(f"is in {unit}, not m/s")):
        read_csv(rec, column=name)
    code, err = run(capsys, "analyze", "obsnl:coulomb_friction", "--record", str(rec))
    one_line_refusal(code, err, f"is in {unit}", "accel_m_s2")


@pytest.mark.parametrize("name", ["accel_m_s2", "accel", "acc_x", "accel_ns", "acceleration (m/s^2)", "a_m/s/s",
                                  "accel_in", "accel_m_s²", "accel [m·s⁻²]", "acc_ms2", "accel_ms"])
def test_an_acceleration_in_m_s2_or_without_unit_is_read(tmp_path, name):
    rec = record_csv(tmp_path / "r.csv", ["0,0.1", "0.01,0.2", "0.02,0.3"], header=f"time_s,{name}")
    assert read_csv(rec).accel.tolist() == [0.1, 0.2, 0.3]
    assert records.acceleration_unit(name) is None


# ============================================================================ 6 numbers that are not plain
@pytest.mark.parametrize("cell", ["1_0", "\u0661", "\uff11", "\u0967", "1e1_0", "0x10", "1 0", "\u0131nf", "nan1"])
def test_cells_python_reads_but_not_plain_decimals_are_refused(tmp_path, cell):
    # used to: float('1_0') == 10, float('١') == 1 (Arabic-Indic digit), read without a word
    rows = ["0,1", f"0.01,{cell}", "0.02,1"]
    with pytest.raises(DataError, match="line 3: column 'accel_m_s2' is not a number.*plain decimal"):
        read_csv(record_csv(tmp_path / "r.csv", rows))
    d = tmp_path / "d.csv"
    d.write_text("time_s,f,y\n0,1,0\n0.01,1,0\n" + f"0.02,{cell},0\n" + "".join(f"0.{k:02d},1,0\n" for k in range(3, 30)))
    with pytest.raises(DataError, match="line 4: column 'f' is not a number"):
        read_measured(d, inputs=["f"], outputs=["y"])
    if " " not in cell:  # AT2 values are separated by spaces
        a = tmp_path / "x.AT2"
        a.write_text(AT2_HEAD + "NPTS=3, DT=0.01\n" + f"0.1 {cell} 0.3\n", encoding="utf-8")
        with pytest.raises(DataError, match="line 5: not a number"):
            read_at2(a)


def test_text_in_a_column_not_read_and_spaces_around_numbers_stay_allowed(tmp_path):
    d = tmp_path / "d.csv"
    d.write_text("time_s,f,y,note\n" + "".join(f"{k / 100},\u00a0{k} ,{-k},run_1 é\n" for k in range(30)), encoding="utf-8")
    m = read_measured(d, inputs=["f"], outputs=["y"])
    assert m.u[:, 0].tolist() == list(range(30))


def test_a_model_input_named_t_is_not_counted_from_its_first_value(tmp_path):
    # used to: an input 't' (a time column's name) beside time_s was taken for absolute time from 1e4 on
    # and shifted to start at 0, silently
    d = tmp_path / "d.csv"
    d.write_text("time_s,t,y\n" + "".join(f"{k / 100},{20_000 + k},{k}\n" for k in range(30)))
    m = read_measured(d, inputs=["t"], outputs=["y"])
    assert m.u[:, 0].tolist() == [20_000 + k for k in range(30)]


# ============================================================================ 7 files that are not regular
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_is_refused_as_not_a_regular_file_without_blocking(tmp_path, capsys):
    # used to: "does not exist" (and opening it would have blocked)
    fifo = tmp_path / "r.csv"
    os.mkfifo(fifo)
    for read in (read_csv, read_at2, lambda p: read_measured(p, inputs=["f"], outputs=["y"])):
        with pytest.raises(DataError, match=r"is a FIFO, not a regular file: give a file"):
            in_time(lambda: read(fifo))
    code, err = in_time(lambda: run(capsys, "analyze", "obsnl:coulomb_friction", "--record", str(fifo)))
    one_line_refusal(code, err, "is a FIFO, not a regular file")


def test_missing_files_folders_and_text_that_is_not_utf8_are_named(tmp_path):
    with pytest.raises(DataError, match="does not exist"):
        read_csv(tmp_path / "none.csv")
    with pytest.raises(DataError, match="is a folder; give a file"):
        read_at2(tmp_path)
    p = data_csv(tmp_path / "d.csv", n=30)
    good = p.read_bytes()
    p.write_bytes(good[:200] + b"\xff" + good[200:])
    with pytest.raises(DataError, match="is not UTF-8 text \\(byte 200\\)"):
        read_measured(p, inputs=["f"], outputs=["y"])
