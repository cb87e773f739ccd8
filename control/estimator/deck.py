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
from skatelib.control.estimator.vec3 import cross
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
    n = footholds.shape[1]
    a = footholds[0:2] - footholds[0:2].sum(axis=1, keepdims=True) / n
    b = centres[0:2] - centres[0:2].sum(axis=1, keepdims=True) / n
    return math.atan2(float(np.sum(a[0] * b[1] - a[1] * b[0])), float(np.sum(a[0] * b[0] + a[1] * b[1])))


def _rolled(footholds: np.ndarray, roll: float) -> np.ndarray:
    """The footholds' x, y rolled by ``roll`` about x (Rx(roll) f's first two rows)."""
    return np.stack((footholds[0], math.cos(roll) * footholds[1] - math.sin(roll) * footholds[2]))


PAIRS = {n: np.triu_indices(n, 1) for n in range(5)}  # the pairs of n deck feet


def deck_rates(centres: np.ndarray, velocities: np.ndarray, h: np.ndarray, prior: np.ndarray,
               weight: float) -> np.ndarray:
    """(yaw rate, roll rate) from the deck feet's centres and contact-point velocities (3, n): the
    least-squares solution of the pairs' rows and the prior's, by its 2 x 2 normal equations."""
    i, j = PAIRS[centres.shape[1]] if centres.shape[1] < 5 else np.triu_indices(centres.shape[1], 1)
    d = centres[:, i] - centres[:, j]
    dv = velocities[:, i] - velocities[:, j]
    c1 = np.stack((-d[1], d[0], np.zeros(d.shape[1])))  # e_z x d
    c2 = cross(h, d)
    w2 = weight * weight
    a11, a12, a22 = w2 + float(np.sum(c1 * c1)), float(np.sum(c1 * c2)), w2 + float(np.sum(c2 * c2))
    b1 = w2 * float(prior[0]) + float(np.sum(c1 * dv))
    b2 = w2 * float(prior[1]) + float(np.sum(c2 * dv))
    det = a11 * a22 - a12 * a12
    return np.array([(a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det])


@dataclass(frozen=True)
class DeckSettings:
    """The rates' pull towards the last ones (``prior``, in metres of foot spacing: a pair 5 cm
    apart observes as much as the prior); ``roll``: False takes the deck's roll and roll rate as
    zero (a board assumed level: the negative control of the steering maneuver)."""

    prior: float = 0.05
    roll: bool = True


def update_deck(deck: DeckEstimate, on_deck: np.ndarray, centres: np.ndarray, velocities: np.ndarray,
                dt: float, settings: DeckSettings = DeckSettings()) -> DeckEstimate:
    """The deck after one tick of ``dt`` [s] from the feet ``on_deck`` (bool (4,)) with their centres
    and contact-point velocities (3, 4, world)."""
    idx = np.flatnonzero(on_deck)
    n = len(idx)
    c, f = centres[:, idx], deck.footholds[:, idx]
    yaw_rate, roll_rate = deck.yaw_rate, deck.roll_rate
    if n >= 2:
        yaw_rate, roll_rate = (float(w) for w in deck_rates(c, velocities[:, idx], deck.R[:, 0],
                                                            np.array([yaw_rate, roll_rate]), settings.prior))
    roll = deck.roll + roll_rate * dt
    yaw = heading_fit(_rolled(f, roll), c) if n >= 2 else deck.yaw + yaw_rate * dt
    if n >= 3:
        nz = plane_normal(c)
        for _ in range(2):  # the roll from the normal at the heading, the heading of the rolled footholds
            roll = math.atan2(math.sin(yaw) * float(nz[0]) - math.cos(yaw) * float(nz[1]), float(nz[2]))
            yaw = heading_fit(_rolled(f, roll), c)
    if not settings.roll:
        roll = roll_rate = 0.0
        yaw = heading_fit(f[0:2], c) if n >= 2 else yaw
    out = DeckEstimate(yaw=yaw, roll=roll, pos=deck.pos, footholds=deck.footholds, yaw_rate=yaw_rate,
                       roll_rate=roll_rate)
    if n:
        out.pos = c.sum(axis=1) / n - out.R @ (f.sum(axis=1) / n)
    return out
