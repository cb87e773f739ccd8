"""The ``--perturb KEY=VALUE,...`` syntax that the model plant's and the twin's error sets share:
items split on commas, each ``KEY=VALUE`` with a known key given once, the value a finite number,
``+10%`` relative; and the range each key may take (:data:`BOUNDS`). What each key means is the
parser's of each plant (:mod:`skatelib.proving.perturb`, :mod:`skatelib.sim.errors`)."""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Iterator
from dataclasses import dataclass

FACTOR = "x"  # a Bound's unit for a factor of the planned value


@dataclass(frozen=True)
class Bound:
    """The values a key may take: ``low`` to ``high`` in ``unit`` (:data:`FACTOR`: a factor of the
    planned value, whether the item gives a percentage or a value), ``low`` itself excluded when
    ``low_open``."""

    low: float
    high: float
    unit: str
    low_open: bool = False

    def holds(self, value: float) -> bool:
        slack = 1e-9 * max(1.0, abs(self.low), abs(self.high))  # -90% is 0.09999999999999998x
        above = self.low + slack < value if self.low_open else self.low - slack <= value
        return math.isfinite(value) and above and value <= self.high + slack

    def shown(self, value: float) -> str:
        """``value`` in this bound's terms (``2.5x the planned value``, ``0.1 m``)."""
        return f"{value:g}x the planned value" if self.unit == FACTOR else f"{value:g} {self.unit}".rstrip()

    def __str__(self) -> str:
        if self.unit == FACTOR:
            return f"{self.low:g}x to {self.high:g}x the planned value"
        span = f"more than {self.low:g}, up to {self.high:g}" if self.low_open else f"{self.low:g} to {self.high:g}"
        return f"{span} {self.unit}".rstrip()


# What every key of either plant may take. A factor changes a figure of the plan; the bounds keep a
# plant one a controller could meet (a robot a tenth or ten times as heavy as planned at the
# extremes) and a disturbance one a run can measure; far past them a run stopped on a traceback (a
# matrix not positive definite for noise=1e6) or reported a speed of nan for a robot of 1e308 kg.
BOUNDS: dict[str, Bound] = {
    "mass": Bound(0.1, 10.0, FACTOR),  # the robot's mass (the twin: every link's mass and inertia)
    "inertia": Bound(0.1, 10.0, FACTOR),  # the trunk's inertia (model plant)
    "board_mass": Bound(0.1, 10.0, FACTOR),  # the board's mass (model plant; the twin: the deck's)
    "kb": Bound(0.1, 10.0, FACTOR),  # the trucks' roll stiffness
    "bb": Bound(0.1, 10.0, FACTOR),  # the trucks' roll damping
    "rolling": Bound(0.0, 10.0, FACTOR),  # the wheels' rolling resistance (0: none)
    "armature": Bound(0.1, 10.0, FACTOR),  # the rotors' reflected inertia (twin)
    "motor": Bound(0.1, 2.0, FACTOR),  # the motors' torque per commanded torque (twin)
    "tanh": Bound(1.0, 1e4, "s/m"),  # k of Eq. (10) (model plant; the config's range)
    "mu": Bound(0.0, 2.0, "", low_open=True),  # the floor's friction coefficient
    "com": Bound(-0.05, 0.05, "m"),  # the COM's lateral shift (model plant)
    "noise": Bound(0.0, 0.05, "m or rad"),  # the feedback's noise (5x that per second on rates)
    "impulse": Bound(-50.0, 50.0, "N s"),  # a lateral push on the trunk (model plant)
    "impulse_t": Bound(0.0, 60.0, "s"),  # when, from the entry's start (model plant)
    "init": Bound(0.0, 0.05, "m"),  # the start's lateral and vertical error (model plant)
    "payload": Bound(0.0, 10.0, "kg"),  # a mass on the trunk (twin)
    "payload_x": Bound(-0.5, 0.5, "m"),  # where, in the trunk frame (twin)
    "payload_y": Bound(-0.5, 0.5, "m"),
    "payload_z": Bound(-0.5, 0.5, "m"),
    "delay": Bound(0.0, 0.1, "s"),  # the feedback's delay (twin)
    # The robot's sensors on the twin (with --state estimate): added to the IMU's figures (a
    # BMI088's noise, per-run biases and bias walks) and the encoders' quantization. A gyroscope
    # bias of 0.1 rad/s is 6 deg/s (six times the datasheet's zero-rate offset), an accelerometer
    # bias of 0.5 m/s^2 about 50 mg; 10x the noise a poor IMU; 0.05 rad a joint zeroed 3 deg off.
    "gyro_bias": Bound(-0.1, 0.1, "rad/s"),  # on each gyroscope axis, beside the drawn one
    "accel_bias": Bound(-0.5, 0.5, "m/s^2"),  # on each accelerometer axis, beside the drawn one
    "imu_noise": Bound(0.0, 10.0, "x the datasheet's"),  # the IMU's white noise and bias walks
    "encoder_offset": Bound(-0.05, 0.05, "rad"),  # a zero offset on one joint (FL hip)
    "imu_tilt": Bound(-0.1, 0.1, "rad"),  # the IMU mounted rolled about the trunk's x axis
    "sensor_delay": Bound(0.0, 0.02, "s"),  # every reading this late (whole ticks)
}
SENSOR_KEYS = ("gyro_bias", "accel_bias", "imu_noise", "encoder_offset", "imu_tilt", "sensor_delay")
# The sensor errors of a run when --perturb omits their keys: the datasheet's IMU, a joint zeroed a
# tenth of a degree off, the IMU mounted 0.3 deg rolled (a machining tolerance) and one tick
# (2 ms) of delay; no bias beyond the drawn ones (the standstill calibration removes a constant
# gyroscope bias; gyro_bias= tests it).
# The model plant's and the twin's default errors (``skatelib track`` and ``validate --closed-loop``
# without --perturb): 10 % more mass, a 20 % softer deck, twice the rolling resistance, mu 0.5.
DEFAULT_PLANT_PERTURBATION = "mass=+10%,kb=-20%,rolling=+100%,mu=0.5"
DEFAULT_SENSOR_PERTURBATION = ("gyro_bias=0,accel_bias=0,imu_noise=1,encoder_offset=0.002,imu_tilt=0.005,"
                               "sensor_delay=0.002")


