"""The robot's state estimator at every whole-body tick (500 Hz class): the IMU and the twelve
joint encoders in, a :class:`skatelib.control.feedback.RobotState` out (what the controller reads
of robot and board). Which feet stand, and on what, comes from the entry's contact schedule, as
CyberDog2 has no foot force sensors: a foot planned on the deck or the ground that is within
``touch_m`` of its surface (its centre's height over the ground, or over the deck's plane) counts
as touching; one whose velocity disagrees with its surface's is left out of the velocity
correction (:mod:`.odometry`), so a foot that lands late or early does not pull the estimate.

The world frame is the one the robot starts in: the ride's first planned pose (position, heading)
and speed, standing on a level deck of the board's known height.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import pinocchio as pin
from skatelib.control.estimator.attitude import AttitudeFilter, AttitudeSettings
from skatelib.control.estimator.deck import DeckEstimate, DeckSettings, update_deck
from skatelib.control.estimator.odometry import FootMeasure, LegOdometry, OdometrySettings
from skatelib.control.feedback import ON_DECK, ON_FLOOR, RobotState
from skatelib.control.kinematics import LegKinematics
from skatelib.library.channels import BOARD, GROUND

UP = np.array([0.0, 0.0, 1.0])


class Reading(Protocol):
    """One tick's sensor readings (IMU frame; joints in channel order)."""

    @property
    def t(self) -> float: ...

    @property
    def gyro(self) -> np.ndarray: ...

    @property
    def accel(self) -> np.ndarray: ...

    @property
    def q(self) -> np.ndarray: ...

    @property
    def qd(self) -> np.ndarray: ...


@dataclass(frozen=True)
class BoardGeometry:
    """What the robot knows of its board: the deck's top over the floor and the roll axis (the
    axles) below it [m]."""

    deck_height_m: float
    axis_depth_m: float


@dataclass(frozen=True)
class EstimatorSettings:
    """The estimator's parts' settings; ``touch_m``: a foot this close to its surface touches [m];
    ``settle_s``: a foot's velocity is used this long after it touches down (its impact over) [s]."""

    attitude: AttitudeSettings = field(default_factory=AttitudeSettings)
    odometry: OdometrySettings = field(default_factory=OdometrySettings)
    deck: DeckSettings = field(default_factory=DeckSettings)
    touch_m: float = 0.005
    settle_s: float = 0.02


@dataclass
class LegTerms:
    """The legs at the measured joints (trunk frame): foot centres (3, 4), their linear and angular
    Jacobians in the legs' joints (4, 3, 3 each)."""

    r: np.ndarray
    J: np.ndarray
    Jw: np.ndarray


def leg_terms(kin: LegKinematics, q: np.ndarray) -> LegTerms:
    """Foot centres and Jacobians of the fixed-trunk model at ``q`` (channel order)."""
    qp = pin.neutral(kin.model)
    qp[kin.q_index] = q
    pin.computeJointJacobians(kin.model, kin.data, qp)
    pin.updateFramePlacements(kin.model, kin.data)
    r, J, Jw = np.empty((3, 4)), np.empty((4, 3, 3)), np.empty((4, 3, 3))
    for i, f in enumerate(kin.feet):
        r[:, i] = kin.data.oMf[f].translation
        full = pin.getFrameJacobian(kin.model, kin.data, f, pin.LOCAL_WORLD_ALIGNED)[:, kin.v_index[3 * i:3 * i + 3]]
        J[i], Jw[i] = full[:3], full[3:]
    return LegTerms(r, J, Jw)


