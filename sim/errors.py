"""Model errors of the twin (``skatelib track --plant mujoco --perturb``): what makes the physical
robot and board differ from the figures the library was planned with, and the sensors' errors.

Keys (``KEY=VALUE,...``; ``+10%`` relative to the planned figure, a plain number absolute, in the
unit of the model plant's key of the same name, :mod:`skatelib.proving.perturb`):

* ``mass``: every robot link's mass and inertia (``+10%``: 10 % heavier; ``9.37``: a 9.37 kg robot);
* ``mu``: the floor's friction coefficient (the deck keeps the library's);
* ``kb``, ``bb``: the trucks' roll stiffness [N m/rad] and damping [N m s/rad] (the deck's, about
  its roll axis);
* ``rolling``: the wheels' rolling resistance [N] at the planned weight (the force follows the
  wheels' load, as on the model plant);
* ``armature``: the rotors' reflected inertia [kg m^2], each joint's;
* ``board_mass``: the deck's mass and inertia (a percentage: the deck's; a plain number: the whole
  board's mass [kg], as on the model plant, the deck taking the change and the hangers and wheels
  as planned);
* ``motor``: the motors' strength, the torque a command delivers [N m per commanded N m]
  (``-10%`` or ``0.9``: a tenth weaker);
* ``payload`` [kg] at ``payload_x``, ``payload_y``, ``payload_z`` [m] in the trunk frame;
* ``noise`` [m, rad; 5x per second for velocities] and ``delay`` [s]: the controller's state
  feedback (``--state true``);
* the robot's sensors (``--state estimate``, :mod:`skatelib.sim.sensors`): ``gyro_bias`` [rad/s]
  and ``accel_bias`` [m/s^2] on each axis beside the per-run drawn ones, ``imu_noise`` (a factor
  on the IMU's white noise and bias walks), ``encoder_offset`` [rad] on the FL hip, ``imu_tilt``
  [rad] (the IMU rolled on its mount), ``sensor_delay`` [s]. A sensor key omitted takes its value
  from :data:`skatelib.library.perturb.DEFAULT_SENSOR_PERTURBATION`.

Each value within its range (:data:`skatelib.library.perturb.BOUNDS`; a factor of the planned
figure for ``mass``, ``kb``, ``bb``, ``rolling``, ``armature``, ``board_mass``, ``motor``, what
the twin applies: a plain number is divided by the twin's planned figure, :class:`TwinFigures`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from skatelib.library.errors import SkatelibError
from skatelib.library.perturb import BOUNDS, DEFAULT_SENSOR_PERTURBATION, SENSOR_KEYS, bounded, perturbation_items
from skatelib.sim.figures import GEAR_RATIO, ROTOR_INERTIA_KGM2, TwinFigures
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
# What a plain number of a scale key is: the quantity and its unit, those of the model plant's key.
_ABSOLUTE_UNITS = {"mass": ("the robot's mass", "kg"), "kb": ("the deck's roll stiffness", "N m/rad"),
                   "bb": ("the deck's roll damping", "N m s/rad"),
                   "rolling": ("the rolling resistance at the planned weight", "N"),
                   "armature": ("each joint's rotor inertia", "kg m^2"),
                   "board_mass": ("the board's mass", "kg"), "motor": ("the motors' strength", "N m per commanded N m")}
_ABSOLUTE = {"mu": "floor_mu", "payload": "payload_kg", "noise": "noise_std", "delay": "delay_s"}
_PAYLOAD_AXES = {"payload_x": 0, "payload_y": 1, "payload_z": 2}
TWIN_KEYS = (*_SCALES, *_ABSOLUTE, *_PAYLOAD_AXES, *SENSOR_KEYS)
# A default set of errors, the same physical ones as the model plant's default.
DEFAULT_TWIN_PERTURBATION = "mass=+10%,mu=0.5,kb=-20%,rolling=+100%"


def parse_twin_perturbation(text: str, planned: TwinFigures | float) -> TwinErrors:
    """``KEY=VALUE,...`` (module docstring) as :class:`TwinErrors`, each value (a factor for the
    figures that scale) within :data:`skatelib.library.perturb.BOUNDS`.

    Args:
        text: The errors.
        planned: The twin's planned figures, which a plain number of a scale key is converted
            against (``mass=9.37`` [kg] of a robot planned at 8.52 kg: 1.1x); or the library's
            friction coefficient alone, which takes the scale keys as percentages only (``armature``
            and ``motor`` excepted: their planned figures are the same for every library).

    Raises:
        TwinPerturbationError: Naming the item and the valid keys, or the value and its allowed range;
            a plain number of a scale key whose planned figure is not given, naming its unit.
    """
    figures = planned if isinstance(planned, TwinFigures) else None
    library_mu = planned.friction_mu if isinstance(planned, TwinFigures) else planned
    changes: dict[str, float] = {}
    payload_pos = [0.0, 0.0, 0.0]
    sensors = dict(_sensor_values(DEFAULT_SENSOR_PERTURBATION))
    for item, key, number, relative in perturbation_items(text, TWIN_KEYS, TwinPerturbationError):
        if key in SENSOR_KEYS:
            if relative:
                raise TwinPerturbationError(f"--perturb {item!r}: {key} takes an absolute value")
            sensors[key] = bounded(item, key, number, TwinPerturbationError)
        elif key in _SCALES:
            scale = 1.0 + number / 100.0 if relative else _factor(item, key, number, figures)
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


def planned_figure(key: str, figures: TwinFigures | None) -> tuple[float, float] | None:
    """The twin's planned value of a scale key's quantity in its unit (:data:`_ABSOLUTE_UNITS`) and
    the part of it that the key's factor leaves alone (``board_mass`` scales the deck, not the
    hangers and wheels), or None when it is the library's and ``figures`` are not given."""
    if key == "motor":
        return 1.0, 0.0
    if key == "armature":
        return ROTOR_INERTIA_KGM2 * GEAR_RATIO**2, 0.0  # sim.robot's, whatever the library
    if figures is None:
        return None
    b = figures.board
    weight_N = (figures.robot_mass_kg + b.mass_kg) * figures.gravity_mps2
    return {"mass": (figures.robot_mass_kg, 0.0), "kb": (b.roll_stiffness_Nm_per_rad, 0.0),
            "bb": (b.roll_damping_Nms_per_rad, 0.0), "rolling": (b.rolling_friction_coeff * weight_N, 0.0),
            "board_mass": (b.mass_kg, b.mass_kg - b.deck_mass_kg)}[key]


