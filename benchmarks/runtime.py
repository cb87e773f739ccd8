"""The runtime on the robot's side: opening a library (verified) against a naive per-entry h5py
read, ``Entry.sample`` against per-channel ``np.interp``, ``Entry.window`` against ten ``sample``
calls, and the first ``Entry.window`` of a fresh process against the next ones. Run in a process of
its own (a build's idle workers would disturb it)."""

from __future__ import annotations

import subprocess
import sys
import timeit
from pathlib import Path
from typing import Any

from benchmarks.figures import Figure, Measured

OPEN = Figure("runtime-open", "MotionLibrary.open (verified before parsing)", "ms", 10.0, "naive per-entry h5py read")
SAMPLE = Figure("runtime-sample", "Entry.sample", "us", 3.0, "per-channel np.interp")
WINDOW = Figure("runtime-window", "Entry.window(n=10)", "us", 15.0, "ten sample() calls")
FIRST = Figure("runtime-first-window", "first Entry.window(n=10) of a fresh process, after select", "us", 60.0,
               "median of its next 50 calls")
FIGURES = (OPEN, SAMPLE, WINDOW, FIRST)

# A fresh interpreter: open, select, then time each of 51 window calls (what a control loop does).
FIRST_CALLS = ("import sys, time; from skatelib.runtime import MotionLibrary; "
               "e = MotionLibrary.open(sys.argv[1]).select(0.5, clamp=True); ts = []\n"
               "for k in range(51):\n t0 = time.perf_counter(); e.window(0.034 * k, 10, 0.034); "
               "ts.append(time.perf_counter() - t0)\nprint(*ts)")


def first_window(path: Path) -> Measured:
    """The first window call of a fresh process and the median of the next 50 (best of 5 processes)."""
    import numpy as np

    runs = [[float(x) for x in subprocess.run([sys.executable, "-c", FIRST_CALLS, str(path)], capture_output=True,
                                              text=True, check=True).stdout.split()] for _ in range(5)]
    first = min(r[0] for r in runs)
    return Measured(FIRST, first * 1e6, min(float(np.median(r[1:])) for r in runs) * 1e6)


def measure(path: Path) -> list[Measured]:
    """Best of repeats of each call on the library at ``path``."""
    import h5py
    import numpy as np
    from skatelib.runtime import MotionLibrary

    t_open = min(timeit.repeat(lambda: MotionLibrary.open(path), number=1, repeat=30))

    def naive_open() -> dict[str, Any]:
        with h5py.File(path, "r") as f:
            g = f["entries"]
            return {k: {n: g[k][n][()] for n in g[k]} for k in g}

    t_naive = min(timeit.repeat(naive_open, number=1, repeat=10))
    e = MotionLibrary.open(path).select(0.5, 2)
    e.sample(0.0)
    n = 100_000
    t_sample = min(timeit.repeat(lambda: e.sample(0.613), number=n, repeat=5)) / n
    t_interp = min(timeit.repeat(lambda: [np.interp(0.613, e.t, e.state[:, j]) for j in range(28)],
                                 number=2000, repeat=5)) / 2000
    t_window = min(timeit.repeat(lambda: e.window(0.61, 10, 1 / 30), number=20000, repeat=5)) / 20000
    t_loop = min(timeit.repeat(lambda: [e.sample(0.61 + k / 30) for k in range(10)], number=5000, repeat=5)) / 5000
    cpp = Path("build/cpp/skatelib_bench")
    note = ""
    if cpp.exists():
        note = "C++ reader: " + subprocess.run([str(cpp), str(path), "0.5", "2"], capture_output=True,
                                               text=True).stdout.strip()
    return [Measured(OPEN, t_open * 1e3, t_naive * 1e3), Measured(SAMPLE, t_sample * 1e6, t_interp * 1e6, note),
            Measured(WINDOW, t_window * 1e6, t_loop * 1e6), first_window(path)]
