"""The API reference (``make docs``: tools/build_docs.py, pdoc) builds with no warning and documents
the Python API; a docstring or annotation pdoc cannot read fails it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tests.helpers import load_tool

ROOT = Path(__file__).resolve().parents[1]


def _tool():
    return load_tool("build_docs")


def test_the_reference_builds_without_a_warning(tmp_path):
    """The tool as make docs runs it: exit 0, the API's page with build, validate and track and their
    arguments' sections, the runtime's page."""
    r = subprocess.run([sys.executable, str(ROOT / "tools" / "build_docs.py"), str(tmp_path / "docs")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    page = (tmp_path / "docs" / "skatelib.html").read_text()
    for name in ("build", "validate", "track"):
        assert f'id="{name}"' in page
    assert "Raises:" in page and "ConfigError" in page
    assert (tmp_path / "docs" / "skatelib" / "runtime.html").exists()


def test_a_warning_fails_the_build(tmp_path, monkeypatch):
    """Negative control: a module whose NamedTuple field pdoc cannot resolve gives a warning naming
    it, and the tool exits 1."""
    (tmp_path / "doctored.py").write_text('"""A doctored module."""\nfrom __future__ import annotations\n'
                                          "from typing import NamedTuple\nimport numpy as np\n\n\n"
                                          'class Row(NamedTuple):\n    """A row."""\n\n    values: np.ndarray\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    found = _tool().build(tmp_path / "docs", ("doctored",))
    assert any("doctored.Row" in w for w in found), found
    r = subprocess.run([sys.executable, str(ROOT / "tools" / "build_docs.py"), str(tmp_path / "docs2"), "doctored"],
                       capture_output=True, text=True, timeout=300, env={"PYTHONPATH": str(tmp_path), "PATH": ""})
    assert r.returncode == 1 and "doctored.Row" in r.stdout, r.stdout + r.stderr
