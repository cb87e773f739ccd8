"""The board alone in the twin, measured the way a bench test would measure a real board: its yaw
rate with the deck held rolled (steering), its roll under a known lateral load, its coasting
deceleration, and the lateral load at which a wheel lifts. Each returns what it measured; what the
optimizer's model predicts is computed elsewhere (``skatelib.pipeline.quadruped.model.board``), so a
test can set the two side by side."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from skatelib.sim.figures import TwinFigures
from skatelib.sim.rolling import RollingResistance, step
from skatelib.sim.scene import scene_spec

WHEELS = ("wheel_fl", "wheel_fr", "wheel_rl", "wheel_rr")


@dataclass(frozen=True)
class Steering:
    """A coasting board held at a roll: the forward speed [m/s] and yaw rate [rad/s] it settles
    at, and K = v sin(phi) / omega_z [m] (Eq. 14's K_board, with its sign: Eq. 14 says -K)."""

    speed_mps: float
    yaw_rate_radps: float

    def k_board_m(self, roll_rad: float) -> float:
        return -self.speed_mps * math.sin(roll_rad) / self.yaw_rate_radps


class _Board(NamedTuple):
    m: Any
    d: Any
    rolling: RollingResistance


def _board(f: TwinFigures, payload_kg: float = 0.0, payload_height_m: float = 0.1) -> _Board:
    """The board alone (with a payload welded on the deck's centre), compiled, and its data."""
    import mujoco

    spec = scene_spec(f, with_robot=False)
    if payload_kg:
        load = spec.body("deck").add_body(name="payload", pos=[0, 0, payload_height_m])
        load.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.15, 0.08, 0.04], mass=payload_kg, contype=0,
                      conaffinity=0, rgba=[0.8, 0.3, 0.2, 1])
    m = spec.compile()
    return _Board(m, mujoco.MjData(m), RollingResistance(m, f.board.rolling_friction_coeff))


def _deck(m: Any, d: Any) -> tuple[int, np.ndarray]:
    deck = m.body("deck").id
    return deck, d.xmat[deck].reshape(3, 3)


def deck_roll(m: Any, d: Any) -> float:
    """The deck's roll about its own x axis [rad] (positive: the left side up)."""
    _, R = _deck(m, d)
    return math.atan2(R[2, 1], R[2, 2])


def _launch(m: Any, d: Any, speed_mps: float) -> None:
    """The board rolling forward at ``speed_mps``, its wheels turning with it."""
    d.qvel[m.joint("deck_free").dofadr[0]] = speed_mps
    for w in WHEELS:
        d.qvel[m.joint(w).dofadr[0]] = speed_mps / m.geom(w).size[0]


def steering(f: TwinFigures, roll_rad: float, speed_mps: float = 0.5, duration_s: float = 2.4) -> Steering:
    """Coast carrying the robot's mass, the deck held at ``roll_rad`` by a torque about its x axis
    (a rider leaning); the speed and yaw rate averaged over the last third."""
    import mujoco

    m, d, rolling = _board(f, f.robot_mass_kg)
    _launch(m, d, speed_mps)
    deck, _ = _deck(m, d)
    v, w = [], []
    held = 0.0  # the integral of the roll error [rad s]
    n = round(duration_s / m.opt.timestep)
    for k in range(n):
        mujoco.mj_forward(m, d)
        _, R = _deck(m, d)
        rate = float(R[:, 0] @ d.cvel[deck][:3])  # about the deck's x axis (world-frame angular velocity)
        error = roll_rad - deck_roll(m, d)
        held += error * m.opt.timestep
        d.xfrc_applied[deck, 3:6] = R[:, 0] * (600.0 * error + 1500.0 * held - 60.0 * rate)
        step(m, d, rolling)
        if k >= 2 * n // 3:
            heading = R[:2, 0] / np.linalg.norm(R[:2, 0])
            v.append(float(heading @ d.qvel[m.joint("deck_free").dofadr[0]:][:2]))
            w.append(float(d.cvel[deck][2]))
    return Steering(float(np.mean(v)), float(np.mean(w)))


