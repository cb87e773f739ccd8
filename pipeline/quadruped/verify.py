"""Independent physics checks of a solved push-off trajectory.

Nothing here uses the transcription: each shooting interval is re-integrated with a fine-step
RK4 of the mode dynamics, and friction, slip, joint and torque limits are measured on the
stored arrays. ``skatelib validate`` runs these on every library entry.
"""

from __future__ import annotations

import dataclasses
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from skatelib.library.channels import (
    GROUND,
    I_BOARD_ROLL,
    S_Q,
    S_RPY,
    SWING,
    U_QD,
)
from skatelib.library.margins import friction_margins
from skatelib.pipeline.quadruped.leg_dynamics import rigid_leg_torques
from skatelib.pipeline.quadruped.measures import (
    board_slip,
    defect,
    ground_slip,
    max_torque,
    near_ground_speeds,
    riding_end,
    swing_clearance,
    wheel_loads,
)
from skatelib.pipeline.quadruped.system import SkateSystem

if TYPE_CHECKING:
    from skatelib.pipeline.quadruped.config import QuadrupedConfig
    from skatelib.pipeline.quadruped.pushoff import SolveResult


@dataclass(frozen=True)
class Tolerances:
    """What the physics checks accept. Looser than the TO's own bounds (they hold to ~1e-6), tight
    enough to refuse a terminal shove (board fast, robot slow and falling) or a slipping foot."""

    defect: float = 1e-3
    force_N: float = 1e-3
    slip_m: float = 1e-5
    angle_rad: float = 1e-6
    momentum_speed_rel: float = 0.02
    relative_speed_mps: float = 0.02
    vertical_speed_mps: float = 0.02
    angular_speed_radps: float = 0.05
    clearance_m: float = 1e-4
    near_ground_speed_mps: float = 0.005  # over the limit (the optimizer's bound eases off smoothly)


