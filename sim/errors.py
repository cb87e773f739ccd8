"""Model errors of the twin (``skatelib track --plant mujoco --perturb``): what makes the physical
robot and board differ from the figures the library was planned with, and the sensors' errors.

Keys (``KEY=VALUE,...``; ``+10%`` relative, a plain number absolute):

* ``mass``: every robot link's mass and inertia (``+10%``: 10 % heavier);
* ``mu``: the floor's friction coefficient (the deck keeps the library's);
* ``kb``, ``bb``: the trucks' roll stiffness and damping;
* ``rolling``: the wheels' rolling resistance;
* ``armature``: the rotors' reflected inertia;
* ``board_mass``: the deck's mass and inertia;
* ``motor``: the motors' strength (the torque a command delivers; ``-10%``: a tenth weaker);
* ``payload`` [kg] at ``payload_x``, ``payload_y``, ``payload_z`` [m] in the trunk frame;
* ``noise`` [m, rad; 5x per second for velocities] and ``delay`` [s]: the controller's state
  feedback (``--state true``);
* the robot's sensors (``--state estimate``, :mod:`skatelib.sim.sensors`): ``gyro_bias`` [rad/s]
  and ``accel_bias`` [m/s^2] on each axis beside the per-run drawn ones, ``imu_noise`` (a factor
  on the IMU's white noise and bias walks), ``encoder_offset`` [rad] on the FL hip, ``imu_tilt``
  [rad] (the IMU rolled on its mount), ``sensor_delay`` [s]. A sensor key omitted takes its value
  from :data:`skatelib.library.perturb.DEFAULT_SENSOR_PERTURBATION`.

Each value within its range (:data:`skatelib.library.perturb.BOUNDS`; a factor of the planned
figure for ``mass``, ``kb``, ``bb``, ``rolling``, ``armature``, ``board_mass``, ``motor``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from skatelib.library.errors import SkatelibError
from skatelib.library.perturb import DEFAULT_SENSOR_PERTURBATION, SENSOR_KEYS, bounded, perturbation_items
from skatelib.sim.sensors import SensorErrors


class TwinPerturbationError(SkatelibError, ValueError):
    """A ``--perturb`` item the twin does not know, or a value out of its range."""


@dataclass(frozen=True)
class TwinErrors:
    """Scale factors (1: as planned) and absolute figures of one twin run."""

    mass_scale: float = 1.0
    floor_mu: float | None = None  # None: the library's
    kb_scale: float = 1.0
    bb_scale: float = 1.0
    rolling_scale: float = 1.0
    armature_scale: float = 1.0
    deck_mass_scale: float = 1.0
    motor_scale: float = 1.0  # torque delivered per torque commanded
    payload_kg: float = 0.0
    payload_pos_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    noise_std: float = 0.0
    delay_s: float = 0.0
    sensors: SensorErrors = field(default_factory=SensorErrors)


_SCALES = {"mass": "mass_scale", "kb": "kb_scale", "bb": "bb_scale", "rolling": "rolling_scale",
           "armature": "armature_scale", "board_mass": "deck_mass_scale", "motor": "motor_scale"}
_ABSOLUTE = {"mu": "floor_mu", "payload": "payload_kg", "noise": "noise_std", "delay": "delay_s"}
_PAYLOAD_AXES = {"payload_x": 0, "payload_y": 1, "payload_z": 2}
TWIN_KEYS = (*_SCALES, *_ABSOLUTE, *_PAYLOAD_AXES, *SENSOR_KEYS)
# A default set of errors, the same physical ones as the model plant's default.
DEFAULT_TWIN_PERTURBATION = "mass=+10%,mu=0.5,kb=-20%,rolling=+100%"


def parse_twin_perturbation(text: str, library_mu: float) -> TwinErrors:
    """``KEY=VALUE,...`` (module docstring) as :class:`TwinErrors`, each value (a factor for the
    figures that scale) within :data:`skatelib.library.perturb.BOUNDS`.

    Raises:
        TwinPerturbationError: Naming the item and the valid keys, or the value and its allowed range.
    """
    changes: dict[str, float] = {}
    payload_pos = [0.0, 0.0, 0.0]
    sensors = dict(_sensor_values(DEFAULT_SENSOR_PERTURBATION))
    for item, key, number, relative in perturbation_items(text, TWIN_KEYS, TwinPerturbationError):
        if key in SENSOR_KEYS:
            if relative:
                raise TwinPerturbationError(f"--perturb {item!r}: {key} takes an absolute value")
            sensors[key] = bounded(item, key, number, TwinPerturbationError)
        elif key in _SCALES:
            scale = 1.0 + number / 100.0 if relative else number
            changes[_SCALES[key]] = bounded(item, key, scale, TwinPerturbationError)
        elif key == "mu" and relative:
            changes["floor_mu"] = bounded(item, key, library_mu * (1.0 + number / 100.0), TwinPerturbationError)
        elif relative:
            raise TwinPerturbationError(f"--perturb {item!r}: {key} takes an absolute value")
        elif key in _PAYLOAD_AXES:
            payload_pos[_PAYLOAD_AXES[key]] = bounded(item, key, number, TwinPerturbationError)
        else:
            changes[_ABSOLUTE[key]] = bounded(item, key, number, TwinPerturbationError)
    return replace(TwinErrors(), payload_pos_m=(payload_pos[0], payload_pos[1], payload_pos[2]),
                   sensors=sensor_errors(sensors), **changes)


def _sensor_values(text: str) -> dict[str, float]:
    return {key: bounded(item, key, number, TwinPerturbationError)
            for item, key, number, _ in perturbation_items(text, SENSOR_KEYS, TwinPerturbationError)}


def sensor_errors(values: dict[str, float]) -> SensorErrors:
    """The sensors' errors of the sensor keys' ``values`` (omitted ones: the default set's)."""
    v = {**_sensor_values(DEFAULT_SENSOR_PERTURBATION), **values}
    return SensorErrors(noise_scale=v["imu_noise"], gyro_bias_rad_s=(v["gyro_bias"],) * 3,
                        accel_bias_mps2=(v["accel_bias"],) * 3, encoder_offset_rad=v["encoder_offset"],
                        imu_tilt_rad=v["imu_tilt"], delay_s=v["sensor_delay"])
