"""``make bench``: every figure as a ratio against a baseline measured in the same run, written to
the table of ``docs/benchmarks.md``.

One module per subject, each with its figures (name, target, baseline) as data and a ``measure``
function: :mod:`benchmarks.pushoff`, :mod:`benchmarks.library`, :mod:`benchmarks.runtime`,
:mod:`benchmarks.humanoid`, :mod:`benchmarks.humanoid_twin`, :mod:`benchmarks.rerun_log`, :mod:`benchmarks.mpc`,
:mod:`benchmarks.fatrop`, :mod:`benchmarks.sim`, :mod:`benchmarks.wbc`, :mod:`benchmarks.estimator`,
:mod:`benchmarks.certify`.

``python -m benchmarks.run [pushoff|library|runtime|...|certify ...]`` runs a subset
(and rewrites only its rows); ``--no-write`` leaves the table alone.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import importlib
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks.figures import Measured, write_table

# name -> (module, whether its measure() takes the default library's path)
PARTS: dict[str, tuple[str, bool]] = {
    "pushoff": ("benchmarks.pushoff", False),
    "kernels": ("benchmarks.kernels", False),
    "library": ("benchmarks.library", True),
    "runtime": ("benchmarks.runtime", True),
    "humanoid": ("benchmarks.humanoid", False),
    "humanoid-twin": ("benchmarks.humanoid_twin", False),
    "rerun": ("benchmarks.rerun_log", True),
    "mpc": ("benchmarks.mpc", True),
    "fatrop": ("benchmarks.fatrop", False),
    "sim": ("benchmarks.sim", False),
    "wbc": ("benchmarks.wbc", True),
    "estimator": ("benchmarks.estimator", True),
    "certify": ("benchmarks.certify", True),
}


def _runtime_in_own_process(path: Path) -> list[Measured]:
    """The runtime figures from a fresh process: the build's idle worker processes would disturb them."""
    import pickle

    code = ("import pickle, sys; from pathlib import Path; from benchmarks.runtime import measure; "
            "sys.stdout.buffer.write(pickle.dumps(measure(Path(sys.argv[1]))))")
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, check=True).stdout
    results: list[Measured] = pickle.loads(out)  # our own child's output
    return results


def _default_library(path: Path) -> Path:
    """The default library at ``path``, built unless the library benchmark built it there."""
    if not path.exists():
        from skatelib.pipeline.build.contract import BuildOptions
        from skatelib.pipeline.build.orchestrate import build_library
        from skatelib.pipeline.config import load_config

        build_library(load_config(None), path, BuildOptions(progress=False))
    return path


def measure(part: str, lib: Path) -> list[Measured]:
    module, with_library = PARTS[part]
    if part == "runtime":
        return _runtime_in_own_process(_default_library(lib))
    if part == "library":
        return list(importlib.import_module(module).measure(lib))
    run = importlib.import_module(module).measure
    return list(run(_default_library(lib)) if with_library else run())


def main(parts: list[str], write: bool) -> list[Measured]:
    unknown = sorted(set(parts) - set(PARTS))
    if unknown:
        raise SystemExit(f"unknown benchmark {', '.join(unknown)}; choose from {', '.join(PARTS)}")
    lib = Path(tempfile.mkdtemp()) / "default.h5"
    results: list[Measured] = []
    for part in parts:
        for m in measure(part, lib):
            print(m.line(), flush=True)
            results.append(m)
    if write:
        write_table(results)
        print("wrote the table of docs/benchmarks.md")
    return results


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--no-write"]
    main(args or list(PARTS), write="--no-write" not in sys.argv[1:])
