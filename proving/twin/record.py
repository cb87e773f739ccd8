"""A run on a multibody plant as a library entry, for the viewers (``skatelib track --plant mujoco
--save OUT.rrd`` shows it beside the plan, with the views of ``inspect``): at every MPC update the
model state of the plant as sensed (its 28 channels; on the estimate, the plant's true state), the
whole-body QP's forces over the update, the joint velocities, each foot's contact (on the deck, on
the floor, none) and where it touches, and the deck's pose; on the estimate, the estimate's model
state beside them (:data:`ESTIMATE_STATE`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from skatelib.control.feedback import ON_FLOOR
from skatelib.library import schema
from skatelib.library.channels import BOARD, CONTROL_NAMES, GROUND, LEGS, NX, STATE_NAMES, SWING
from skatelib.runtime import Entry

# The dataset of a run's entry that holds the estimate's model state at each row (a run on the
# estimate); the entry's own state is the plant's true one.
ESTIMATE_STATE = "estimate_state"


@dataclass
class TwinRecord:
    """The rows of a kept run, one per MPC update."""

    t: list[float] = field(default_factory=list)
    state: list[np.ndarray] = field(default_factory=list)
    forces: list[np.ndarray] = field(default_factory=list)  # (3, 4) the whole-body QP's, averaged over the update
    qd: list[np.ndarray] = field(default_factory=list)
    contact: list[np.ndarray] = field(default_factory=list)
    feet: list[np.ndarray] = field(default_factory=list)  # (3, 4) contact points
    board: list[np.ndarray] = field(default_factory=list)  # (4,) deck x, y, z, yaw
    estimate: list[np.ndarray] = field(default_factory=list)  # the estimate's model state (on the estimate)

    def add(self, t: float, x: np.ndarray, st: Any) -> None:
        self.t.append(t)
        self.state.append(np.asarray(x[:NX], dtype=np.float64).copy())
        self.qd.append(np.asarray(st.qd, dtype=np.float64).copy())
        touch = np.asarray(st.foot_touch)
        self.contact.append(np.where(touch == ON_FLOOR, GROUND, np.where(touch > 0, BOARD, SWING)).astype(np.int8))
        self.feet.append(np.array(st.contact_points, dtype=np.float64))
        self.board.append(np.r_[st.deck_pos, st.deck_yaw])

    def estimated(self, x: np.ndarray) -> None:
        """The estimate's model state at the row just added (a run on the estimate)."""
        self.estimate.append(np.asarray(x[:NX], dtype=np.float64).copy())

    def applied(self, forces: np.ndarray) -> None:
        """The forces the ticks after the last update applied (the row of that update)."""
        self.forces.append(np.array(forces, dtype=np.float64))

    def as_entry(self, key: str, target_velocity_mps: float) -> Entry:
        n = min(len(self.t), len(self.forces))
        if n < 2:
            raise ValueError(f"{key}: a run of {n} updates is too short to show")
        forces = np.array([f.T.reshape(12) for f in self.forces[:n]])
        arrays = {
            schema.D_T: np.array(self.t[:n]), schema.D_STATE: np.array(self.state[:n]),
            schema.D_CONTROL: np.hstack([forces, np.array(self.qd[:n])])[:-1],
            schema.D_CONTACT: np.array(self.contact[:n]),
            schema.D_FOOT_POS: np.transpose(np.array(self.feet[:n]), (0, 2, 1)),
            schema.D_BOARD_POS: np.array(self.board[:n]),
        }
        columns = {schema.D_STATE: STATE_NAMES, schema.D_CONTROL: CONTROL_NAMES, schema.D_CONTACT: LEGS,
                   schema.D_FOOT_POS: LEGS, schema.D_BOARD_POS: ("board_x", "board_y", "board_z", "board_yaw")}
        if len(self.estimate) >= n:
            arrays[ESTIMATE_STATE] = np.array(self.estimate[:n])
            columns[ESTIMATE_STATE] = STATE_NAMES
        attrs = {schema.A_TARGET_VELOCITY: target_velocity_mps, schema.A_N_STRIDES: 0, schema.A_SUCCESS: True,
                 schema.A_STATUS: "full physics"}
        return Entry(key, attrs, arrays, columns)
