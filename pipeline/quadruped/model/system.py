"""The robot-plus-board system of one build: robot description, single rigid body, board and
nominal stance, all derived from a validated config."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.channels import LEGS
from skatelib.library.errors import ConfigError, ModelError
from skatelib.pipeline.ocp.rotations import rpy_to_matrix
from skatelib.pipeline.quadruped.config import ContactConfig, QuadrupedConfig
from skatelib.pipeline.quadruped.model.board import BoardModel
from skatelib.pipeline.quadruped.model.ik import DampedNewton
from skatelib.pipeline.quadruped.model.riding import riding_pose
from skatelib.pipeline.quadruped.model.robot import Quadruped, SingleRigidBody


@dataclass(frozen=True)
class Stance:
    """Nominal configuration on the board at rest.

    Attributes:
        q_board: Joint angles with all four feet on the deck (four-leg balancing) [rad].
        q_push: Joint angles with the push foot on the ground beside the deck [rad].
        cr: (2, 4) contact points x, y of the feet in the board frame (Eq. 8) [m].
        trunk_height_m: Trunk origin height above the ground [m].
        push_foot_board_xy: Push foot x, y in the board frame when on the ground [m].
        q_ride: Joint angles riding: three feet on the deck, the push foot lifted beside it at the
            middle of the end's height band (where every entry ends, within ``[terminal]``'s
            tolerances, and every transition from riding starts) [rad].
        ride_trunk: Trunk origin x, y in the board frame [m] and its roll, pitch [rad] riding
            (:mod:`.riding`).
    """

    q_board: np.ndarray
    q_push: np.ndarray
    cr: np.ndarray
    trunk_height_m: float
    push_foot_board_xy: np.ndarray
    q_ride: np.ndarray
    ride_trunk: np.ndarray


END_BAND_M = 0.02  # the push foot ends at most this far above its least end height



def robot_of(cfg: QuadrupedConfig) -> Quadruped:
    """The config's robot from its URDF.

    Raises:
        ConfigError: Naming the config and ``[robot] urdf``: a URDF pinocchio cannot read, or one
            without the config's joints, feet or three-joint legs.
    """
    try:
        return Quadruped(cfg.urdf_path, cfg.robot.joint_names, cfg.robot.foot_frames)
    except ModelError as e:
        raise ConfigError(cfg.path, "robot.urdf", str(e)) from e

@dataclass(frozen=True)
class SkateSystem:
    """Everything the dynamics, the TO and the checks need to know about robot and board."""

    robot: Quadruped
    srb: SingleRigidBody
    board: BoardModel
    stance: Stance
    gravity_mps2: float
    foot_radius_m: float
    friction_mu: float
    torque_limit_Nm: float
    joint_velocity_limit_radps: float
    push_leg: str
    extra: dict[str, float] = field(default_factory=dict)
    contact: ContactConfig | None = None  # how gently the push foot meets the ground (the checks' limits)
    end_push_foot_height_m: float = 0.0  # the push foot's least height at the end
    joint_limit_margin_rad: float = 0.0  # how far the plan's joint angles stay inside their limits

    @property
    def push_index(self) -> int:
        return LEGS.index(self.push_leg)

    def drive(self, from_velocity_mps: float, target_velocity_mps: float, duration_s: float) -> float:
        """Which way the planted push foot drives robot and board in an entry from
        ``from_velocity_mps`` to ``target_velocity_mps`` [m/s] lasting ``duration_s``: +1 (pushes
        forward) when rolling friction alone (as the plan has it) would end slower than the target,
        -1 (brakes) when it would end faster. A slow-down smaller than what the coast takes pushes a
        little; a start-up always pushes."""
        coast = self.board.rolling_friction_N / (self.srb.mass_kg + self.board.mass_kg) * duration_s
        return 1.0 if target_velocity_mps >= from_velocity_mps - coast else -1.0

    @property
    def riding_com_m(self) -> np.ndarray:
        """The riding stance's centre of mass in the board frame (origin on the deck top) [m]."""
        x, y, roll, pitch = self.stance.ride_trunk
        trunk = np.array([x, y, self.stance.trunk_height_m - self.board.deck_height_m])
        return trunk + np.asarray(rpy_to_matrix(np.array([roll, pitch, 0.0]))) @ self.srb.com_offset_m

    def stiff_linear_part(self, nx: int) -> np.ndarray:
        """``L`` with the deck's roll spring-damper (Eq. 6-7) on rows 26-27, zero elsewhere."""
        L = np.zeros((nx, nx))
        b = self.board
        L[26, 27] = 1.0
        # the trucks' and the deck weight's torque at small rolls (the rest is in the nonlinear part)
        upright = b.roll_stiffness_Nm_per_rad - b.deck_mass_kg * b.gravity_mps2 * b.roll_axis_depth_m
        L[27, 26] = -upright / b.roll_inertia_kgm2
        L[27, 27] = -b.roll_damping_Nms_per_rad / b.roll_inertia_kgm2
        return L

    @staticmethod
    def from_config(cfg: QuadrupedConfig) -> SkateSystem:
        """Load the URDF, solve the nominal stance, compute the SRB and the board model."""
        robot = robot_of(cfg)
        st = cfg.stance
        r = cfg.robot.foot_radius_m
        xs = (st.foot_x_front_m, st.foot_x_front_m, st.foot_x_rear_m, st.foot_x_rear_m)
        ys = (st.foot_y_m, -st.foot_y_m, st.foot_y_m, -st.foot_y_m)
        cr = np.array([xs, ys], dtype=float)
        h = st.base_height_above_deck_m
        board_targets = np.array([[x - st.base_x_offset_m, y, -h + r] for x, y in zip(xs, ys, strict=True)])
        q_board = solve_leg_ik(robot, board_targets)
        push = LEGS.index(cfg.schedule.push_leg)
        side = 1.0 if ys[push] > 0 else -1.0
        push_xy = np.array([xs[push], side * st.push_foot_y_m])
        push_targets = board_targets.copy()
        push_targets[push] = [push_xy[0] - st.base_x_offset_m, push_xy[1], -h - cfg.board.deck_height_m + r]
        q_push = solve_leg_ik(robot, push_targets, q0=q_board)
        srb = robot.single_rigid_body(q_board)
        ride_targets = push_targets.copy()
        ride_targets[push, 2] += cfg.terminal.push_foot_height_m + END_BAND_M / 2
        ride_trunk, q_ride = riding_pose(robot, ride_targets, srb.com_offset_m, push, q_board,
                                         (st.ride_load_fraction, cfg.optimization.joint_limit_margin_rad))
        board = BoardModel.from_config(cfg.board, srb.mass_kg, cfg.robot.gravity_mps2, st.foot_y_m,
                                       cfg.optimization.rolling_friction_factor)
        stance = Stance(q_board=q_board, q_push=q_push, cr=cr,
                        trunk_height_m=h + cfg.board.deck_height_m, push_foot_board_xy=push_xy, q_ride=q_ride,
                        ride_trunk=ride_trunk + np.array([st.base_x_offset_m, 0.0, 0.0, 0.0]))
        return SkateSystem(
            robot=robot, srb=srb, board=board, stance=stance, gravity_mps2=cfg.robot.gravity_mps2,
            foot_radius_m=r, friction_mu=cfg.robot.friction_mu, torque_limit_Nm=cfg.robot.torque_limit_Nm,
            joint_velocity_limit_radps=cfg.robot.joint_velocity_limit_radps, push_leg=cfg.schedule.push_leg,
            contact=cfg.contact, end_push_foot_height_m=cfg.terminal.push_foot_height_m,
            joint_limit_margin_rad=cfg.optimization.joint_limit_margin_rad,
        )


