"""The model plant's loop, which ticks the closed loop's parts at their rates: every MPC update
(30 Hz) the feedback of the model plant and the controller's update on it
(:class:`skatelib.control.update.MpcUpdate`: the observers, the reference's horizon, one QP);
between updates the plant
at ``plant_substeps`` steps; after each update the stance legs' joint angles by inverse kinematics
(the whole-body controller's share) and the fall checks.

After every update the stance legs' joint angles follow by inverse kinematics from where their
feet touch the plant's deck or ground (:mod:`skatelib.control.kinematics`); their torques and
joint limits are checked, and the next update's QP holds the torques within the limit at those
angles.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from skatelib.control.kinematics import LegKinematics
from skatelib.control.linear_model import Feedback
from skatelib.control.qp import QpSolveFailed
from skatelib.control.reference import EntryReference, Reference
from skatelib.control.update import MpcUpdate
from skatelib.library.channels import BOARD, GROUND, I_BOARD_ROLL, NX, S_Q, SWING
from skatelib.library.margins import forward_speed
from skatelib.library.rotations import board_rotations, rpy_matrices
from skatelib.proving.perturb import impulse_checked, run_updates
from skatelib.proving.plant import Plant, PlantInput
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.trace import Run, Trace
from skatelib.proving.verdict import fall_reason
from skatelib.runtime import MotionLibrary


def simulate(ref: Reference, x_init: np.ndarray, loop: ClosedLoop, keep_trace: bool = False,
             kinematics: LegKinematics | None = None) -> Run:
    """Run the MPC against the plant from ``ref.t0`` to ``ref.t_stop``.

    Args:
        ref: The reference (:class:`skatelib.control.reference.EntryReference` or the steering
            experiment's).
        x_init: (31,) initial plant state of the model's COM (28 channels, board origin).
        loop: Model, plant, disturbances, MPC and run settings.
        kinematics: The robot's legs: after every update, the stance legs' joint angles by
            inverse kinematics and the torques of the commanded forces (the whole-body
            controller's job) are measured on the plant's state.

    BLAS runs on one thread meanwhile, as in a controller's real-time loop: the MPC's matrices are
    small (about 100 x 400), and a multi-threaded BLAS makes an update several times slower on
    2 cores.

    Raises:
        PerturbationError: An impulse the run would never apply, before it starts
            (:func:`skatelib.proving.perturb.impulse_checked`).
    """
    from skatelib.proving.setup import one_blas_thread

    impulse_checked(loop.dist, ref, (loop.mpc.dt, loop.settings.plant_substeps))
    with one_blas_thread():
        return _Loop(ref, x_init, loop, kinematics, keep_trace).run()


def entry_impulses_checked(lib: MotionLibrary, keys: Sequence[str], loop: ClosedLoop) -> None:
    """:func:`skatelib.proving.perturb.impulse_checked` for the runs of the entries ``keys`` of
    ``lib``, before any of them rides (:func:`simulate` checks each run again as it starts).

    Raises:
        PerturbationError: Naming ``impulse_t``, the first entry whose run it is beyond and its end.
    """
    if loop.dist.impulse_Ns:
        for key in keys:
            ref = EntryReference(lib, lib[key], loop.model, loop.settings)
            impulse_checked(loop.dist, ref, (loop.mpc.dt, loop.settings.plant_substeps), f"the run of {key}")


class _Loop:
    """One run's state between the ticks."""

    def __init__(self, ref: Reference, x_init: np.ndarray, loop: ClosedLoop, kinematics: LegKinematics | None,
                 keep_trace: bool):
        self.ref, self.loop, self.kin, self.keep_trace = ref, loop, kinematics, keep_trace
        cfg, dist = loop.mpc, loop.dist
        self.rng = np.random.default_rng(loop.settings.seed)
        self.com_shift = np.array([0.0, dist.com_offset_m, 0.0])
        self.plant = Plant(loop.plant, self.com_shift)
        self.result = Run(plant=self.plant)
        self.mpc = MpcUpdate(ref, loop.model, cfg, cfg.dt)
        self._last_U: np.ndarray | None = None  # what the model plant was last given
        self.h = cfg.dt / loop.settings.plant_substeps
        s = np.array(x_init, dtype=np.float64)
        s[0:3] += rpy_matrices(s[3:6]) @ self.com_shift  # the true COM
        s[1] += dist.init_error_m
        s[2] += dist.init_error_m
        self.s = s
        self.ground = ref.initial_ground()
        self.prev_contact = ref.contact(ref.t0)
        self.t = ref.t0
        self.t_1s = ref.t_end + 1.0
        self.q_legs = np.array(x_init[S_Q], dtype=np.float64)
        self.rows: list[list[Any]] = [[] for _ in range(7)]  # the trace's columns

    def run(self) -> Run:
        cfg = self.loop.mpc
        for _ in range(run_updates(self.ref, cfg.dt)):
            update = self.update()
            if update is None:
                break
            forces, qd, x_ref = update
            self.substeps(forces, qd, x_ref)
            if self.result.fall:
                break
            self.after_update(forces, x_ref)
            if self.result.fall:
                break
        if self.keep_trace and self.rows[0]:
            self.result.trace = Trace(*(np.array(col) for col in self.rows))
        return self.result

    def feedback(self) -> Feedback:
        """What the estimator reports (the model's COM, noise) and the lever arms of the feet."""
        dist, model, s = self.loop.dist, self.loop.model, self.s
        x_fb = s[:NX].copy()
        x_fb[0:3] -= rpy_matrices(x_fb[3:6]) @ self.com_shift
        if dist.noise_std > 0:
            x_fb[0:6] += self.rng.normal(0.0, dist.noise_std, 6)
            x_fb[6:12] += self.rng.normal(0.0, 5 * dist.noise_std, 6)
        pts = self.plant.contact_points(s, self.ref.contact(self.t), self.ground)
        r_board = model.moment_arms(board_rotations(x_fb[5], x_fb[I_BOARD_ROLL]))
        maps = None if self.kin is None else self.kin.torque_maps(self.q_legs, rpy_matrices(x_fb[3:6]))
        return Feedback(x=x_fb, r_robot=pts - x_fb[0:3, None], r_board=r_board, torque_maps=maps)

    def update(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """One MPC update: (forces (3, 4), joint velocities (12,), the reference of its first step),
        or None when the QP failed (recorded as a fall). The observer compares the feedback with
        the model's prediction under the MPC's own forces: the model plant applies them as given."""
        try:
            step = self.mpc(self.t, self.feedback(), self.s[NX:NX + 2], self._last_U)
        except QpSolveFailed as e:
            self.result.fall = f"the MPC's QP failed at t = {self.t:.2f} s ({e})"
            return None
        self._last_U = step.U
        self.result.times_s.append(step.solve_s)
        return step.forces, step.U[12:24], step.horizon.x_ref[0]

    def substeps(self, forces: np.ndarray, qd: np.ndarray, x_ref0: np.ndarray) -> None:
        """The plant's steps until the next update (touch-downs where the plan puts them)."""
        ref, dist, run, h = self.ref, self.loop.dist, self.result, self.h
        plant_params = self.loop.plant
        for _sub in range(self.loop.settings.plant_substeps):
            c = ref.contact(self.t)
            self.touch_down(c)
            ext = None
            if dist.impulse_Ns and abs(self.t - dist.impulse_t_s) < h / 2:
                ext = np.array([0.0, dist.impulse_Ns / h, 0.0])
            s_new = self.plant.step(self.s, PlantInput(forces, qd, ext), c, self.ground, h, self.t)
            if ref.t_end <= self.t < self.t_1s:
                v_f = float(forward_speed(self.s))
                run.friction_loss_Ns += plant_params.rolling_N * np.tanh(plant_params.tanh_scale_s_per_m * v_f) * h
            self.s = s_new
            self.t += h
            self.measure_speeds()
            if self.keep_trace:
                self.record(x_ref0, forces, qd, c)
            run.max_roll_rad = max(run.max_roll_rad, abs(float(self.s[I_BOARD_ROLL])))
            if not np.all(np.isfinite(self.s)):
                run.fall = f"the state diverged at t = {self.t:.2f} s"
                return

    def touch_down(self, c: np.ndarray) -> None:
        for i in range(4):
            if c[i] == GROUND and self.prev_contact[i] != GROUND:
                self.ground[:, i] = self.ref.touchdown_point(self.t, i) + np.r_[
                    self.s[NX:NX + 2] - self.ref.board_xy(self.t), 0.0]
        self.prev_contact = c

    def measure_speeds(self) -> None:
        run, t, s = self.result, self.t, self.s
        if np.isnan(run.momentum_at_end_mps) and t >= self.ref.t_end - 1e-9:
            run.momentum_at_end_mps = self.plant.momentum_speed(s)
        if np.isnan(run.speed_after_1s_mps) and t >= self.t_1s - 1e-9:
            run.speed_after_1s_mps = float(forward_speed(s))
            run.momentum_after_1s_mps = self.plant.momentum_speed(s)
        ends = self.ref.stage_ends
        if len(run.stage_speeds_mps) < len(ends) and t >= ends[len(run.stage_speeds_mps)] - 1e-9:
            run.stage_speeds_mps.append(self.plant.momentum_speed(s))

    def record(self, x_ref0: np.ndarray, forces: np.ndarray, qd: np.ndarray, c: np.ndarray) -> None:
        s = self.s
        values = (self.t, s.copy(), x_ref0.copy(), self.plant.admissible(s, forces, c, self.t, record=False), qd,
                  c.copy(), self.plant.contact_points(s, c, self.ground))
        for col, v in zip(self.rows, values, strict=True):
            col.append(v)

    def after_update(self, forces: np.ndarray, x_ref0: np.ndarray) -> None:
        """Errors against the reference of this update's first step (re-anchored), the whole-body
        share and the fall checks."""
        run, s, contact = self.result, self.s, self.prev_contact
        run.updates.append((self.t, s.copy(), x_ref0.copy()))
        pos_err = float(np.linalg.norm(s[0:3] - rpy_matrices(s[3:6]) @ self.com_shift - x_ref0[0:3]))
        run.max_position_error_m = max(run.max_position_error_m, pos_err)
        run.max_attitude_error_rad = max(run.max_attitude_error_rad, float(np.max(np.abs(s[3:6] - x_ref0[3:6]))))
        pts = self.plant.contact_points(s, contact, self.ground)
        reach = max((float(np.linalg.norm(pts[:, i] - s[0:3])) for i in range(4) if contact[i] != SWING),
                    default=0.0)
        run.fall = fall_reason(self.ref, s, x_ref0, reach, self.loop.plant.roll_limit_rad, self.t)
        if self.kin is not None and not run.fall:  # a fallen body's legs by inverse kinematics measure nothing
            self.q_legs = self.whole_body(self.kin, forces, pts, x_ref0[S_Q])

    def whole_body(self, kin: LegKinematics, forces: np.ndarray, points: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        """Stance legs by inverse kinematics to where their feet touch the plant's deck or ground,
        swinging legs at the reference; records torque, reach and joint-limit figures."""
        run, s, contact = self.result, self.s, self.prev_contact
        R = rpy_matrices(s[3:6])
        origin = s[0:3] - R @ (self.loop.model.com_offset_m + self.com_shift)  # the trunk frame's origin
        loaded = contact != SWING
        normals = np.where(contact[None, :] == BOARD, board_rotations(s[5], s[I_BOARD_ROLL])[:, 2:3],
                           np.array([[0.0], [0.0], [1.0]]))
        centres = R.T @ (points + kin.foot_radius_m * normals - origin[:, None])
        q0 = np.where(np.repeat(loaded, 3), self.q_legs, q_ref)
        q, residual = kin.inverse(centres, q0, loaded)
        tau = kin.torques(q, R.T @ forces, loaded)
        run.max_torque_Nm = max(run.max_torque_Nm, float(np.max(np.abs(tau))))
        run.max_ik_residual_m = max(run.max_ik_residual_m, float(np.max(residual)))
        excess = np.maximum(kin.lower_rad - q, q - kin.upper_rad)[np.repeat(loaded, 3)]
        run.max_joint_limit_excess_rad = max(run.max_joint_limit_excess_rad, float(np.max(excess, initial=0.0)))
        return q
