"""What several test modules share: the tiny config that really solves, the command line as a user
runs it (a subprocess of this interpreter), and a copy of a shared library to write into."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

TINY = Path(__file__).parent / "configs" / "tiny.toml"  # 2 entries, 1 stride
CLI = [sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()"]


def run_cli(args: list[str], timeout: float = 300, env: dict[str, str] | None = None,
            **kw: object) -> subprocess.CompletedProcess:
    """The command line in a subprocess, output captured, tables 200 columns wide."""
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=timeout,
                          env=env or {**os.environ, "COLUMNS": "200"}, **kw)  # type: ignore[call-overload]


def interpreted_tiny(path: Path, extra: str = "") -> Path:
    """The tiny config with its stage functions interpreted, and ``extra`` (TOML), written to
    ``path``: for a test that changes the model (no compile of its own for a model solved once) or
    needs a solve of seconds."""
    path.write_text(f'extends = "{TINY.as_posix()}"\n[optimization]\ncompile = false\n{extra}')
    return path


def copy_of(path: Path, folder: Path, name: str = "lib.h5") -> Path:
    """A copy of a shared library, for a test that writes into it or beside it."""
    folder.mkdir(parents=True, exist_ok=True)
    return Path(shutil.copy(path, folder / name))


def load_tool(name: str) -> Any:
    """The script ``tools/<name>.py`` as a module (the tools are not part of the package)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, Path(__file__).resolve().parents[1] / "tools" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
