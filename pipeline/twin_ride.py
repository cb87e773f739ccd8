"""``skatelib track LIB --ride ... --plant mujoco``: a chained ride (:mod:`skatelib.control.ride`) on
the physical twin, by the MPC and the whole-body controller of ``skatelib.control`` on the MuJoCo
model of ``skatelib.sim``: the joined entry starts rolling at the first stage's start speed, each
stage is judged by the plant's momentum speed at its end, the run by the twin's verdict."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def twin_ride(path: Path, stages: list[tuple[float, float]], perturb: str, mpc: Any, settings: Any,
              outputs: tuple[bool, Path | None] = (False, None)) -> Any:
    """Ride ``stages`` on the twin with ``perturb``'s errors; a :class:`skatelib.control.ride.RideResult`
    whose ``run`` is the twin's verdict. ``outputs``: whether to keep the run as an entry (for a
    recording), and a video to render it to (MuJoCo's offscreen renderer)."""
    keep, video = outputs
    from skatelib.control.params import SkateParams
    from skatelib.control.ride import RideResult, judge_stages, plan_ride
    from skatelib.control.settings import ClosedLoop
    from skatelib.control.twin_feedback import Sensors
    from skatelib.control.twin_loop import TwinLoop, TwinLoopSettings, entry_ride
    from skatelib.control.twin_verdict import twin_result
    from skatelib.pipeline.twin_track import _check, _plant
    from threadpoolctl import threadpool_limits

    lib = _check(path, perturb)
    plan = plan_ride(lib, stages)
    nominal = SkateParams.from_library(lib)
    plant, errors = _plant(lib, perturb, nominal.mu)
    loop = ClosedLoop(nominal, nominal, mpc=mpc, settings=settings)
    from skatelib.control.kinematics import LegKinematics

    radius = LegKinematics.from_library(lib).foot_radius_m
    twin = TwinLoop(lib, entry_ride(lib, plan.entry, loop, radius), loop, plant,
                    TwinLoopSettings(sensors=Sensors(errors.noise_std, errors.delay_s)), keep=keep or video is not None)
    with threadpool_limits(limits=1, user_api="blas"):
        run = twin.ride()
    result = twin_result(plan.key, stages[-1][1], run)
    kept = run.record.as_entry(plan.key, stages[-1][1]) if keep and len(run.record.forces) > 1 else None
    if video is not None:
        from skatelib.sim.video import write_run

        write_run(plant.m, run.qpos, video, fps=1.0 / twin.dt)
    return RideResult(judge_stages(plan, run.measures.stage_speeds_mps), result, kept, plan.entry)
