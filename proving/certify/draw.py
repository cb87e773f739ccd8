"""The draws of a certificate. Every entry's draws come from its own ``numpy.random.SeedSequence``
(the table's seed, spawned by the entry's key) and each draw from a child of it; a draw is then
made, from one 32-bit seed alone, by ``numpy.random.default_rng(seed)``: the same seed gives the
same errors and shove on any machine and backend, and ``skatelib track --entry K --draw SEED``
rides that one draw again."""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np
from skatelib.proving.certify.spec import CertifySpec
from skatelib.sim.errors import TwinErrors, sensor_errors


def draw_seeds(spec: CertifySpec, key: str, samples: int | None = None) -> list[int]:
    """The seeds of an entry's draws (``samples``, or the table's): the entry's SeedSequence
    (spawn key: the CRC-32 of its key) spawned once per draw, each child's first 32-bit word."""
    n = spec.samples if samples is None else samples
    entry = np.random.SeedSequence(spec.seed, spawn_key=(zlib.crc32(key.encode()),))
    return [int(child.generate_state(1, np.uint32)[0]) for child in entry.spawn(n)]


@dataclass(frozen=True)
class Draw:
    """One ride's errors (:class:`skatelib.sim.errors.TwinErrors`), its shove (size [N s],
    direction [rad] from the world's x axis, when: a fraction of the entry) and the seed of the
    ride's own noise (the sensors')."""

    seed: int
    errors: TwinErrors
    shove_Ns: float
    shove_direction_rad: float
    shove_at: float
    noise_seed: int

    def impulse(self) -> tuple[float, float, float]:
        """The shove as a world-frame impulse [N s]."""
        c, s = np.cos(self.shove_direction_rad), np.sin(self.shove_direction_rad)
        return float(self.shove_Ns * c), float(self.shove_Ns * s), 0.0


def make_draw(spec: CertifySpec, seed: int) -> Draw:
    """The draw of ``seed`` under ``spec``'s distributions (uniform in each range, in field order)."""
    rng = np.random.default_rng(seed)
    v = {name: float(rng.uniform(lo, hi)) for name, (lo, hi) in spec.ranges().items()}
    sensors = sensor_errors({"gyro_bias": v["gyro_bias_rad_s"], "accel_bias": v["accel_bias_mps2"],
                             "imu_tilt": v["imu_tilt_rad"], "encoder_offset": v["encoder_offset_rad"]})
    errors = TwinErrors(mass_scale=v["robot_mass"], floor_mu=v["floor_mu"], kb_scale=v["truck_stiffness"],
                        rolling_scale=v["rolling"], deck_mass_scale=v["deck_mass"], motor_scale=v["motor_strength"],
                        payload_kg=v["payload_kg"], sensors=sensors,
                        payload_pos_m=(v["payload_x_m"], v["payload_y_m"], v["payload_z_m"]))
    return Draw(seed=seed, errors=errors, shove_Ns=v["shove_Ns"],
                shove_direction_rad=float(rng.uniform(-np.pi, np.pi)), shove_at=float(rng.uniform(0.0, 1.0)),
                noise_seed=int(rng.integers(0, 2**32 - 1)))
