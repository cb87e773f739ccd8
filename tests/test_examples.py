"""The scripts of examples/ run as a user runs them (a subprocess), on small configs that really
solve, and do what they say; they use the public API alone and no absolute path."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest
from skatelib.runtime import MotionLibrary

from tests.helpers import TINY

pytestmark = pytest.mark.slow  # make test-fast leaves this module out

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
# What an example may import of skatelib: the Python API, the runtime and the robot's controller.
PUBLIC = ("skatelib", "skatelib.runtime", "skatelib.control")
# Each example -> the test that runs it (controller_tick.py: tests/test_controller_install.py).
RUN_BY = {"custom_config.py": "test_custom_config_builds_validates_and_tracks",
          "control_loop.py": "test_control_loop_ticks_at_500_hz",
          "dask_build.py": "test_dask_build_on_a_local_cluster",
          "controller_tick.py": "test_controller_install.test_the_controller_imports_no_harness"}


def internal_imports(source: str) -> list[str]:
    """The skatelib modules a script imports beyond :data:`PUBLIC`, and its absolute paths
    (string literals that start with ``/``)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                 else [node.module] if isinstance(node, ast.ImportFrom) and node.module else [])
        found += [n for n in names if n.split(".")[0] == "skatelib"
                  and not any(n == p or (p != "skatelib" and n.startswith(p + ".")) for p in PUBLIC)]
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.startswith("/"):
            found.append(f"absolute path {node.value!r}")
    return found


def test_examples_use_the_public_api_alone():
    """No example imports skatelib's internals (pipeline, proving, sim, library) or names an
    absolute path, and each is run by a test of the suite."""
    scripts = sorted(p.name for p in EXAMPLES.glob("*.py"))
    assert scripts == sorted(RUN_BY)
    for name in scripts:
        assert internal_imports((EXAMPLES / name).read_text()) == [], name


def test_the_check_sees_internal_imports():
    """Negative control: the build through its internal module, the config module and an absolute
    ``extends`` path are each reported."""
    doctored = ("from skatelib.pipeline.build.orchestrate import build_library\n"
                "import skatelib.pipeline.config\nimport skatelib\nfrom skatelib.runtime import MotionLibrary\n"
                "EXTENDS = '/work/configs/cyberdog2.toml'\n")
    assert internal_imports(doctored) == ["skatelib.pipeline.build.orchestrate", "skatelib.pipeline.config",
                                          "absolute path '/work/configs/cyberdog2.toml'"]


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


def test_custom_config_builds_validates_and_tracks(custom):
    """The script writes a config that extends the shipped default by name, builds it with a line
    per entry as it starts and finishes, validates every entry (the start-up and the stop from its
    speed, the fewest strides that pass) and rides each on the model plant as planned, each passing."""
    tmp, r = custom
    assert r.returncode == 0, r.stdout + r.stderr
    assert "validate v0.40_s1: ok" in r.stdout
    assert 'extends = "skatelib:cyberdog2.toml"' in (tmp / "custom.toml").read_text()
    lib = MotionLibrary.open(tmp / "custom.h5")
    assert lib.keys()[0] == "v0.40_s1" and lib.keys()[1].startswith("v0.40-0.00_s") and len(lib) == 2
    assert all(e.success for e in lib)
    # progress: each entry started, then finished, before the file was written (a transition's task is
    # named without its stride count, which it chooses: v0.40-0.00 became v0.40-0.00_s1)
    started = [line.split("solving ")[1] for line in r.stdout.splitlines() if line.startswith("  solving ")]
    assert len(started) == 2 and all(any(e.key.startswith(s) for e in lib) for s in started), started
    for s in started:
        assert r.stdout.index(f"solving {s}\n") < r.stdout.index(f"  {s}: ok") < r.stdout.index("wrote ")
    assert "ridden 2 of 2" in r.stdout
    assert "track v0.40_s1 (model plant, errors: none): delivered" in r.stdout


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