def _factor(item: str, key: str, value: float, figures: TwinFigures | None) -> float:
    """The factor the twin applies for the absolute ``value`` of the scale key ``key``.

    Raises:
        TwinPerturbationError: The planned figure is not given (asking for a percentage, naming
            the unit), or the factor is out of its range (naming the planned figure).
    """
    what, unit = _ABSOLUTE_UNITS[key]
    planned = planned_figure(key, figures)
    if planned is None:
        raise TwinPerturbationError(f"--perturb {item!r}: give {key} as a percentage of the planned value "
                                    f"({key}=+10%): a plain number would be {what} [{unit}], and the twin's "
                                    "planned figures that convert it were not given")
    total, fixed = planned
    scaled = total - fixed
    factor = (value - fixed) / scaled if scaled else (1.0 if value == fixed else math.inf)
    bound = BOUNDS[key]
    if not bound.holds(factor):
        part = f"; the factor scales the deck's {scaled:g} kg, the hangers and wheels as planned" if fixed else ""
        raise TwinPerturbationError(f"--perturb {item!r}: {key} would be {bound.shown(factor)} ({value:g} {unit} of "
                                    f"the planned {total:g} {unit}{part}); allowed: {bound}")
    return factor


def _sensor_values(text: str) -> dict[str, float]:
    return {key: bounded(item, key, number, TwinPerturbationError)
            for item, key, number, _ in perturbation_items(text, SENSOR_KEYS, TwinPerturbationError)}


def sensor_errors(values: dict[str, float]) -> SensorErrors:
    """The sensors' errors of the sensor keys' ``values`` (omitted ones: the default set's)."""
    v = {**_sensor_values(DEFAULT_SENSOR_PERTURBATION), **values}
    return SensorErrors(noise_scale=v["imu_noise"], gyro_bias_rad_s=(v["gyro_bias"],) * 3,
                        accel_bias_mps2=(v["accel_bias"],) * 3, encoder_offset_rad=v["encoder_offset"],
                        imu_tilt_rad=v["imu_tilt"], delay_s=v["sensor_delay"])
