"""The humanoid twin under its stabilizer: the 1.0 m/s skate of ``configs/hrp2_skate.toml`` (push,
slide, stop and 1 s of hold: 5 s) executed under the default model errors (the stabilizer at
500 Hz, the servos' feed-forward, the verdict's sampling at every tick, the physics at 1 kHz), as
a multiple of real time; the baseline is the same twin stepped bare for as long (the servos
holding the first posture, the wheels' rolling resistance applied), in the same run. The walk's
figure beside it in the note. The twin's and the stabilizer's C code is built (or loaded from the
cache) before either is timed: a first run on a machine compiles it once."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from benchmarks.figures import Figure, Measured

TWIN = Figure("humanoid-twin", "the 1.0 m/s skate (5 s) on the humanoid twin under the stabilizer, default errors",
              "x", 5.0, "the bare twin stepped as long", at_least=True)
FIGURES = (TWIN,)


def _library(folder: Path, config: str, velocity: float) -> Path:
    """One entry of a shipped humanoid config, built into ``folder``."""
    from skatelib.pipeline.build.contract import BuildOptions
    from skatelib.pipeline.build.orchestrate import build_library
    from skatelib.pipeline.config import CONFIG_DIR, load_config

    cfg = folder / f"{config}.toml"
    cfg.write_text(f'extends = "{(CONFIG_DIR / config).as_posix()}.toml"\n[sweep]\nvelocities_mps = [{velocity}]\n')
    out = folder / f"{config}.h5"
    if build_library(load_config(cfg), out, BuildOptions(jobs=1, cache=False, progress=False)).failed:
        raise RuntimeError(f"humanoid twin benchmark: {config} at {velocity} m/s did not build")
    return out


def _realtime(path: Path) -> tuple[float, float, str]:
    """The only entry of ``path`` executed under the default errors, and the bare twin stepped as
    long: both as multiples of real time; and the entry's key."""
    from skatelib.control.humanoid_native import tick_library
    from skatelib.proving.humanoid.loop import HOLD_S, STEPS_PER_TICK, figures_for, run_entry
    from skatelib.runtime import MotionLibrary
    from skatelib.sim.humanoid.errors import DEFAULT_HUMANOID_PERTURBATION, parse_humanoid_perturbation
    from skatelib.sim.humanoid.plant import HumanoidPlant
    from skatelib.sim.native import twin_library

    lib = MotionLibrary.open(path)
    key = next(iter(lib)).key
    errors = parse_humanoid_perturbation(DEFAULT_HUMANOID_PERTURBATION)
    twin_library(), tick_library()  # the C code built (once per machine, then cached) before the clock
    t0 = time.perf_counter()
    run = run_entry(lib, key, errors)
    loop = float(run.t[-1]) / (time.perf_counter() - t0)
    if run.fell_at is not None:
        raise RuntimeError(f"humanoid twin benchmark: {key} fell ({run.fall_reason})")
    duration = float(lib[key].t[-1]) + HOLD_S
    plant = HumanoidPlant(figures_for(lib, key), errors)
    q0 = plant.f.q0_rad
    ticks = round(duration / (STEPS_PER_TICK * plant.timestep_s))
    t0 = time.perf_counter()
    for _ in range(ticks):
        plant.step(q0, STEPS_PER_TICK)
    bare = duration / (time.perf_counter() - t0)
    return loop, bare, key


def measure() -> list[Measured]:
    with tempfile.TemporaryDirectory() as d:
        skate, skate_bare, _ = _realtime(_library(Path(d), "hrp2_skate", 1.0))
        walk, walk_bare, key = _realtime(_library(Path(d), "hrp2_walk", 0.375))
    note = f"the walk ({key}, 7.6 s): {walk:.1f}x, its bare twin {walk_bare:.0f}x"
    return [Measured(TWIN, skate, skate_bare, note)]
