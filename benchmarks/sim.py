"""The physical twin's speed: the bare simulation (robot standing on the board, no controller)
stepped at its 1 ms timestep, as a multiple of real time; beside it the same with the standing
controller in Python in the loop."""

from __future__ import annotations

import time

from benchmarks.figures import Figure, Measured

SIM = Figure("twin-realtime", "the twin stepped bare at 1 ms (robot on the board)", "x", 20.0, "real time",
             at_least=True)
FIGURES = (SIM,)


def measure(seconds: float = 5.0) -> list[Measured]:
    import mujoco
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.quadruped.config import QuadrupedConfig
    from skatelib.pipeline.twin import twin_figures
    from skatelib.sim.scene import twin_model
    from skatelib.sim.stand import StandController

    f = twin_figures(load_config(None, QuadrupedConfig))
    m = twin_model(f)
    d = mujoco.MjData(m)
    steps = round(seconds / m.opt.timestep)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    t0 = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(m, d)
    bare = seconds / (time.perf_counter() - t0)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    ctl = StandController(m, f.robot_mass_kg, f.gravity_mps2)
    t0 = time.perf_counter()
    for _ in range(steps):
        ctl(d)
        mujoco.mj_step(m, d)
    controlled = seconds / (time.perf_counter() - t0)
    return [Measured(SIM, bare, 1.0, f"with the standing controller in Python: {controlled:.1f}x")]
