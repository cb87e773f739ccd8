"""The ``/model`` records (:mod:`skatelib.library.model`) written to and read from a library's
attributes and datasets: the one place that spells out their names, with the format's migrations."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
from skatelib.library.model import (
    ATTR,
    LEGACY_PIVOT_ATTR,
    BoardModel,
    HumanoidBoard,
    HumanoidModel,
    QuadrupedArrays,
    QuadrupedModel,
)

TERMINAL_PREFIX = "terminal_"
_ROBOT_FIELDS = ("robot_mass_kg", "friction_mu", "gravity_mps2", "foot_radius_m", "torque_limit_Nm",
                 "joint_velocity_limit_radps", "push_leg")


def _attr_fields(cls: type) -> list[dataclasses.Field[Any]]:
    return [f for f in dataclasses.fields(cls) if ATTR in f.metadata]


def attributes(m: QuadrupedModel) -> dict[str, Any]:
    """The record as ``/model`` attributes: the robot's, the board's, the build's settings and the
    terminal tolerances, then the board's source (None fields are not written)."""
    model_fields = {f.name: f for f in _attr_fields(QuadrupedModel)}
    board = [f for f in _attr_fields(BoardModel) if f.name != "source"]
    rest = [f for name, f in model_fields.items() if name not in _ROBOT_FIELDS]
    pairs: list[tuple[str, Any]] = [(model_fields[n].metadata[ATTR], getattr(m, n)) for n in _ROBOT_FIELDS]
    pairs += [(f.metadata[ATTR], getattr(m.board, f.name)) for f in board]
    pairs += [(f.metadata[ATTR], getattr(m, f.name)) for f in rest if f.name not in ("final_velocity_tol",
                                                                                      "stop_speed_tol_mps")]
    pairs += [(TERMINAL_PREFIX + k, v) for k, v in m.terminal.items()]
    pairs += [("final_velocity_tol", m.final_velocity_tol), ("stop_speed_tol_mps", m.stop_speed_tol_mps),
              ("board_source", m.board.source)]
    return {k: v for k, v in pairs if v is not None}


def arrays(m: QuadrupedModel) -> dict[str, np.ndarray]:
    """The record's ``/model`` datasets."""
    return {k: v for k, v in dataclasses.asdict(m.arrays).items() if v is not None}


def _read(cls: type, attrs: Mapping[str, Any], extra: Mapping[str, Any]) -> Any:
    values: dict[str, Any] = {}
    for f in _attr_fields(cls):
        name = f.metadata[ATTR]
        if name in attrs:
            kind = {"str": str, "int": int}.get(str(f.type), float)
            values[f.name] = kind(attrs[name])
        elif f.default is dataclasses.MISSING:
            raise KeyError(name)
    return cls(**values, **extra)


def read_quadruped_model(attrs: Mapping[str, Any], datasets: Mapping[str, np.ndarray]) -> QuadrupedModel:
    """The record of a quadruped library's ``/model`` attributes and datasets, any format version.

    Migrations: a library without ``board_pivot_from_horizontal_rad`` (format 1.1) was optimized
    with the linear roll spring (``modelled_trucks`` False); its trucks' axis angle is
    ``board_rake_front_rad`` when stored, else the public model's.

    Raises:
        KeyError: Naming a required attribute or dataset the file lacks.
    """
    modelled = "board_pivot_from_horizontal_rad" in attrs
    board_attrs = dict(attrs)
    if not modelled and LEGACY_PIVOT_ATTR in attrs:
        board_attrs["board_pivot_from_horizontal_rad"] = attrs[LEGACY_PIVOT_ATTR]
    board = _read(BoardModel, board_attrs, {"modelled_trucks": modelled})

    def need(name: str, shape: tuple[int, ...]) -> np.ndarray:
        if name not in datasets:
            raise KeyError(name)
        return np.asarray(datasets[name], dtype=np.float64).reshape(shape)

    def maybe(name: str, shape: tuple[int, ...]) -> np.ndarray | None:
        return need(name, shape) if name in datasets else None

    arr = QuadrupedArrays(
        robot_inertia_kgm2=need("robot_inertia_kgm2", (3, 3)), robot_com_offset_m=need("robot_com_offset_m", (3,)),
        joint_lower_rad=need("joint_lower_rad", (12,)), joint_upper_rad=need("joint_upper_rad", (12,)),
        stance_q_board_rad=need("stance_q_board_rad", (12,)), stance_q_push_rad=maybe("stance_q_push_rad", (12,)),
        stance_deck_points_m=need("stance_deck_points_m", (-1, 4))[:2],
        stance_q_ride_rad=maybe("stance_q_ride_rad", (12,)), stance_ride_trunk=maybe("stance_ride_trunk", (-1,)),
        stance_riding_com_m=maybe("stance_riding_com_m", (-1,)))
    terminal = {k[len(TERMINAL_PREFIX):]: float(v) for k, v in attrs.items() if str(k).startswith(TERMINAL_PREFIX)}
    model: QuadrupedModel = _read(QuadrupedModel, attrs, {"board": board, "arrays": arr, "terminal": terminal})
    return model


def humanoid_attributes(m: HumanoidModel) -> dict[str, Any]:
    """The humanoid record as ``/model`` attributes."""
    out = {f.metadata[ATTR]: getattr(m, f.name) for f in _attr_fields(HumanoidModel)}
    if m.board is not None:
        out.update({f.metadata[ATTR]: getattr(m.board, f.name) for f in _attr_fields(HumanoidBoard)})
    return out


def read_humanoid_model(attrs: Mapping[str, Any]) -> HumanoidModel:
    """The record of a humanoid library's ``/model`` attributes.

    Raises:
        KeyError: Naming a required attribute the file lacks (a skate's board is read when the
            file has its deck height).
    """
    board = _read(HumanoidBoard, attrs, {}) if "skate_board_deck_height_m" in attrs else None
    model: HumanoidModel = _read(HumanoidModel, attrs, {"board": board})
    return model


def attribute_names() -> tuple[str, ...]:
    """Every ``/model`` attribute and dataset name the records know (the layout checker keeps them
    in library/)."""
    records = (QuadrupedModel, BoardModel, HumanoidModel, HumanoidBoard)
    names = [f.metadata[ATTR] for cls in records for f in _attr_fields(cls)]
    return (*names, LEGACY_PIVOT_ATTR, *QuadrupedArrays.names())
