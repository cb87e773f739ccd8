"""What a closed-loop run records: the figures the verdicts are made from (:class:`Run`) and, when
asked, its time series (:class:`Trace`), which it hands out as a library entry for the views."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from skatelib.library import schema
from skatelib.library.channels import CONTROL_NAMES, LEGS, NX, STATE_NAMES
from skatelib.proving.plant import Plant
from skatelib.runtime import Entry


@dataclass
class Trace:
    """Time series of a run, per plant step, for plots and Rerun: t (M,), plant state (M, 31),
    reference (M, 28), applied forces (M, 3, 4), joint velocities (M, 12), contact (M, 4) and
    contact points (M, 3, 4)."""

    t: np.ndarray
    state: np.ndarray
    reference: np.ndarray
    forces: np.ndarray
    qd: np.ndarray
    contact: np.ndarray
    feet: np.ndarray

    def as_entry(self, key: str, target_velocity_mps: float, stride: int = 1) -> Entry:
        """The run as a library entry (every ``stride``-th plant step; control k acts on
        [t_k, t_k+1), so one row fewer), for the same views as the library's entries."""
        sl = slice(None, None, stride)
        n = len(self.t[sl])
        forces = np.transpose(self.forces[sl], (0, 2, 1)).reshape(n, 12)  # f_<leg>_<axis>, legs in order
        state = self.state[sl]
        arrays = {
            schema.D_T: self.t[sl], schema.D_STATE: state[:, :NX],
            schema.D_CONTROL: np.hstack([forces, self.qd[sl]])[:-1],
            schema.D_CONTACT: self.contact[sl], schema.D_FOOT_POS: np.transpose(self.feet[sl], (0, 2, 1)),
            schema.D_BOARD_POS: np.column_stack([state[:, NX:NX + 3], state[:, 5]]),
        }
        columns = {schema.D_STATE: STATE_NAMES, schema.D_CONTROL: CONTROL_NAMES, schema.D_CONTACT: LEGS,
                   schema.D_FOOT_POS: LEGS, schema.D_BOARD_POS: ("board_x", "board_y", "board_z", "board_yaw")}
        attrs = {schema.A_TARGET_VELOCITY: target_velocity_mps, schema.A_N_STRIDES: 0, schema.A_SUCCESS: True,
                 schema.A_STATUS: "closed loop"}
        return Entry(key, attrs, arrays, columns)


@dataclass
class Run:
    """What a closed-loop simulation measured (the verdicts are made from it).

    Attributes:
        updates: Per MPC update after its plant steps: time [s], plant state (31,) and the
            reference of the update's first step (28,).
    """

    plant: Plant
    fall: str = ""
    times_s: list[float] = field(default_factory=list)
    max_position_error_m: float = 0.0
    max_attitude_error_rad: float = 0.0
    max_roll_rad: float = 0.0
    max_torque_Nm: float = 0.0  # stance legs, -J^T f at the inverse-kinematics joint angles
    max_ik_residual_m: float = 0.0  # how far a stance foot stayed from where its leg can put it
    max_joint_limit_excess_rad: float = 0.0
    friction_loss_Ns: float = 0.0  # rolling friction's impulse from the end of the plan to 1 s later
    momentum_at_end_mps: float = float("nan")
    stage_speeds_mps: list[float] = field(default_factory=list)  # a ride's: the momentum speed at each stage's end
    speed_after_1s_mps: float = float("nan")
    momentum_after_1s_mps: float = float("nan")
    updates: list[tuple[float, np.ndarray, np.ndarray]] = field(default_factory=list)
    trace: Trace | None = None
