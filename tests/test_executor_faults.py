"""Faults in parallel and compiled runs: each has a deadline and a one-line error, none hangs.

- a Dask cluster with no worker (an in-process ``LocalCluster`` on the loopback address): refused by ``report``,
  ``identify`` and ``Executor.map`` within seconds, where it used to wait for ever;
- a fake scheduler (a plain TCP socket on 127.0.0.1) that accepts and never answers, or that sends the Dask
  handshake and then goes silent: refused before any work, within the probe's deadline, with a reason that names
  what failed and the fix;
- a local worker process that dies (``os._exit`` in a task): an ExecutorError naming the task, exit code 2 from
  the command line, where it used to be a raw ``BrokenProcessPool`` traceback.

The deadlines checked are the ones the code promises (the probe's ``timeout`` per step, ``DEADLINE`` in a run),
with a margin for a loaded machine. Every server and cluster here stops by itself: bounded loops, loopback only.
"""

from __future__ import annotations

import socket
import struct
import threading
import time
from contextlib import contextmanager

import numpy as np
import pytest

import obsnl
import obsnl.batch
from obsnl import executor as executor_module
from obsnl.errors import ExecutorError, OptionError
from obsnl.executor import Executor

from .dying_tasks import dies, dies_on_two

distributed = pytest.importorskip("distributed")


@contextmanager
def _cluster_without_workers():
    """A Dask scheduler in this process, on the loopback address, with no worker."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, protocol="tcp", host="127.0.0.1",
                      dashboard_address=None) as cluster:
        yield cluster


def _dask_handshake() -> bytes:
    """A Dask server's first message, from the wire format of dask.distributed's TCP comm: the message's length
    (8 bytes, little-endian), the number of frames (8 bytes), each frame's length (8 bytes), then the frames; the
    handshake is one msgpack frame, a map holding ``pickle-protocol``."""
    import msgpack

    frame = msgpack.dumps({"compression": None, "python": (3, 11, 0), "pickle-protocol": 5})
    body = struct.pack("<Q", 1) + struct.pack("<Q", len(frame)) + frame
    return struct.pack("<Q", len(body)) + body


@contextmanager
def _silent_server(first: bytes = b""):
    """``tcp://127.0.0.1:PORT`` of a server that accepts, sends ``first`` and then says nothing; it stops when the
    block ends (or after 60 s on its own), closing every connection."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    server.settimeout(0.2)
    stop, held = threading.Event(), []

    def serve() -> None:
        end = time.monotonic() + 60.0
        while not stop.is_set() and time.monotonic() < end:
            try:
                conn, _ = server.accept()
            except OSError:  # the accept timed out: look at the stop flag again
                continue
            if first:
                conn.sendall(first)
            held.append(conn)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        stop.set()
        thread.join(timeout=5.0)
        for conn in held:
            conn.close()
        server.close()


def _leak(t: np.ndarray, a: float = 2.0) -> np.ndarray:
    """x of x' = sin(t) - a x, x(0) = 0, in closed form: (a sin t - cos t + exp(-a t)) / (a^2 + 1)."""
    return (a * np.sin(t) - np.cos(t) + np.exp(-a * t)) / (a**2 + 1)


def _no_work(*args, **kwargs):
    raise AssertionError("work started before the scheduler was checked")


def _one_line(err: str) -> str:
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    return err


# -- a Dask cluster without workers ------------------------------------------------------------------------------


def test_report_refuses_a_scheduler_without_workers_within_seconds(tmp_path, capsys, monkeypatch):
    from obsnl.cli import main

    monkeypatch.setattr(obsnl.batch, "read_model", _no_work)
    with _cluster_without_workers() as cluster:
        start = time.monotonic()
        code = main(["report", "obsnl:coulomb_friction", "--out", str(tmp_path / "r"), "--scheduler",
                     cluster.scheduler_address])
        seconds = time.monotonic() - start
    err = _one_line(capsys.readouterr().err)
    assert code == 2 and seconds < 15.0, (code, seconds)  # the probe waits 5 s for a first worker
    assert "has no worker" in err and "dask worker" in err and "--scheduler" in err
    assert not (tmp_path / "r").exists()


