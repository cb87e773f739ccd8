"""A humanoid entry executed on the twin: the stabilizer (500 Hz) reads the twin's sensors and
sends joint angle targets to its servos (1 kHz physics), with the plan's joint speeds and the
torques its motion needs fed forward (:mod:`skatelib.control.humanoid_torques`), through the entry
and a static hold at its end; what the twin did and what was planned, sampled at every tick (a
skate's also its deck's speed and its soles' places on the deck)."""

from __future__ import annotations

import json
from dataclasses import dataclass, replace

import numpy as np
from skatelib.control.humanoid_kinematics import HumanoidKinematics
from skatelib.control.humanoid_reference import HumanoidReference, ReferenceSample, polygon_margin
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
    # A skate's: the surface under each sole (N, 2) (0: the ground; the deck's height), each
    # sole's place (N, 2, 3) and yaw (N, 2) in the deck's frame, the deck's velocity (N, 3), and
    # when the push ends [s] (None: a walk).
    sole_plane: np.ndarray | None = None
    sole_deck_pos: np.ndarray | None = None
    sole_deck_yaw: np.ndarray | None = None
    deck_v: np.ndarray | None = None
    push_end_s: float | None = None
    # Where the plan's board sole is from the twin's (N, 2): what a skate's COM and ZMP above were
    # moved by (zeros for a walk). With RunOptions.keep_poses: the twin's configurations (N, nq) in
    # its MuJoCo model's layout, and the plan's (N, nq) in the same layout (its waist, joints, the
    # twin's board), for a recording or a video; ``layout``: where in them the waist's free joint,
    # the joints (in the library's order) and the board's deck (-1: none) are.
    board_shift: np.ndarray | None = None
    qpos: np.ndarray | None = None
    qpos_plan: np.ndarray | None = None
    layout: tuple[int, np.ndarray, int] | None = None


def figures_for(lib: MotionLibrary, key: str) -> HumanoidFigures:
    e = lib[key]
    feet = np.asarray(e.arrays[schema.D_FEET])
    return HumanoidFigures.from_record(lib.humanoid_model, lib.urdf, tuple(e.columns[schema.D_JOINTS]),
                                       np.asarray(e.arrays[schema.D_JOINTS])[0],
                                       np.asarray(e.arrays[schema.D_BASE_POSE])[0], feet[0, 0:2])


def push_end_s(lib: MotionLibrary, key: str) -> float | None:
    """A skate entry's push duration [s] (its plan's first step; None: a walk)."""
    if lib.humanoid_model.board is None:
        return None
    return float(json.loads(str(lib[key].attrs[schema.A_PLAN]))[0]["duration_s"])


def _fallen(tr: Truth) -> str:
    if tr.base_pos[2] < FALLEN_HEIGHT_M:
        return f"waist at {tr.base_pos[2]:.2f} m"
    tilt = float(np.arccos(np.clip(tr.base_R[2, 2], -1.0, 1.0)))
    if tilt > FALLEN_TILT_RAD:
        return f"waist tilted {tilt:.2f} rad"
    if tr.floor_touches:
        return f"{', '.join(tr.floor_touches)} on the floor"
    return ""


def _deck_rows(rows: dict[str, list[np.ndarray]], tr: Truth) -> None:
    """A skate's deck samples: the soles' places and yaws on the deck, the deck's velocity."""
    if tr.deck_R is not None and tr.deck_v is not None:
        rows["deck_pos"].append(tr.on_deck(tr.sole_pos))
        rows["deck_yaw"].append(tr.sole_yaw - np.arctan2(tr.deck_R[1, 0], tr.deck_R[0, 0]))
        rows["deck_v"].append(tr.deck_v)


