"""The certificate's throughput: rides per second of ``skatelib certify`` on two workers (draws of
``v0.50_s2``, no cache), against one ``track --plant mujoco`` ride of the same entry in this
process (the default model errors), and what the default library's certificate (every successful
entry, the [certify] table's N) would take at that rate, here and on 100 cores."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from benchmarks.figures import Figure, Measured

DRAWS = 10
RATE = Figure("certify-rides", f"skatelib certify, {DRAWS} draws of v0.50_s2, 2 workers", "rides/s", 0.5,
              "one track --plant mujoco ride of it, one process", at_least=True)
FIGURES = (RATE,)


def measure(path: Path) -> list[Measured]:
    from skatelib.pipeline.certify_run import CertifyOptions, certify
    from skatelib.pipeline.certify_spec import library_spec
    from skatelib.proving.twin.track import twin_jobs
    from skatelib.runtime import MotionLibrary
    from skatelib.sim.errors import DEFAULT_TWIN_PERTURBATION

    lib = MotionLibrary.open(path)
    key = lib.select(0.5, 2).key
    t0 = time.perf_counter()
    twin_jobs(path, [key], DEFAULT_TWIN_PERTURBATION)[0]()
    one = time.perf_counter() - t0
    spec = dataclasses.replace(library_spec(lib), samples=DRAWS)
    t0 = time.perf_counter()
    cert = certify(path, spec, [key], CertifyOptions(jobs=2, cache=False))
    rate = DRAWS / (time.perf_counter() - t0)
    rides = sum(e.success for e in lib) * library_spec(lib).samples
    e = cert.entries[key]
    return [Measured(RATE, rate, 1.0 / one,
                     f"{e.successes} of {DRAWS} pass; the default library's {rides} rides: {rides / rate / 60:.0f} min "
                     f"here, {rides / (rate / 2 * 100):.0f} s on 100 cores")]
