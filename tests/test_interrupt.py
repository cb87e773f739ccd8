"""Ctrl-C and SIGTERM stop a solve that runs in the command's own process (``solve``, ``build -j 1``)
as they stop a worker's: exit 130 at once, finished entries cached, no library written, although
CasADi catches the interrupt inside IPOPT and reports a failed solve."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
from skatelib.library.errors import EXIT_INTERRUPTED
from skatelib.pipeline.build import interrupt

from tests.helpers import CLI, interpreted_tiny

SIGNALS = [signal.SIGINT, signal.SIGTERM]


def _start(args: list[str], cache: Path) -> subprocess.Popen:
    env = {**os.environ, "SKATELIB_CACHE_DIR": str(cache), "COLUMNS": "200"}
    return subprocess.Popen([*CLI, *args], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)  # the signal goes to the command alone


def _ended(p: subprocess.Popen, sig: int) -> tuple[float, str]:
    """Send ``sig``; the seconds the command took to end, and its stderr."""
    sent = time.monotonic()
    p.send_signal(sig)
    _, stderr = p.communicate(timeout=120)
    return time.monotonic() - sent, stderr


@pytest.mark.slow
@pytest.mark.parametrize("sig", SIGNALS, ids=["SIGINT", "SIGTERM"])
def test_a_signal_inside_ipopt_stops_solve(tmp_path, sig):
    """``skatelib solve -v`` is sent the signal once IPOPT prints its iteration header (it is inside
    IPOPT): it exits 130 within seconds, writing no library (without the record of the interrupt
    the next attempt of the ladder ran, and the library was written with exit 0)."""
    out = tmp_path / "one.h5"
    # interpreted, six substeps: a solve of about 4 s, a wide window for the signal (compiled, the
    # config's two: about a second)
    cfg = interpreted_tiny(tmp_path / "interpreted.toml", "substeps = 6\n")
    p = _start(["solve", "-V", "0.3", "-s", "1", "--config", str(cfg), "-o", str(out), "-v"], tmp_path / "cache")
    assert p.stdout is not None
    for line in p.stdout:
        if line.startswith("iter"):
            break
    else:
        pytest.fail(f"IPOPT never started: {p.communicate()}")
    time.sleep(0.3)  # a few iterations in
    took, stderr = _ended(p, sig)
    assert p.returncode == EXIT_INTERRUPTED, stderr
    assert "KeyboardInterrupt" in stderr  # CasADi did catch it inside IPOPT
    assert "interrupted" in stderr and not out.exists() and not list(tmp_path.glob(".*one.h5*"))
    assert took < 10, f"ended {took:.1f} s after the signal"


@pytest.mark.slow
@pytest.mark.parametrize("sig", SIGNALS, ids=["SIGINT", "SIGTERM"])
def test_a_signal_stops_a_serial_build_keeping_what_is_finished(tmp_path, sig):
    """``skatelib build -j 1`` of two cold entries, signalled during the second solve: exit 130
    saying one entry is cached, that one in the cache, no library written, within seconds."""
    cfg = interpreted_tiny(tmp_path / "two.toml",  # a second solve of seconds to signal inside: six substeps
                           "substeps = 6\n[sweep]\nvelocities_mps = [0.3, 0.4]\nstrides = [1]\nwarm_start = false\n")
    out, cache = tmp_path / "out" / "two.h5", tmp_path / "cache"
    p = _start(["build", str(cfg), "-o", str(out), "-j", "1", "--no-progress"], cache)
    deadline = time.monotonic() + 120
    while not list((cache / "entries").glob("*.entry")) and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.05)
    assert p.poll() is None, "the build ended before the signal"
    time.sleep(0.5)  # the second entry's cold solve (about 4 s of IPOPT) is under way
    took, stderr = _ended(p, sig)
    assert p.returncode == EXIT_INTERRUPTED, stderr
    assert "1 of 2 entries are cached" in stderr and "no library was written" in stderr
    assert len(list((cache / "entries").glob("*.entry"))) == 1
    assert not out.exists() and not list(out.parent.glob("*"))
    assert took < 10, f"ended {took:.1f} s after the signal"


def test_the_record_outlives_a_swallowed_interrupt_until_reset():
    """The handler records the interrupt before raising; :func:`interrupt.check` raises again after
    whoever caught it, until :func:`interrupt.reset` (a new command)."""
    interrupt.reset()
    interrupt.check()  # nothing came
    with contextlib.suppress(KeyboardInterrupt):  # what CasADi does inside IPOPT
        interrupt.handle(signal.SIGINT, None)
    assert interrupt.arrived()
    with pytest.raises(KeyboardInterrupt):
        interrupt.check()
    interrupt.reset()
    assert not interrupt.arrived()
    interrupt.check()
