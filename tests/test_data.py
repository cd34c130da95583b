"""Records: CSV and PEER AT2 readers (the shipped Northridge files agree), validation, noise."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest

from obsnl.estimation.records import add_noise, read_at2, read_csv, read_record, rms
from obsnl.estimation.accelerogram import G, Record
from obsnl.errors import DataError

DATA = resources.files("obsnl").joinpath("studies/data")


def test_shipped_csv_and_at2_agree():
    a = read_record(str(DATA.joinpath("RSN960_NORTHR_LOS270.AT2")))
    c = read_record(str(DATA.joinpath("northridge1994_LOS270_ngawest2_accel.csv")))
    assert len(a) == len(c) == 1999  # NPTS of the header; the 2000th number is padding
    assert a.dt == pytest.approx(0.01) and c.dt == pytest.approx(0.01, rel=1e-9)
    np.testing.assert_allclose(a.accel, c.accel, rtol=0, atol=1e-7)
    assert np.max(np.abs(a.accel)) == pytest.approx(0.4716 * G, rel=1e-3)  # PGA from the record's README
    assert "Northridge" in a.source


def _csv(tmp_path, rows, header="time_s,accel_m_s2"):
    p = tmp_path / "r.csv"
    p.write_text(header + "\n" + "\n".join(rows) + "\n")
    return p


@pytest.mark.parametrize("rows, match", [
    (["0.00,1.0", "0.01,nan", "0.02,1.0"], "line 3: NaN/inf"),
    (["0.00,1.0", "0.01,inf", "0.02,1.0"], "line 3: NaN/inf"),
    (["0.00,1.0", "0.01,2.0", "0.03,1.0", "0.04,1.0"], "irregular time step at sample 2"),
    (["0.00,1.0", "0.01,2.0", "0.01,1.0"], "does not increase at sample 2"),
    (["0.00,1.0", "0.01,x"], "not a number"),
    (["0.00,1.0,3", "0.01,1.0"], "3 fields"),
    (["0.00,1.0"], "at least 2 samples"),
])
def test_bad_csv_is_refused(tmp_path, rows, match):
    with pytest.raises(DataError, match=match):
        read_csv(_csv(tmp_path, rows))


def test_csv_without_time_column(tmp_path):
    with pytest.raises(DataError, match="no time column"):
        read_csv(_csv(tmp_path, ["1,2"], header="a,b"))


ROWS = ["0.00,1.0,9.0", "0.01,2.0,8.0", "0.02,1.5,7.0"]


@pytest.mark.parametrize("header, match", [
    ("time_s,vel_m_s,disp_m", "cannot tell the acceleration column"),  # used to drive the model with velocity
    ("time_ms,accel_m_s2,x", "not in seconds"),  # used to be read as seconds
    ("time_s,accel,accel", "appears 2 times"),
    ("time_s,t,accel_m_s2", "2 time columns"),
])
def test_record_columns_are_chosen_by_name_or_refused(tmp_path, header, match):
    with pytest.raises(DataError, match=match):
        read_csv(_csv(tmp_path, ROWS, header=header))


def test_record_acceleration_column_by_name(tmp_path):
    rec = read_csv(_csv(tmp_path, ROWS, header="time_s,vel_m_s,accel_m_s2"))
    assert rec.accel.tolist() == [9.0, 8.0, 7.0]  # the acc... column, not the first one after time


def test_record_and_data_files_that_are_not_text(tmp_path):
    from obsnl.estimation.measured import read_measured

    p = tmp_path / "bin.csv"
    p.write_bytes(bytes(range(256)) * 4)  # not UTF-8: used to end in a UnicodeDecodeError traceback
    for read in (read_csv, lambda q: read_measured(q, inputs=["f"], outputs=["x"])):
        with pytest.raises(DataError, match="not UTF-8"):
            read(p)
        with pytest.raises(DataError, match="is a folder"):
            read(tmp_path)


@pytest.mark.parametrize("header, match", [
    ("time_s,f,f,x", "'f' appears 2 times"),  # the first f used to be read, silently
    ("time_s,t,f,x", "two time columns"),
    ("time_ms,f,x", "not in seconds"),
])
def test_measured_data_columns_are_unambiguous(tmp_path, header, match):
    from obsnl.estimation.measured import read_measured

    p = tmp_path / "d.csv"
    n = header.count(",") + 1
    p.write_text(header + "\n" + "\n".join(",".join(str(0.1 * k + j) for j in range(n)) for k in range(5)) + "\n")
    with pytest.raises(DataError, match=match):
        read_measured(p, inputs=["f"], outputs=["x"])


@pytest.mark.parametrize("scale, step, match", [(1e300, 0.01, "rescale"), (1.0, 20.0, "in seconds")])
def test_record_values_and_step_are_sane(tmp_path, scale, step, match):
    # x 1e300 used to end in "state_scale must be 2 positive numbers"; a time column in milliseconds
    # (step 20) in "Q contains NaN/inf", both after the progress bar
    rows = [f"{k * step:.6g},{float(scale * np.sin(0.1 * k))!r}" for k in range(50)]
    with pytest.raises(DataError, match=match):
        read_csv(_csv(tmp_path, rows))


def test_at2_validation(tmp_path):
    head = ["PEER NGA STRONG MOTION DATABASE RECORD", "test", "ACCELERATION TIME SERIES IN UNITS OF G",
            "NPTS=   4, DT=   .0100 SEC"]
    p = tmp_path / "x.AT2"
    p.write_text("\n".join(head + ["  .1  .2  .3  .4  .0"]) + "\n")
    r = read_at2(p)
    np.testing.assert_allclose(r.accel, np.array([0.1, 0.2, 0.3, 0.4]) * G)
    p.write_text("\n".join(head + ["  .1  .2"]) + "\n")
    with pytest.raises(DataError, match="NPTS=4 but the file holds 2"):
        read_at2(p)
    p.write_text("\n".join(head[:2] + ["VELOCITY IN CM/S", head[3], ".1 .2 .3 .4"]) + "\n")
    with pytest.raises(DataError, match="units of g"):
        read_at2(p)
    with pytest.raises(DataError, match="unknown record type"):
        read_record(tmp_path / "x.txt")
    (tmp_path / "runs").mkdir()  # a folder was "unknown record type ''"
    with pytest.raises(DataError, match="a folder, not a record file"):
        read_record(tmp_path / "runs")


def test_record_validation_and_resampling():
    with pytest.raises(DataError, match="NaN/inf at sample 1"):
        Record("r", np.array([0.0, np.nan, 1.0]), 0.01)
    r = Record("r", np.sin(np.arange(400) * 0.05), 0.005)
    half = r.resampled(0.01)
    assert half.dt == 0.01 and len(half) == 200 and "resampled" in half.notes[0]
    assert r.resampled(0.005) is r
    assert len(r.head(10)) == 10


def test_noise_ratio_and_seed():
    x = np.sin(np.linspace(0, 50, 20000))
    a, b = add_noise(x, ratio=1e-3, seed=5), add_noise(x, ratio=1e-3, seed=5)  # fixed seed: reproducible
    np.testing.assert_array_equal(a, b)
    assert rms(a - x) / rms(x) == pytest.approx(1e-3, rel=0.03)
    assert not np.array_equal(a, add_noise(x, ratio=1e-3, seed=6))
    with pytest.raises(DataError):
        add_noise(x, ratio=-1.0)
