"""splitlf._files: the checks and the atomic writer every output file goes through."""

from __future__ import annotations

import errno
import os
import tempfile

import pytest

from splitlf._files import check_writable


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
