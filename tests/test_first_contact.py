"""A user who installed only what building needs (``make library``: the ``[build]`` extra) and runs
another command: it exits 4 and says which extra to install, whatever package it reached first.
The missing packages are hidden from the subprocess by an import hook, so no second virtual
environment is needed; a test holds the command line's table of extras to pyproject.toml."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib

import pytest
from skatelib.pipeline.cli.app import EXTRA_OF, install_hint

from tests.test_extras import ROOT, _names

EXTRAS = {  # extra -> the import names of its packages that the [build] extra does not bring
    "control": ("daqp", "proxsuite", "osqp", "threadpoolctl"),
    "viz": ("rerun",),
    "plot": ("matplotlib",),
    "sim": ("mujoco",),
}


def _cli(args: list[str], hidden: tuple[str, ...] = ()) -> subprocess.CompletedProcess:
    hook = (
        "import sys\n"
        f"HIDDEN = {set(hidden)!r}\n"
        "class Hide:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in HIDDEN:\n"
        "            raise ModuleNotFoundError(f'No module named {name!r}', name=name)\n"
        "sys.meta_path.insert(0, Hide())\n"
        "from skatelib.pipeline.cli.app import main\n"
        "main()\n")
    return subprocess.run([sys.executable, "-c", hook, *args], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "COLUMNS": "200"})


@pytest.fixture(scope="module")
def lib(tiny_v03):
    """A library of one solved entry (0.3 m/s, one stride; the session's)."""
    return tiny_v03.path


@pytest.mark.parametrize(("args", "extra"), [
    (["track", "{lib}", "--no-progress"], "control"),
    (["validate", "{lib}", "--closed-loop"], "control"),
    (["track", "{lib}", "--plant", "mujoco", "--no-progress"], "sim"),
    (["inspect", "{lib}", "--save", "{tmp}/x.rrd"], "viz"),
    (["plot", "{lib}", "-o", "{tmp}/fig"], "plot"),
])
def test_each_command_names_the_extra_it_needs(lib, tmp_path, args, extra):
    """Exit 4, no traceback, and the install line of the missing extra on stderr."""
    line = [a.format(lib=lib, tmp=tmp_path) for a in args]
    r = _cli(line, EXTRAS[extra])
    assert r.returncode == 4, (r.returncode, r.stdout, r.stderr)
    assert f"skatelib[{extra}" in r.stderr.replace("'", "").replace(",", "[") or f"[{extra}" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr


def test_every_hidden_package_is_reported_with_its_extra():
    """The command line's module -> extra table agrees with pyproject.toml: each import name is a
    package of the extra it names."""
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    for module, extra in EXTRA_OF.items():
        names = {n for r in extras[extra] if not r.startswith("skatelib[") for n in _names(r)}
        assert module in names or (module == "dask" and "distributed" in names), (module, extra, names)
    hint = install_hint(ModuleNotFoundError("No module named 'threadpoolctl'", name="threadpoolctl"))
    assert hint.endswith("pip install 'skatelib[control]'")
    assert "make venv" in install_hint(ModuleNotFoundError("No module named 'x'", name="x"))
