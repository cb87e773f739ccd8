"""What several test modules share: the tiny config that really solves, and the command line as a
user runs it (a subprocess of this interpreter)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

TINY = Path(__file__).parent / "configs" / "tiny.toml"  # 2 entries, 1 stride, interpreted stage functions
CLI = [sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()"]


def run_cli(args: list[str], timeout: float = 300, **kw: object) -> subprocess.CompletedProcess:
    """The command line in a subprocess, output captured, tables 200 columns wide."""
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "COLUMNS": "200"}, **kw)  # type: ignore[call-overload]


def one_entry_library(folder: Path) -> Path:
    """``skatelib solve`` of the tiny config at 0.3 m/s and one stride: a library of one solved entry."""
    out = folder / "lib.h5"
    r = run_cli(["solve", "-V", "0.3", "-s", "1", "--config", str(TINY), "-o", str(out)])
    assert r.returncode == 0, r.stdout + r.stderr
    return out
