"""Model errors of the humanoid twin (``skatelib track HUMANOID_LIB --plant mujoco --perturb``):
what makes the physical robot differ from the figures its motions were planned with, and its
sensors' noise.

Keys (``KEY=VALUE,...``; ``+5%`` relative, a plain number absolute):

* ``mass``: every link's mass and inertia (``+5%``: 5 % heavier; a skate's board keeps its own);
* ``com_x``, ``com_y`` [m]: the whole robot's COM moved in the waist frame (the upper body's
  mass centre shifted by the offset times the robot's mass over the upper body's);
* ``mu``: the floor's friction coefficient;
* ``noise``: the sensors' noise, a multiple of :data:`SENSOR_NOISE` (1: the default figures);
* ``shove`` [N] at ``shove_t`` [s] for 0.1 s: a lateral push on the waist.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from skatelib.library.errors import SkatelibError
from skatelib.library.perturb import perturbation_items
from skatelib.sim.board import BODIES as BOARD_BODIES

if TYPE_CHECKING:  # mujoco is imported where the twin is built (the [sim] extra)
    import mujoco

UPPER_BODY = "torso"
SHOVE_S = 0.1
# The sensors' noise at ``noise=1`` (standard deviations; chosen for a 6-axis F/T sensor of a
# few hundred newtons' range, a MEMS IMU and 16-bit joint encoders; docs/sources.md).
SENSOR_NOISE = {"force_noise_N": 2.0, "torque_noise_Nm": 0.2, "imu_noise_rad": 0.002, "gyro_noise_radps": 0.01,
                "encoder_noise_rad": 1e-4}
# The default model-error set of the humanoid's track: mass +5 %, the COM 2 cm ahead, mu 0.4,
# the sensors' noise.
DEFAULT_HUMANOID_PERTURBATION = "mass=+5%,com_x=0.02,mu=0.4,noise=1"
_BOUNDS = {"mass": (0.5, 2.0), "com_x": (-0.1, 0.1), "com_y": (-0.1, 0.1), "mu": (0.05, 2.0), "noise": (0.0, 20.0),
           "shove": (-500.0, 500.0), "shove_t": (0.0, 60.0)}
HUMANOID_KEYS = tuple(_BOUNDS)


class HumanoidPerturbationError(SkatelibError, ValueError):
    """A ``--perturb`` item the humanoid twin does not know, or a value out of its range."""


@dataclass(frozen=True)
class HumanoidErrors:
    """One twin run's errors (the defaults: as planned, noiseless sensors)."""

    mass_scale: float = 1.0
    com_offset_m: tuple[float, float] = (0.0, 0.0)
    floor_mu: float | None = None
    force_noise_N: float = 0.0
    torque_noise_Nm: float = 0.0
    imu_noise_rad: float = 0.0
    gyro_noise_radps: float = 0.0
    encoder_noise_rad: float = 0.0
    shove_N: float = 0.0
    shove_t_s: float = 0.0

    def apply(self, spec: mujoco.MjSpec) -> mujoco.MjSpec:
        """``spec`` with the links' masses, the COM offset and the floor's friction changed."""
        robot = [b for b in spec.bodies if b.name != "world" and b.name not in BOARD_BODIES]
        total = sum(b.mass for b in robot)
        for b in robot:
            if self.mass_scale != 1.0:
                b.mass *= self.mass_scale
                b.inertia = [self.mass_scale * i for i in b.inertia]
        if any(self.com_offset_m):
            upper = spec.body(UPPER_BODY)
            k = total / upper.mass  # the upper body moves its share of the whole COM's offset
            upper.ipos = [upper.ipos[0] + k * self.com_offset_m[0], upper.ipos[1] + k * self.com_offset_m[1],
                          upper.ipos[2]]
        # MuJoCo takes the larger of two geoms' friction: set both (the soles' and the floor's; the
        # wheels and the deck's grip tape keep theirs)
        if self.floor_mu is not None:
            for g in spec.geoms:
                if g.contype or g.name == "floor":
                    g.friction = [self.floor_mu, g.friction[1], g.friction[2]]
        return spec

    def push(self, d: mujoco.MjData, body: int) -> None:
        """The shove's force on ``body`` while it lasts (else none)."""
        on = self.shove_N != 0.0 and self.shove_t_s <= d.time < self.shove_t_s + SHOVE_S
        d.xfrc_applied[body, 0:3] = (0.0, self.shove_N if on else 0.0, 0.0)


def parse_humanoid_perturbation(text: str) -> HumanoidErrors:
    """``KEY=VALUE,...`` (module docstring) as :class:`HumanoidErrors`.

    Raises:
        HumanoidPerturbationError: Naming the item and the valid keys, or the value and its range.
    """
    e = HumanoidErrors()
    com = [0.0, 0.0]
    for item, key, number, relative in perturbation_items(text, HUMANOID_KEYS, HumanoidPerturbationError):
        value = 1.0 + number / 100.0 if (relative and key == "mass") else number
        if relative and key != "mass":
            raise HumanoidPerturbationError(f"--perturb {item!r}: {key} takes an absolute value")
        lo, hi = _BOUNDS[key]
        if not lo <= value <= hi or not np.isfinite(value):
            raise HumanoidPerturbationError(f"--perturb {item!r}: {key} must lie in [{lo:g}, {hi:g}]")
        if key == "mass":
            e = replace(e, mass_scale=value)
        elif key in ("com_x", "com_y"):
            com[key == "com_y"] = value
        elif key == "mu":
            e = replace(e, floor_mu=value)
        elif key == "noise":
            n = SENSOR_NOISE
            e = replace(e, force_noise_N=value * n["force_noise_N"], torque_noise_Nm=value * n["torque_noise_Nm"],
                        imu_noise_rad=value * n["imu_noise_rad"], gyro_noise_radps=value * n["gyro_noise_radps"],
                        encoder_noise_rad=value * n["encoder_noise_rad"])
        elif key == "shove":
            e = replace(e, shove_N=value)
        else:
            e = replace(e, shove_t_s=value)
    return replace(e, com_offset_m=(com[0], com[1]))
