"""splitlf._files: the checks and the atomic writer every output file goes through."""

from __future__ import annotations

import errno
import os
import signal
import struct
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numpy as np
import pytest
from _subprocess import run_python

from splitlf._files import check_writable, read_npy, read_toml
from splitlf.errors import InvalidParameter, TooLargeError


def test_check_writable_accepts_a_writable_folder_and_leaves_nothing(tmp_path):
    target = tmp_path / "out.csv"
    assert check_writable(target) == target
    assert list(tmp_path.iterdir()) == []


def test_check_writable_refuses_an_existing_file_without_force(tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("old")
    assert check_writable(target) == target  # force defaults to True
    with pytest.raises(FileExistsError, match="pass --force"):
        check_writable(target, force=False, hint="pass --force")
    with pytest.raises(FileNotFoundError, match="does not exist"):
        check_writable(tmp_path / "missing" / "out.csv")
    with pytest.raises(IsADirectoryError):
        check_writable(tmp_path)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_check_writable_refuses_a_read_only_folder(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        with pytest.raises(PermissionError, match="not writable"):
            check_writable(folder / "out.csv")
    finally:
        folder.chmod(0o700)


def test_check_writable_names_the_folder_when_the_trial_file_fails(tmp_path, monkeypatch):
    def refuse(*args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    with pytest.raises(OSError, match=r"folder .* is not writable \(Read-only file system\)") \
            as info:
        check_writable(tmp_path / "out.csv")
    assert info.value.errno == errno.EROFS


# -- readers: regular files only, .npy headers checked before loading --------------------

def npy_bytes(header: bytes, version: tuple[int, int] = (1, 0), data: bytes = b"") -> bytes:
    """A .npy file of the given header dict text (the format's layout written by hand:
    magic, version, header length, header padded to 64 bytes with a newline, data)."""
    pad = 64 - (10 + len(header) + 1) % 64
    text = header + b" " * pad + b"\n"
    return b"\x93NUMPY" + bytes(version) + struct.pack("<H", len(text)) + text + data


@pytest.mark.parametrize("reader", ["toml", "npy"])
def test_a_fifo_is_refused_at_once(tmp_path, reader):
    """A FIFO given as a config or array file: an error naming it, not a read that waits
    for a writer forever (in a child, so that a regression is a timeout, not a hang)."""
    fifo = tmp_path / "input"
    os.mkfifo(fifo)
    call = "read_toml(p)" if reader == "toml" else "read_npy(p, 'texture')"
    r = run_python(f"""
        from splitlf._files import read_npy, read_toml
        p = {str(fifo)!r}
        try:
            {call}
        except ValueError as e:
            print(e)
    """, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().startswith(f"{fifo}: not a regular file")


def test_read_npy_reads_an_array(tmp_path):
    a = np.arange(12, dtype=np.float32).reshape(3, 4)
    np.save(tmp_path / "a.npy", a)
    b = read_npy(tmp_path / "a.npy", "texture")
    assert b.dtype == a.dtype and np.array_equal(a, b)


def test_a_malformed_npy_header_is_invalid_parameter(tmp_path):
    """numpy.load lets tokenize.TokenError out of an unterminated header."""
    p = tmp_path / "bad.npy"
    p.write_bytes(npy_bytes(b"{'descr': '<f8', 'fortran_order': False, 'shape': (2,"))
    with pytest.raises(InvalidParameter, match=r"invalid depth file .*bad\.npy: not a NumPy") \
            as info:
        read_npy(p, "depth")
    assert info.value.name == "depth"
    p.write_bytes(b"not an array at all")
    with pytest.raises(InvalidParameter, match="not a NumPy .npy array"):
        read_npy(p, "depth")


def test_a_huge_declared_shape_is_too_large_before_loading(tmp_path):
    """1e13 float64 = 80 TB declared in a 128-byte file: refused from the header (numpy's
    own load raises its _ArrayMemoryError, or worse, tries)."""
    p = tmp_path / "huge.npy"
    p.write_bytes(npy_bytes(b"{'descr': '<f8', 'fortran_order': False, "
                            b"'shape': (100000, 100000, 1000), }"))
    with pytest.raises(TooLargeError, match="declares a texture array of shape") as info:
        read_npy(p, "texture")
    assert info.value.bytes == 10**13 * 8


def test_data_shorter_than_declared_and_pickles_are_refused(tmp_path):
    p = tmp_path / "short.npy"
    p.write_bytes(npy_bytes(b"{'descr': '<f8', 'fortran_order': False, 'shape': (4,), }",
                            data=b"\0" * 16))  # 2 of the 4 values
    with pytest.raises(InvalidParameter, match="not a NumPy .npy array"):
        read_npy(p, "texture")
    np.save(tmp_path / "obj.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(InvalidParameter, match="Python objects"):
        read_npy(tmp_path / "obj.npy", "texture")


def test_read_toml_refuses_a_folder_and_a_device(tmp_path):
    with pytest.raises(ValueError, match="not a regular file"):
        read_toml(tmp_path)
    with pytest.raises(ValueError, match="not a regular file"):
        read_toml("/dev/zero")


# -- the atomic writer on SIGTERM ---------------------------------------------------------

def test_sigterm_during_a_write_leaves_no_temporary_file(tmp_path):
    target = tmp_path / "out.npz"
    child = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import sys, time
        from splitlf._files import atomic_output
        with atomic_output({str(target)!r}) as tmp:
            tmp.write_bytes(b"partial")
            print(tmp, flush=True)
            time.sleep(60)
    """)], stdout=subprocess.PIPE, text=True)
    try:
        tmp = Path(child.stdout.readline().strip())  # the child is inside the block
        assert tmp.exists()
        child.send_signal(signal.SIGTERM)
        assert child.wait(timeout=30) == -signal.SIGTERM  # the default action: ended by it
    finally:
        child.kill()
        child.wait()
        child.stdout.close()
    assert list(tmp_path.iterdir()) == []


def test_sigterm_during_a_write_then_reaches_a_handler_of_the_program(tmp_path):
    target = tmp_path / "out.txt"
    r = run_python(f"""
        import os, signal
        from splitlf._files import atomic_output
        seen = []
        signal.signal(signal.SIGTERM, lambda *a: seen.append("term"))
        try:
            with atomic_output({str(target)!r}) as tmp:
                tmp.write_text("partial")
                os.kill(os.getpid(), signal.SIGTERM)
                for _ in range(1000):  # let the handlers run
                    if seen:
                        break
                raise KeyboardInterrupt  # the program's handler chose to stop the write
        except KeyboardInterrupt:
            pass
        print(seen, os.listdir({str(tmp_path)!r}),
              signal.getsignal(signal.SIGTERM).__name__)
    """, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["['term']", "[]", "<lambda>"]
