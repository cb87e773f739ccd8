"""Humanoid (GPM) motions as library entries, and the library they make: one entry per velocity."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.channels import (
    HUMANOID_CONTROL_NAMES,
    HUMANOID_CONTROL_UNITS,
    HUMANOID_STATE_NAMES,
    HUMANOID_STATE_UNITS,
    POINT_NAMES,
    ZMP_NAMES,
)
from skatelib.library.model import HumanoidBoard, HumanoidModel
from skatelib.library.model_io import humanoid_attributes
from skatelib.library.records import EntryRecord
from skatelib.library.writer import write_library
from skatelib.pipeline.build.provenance import root_attributes
from skatelib.pipeline.humanoid.body import BodyMotion
from skatelib.pipeline.humanoid.config import HumanoidConfig
from skatelib.pipeline.humanoid.motion import plan_json, served_arrays
from skatelib.pipeline.humanoid.tasks import EntryOutcome, entry_name


def entry_from_motion(o: EntryOutcome, config: HumanoidConfig) -> EntryRecord:
    """A library entry with the sampled trajectory and every step's GPM node values; ``success``
    only when every step converged and the independent checks hold."""
    m, steps = o.motion, o.motion.steps
    strides = entry_name(config, m.velocity_mps)[1]
    attrs = {
        schema.A_TARGET_VELOCITY: m.velocity_mps, schema.A_N_STRIDES: strides, "n_phases": len(steps),
        "motion": config.sweep.motion, schema.A_SUCCESS: o.success,
        schema.A_STATUS: o.status, schema.A_ITERATIONS: sum(r.iterations for r in steps),
        schema.A_SOLVE_TIME: sum(r.solve_time_s for r in steps), schema.A_OBJECTIVE: sum(r.objective for r in steps),
        schema.A_MAX_VIOLATION: max(r.max_violation for r in steps),
        schema.A_PLAN: plan_json(m.plan), schema.A_CACHE_KEY: o.cache_key,
        schema.A_STEPS: json.dumps([{"name": r.spec.name, "status": r.status, "iterations": r.iterations,
                                   schema.A_SOLVE_TIME: r.solve_time_s, "duration_s": r.spec.duration_s,
                                   "terminal": r.spec.terminal} for r in steps]),
    }
    arrays = served_arrays(m, config.gpm.nodes)
    columns = {schema.D_STATE: HUMANOID_STATE_NAMES, schema.D_CONTROL: HUMANOID_CONTROL_NAMES,
               schema.D_ZMP: ZMP_NAMES, schema.D_CONTACT_POINT: POINT_NAMES}
    units = {schema.D_STATE: HUMANOID_STATE_UNITS, schema.D_CONTROL: HUMANOID_CONTROL_UNITS,
             schema.D_ZMP: ("m", "m"), schema.D_CONTACT_POINT: ("m", "m", "m")}
    if o.body is not None:
        attrs[schema.A_WHOLEBODY] = json.dumps(o.body.figures, sort_keys=True)
        body_arrays, body_columns, body_units = _body_records(o.body)
        arrays |= body_arrays
        columns |= body_columns
        units |= body_units
    return EntryRecord(key=o.key, attrs=attrs, arrays=arrays, columns=columns, units=units)


FEET_NAMES = tuple(f"{side}_{c}" for side in ("R", "L") for c in ("x", "y", "z", "yaw", "pitch"))


def _body_records(b: BodyMotion) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """The whole body's arrays, column names and units (format 1.3)."""
    n = len(b.joint_names)
    arrays = {schema.D_JOINTS: b.q, schema.D_JOINT_VELOCITIES: b.qd, schema.D_BASE_POSE: b.base, schema.D_FEET: b.feet,
              schema.D_COM_REFERENCE: b.com_reference, schema.D_ZMP_UNFILTERED: b.zmp_unfiltered,
              schema.D_ZMP_WHOLEBODY: b.zmp_wholebody}
    columns = {schema.D_JOINTS: b.joint_names, schema.D_JOINT_VELOCITIES: b.joint_names,
               schema.D_BASE_POSE: ("x", "y", "z", "qx", "qy", "qz", "qw"), schema.D_FEET: FEET_NAMES,
               schema.D_COM_REFERENCE: POINT_NAMES, schema.D_ZMP_UNFILTERED: ZMP_NAMES,
               schema.D_ZMP_WHOLEBODY: ZMP_NAMES}
    units = {schema.D_JOINTS: ("rad",) * n, schema.D_JOINT_VELOCITIES: ("rad/s",) * n,
             schema.D_BASE_POSE: ("m",) * 3 + ("",) * 4, schema.D_FEET: ("m", "m", "m", "rad", "rad") * 2,
             schema.D_COM_REFERENCE: ("m",) * 3, schema.D_ZMP_UNFILTERED: ("m", "m"),
             schema.D_ZMP_WHOLEBODY: ("m", "m")}
    return arrays, columns, units


def board_record(config: HumanoidConfig) -> HumanoidBoard | None:
    """A skate's ``[board]`` as the library's record (None without one)."""
    if config.board is None:
        return None
    return HumanoidBoard(**dataclasses.asdict(config.board))


def write_humanoid_library(out: Path, config: HumanoidConfig, outcomes: list[EntryOutcome]) -> Path:
    """Write the motions as a library (atomically): its model, provenance and one entry each."""
    h = config.humanoid
    model = HumanoidModel(robot_mass_kg=h.mass_kg, gravity_mps2=h.gravity_mps2, com_height_m=h.com_height_m,
                          foot_length_m=h.foot_length_m, foot_width_m=h.foot_width_m, step_width_m=h.step_width_m,
                          friction_mu=h.friction_mu, leg_min_m=h.leg_min_m, leg_max_m=h.leg_max_m,
                          gpm_nodes=config.gpm.nodes, gpm_solver=config.gpm.solver, motion=config.sweep.motion,
                          source=h.source, board=board_record(config))
    root = root_attributes("humanoid", config.meta.name, config.text, config.resolved_json(),
                           {"solver": config.gpm.solver, "nodes": config.gpm.nodes})
    urdf = config.wholebody.urdf_path(config.path).read_text()
    return write_library(out, root, humanoid_attributes(model), {}, {schema.D_ROBOT_URDF: urdf},
                         same_datasets([entry_from_motion(o, config) for o in outcomes]))


def same_datasets(records: list[EntryRecord]) -> list[EntryRecord]:
    """Every entry with the same datasets, as a library needs: one whose steps failed before the
    whole body was made gets the whole body's datasets with no rows (its status says why)."""
    full = next((r for r in records if schema.D_JOINTS in r.arrays), None)
    if full is None:
        return records
    out = []
    for r in records:
        missing = [k for k in full.arrays if k not in r.arrays]
        if missing:
            r = replace(r, arrays={**r.arrays, **{k: np.zeros((0, *np.shape(full.arrays[k])[1:])) for k in missing}},
                        columns={**r.columns, **{k: full.columns[k] for k in missing if k in full.columns}},
                        units={**r.units, **{k: full.units[k] for k in missing if k in full.units}})
        out.append(r)
    return out
