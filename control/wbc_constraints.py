"""The whole-body QP's constraints, each a block of rows lo <= C x <= up over x = (qdd, f) that the
QP's assembly (:mod:`skatelib.control.wbc`) stacks in order:

* :class:`FloatingBaseDynamics`: (M qdd + h - J_c^T f)_base = 0, the floating base's Newton-Euler
  (6 rows), and the torque limits |(M qdd + h - J_c^T f)_joints| <= tau_max (12 rows); it leads the
  matrix, so that its 18 rows times x, plus h, are the generalized forces;
* :class:`StanceFeet`: J_i qdd + Jdot_i v = a_i, each stance foot moving with its deck point or
  the ground (3 rows each);
* :class:`SurfaceForces`: each stance foot's normal force within its bounds and (with
  ``friction_rows``) its force inside the 4-facet pyramid about its surface's normal.
"""

# No postponed annotations here: pdoc (make docs) resolves a NamedTuple's field types only when
# they are evaluated at class creation.

import functools
from typing import NamedTuple, Protocol

import numpy as np
from skatelib.control.multibody import DynamicsTerms
from skatelib.control.wbc_settings import NV, WbcSettings
from skatelib.control.wbc_targets import StanceSet, WbcTargets

NONE = 1e30  # a bound that binds nothing


class RowBlock(NamedTuple):
    """A constraint's views into the QP's arrays: ``lo <= rows @ x <= up``, ``equality``: held at ``up``."""

    rows: np.ndarray
    lo: np.ndarray
    up: np.ndarray
    equality: np.ndarray


class Constraint(Protocol):
    """A block of the whole-body QP's rows (:class:`RowBlock`)."""

    def size(self, stance: StanceSet) -> int:
        """Its rows for this stance set."""
        ...

    def fixed(self, block: RowBlock, stance: StanceSet) -> None:
        """What does not change between ticks of one stance set: its bounds and equality flags
        (the block comes with zero rows, bounds -NONE and NONE, no equality)."""
        ...

    def fill(self, block: RowBlock, T: DynamicsTerms, tg: WbcTargets, stance: StanceSet, Jc: np.ndarray) -> None:
        """This tick's rows (its (size, n) block of the matrix) and changing bounds; ``Jc``: the
        stance feet's stacked Jacobians (3 rows each, NV columns), ``stance``: their feet."""
        ...


class FloatingBaseDynamics:
    """The generalized forces M qdd + h - J_c^T f of the floating-base model (18 rows, leading the
    matrix): zero on the base (its Newton-Euler: no actuator there, 6 rows held at equality), the
    joints' torques within +-``limit_Nm`` (12 rows). One block, as one product of M and J_c fills
    both and the torques are read off it."""

    def __init__(self, limit_Nm: float):
        self.set_limit(limit_Nm)

    def set_limit(self, limit_Nm: float) -> None:
        """Hold the joints' torques within +-``limit_Nm`` [N m] from the next tick on."""
        self.limit_Nm = limit_Nm
        self.band = np.r_[np.zeros(6), np.full(NV - 6, limit_Nm)]  # the rows' bounds, less h
        self.neg_band = -self.band

    def size(self, stance: StanceSet) -> int:
        return NV

    def fixed(self, block: RowBlock, stance: StanceSet) -> None:
        block.equality[:6] = True

    def fill(self, block: RowBlock, T: DynamicsTerms, tg: WbcTargets, stance: StanceSet, Jc: np.ndarray) -> None:
        rows = block.rows
        rows[:, :NV] = T.M
        np.negative(Jc.T, out=rows[:, NV:])
        np.subtract(self.band, T.h, out=block.up)
        np.subtract(self.neg_band, T.h, out=block.lo)


class StanceFeet:
    """Each stance foot accelerates as its target says (with its deck point, or not at all on the floor)."""

    def size(self, stance: StanceSet) -> int:
        return stance.n_forces

    def fixed(self, block: RowBlock, stance: StanceSet) -> None:
        block.equality[:] = True

    def fill(self, block: RowBlock, T: DynamicsTerms, tg: WbcTargets, stance: StanceSet, Jc: np.ndarray) -> None:
        legs = stance.legs
        block.rows[:, :NV] = Jc
        block.up[:] = block.lo[:] = (tg.stance_acc[:, legs] - T.dJv_feet[legs].T).T.ravel()


def surface_coefficients(mu: float, friction_rows: bool = True) -> np.ndarray:
    """(1 + 4, 3) a stance foot's rows on a surface of rotation R, as ``coefficients @ R.T``: its
    normal (R's z axis), then (with ``friction_rows``) the 4-facet pyramid of ``mu`` about it, facing
    R's x and y axes (r . f <= 0 inside)."""
    facets = [[1.0, 0.0, -mu], [-1.0, 0.0, -mu], [0.0, 1.0, -mu], [0.0, -1.0, -mu]]
    return np.array([[0.0, 0.0, 1.0], *(facets if friction_rows else [])])


def pyramid(frame: np.ndarray, mu: float) -> np.ndarray:
    """(4, 3) rows r with r . f <= 0 inside the 4-facet pyramid of ``mu`` about the z axis of the
    rotation ``frame``."""
    return surface_coefficients(mu)[1:] @ frame.T


class SurfaceForces:
    """Each stance foot's normal force within [normal_min_N, normal_max_N] and its force inside the
    friction pyramid of ``mu`` about its surface's normal (the deck's, or the floor's): a normal
    row, then the facets, foot after foot."""

    def __init__(self, mu: float, s: WbcSettings):
        self.coefficients = surface_coefficients(mu, s.friction_rows)
        self.floor_rows = self.coefficients.copy()  # on the floor R = I
        self.per_leg = len(self.coefficients)
        self.normal_N = (s.normal_min_N, s.normal_max_N)

    def size(self, stance: StanceSet) -> int:
        return self.per_leg * len(stance.legs)

    def fixed(self, block: RowBlock, stance: StanceSet) -> None:
        r = self.per_leg * np.arange(len(stance.legs))  # each leg's normal row, then its facets
        block.lo[r], block.up[r] = self.normal_N
        for facet in range(1, self.per_leg):
            block.up[r + facet] = 0.0

    def fill(self, block: RowBlock, T: DynamicsTerms, tg: WbcTargets, stance: StanceSet, Jc: np.ndarray) -> None:
        legs = stance.legs
        if len(legs):
            deck = self.coefficients @ tg.deck_R.T
            blocks = np.where(tg.on_deck[legs, None, None], deck, self.floor_rows)
            block.rows.reshape(-1)[_block_index(len(legs), self.per_leg)] = blocks.ravel()


@functools.cache
def _block_index(k: int, per_leg: int) -> np.ndarray:
    """Where the (k, per_leg, 3) blocks of ``k`` stance feet go in their rows' block, raveled: each
    foot's normal and facets over its own 3 force columns."""
    legs = np.arange(k)
    r_idx = per_leg * legs[:, None, None] + np.arange(per_leg)[None, :, None] + np.zeros((1, 1, 3), dtype=int)
    c_idx = NV + 3 * legs[:, None, None] + np.zeros((1, per_leg, 1), dtype=int) + np.arange(3)
    return np.ravel_multi_index((r_idx.ravel(), c_idx.ravel()), (per_leg * k, NV + 3 * k))


def default_constraints(torque_limit_Nm: float, mu: float, s: WbcSettings) -> list[Constraint]:
    """The paper's constraints, in the order the QP stacks them (the generalized forces' rows first)."""
    return [FloatingBaseDynamics(torque_limit_Nm), StanceFeet(), SurfaceForces(mu, s)]
