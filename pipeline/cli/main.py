"""The ``skatelib`` command's entry point. It imports nothing beyond the standard library until it
knows the build pipeline's packages are there: a runtime-only install (``pip install skatelib``:
numpy and h5py, for :mod:`skatelib.runtime` on the robot) gets a message naming the extra to
install instead of a traceback."""

from __future__ import annotations

import importlib.util
import sys

from skatelib.library.errors import EXIT_DEPENDENCY  # standard library only
from skatelib.pipeline.api import PIPELINE_MODULES  # standard library only until a function runs


def main() -> None:
    """Run the command line, or exit 4 naming the missing packages and the extra that brings them."""
    missing = [m for m in PIPELINE_MODULES if importlib.util.find_spec(m) is None]
    if missing:
        sys.stderr.write(
            f"skatelib: the command line needs the build pipeline's packages; missing: {', '.join(missing)}.\n"
            "This is a runtime-only install (numpy + h5py, enough for skatelib.runtime on a robot).\n"
            "To build, validate or inspect libraries: pip install 'skatelib[pipeline]'\n")
        raise SystemExit(EXIT_DEPENDENCY)
    from skatelib.pipeline.cli.app import main as cli_main

    cli_main()
