"""The board's posture and rotation rate from the feet on its deck (the paper's Sec. V-A: "the
skateboard's posture from the positions of the feet in contact with it").

A foot on the deck is a sphere of radius r resting on its top, so its centre c_i lies r above the
deck's top plane wherever it rolls: the plane through the deck feet's centres (three or more) is
the deck's top raised by r, its normal n the deck's z axis. The deck's rotation is
R_B = Rz(psi) Rx(phi) (its wheels keep it from pitching), so n = Rz(psi) (0, -sin phi, cos phi):

    phi = atan2(-n . (Rz(psi) e_y), n_z)

The heading psi and the deck's position from where the feet stand on it (their footholds f_i in
the deck frame, taken at touchdown): psi by the 2-D Procrustes fit of Rx(phi) f_i's x, y to c_i's
(roll and heading refined in turn, twice), the
top centre p_B = mean(c_i) - R_B mean(f_i). With fewer than three deck feet the roll is carried
on by the roll rate (and with fewer than two the heading by the yaw rate).

The rates: two points of one rigid deck move apart as c_i' - c_j' = omega_B x (c_i - c_j), and a
deck on its wheels turns about e_z (steering) and its heading h (roll) only: omega_B = psi' e_z +
phi' h. Least squares over the pairs of deck feet, pulled towards the last rates (weight
``prior``) where the pairs leave a rate unobserved (two feet one behind the other see no roll).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from skatelib.library.rotations import board_rotations

UP = np.array([0.0, 0.0, 1.0])


@dataclass
class DeckEstimate:
    """The deck: heading ``yaw`` and ``roll`` [rad], their rates [rad/s], the top centre ``pos``
    [m], its rotation ``R``; ``footholds`` (3, 4) the feet's centres in the deck frame."""

    yaw: float
    roll: float
    pos: np.ndarray
    footholds: np.ndarray
    yaw_rate: float = 0.0
    roll_rate: float = 0.0
    R: np.ndarray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self) -> None:
        self.R = board_rotations(self.yaw, self.roll)

    @property
    def omega(self) -> np.ndarray:
        """The deck's angular velocity (world)."""
        return np.asarray(self.yaw_rate * UP + self.roll_rate * self.R[:, 0])


def plane_normal(points: np.ndarray) -> np.ndarray:
    """The upward unit normal of the least-squares plane through (3, n >= 3) points."""
    centred = points - points.mean(axis=1, keepdims=True)
    n = np.linalg.svd(centred)[0][:, 2]
    return n if n[2] > 0 else -n


def heading_fit(footholds: np.ndarray, centres: np.ndarray) -> float:
    """The rotation about z that best carries footholds' x, y onto the centres' (2-D Procrustes)."""
    a = footholds[0:2] - footholds[0:2].mean(axis=1, keepdims=True)
    b = centres[0:2] - centres[0:2].mean(axis=1, keepdims=True)
    return math.atan2(float(np.sum(a[0] * b[1] - a[1] * b[0])), float(np.sum(a[0] * b[0] + a[1] * b[1])))


def deck_rates(centres: np.ndarray, velocities: np.ndarray, h: np.ndarray, prior: np.ndarray,
               weight: float) -> np.ndarray:
    """(yaw rate, roll rate) from the deck feet's centres and contact-point velocities (3, n)."""
    rows, rhs = [weight * np.eye(2)], [weight * prior]
    n = centres.shape[1]
    for i in range(n):
        for j in range(i + 1, n):
            d = centres[:, i] - centres[:, j]
            rows.append(np.column_stack([np.cross(UP, d), np.cross(h, d)]))
            rhs.append(velocities[:, i] - velocities[:, j])
    A, b = np.vstack(rows), np.concatenate(rhs)
    return np.asarray(np.linalg.lstsq(A, b, rcond=None)[0])


@dataclass(frozen=True)
class DeckSettings:
    """The rates' pull towards the last ones (prior weight [s]... in units of metres of foot
    spacing: a pair 5 cm apart observes as much as the prior)."""

    prior: float = 0.05


def update_deck(deck: DeckEstimate, on_deck: np.ndarray, centres: np.ndarray, velocities: np.ndarray,
                dt: float, settings: DeckSettings = DeckSettings()) -> DeckEstimate:
    """The deck after one tick of ``dt`` [s] from the feet ``on_deck`` (bool (4,)) with their centres
    and contact-point velocities (3, 4, world)."""
    idx = np.nonzero(on_deck)[0]
    c, f = centres[:, idx], deck.footholds[:, idx]
    rates = np.array([deck.yaw_rate, deck.roll_rate])
    if len(idx) >= 2:
        rates = deck_rates(c, velocities[:, idx], deck.R[:, 0], rates, settings.prior)
    roll = deck.roll + rates[1] * dt
    yaw = heading_fit(board_rotations(0.0, roll) @ f, c) if len(idx) >= 2 else deck.yaw + rates[0] * dt
    if len(idx) >= 3:
        n = plane_normal(c)
        for _ in range(2):  # the roll from the normal at the heading, the heading of the rolled footholds
            y_axis = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
            roll = math.atan2(-float(n @ y_axis), float(n[2]))
            yaw = heading_fit(board_rotations(0.0, roll) @ f, c)
    out = DeckEstimate(yaw=yaw, roll=roll, pos=deck.pos, footholds=deck.footholds, yaw_rate=float(rates[0]),
                       roll_rate=float(rates[1]))
    if len(idx):
        out.pos = c.mean(axis=1) - out.R @ f.mean(axis=1)
    return out