def solve_leg_ik(robot: Quadruped, targets: np.ndarray, q0: np.ndarray | None = None,
                 tol: float = 1e-12, max_iter: int = 100) -> np.ndarray:
    """Joint angles placing each foot centre at ``targets`` (4 x 3, trunk frame) by damped Newton.

    Raises:
        ModelError: When a target is out of reach or the solution violates joint limits.
    """
    q_sym = ca.SX.sym("q", 12)
    p: Any = ca.vec(robot.foot_positions_body(q_sym))
    fn = ca.Function("ik", [q_sym], [p, ca.jacobian(p, q_sym)])
    q_init = np.tile([0.0, -0.8, 1.6], 4) if q0 is None else q0
    q, residual = DampedNewton(1e-9, tol, max_iter).solve(fn, targets, q_init)
    if residual >= tol:
        raise ModelError(f"stance IK did not converge (residual {residual:.2e} m): "
                         "a foot target is out of reach; check [stance] heights and foot positions")
    lo, hi = robot.lower_limits, robot.upper_limits
    bad = np.flatnonzero((q < lo - 1e-9) | (q > hi + 1e-9))
    if bad.size:
        raise ModelError(f"stance IK solution violates the limits of joints {[robot.joint_names[i] for i in bad]}; "
                         "adjust the [stance] table")
    return q
