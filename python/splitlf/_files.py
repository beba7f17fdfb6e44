"""Writing output files without losing data: one helper for every file splitlf writes.

A writer never touches the target directly. It writes a temporary file in the target's
folder (same file system, so the final rename is atomic), the data are flushed to disk,
and only then ``os.replace`` puts the file in place. A failure part-way (a full disk, an
interrupted run, a bug, a SIGTERM) leaves the previous file untouched and removes the
temporary one. An existing target is refused unless ``force`` is given.

Readers (:func:`open_regular`, :func:`read_toml`, :func:`read_npy`) refuse anything but a
regular file before reading it: a FIFO, a device or a folder given as an input file is an
error naming it, never a read that blocks forever or runs away.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import signal
import stat
import sys
import tempfile
import threading
import tokenize
from collections.abc import Iterator
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from . import _native
from .errors import InvalidParameter, TooLargeError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10 (the tomli backport)
    import tomli as tomllib

__all__ = ["MAX_TOML_BYTES", "atomic_folder", "atomic_output", "check_new",
           "check_new_folder", "check_writable", "json_safe", "open_regular",
           "probe_folder", "read_npy", "read_toml", "text_file"]

#: Largest TOML file read (a design or sweep file is a few kB; this refuses a runaway input
#: such as /dev/zero or a mistaken data file before reading it).
MAX_TOML_BYTES = 16 * 2**20


def check_new(path: str | os.PathLike[str], force: bool, hint: str = "") -> Path:
    """``path`` as a :class:`~pathlib.Path`, after checking it may be written.

    Raises ``FileExistsError`` when ``path`` exists and ``force`` is false (``hint`` is
    appended to the message, e.g. "pass --force to overwrite"), ``IsADirectoryError`` when
    it is a folder and ``FileNotFoundError`` when its folder does not exist.
    """
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{p}: is a folder, not a file")
    if p.exists() and not force:
        more = f"; {hint}" if hint else ""
        raise FileExistsError(f"{p}: exists, not overwritten{more}")
    folder = p.parent
    if not folder.is_dir():
        raise FileNotFoundError(f"{p}: folder {folder} does not exist")
    return p


def check_writable(path: str | os.PathLike[str], force: bool = True, hint: str = "") -> Path:
    """``path`` as a :class:`~pathlib.Path`, after checking that a file can be written
    there now: the checks of :func:`check_new`, then a trial file created (and removed) in
    its folder, so a read-only or full folder is found before a long computation rather
    than after it.

    Raises what :func:`check_new` raises, and ``PermissionError`` (or the ``OSError`` of
    the trial, e.g. a read-only file system) naming the folder when it cannot be written.
    """
    p = check_new(path, force, hint)
    probe_folder(p.parent, p)
    return p


def probe_folder(folder: Path, target: Path) -> None:
    """Create and remove a trial file in ``folder``, where ``target`` is to be written: a
    read-only, unpermitted or full folder is found now. Raises the ``OSError`` of the trial
    (same type and errno), its message naming ``target`` and the folder."""
    try:
        fd, name = tempfile.mkstemp(dir=folder, prefix=f".{target.name}.", suffix=".check")
    except OSError as e:
        reason = e.strerror or type(e).__name__
        raise type(e)(e.errno, f"{target}: folder {folder} is not writable ({reason})") from None
    os.close(fd)
    with contextlib.suppress(FileNotFoundError):
        os.unlink(name)


def _mode_for(path: Path) -> int:
    """Permissions of the new file: those of the file it replaces, else 0o666 & ~umask."""
    try:
        return os.stat(path).st_mode & 0o7777
    except FileNotFoundError:
        return 0o666 & ~_umask()


def _umask() -> int:
    # Linux reports the umask without changing it; os.umask must set it to read it, which
    # would briefly affect files other threads create.
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    umask = os.umask(0o022)
    os.umask(umask)
    return umask


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str], *, force: bool = False,
                  hint: str = "") -> Iterator[Path]:
    """Context manager: yields a temporary path in the folder of ``path`` (same suffix, so
    writers that choose a format by suffix still do); when the block ends without error,
    the file is flushed to disk and renamed onto ``path``; on any error it is removed and
    ``path`` is left as it was. A SIGTERM during the block (on the main thread) removes it
    too, then takes its previous course (by default the process ends, status 143).

    ``force``: overwrite an existing ``path`` (otherwise ``FileExistsError``, checked both
    before the block and again just before the rename). Raises the errors of
    :func:`check_new` and any ``OSError`` of the writer.
    """
    target = check_new(path, force, hint)
    fd, name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.",
                                suffix=f".tmp{target.suffix}")
    os.close(fd)
    tmp = Path(name)
    try:
        with _removed_on_sigterm(tmp):
            yield tmp
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            os.chmod(tmp, _mode_for(target))
            check_new(target, force, hint)
            os.replace(tmp, target)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


@contextlib.contextmanager
def atomic_folder(path: str | os.PathLike[str], *, force: bool = False,
                  hint: str = "") -> Iterator[Path]:
    """Context manager: a folder's :func:`atomic_output`. Yields a new empty temporary
    folder beside ``path``; when the block ends without error, its files are flushed to
    disk and the folder is renamed onto ``path``; on any error it is removed with what was
    written into it, and ``path`` is left as it was.

    ``path`` may be missing or an empty folder; a folder with files in it is refused
    (``FileExistsError``, ``hint`` appended) unless ``force``, when it is replaced whole
    (renamed aside, the new folder renamed in, then the old one removed). Raises
    ``NotADirectoryError`` when ``path`` is a file and ``FileNotFoundError`` when its
    parent folder does not exist.
    """
    import shutil

    target = check_new_folder(path, force, hint)
    tmp = Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp"))
    old: Path | None = None
    try:
        yield tmp
        for f in tmp.rglob("*"):
            if f.is_file():
                with open(f, "rb+") as fh:
                    os.fsync(fh.fileno())
        os.chmod(tmp, 0o777 & ~_umask())
        check_new_folder(target, force, hint)
        if target.is_dir() and any(target.iterdir()):
            old = Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}.",
                                        suffix=".old"))
            os.replace(target, old)
        os.replace(tmp, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)


def check_new_folder(path: str | os.PathLike[str], force: bool, hint: str = "") -> Path:
    """``path`` as a :class:`~pathlib.Path`, after checking it may be written as an output
    folder: missing or empty, or with files in it only when ``force`` (see
    :func:`atomic_folder`, whose errors it raises)."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise NotADirectoryError(f"{p}: is a file, not a folder")
    if p.is_dir() and any(p.iterdir()) and not force:
        more = f"; {hint}" if hint else ""
        raise FileExistsError(f"{p}: a folder with files in it, not overwritten{more}")
    if not p.parent.is_dir():
        raise FileNotFoundError(f"{p}: folder {p.parent} does not exist")
    return p


