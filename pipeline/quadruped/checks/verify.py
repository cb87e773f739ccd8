"""Independent physics checks of a solved push-off trajectory.

Nothing here uses the transcription: each shooting interval is re-integrated with a fine-step
RK4 of the mode dynamics, and friction, slip, joint and torque limits are measured on the
stored arrays. ``skatelib validate`` runs these on every library entry.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from skatelib.library.channels import (
    GROUND,
    I_BOARD_ROLL,
    S_BOARD_V,
    S_Q,
    S_RPY,
    SWING,
    U_QD,
)
from skatelib.library.margins import friction_margins, momentum_speed
from skatelib.pipeline.quadruped.checks.measures import (
    board_lateral_speed,
    board_slip,
    defect,
    ground_slip,
    max_torque,
    near_ground_speeds,
    riding_end,
    swing_clearance,
    wheel_loads,
)
from skatelib.pipeline.quadruped.checks.report import PhysicsReport
from skatelib.pipeline.quadruped.model.leg_dynamics import rigid_leg_torques
from skatelib.pipeline.quadruped.model.system import SkateSystem

if TYPE_CHECKING:
    from skatelib.pipeline.quadruped.config import QuadrupedConfig
    from skatelib.pipeline.quadruped.problem.pushoff import SolveResult


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
                     substeps: int = 40, from_velocity_mps: float = 0.0) -> PhysicsReport:
    """Measure a push-off or transition trajectory (library arrays) against the model's physics.

    Args:
        target_velocity_mps: The entry's label: the speed robot and board must ride at together.
        substeps: RK4 steps per knot interval of the fine re-integration.
        from_velocity_mps: The speed it starts riding at (0: a start-up from rest); a target slower
            than rolling friction alone would leave makes the planted foot a brake, which must never
            push (``SkateSystem.drive``).
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
    drive = system.drive(from_velocity_mps, target_velocity_mps, float(t[-1] - t[0]))
    propulsion = drive * np.einsum("kj,kj->k", heading, f[:, p, :2])[planted]
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
        start_momentum_speed_mps=float(momentum_speed(state[0], system.srb.mass_kg, system.board.mass_kg)),
        max_board_lateral_speed_mps=board_lateral_speed(state),
        final_board_speed_norm_mps=float(np.linalg.norm(state[-1, S_BOARD_V])),
        from_velocity_mps=from_velocity_mps, braking=drive < 0, stop=target_velocity_mps == 0,
    )


def judge(config: QuadrupedConfig, r: SolveResult) -> tuple[SolveResult, dict[str, float]]:
    """Run the independent physics checks on a converged result; a result that fails them is
    returned with ``success = False`` and the failed checks as its status."""
    from skatelib.pipeline.quadruped.problem.pushoff import problem_for

    if not r.success:
        return r, {}
    system = problem_for(config, r.n_strides).system
    report = check_trajectory(system, Trajectory.of(r), r.target_velocity_mps, from_velocity_mps=r.from_velocity_mps)
    failures = report.failures(system)
    if failures:
        r = replace(r, success=False, status=f"Physics_Check_Failed: {'; '.join(failures)}")
    return r, report.as_dict()
