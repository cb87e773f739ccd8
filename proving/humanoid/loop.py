"""A humanoid entry executed on the twin: the stabilizer (500 Hz) reads the twin's sensors and
sends joint angle targets to its servos (1 kHz physics), with the plan's joint speeds and the
torques its motion needs fed forward (:mod:`skatelib.control.humanoid_torques`), through the entry
and a static hold at its end; what the twin did and what was planned, sampled at every tick."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skatelib.control.humanoid_kinematics import HumanoidKinematics
from skatelib.control.humanoid_reference import HumanoidReference, polygon_margin
from skatelib.control.humanoid_stabilizer import LipStabilizer, StabilizerGains
from skatelib.control.humanoid_torques import PlannedTorques
from skatelib.library import schema
from skatelib.runtime import MotionLibrary
from skatelib.sim.humanoid.errors import HumanoidErrors
from skatelib.sim.humanoid.figures import HumanoidFigures
from skatelib.sim.humanoid.plant import HumanoidPlant, Truth

STEPS_PER_TICK = 2  # 1 ms physics, a 500 Hz stabilizer
HOLD_S = 1.0  # after the entry, the reference holds its end
FALLEN_HEIGHT_M = 0.4  # the waist lower than this: fallen
FALLEN_TILT_RAD = 0.5
LANDING = StabilizerGains()  # the landing rule the verdict's support polygon follows


@dataclass(frozen=True)
class HumanoidRun:
    """A run's samples (one row per stabilizer tick; world frame)."""

    key: str
    t: np.ndarray
    com: np.ndarray  # (N, 3) the twin's COM
    com_ref: np.ndarray  # (N, 3)
    zmp: np.ndarray  # (N, 2) from the soles' contact forces (NaN when airborne)
    zmp_measured: np.ndarray  # (N, 2) the stabilizer's, from the ankle sensors
    zmp_ref: np.ndarray  # (N, 2) the plan's
    zmp_margin: np.ndarray  # (N,) the contact ZMP inside the support polygon [m]: the planned places of
    # the plan's support soles and of any the twin has landed early (the stabilizer's rule on the contact forces)
    zmp_margin_clock: np.ndarray  # (N,) the same inside the polygon of the soles the plan's clock has down
    support: np.ndarray  # (N, 2) the plan's support soles
    sole_pos: np.ndarray  # (N, 2, 3)
    sole_yaw: np.ndarray  # (N, 2)
    sole_fz: np.ndarray  # (N, 2) the floor's normal force on each sole [N]
    torque: np.ndarray  # (N, n)
    torque_limit: np.ndarray  # (n,)
    fell_at: float | None  # the first time the twin had fallen (None: it did not)
    fall_reason: str


def figures_for(lib: MotionLibrary, key: str) -> HumanoidFigures:
    e = lib[key]
    return HumanoidFigures.from_record(lib.humanoid_model, lib.urdf, tuple(e.columns[schema.D_JOINTS]),
                                       np.asarray(e.arrays[schema.D_JOINTS])[0],
                                       np.asarray(e.arrays[schema.D_BASE_POSE])[0])


def _fallen(tr: Truth) -> str:
    if tr.base_pos[2] < FALLEN_HEIGHT_M:
        return f"waist at {tr.base_pos[2]:.2f} m"
    tilt = float(np.arccos(np.clip(tr.base_R[2, 2], -1.0, 1.0)))
    if tilt > FALLEN_TILT_RAD:
        return f"waist tilted {tilt:.2f} rad"
    if tr.floor_touches:
        return f"{', '.join(tr.floor_touches)} on the floor"
    return ""


@dataclass(frozen=True)
class RunOptions:
    """How a run goes besides the plant's errors and the stabilizer's gains.

    Attributes:
        seed: The sensors' noise seed.
        hold_s: How long the robot holds the entry's last posture after it [s].
        feedforward: Feed the servos the plan's joint speeds and torques (else the angles alone).
    """

    seed: int = 0
    hold_s: float = HOLD_S
    feedforward: bool = True


def run_entry(lib: MotionLibrary, key: str, errors: HumanoidErrors | None = None,
              gains: StabilizerGains | None = None, options: RunOptions | None = None) -> HumanoidRun:
    """Execute entry ``key`` on the twin with ``errors`` under the stabilizer (``gains``)."""
    o = options or RunOptions()
    f = figures_for(lib, key)
    plant = HumanoidPlant(f, errors, o.seed)
    ref = HumanoidReference(lib[key], lib.humanoid_model)
    dt = STEPS_PER_TICK * plant.timestep_s
    kin = HumanoidKinematics(lib.urdf, f.joint_names)
    stab = LipStabilizer(kin, dt, gains)
    torques = PlannedTorques(HumanoidKinematics(lib.urdf, f.joint_names), ref)
    n = round((ref.duration_s + o.hold_s) / dt)
    rows: dict[str, list[np.ndarray]] = {k: [] for k in (
        "t", "com", "com_ref", "zmp", "zmp_measured", "zmp_ref", "margin", "margin_clock", "support", "sole_pos",
        "sole_yaw", "sole_fz", "torque")}
    fell_at, reason = None, ""
    for _ in range(n):
        r = plant.readings()
        s = ref.sample(r.t)
        out = stab.tick(s, r.q, np.roll(r.imu_quat_wxyz, -1), r.ft_force, r.ft_torque)
        qd, tau = torques.sample(r.t)
        if o.feedforward:
            plant.step(out.q_target, STEPS_PER_TICK, qd, tau)
        else:
            plant.step(out.q_target, STEPS_PER_TICK)
        tr = plant.truth()
        for k, v in (("t", tr.t), ("com", tr.com), ("com_ref", s.com), ("zmp", tr.zmp), ("zmp_measured",
                     out.zmp_measured), ("zmp_ref", s.zmp), ("support", s.support), ("sole_pos", tr.sole_pos),
                     ("sole_yaw", tr.sole_yaw), ("sole_fz", tr.sole_force[:, 2]), ("torque", tr.torque)):
            rows[k].append(np.asarray(v))
        airborne = np.isnan(tr.zmp).any()
        down = s.with_landed(tr.sole_force[:, 2], LANDING.landing_load_N, LANDING.landing_window_m)
        rows["margin"].append(np.asarray(-np.inf if airborne else polygon_margin(down.polygon(), tr.zmp)))
        rows["margin_clock"].append(np.asarray(-np.inf if airborne else polygon_margin(s.polygon(), tr.zmp)))
        reason = _fallen(tr)
        if reason:
            fell_at = tr.t
            break
    a = {k: np.array(v) for k, v in rows.items()}
    return HumanoidRun(key, a["t"], a["com"], a["com_ref"], a["zmp"], a["zmp_measured"], a["zmp_ref"], a["margin"],
                       a["margin_clock"], a["support"], a["sole_pos"], a["sole_yaw"], a["sole_fz"], a["torque"],
                       f.torque_limit_Nm, fell_at, reason)
