"""Turn push-off solve results into a motion-library file with full provenance."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import model_io, schema
from skatelib.library.channels import CONTROL_NAMES, CONTROL_UNITS, LEGS, STATE_NAMES, STATE_UNITS
from skatelib.library.model import BoardModel, QuadrupedArrays, QuadrupedModel
from skatelib.library.records import EntryRecord
from skatelib.library.writer import write_library
from skatelib.pipeline.build.provenance import root_attributes
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.model.system import SkateSystem
from skatelib.pipeline.quadruped.problem.pushoff import SolveResult

BOARD_POS_COLUMNS = ("board_x", "board_y", "board_z", "board_yaw")
BOARD_POS_UNITS = ("m", "m", "m", "rad")


def quadruped_model(config: QuadrupedConfig, system: SkateSystem) -> QuadrupedModel:
    """Every physical parameter the build used, as the library's ``/model`` record."""
    b, s = system.board, system
    board = BoardModel(
        mass_kg=b.mass_kg, roll_stiffness_Nm_per_rad=b.roll_stiffness_Nm_per_rad,
        roll_damping_Nms_per_rad=b.roll_damping_Nms_per_rad, roll_inertia_kgm2=b.roll_inertia_kgm2,
        rolling_friction_N=b.rolling_friction_nominal_N, rolling_friction_plan_N=b.rolling_friction_N,
        rolling_coeff=b.rolling_coeff_nominal, rolling_coeff_plan=b.rolling_coeff, K_board_m=b.K_board_m,
        deck_mass_kg=b.deck_mass_kg, tanh_scale_s_per_m=b.tanh_scale_s_per_m, pivot_from_horizontal_rad=b.pivot_rad,
        roll_axis_height_m=b.deck_height_m - b.roll_axis_depth_m, wheel_track_m=b.wheel_track_m,
        wheel_load_margin=b.wheel_load_margin, l_front_m=b.l_front_m, l_rear_m=b.l_rear_m,
        deck_height_m=b.deck_height_m, deck_length_m=b.deck_length_m, deck_width_m=b.deck_width_m,
        truck_width_m=b.truck_width_m, roll_limit_rad=b.roll_limit_rad, source=config.board.source)
    arrays = QuadrupedArrays(
        robot_inertia_kgm2=s.srb.inertia_kgm2, robot_com_offset_m=s.srb.com_offset_m,
        joint_lower_rad=s.robot.lower_limits, joint_upper_rad=s.robot.upper_limits,
        stance_q_board_rad=s.stance.q_board, stance_q_push_rad=s.stance.q_push, stance_deck_points_m=s.stance.cr,
        stance_q_ride_rad=s.stance.q_ride, stance_ride_trunk=s.stance.ride_trunk, stance_riding_com_m=s.riding_com_m)
    opt = config.optimization
    return QuadrupedModel(
        board=board, arrays=arrays, robot_mass_kg=s.srb.mass_kg, friction_mu=s.friction_mu,
        gravity_mps2=s.gravity_mps2, foot_radius_m=s.foot_radius_m, torque_limit_Nm=s.torque_limit_Nm,
        joint_velocity_limit_radps=s.joint_velocity_limit_radps, push_leg=s.push_leg,
        schedule_period_s=config.schedule.period_s, schedule_push_duty=config.schedule.push_duty, dt_s=opt.dt_s,
        integrator=opt.integrator, robot_source=config.robot.source, friction_model=opt.friction_model,
        friction_mu_plan=opt.friction_margin * s.friction_mu, joint_limit_margin_rad=opt.joint_limit_margin_rad,
        terminal=dataclasses.asdict(config.terminal), final_velocity_tol=opt.final_velocity_tol,
        stop_speed_tol_mps=config.transitions.stop_speed_tol_mps)


def entry_from_result(r: SolveResult, attempts: int = 1, physics: dict[str, float] | None = None,
                      cache_key: str = "") -> EntryRecord:
    attrs = {
        schema.A_TARGET_VELOCITY: r.target_velocity_mps, schema.A_N_STRIDES: r.n_strides,
        schema.A_FROM_VELOCITY: r.from_velocity_mps,
        schema.A_SUCCESS: r.success, schema.A_STATUS: r.status, schema.A_ITERATIONS: r.iterations,
        schema.A_SOLVE_TIME: r.solve_time_s, "build_time_s": r.build_time_s, schema.A_OBJECTIVE: r.objective,
        schema.A_MAX_VIOLATION: r.max_constraint_violation, "final_velocity_mps": r.final_velocity_mps,
        "final_velocity_error": r.final_velocity_error, "attempts": attempts,
        "ipopt_options_json": json.dumps(r.ipopt_options, sort_keys=True, default=str),
        schema.A_PHYSICS: json.dumps(physics or {}, sort_keys=True), schema.A_CACHE_KEY: cache_key,
    }
    arrays = {schema.D_T: r.t, schema.D_STATE: r.state, schema.D_CONTROL: r.control,
              schema.D_CONTACT: r.contact.astype(np.int8), schema.D_FOOT_POS: r.foot_pos,
              schema.D_BOARD_POS: r.board_pos}
    columns = {schema.D_STATE: STATE_NAMES, schema.D_CONTROL: CONTROL_NAMES, schema.D_CONTACT: LEGS,
               schema.D_FOOT_POS: LEGS, schema.D_BOARD_POS: BOARD_POS_COLUMNS}
    units = {schema.D_STATE: STATE_UNITS, schema.D_CONTROL: CONTROL_UNITS,
             schema.D_CONTACT: ("0 swing, 1 board, 2 ground",) * 4, schema.D_FOOT_POS: ("m",) * 4,
             schema.D_BOARD_POS: BOARD_POS_UNITS}
    key = schema.entry_key(r.target_velocity_mps, r.n_strides, r.from_velocity_mps)
    return EntryRecord(key=key, attrs=attrs, arrays=arrays,
                     columns=columns, units=units)


def write_quadruped_library(path: Path | str, config: QuadrupedConfig, system: SkateSystem,
                            entries: Sequence[EntryRecord], solver_options: dict[str, Any],
                            frontier_json: str | None = None) -> Path:
    """Write a quadruped motion library atomically (with the reachable-speed frontier when given)."""
    record = quadruped_model(config, system)
    root = root_attributes("quadruped", config.meta.name, config.text, config.resolved_json(), solver_options)
    if frontier_json is not None:
        root[schema.A_FRONTIER] = frontier_json
    return write_library(path, root, model_io.attributes(record), model_io.arrays(record),
                         {schema.D_ROBOT_URDF: system.robot.urdf_text},
                         entries)
