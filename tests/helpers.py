"""What several test modules share: the tiny config that really solves, and the command line as a
user runs it (a subprocess of this interpreter)."""

from __future__ import annotations

import sys
from pathlib import Path

TINY = Path(__file__).parent / "configs" / "tiny.toml"  # 2 entries, 1 stride, interpreted stage functions
CLI = [sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()"]