def _margins(s: ReferenceSample, tr: Truth, zmp: np.ndarray, shift: np.ndarray | None) -> tuple[float, float]:
    """The contact ZMP's distance inside the polygon of the soles down (the plan's, and any landed
    early) and inside that of the plan's clock alone (-inf: airborne); a skate's (``shift``: the
    plan's board sole from the twin's) with its soles where they are, moved by ``shift``."""
    if np.isnan(tr.zmp).any():
        return -np.inf, -np.inf
    down = s.with_landed(tr.sole_force[:, 2], LANDING.landing_load_N, LANDING.landing_window_m)
    clock = s
    if shift is not None:
        placed = np.column_stack([tr.sole_pos[:, 0:2] + shift, s.soles[:, 2]])
        down, clock = replace(down, soles=placed, sole_yaw=tr.sole_yaw), replace(s, soles=placed,
                                                                                 sole_yaw=tr.sole_yaw)
    margin = polygon_margin(down.polygon(), zmp)
    # the clock's soles are the same soles, most ticks the same ones down: the same polygon
    return margin, margin if np.array_equal(down.support, clock.support) else polygon_margin(clock.polygon(), zmp)


@dataclass(frozen=True)
class RunOptions:
    """How a run goes besides the plant's errors and the stabilizer's gains.

    Attributes:
        seed: The sensors' noise seed.
        hold_s: How long the robot holds the entry's last posture after it [s].
        feedforward: Feed the servos the plan's joint speeds and torques (else the angles alone).
        keep_poses: Keep the twin's and the plan's configurations at every tick (a recording, a video).
    """

    seed: int = 0
    hold_s: float = HOLD_S
    feedforward: bool = True
    keep_poses: bool = False


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
    skate = f.board is not None
    rows: dict[str, list[np.ndarray]] = {k: [] for k in (
        "t", "com", "com_ref", "zmp", "zmp_measured", "zmp_ref", "margin", "margin_clock", "support", "sole_pos",
        "sole_yaw", "sole_fz", "torque", "plane", "deck_pos", "deck_yaw", "deck_v", "shift", "qpos", "qpos_plan")}
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
        tr = plant.truth(s.ground_z)
        # On a board the robot is where its board has rolled to: a skate's COM and ZMP are taken
        # relative to the board sole (the plan's and the twin's), its support polygon where the
        # soles are (the plan's slide has no rolling resistance; the twin's board falls behind it).
        shift = s.soles[0, 0:2] - tr.sole_pos[0, 0:2] if skate else np.zeros(2)
        com = tr.com + np.append(shift, 0.0)
        zmp = tr.zmp + shift
        for k, v in (("t", tr.t), ("com", com), ("com_ref", s.com), ("zmp", zmp), ("zmp_measured",
                     out.zmp_measured), ("zmp_ref", s.zmp), ("support", s.support), ("sole_pos", tr.sole_pos),
                     ("sole_yaw", tr.sole_yaw), ("sole_fz", tr.sole_force[:, 2]), ("torque", tr.torque),
                     ("plane", s.sole_plane)):
            rows[k].append(np.asarray(v))
        _deck_rows(rows, tr)
        rows["shift"].append(shift)
        if o.keep_poses:
            rows["qpos"].append(plant.d.qpos.copy())
            rows["qpos_plan"].append(plant.pose_qpos(s.base_pos, np.roll(s.base_quat_xyzw, 1), s.q))
        margin, margin_clock = _margins(s, tr, zmp, shift if skate else None)
        rows["margin"].append(np.asarray(margin))
        rows["margin_clock"].append(np.asarray(margin_clock))
        reason = _fallen(tr)
        if reason:
            fell_at = tr.t
            break
    a = {k: np.array(v) for k, v in rows.items()}
    return HumanoidRun(key, a["t"], a["com"], a["com_ref"], a["zmp"], a["zmp_measured"], a["zmp_ref"], a["margin"],
                       a["margin_clock"], a["support"], a["sole_pos"], a["sole_yaw"], a["sole_fz"], a["torque"],
                       f.torque_limit_Nm, fell_at, reason, sole_plane=a["plane"] if skate else None,
                       sole_deck_pos=a["deck_pos"] if skate else None, sole_deck_yaw=a["deck_yaw"] if skate else None,
                       deck_v=a["deck_v"] if skate else None, push_end_s=push_end_s(lib, key),
                       board_shift=a["shift"], qpos=a["qpos"] if o.keep_poses else None,
                       qpos_plan=a["qpos_plan"] if o.keep_poses else None,
                       layout=plant.layout() if o.keep_poses else None)
