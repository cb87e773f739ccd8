"""Writing on a device with no room: one clear message naming the path and the space needed, exit
2, the old file untouched and no partial output. The device is made to refuse by a file-size
limit (RLIMIT_FSIZE, with SIGXFSZ ignored so that write() fails with EFBIG instead of killing the
process), which needs no mount; a short free-space figure is checked before writing a byte."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
from pathlib import Path

import pytest
from skatelib.library import atomic
from skatelib.library.errors import OutputError
from skatelib.pipeline.ocp.stagewise import c_compiler

from tests.helpers import CLI, TINY, copy_of, interpreted_tiny

LIMIT_BYTES = 8_000  # smaller than any library, figure or recording written here


def _limited() -> None:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT_BYTES, LIMIT_BYTES))


def _run(args: list[str], limited: bool = False) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "COLUMNS": "200"}, preexec_fn=_limited if limited else None)


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() if p.is_file() else b"<folder>" for p in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def solved(tmp_path_factory, tiny_v03):
    """A one-entry library of the tiny config (a copy of the session's) and its figures, written with
    room; the module's commands use the entry cache it was solved with."""
    d = tmp_path_factory.mktemp("disk")
    lib = copy_of(tiny_v03.path, d)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SKATELIB_CACHE_DIR", str(tiny_v03.cache))
        r = _run(["plot", str(lib), "-o", str(d / "fig"), "-f", "png"])
        assert r.returncode == 0, r.stdout + r.stderr
        yield d, lib


def test_a_library_that_does_not_fit_leaves_the_old_one(solved, tmp_path):
    """solve onto an existing library with no room: exit 2 naming the path and 'cannot be written',
    no traceback or crash, the old file byte for byte, no temporary left. (The stage functions
    interpreted: compiled, their code is copied to be loaded before the solve, and the copy is the
    first write refused; the next test.)"""
    d, lib = solved
    before = _snapshot(d)
    cfg = interpreted_tiny(tmp_path / "interpreted.toml")
    r = _run(["solve", "-V", "0.3", "-s", "1", "--config", str(cfg), "-o", str(lib)], limited=True)
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    assert str(lib) in r.stderr and "cannot be written" in r.stderr and "Traceback" not in r.stderr
    assert _snapshot(d) == before


@pytest.mark.skipif(c_compiler() is None, reason="no C compiler: nothing is compiled")
def test_compiled_code_that_cannot_be_copied_to_be_loaded_is_a_clear_error(solved):
    """A compiled solve with no room for the copy of the compiled code it loads: exit 2 naming the
    folder of compiled code and what to do, no traceback, the old library byte for byte."""
    d, lib = solved
    before = _snapshot(d)
    r = _run(["solve", "-V", "0.3", "-s", "1", "--config", str(TINY), "-o", str(lib)], limited=True)
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    err = " ".join(r.stderr.split())
    assert os.environ["SKATELIB_COMPILE_DIR"] in err and "cannot be copied there to be loaded" in err, err
    assert "SKATELIB_COMPILE_DIR" in err and "Traceback" not in err
    assert _snapshot(d) == before


def test_figures_are_all_or_none(solved):
    """plot with no room for its figures: exit 2, the old figures unchanged, no staging folder left;
    negative control: with room the same command writes them."""
    d, lib = solved
    before = _snapshot(d / "fig")
    r = _run(["plot", str(lib), "-o", str(d / "fig"), "-f", "png", "-f", "svg"], limited=True)
    assert r.returncode == 2 and "cannot be written" in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert _snapshot(d / "fig") == before
    r = _run(["plot", str(lib), "-o", str(d / "fig"), "-f", "png", "-f", "svg"])
    assert r.returncode == 0 and any(p.suffix == ".svg" for p in (d / "fig").iterdir())


def test_a_recording_that_does_not_fit_is_not_left(solved):
    """inspect --save with no room: exit 2, no recording and no temporary."""
    pytest.importorskip("rerun")
    d, lib = solved
    rrd = d / "sub" / "x.rrd"
    r = _run(["inspect", str(lib), "--save", str(rrd)], limited=True)
    assert r.returncode == 2 and "cannot be written" in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert not rrd.parent.exists() or list(rrd.parent.iterdir()) == []


def test_short_free_space_is_refused_before_writing(tmp_path, monkeypatch):
    """write_atomic compares the data's size with the folder's free space first: it refuses
    naming both, and the old file stays."""
    target = tmp_path / "x.bin"
    target.write_bytes(b"old")

    class Usage:
        free = 10

    monkeypatch.setattr(atomic.shutil, "disk_usage", lambda _: Usage)
    with pytest.raises(OutputError, match=r"needs about 0\.00 MB and 0\.00 MB are free"):
        atomic.write_atomic(target, b"x" * 100)
    assert target.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["x.bin"]
