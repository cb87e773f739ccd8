"""What the optimizer's board model (:mod:`skatelib.pipeline.quadruped.model.board`) predicts for the
board on its own, in the terms a bench test measures a real board in: the yaw rate at a held roll
(Eq. 14), the roll under a vertical load off the centre line (Eq. 6-8 in equilibrium), the coasting
deceleration (Eq. 9b-10) and the load offset at which a wheel lifts (the wheel-load limit). The
twin's measurements of the same things are in ``skatelib.sim.board_checks``."""

from __future__ import annotations

import math

from skatelib.pipeline.quadruped.model.board import BoardModel


def yaw_rate(board: BoardModel, roll_rad: float, speed_mps: float) -> float:
    """Eq. (14): omega_z = -v sin(phi) / K_board [rad/s]."""
    return -speed_mps * math.sin(roll_rad) / board.K_board_m


def _load_moment(board: BoardModel, load_N: float, y_m: float, phi: float) -> float:
    """The roll moment of a vertical load on the deck's top at (0, y) about the roll axis [N m]."""
    h = board.roll_axis_depth_m
    return -load_N * (y_m * math.cos(phi) - h * math.sin(phi))


def _balance(board: BoardModel, load_N: float, y_m: float, phi: float) -> float:
    return float(board.roll_torque(phi, 0.0)) + _load_moment(board, load_N, y_m, phi)


def static_roll(board: BoardModel, load_N: float, y_m: float, limit_rad: float = 0.6) -> float | None:
    """The deck's roll [rad] under ``load_N`` pressing down on its top at (0, ``y_m``): the smallest
    equilibrium reached from the level deck, or None when there is none within ``limit_rad`` (the
    deck snaps over)."""
    step = 1e-3 * math.copysign(1.0, -y_m) if y_m else 1e-3
    phi, f = 0.0, _balance(board, load_N, y_m, 0.0)
    while abs(phi) < limit_rad:
        nxt = phi + step
        g = _balance(board, load_N, y_m, nxt)
        if f == 0.0 or f * g <= 0.0:
            lo, hi = phi, nxt
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if _balance(board, load_N, y_m, lo) * _balance(board, load_N, y_m, mid) <= 0.0:
                    hi = mid
                else:
                    lo = mid
            return 0.5 * (lo + hi)
        phi, f = nxt, g
    return None


def coast_deceleration(board: BoardModel, payload_kg: float, speed_mps: float = 1.0) -> float:
    """The coasting board's deceleration carrying ``payload_kg`` [m/s^2], Eq. (9b)-(10) with the
    rolling resistance of the wheels' load."""
    mass = board.mass_kg + payload_kg
    return float(board.friction_force(speed_mps, board.wheel_load(payload_kg * board.gravity_mps2))) / mass


def lifting_offset(board: BoardModel, load_N: float, hi_m: float = 0.3) -> float:
    """The smallest offset [m] of a vertical ``load_N`` on the deck's top at which the trucks'
    torque in equilibrium (the load's moment and the deck's weight's) reaches what the wheel track
    holds, or the deck has no equilibrium."""

    def lifts(y: float) -> bool:
        phi = static_roll(board, load_N, y)
        if phi is None:
            return True
        return abs(float(board.truck_torque(phi))) >= board.wheel_load(load_N) * board.wheel_track_m / 2

    lo, hi = 0.0, hi_m
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if lifts(mid) else (mid, hi)
    return 0.5 * (lo + hi)
