"""What the independent physics checks of :mod:`skatelib.pipeline.quadruped.checks.verify` measured on one
trajectory (:class:`PhysicsReport`) and what they accept (:class:`Tolerances`)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from skatelib.pipeline.quadruped.model.system import SkateSystem


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
    lateral_speed_mps: float = 0.02  # the board across its heading: its wheels roll, they do not slide
    stop_speed_mps: float = 0.02  # a stop's board at its end, in every direction


@dataclass(frozen=True)
class PhysicsReport:
    """Measured margins; negative margins and positive violations are failures.

    Attributes:
        max_defect: Largest state mismatch between knot k+1 and a fine re-integration from knot k.
        min_friction_margin_N: Smallest Coulomb margin mu f_n - |f_t| over feet in contact [N]
            (deck frame on the board, world frame on the ground; the exact cone, not a pyramid).
        min_normal_force_N: Smallest normal force over feet in contact [N].
        max_swing_force_N: Largest |force| on a swinging foot [N].
        min_push_propulsion_N: Smallest ground force on the planted push foot along the way it drives
            the board: forward (along the heading) in a start-up or speed-up, backward in a
            slow-down or stop [N].
        max_ground_slip_m: Largest motion of the pushing foot while on the ground [m].
        max_board_slip_m: Largest distance of a foot from its deck point [m].
        min_swing_clearance_m: Lowest point of the swinging push foot above the ground, or above the
            deck top where it is over the deck [m].
        max_joint_limit_violation_rad: Largest joint-angle excursion past a limit [rad].
        max_torque_Nm: Largest quasi-static joint torque [N m] (limit: ``torque_limit_Nm``).
        max_torque_rigid_legs_Nm: Largest joint torque with the legs' own mass, by pinocchio inverse
            dynamics of the whole URDF (:mod:`skatelib.pipeline.quadruped.model.leg_dynamics`) [N m].
        max_joint_velocity_radps: Largest joint speed [rad/s].
        max_board_roll_rad: Largest |deck roll| [rad].
        final_board_speed_mps: Board speed along its heading at the end [m/s].
        final_robot_speed_mps: Robot COM speed along the heading at the end [m/s].
        momentum_speed_mps: (m_R v_R + m_B v_B) / (m_R + m_B) along the heading at the end: the
            speed both ride at once the feet hold on the deck [m/s].
        momentum_speed_error: Error of the momentum speed against the label, relative to the label
            (for a stop, to 1 m/s) [-].
        start_momentum_speed_mps: The momentum speed at the first knot: the speed the entry starts
            riding at (0 for a start-up) [m/s].
        final_relative_speed_mps: |robot COM horizontal velocity - board velocity| at the end [m/s].
        final_vertical_speed_mps: |vertical COM speed| at the end [m/s].
        final_angular_speed_radps: Largest |body angular velocity| component at the end [rad/s].
        min_wheel_load_N: Least load the lighter side's wheels carry (below zero a wheel lifts) [N].
        max_near_ground_speed_mps: The push foot's largest speed over the ground within the
            near-ground height (``[contact]``) [m/s].
        max_near_ground_descent_mps: Its largest descent speed there [m/s].
        final_push_foot_height_m: The push foot's height above the ground at the end [m].
        max_board_lateral_speed_mps: The board's largest velocity across its heading at a knot:
            its wheels roll along the heading and cannot slide sideways [m/s].
        final_board_speed_norm_mps: The board's speed at the end in any direction [m/s] (a stop
            ends at rest).
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
    start_momentum_speed_mps: float = 0.0
    max_board_lateral_speed_mps: float = 0.0
    final_board_speed_norm_mps: float = 0.0
    from_velocity_mps: float = 0.0
    braking: bool = False  # a slow-down or stop: the planted foot brakes
    stop: bool = False  # a stop (label 0): the momentum speed's error is the speed left [m/s]

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
            (self.min_push_propulsion_N < -tol.force_N, self._drive_failure()),
            (abs(self.start_momentum_speed_mps - self.from_velocity_mps)
             > tol.momentum_speed_rel * (self.from_velocity_mps or 1.0),
             f"starts riding at {self.start_momentum_speed_mps:.3f} m/s, not {self.from_velocity_mps:.3f}"),
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
            (self.momentum_speed_error > tol.momentum_speed_rel, self._speed_failure(tol)),
            (self.final_relative_speed_mps > tol.relative_speed_mps,
             f"robot and board differ by {self.final_relative_speed_mps:.3f} m/s at the end"),
            (self.final_vertical_speed_mps > tol.vertical_speed_mps,
             f"body moves vertically at {self.final_vertical_speed_mps:.3f} m/s at the end"),
            (self.final_angular_speed_radps > tol.angular_speed_radps,
             f"body turns at {self.final_angular_speed_radps:.3f} rad/s at the end"),
            (self.min_wheel_load_N < -tol.force_N, f"a wheel lifts (its side's load {self.min_wheel_load_N:.2f} N)"),
            (self.max_board_lateral_speed_mps > tol.lateral_speed_mps,
             f"the board slides sideways at {self.max_board_lateral_speed_mps:.3f} m/s across its heading "
             f"(wheels roll; at most {tol.lateral_speed_mps})"),
            (self.stop and self.final_board_speed_norm_mps > tol.stop_speed_mps,
             f"a stop ends with the board moving {self.final_board_speed_norm_mps:.3f} m/s "
             f"(at most {tol.stop_speed_mps} in every direction)"),
            (self.final_push_foot_height_m < system.end_push_foot_height_m - tol.clearance_m,
             f"push foot {self.final_push_foot_height_m:.3f} m above the ground at the end "
             f"(at least {system.end_push_foot_height_m})"),
            *self._near_ground(system, tol),
        ]
        return [msg for bad, msg in checks if bad]

    def _speed_failure(self, tol: Tolerances) -> str:
        if self.stop:
            return (f"still rides at {self.momentum_speed_mps:.3f} m/s (momentum speed); a stop ends below "
                    f"{tol.momentum_speed_rel:.3f} m/s")
        return (f"rides at {self.momentum_speed_mps:.3f} m/s (momentum speed), {100 * self.momentum_speed_error:.1f} % "
                "off the label")

    def _drive_failure(self) -> str:
        if self.braking:
            return f"braking foot pushes: ground force {-self.min_push_propulsion_N:.3g} N forward"
        return f"push foot brakes: ground force {self.min_push_propulsion_N:.3g} N along the heading"

    def _near_ground(self, system: SkateSystem, tol: Tolerances) -> list[tuple[bool, str]]:
        c = system.contact
        if c is None:
            return []
        where = f"within {c.near_ground_m * 100:.0f} cm of the ground"
        return [(self.max_near_ground_speed_mps > c.near_ground_speed_mps + tol.near_ground_speed_mps,
                 f"push foot moves {self.max_near_ground_speed_mps:.2f} m/s over the ground {where}"),
                (self.max_near_ground_descent_mps > c.near_ground_descent_mps + tol.near_ground_speed_mps,
                 f"push foot descends at {self.max_near_ground_descent_mps:.2f} m/s {where}")]
