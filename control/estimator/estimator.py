"""The robot's state estimator at every whole-body tick (500 Hz class): the IMU and the twelve
joint encoders in, a :class:`skatelib.control.feedback.RobotState` out (what the controller reads
of robot and board). Which feet stand, and on what, comes from the entry's contact schedule, as
CyberDog2 has no foot force sensors: a foot planned on the deck or the ground that is within
``touch_m`` of its surface (its centre's height over the ground, or over the deck's plane) counts
as touching; one whose velocity disagrees with its surface's is left out of the velocity
correction (:mod:`.odometry`), so a foot that lands late or early does not pull the estimate.
A loaded foot gives (:mod:`.loads`): its centre sits that much less than its radius over its
surface, in the deck's plane, the deck's top, the trunk's height and the touch test alike.

The world frame is the one the robot starts in: the ride's first planned pose (position, heading)
and speed, standing on a level deck of the board's known height.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from skatelib.control.estimator.attitude import AttitudeFilter, AttitudeSettings
from skatelib.control.estimator.deck import DeckEstimate, DeckSettings, plane_normal, update_deck
from skatelib.control.estimator.legs import LegTermsBuffer, leg_terms
from skatelib.control.estimator.loads import BodyFigures, compressions
from skatelib.control.estimator.odometry import LegOdometry, OdometrySettings
from skatelib.control.estimator.vec3 import cross
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
    ``settle_s``: a deck foot's velocity is used this long after it touches down (its impact over)
    [s]; ``floor_settle_s``: a floor foot's, this long (it slides while its load builds) [s];
    ``mount_from_legs``: at the standstill, the trunk's up from its three or more feet on the level
    deck, and the IMU's mounting turned to read gravity along it (False: the IMU's axes taken for
    the trunk's); ``liftoff_s``: a floor foot's velocity is not used this long before its planned
    lift-off (its load going, it slips back) [s]; ``tilt_from_velocity``: the attitude's tilt
    reference is the accelerometer's reading less the trunk's acceleration as the position filter
    has it (:mod:`.attitude`; False: the reading itself, which takes a deceleration for gravity);
    ``mounted_bias_mps2``: with the mounting from the legs, what is left of the accelerometer's
    horizontal bias (1 sigma, trunk x and y) [m/s^2]: the mounting holds the rest (levelled on
    the standstill's reading, the bias cancels in the horizontal acceleration), so the filter's
    bias state may not take up there what a slipping floor foot reads (it would then drift the
    velocity through every coast after)."""

    attitude: AttitudeSettings = field(default_factory=AttitudeSettings)
    odometry: OdometrySettings = field(default_factory=OdometrySettings)
    deck: DeckSettings = field(default_factory=DeckSettings)
    touch_m: float = 0.005
    settle_s: float = 0.02
    floor_settle_s: float = 0.06
    mount_from_legs: bool = True
    liftoff_s: float = 0.15
    tilt_from_velocity: bool = True
    mounted_bias_mps2: float = 1e-3


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
        body: The robot's mass, centre of mass and feet's compliance (None: rigid feet).
    """

    def __init__(self, kin: LegKinematics, board: BoardGeometry, schedule: Callable[[float], np.ndarray],  # noqa: PLR0913
                 start: RobotState, settings: EstimatorSettings | None = None, gravity_mps2: float = 9.81,
                 imu_mount: np.ndarray | None = None, body: BodyFigures | None = None):
        self.kin, self.board, self.schedule = kin, board, schedule
        self.body = body
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
        self.legs = LegTermsBuffer(kin)
        self.give = np.zeros(4)  # each stance foot's give under its static load [m] (.loads)
        self.accel_world = np.zeros(3)  # the trunk's acceleration over the last tick as the filter has it [m/s^2]

    def calibrate(self, still: Sequence[Reading]) -> None:
        """The gyroscope's bias and the trunk's tilt from readings taken standing still; with
        ``mount_from_legs`` the IMU's mounting from the deck feet (the deck level at the start)."""
        self.attitude.calibrate([r.gyro for r in still], [r.accel for r in still])
        if self.s.mount_from_legs and still and int(self.stance.sum()) >= 3:
            r, _, _ = self.legs(still[-1].q)
            self.attitude.align_mount(plane_normal(r[:, self.stance]))
            self.odometry.horizontal_bias_known(self.s.mounted_bias_mps2)

    def __call__(self, reading: Reading) -> RobotState:
        """The state after one tick's readings."""
        dt = 0.0 if self.last_t is None else reading.t - self.last_t
        self.last_t = self.now = reading.t
        odo = self.odometry
        known = self.accel_world if self.s.tilt_from_velocity else None
        R, omega = self.attitude.update(reading.gyro, reading.accel, dt, known,
                                        odo.x[7:10] if known is not None else None)
        v_before = odo.v.copy()
        if dt > 0:
            odo.predict(R, self.attitude.accel, dt, self.g)
        r, J, Jw = self.legs(reading.q)
        qd = np.asarray(reading.qd, dtype=float).reshape(4, 3, 1)
        # the feet's contact points' velocities relative to the trunk's, and their angular velocities (world)
        rel = R @ (cross(omega, r) + (J @ qd)[:, :, 0].T)
        spin = R @ (omega[:, None] + (Jw @ qd)[:, :, 0].T)
        plan = self.schedule(reading.t)
        board = plan == BOARD
        normals = np.where(board, self.deck.R[:, 2:3], UP[:, None])
        rel -= cross(spin, self.rho * normals)
        centres = odo.p[:, None] + R @ r
        if self.body is not None:
            self.give = compressions(centres, self.stance & (plan != 0), odo.p + R @ self.body.com_offset_m, self.body,
                                     self.g)
        rigid = centres + self.give * normals  # where the centres would be on rigid feet
        self.deck = update_deck(self.deck, board & self.stance, rigid, odo.v[:, None] + rel, dt, self.s.deck)
        self.used = self._correct(plan, centres, rel, r, R)
        if dt > 0:
            self.accel_world = (odo.v - v_before) / dt
        return self._state(reading, R, omega, r, plan)

    def _correct(self, plan: np.ndarray, centres: np.ndarray, rel: np.ndarray, r: np.ndarray,
                 R: np.ndarray) -> np.ndarray:
        """The filter's correction by the feet that stand (planned on a surface, their touchdown
        ``settle_s`` past): returns which were used."""
        used = np.zeros(4, dtype=bool)
        board = plan == BOARD
        # a floor foot about to lift off pushes with its load going: it slips back, where its row
        # has it stay put
        lifting = (plan == GROUND) & (self.schedule(self.now + self.s.liftoff_s) != GROUND)
        settle = np.where(board, self.s.settle_s, self.s.floor_settle_s)
        idx = np.flatnonzero((board | (plan == GROUND)) & (self.now - self.down_since >= settle) & ~lifting)
        if not len(idx):
            return used
        deck, b = self.deck, self.board
        on_deck = board[idx]
        surface = np.zeros((3, len(idx)))
        if self.s.odometry.moving_deck and on_deck.any():
            axis = deck.pos - b.axis_depth_m * deck.R[:, 2]
            surface[:, on_deck] = cross(deck.omega, centres[:, idx[on_deck]] - axis[:, None])
        held = deck.footholds[:, idx].copy()
        held[2] += b.axis_depth_m
        target = np.where(on_deck, b.deck_height_m - b.axis_depth_m + deck.R[2] @ held, self.rho)
        target = target - self.give[idx]
        used[idx] = self.odometry.correct_feet(on_deck, rel[:, idx], surface, deck.R[:, 0], target - R[2] @ r[:, idx])
        return used

    def _state(self, reading: Reading, R: np.ndarray, omega: np.ndarray, r: np.ndarray,
               plan: np.ndarray) -> RobotState:
        odo, deck, b = self.odometry, self.deck, self.board
        centres = odo.p[:, None] + R @ r
        deck_n = deck.R[:, 2]
        over_deck = deck_n @ (centres - deck.pos[:, None]) - self.rho
        over_floor = centres[2] - self.rho
        deck_side = (plan == BOARD) | ((plan != GROUND) & (np.abs(over_deck) < np.abs(over_floor)))
        gap = np.where(deck_side, over_deck, over_floor) + self.give  # from where a loaded foot's centre sits
        touching = gap < self.s.touch_m
        touch = np.where(touching, np.where(deck_side, ON_DECK, ON_FLOOR), 0).astype(np.int8)
        newly = touching & deck_side & ~self.stance & (plan == BOARD)
        if newly.any():  # a foot lands on the deck: where it stands on it
            hold = deck.R.T @ (centres[:, newly] + self.give[newly] * deck_n[:, None] - deck.pos[:, None])
            hold[2] = self.rho
            deck.footholds[:, newly] = hold
        stance = touching & (plan != 0)
        self.down_since = np.where(stance & ~self.stance, self.now, np.where(stance, self.down_since, np.inf))
        self.stance = stance
        normals = np.where(deck_side, deck_n[:, None], UP[:, None])
        omega_b = deck.omega
        deck_v = odo.u * deck.R[:, 0] + cross(omega_b, b.axis_depth_m * deck_n)
        return RobotState(trunk_pos=odo.p.copy(), trunk_R=R.copy(), trunk_v=odo.v.copy(), trunk_omega=omega.copy(),
                          q=np.array(reading.q), qd=np.array(reading.qd), deck_pos=deck.pos.copy(),
                          deck_R=deck.R.copy(), deck_v=deck_v, deck_omega=omega_b, foot_touch=touch,
                          contact_points=centres - self.rho * normals)
