"""A humanoid entry executed on the twin: the stabilizer (500 Hz) reads the twin's sensors and
sends joint angle targets to its servos (1 kHz physics), with the plan's joint speeds and the
torques its motion needs fed forward (:mod:`skatelib.control.humanoid_torques`), through the entry
and a static hold at its end; what the twin did and what was planned, sampled at every tick (a
skate's also its deck's speed and its soles' places on the deck)."""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
from skatelib.control.humanoid_kinematics import HumanoidKinematics
from skatelib.control.humanoid_reference import HumanoidReference, ReferenceSample
from skatelib.control.humanoid_stabilizer import LipStabilizer, StabilizerGains
from skatelib.control.humanoid_torques import PlannedTorques
from skatelib.library import schema
from skatelib.proving.humanoid import support
from skatelib.runtime import MotionLibrary
from skatelib.sim.humanoid.errors import HumanoidErrors
from skatelib.sim.humanoid.figures import HumanoidFigures
from skatelib.sim.humanoid.plant import HumanoidPlant
from skatelib.sim.humanoid.state import DECK_FIELDS, TRUTH_LAYOUT, truth_columns

STEPS_PER_TICK = 2  # 1 ms physics, a 500 Hz stabilizer
HOLD_S = 1.0  # after the entry, the reference holds its end
FALLEN_HEIGHT_M = 0.4  # the waist lower than this: fallen
FALLEN_TILT_RAD = 0.5
COS_FALLEN_TILT = float(np.cos(FALLEN_TILT_RAD))
LANDING = StabilizerGains()  # the landing rule the verdict's support polygon follows
T_AT = TRUTH_LAYOUT["t"][0]  # where a truth row holds the time, the waist's height and its R[2, 2]
BASE_Z, BASE_R22 = TRUTH_LAYOUT["base_pos"][0] + 2, TRUTH_LAYOUT["base_R"][0] + 8


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


def _fallen(row: np.ndarray, plant: HumanoidPlant) -> str:
    """Why the twin has fallen by its :meth:`~HumanoidPlant.truth_row` ``row`` ("": it has not)."""
    z, tilt = float(row[BASE_Z]), float(row[BASE_R22])
    if z < FALLEN_HEIGHT_M:
        return f"waist at {z:.2f} m"
    if tilt < COS_FALLEN_TILT:  # tilted more than FALLEN_TILT_RAD
        return f"waist tilted {float(np.arccos(np.clip(tilt, -1.0, 1.0))):.2f} rad"
    touches = plant.floor_touches(row)
    if touches:
        return f"{', '.join(touches)} on the floor"
    return ""


