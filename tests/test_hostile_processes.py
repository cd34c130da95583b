"""Hostile input, second round (issue 26), the processes: workers that outlived a SIGTERM to the main
process, and a scheduler address where something other than a Dask scheduler answers.

Each test excludes the old behaviour: it failed before the fix.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from .test_hostile_writes import one_line_refusal, run


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