@contextlib.contextmanager
def _removed_on_sigterm(tmp: Path) -> Iterator[None]:
    """While the block runs, a SIGTERM removes ``tmp`` and is then handled as it would
    have been without this block (the previous handler restored and the signal sent
    again: the default action ends the process). Only on the main thread (where Python
    runs signal handlers), and not when SIGTERM is ignored."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.getsignal(signal.SIGTERM)
    if previous in (signal.SIG_IGN, None):
        yield
        return

    def on_term(signum: int, frame: Any) -> None:
        with contextlib.suppress(OSError):
            tmp.unlink()
        signal.signal(signal.SIGTERM, previous)
        os.kill(os.getpid(), signal.SIGTERM)

    signal.signal(signal.SIGTERM, on_term)
    try:
        yield
    finally:
        if signal.getsignal(signal.SIGTERM) is on_term:
            signal.signal(signal.SIGTERM, previous)


def open_regular(path: str | os.PathLike[str], expected: str = "a file") -> BinaryIO:
    """``path`` opened for binary reading, after checking that it is a regular file:
    ``ValueError`` naming it (and ``expected``, e.g. "a TOML file") for a FIFO, a device, a
    socket or a folder, before any read can block. The file is opened without blocking
    and checked again (no race with a file swapped in between); ``OSError`` when it cannot
    be opened (``FileNotFoundError`` when missing)."""
    name = os.fspath(path)
    if not stat.S_ISREG(os.stat(name).st_mode):
        raise ValueError(f"{name}: not a regular file ({expected} is expected)")
    fd = os.open(name, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ValueError(f"{name}: not a regular file ({expected} is expected)")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_npy(path: str | os.PathLike[str], what: str = "array") -> np.ndarray:
    """The array of a NumPy ``.npy`` file (no pickled objects), checked before it is
    loaded: a regular file (:func:`open_regular`), a readable header (version 1.0 or 2.0)
    and a declared size within the memory a call may take now
    (``_native.available_memory``). ``what`` names the input in errors ("texture",
    "depth").

    Raises :class:`InvalidParameter` (a ``ValueError``) naming ``what`` and the file for
    anything that is not such an array (a malformed header, pickled objects, data shorter
    than the header declares), :class:`TooLargeError` for a declared size over the
    budget, ``ValueError`` for a path that is not a regular file, ``OSError`` when it
    cannot be read."""
    name = os.fspath(path)
    with open_regular(path, f"a NumPy .npy file ({what})") as fh:
        shape, dtype = _npy_header(fh, name, what)
        nbytes = int(np.prod(shape, dtype=object)) * dtype.itemsize
        limit = int(_native.available_memory())
        if nbytes > limit:
            raise TooLargeError(f"{name}: its header declares a {what} array of shape "
                                f"{shape} ({dtype}), {nbytes} bytes, over the {limit} bytes "
                                "this call may take now", what=f"{what} file {name}",
                                nbytes=nbytes, limit=limit)
        fh.seek(0)
        try:
            return np.lib.format.read_array(fh, allow_pickle=False)
        except (ValueError, EOFError, OSError) as e:
            raise _not_npy(name, what, str(e)) from None


def _npy_header(fh: BinaryIO, name: str, what: str) -> tuple[tuple[int, ...], np.dtype]:
    """The shape and dtype a .npy header declares (the header alone is read)."""
    fmt = np.lib.format
    try:
        version = fmt.read_magic(fh)
        if version == (1, 0):
            shape, _, dtype = fmt.read_array_header_1_0(fh)
        elif version == (2, 0):
            shape, _, dtype = fmt.read_array_header_2_0(fh)
        else:
            raise ValueError(f"format version {version[0]}.{version[1]} (1.0 or 2.0 read here)")
    except (ValueError, TypeError, SyntaxError, EOFError, UnicodeError, RecursionError,
            MemoryError, OverflowError, tokenize.TokenError, io.UnsupportedOperation) as e:
        raise _not_npy(name, what, str(e) or type(e).__name__) from None
    if dtype.hasobject:
        raise _not_npy(name, what, "it holds Python objects (pickles are not read)")
    return tuple(int(n) for n in shape), dtype


def _not_npy(name: str, what: str, reason: str) -> InvalidParameter:
    allowed = "a NumPy .npy array file"
    return InvalidParameter(f"invalid {what} file {name}: not a NumPy .npy array ({reason}); "
                            f"allowed {allowed}", name=what, value=name, allowed=allowed)


def read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Parse a TOML file. Every error names the file: ``ValueError`` for a path that is
    not a regular file (a device such as /dev/zero, a pipe), a file over
    :data:`MAX_TOML_BYTES`, invalid TOML or text that is not UTF-8 (e.g. a binary file);
    ``OSError`` when it cannot be read (``FileNotFoundError`` when missing)."""
    name = os.fspath(path)
    with open_regular(path, "a TOML file") as fh:
        info = os.fstat(fh.fileno())
        if info.st_size > MAX_TOML_BYTES:
            raise ValueError(f"{name}: {info.st_size} bytes, over the {MAX_TOML_BYTES} bytes "
                             "a TOML file may have here")
        data = fh.read(MAX_TOML_BYTES + 1)
    if len(data) > MAX_TOML_BYTES:
        raise ValueError(f"{name}: over the {MAX_TOML_BYTES} bytes a TOML file may have here")
    try:
        return tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise ValueError(f"{name}: not a TOML text file (not UTF-8 at byte {e.start})") from None
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{name}: not valid TOML: {e}") from None


def text_file(lines: list[str], path: str | os.PathLike[str] | None) -> str:
    """``lines`` as one text (each line ending in a newline), also written atomically to
    ``path`` when given (replacing a file there whole or not at all)."""
    body = "\n".join(lines) + "\n"
    if path is not None:
        with atomic_output(path, force=True) as tmp:
            tmp.write_text(body, encoding="utf-8")
    return body


def json_safe(data: Any) -> Any:
    """``data`` with every non-finite float replaced by None, recursing into dicts, lists and
    tuples (JSON has neither inf nor NaN): what every JSON file splitlf writes goes through."""
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: json_safe(v) for k, v in data.items()}
    if isinstance(data, list | tuple):
        return [json_safe(v) for v in data]
    return data
