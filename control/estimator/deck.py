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
    """The upward unit normal of the least-squares plane through (3, n >= 3) points (three: the
    plane through them)."""
    if points.shape[1] == 3:
        n = cross(points[:, 1] - points[:, 0], points[:, 2] - points[:, 0])
        n = n / math.sqrt(float(n @ n))
    else:
        n = np.linalg.svd(points - points.mean(axis=1, keepdims=True))[0][:, 2]
    return n if n[2] > 0 else -n


def heading_fit(footholds: np.ndarray, centres: np.ndarray) -> float:
    """The rotation about z that best carries footholds' x, y onto the centres' (2-D Procrustes)."""
    return _HeadingFit(footholds, centres)(0.0)


class _HeadingFit:
    """:func:`heading_fit` of the footholds rolled by any angle about x (Rx(roll) f), the sums it
    needs taken once: rolling is linear in (cos, sin) of the roll."""

    def __init__(self, footholds: np.ndarray, centres: np.ndarray):
        n = footholds.shape[1]
        f = footholds - footholds.sum(axis=1, keepdims=True) / n
        bx, by = (centres[0:2] - centres[0:2].sum(axis=1, keepdims=True) / n)
        fx, fy, fz = f
        self.sums = [float(s.sum()) for s in (fx * by, fy * bx, fz * bx, fx * bx, fy * by, fz * by)]

    def __call__(self, roll: float) -> float:
        xby, ybx, zbx, xbx, yby, zby = self.sums
        c, s = math.cos(roll), math.sin(roll)
        # a = (f_x, c f_y - s f_z): sum(a_x b_y - a_y b_x), sum(a_x b_x + a_y b_y)
        return math.atan2(xby - c * ybx + s * zbx, xbx + c * yby - s * zby)


PAIRS = {n: np.triu_indices(n, 1) for n in range(5)}  # the pairs of n deck feet


def deck_rates(centres: np.ndarray, velocities: np.ndarray, h: np.ndarray, prior: np.ndarray,
               weight: float) -> np.ndarray:
    """(yaw rate, roll rate) from the deck feet's centres and contact-point velocities (3, n): the
    least-squares solution of the pairs' rows and the prior's, by its 2 x 2 normal equations."""
    i, j = PAIRS[centres.shape[1]] if centres.shape[1] < 5 else np.triu_indices(centres.shape[1], 1)
    d = centres[:, i] - centres[:, j]
    dv = velocities[:, i] - velocities[:, j]
    c1 = np.array((-d[1], d[0], np.zeros(d.shape[1])))  # e_z x d
    c2 = cross(h, d)
    w2 = weight * weight
    a11, a12, a22 = w2 + float((c1 * c1).sum()), float((c1 * c2).sum()), w2 + float((c2 * c2).sum())
    b1 = w2 * float(prior[0]) + float((c1 * dv).sum())
    b2 = w2 * float(prior[1]) + float((c2 * dv).sum())
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
    fit = _HeadingFit(f, c) if n >= 2 else None
    yaw = fit(roll) if fit else deck.yaw + yaw_rate * dt
    if fit and n >= 3:
        nx, ny, nz = (float(x) for x in plane_normal(c))
        for _ in range(2):  # the roll from the normal at the heading, the heading of the rolled footholds
            roll = math.atan2(math.sin(yaw) * nx - math.cos(yaw) * ny, nz)
            yaw = fit(roll)
    if not settings.roll:
        roll = roll_rate = 0.0
        yaw = fit(0.0) if fit else yaw
    out = DeckEstimate(yaw=yaw, roll=roll, pos=deck.pos, footholds=deck.footholds, yaw_rate=yaw_rate,
                       roll_rate=roll_rate)
    if n:
        out.pos = c.sum(axis=1) / n - out.R @ (f.sum(axis=1) / n)
    return out
