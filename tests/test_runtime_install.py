"""A runtime-only install: the wheel installed into a fresh venv without extras pulls numpy and h5py
alone, opens and samples a library, and its `skatelib` command names the extra to install."""

from __future__ import annotations

import subprocess
import sys
import venv
from pathlib import Path

import numpy as np
import pytest
from skatelib.library import schema
from skatelib.library.channels import CONTROL_NAMES, LEGS, STATE_NAMES
from skatelib.library.records import EntryRecord
from skatelib.library.writer import write_library

ROOT = Path(__file__).resolve().parent.parent


def _library(path: Path) -> Path:
    t = np.arange(5) * 0.1
    state = np.outer(t, np.ones(28))
    attrs = dict(zip(schema.ENTRY_ATTRS, (0.5, 2, True, "Solve_Succeeded", 10, 0.1, 1.0, 1e-9), strict=True))
    e = EntryRecord(key="v0.50_s2", attrs=attrs, arrays={"t": t, "state": state, "control": np.zeros((4, 24)),
                  "contact": np.ones((5, 4), np.int8), "foot_pos": np.zeros((5, 4, 3)), "board_pos": np.zeros((5, 4))},
                  columns={"state": STATE_NAMES, "control": CONTROL_NAMES, "contact": LEGS})
    root = {schema.A_KIND: "quadruped", schema.A_NAME: "t", schema.A_SKATELIB_VERSION: "0", schema.A_CREATED: "x",
            schema.A_GIT_COMMIT: "x", schema.A_GIT_DIRTY: False, schema.A_CONFIG_TOML: "", schema.A_CASADI: "x",
            schema.A_IPOPT: "x", schema.A_PINOCCHIO: "x"}
    return write_library(path, root, dict.fromkeys(schema.QUADRUPED_MODEL_ATTRS, 1.0), {}, {}, [e])


@pytest.mark.slow
def test_wheel_without_extras_serves_the_runtime(tmp_path):
    """numpy and h5py are the only dependencies installed; the library opens and samples with no
    pipeline package imported; the command exits 4 with the install hint instead of a traceback."""
    dist = tmp_path / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", str(dist),
                    str(ROOT)], check=True, capture_output=True)
    (wheel,) = dist.glob("skatelib-*.whl")
    env_dir = tmp_path / "rt"
    venv.create(env_dir, with_pip=True)
    py = env_dir / "bin" / "python"
    r = subprocess.run([str(py), "-m", "pip", "install", "-q", str(wheel)], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    listed = subprocess.run([str(py), "-m", "pip", "list", "--format=freeze"], capture_output=True, text=True,
                            check=True).stdout
    names = {line.split("==")[0].lower() for line in listed.split()} - {"pip", "setuptools", "wheel"}
    assert names == {"skatelib", "numpy", "h5py"}, names
    lib = _library(tmp_path / "lib.h5")
    code = ("import sys; from skatelib.runtime import MotionLibrary; e = MotionLibrary.open(sys.argv[1])['v0.50_s2']; "
            "w = e.window(0.05, 3, 0.1); print(e.sample(0.25)['base_x'], w['base_x'].tolist(), w.contact.tolist()[0]); "
            "bad = [m for m in ('casadi', 'pinocchio', 'typer', 'rich', 'joblib') if m in sys.modules]; "
            "sys.exit(1 if bad else 0)")
    out = subprocess.run([str(py), "-c", code, str(lib)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout.split()[0] == "0.25"
    cli = subprocess.run([str(env_dir / "bin" / "skatelib"), "--help"], capture_output=True, text=True)
    assert cli.returncode == 4 and "pip install 'skatelib[pipeline]'" in cli.stderr
    assert "Traceback" not in cli.stderr


@pytest.mark.slow
def test_wheel_ships_the_default_config_and_robot(tmp_path):
    """The wheel holds configs/ and the URDF as package data: installed (without its dependencies,
    which this venv has) and first on the path, `skatelib model` without a config reads the
    installed default config and robot, not the checkout's."""
    import zipfile

    dist = tmp_path / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", str(dist),
                    str(ROOT)], check=True, capture_output=True)
    (wheel,) = dist.glob("skatelib-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {"skatelib/configs/cyberdog2.toml", "skatelib/configs/robots/cyberdog2.urdf",
            "skatelib/configs/hrp2_walk.toml"} <= names
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target), str(wheel)],
                   check=True, capture_output=True)
    code = ("from skatelib.pipeline.config import load_config; import skatelib.pipeline as p; "
            "c = load_config(None); print(p.__file__); print(c.path); print(c.urdf_path)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"}, cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    module, config, urdf = r.stdout.split()
    assert all(Path(x).resolve().is_relative_to(target.resolve()) for x in (module, config, urdf)), r.stdout
