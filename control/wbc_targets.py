"""What one whole-body tick asks (:class:`WbcTargets`), made from the body plan and the measured
state (:class:`TargetMaker`), the stance set it holds (:class:`StanceSet`) and the planned contact
codes looked up on a grid (:class:`ContactTable`); the tasks (:mod:`skatelib.control.wbc_tasks`)
and constraints (:mod:`skatelib.control.wbc_constraints`) read them.

* The centre of mass: the MPC's force sum over the mass plus PD to the plan, placed on the board's
  frame that does not roll (its top centre as it would be with the deck level: a frame that rolls
  with the deck would move the body sideways as the deck rolls, and the deck roll further).
* The trunk's attitude: PD to the plan's, its yaw from the board's.
* A swinging foot bound for the deck follows the deck (rolled with it); one bound for the floor is
  placed in the level board frame but moves at the plan's speed over the floor, so that it lands
  at rest on it whatever speed the board has (at the board's speed it would land sliding, and
  brake). A foot planned down but not yet touching aims a little into its surface.
* A stance foot accelerates with its deck point (or stays on the floor), with velocity feedback.
* The stance set: planned and touching; a foot that lands shortly before its planned stance stays
  down; one planned up leaves its surface.

The arithmetic runs in C (:mod:`skatelib.control.wbc_native`) unless ``WbcSettings(compiled=False)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin
from skatelib.control.body_plan import BodyTargets, Plan, yaw_matrix
from skatelib.control.feedback import ON_DECK, ON_FLOOR, MultibodyState
from skatelib.control.multibody import DynamicsTerms
from skatelib.control.params import SkateParams
from skatelib.control.wbc_native import CompiledTargets, wbc_library
from skatelib.control.wbc_settings import WbcSettings
from skatelib.library.channels import BOARD, SWING

TOUCHDOWN_REACH_M = 0.005  # a foot planned down but not touching aims this far into its surface
EARLY_CONTACT_S = 0.1  # a swinging foot that lands this close before its planned stance stays down
UP = np.array([0.0, 0.0, 1.0])


@dataclass
class WbcTargets:
    """What one tick asks (world frame; legs FL FR RL RR).

    Attributes:
        stance: (4,) feet held on their surface.
        on_deck: (4,) feet on (or bound for) the deck; the others' surface is the floor.
        deck_R: (3, 3) the deck's rotation (its z axis the normal; the friction pyramid's facets
            face its x and y axes).
        stance_acc: (3, 4) the stance feet's accelerations (their deck point's, with feedback) [m/s^2].
        com_acc / angular_acc: The model COM point's acceleration [m/s^2]; the trunk's angular
            acceleration in the trunk frame [rad/s^2].
        swing_acc: (3, 4) the swinging feet's accelerations [m/s^2].
        forces: (3, 4) the MPC's contact forces [N].
        posture_acc: (12,) joint accelerations toward the posture, channel order [rad/s^2].
    """

    stance: np.ndarray
    on_deck: np.ndarray
    deck_R: np.ndarray
    stance_acc: np.ndarray
    com_acc: np.ndarray
    angular_acc: np.ndarray
    swing_acc: np.ndarray
    forces: np.ndarray
    posture_acc: np.ndarray


@dataclass(frozen=True)
class StanceSet:
    """The feet a tick holds on their surface (``legs``, indices FL FR RL RR = 0-3, ascending) and
    the swinging ones (``swing``): what fixes the whole-body QP's shape."""

    legs: np.ndarray
    swing: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "swing", np.setdiff1d(np.arange(4), self.legs))

    @classmethod
    def of(cls, stance: np.ndarray) -> StanceSet:
        """The stance set of a (4,) mask."""
        return cls(np.nonzero(stance)[0])

    @property
    def n_forces(self) -> int:
        """The QP's force variables: 3 per stance foot."""
        return 3 * len(self.legs)


class ContactTable:
    """The planned contact codes on a grid of ``step_s`` from ``t0`` to ``t_stop`` (and
    ``LOOKAHEAD_S`` beyond), whether each foot is planned down, and whether it is on the deck now or
    (swinging) bound for it next: what a tick asks of the schedule several times, looked up instead
    of sampled."""

    LOOKAHEAD_S = 0.6

    def __init__(self, contact_at: Callable[[float], np.ndarray], t0: float, t_stop: float, step_s: float):
        self.t0, self.step = t0, step_s
        n = math.ceil((t_stop + self.LOOKAHEAD_S - t0) / step_s) + 2
        self.codes = np.array([contact_at(t0 + k * step_s) for k in range(n)], dtype=np.int8)
        upcoming = self.codes.copy()  # each foot's code now, or for a swinging one its next stance's
        for k in range(n - 2, -1, -1):
            later = upcoming[k + 1]
            fill = (self.codes[k] == SWING) & (later != SWING)
            upcoming[k, fill] = later[fill]
        self.planned = self.codes != SWING  # (n, 4) planned down
        self.deck_next = upcoming == BOARD  # (n, 4) now or next on the deck

    def index(self, t: float) -> int:
        """The grid row of ``t`` (clamped)."""
        return min(max(round((t - self.t0) / self.step), 0), len(self.codes) - 1)

    def at(self, t: float) -> np.ndarray:
        return self.codes[self.index(t)]

    def at_times(self, t: np.ndarray) -> np.ndarray:
        """(n, 4) the codes at the times ``t`` (n,), as :meth:`at` gives each."""
        return self.codes[np.clip(np.rint((t - self.t0) / self.step), 0, len(self.codes) - 1).astype(np.intp)]


