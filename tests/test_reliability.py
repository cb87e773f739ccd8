"""Reliability drill: a killed build leaves nothing running and resumes; every bad input is a
one-paragraph message on stderr with the documented exit code, before any solving, with nothing
written; damaged library files are refused wherever the damage is."""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from skatelib.library.errors import LibraryFormatError
from skatelib.runtime import MotionLibrary

from tests.helpers import CLI, TINY

CONFIGS = Path(__file__).resolve().parent.parent / "configs"


def _run(args: list[str], env: dict[str, str] | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "COLUMNS": "200", **(env or {})})


def _session(sid: int) -> list[int]:
    """Live processes of a session (the build and everything it started keep its session id)."""
    out = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[3]) == sid and fields[0] != "Z":  # fields: state, ppid, pgrp, session, ...
            out.append(int(d.name))
    return out


def _two_chains(tmp_path: Path) -> Path:
    """0.3 m/s in one and two strides: two chains, one per worker; when the one-stride entry is
    cached, the two-stride one is still being solved."""
    p = tmp_path / "two.toml"
    p.write_text(f'extends = "{TINY.as_posix()}"\n[sweep]\nvelocities_mps = [0.3]\nstrides = [1, 2]\n')
    return p


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_killed_build_leaves_no_process_and_resumes(tmp_path, sig):
    """SIGKILL or SIGTERM during a build: within 10 s no process of it is alive (found by session,
    not by name); SIGTERM exits 130 saying how many entries are cached; the same command then
    resumes from the cache and writes the library."""
    cfg, out, cache = _two_chains(tmp_path), tmp_path / "out" / "x.h5", tmp_path / "cache"
    env = {**os.environ, "SKATELIB_CACHE_DIR": str(cache), "COLUMNS": "200"}
    p = subprocess.Popen([*CLI, "build", str(cfg), "-o", str(out), "--no-progress", "-j", "2"], env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 120
    while not list((cache / "entries").glob("*.entry")) and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.2)
    assert p.poll() is None, "the build ended before it could be killed"
    assert len(_session(p.pid)) >= 3  # the build, the queue's manager, workers
    os.kill(p.pid, sig)
    _, stderr = p.communicate(timeout=60)
    deadline = time.monotonic() + 10
    while _session(p.pid) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert _session(p.pid) == [], "processes of the killed build are still running after 10 s"
    assert not out.exists() and not list(out.parent.glob(".x.h5.*"))
    if sig == signal.SIGTERM:
        assert p.returncode == 130 and "interrupted:" in stderr and "run the same command to resume" in stderr.lower()
    again = subprocess.run([*CLI, "build", str(cfg), "-o", str(out), "--no-progress"], env=env,
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stdout + again.stderr
    assert " c " in again.stdout or "c │" in again.stdout  # some entries came from the cache
    assert len(MotionLibrary.open(out)) == 2


CASES = {
    "colliding speeds": ("[sweep]\nvelocities_mps = [0.501, 0.504]\nstrides = [1]\n", "sweep.velocities_mps"),
    "repeated strides": ("[sweep]\nvelocities_mps = [0.3]\nstrides = [1, 1]\n", "sweep.strides"),
    "NaN friction": ("[robot]\nfriction_mu = nan\n", "robot.friction_mu"),
    "NaN dt": ("[optimization]\ndt_s = nan\n", "optimization.dt_s"),
    "NaN speed": ("[sweep]\nvelocities_mps = [nan]\nstrides = [1]\n", "sweep.velocities_mps"),
    "meta not a table": ("meta = 5\n", "meta"),
    "URDF is a folder": ('[robot]\nurdf = "."\n', "robot.urdf"),
    "URDF is no XML": ('[robot]\nurdf = "bad.toml"\n', "robot.urdf"),  # the parser's words go into the message
}


@pytest.mark.parametrize("case", CASES)
def test_bad_configs_are_refused_before_any_solve(tmp_path, case):
    """Each bad config: exit 2, the file and key named on stderr, no traceback, nothing written."""
    text, key = CASES[case]
    cfg = tmp_path / "bad.toml"
    cfg.write_text(f'extends = "{TINY.as_posix()}"\n{text}' if not text.startswith("meta") else text)
    out = tmp_path / "out.h5"
    r = _run(["build", str(cfg), "-o", str(out), "--no-progress"], env={"SKATELIB_CACHE_DIR": str(tmp_path / "c")})
    assert r.returncode == 2, r.stdout + r.stderr
    assert "bad.toml" in r.stderr and key in r.stderr and "Traceback" not in r.stderr + r.stdout
    assert r.stderr.startswith("error:"), r.stderr  # nothing above the message
    assert list(tmp_path.iterdir()) == [cfg]


def test_config_file_problems_are_named(tmp_path):
    """An extends cycle names the chain; a non-UTF-8 file, a library given as a config and a humanoid
    config with no speeds are refused with exit 2."""
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    a.write_text('extends = "b.toml"\n')
    b.write_text('extends = "a.toml"\n')
    r = _run(["build", str(a)])
    assert r.returncode == 2 and "a.toml -> b.toml -> a.toml" in r.stderr
    latin = tmp_path / "latin.toml"
    latin.write_bytes(b"[meta]\nname = \"caf\xe9\"\n")
    r = _run(["build", str(latin)])
    assert r.returncode == 2 and "not UTF-8" in r.stderr
    lib = tmp_path / "lib.h5"
    lib.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(64))
    r = _run(["build", str(lib)])
    assert r.returncode == 2 and "not a TOML config" in r.stderr
    walk = tmp_path / "walk.toml"
    walk.write_text(f'extends = "{(CONFIGS / "hrp2_walk.toml").as_posix()}"\n[sweep]\nmotion = "walk"\n'
                    "velocities_mps = []\n")
    r = _run(["build", str(walk), "-o", str(tmp_path / "w.h5")])
    assert r.returncode == 2 and "sweep.velocities_mps" in r.stderr and not (tmp_path / "w.h5").exists()


