"""What the controller reads of the robot and its board at a tick (from the robot's estimator,
or a multibody plant's state in the proving ground): the :class:`MultibodyState` protocol, and
the MPC's 28 channels made of it."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from skatelib.library.channels import BOARD, GROUND, I_BOARD_ROLL, NX, S_Q
from skatelib.library.rotations import board_rotations, roll_of, rpy_matrices, yaw_of
from skatelib.runtime import Entry

# A foot's touch code in ``MultibodyState.foot_touch`` (0: touching nothing).
ON_DECK, ON_FLOOR = 1, 2


class MultibodyState(Protocol):
    """The fields of the robot's and the board's state the controller reads at a tick (world frame;
    see the twin's state, or :class:`RobotState`)."""

    trunk_pos: np.ndarray
    trunk_R: np.ndarray
    trunk_v: np.ndarray
    trunk_omega: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    deck_pos: np.ndarray
    deck_R: np.ndarray
    deck_v: np.ndarray
    deck_omega: np.ndarray
    foot_touch: np.ndarray  # (4,) each foot's touch code
    contact_points: np.ndarray  # (3, 4) where each foot touches (or its lowest point)

    @property
    def deck_yaw(self) -> float: ...

    @property
    def deck_roll(self) -> float: ...


class StateError(ValueError):
    """A state the controller cannot act on (a field's shape, a NaN or an inf, an unknown touch code)."""


# Each field's shape; the controller refuses a state that breaks one, or holds a NaN or an inf.
SHAPES: dict[str, tuple[int, ...]] = {
    "trunk_pos": (3,), "trunk_R": (3, 3), "trunk_v": (3,), "trunk_omega": (3,), "q": (12,), "qd": (12,),
    "deck_pos": (3,), "deck_R": (3, 3), "deck_v": (3,), "deck_omega": (3,), "foot_touch": (4,),
    "contact_points": (3, 4),
}


def check_state(st: MultibodyState) -> None:
    """A state the controller can act on: every field of its shape and finite, each foot's touch
    code one of 0, ``ON_DECK``, ``ON_FLOOR`` (a NaN would make every torque NaN, an unknown code a
    foot that carries nothing). Some microseconds: one concatenation and one test on the good path.

    Raises:
        StateError: Naming the field and what is wrong; the caller holds its last command or stops.
    """
    check_arrays("state", {name: (getattr(st, name), shape) for name, shape in SHAPES.items()})
    touch = st.foot_touch
    if not set(touch.tolist()) <= {0, ON_DECK, ON_FLOOR}:
        raise StateError(f"state.foot_touch {touch!r}: each foot's code is 0 (touching nothing), {ON_DECK} (the "
                         f"deck) or {ON_FLOOR} (the floor)")


def check_arrays(what: str, arrays: dict[str, tuple[Any, tuple[int, ...]]],
                 error: type[ValueError] = StateError) -> None:
    """Each of ``arrays`` (name: (array, shape)) of its shape, and every number finite (one test of
    them all on the good path).

    Raises:
        StateError: (or ``error``) Naming ``what.name`` and what is wrong; nothing has used it yet:
            the caller skips it, holds its last command or stops.
    """
    for name, (a, shape) in arrays.items():
        if getattr(a, "shape", None) != shape:
            raise error(f"{what}.{name}: shape {np.shape(a)}, {shape} expected")
    if not np.isfinite(np.concatenate([a for a, _ in arrays.values()], axis=None)).all():
        name, a = next((n, a) for n, (a, _) in arrays.items() if not np.isfinite(a).all())
        raise error(f"{what}.{name} is not finite ({a!r}): a sensor or the estimator failed; skip it, hold the "
                    "last command or stop (nothing has used it)")


def rpy_of(R: np.ndarray) -> np.ndarray:
    """Z-Y-X angles (roll, pitch, yaw) of a rotation matrix."""
    return np.array([math.atan2(R[2, 1], R[2, 2]), -math.asin(max(-1.0, min(1.0, R[2, 0]))),
                     math.atan2(R[1, 0], R[0, 0])])


def quat_wxyz(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    w = math.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    q = np.array([w, x, y, z])
    return np.asarray(q / np.linalg.norm(q))


def mpc_state(st: MultibodyState, com: np.ndarray, com_v: np.ndarray) -> np.ndarray:
    """The MPC's 28 channels: the centre of mass (of the controller's model at the measured
    joints), trunk angles and rates, joints, board."""
    x = np.zeros(NX)
    R = st.trunk_R
    x[0:3] = com
    x[3:6] = rpy_of(R)
    x[6:9] = com_v
    x[9:12] = st.trunk_omega
    x[12:24] = st.q
    x[24:26] = st.deck_v[0:2]
    x[26] = st.deck_roll
    x[27] = float(st.deck_R[:, 0] @ st.deck_omega)
    return x


@dataclass
class RobotState:
    """A state as the robot's estimator gives it to the controller (world frame): the trunk's pose,
    its velocity (world) and angular velocity (trunk frame), the joints in channel order, the
    deck's pose and velocity, each foot's touch code and contact point."""

    trunk_pos: np.ndarray
    trunk_R: np.ndarray
    trunk_v: np.ndarray
    trunk_omega: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    deck_pos: np.ndarray
    deck_R: np.ndarray
    deck_v: np.ndarray
    deck_omega: np.ndarray
    foot_touch: np.ndarray
    contact_points: np.ndarray

    @property
    def deck_yaw(self) -> float:
        return yaw_of(self.deck_R)

    @property
    def deck_roll(self) -> float:
        """Roll about the deck's own x axis (Z-Y-X angles)."""
        return roll_of(self.deck_R)


def planned_state(entry: Entry, k: int, com_offset_m: np.ndarray) -> RobotState:
    """The state an entry plans at its knot ``k``, as the estimator would report it if the robot
    were exactly on the plan: the trunk's origin from the planned centre of mass (``com_offset_m``
    in the trunk frame), the deck at the planned board pose and roll, the feet on their planned
    contacts. A controller's dry run on a library starts here."""
    if entry.board_pos is None or entry.contact is None or entry.foot_pos is None:
        raise ValueError(f"{entry.key}: not a quadruped entry (no board, contacts or feet)")
    x = np.asarray(entry.state[k], dtype=np.float64)
    R = rpy_matrices(x[3:6])
    board = np.asarray(entry.board_pos[k], dtype=np.float64)
    deck_R = board_rotations(float(board[3]), float(x[I_BOARD_ROLL]))
    heading = deck_R[:, 0]
    contact = np.asarray(entry.contact[k])
    touch = np.where(contact == BOARD, ON_DECK, np.where(contact == GROUND, ON_FLOOR, 0))
    return RobotState(
        trunk_pos=x[0:3] - R @ com_offset_m, trunk_R=R, trunk_v=x[6:9].copy(), trunk_omega=x[9:12].copy(),
        q=x[S_Q].copy(), qd=np.zeros(12), deck_pos=board[0:3].copy(), deck_R=deck_R,
        deck_v=np.r_[x[24:26], 0.0], deck_omega=heading * x[27], foot_touch=touch,
        contact_points=np.asarray(entry.foot_pos[k], dtype=np.float64).T.copy())
