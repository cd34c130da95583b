"""Documents a user names (a model file, a branch table, a written ``table2.json``): only a regular file of a bounded
size is read (``obsnl/_files.py``).

Old behaviour excluded: ``obsnl analyze FIFO.toml`` blocked without end on the read; a model file that was a
device (``/dev/zero``, or a link to it named ``m.toml``) was read until memory ran out (a ``MemoryError`` traceback
under a memory limit); a FIFO given as a branch table was said not to exist; ``read_reproduction`` of a FIFO
blocked. Each case runs in a fresh interpreter with a deadline, so that a reader that blocks fails the test instead
of hanging the suite.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

import obsnl
from obsnl._files import read_document
from obsnl.errors import ParseError

needs_fifo = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")

#: Longest a refusal may take, in a fresh interpreter that imports obsnl (a second or two): a reader that blocks on a
#: FIFO or reads a device never ends, and is stopped here.
DEADLINE = 120


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    try:
        return subprocess.run([sys.executable, "-m", "obsnl", *args], capture_output=True, text=True,
                              timeout=DEADLINE, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        pytest.fail(f"obsnl {' '.join(args)} ran past {DEADLINE} s: the reader blocked")


def _one_line_refusal(r: subprocess.CompletedProcess[str], *words: str) -> None:
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr[-2000:]
    for w in words:
        assert w in lines[0], lines[0]


@needs_fifo
def test_a_fifo_named_as_a_model_file_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "model.toml"
    os.mkfifo(fifo)
    _one_line_refusal(_cli("analyze", str(fifo)), "is a FIFO, not a regular file", "give a .toml or .json model file")


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero on this system")
def test_a_device_named_as_a_model_file_is_refused_before_it_is_read(tmp_path):
    link = tmp_path / "model.toml"
    link.symlink_to("/dev/zero")
    _one_line_refusal(_cli("analyze", str(link)), "is a character device, not a regular file")


def test_a_model_file_over_the_bound_is_refused_before_it_is_parsed(tmp_path):
    path = tmp_path / "big.toml"
    line = b"# " + b"x" * 1022 + b"\n"
    path.write_bytes(line * (32 * 1024 + 1))  # 32 MiB and one KiB: comments, valid TOML
    with pytest.raises(ParseError, match=r"over 32 MiB, too large for one; give a \.toml or \.json model file"):
        obsnl.read_model(path)


@needs_fifo
@pytest.mark.parametrize("reader, name, said", [
    # read_branch_table said such a FIFO did not exist
    ("obsnl.observability.contract.branch_table:read_branch_table", "table.json", "TableError branch table"),
    # read_reproduction blocked on it
    ("obsnl.studies.seed_reproduction:read_reproduction", "table2.json", "DataError table2.json"),
])
def test_a_reader_of_a_document_names_a_fifo_without_blocking(tmp_path, reader, name, said):
    fifo = tmp_path / name
    os.mkfifo(fifo)
    module, function = reader.split(":")
    prog = (f"import sys\nfrom {module} import {function}\n"
            f"try:\n    {function}(sys.argv[1])\nexcept Exception as exc:\n    print(type(exc).__name__, exc)\n")
    try:
        r = subprocess.run([sys.executable, "-c", prog, str(fifo)], capture_output=True, text=True, timeout=DEADLINE)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{function} blocked on a FIFO")
    assert r.stdout.startswith(said) and "is a FIFO, not a regular file" in r.stdout, r.stdout


def test_read_document_names_each_refusal_and_reads_a_regular_file(tmp_path):
    def refused(path, **kw) -> str:
        with pytest.raises(ValueError) as info:
            read_document(path, where=f"file {path.name!r}", error=ValueError, fix="give a file", **kw)
        return str(info.value)

    good = tmp_path / "good.json"
    good.write_text('{"a": "\u00e9"}', encoding="utf-8")
    assert read_document(good, where="file", error=ValueError, fix="give a file") == '{"a": "\u00e9"}'
    assert refused(tmp_path / "missing.json") == "file 'missing.json' does not exist; give a file"
    assert refused(tmp_path) == f"file {tmp_path.name!r} is a folder; give a file"
    big = tmp_path / "big.json"
    big.write_bytes(b"1" * 2049)
    assert refused(big, limit=2048) == "file 'big.json' is over 2,048 bytes, too large for one; give a file"
    latin = tmp_path / "latin.json"
    latin.write_bytes(b'{"a": "\xe9"}')
    assert refused(latin) == "file 'latin.json' is not UTF-8 text (byte 7); give a file"


@pytest.mark.parametrize("reader", ["obsnl.observability.contract.branch_table:read_branch_table",
                                    "obsnl.studies.seed_reproduction:read_reproduction"])
def test_a_reader_refuses_an_argument_that_is_not_a_path_in_one_line(reader):
    # a number reached Path(), a TypeError
    import importlib

    from obsnl.errors import OptionError

    module, function = reader.split(":")
    with pytest.raises(OptionError, match=rf"^{function} takes the path of .* \(text or a path\), got int 5$"):
        getattr(importlib.import_module(module), function)(5)


@pytest.mark.parametrize("suffix", [".toml", ".json", "." + "t" * 200])
def test_a_long_path_is_not_echoed_whole(tmp_path, suffix):
    # the model reader echoed a path of thousands of characters whole; the system's refusals cut it at 100
    from obsnl.observability.contract.branch_table import read_branch_table

    long = tmp_path / ("d" * 200) / ("m" * 200 + suffix)
    for read in (obsnl.read_model, read_branch_table):
        with pytest.raises(obsnl.ObsnlError) as info:
            read(long)
        assert len(str(info.value)) < 400 and "\n" not in str(info.value), str(info.value)
