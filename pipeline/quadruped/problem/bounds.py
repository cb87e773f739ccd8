"""Variable bounds of the push-off NLP (Sec. IV-B) as terms that name the channels they bound.

The knot vector (:mod:`skatelib.pipeline.quadruped.problem.knots`) is the transcription state followed by
the 24 controls; ``columns`` turns channel names into its columns. The NLP's bounds are the
intersection of these boxes (:func:`skatelib.pipeline.ocp.terms.variable_bounds`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skatelib.library.channels import BOARD, SWING
from skatelib.pipeline.ocp.terms import INF, BoundTerm, Box
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.model.schedule import KnotSchedule
from skatelib.pipeline.quadruped.model.system import SkateSystem
from skatelib.pipeline.quadruped.problem.knots import NXA, columns

LAST = slice(-1, None)
BEFORE_LAST = slice(-2, -1)
FORCES = columns("f_FL_x", "f_RR_z")
JOINT_SPEEDS = columns("qd_FL_abad", "qd_RR_knee")
CONTROLS = columns("f_FL_x", "qd_RR_knee")


@dataclass(frozen=True)
class SwingForces:
    """A swinging foot carries no force: its three force channels are fixed at zero."""

    schedule: KnotSchedule
    name: str = "swing_forces"

    @property
    def columns(self) -> slice:
        return FORCES

    def bounds(self, n_knots: int) -> tuple[np.ndarray, np.ndarray]:
        swing = np.repeat(self.schedule.contact[:n_knots] == SWING, 3, axis=1)
        return np.where(swing, 0.0, -INF), np.where(swing, 0.0, INF)


@dataclass(frozen=True)
class DeckSupport:
    """Each foot on the deck pushes down on it with at least ``min_force_N`` (the config's
    ``min_deck_load_fraction`` of the robot's weight; its vertical force: a bound on the variable,
    no constraint row). Without it an optimum may balance the body on the line between two feet
    with the third nearly unloaded: a state the single rigid body holds and a robot with swinging
    legs tips over."""

    schedule: KnotSchedule
    min_force_N: float
    name: str = "deck_support"

    @property
    def columns(self) -> slice:
        return FORCES

    def bounds(self, n_knots: int) -> tuple[np.ndarray, np.ndarray]:
        lo = np.full((n_knots, 12), -INF)
        on_deck = self.schedule.contact[:n_knots] == BOARD
        lo[:, 2::3] = np.where(on_deck, self.min_force_N, -INF)
        lo[-1] = -INF  # the placeholder control of the last knot
        return lo, np.full((n_knots, 12), INF)


def bound_terms(config: QuadrupedConfig, system: SkateSystem, schedule: KnotSchedule,
                x0: np.ndarray) -> list[BoundTerm]:
    """Every bound of the push-off NLP: boxes on the trunk, joints, deck and controls, the initial
    state, and the riding end (Sec. IV-B's last knot, tolerances from ``[terminal]``)."""
    term = config.terminal
    margin = system.joint_limit_margin_rad  # the config's, as the guess has it
    fmax = 4.0 * system.srb.mass_kg * system.gravity_mps2
    qd_max, roll_max = system.joint_velocity_limit_radps, system.board.roll_limit_rad
    z0 = float(x0[columns("base_z")][0])
    return [
        Box("trunk_height", columns("base_z"), 0.05, 1.0),
        Box("trunk_attitude", columns("base_roll", "base_pitch"), -0.6, 0.6),
        Box("joint_limits", columns("q_FL_abad", "q_RR_knee"), system.robot.lower_limits + margin,
            system.robot.upper_limits - margin),
        Box("deck_roll", columns("board_roll"), -roll_max, roll_max),
        Box("force_box", FORCES, -fmax, fmax),
        Box("joint_speed", JOINT_SPEEDS, -qd_max, qd_max),
        SwingForces(schedule),
        DeckSupport(schedule, config.contact.min_deck_load_fraction * system.srb.mass_kg * system.gravity_mps2),
        Box("initial_state", slice(0, NXA), x0, x0, knots=slice(0, 1)),
        Box("placeholder_control", CONTROLS, 0.0, 0.0, knots=LAST),  # u_N enters no term
        Box("end_height", columns("base_z"), z0 - term.height_tol_m, z0 + term.height_tol_m, knots=LAST),
        Box("end_attitude", columns("base_roll", "base_pitch"), -term.attitude_tol_rad, term.attitude_tol_rad,
            knots=LAST),
        Box("end_vertical_speed", columns("base_vz"), -term.vertical_speed_tol_mps, term.vertical_speed_tol_mps,
            knots=LAST),
        Box("end_angular_speed", columns("base_wx", "base_wz"), -term.angular_speed_tol_radps,
            term.angular_speed_tol_radps, knots=LAST),
        Box("end_joints", columns("q_FL_abad", "q_RR_knee"), system.stance.q_ride - term.joint_tol_rad,
            system.stance.q_ride + term.joint_tol_rad, knots=LAST),
        Box("end_joint_speed", JOINT_SPEEDS, -term.joint_velocity_tol_radps, term.joint_velocity_tol_radps,
            knots=BEFORE_LAST),
    ]
