"""The controller's feedback on the twin from the robot's own sensors: the twin's IMU and encoders
(:mod:`skatelib.sim.sensors`) read at every tick, the robot side's estimator
(:mod:`skatelib.control.estimator.estimator`) on them, and the estimator's error against the
twin's truth (trunk velocity, board speed, board roll: RMS and worst).

The estimator is given nothing of the twin but the readings: its start is the ride's planned first
pose and speed (where the plant is placed), its board geometry the library's."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from skatelib.control.estimator.estimator import BoardGeometry, EstimatorSettings, StateEstimator
from skatelib.control.estimator.loads import BodyFigures
from skatelib.control.feedback import ON_DECK, RobotState
from skatelib.control.kinematics import LegKinematics
from skatelib.control.params import SkateParams
from skatelib.library.channels import BOARD
from skatelib.library.rotations import board_rotations, rpy_matrices
from skatelib.sim.sensors import SensorErrors, TwinSensors

CALIBRATION_S = 2.0  # the robot stands still this long before it rides (its gyroscope's bias)


@dataclass
class EstimatorErrors:
    """The estimate against the truth, per tick: the trunk's velocity (norm of the difference)
    [m/s], the board's speed along its heading [m/s], the deck's roll [rad]."""

    trunk_v: list[float] = field(default_factory=list)
    board_speed: list[float] = field(default_factory=list)
    board_roll: list[float] = field(default_factory=list)

    def add(self, est: RobotState, true: Any) -> None:
        self.trunk_v.append(float(np.linalg.norm(est.trunk_v - true.trunk_v)))
        h = true.deck_R[:, 0]
        self.board_speed.append(float(est.deck_v @ est.deck_R[:, 0] - true.deck_v @ h))
        self.board_roll.append(float(est.deck_roll - true.deck_roll))

    @staticmethod
    def _rms(x: list[float]) -> float:
        return math.sqrt(float(np.mean(np.square(x)))) if x else math.nan

    @staticmethod
    def _worst(x: list[float]) -> float:
        return float(np.max(np.abs(x))) if x else math.nan

    def summary(self) -> dict[str, float]:
        """RMS and worst of each error."""
        return {f"{k}_{w}": (self._rms if w == "rms" else self._worst)(getattr(self, k))
                for k in ("trunk_v", "board_speed", "board_roll") for w in ("rms", "worst")}


def start_state(x0: np.ndarray, board0: np.ndarray, from_velocity_mps: float, on_deck: np.ndarray,
                com_offset_m: np.ndarray) -> RobotState:
    """The state the robot starts a ride in, as it knows it: the plan's first pose, the deck level
    at the plan's place and heading, rolling at ``from_velocity_mps``."""
    R = rpy_matrices(x0[3:6])
    deck_R = board_rotations(float(board0[3]), 0.0)
    v = from_velocity_mps * deck_R[:, 0]
    return RobotState(trunk_pos=x0[0:3] - R @ com_offset_m, trunk_R=R, trunk_v=v, trunk_omega=np.zeros(3),
                      q=x0[12:24].copy(), qd=np.zeros(12), deck_pos=np.array([board0[0], board0[1], 0.0]),
                      deck_R=deck_R, deck_v=v, deck_omega=np.zeros(3),
                      foot_touch=np.where(on_deck, ON_DECK, 0).astype(np.int8), contact_points=np.zeros((3, 4)))


class EstimatedFeedback:
    """Per tick: the twin's sensors read, the estimator's state (what the controller is fed), and
    its error against the twin's true state."""

    def __init__(self, plant: Any, lib: Any, p: SkateParams, schedule: Callable[[float], np.ndarray],  # noqa: PLR0913
                 start: RobotState, tick_s: float, errors: SensorErrors, seed: int,
                 settings: EstimatorSettings | None = None):
        self.sensors = TwinSensors(plant, tick_s, errors, seed)
        board = lib.quadruped_model.board
        geometry = BoardGeometry(deck_height_m=board.deck_height_m, axis_depth_m=p.roll_axis_depth_m)
        body = BodyFigures(p.mass_kg, np.asarray(p.com_offset_m, dtype=float))
        self.estimator = StateEstimator(LegKinematics.from_library(lib), geometry, schedule, start, settings,
                                        p.gravity_mps2, body=body)
        self.estimator.calibrate(self.sensors.standstill(round(CALIBRATION_S / tick_s)))
        self.errors = EstimatorErrors()

    def __call__(self, true: Any) -> RobotState:
        est = self.estimator(self.sensors.read())
        self.errors.add(est, true)
        return est


def deck_feet(schedule: Callable[[float], np.ndarray], t0: float) -> np.ndarray:
    """The feet the schedule has on the deck at ``t0``."""
    return np.asarray(schedule(t0) == BOARD)
