"""The scripts of examples/ run as a user runs them (a subprocess), on small configs that really
solve, and do what they say."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from skatelib.runtime import MotionLibrary

from tests.helpers import TINY

pytestmark = pytest.mark.slow  # make test-fast leaves this module out

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _run(args: list[str], tmp_path: Path, timeout: int = 600) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "SKATELIB_CACHE_DIR": str(tmp_path / "cache")}
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env, timeout=timeout,
                          cwd=tmp_path)


@pytest.fixture(scope="module")
def custom(tmp_path_factory):
    """examples/custom_config.py with one interpreted 0.4 m/s, 1-stride start-up and its stop."""
    tmp = tmp_path_factory.mktemp("custom")
    r = _run([str(EXAMPLES / "custom_config.py"), "--out", str(tmp / "custom.h5"), "--speeds", "0.4", "--strides",
              "1", "--interpreted"], tmp)
    return tmp, r


def test_custom_config_builds_and_validates(custom):
    """The script writes a config that extends the default, builds it, validates every entry: the
    start-up and the stop from its speed (the fewest strides that pass)."""
    tmp, r = custom
    assert r.returncode == 0, r.stdout + r.stderr
    assert "validate v0.40_s1: ok" in r.stdout
    assert 'extends = "' in (tmp / "custom.toml").read_text()
    lib = MotionLibrary.open(tmp / "custom.h5")
    assert lib.keys()[0] == "v0.40_s1" and lib.keys()[1].startswith("v0.40-0.00_s") and len(lib) == 2
    assert all(e.success for e in lib)


def test_control_loop_ticks_at_500_hz(custom):
    """The 500 Hz loop runs the whole entry plus half a second at 2 ms ticks on the runtime."""
    tmp, _ = custom
    r = _run([str(EXAMPLES / "control_loop.py"), str(tmp / "custom.h5"), "--speed", "0.4"], tmp)
    assert r.returncode == 0, r.stdout + r.stderr
    duration = MotionLibrary.open(tmp / "custom.h5")["v0.40_s1"].duration_s
    assert f"{int((duration + 0.5) / 0.002)} ticks at 500 Hz" in r.stdout
    # It ends riding at the label: three feet on the board, the push foot (rear left) lifted.
    assert "contact [1, 1, 0, 1]" in r.stdout
    speed = float(r.stdout.split("end: board ")[1].split()[0])
    assert abs(speed - 0.4) <= 0.01 * 0.4


def test_dask_build_on_a_local_cluster(tmp_path):
    """The dask example builds the tiny config on a local cluster of two worker processes."""
    pytest.importorskip("distributed")
    r = _run([str(EXAMPLES / "dask_build.py"), str(TINY), "--out", str(tmp_path / "dask.h5")], tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "2 of 2 entries succeeded" in r.stdout
    assert MotionLibrary.open(tmp_path / "dask.h5").keys() == ["v0.30_s1", "v0.40_s1"]