class StateEstimator:
    """The estimator of the module docstring.

    Args:
        kin: The robot's legs (pinocchio, fixed trunk).
        board: The board's known geometry.
        schedule: The contact codes planned at a time (the entry's schedule).
        start: The state the robot starts in (its pose, velocity, the deck's pose; the feet's
            touch codes say which stand on the deck).
        settings: The parts' settings.
        gravity_mps2: g.
    """

    def __init__(self, kin: LegKinematics, board: BoardGeometry, schedule: Callable[[float], np.ndarray],  # noqa: PLR0913
                 start: RobotState, settings: EstimatorSettings | None = None, gravity_mps2: float = 9.81,
                 imu_mount: np.ndarray | None = None):
        self.kin, self.board, self.schedule = kin, board, schedule
        self.s = settings or EstimatorSettings()
        self.g = gravity_mps2
        self.attitude = AttitudeFilter(start.trunk_R, self.s.attitude, imu_mount)
        self.rho = kin.foot_radius_m
        legs = leg_terms(kin, start.q)
        centres = start.trunk_pos[:, None] + start.trunk_R @ legs.r
        on_deck = start.foot_touch == ON_DECK
        deck_R = start.deck_R
        # The start: the deck level at its known height, the trunk over it as its deck feet say.
        lift = board.deck_height_m + self.rho - float(np.mean(centres[2, on_deck])) if on_deck.any() else 0.0
        p0 = start.trunk_pos + lift * UP
        centres = centres + lift * UP[:, None]
        top = np.array([start.deck_pos[0], start.deck_pos[1], board.deck_height_m])
        footholds = deck_R.T @ (centres - top[:, None])
        footholds[2] = self.rho
        heading = deck_R[:, 0]
        self.deck = DeckEstimate(yaw=start.deck_yaw, roll=start.deck_roll, pos=top, footholds=footholds)
        self.odometry = LegOdometry(p0, start.trunk_v, float(heading @ start.deck_v), self.s.odometry)
        self.stance = on_deck.copy()
        self.down_since = np.where(on_deck, -np.inf, np.inf)  # when each foot touched down
        self.last_t: float | None = None
        self.now = 0.0
        self.used = np.zeros(4, dtype=bool)

    def calibrate(self, still: Sequence[Reading]) -> None:
        """The gyroscope's bias and the trunk's tilt from readings taken standing still."""
        self.attitude.calibrate([r.gyro for r in still], [r.accel for r in still])

    def __call__(self, reading: Reading) -> RobotState:
        """The state after one tick's readings."""
        dt = 0.0 if self.last_t is None else reading.t - self.last_t
        self.last_t = self.now = reading.t
        R, omega = self.attitude.update(reading.gyro, reading.accel, dt)
        imu_accel = self.attitude.mount @ reading.accel
        odo = self.odometry
        if dt > 0:
            odo.predict(R, imu_accel, dt, self.g)
        legs = leg_terms(self.kin, reading.q)
        qd = reading.qd
        rel = np.empty((3, 4))  # the feet's contact points' velocities relative to the trunk's (world)
        spin = np.empty((3, 4))  # the feet's angular velocities (world)
        for i in range(4):
            j = slice(3 * i, 3 * i + 3)
            rel[:, i] = R @ (np.cross(omega, legs.r[:, i]) + legs.J[i] @ qd[j])
            spin[:, i] = R @ (omega + legs.Jw[i] @ qd[j])
        plan = self.schedule(reading.t)
        deck_n = self.deck.R[:, 2]
        normals = np.where((plan == BOARD)[None, :], deck_n[:, None], UP[:, None])
        rel -= np.cross(spin.T, (self.rho * normals).T).T
        centres = odo.p[:, None] + R @ legs.r
        on_deck = (plan == BOARD) & self.stance
        self.deck = update_deck(self.deck, on_deck, centres, odo.v[:, None] + rel, dt, self.s.deck)
        feet = self._measures(plan, centres, rel, legs.r, R)
        used = odo.correct([m for _, m in feet])
        self.used = np.zeros(4, dtype=bool)
        self.used[[i for i, _ in feet]] = used
        return self._state(reading, R, omega, legs.r, plan)

    def _measures(self, plan: np.ndarray, centres: np.ndarray, rel: np.ndarray, r: np.ndarray,
                  R: np.ndarray) -> list[tuple[int, FootMeasure]]:
        deck, b = self.deck, self.board
        axis = deck.pos - b.axis_depth_m * deck.R[:, 2]
        out = []
        for i in range(4):
            if plan[i] not in (BOARD, GROUND) or not self.now - self.down_since[i] >= self.s.settle_s:
                continue
            offset_z = float((R @ r[:, i])[2])
            if plan[i] == BOARD:
                moving = self.s.odometry.moving_deck
                surface = np.cross(deck.omega, centres[:, i] - axis) if moving else np.zeros(3)
                held = deck.R @ (deck.footholds[:, i] + b.axis_depth_m * UP)
                target = b.deck_height_m - b.axis_depth_m + float(held[2])
                out.append((i, FootMeasure(True, rel[:, i], surface, deck.R[:, 0], offset_z, target)))
            else:
                out.append((i, FootMeasure(False, rel[:, i], np.zeros(3), deck.R[:, 0], offset_z, self.rho)))
        return out

    def _state(self, reading: Reading, R: np.ndarray, omega: np.ndarray, r: np.ndarray,
               plan: np.ndarray) -> RobotState:
        odo, deck, b = self.odometry, self.deck, self.board
        centres = odo.p[:, None] + R @ r
        deck_n = deck.R[:, 2]
        over_deck = deck_n @ (centres - deck.pos[:, None]) - self.rho
        over_floor = centres[2] - self.rho
        deck_side = (plan == BOARD) | ((plan != GROUND) & (np.abs(over_deck) < np.abs(over_floor)))
        gap = np.where(deck_side, over_deck, over_floor)
        touching = gap < self.s.touch_m
        touch = np.where(touching, np.where(deck_side, ON_DECK, ON_FLOOR), 0).astype(np.int8)
        newly = touching & deck_side & ~self.stance & (plan == BOARD)
        if newly.any():  # a foot lands on the deck: where it stands on it
            hold = deck.R.T @ (centres[:, newly] - deck.pos[:, None])
            hold[2] = self.rho
            deck.footholds[:, newly] = hold
        stance = touching & (plan != 0)
        self.down_since = np.where(stance & ~self.stance, self.now, np.where(stance, self.down_since, np.inf))
        self.stance = stance
        normals = np.where(deck_side[None, :], deck_n[:, None], UP[:, None])
        deck_v = odo.u * deck.R[:, 0] + np.cross(deck.omega, b.axis_depth_m * deck_n)
        return RobotState(trunk_pos=odo.p.copy(), trunk_R=R.copy(), trunk_v=odo.v.copy(), trunk_omega=omega.copy(),
                          q=np.array(reading.q), qd=np.array(reading.qd), deck_pos=deck.pos.copy(),
                          deck_R=deck.R.copy(),
                          deck_v=deck_v, deck_omega=deck.omega, foot_touch=touch,
                          contact_points=centres - self.rho * normals)