@dataclass
class TargetMaker:
    """The targets of each tick; keeps the stance set between ticks."""

    plan: Plan
    contacts: ContactTable  # the planned contact codes
    p: SkateParams
    g: WbcSettings

    def __post_init__(self) -> None:
        self.stance = np.zeros(4, dtype=bool)
        self._gravity = self.p.gravity_mps2 * UP
        lib = wbc_library() if self.g.compiled else None
        self._native = None if lib is None else CompiledTargets(lib, self.p, self.g, TOUCHDOWN_REACH_M)

    def __call__(self, t: float, st: MultibodyState, T: DynamicsTerms, feet_v: np.ndarray,
                 forces: np.ndarray) -> WbcTargets:
        g, table, bt = self.g, self.contacts, self.plan.at(t)  # (a plan may adapt while it runs)
        k = table.index(t)
        if self._native is not None:
            codes = (table.planned[k], table.planned[table.index(t + EARLY_CONTACT_S)], table.deck_next[k])
            return self._compiled(st, T, feet_v, forces, bt, codes)
        yaw = st.deck_yaw
        Ry = yaw_matrix(yaw)
        deck_R = st.deck_R
        level = st.deck_pos + self.p.roll_axis_depth_m * (UP - deck_R[:, 2])
        planned = table.planned[k]
        touching = st.foot_touch > 0
        early = touching & table.planned[table.index(t + EARLY_CONTACT_S)]  # landed before its time
        self.stance = (planned | early) & (touching | self.stance)
        v_ref = Ry @ bt.com_v
        v_ref[0:2] += st.deck_v[0:2]
        com_acc = (forces @ planned / self.p.mass_kg - self._gravity
                   + g.kp_com * (level + Ry @ bt.com - T.com) + g.kd_com * (v_ref - T.com_v))
        R = st.trunk_R
        roll, pitch, yaw_plan = bt.rpy.tolist()
        ang_acc = (g.kp_attitude * (R.T @ pin.log3(pin.rpy.rpyToMatrix(roll, pitch, yaw_plan + yaw) @ R.T))
                   + g.kd_attitude * (bt.omega - st.trunk_omega))
        swing_acc, on_deck = self._feet(k, st, T.feet, feet_v, bt, (level, Ry))
        W = pin.skew(st.deck_omega)
        spin = W @ (T.feet - st.deck_pos[:, None])  # the deck points' velocities from its rotation
        stance_acc = np.where(st.foot_touch == ON_FLOOR, -g.stance_gain * feet_v,
                              W @ spin + g.stance_gain * (st.deck_v[:, None] + spin - feet_v))
        posture = g.kp_posture * (bt.q - st.q) - g.kd_posture * st.qd
        return WbcTargets(stance=self.stance.copy(), on_deck=on_deck, deck_R=deck_R, stance_acc=stance_acc,
                          com_acc=com_acc, angular_acc=ang_acc, swing_acc=swing_acc, forces=forces,
                          posture_acc=posture)

    def _compiled(self, st: MultibodyState, T: DynamicsTerms, feet_v: np.ndarray, forces: np.ndarray,
                  bt: BodyTargets, codes: tuple[np.ndarray, np.ndarray, np.ndarray]) -> WbcTargets:
        """:meth:`__call__`'s arithmetic in C (the same equations); ``codes``: the feet planned down
        now, planned down ``EARLY_CONTACT_S`` ahead, on (or bound for) the deck now."""
        assert self._native is not None
        o = self._native((st.trunk_R.ravel(), st.trunk_omega, st.q, st.qd, st.deck_pos, st.deck_R.ravel(), st.deck_v,
                          st.deck_omega, st.foot_touch, (st.deck_yaw,), T.com, T.com_v, T.feet.ravel(),
                          feet_v.ravel(), forces.ravel(), bt.com, bt.com_v, bt.rpy, bt.omega, bt.q, bt.board_v,
                          bt.feet.ravel(), bt.feet_v.ravel(), bt.feet_a.ravel(), *codes, self.stance))
        self.stance = o[0:4] > 0.5
        return WbcTargets(stance=self.stance.copy(), on_deck=o[4:8] > 0.5, deck_R=st.deck_R,
                          stance_acc=o[8:20].reshape(3, 4), com_acc=o[20:23], angular_acc=o[23:26],
                          swing_acc=o[26:38].reshape(3, 4), forces=forces, posture_acc=o[38:50])

    def _feet(self, k: int, st: MultibodyState, feet: np.ndarray, feet_v: np.ndarray, bt: BodyTargets,
              frame: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """Swinging feet's accelerations and which feet are on (or bound for) the deck (module
        docstring), at the contact table's index ``k``; ``frame``: the level board frame's origin and
        yaw rotation."""
        g, table = self.g, self.contacts
        level, Ry = frame
        deck = table.deck_next[k]
        deck_n = st.deck_R[:, 2:3]
        target = np.where(deck, st.deck_pos[:, None] + st.deck_R @ bt.feet, level[:, None] + Ry @ bt.feet)
        target_v = Ry @ (bt.feet_v + np.where(deck, 0.0, bt.board_v[:, None])) + st.deck_v[:, None] * deck
        touch = st.foot_touch
        on_deck = (touch == ON_DECK) | ((touch == 0) & deck)  # touching the deck, or bound for it
        normals = np.where(on_deck, deck_n, UP[:, None])
        reach = table.planned[k] & ~self.stance
        target -= TOUCHDOWN_REACH_M * (normals * reach)
        acc = Ry @ bt.feet_a + g.kp_swing * (target - feet) + g.kd_swing * (target_v - feet_v)
        return acc, on_deck