@dataclass(frozen=True)
class PhysicsReport:
    """Measured margins; negative margins and positive violations are failures.

    Attributes:
        max_defect: Largest state mismatch between knot k+1 and a fine re-integration from knot k.
        min_friction_margin_N: Smallest Coulomb margin mu f_n - |f_t| over feet in contact [N]
            (deck frame on the board, world frame on the ground; the exact cone, not a pyramid).
        min_normal_force_N: Smallest normal force over feet in contact [N].
        max_swing_force_N: Largest |force| on a swinging foot [N].
        min_push_propulsion_N: Smallest forward (board heading) ground force on the planted push foot [N].
        max_ground_slip_m: Largest motion of the pushing foot while on the ground [m].
        max_board_slip_m: Largest distance of a foot from its deck point [m].
        min_swing_clearance_m: Lowest point of the swinging push foot above the ground, or above the
            deck top where it is over the deck [m].
        max_joint_limit_violation_rad: Largest joint-angle excursion past a limit [rad].
        max_torque_Nm: Largest quasi-static joint torque [N m] (limit: ``torque_limit_Nm``).
        max_torque_rigid_legs_Nm: Largest joint torque with the legs' own mass, by pinocchio inverse
            dynamics of the whole URDF (:mod:`skatelib.pipeline.quadruped.leg_dynamics`) [N m].
        max_joint_velocity_radps: Largest joint speed [rad/s].
        max_board_roll_rad: Largest |deck roll| [rad].
        final_board_speed_mps: Board speed along its heading at the end [m/s].
        final_robot_speed_mps: Robot COM speed along the heading at the end [m/s].
        momentum_speed_mps: (m_R v_R + m_B v_B) / (m_R + m_B) along the heading at the end: the
            speed both ride at once the feet hold on the deck [m/s].
        momentum_speed_error: Relative error of the momentum speed against the label [-].
        final_relative_speed_mps: |robot COM horizontal velocity - board velocity| at the end [m/s].
        final_vertical_speed_mps: |vertical COM speed| at the end [m/s].
        final_angular_speed_radps: Largest |body angular velocity| component at the end [rad/s].
        min_wheel_load_N: Least load the lighter side's wheels carry (below zero a wheel lifts) [N].
        max_near_ground_speed_mps: The push foot's largest speed over the ground within the
            near-ground height (``[contact]``) [m/s].
        max_near_ground_descent_mps: Its largest descent speed there [m/s].
        final_push_foot_height_m: The push foot's height above the ground at the end [m].
    """

    max_defect: float
    min_friction_margin_N: float
    min_normal_force_N: float
    max_swing_force_N: float
    min_push_propulsion_N: float
    max_ground_slip_m: float
    max_board_slip_m: float
    min_swing_clearance_m: float
    max_joint_limit_violation_rad: float
    max_torque_Nm: float
    max_torque_rigid_legs_Nm: float
    max_joint_velocity_radps: float
    max_board_roll_rad: float
    final_board_speed_mps: float
    final_robot_speed_mps: float
    momentum_speed_mps: float
    momentum_speed_error: float
    final_relative_speed_mps: float
    final_vertical_speed_mps: float
    final_angular_speed_radps: float
    min_wheel_load_N: float
    max_near_ground_speed_mps: float
    max_near_ground_descent_mps: float
    final_push_foot_height_m: float

    def as_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in asdict(self).items()}

    def failures(self, system: SkateSystem, tol: Tolerances = Tolerances()) -> list[str]:
        """Human-readable list of the checks that fail; empty when the trajectory is valid."""
        checks = [
            (self.max_defect > tol.defect, f"dynamics defect {self.max_defect:.2e} > {tol.defect:.0e}"),
            (self.min_friction_margin_N < -tol.force_N,
             f"outside the Coulomb cone by {-self.min_friction_margin_N:.3g} N"),
            (self.min_normal_force_N < -tol.force_N, f"pulling normal force {self.min_normal_force_N:.3g} N"),
            (self.max_swing_force_N > tol.force_N, f"force {self.max_swing_force_N:.3g} N on a swinging foot"),
            (self.min_push_propulsion_N < -tol.force_N,
             f"push foot brakes: ground force {self.min_push_propulsion_N:.3g} N along the heading"),
            (self.max_ground_slip_m > tol.slip_m, f"push foot slides {self.max_ground_slip_m:.2e} m on the ground"),
            (self.max_board_slip_m > tol.slip_m, f"foot leaves its deck point by {self.max_board_slip_m:.2e} m"),
            (self.min_swing_clearance_m < -tol.clearance_m,
             f"swinging foot {-self.min_swing_clearance_m:.3g} m into the ground or deck"),
            (self.max_joint_limit_violation_rad > tol.angle_rad,
             f"joint limit exceeded by {self.max_joint_limit_violation_rad:.2e} rad"),
            (self.max_torque_Nm > system.torque_limit_Nm * (1 + 1e-6) + tol.force_N,
             f"torque {self.max_torque_Nm:.3f} N m > {system.torque_limit_Nm} N m"),
            (self.max_torque_rigid_legs_Nm > system.torque_limit_Nm * (1 + 1e-6) + tol.force_N,
             f"torque {self.max_torque_rigid_legs_Nm:.2f} N m > {system.torque_limit_Nm} N m with the legs' mass"),
            (self.max_joint_velocity_radps > system.joint_velocity_limit_radps * (1 + 1e-6),
             f"joint speed {self.max_joint_velocity_radps:.2f} rad/s over the limit"),
            (self.max_board_roll_rad > system.board.roll_limit_rad * (1 + 1e-6),
             f"deck roll {self.max_board_roll_rad:.3f} rad over the limit"),
            (self.momentum_speed_error > tol.momentum_speed_rel,
             f"rides at {self.momentum_speed_mps:.3f} m/s (momentum speed), {100 * self.momentum_speed_error:.1f} % "
             f"off the label"),
            (self.final_relative_speed_mps > tol.relative_speed_mps,
             f"robot and board differ by {self.final_relative_speed_mps:.3f} m/s at the end"),
            (self.final_vertical_speed_mps > tol.vertical_speed_mps,
             f"body moves vertically at {self.final_vertical_speed_mps:.3f} m/s at the end"),
            (self.final_angular_speed_radps > tol.angular_speed_radps,
             f"body turns at {self.final_angular_speed_radps:.3f} rad/s at the end"),
            (self.min_wheel_load_N < -tol.force_N, f"a wheel lifts (its side's load {self.min_wheel_load_N:.2f} N)"),
            (self.final_push_foot_height_m < system.end_push_foot_height_m - tol.clearance_m,
             f"push foot {self.final_push_foot_height_m:.3f} m above the ground at the end "
             f"(at least {system.end_push_foot_height_m})"),
            *self._near_ground(system, tol),
        ]
        return [msg for bad, msg in checks if bad]

    def _near_ground(self, system: SkateSystem, tol: Tolerances) -> list[tuple[bool, str]]:
        c = system.contact
        if c is None:
            return []
        where = f"within {c.near_ground_m * 100:.0f} cm of the ground"
        return [(self.max_near_ground_speed_mps > c.near_ground_speed_mps + tol.near_ground_speed_mps,
                 f"push foot moves {self.max_near_ground_speed_mps:.2f} m/s over the ground {where}"),
                (self.max_near_ground_descent_mps > c.near_ground_descent_mps + tol.near_ground_speed_mps,
                 f"push foot descends at {self.max_near_ground_descent_mps:.2f} m/s {where}")]