def _support_margins(plan: dict[str, np.ndarray], twin: dict[str, np.ndarray], zmp: np.ndarray, shift: np.ndarray,
                     skate: bool, size: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Each tick's contact ZMP (``zmp``) distance inside the polygon of the soles down (the plan's,
    and any landed early: the stabilizer's rule on the contact forces) and inside that of the plan's
    clock alone; a skate's with its soles where they are, moved by ``shift`` (the plan's board sole
    from the twin's)."""
    clock = plan["support"]
    landed = ~clock & (plan["soles"][:, :, 2] - plan["sole_plane"] < LANDING.landing_window_m) & (
        twin["sole_force"][:, :, 2] > LANDING.landing_load_N)
    centres, yaw = (twin["sole_pos"][:, :, 0:2] + shift[:, None, :], twin["sole_yaw"]) if skate else (
        plan["soles"][:, :, 0:2], plan["sole_yaw"])
    down = support.margins(centres, yaw, clock | landed, size, zmp)
    at_clock = down.copy()
    moved = landed.any(axis=1)
    if moved.any():
        at_clock[moved] = support.margins(centres[moved], yaw[moved], clock[moved], size, zmp[moved])
    return down, at_clock


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
    stab = LipStabilizer(HumanoidKinematics(lib.urdf, f.joint_names), dt, gains)
    torques = PlannedTorques(HumanoidKinematics(lib.urdf, f.joint_names), ref)
    rows: list[np.ndarray] = []
    samples: list[ReferenceSample] = []
    measured: list[np.ndarray] = []
    poses: list[tuple[np.ndarray, np.ndarray]] = []
    fell_at, reason = None, ""
    for _ in range(round((ref.duration_s + o.hold_s) / dt)):
        r = plant.readings()
        s = ref.sample(r.t)
        out = stab.tick(s, r.q, r.imu_quat_wxyz[XYZW], r.ft_force, r.ft_torque)
        qd, tau = torques.sample(r.t)
        if o.feedforward:
            plant.step(out.q_target, STEPS_PER_TICK, qd, tau)
        else:
            plant.step(out.q_target, STEPS_PER_TICK)
        row = plant.truth_row(s.ground_z)
        rows.append(row)
        samples.append(s)
        measured.append(out.zmp_measured)
        if o.keep_poses:
            poses.append((plant.d.qpos.copy(), plant.pose_qpos(s.base_pos, s.base_quat_xyzw[WXYZ], s.q)))
        reason = _fallen(row, plant)
        if reason:
            fell_at = float(row[T_AT])
            break
    return _run(lib, key, f, (np.array(rows), samples, measured, poses), (fell_at, reason),
                plant.layout() if o.keep_poses else None)


XYZW, WXYZ = np.array([1, 2, 3, 0]), np.array([3, 0, 1, 2])  # a quaternion's components reordered


def _run(lib: MotionLibrary, key: str, f: HumanoidFigures, ticks: tuple[np.ndarray, list, list, list],
         fall: tuple[float | None, str], layout: tuple[int, np.ndarray, int] | None) -> HumanoidRun:
    """The run's arrays from each tick's truth row, reference sample and measured ZMP (and poses);
    when and why it fell."""
    table, samples, measured, poses = ticks
    fell_at, reason = fall
    twin = truth_columns(table, ("t", "com", "zmp", "sole_pos", "sole_yaw", "sole_force", "torque",
                                 *(DECK_FIELDS if f.board is not None else ())))
    plan = {name: np.array([getattr(x, name) for x in samples]) for name in (
        "soles", "sole_yaw", "com", "zmp", "support", "sole_plane")}
    n, skate = len(table), f.board is not None
    # On a board the robot is where its board has rolled to: a skate's COM and ZMP are taken
    # relative to the board sole (the plan's and the twin's), its support polygon where the
    # soles are (the plan's slide has no rolling resistance; the twin's board falls behind it).
    shift = plan["soles"][:, 0, 0:2] - twin["sole_pos"][:, 0, 0:2] if skate else np.zeros((n, 2))
    zmp = twin["zmp"] + shift
    margin, margin_clock = _support_margins(plan, twin, zmp, shift, skate, (lib.humanoid_model.foot_length_m,
                                                                           lib.humanoid_model.foot_width_m))
    deck: dict[str, np.ndarray | None] = {"sole_deck_pos": None, "sole_deck_yaw": None, "deck_v": None}
    if skate:
        R = twin["deck_R"]
        deck = {"sole_deck_pos": np.einsum("nsi,nij->nsj", twin["sole_pos"] - twin["deck_pos"][:, None, :], R),
                "sole_deck_yaw": twin["sole_yaw"] - np.arctan2(R[:, 1, 0], R[:, 0, 0])[:, None],
                "deck_v": twin["deck_v"]}
    return HumanoidRun(key, twin["t"], twin["com"] + np.column_stack([shift, np.zeros(n)]), plan["com"], zmp,
                       np.array(measured), plan["zmp"], margin, margin_clock, plan["support"], twin["sole_pos"],
                       twin["sole_yaw"], twin["sole_force"][:, :, 2], twin["torque"], f.torque_limit_Nm, fell_at,
                       reason, sole_plane=plan["sole_plane"] if skate else None, **deck,
                       push_end_s=push_end_s(lib, key), board_shift=shift,
                       qpos=np.array([q for q, _ in poses]) if layout else None,
                       qpos_plan=np.array([q for _, q in poses]) if layout else None, layout=layout)