def bounded(item: str, key: str, value: float, error: type[Exception]) -> float:
    """``value`` of ``key`` (a factor for a :data:`FACTOR` bound) when :data:`BOUNDS` allow it.

    Raises:
        error: Naming the item, the value and the allowed range.
    """
    bound = BOUNDS[key]
    if not bound.holds(value):
        raise error(f"--perturb {item!r}: {key} would be {bound.shown(value)}; allowed: {bound}")
    return value


def bounds_text(keys: Iterable[str]) -> str:
    """The ranges of ``keys``, for a command's help, keys of one range together: ``mass kb 0.1x to
    10x the planned value; ...``."""
    groups: dict[Bound, list[str]] = {}
    for k in keys:
        groups.setdefault(BOUNDS[k], []).append(k)
    return "; ".join(f"{' '.join(names)} {bound}" for bound, names in groups.items())


def perturbation_items(text: str, keys: Collection[str], error: type[Exception]
                       ) -> Iterator[tuple[str, str, float, bool]]:
    """Each item of ``text`` as (item, key, number, relative).

    Raises:
        error: Naming the item: no ``=``, a key not in ``keys`` (listing them), a key given twice, a
            value that is not a finite number or percentage.
    """
    seen: set[str] = set()
    for item in filter(None, (s.strip() for s in text.split(","))):
        key, sep, value = (s.strip() for s in item.partition("="))
        if not sep or key not in keys:
            raise error(f"--perturb {item!r}: expected KEY=VALUE with KEY one of {', '.join(keys)}")
        if key in seen:
            raise error(f"--perturb {text!r}: {key} is given twice; give each key once")
        seen.add(key)
        relative = value.endswith("%")
        try:
            number = float(value[:-1] if relative else value)
        except ValueError:
            raise error(f"--perturb {item!r}: {value!r} is not a number or a percentage") from None
        if not math.isfinite(number):
            allowed = f"; allowed: {BOUNDS[key]}" if key in BOUNDS else ""
            raise error(f"--perturb {item!r}: {key} must be a finite number{allowed}")
        yield item, key, number, relative