@dataclass(frozen=True)
class Trajectory:
    """The arrays of a push-off as a library stores them (``docs/library-format.md``)."""

    t: np.ndarray
    state: np.ndarray
    control: np.ndarray
    contact: np.ndarray
    foot_pos: np.ndarray
    board_pos: np.ndarray

    @classmethod
    def of(cls, x: Any) -> Trajectory:
        """The six arrays of a solve result, a library entry or anything else that has them."""
        arrays = [getattr(x, f.name) for f in dataclasses.fields(cls)]
        if any(a is None for a in arrays):
            raise ValueError(f"{x!r} lacks push-off arrays (a humanoid entry?)")
        return cls(*arrays)


def check_trajectory(system: SkateSystem, traj: Trajectory, target_velocity_mps: float,
                     substeps: int = 40) -> PhysicsReport:
    """Measure a push-off trajectory (library arrays) against the model's physics.

    Args:
        target_velocity_mps: The entry's label: the speed robot and board must ride at together.
        substeps: RK4 steps per knot interval of the fine re-integration.
    """
    t, state, control, contact = traj.t, traj.state, traj.control, traj.contact
    foot_pos, board_pos = traj.foot_pos, traj.board_pos
    margins, normals = friction_margins(state, control, contact, system.friction_mu)
    f = control[:, :12].reshape(len(control), 4, 3)
    swing = contact[:len(control)] == SWING
    p = system.push_index
    yaw = state[:-1, S_RPY][:, 2]
    heading = np.stack([np.cos(yaw), np.sin(yaw)], axis=-1)
    planted = contact[:len(control), p] == GROUND
    propulsion = np.einsum("kj,kj->k", heading, f[:, p, :2])[planted]
    q = state[:, S_Q]
    lim = float(max(np.max(system.robot.lower_limits - q), np.max(q - system.robot.upper_limits), 0.0))
    near = near_ground_speeds(system, t, contact, foot_pos)
    return PhysicsReport(
        max_defect=defect(system, t, state, control, substeps),
        min_friction_margin_N=float(margins.min(initial=np.inf)),
        min_normal_force_N=float(normals.min(initial=np.inf)),
        max_swing_force_N=float(np.linalg.norm(f, axis=-1)[swing].max(initial=0.0)),
        min_push_propulsion_N=float(propulsion.min(initial=np.inf)),
        max_ground_slip_m=ground_slip(contact[:, p], foot_pos[:, p]),
        max_board_slip_m=board_slip(system, state, contact, foot_pos, board_pos),
        min_swing_clearance_m=swing_clearance(system, state, contact, foot_pos, board_pos),
        max_joint_limit_violation_rad=lim, max_torque_Nm=max_torque(system, state, control),
        max_torque_rigid_legs_Nm=float(np.abs(rigid_leg_torques(system, t, state, control, contact, foot_pos)).max()),
        max_joint_velocity_radps=float(np.abs(control[:, U_QD]).max()),
        max_board_roll_rad=float(np.abs(state[:, I_BOARD_ROLL]).max()),
        **riding_end(system, state[-1], target_velocity_mps),
        min_wheel_load_N=wheel_loads(system, state, control, contact),
        max_near_ground_speed_mps=near[0], max_near_ground_descent_mps=near[1],
        final_push_foot_height_m=float(foot_pos[-1, p, 2]),
    )


def judge(config: QuadrupedConfig, r: SolveResult) -> tuple[SolveResult, dict[str, float]]:
    """Run the independent physics checks on a converged result; a result that fails them is
    returned with ``success = False`` and the failed checks as its status."""
    from skatelib.pipeline.quadruped.pushoff import problem_for

    if not r.success:
        return r, {}
    system = problem_for(config, r.n_strides).system
    report = check_trajectory(system, Trajectory.of(r), r.target_velocity_mps)
    failures = report.failures(system)
    if failures:
        r = replace(r, success=False, status=f"Physics_Check_Failed: {'; '.join(failures)}")
    return r, report.as_dict()
