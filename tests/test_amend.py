"""Amending a library (``validate --closed-loop`` stores its verdicts in the file) keeps the file's
permission bits and refuses, before any work, a file that is not to be rewritten: one with no write
bit for anyone (root's ``os.access`` says yes to it, and it had been replaced, its mode 0644), one in
a folder where its replacement cannot be made."""

from __future__ import annotations

import os
import shutil
import stat
from pathlib import Path

import pytest
from skatelib.library.amend import amend_library, check_amendable
from skatelib.library.errors import EXIT_USAGE, LibraryFormatError, OutputError
from skatelib.library.reader import read_library

from tests.helpers import run_cli

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"


def _copy(tmp_path: Path, mode: int) -> Path:
    path = tmp_path / "lib.h5"
    shutil.copyfile(REFERENCE, path)
    path.chmod(mode)
    return path


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


@pytest.mark.parametrize("mode", [0o640, 0o600, 0o664])
def test_an_amended_library_keeps_its_mode(tmp_path, mode):
    """The rewritten file has the permission bits of the old one (the old code gave 0666 less the
    umask), and the attribute is there."""
    path = _copy(tmp_path, mode)
    amend_library(path, {"note": "x"}, {})
    assert _mode(path) == mode and read_library(path).attrs["note"] == "x"


@pytest.mark.parametrize("mode", [0o444, 0o400, 0o000])
def test_a_read_only_library_is_refused_and_left_alone(tmp_path, mode):
    """A file without a write bit: OutputError naming it and 'read-only'; bytes and mode unchanged,
    even for root."""
    path = _copy(tmp_path, mode)
    before = path.read_bytes()
    with pytest.raises(OutputError, match="read-only") as e:
        amend_library(path, {"note": "x"}, {})
    assert e.value.path == path and path.read_bytes() == before and _mode(path) == mode


def test_a_missing_file_is_a_library_error(tmp_path):
    with pytest.raises(LibraryFormatError, match="no such"):
        check_amendable(tmp_path / "none.h5")


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root writes any folder")
def test_a_file_in_a_read_only_folder_is_refused(tmp_path):
    path = _copy(tmp_path, 0o644)
    tmp_path.chmod(0o555)
    try:
        with pytest.raises(OutputError, match="folder"):
            check_amendable(path)
    finally:
        tmp_path.chmod(0o755)


def test_validate_closed_loop_refuses_a_read_only_library_before_riding(tmp_path):
    """`validate --closed-loop` on a mode-0444 file: exit 2 at once with one message naming the file,
    no traceback, no ride (no closed-loop table), the file and its mode as they were."""
    pytest.importorskip("daqp")
    path = _copy(tmp_path, 0o444)
    before = path.read_bytes()
    r = run_cli(["validate", str(path), "--closed-loop", "-j", "1"], timeout=600)
    assert r.returncode == EXIT_USAGE, r.stdout + r.stderr
    assert str(path) in r.stderr and "read-only" in r.stderr and "Traceback" not in r.stderr
    assert "closed loop" not in r.stdout and "stored" not in r.stdout
    assert path.read_bytes() == before and _mode(path) == 0o444
