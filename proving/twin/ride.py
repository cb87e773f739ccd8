"""``skatelib track LIB --ride ... --plant mujoco``: a chained ride (:mod:`skatelib.proving.ride`) on
the physical twin, by the MPC and the whole-body controller of ``skatelib.control`` on the MuJoCo
model of ``skatelib.sim``: the joined entry starts rolling at the first stage's start speed, each
stage is judged by the plant's momentum speed at its end, the run by the twin's verdict."""

from __future__ import annotations

from pathlib import Path

from skatelib.control.mpc_config import MpcConfig
from skatelib.control.settings import TrackSettings
from skatelib.proving.ride import RideResult


def twin_ride(path: Path, stages: list[tuple[float, float]], perturb: str, mpc: MpcConfig, settings: TrackSettings,
              outputs: tuple[bool, Path | None] = (False, None)) -> RideResult:
    """Ride ``stages`` on the twin with ``perturb``'s errors; a :class:`skatelib.proving.ride.RideResult`
    whose ``run`` is the twin's verdict. ``outputs``: whether to keep the run as an entry (for a
    recording), and a video to render it to (MuJoCo's offscreen renderer)."""
    from skatelib.proving.ride import judge_stages, plan_ride
    from skatelib.proving.twin.track import check_twin, ride_twin
    from skatelib.proving.twin.verdict import twin_result

    keep, video = outputs
    lib = check_twin(path, perturb)
    plan = plan_ride(lib, stages)
    run, plant = ride_twin(lib, plan.entry, perturb, (mpc, settings), keep=keep or video is not None)
    target_velocity_mps = stages[-1][1]
    kept = run.record.as_entry(plan.key, target_velocity_mps) if keep and len(run.record.forces) > 1 else None
    verdict = twin_result(plan.key, target_velocity_mps, run)
    if video is not None:
        from skatelib.proving.twin.footage import film_run

        labels = tuple(zip(plan.ends, (v for _, v in plan.stages), strict=True))
        film_run(lib, plan.entry, (run, plant.m), verdict, (perturb, settings.transfer_s, labels), video)
    return RideResult(judge_stages(plan, run.measures.stage_speeds_mps), verdict, kept, plan.entry)
