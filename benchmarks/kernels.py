"""The cold push-off (0.5 m/s x 2 strides) under each of OpenBLAS's kernel sets, with native and
with portable stage code: whether its IPOPT path hinges on rounding. Each variant runs in a process
of its own (``OPENBLAS_CORETYPE`` is read when numpy loads OpenBLAS), after its problem is built
(a first run compiles the stage code for that kernel set and flags: the problem's constants are
computed with numpy, so their last bits follow the kernel set); the baseline of each kernel set is
the same solve with the stage functions interpreted, in the same run. A kernel set this CPU cannot
run (SkylakeX's AVX-512 on a CPU without it: an illegal instruction) is reported as such. Like the
push-off rows, each solve evaluates its stage derivatives on every core the process may use."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

from benchmarks.figures import Figure, Measured

KERNELS = ("Haswell", "SkylakeX", "Prescott")
CODES = ("native", "portable", "interpreted")
SPREAD = Figure("pushoff-kernels", "cold push-off 0.5 m/s x 2: most IPOPT iterations over OpenBLAS's kernel "
                "sets (Haswell, SkylakeX, Prescott) x native and portable stage code", "it", 25,
                "fewest of the same variants")


def _child(code: str) -> None:
    """Solve once in this process (its kernel set from the environment) and print the figures."""
    import dataclasses

    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.quadruped.config import QuadrupedConfig
    from skatelib.pipeline.quadruped.problem import pushoff

    cfg = load_config(None, QuadrupedConfig)
    opt = dataclasses.replace(cfg.optimization, compile=code != "interpreted", compile_native=code == "native")
    cfg = dataclasses.replace(cfg, optimization=opt)
    pushoff.problem_for(cfg, 2)  # built (and on a first run compiled) before the clock starts
    t0 = time.perf_counter()
    r = pushoff.solve(pushoff.PushoffSpec(cfg, 0.5, 2))
    print(json.dumps({"iterations": r.iterations, "seconds": time.perf_counter() - t0, "success": r.success}))


def _run(kernel: str, code: str) -> dict[str, float] | str:
    """One variant's figures, or why there are none."""
    env = {k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"} | {"OPENBLAS_CORETYPE": kernel}
    done = subprocess.run([sys.executable, "-m", "benchmarks.kernels", code], env=env, capture_output=True,
                          text=True, timeout=1800)
    if done.returncode == -signal.SIGILL:
        return "not runnable on this CPU (illegal instruction)"
    if done.returncode != 0:
        raise RuntimeError(f"push-off under {kernel}, {code}: exit {done.returncode}: {done.stderr[-800:]}")
    out: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    if not out["success"]:
        raise RuntimeError(f"push-off under {kernel}, {code}: the solve failed")
    return out


def measure() -> list[Measured]:
    notes, compiled = [], []
    for kernel in KERNELS:
        runs = {code: _run(kernel, code) for code in CODES}
        if any(isinstance(r, str) for r in runs.values()):
            notes.append(f"{kernel}: {next(r for r in runs.values() if isinstance(r, str))}")
            continue
        figures = {code: r for code, r in runs.items() if not isinstance(r, str)}
        compiled += [figures["native"]["iterations"], figures["portable"]["iterations"]]
        notes.append(f"{kernel}: " + ", ".join(f"{code} {f['iterations']:.0f} it {f['seconds']:.2f} s"
                                               for code, f in figures.items()))
    if not compiled:
        raise RuntimeError("push-off kernels: no kernel set runs on this CPU")
    return [Measured(SPREAD, max(compiled), min(compiled), "; ".join(notes))]


if __name__ == "__main__":
    _child(sys.argv[1])