def test_outputs_are_checked_before_any_solve(tmp_path):
    """-o a folder, -o the config itself, -o a file that is not a library, -o inside a file: exit 2
    in well under the time of one solve, and nothing is changed."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(f'extends = "{TINY.as_posix()}"\n')
    other = tmp_path / "notes.txt"
    other.write_text("keep me")
    for target, words in ((tmp_path, "is a folder"), (cfg, "is an input"), (other, "not a skatelib library"),
                          (other / "x.h5", "cannot be written")):
        t0 = time.monotonic()
        r = _run(["build", str(cfg), "-o", str(target), "--no-progress"])
        assert r.returncode == 2 and words in " ".join(r.stderr.split()), (target, r.stderr)  # wraps at a long path
        assert time.monotonic() - t0 < 20
    assert other.read_text() == "keep me" and cfg.read_text().startswith("extends")


def test_backend_scheduler_cache_and_velocity_are_checked(tmp_path):
    """--backend foo, a malformed or unreachable scheduler, a cache path that is a file and a solve
    speed outside the config's range: exit 2 with the option or variable named."""
    r = _run(["build", "--backend", "foo"])
    assert r.returncode == 2 and "--backend" in r.stderr
    r = _run(["build", str(TINY), "--backend", "dask", "--scheduler", "notaurl", "-o", str(tmp_path / "x.h5")])
    assert r.returncode == 2 and "tcp://HOST:PORT" in r.stderr
    t0 = time.monotonic()
    r = _run(["build", str(TINY), "--backend", "dask", "--scheduler", "tcp://127.0.0.1:9", "-o",
              str(tmp_path / "x.h5")])
    assert r.returncode == 2 and "no dask scheduler answers" in r.stderr and time.monotonic() - t0 < 30
    blocker = tmp_path / "cachefile"
    blocker.write_text("")
    r = _run(["build", str(TINY), "-o", str(tmp_path / "x.h5"), "--no-progress"],
             env={"SKATELIB_CACHE_DIR": str(blocker)})
    assert r.returncode == 2 and "SKATELIB_CACHE_DIR" in r.stderr
    r = _run(["solve", "--velocity", "4.0", "--strides", "1", "-o", str(tmp_path / "x.h5")])
    assert r.returncode == 2 and "--velocity" in r.stderr and "less than or equal to 3" in r.stderr
    assert not (tmp_path / "x.h5").exists()


