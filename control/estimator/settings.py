"""What the estimator knows of the board and how its parts are set."""

from __future__ import annotations

from dataclasses import dataclass, field

from skatelib.control.estimator.attitude import AttitudeSettings
from skatelib.control.estimator.deck import DeckSettings
from skatelib.control.estimator.odometry import OdometrySettings


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
    compiled: bool = True
