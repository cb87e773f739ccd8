"""What the humanoid twin tells: its sensors' readings (:class:`Readings`) and what happened
(:class:`Truth`), as :class:`skatelib.sim.humanoid.plant.HumanoidPlant` reads them; a truth as one
row of numbers (:mod:`skatelib.sim.native`'s ``H_`` layout), a run's rows as one table and its
columns (:func:`truth_columns`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from skatelib.sim import native as n


@dataclass(frozen=True)
class Readings:
    """The robot's sensors at one instant (noise included).

    Attributes:
        imu_quat_wxyz / imu_gyro: The waist's orientation and its rate in the waist frame.
        ft_force / ft_torque: (2, 3) right then left: the wrench the ground side exerts on the foot
            below each ankle sensor, in the foot frame, about the sensor's point.
    """

    t: float
    q: np.ndarray
    qd: np.ndarray
    imu_quat_wxyz: np.ndarray
    imu_gyro: np.ndarray
    ft_force: np.ndarray
    ft_torque: np.ndarray


@dataclass(frozen=True)
class Truth:
    """What happened (world frame): the COM, each sole's contact and the other links on the floor.

    Attributes:
        sole_force: (2, 3) the floor's (or a skate's deck's) force on each sole box; sole_zmp (2, 2)
            its centre of pressure on the plane of its bottom (NaN without contact); zmp (2,) both
            soles' together, on the plane ``truth``'s ``plane_z`` names.
        sole_pos / sole_yaw: (2, 3) / (2,) the soles' frames; sole_v / sole_wz their velocity and
            yaw rate.
    """

    t: float
    com: np.ndarray
    com_v: np.ndarray
    base_pos: np.ndarray
    base_R: np.ndarray
    sole_force: np.ndarray
    sole_zmp: np.ndarray
    zmp: np.ndarray
    sole_pos: np.ndarray
    sole_yaw: np.ndarray
    sole_v: np.ndarray
    sole_wz: np.ndarray
    torque: np.ndarray
    floor_touches: tuple[str, ...]
    deck_pos: np.ndarray | None = None  # a skate's deck: its top's centre (3,), orientation (3, 3) and velocity (3,)
    deck_R: np.ndarray | None = None
    deck_v: np.ndarray | None = None

    def on_deck(self, p: np.ndarray) -> np.ndarray:
        """World points (..., 3) in the deck's frame (its top's centre, x forward)."""
        if self.deck_pos is None or self.deck_R is None:
            raise ValueError("the twin has no board")
        return np.asarray((np.asarray(p) - self.deck_pos) @ self.deck_R)


# Each field of a truth row: where it starts and its shape (the joints' torques from H_N to the end).
TRUTH_LAYOUT: dict[str, tuple[int, tuple[int, ...]]] = {
    "t": (n.H_T, ()), "com": (n.H_COM, (3,)), "com_v": (n.H_COM_V, (3,)), "base_pos": (n.H_BASE_POS, (3,)),
    "base_R": (n.H_BASE_R, (3, 3)), "sole_force": (n.H_FORCE, (2, 3)), "sole_zmp": (n.H_SOLE_ZMP, (2, 2)),
    "zmp": (n.H_ZMP, (2,)), "sole_pos": (n.H_SOLE_POS, (2, 3)), "sole_yaw": (n.H_YAW, (2,)),
    "sole_v": (n.H_SOLE_V, (2, 3)), "sole_wz": (n.H_WZ, (2,)), "deck_pos": (n.H_DECK_POS, (3,)),
    "deck_R": (n.H_DECK_R, (3, 3)), "deck_v": (n.H_DECK_V, (3,))}
DECK_FIELDS = ("deck_pos", "deck_R", "deck_v")


def truth_of_row(s: np.ndarray, floor_touches: tuple[str, ...], deck: bool) -> Truth:
    """A :class:`Truth` of views of a truth row ``s`` (``deck``: the twin has a board, else its deck
    fields are None)."""
    fields: dict[str, Any] = {}
    for name, (at, shape) in TRUTH_LAYOUT.items():
        if shape == ():
            fields[name] = float(s[at])
        elif deck or name not in DECK_FIELDS:
            fields[name] = s[at:at + int(np.prod(shape, dtype=int))].reshape(shape)
    return Truth(**fields, torque=s[n.H_N:], floor_touches=floor_touches)


def truth_row(tr: Truth, stray: list[int]) -> np.ndarray:
    """``tr`` as a row of ``TRUTH_LAYOUT`` (no board: zeros), the ids of the ``stray`` geoms on the
    floor (the first ``N_STRAY`` of them, and how many)."""
    row = np.zeros(n.H_N + len(tr.torque))
    for name, (at, shape) in TRUTH_LAYOUT.items():
        value = getattr(tr, name)
        if value is not None:
            row[at:at + int(np.prod(shape, dtype=int))] = np.ravel(value)
    row[n.H_N_STRAY] = len(stray)
    row[n.H_STRAY:n.H_STRAY + min(len(stray), n.N_STRAY)] = stray[:n.N_STRAY]
    row[n.H_N:] = tr.torque
    return row


def truth_columns(table: np.ndarray, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The fields ``names`` (``TRUTH_LAYOUT``'s, and ``torque``) of a table of truth rows (N, width),
    each (N, *shape): copies, the table may go."""
    out = {}
    for name in names:
        if name == "torque":
            out[name] = table[:, n.H_N:].copy()
            continue
        at, shape = TRUTH_LAYOUT[name]
        size = int(np.prod(shape, dtype=int))
        out[name] = table[:, at:at + size].reshape(len(table), *shape).copy() if shape else table[:, at].copy()
    return out