def static_roll(f: TwinFigures, load_N: float, y_m: float, settle_s: float = 3.0) -> float:
    """The deck's roll under a vertical load ``load_N`` pressing on its top at (0, ``y_m``) [rad]
    (the load ramped up over the first second, as a bench test loads a board)."""
    m, d, rolling = _board(f)
    _press(_Board(m, d, rolling), load_N, y_m, settle_s)
    return deck_roll(m, d)


def _press(board: _Board, load_N: float, y_m: float, duration_s: float, ramp_s: float = 1.0) -> None:
    """Step the board with the vertical load at (0, ``y_m``) of the deck's top, ramped in over ``ramp_s``."""
    m, d, rolling = board
    import mujoco

    deck, _ = _deck(m, d)
    for k in range(round(duration_s / m.opt.timestep)):
        mujoco.mj_forward(m, d)
        _, R = _deck(m, d)
        point = d.xpos[deck] + R @ np.array([0.0, y_m, 0.0])
        share = min(1.0, (k + 1) * m.opt.timestep / ramp_s)
        d.qfrc_applied[:] = 0.0
        mujoco.mj_applyFT(m, d, np.array([0.0, 0.0, -share * load_N]), np.zeros(3), point, deck, d.qfrc_applied)
        step(m, d, rolling)
        if abs(deck_roll(m, d)) > 1.0:  # tipped over
            return
    mujoco.mj_forward(m, d)


def coast_deceleration(f: TwinFigures, payload_kg: float = 0.0, speed_mps: float = 1.0,
                       duration_s: float = 1.0) -> float:
    """The coasting board's deceleration [m/s^2] (a least-squares slope of its speed over time),
    carrying ``payload_kg`` welded on the deck."""

    m, d, rolling = _board(f, payload_kg)
    _launch(m, d, speed_mps)
    t, v = [], []
    for _ in range(round(0.2 / m.opt.timestep)):  # settle on the contacts first
        step(m, d, rolling)
    for _ in range(round(duration_s / m.opt.timestep)):
        step(m, d, rolling)
        t.append(d.time)
        v.append(float(d.qvel[m.joint("deck_free").dofadr[0]]))
    return float(-np.polyfit(t, v, 1)[0])


def wheel_loads(m: Any, d: Any) -> dict[str, float]:
    """Normal force [N] of each wheel on the floor."""
    import mujoco

    out = dict.fromkeys(WHEELS, 0.0)
    force = np.zeros(6)
    for i in range(d.ncon):
        c = d.contact[i]
        for g in (c.geom1, c.geom2):
            name = m.geom(g).name
            if name in out:
                mujoco.mj_contactForce(m, d, i, force)
                out[name] += float(force[0])
    return out


def lifting_offset(f: TwinFigures, load_N: float, hi_m: float = 0.3, tol_m: float = 5e-4) -> float:
    """The smallest lateral offset [m] of a vertical load ``load_N`` on the deck's top at which a
    wheel no longer carries any of it (bisection over settled boards)."""
    lo = 0.0
    while hi_m - lo > tol_m:
        mid = 0.5 * (lo + hi_m)
        if min(_settled_loads(f, load_N, mid).values()) <= 0.0:
            hi_m = mid
        else:
            lo = mid
    return 0.5 * (lo + hi_m)


def _settled_loads(f: TwinFigures, load_N: float, y_m: float, settle_s: float = 2.5) -> dict[str, float]:
    m, d, rolling = _board(f)
    _press(_Board(m, d, rolling), load_N, y_m, settle_s)
    if abs(deck_roll(m, d)) > 1.0:
        return dict.fromkeys(WHEELS, 0.0)
    return wheel_loads(m, d)
