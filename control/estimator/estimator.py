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

import numpy as np
from skatelib.control.estimator.attitude import AttitudeFilter
from skatelib.control.estimator.deck import DeckEstimate, plane_normal, update_deck
from skatelib.control.estimator.legs import LegTermsBuffer, leg_terms
from skatelib.control.estimator.loads import BodyFigures, compressions
from skatelib.control.estimator.native import CompiledTick, leg_chains, tick_library
from skatelib.control.estimator.odometry import LegOdometry
from skatelib.control.estimator.reading import Reading, check_reading, check_still
from skatelib.control.estimator.settings import BoardGeometry, EstimatorSettings
from skatelib.control.estimator.vec3 import cross
from skatelib.control.feedback import ON_DECK, ON_FLOOR, RobotState
from skatelib.control.kinematics import LegKinematics
from skatelib.library.channels import BOARD, GROUND

UP = np.array([0.0, 0.0, 1.0])


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
        self.native: CompiledTick | None = None  # the C tick, once the first tick has run in it
        self._native_tried = False

    def calibrate(self, still: Sequence[Reading]) -> None:
        """The gyroscope's bias and the trunk's tilt from readings taken standing still; with
        ``mount_from_legs`` the IMU's mounting from the deck feet (the deck level at the start).
        A ``ReadingError`` when there is no reading, or one not finite or of another shape."""
        check_still(still)
        self.attitude.calibrate([r.gyro for r in still], [r.accel for r in still])
        if self.s.mount_from_legs and still and int(self.stance.sum()) >= 3:
            r, _, _ = self.legs(still[-1].q)
            self.attitude.align_mount(plane_normal(r[:, self.stance]))
            self.odometry.horizontal_bias_known(self.s.mounted_bias_mps2)

    def __call__(self, reading: Reading) -> RobotState:
        """The state after one tick's readings. A ``ReadingError`` for a reading of another shape,
        not finite or earlier than the last (:func:`.reading.check_reading`): the estimate is unchanged."""
        check_reading(reading, self.last_t if self.native is None else self.native.last_t)
        if not self._native_tried:
            self._native_tried = True
            self.native = self._compiled()
        if self.native is not None:
            return self._native_tick(reading)
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

    def _compiled(self) -> CompiledTick | None:
        """The C tick loaded with this estimator's state, or None (not asked for, or unavailable)."""
        if not self.s.compiled:
            return None
        lib, chains = tick_library(), leg_chains(self.kin)
        if lib is None or chains is None:
            return None
        native = CompiledTick(lib, chains)
        native.load(*self._native_state())
        return native

    def _native_state(self) -> tuple[dict[str, float], dict[str, np.ndarray]]:
        """The figures, settings and state the C tick starts from (its fields by name)."""
        st, att, odo, deck = self.s, self.attitude, self.odometry, self.deck
        o = st.odometry
        scalars = {"rho": self.rho, "g": self.g, "touch_m": st.touch_m, "settle_s": st.settle_s,
                   "floor_settle_s": st.floor_settle_s, "deck_height": self.board.deck_height_m,
                   "axis_depth": self.board.axis_depth_m, "k_tilt": att.s.k_tilt, "att_gate": att.s.gate,
                   "att_gravity": att.s.gravity_mps2, "foot_velocity2": o.foot_velocity**2,
                   "foot_height2": o.foot_height**2, "gate": o.gate, "deck_prior": st.deck.prior,
                   "turn": float(att.turned), "tilt_from_velocity": float(st.tilt_from_velocity),
                   "moving_deck": float(o.moving_deck), "deck_roll_on": float(st.deck.roll),
                   "has_body": float(self.body is not None), "yaw": deck.yaw, "roll": deck.roll,
                   "yaw_rate": deck.yaw_rate, "roll_rate": deck.roll_rate, "last_t": self.last_t or 0.0,
                   "has_last": float(self.last_t is not None), "now": self.now}
        arrays = {"mount": att.mount, "gyro_bias": att.gyro_bias, "q_proc": odo.process_noise, "R": att.R,
                  "omega": att.omega, "accel": att.accel, "x": odo.x, "P": odo.P, "deck_pos": deck.pos,
                  "footholds": deck.footholds, "deck_R": deck.R, "stance": self.stance, "down_since": self.down_since,
                  "used": self.used, "give": self.give, "accel_world": self.accel_world}
        if self.body is not None:
            scalars["mass"], scalars["compliance"] = self.body.mass_kg, self.body.compliance_m_per_N
            arrays["com_offset"] = self.body.com_offset_m
        return scalars, arrays

    def _native_tick(self, reading: Reading) -> RobotState:
        assert self.native is not None
        t = reading.t
        out = self.native(reading, self.schedule(t), self.schedule(t + self.s.liftoff_s)).copy()  # the state's own
        return RobotState(trunk_pos=out[0:3], trunk_R=out[3:12].reshape(3, 3), trunk_v=out[12:15],
                          trunk_omega=out[15:18], q=np.array(reading.q), qd=np.array(reading.qd),
                          deck_pos=out[18:21], deck_R=out[21:30].reshape(3, 3), deck_v=out[30:33],
                          deck_omega=out[33:36], foot_touch=out[36:40].astype(np.int8),
                          contact_points=out[40:52].reshape(3, 4))

    def sync(self) -> None:
        """With the C tick: its state copied back into the Python parts (attitude, odometry, deck,
        the feet's stance), which it does not update as it runs. The C tick takes the Python parts'
        state, settings and figures once, at the first tick: change them (a bias, the body) before."""
        if self.native is None:
            return
        n = self.native
        self.attitude.R, self.attitude.omega, self.attitude.accel = n.view("R").reshape(3, 3), n.view("omega"), \
            n.view("accel")
        self.odometry.x, self.odometry.P = n.view("x"), n.view("P").reshape(10, 10)
        self.deck = DeckEstimate(yaw=float(n.s.yaw), roll=float(n.s.roll), pos=n.view("deck_pos"),
                                 footholds=n.view("footholds").reshape(3, 4), yaw_rate=float(n.s.yaw_rate),
                                 roll_rate=float(n.s.roll_rate))
        self.stance, self.used = n.view("stance") != 0, n.view("used") != 0
        self.last_t, self.now = n.last_t, float(n.s.now)
        self.down_since, self.give, self.accel_world = n.view("down_since"), n.view("give"), n.view("accel_world")

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
