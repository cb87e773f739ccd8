"""What a certificate draws from: the config's ``[certify]`` table. Each model error is a range
``[low, high]`` drawn uniformly, in the terms of the twin's ``--perturb`` key it sets
(:mod:`skatelib.sim.errors`): a factor of the planned figure, or an absolute value. The shove's
size is drawn uniformly from ``shove_Ns``, its direction uniformly in the horizontal plane, its
time uniformly over the entry (the transfer and the ride after it are not shoved)."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from skatelib.library.errors import ConfigError
from skatelib.library.perturb import BOUNDS


def _range(key: str | None, default: tuple[float, float], doc: str) -> Any:
    """A ``[low, high]`` field; ``key``: the ``--perturb`` key whose range (:data:`BOUNDS`) holds it."""
    return field(default=default, metadata={"doc": doc, "perturb": key})


STATES = ("true", "estimate")


@dataclass(frozen=True)
class CertifySpec:
    """The ``[certify]`` table: how many rides, the seed, and the distributions of a ride's errors."""

    samples: int = field(default=100, metadata={"lo": 1, "hi": 100_000, "doc": "Rides per entry."})
    seed: int = field(default=0, metadata={"lo": 0, "hi": 2**32 - 1, "doc": "Seed of every draw."})
    state: str = field(default="true", metadata={
        "doc": "What the controller is fed: 'true' (the twin's state) or 'estimate' (its estimator on the "
               "twin's sensors, with the sensor errors drawn)."})
    robot_mass: tuple[float, ...] = _range("mass", (0.9, 1.1), "Every robot link's mass and inertia [x planned].")
    payload_kg: tuple[float, ...] = _range("payload", (0.0, 1.0), "A payload on the trunk [kg].")
    payload_x_m: tuple[float, ...] = _range("payload_x", (-0.05, 0.05), "Its place, trunk frame x [m].")
    payload_y_m: tuple[float, ...] = _range("payload_y", (-0.03, 0.03), "Its place, trunk frame y [m].")
    payload_z_m: tuple[float, ...] = _range("payload_z", (0.0, 0.05), "Its place, trunk frame z [m].")
    floor_mu: tuple[float, ...] = _range("mu", (0.4, 0.8), "The floor's friction coefficient.")
    truck_stiffness: tuple[float, ...] = _range("kb", (0.7, 1.3), "The trucks' roll stiffness [x planned].")
    rolling: tuple[float, ...] = _range("rolling", (0.5, 2.0), "The wheels' rolling resistance [x planned].")
    deck_mass: tuple[float, ...] = _range("board_mass", (0.8, 1.2), "The deck's mass and inertia [x planned].")
    motor_strength: tuple[float, ...] = _range("motor", (0.85, 1.05), "Torque delivered per torque commanded [x].")
    gyro_bias_rad_s: tuple[float, ...] = _range("gyro_bias", (-0.01, 0.01), "Gyroscope bias, each axis [rad/s].")
    accel_bias_mps2: tuple[float, ...] = _range("accel_bias", (-0.1, 0.1), "Accelerometer bias, each axis [m/s^2].")
    imu_tilt_rad: tuple[float, ...] = _range("imu_tilt", (-0.01, 0.01), "The IMU's mount rolled [rad].")
    encoder_offset_rad: tuple[float, ...] = _range("encoder_offset", (-0.005, 0.005), "FL hip zero offset [rad].")
    shove_Ns: tuple[float, ...] = _range(None, (0.0, 2.0), "The shove's size, horizontal [N s].")

    def ranges(self) -> dict[str, tuple[float, float]]:
        """Each drawn quantity's ``(low, high)``, in field order."""
        return {f.name: (float(getattr(self, f.name)[0]), float(getattr(self, f.name)[1]))
                for f in dataclasses.fields(self) if "perturb" in f.metadata}

    def as_json(self) -> str:
        """The table as stored with a certificate (sorted keys: equal specs, equal text)."""
        return json.dumps(dataclasses.asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> CertifySpec:
        d: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in json.loads(text).items()}
        return cls(**d)


SHOVE_MAX_NS = 50.0  # the model plant's impulse bound, the largest shove a table may ask for


def check_spec(spec: CertifySpec, path: Path | str, prefix: str = "certify") -> CertifySpec:
    """``spec`` when every range is two numbers, low <= high, inside its key's allowed range.

    Raises:
        ConfigError: Naming the file, the key, the value and what is allowed.
    """
    if spec.state not in STATES:
        raise ConfigError(path, f"{prefix}.state", f"{spec.state!r}: use one of {', '.join(map(repr, STATES))}")
    for f in dataclasses.fields(spec):
        if "perturb" not in f.metadata:
            continue
        value, key, where = getattr(spec, f.name), f.metadata["perturb"], f"{prefix}.{f.name}"
        if len(value) != 2 or value[0] > value[1]:
            raise ConfigError(path, where, f"{list(value)}: give [low, high] with low <= high ({f.metadata['doc']})")
        lo, hi = (0.0, SHOVE_MAX_NS) if key is None else (BOUNDS[key].low, BOUNDS[key].high)
        open_low = key is not None and BOUNDS[key].low_open
        if value[0] < lo or value[1] > hi or (open_low and value[0] <= lo):
            allowed = f"{lo:g} to {hi:g}" if key is None else str(BOUNDS[key])
            raise ConfigError(path, where, f"{list(value)} is outside what it may take: {allowed}")
    return spec