def test_identify_refuses_a_client_without_workers_before_the_filter():
    from distributed import Client

    m = obsnl.Model(name="leak", states=["x"], parameters=["a"], inputs=["u"], equations={"x": "u - a*x"},
                    outputs={"y": "x"})
    t = np.arange(50) * 0.1
    data = {"t": t, "u": np.sin(t), "y": _leak(t)}
    with _cluster_without_workers() as cluster, Client(cluster, set_as_default=False) as client:
        start = time.monotonic()
        with pytest.raises(OptionError, match="has no worker .*none joined within 5 s.*dask worker") as info:
            obsnl.identify(m, data, guess={"a": 1.0}, progress=False, jit=False, executor=Executor(scheduler=client))
        assert time.monotonic() - start < 12.0
    assert "\n" not in str(info.value)


def test_executor_map_stops_when_the_cluster_has_no_worker(monkeypatch):
    from distributed import Client

    monkeypatch.setattr(executor_module, "DEADLINE", 2.0)
    with _cluster_without_workers() as cluster, Client(cluster, set_as_default=False) as client:
        start = time.monotonic()
        with pytest.raises(ExecutorError, match=r"no worker for 2 s with 3 of 3 tasks waiting.*dask worker"):
            Executor(scheduler=client).map(abs, [-1, 2, -3])  # no probe: the run's own deadline
        # a second without a result, then DEADLINE without a worker, with a margin for a loaded machine
        assert time.monotonic() - start < 1.0 + 2.0 + 5.0


# -- a scheduler that does not answer ----------------------------------------------------------------------------


@pytest.mark.parametrize("first, reason", [(b"", "no Dask handshake within 5 s"),
                                           (_dask_handshake(), "sent its handshake but did not answer")])
def test_identify_refuses_a_silent_scheduler_before_any_work(first, reason, tmp_path, capsys, monkeypatch):
    from obsnl.cli import main

    m = tmp_path / "leak.toml"
    m.write_text('name = "leak"\nstates = ["x"]\nparameters = ["a"]\ninputs = ["u"]\n'
                 '[equations]\nx = "u - a*x"\n[outputs]\ny = "x"\n[guess]\na = 1.0\n')
    t = np.arange(50) * 0.1
    csv = tmp_path / "data.csv"
    csv.write_text("t,u,y\n" + "".join(f"{a},{np.sin(a)},{y}\n" for a, y in zip(t, _leak(t))))
    monkeypatch.setattr("obsnl.identification.identify.identify_measured", _no_work)
    with _silent_server(first) as address:
        start = time.monotonic()
        code = main(["identify", str(m), "--data", str(csv), "--scheduler", address, "--no-jit"])
        seconds = time.monotonic() - start
    err = _one_line(capsys.readouterr().err)
    # a connection, a handshake and a question, each at most 5 s; what used to take 31 s of filter work first
    assert code == 2 and seconds < 12.0, (code, seconds, err)
    assert reason in err and "()" not in err and ("restart it" in err or "dask scheduler" in err), err
    assert "leave --scheduler out" in err, err


def test_probe_names_a_scheduler_that_goes_silent_after_its_handshake():
    with _silent_server(_dask_handshake()) as address:
        start = time.monotonic()
        with pytest.raises(OptionError) as info:
            Executor(scheduler=address).probe(timeout=1.0)
        assert time.monotonic() - start < 5.0
    msg = str(info.value)
    assert address in msg and "did not answer" in msg and "no answer within 1 s" in msg and "\n" not in msg


# -- a local worker that dies ------------------------------------------------------------------------------------


def test_executor_map_names_the_task_of_a_worker_that_died():
    start = time.monotonic()
    with pytest.raises(ExecutorError) as info:
        Executor(workers=2).map(dies_on_two, [0, 1, 2, 3], label=lambda x: f"the task of x={x}")
    assert time.monotonic() - start < 25.0
    msg = str(info.value)
    assert "a worker process died (exit code 3) while running the task of x=2" in msg, msg
    assert "workers=1" in msg and "\n" not in msg
    # the pool is not left broken for the next run
    assert Executor(workers=2).map(dies_on_two, [0, 1, 3]) == [0, 1, 3]


def test_report_exits_2_naming_the_model_whose_worker_died(tmp_path, capsys, monkeypatch):
    from obsnl.cli import main

    monkeypatch.setattr(obsnl.batch, "_analyze_task", dies)  # pickled by name: the workers import its module
    code = main(["report", "obsnl:coulomb_friction", "obsnl:msd_force_accel", "--out", str(tmp_path / "r"),
                 "--workers", "2"])
    err = _one_line(capsys.readouterr().err)
    assert code == 2 and "error: a worker process died (exit code 3) while running the analysis of model" in err
    assert "'coulomb_friction'" in err or "'msd_force_accel'" in err
    assert "--workers 1" in err and "BrokenProcessPool" not in err