def test_library_errors_exit_3_on_stderr(tmp_path):
    """A missing or damaged library: exit 3, message on stderr naming the file."""
    r = _run(["validate", str(tmp_path / "none.h5")])
    assert r.returncode == 3 and "none.h5" in r.stderr and r.stdout == ""
    folder = tmp_path / "lib.h5"
    folder.mkdir()
    r = _run(["info", str(folder)])  # a folder is called a folder (it was "no such file")
    assert r.returncode == 3 and "is a folder" in r.stderr and "no such file" not in r.stderr


def test_inspect_save_is_checked_before_logging(tmp_path):
    """inspect --save into a folder, onto a file that is not a recording, or onto the library
    itself: exit 2, nothing overwritten; a read-only folder: exit 2 naming it."""
    from skatelib.library import schema
    from skatelib.library.writer import write_library

    from tests.test_cpp_reader import _entry, _root

    lib = write_library(tmp_path / "f.h5", _root(), dict.fromkeys(schema.QUADRUPED_MODEL_ATTRS, 1.0), {}, {},
                        [_entry(0.3, 1, True)])
    other = tmp_path / "notes.txt"
    other.write_text("keep me")
    for target, words in [(tmp_path, "is a folder"), (other, "not a Rerun recording"), (lib, "is an input")]:
        r = _run(["inspect", str(lib), "--save", str(target)])
        assert r.returncode == 2 and words in r.stderr and "Traceback" not in r.stderr, (target, r.stderr)
    assert other.read_text() == "keep me"
    if os.geteuid() != 0:  # root writes into read-only folders
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o555)
        r = _run(["inspect", str(lib), "--save", str(ro / "x.rrd")])
        assert r.returncode == 2 and "cannot be written" in r.stderr


def _open_damaged(args: tuple[bytes, int, str]) -> str:
    raw, pos, how = args
    data = bytearray(raw)
    if how == "flip":
        data[pos] ^= 0x10
    else:
        data[pos:pos + 4096] = bytes(len(data[pos:pos + 4096]))
    path = Path(f"/tmp/skatelib-fuzz-{os.getpid()}.h5")
    path.write_bytes(bytes(data))
    try:
        MotionLibrary.open(path)
        return "accepted"
    except LibraryFormatError:
        return "refused"
    except Exception as e:
        return f"{type(e).__name__}: {e}"
    finally:
        path.unlink()


@pytest.mark.slow
def test_fuzz_bit_flips_and_zeroed_blocks_are_refused(tmp_path):
    """160 single-bit flips and 40 zeroed 4 KB blocks at random places of a small library, each
    opened in a forked child: every one is refused with LibraryFormatError (never accepted, never
    another exception, never a crash, never a hang: one of these blocks made HDF5 loop forever
    until the reader verified the checksum before parsing)."""
    from skatelib.library import schema
    from skatelib.library.writer import write_library

    from tests.test_cpp_reader import _entry, _root  # a small synthetic library

    lib = write_library(tmp_path / "f.h5", _root(), dict.fromkeys(schema.QUADRUPED_MODEL_ATTRS, 1.0), {}, {},
                        [_entry(0.3, 1, True), _entry(0.5, 2, False)])
    raw = lib.read_bytes()
    rng = np.random.default_rng(7)
    jobs = [(raw, int(p), "flip") for p in rng.integers(0, len(raw), 160)]
    jobs += [(raw, int(p), "zero") for p in rng.integers(0, len(raw) - 1, 40)]
    bad = {}
    with multiprocessing.get_context("fork").Pool(2) as pool:
        pending = [(j, pool.apply_async(_open_damaged, (j,))) for j in jobs]
        for j, res in pending:
            try:
                r = res.get(timeout=30)
            except multiprocessing.TimeoutError:  # HDF5 parsing a damaged file can loop forever
                bad[(j[1], j[2])] = "hangs"
                break
            if r != "refused":
                bad[(j[1], j[2])] = r
    assert not bad, bad
