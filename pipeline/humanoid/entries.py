"""Build humanoid (GPM) motion libraries: one entry per velocity of the sweep."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from skatelib.library import schema
from skatelib.library.records import EntryRecord
from skatelib.library.writer import write_library
from skatelib.pipeline.humanoid.config import HumanoidConfig
from skatelib.pipeline.humanoid.motion import (
    CONTROL_NAMES,
    CONTROL_UNITS,
    STATE_NAMES,
    STATE_UNITS,
    ZMP_NAMES,
    Motion,
    plan_json,
    solve_motion,
)
from skatelib.pipeline.ocp.gpm import GaussPseudospectral
from skatelib.pipeline.provenance import root_attributes


@dataclass(frozen=True)
class HumanoidBuildReport:
    path: Path
    motions: list[Motion]
    wall_time_s: float

    @property
    def failed(self) -> list[Motion]:
        return [m for m in self.motions if not m.success]


def motion_key(config: HumanoidConfig, m: Motion) -> tuple[str, int]:
    """The entry key of a motion and its strides: walking steps between start and stop, or one
    skating push (``n_phases`` keeps the number of GPM phases)."""
    strides = config.walk.steps if config.sweep.motion == "walk" else 1
    return schema.humanoid_key(config.sweep.motion, m.velocity_mps, strides), strides


def entry_from_motion(m: Motion, config: HumanoidConfig) -> EntryRecord:
    """A library entry with the sampled trajectory and every step's GPM node values."""
    n_nodes = config.gpm.nodes
    key, strides = motion_key(config, m)
    steps = m.steps
    nodes_state = np.stack([np.vstack([r.X, r.Xf]) for r in steps])  # (S, N+2, 6): tau_0..tau_N, end
    support = GaussPseudospectral(n_nodes).support
    nodes_t = np.stack([r.t0 + np.concatenate([(support + 1) / 2 * r.spec.duration_s, [r.spec.duration_s]])
                        for r in steps])
    status = "; ".join(f"{r.spec.name}: {r.status}" for r in steps)
    attrs = {
        "target_velocity_mps": m.velocity_mps, "n_strides": strides, "n_phases": len(steps),
        "motion": config.sweep.motion, "success": m.success,
        "status": "Solve_Succeeded" if m.success else status, "iterations": sum(r.iterations for r in steps),
        "solve_time_s": sum(r.solve_time_s for r in steps), "objective": sum(r.objective for r in steps),
        "max_constraint_violation": max(r.max_violation for r in steps),
        "plan_json": plan_json(m.plan),
        "steps_json": json.dumps([{"name": r.spec.name, "status": r.status, "iterations": r.iterations,
                                   "solve_time_s": r.solve_time_s, "duration_s": r.spec.duration_s,
                                   "terminal": r.spec.terminal} for r in steps]),
    }
    arrays = {
        schema.D_T: m.t, schema.D_STATE: m.state, schema.D_CONTROL: m.control, "zmp": m.zmp,
        "contact_point": m.contact_point, "step_index": m.step_index, "nodes_t": nodes_t, "nodes_state": nodes_state,
        "nodes_control": np.stack([r.U for r in steps]), "nodes_contact_point": np.stack([r.P0 for r in steps]),
    }
    columns = {schema.D_STATE: STATE_NAMES, schema.D_CONTROL: CONTROL_NAMES, "zmp": ZMP_NAMES,
               "contact_point": ("x", "y", "z")}
    units = {schema.D_STATE: STATE_UNITS, schema.D_CONTROL: CONTROL_UNITS, "zmp": ("m", "m"),
             "contact_point": ("m", "m", "m")}
    return EntryRecord(key=key, attrs=attrs, arrays=arrays, columns=columns,
                     units=units)


def build_humanoid_library(config: HumanoidConfig, out: Path | None = None,
                           on_entry: Callable[[str, Motion], None] | None = None) -> HumanoidBuildReport:
    """Solve every velocity of the sweep step by step and write the library atomically."""
    t0 = time.perf_counter()
    out = out or Path("out") / f"{config.meta.name}.h5"
    motions = []
    for v in sorted(config.sweep.velocities_mps):
        m = solve_motion(config, v)
        motions.append(m)
        if on_entry:
            on_entry(motion_key(config, m)[0], m)
    h = config.humanoid
    model = {"robot_mass_kg": h.mass_kg, "gravity_mps2": h.gravity_mps2, "com_height_m": h.com_height_m,
             "foot_length_m": h.foot_length_m, "foot_width_m": h.foot_width_m, "step_width_m": h.step_width_m,
             "friction_mu": h.friction_mu, "leg_min_m": h.leg_min_m, "leg_max_m": h.leg_max_m,
             "gpm_nodes": config.gpm.nodes, "gpm_solver": config.gpm.solver, "motion": config.sweep.motion,
             "source": h.source}
    root = root_attributes("humanoid", config.meta.name, config.text, config.resolved_json(),
                           {"solver": config.gpm.solver, "nodes": config.gpm.nodes})
    entries = [entry_from_motion(m, config) for m in motions]
    path = write_library(out, root, model, {}, {}, entries)
    return HumanoidBuildReport(path=path, motions=motions, wall_time_s=time.perf_counter() - t0)
