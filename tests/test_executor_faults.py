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

The processes of the hostile-input review (issue 26): workers that outlived a SIGTERM to the main process, and a
scheduler address where something other than a Dask scheduler answers (an HTTP server, a silent or garbled one).
"""

from __future__ import annotations

import os
import socket
import struct
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

import obsnl
import obsnl.batch
from obsnl import executor as executor_module
from obsnl.errors import CompileError, ExecutorError, OptionError
from obsnl.executor import Executor

from .dying_tasks import dies, dies_on_two
from .helpers import one_line_refusal, run

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
                                           (_dask_handshake(), "sent its handshake but did not answer")],
                         ids=["silent", "silent-after-its-handshake"])
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


def test_executor_map_names_a_scheduler_that_went_silent_since_the_probe(monkeypatch):
    # no probe here (as when the scheduler hangs between the probe and the run): the client's own deadline, and a
    # reason in words where the bare TimeoutError used to print "()"
    monkeypatch.setattr(executor_module, "DEADLINE", 2.0)
    with _silent_server(_dask_handshake()) as address:
        start = time.monotonic()
        with pytest.raises(OptionError) as info:
            Executor(scheduler=address).map(abs, [-1])
        assert time.monotonic() - start < 8.0
    msg = str(info.value)
    assert "did not answer a client within 2 s" in msg and "()" not in msg and "\n" not in msg, msg


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


def test_executor_map_names_the_tasks_whose_dask_worker_died():
    import dask
    from distributed import Client, LocalCluster

    # Dask gives up on a task at the first worker that dies under it (allowed-failures 0: no retry on a new worker)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
            LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                         dashboard_address=None) as cluster, Client(cluster, set_as_default=False) as client:
        start = time.monotonic()
        with pytest.raises(ExecutorError) as info:
            Executor(scheduler=client).map(dies_on_two, [0, 1, 2, 3], label=lambda x: f"the task of x={x}")
        assert time.monotonic() - start < 20.0
    msg = str(info.value)
    # the task that ended the worker is named (tasks queued on the same worker may be named with it)
    assert msg.startswith("Dask workers died while running ") and "the task of x=2" in msg, msg
    assert "without scheduler= and with workers=1" in msg and "\n" not in msg


def test_report_exits_2_naming_the_model_whose_worker_died(tmp_path, capsys, monkeypatch):
    from obsnl.cli import main

    monkeypatch.setattr(obsnl.batch, "_analyze_task", dies)  # pickled by name: the workers import its module
    code = main(["report", "obsnl:coulomb_friction", "obsnl:msd_force_accel", "--out", str(tmp_path / "r"),
                 "--workers", "2"])
    err = _one_line(capsys.readouterr().err)
    assert code == 2 and "error: a worker process died (exit code 3) while running the analysis of model" in err
    assert "'coulomb_friction'" in err or "'msd_force_accel'" in err
    assert "--workers 1" in err and "BrokenProcessPool" not in err


# -- a C compiler that hangs -------------------------------------------------------------------------------------


def _hanging_compiler(tmp_path, monkeypatch, *, version_too: bool = False):
    """``gcc`` and ``cc`` first on PATH that never finish compiling (and, with ``version_too``, never say their
    version either): each writes its process id to a file, then sleeps 120 s. The compile time limit is 2 s, the
    library cache empty (on disk and in this process), so the compiler is reached. Returns the file of ids."""
    import shutil

    from obsnl.estimation import jitcache

    bin_, pids = tmp_path / "bin", tmp_path / "pids"
    bin_.mkdir()
    answer = "" if version_too else 'if [ "$1" = "--version" ]; then echo "cc (hangs) 1.0"; exit 0; fi\n'
    for name in ("gcc", "cc"):
        script = bin_ / name
        script.write_text(f"#!/bin/sh\n{answer}echo $$ >> {pids}\nexec {shutil.which('sleep')} 120\n")
        script.chmod(0o755)
    monkeypatch.setenv("PATH", f"{bin_}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.setenv("OBSNL_COMPILE_SECONDS", "2")
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(jitcache, "_LOADED", {})
    monkeypatch.setattr(jitcache, "_HUNG", {})
    return pids


def _all_stopped(pids) -> bool:
    """Every process the fake compiler started has ended (it was killed, not left sleeping)."""
    for pid in map(int, pids.read_text().split()):
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            continue
        return False
    return True


def _duffing():
    """A Duffing oscillator with a fifth-power term (C code no earlier test compiled) and its response from scipy."""
    from scipy.integrate import solve_ivp

    model = obsnl.Model(name="duffing_hang", states=["x", "v"], parameters=["c", "k", "kn"], inputs=["F"],
                        equations={"x": "v", "v": "F - c*v - k*x - kn*x**5"}, outputs={"disp": "x"},
                        guess={"c": 0.4, "k": 3.5, "kn": 2.5})
    t = np.arange(200) * 0.02
    F = 2.0 * np.sin(2.1 * t) + 1.2 * np.sin(3.7 * t + 0.4)

    def rhs(tt, s):
        return [s[1], np.interp(tt, t, F) - 0.3 * s[1] - 4.0 * s[0] - 2.0 * s[0] ** 5]

    x = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0], method="LSODA", t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.02).y[0]
    return model, {"time_s": t, "F": F, "disp": x + 0.01 * np.std(x) * np.random.default_rng(0).standard_normal(t.size)}


def test_identify_runs_uncompiled_with_one_warning_when_the_compiler_hangs(tmp_path, monkeypatch, capsys):
    from obsnl.estimation.jitcache import compiler_available
    from obsnl.identification.experiments import Tuning

    pids = _hanging_compiler(tmp_path, monkeypatch)
    assert compiler_available()
    model, data = _duffing()
    start = time.monotonic()
    res = obsnl.identify(model, data, progress=False, refine=False, passes=1, tuning=Tuning(0.3, 0.0, 1.0))
    seconds = time.monotonic() - start
    err = capsys.readouterr().err
    assert res.compiled is False
    assert err.count("obsnl: warning:") == 1 and len(err.strip().splitlines()) == 1, err
    assert "did not finish compiling" in err and "within 2 s" in err and "running uncompiled" in err, err
    assert seconds < 20.0, seconds  # the 2 s limit, then a one-pass uncompiled run (under 2 s unloaded)
    assert _all_stopped(pids)
    # asked for explicitly, compiling is an error; the compiler that hung is not waited for again
    start = time.monotonic()
    with pytest.raises(CompileError, match="did not finish compiling .* within 2 s .*not run again.*jit=False"):
        obsnl.identify(model, data, progress=False, refine=False, passes=1, tuning=Tuning(0.3, 0.0, 1.0), jit=True)
    assert time.monotonic() - start < 1.5


def test_identify_cli_with_jit_exits_2_when_the_compiler_does_not_say_its_version(tmp_path, monkeypatch, capsys):
    from obsnl.cli import main

    pids = _hanging_compiler(tmp_path, monkeypatch, version_too=True)
    _, data = _duffing()
    m = tmp_path / "duffing_hang.toml"
    m.write_text('name = "duffing_hang"\nstates = ["x", "v"]\nparameters = ["c", "k", "kn"]\ninputs = ["F"]\n'
                 '[equations]\nx = "v"\nv = "F - c*v - k*x - kn*x**5"\n[outputs]\ndisp = "x"\n'
                 '[guess]\nc = 0.4\nk = 3.5\nkn = 2.5\n')
    csv = tmp_path / "data.csv"
    csv.write_text("time_s,F,disp\n" + "".join(f"{a},{b},{c}\n" for a, b, c in zip(*data.values())))
    start = time.monotonic()
    code = main(["identify", str(m), "--data", str(csv), "--jit", "--no-refine", "--passes", "1"])
    seconds = time.monotonic() - start
    err = capsys.readouterr().err
    said = [ln for ln in err.replace("\r", "\n").splitlines() if ln.strip() and not ln.startswith("identify:")]
    assert "Traceback" not in err and len(said) == 1, err
    err = said[0]
    assert code == 2 and "did not say its --version within 2 s" in err and "--no-jit" in err, err
    assert seconds < 20.0 and _all_stopped(pids)


def test_a_failing_compiler_is_tried_once_not_once_per_tuning(tmp_path, monkeypatch, capsys):
    # the tuning grid's runs read an error as a tuning that fails and tried the next, which compiled again: a compiler
    # that fails slowly (or hangs) cost the run once per tuning of the grid (5 attempts here) before the fallback
    from obsnl.estimation import jitcache

    bin_, count = tmp_path / "bin", tmp_path / "count"
    bin_.mkdir()
    for name in ("gcc", "cc"):
        script = bin_ / name
        script.write_text(f'#!/bin/sh\nif [ "$1" = "--version" ]; then echo "cc (fails) 1.0"; exit 0; fi\n'
                          f'echo x >> {count}\necho "cc1: internal compiler error" >&2\nexit 1\n')
        script.chmod(0o755)
    monkeypatch.setenv("PATH", f"{bin_}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(jitcache, "_LOADED", {})
    model, data = _duffing()
    res = obsnl.identify(model, data, progress=False, refine=False, passes=1)  # the tuning grid
    err = capsys.readouterr().err
    assert res.compiled is False and err.count("obsnl: warning:") == 1 and "internal compiler error" in err
    assert len(count.read_text().split()) == 1


@pytest.mark.parametrize("value", ["soon", "0", "-5", "inf", "nan"])
def test_a_compile_time_limit_that_is_no_number_of_seconds_is_one_line(value, monkeypatch):
    from obsnl.estimation.jitcache import compile_seconds

    monkeypatch.setenv("OBSNL_COMPILE_SECONDS", value)
    with pytest.raises(CompileError, match=r"OBSNL_COMPILE_SECONDS=.* is not a number of seconds above 0"):
        compile_seconds()
    monkeypatch.setenv("OBSNL_COMPILE_SECONDS", "2.5")
    assert compile_seconds() == 2.5


# ----------------------------------------------------------------------------- 8 workers end with the main process
NAP = '''import os, sys, time
def nap(folder):
    open(os.path.join(folder, str(os.getpid())), "w").close()
    time.sleep(120)
'''


MAIN = '''import sys
sys.path.insert(0, sys.argv[1])
import nap
from obsnl.executor import Executor
if __name__ == "__main__":
    Executor(workers=2).map(nap.nap, [sys.argv[2]] * 2)
'''


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(") ")[-1][:1] != "Z"  # a zombie has ended
    except OSError:
        return False


def _session(sid: int) -> list[int]:
    """The live processes of session ``sid`` (field 6 of /proc/PID/stat)."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(") ", 1)[-1].split()
            except OSError:
                continue
            if int(fields[3]) == sid and fields[0] != "Z":
                found.append(int(entry.name))
    return found


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_8_sigterm_to_the_main_process_ends_its_workers(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    (tmp_path / "nap.py").write_text(NAP)
    (tmp_path / "main.py").write_text(MAIN)
    pids = tmp_path / "pids"
    pids.mkdir()
    main = subprocess.Popen([sys.executable, str(tmp_path / "main.py"), str(tmp_path), str(pids)],
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while len(workers) < 2 and time.monotonic() < deadline:  # both workers inside their task
            workers = [int(p.name) for p in pids.iterdir()]
            time.sleep(0.1)
        assert len(workers) == 2
        main.send_signal(signal.SIGTERM)
        main.wait(timeout=30)
        deadline = time.monotonic() + 15
        while any(_alive(p) for p in workers) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not [p for p in workers if _alive(p)]  # they slept on, orphaned, for two minutes
        while _session(main.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert _session(main.pid) == []  # nor multiprocessing's resource tracker (the third process)
    finally:
        for p in set(workers) | set(_session(main.pid)) - {main.pid}:  # this test's own processes, whatever happened
            if _alive(p):
                os.kill(p, signal.SIGKILL)
        if main.poll() is None:
            main.kill()
        main.communicate()


# ----------------------------------------------------------------------------- 9 a scheduler address where something else answers
def _server(reply: bytes | None):
    """A TCP server on the loopback that sends ``reply`` on every connection (None: stays silent)."""
    import socket
    import threading

    srv = socket.create_server(("127.0.0.1", 0))
    conns = []

    def serve() -> None:
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            conns.append(conn)
            if reply is not None:
                conn.sendall(reply)

    threading.Thread(target=serve, daemon=True).start()
    return srv, conns


HTTP = b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"


#: What a distributed scheduler sends first on a new connection (captured from ``dask scheduler``).
DASK_HELLO = (b":\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00\x00\x00\x00\x00*\x00\x00\x00\x00\x00\x00\x00\x83\xab"
              b"compression\xc0\xa6python\x93\x03\x0b\x07\xafpickle-protocol\x05")


def test_9_an_http_server_at_the_scheduler_address_is_refused_in_one_line(tmp_path, capsys):
    srv, conns = _server(HTTP)
    try:
        address = f"tcp://127.0.0.1:{srv.getsockname()[1]}"
        code, err = run(capsys, "reproduce", "--out", str(tmp_path / "o"), "--samples", "50", "--scheduler", address)
    finally:
        srv.close()
        for c in conns:
            c.close()
    one_line_refusal(code, err, "is not a Dask scheduler", "HTTP")  # numpy was asked for 3 EiB
    assert "run/s" not in err and not (tmp_path / "o").exists()


@pytest.mark.parametrize("reply, words", [(None, "no Dask handshake within"),
                                          (b"\x13\x00\x00\x00\x00\x00\x00\x00abcdefghijklmnopqrs", "no Dask handshake")])
def test_9_a_silent_or_garbled_server_is_refused_after_a_short_wait(reply, words):
    import time

    from obsnl.errors import OptionError
    from obsnl.executor import Executor

    srv, conns = _server(reply)
    try:
        t0 = time.monotonic()
        with pytest.raises(OptionError, match=words):
            Executor(scheduler=f"tcp://127.0.0.1:{srv.getsockname()[1]}").probe(timeout=0.5)
        assert time.monotonic() - t0 < 5
    finally:
        srv.close()
        for c in conns:
            c.close()


def test_9_a_dask_scheduler_passes_the_probe():
    # the handshake alone no longer passes (issue 41): a server that sends it and then says nothing is refused, and
    # so is a cluster without a worker (tests/test_executor_faults.py); a scheduler with a worker passes
    from obsnl.errors import OptionError
    from obsnl.executor import Executor

    srv, conns = _server(DASK_HELLO)
    try:
        with pytest.raises(OptionError, match="sent its handshake but did not answer"):
            Executor(scheduler=f"tcp://127.0.0.1:{srv.getsockname()[1]}").probe(timeout=1)
    finally:
        srv.close()
        for c in conns:
            c.close()
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp://",
                                  host="127.0.0.1", dashboard_address=":0") as cluster:
        assert Executor(scheduler=cluster.scheduler_address).probe(timeout=5).kind == "dask"
