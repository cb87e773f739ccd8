"""Motion-library file format, version 1: every HDF5 path and attribute name in one place.

See ``docs/library-format.md`` for the full description. The format version (major.minor) is
separate from the package version: a reader refuses a newer or older major version and warns on
a different minor version.
"""

from __future__ import annotations

import re
from typing import Final

FORMAT_NAME: Final = "skatelib.motion-library"
HDF5_SIGNATURE: Final = b"\x89HDF\r\n\x1a\n"  # the first 8 bytes of an HDF5 file (after any user block)
FORMAT_VERSION: Final = (1, 6)  # 1.1: friction model, terminal state, cache_key, frontier_json; 1.2: the board
# model; 1.3: the humanoid's whole body (joints, feet, filtered COM and ZMP, its URDF); 1.4: transitions from
# riding (from_velocity_mps, keys v0.50-0.80_s2) and the riding stance in /model; 1.5: the humanoid's soles
# carry their pitch (toe-off); 1.6: the robustness certificate (certificate_json, optional)
FORMAT_VERSION_STR: Final = f"{FORMAT_VERSION[0]}.{FORMAT_VERSION[1]}"

# Root attributes.
A_FORMAT: Final = "format"
A_FORMAT_VERSION: Final = "format_version"
A_KIND: Final = "kind"  # "quadruped" or "humanoid"
A_NAME: Final = "name"
A_SKATELIB_VERSION: Final = "skatelib_version"
A_CREATED: Final = "created_utc"
A_GIT_COMMIT: Final = "git_commit"
A_GIT_DIRTY: Final = "git_dirty"
A_CONFIG_TOML: Final = "config_toml"
A_CONFIG_RESOLVED: Final = "config_resolved_json"
A_CASADI: Final = "casadi_version"
A_IPOPT: Final = "ipopt_version"
A_PINOCCHIO: Final = "pinocchio_version"
A_CHECKSUM: Final = "content_sha256"
A_SOLVER_OPTIONS: Final = "solver_options_json"
A_FRONTIER: Final = "frontier_json"  # optional: the reachable-speed frontier (skatelib build --frontier)
A_CERTIFICATE: Final = "certificate_json"  # optional, since 1.6: the robustness certificate (skatelib certify)
ROOT_REQUIRED: Final = (
    A_FORMAT,
    A_FORMAT_VERSION,
    A_KIND,
    A_SKATELIB_VERSION,
    A_CREATED,
    A_GIT_COMMIT,
    A_GIT_DIRTY,
    A_CONFIG_TOML,
    A_CASADI,
    A_IPOPT,
    A_PINOCCHIO,
    A_CHECKSUM,
)

# Model group.
G_MODEL: Final = "model"
D_ROBOT_INERTIA: Final = "robot_inertia_kgm2"
D_ROBOT_URDF: Final = "robot_urdf"
A_FRICTION_MU: Final = "friction_mu"  # every kind's (the typed records: skatelib.library.model)
QUADRUPED_MODEL_ATTRS: Final = (
    "robot_mass_kg",
    "friction_mu",
    "gravity_mps2",
    "board_mass_kg",
    "board_roll_stiffness_Nm_per_rad",
    "board_roll_damping_Nms_per_rad",
    "board_roll_inertia_kgm2",
    "board_rolling_friction_N",
    "board_K_board_m",
)
# Format 1.2: the board model's trucks, roll axis and wheels (a 1.1 file has none of them).
QUADRUPED_BOARD_ATTRS_1_2: Final = (
    "board_pivot_from_horizontal_rad",
    "board_roll_axis_height_m",
    "board_deck_mass_kg",
    "board_wheel_track_m",
    "board_wheel_load_margin",
    "board_rolling_coeff",
)
D_JOINT_LOWER: Final = "joint_lower_rad"
D_JOINT_UPPER: Final = "joint_upper_rad"

# Packed storage: every entry's arrays stacked per dataset name, plus a JSON index that mirrors
# every attribute of the file. /entries/<key>/<name> are virtual views into /packed/<name>.
G_PACKED: Final = "packed"
D_INDEX: Final = "index"

# Entries.
G_ENTRIES: Final = "entries"
D_T: Final = "t"
D_STATE: Final = "state"
D_CONTROL: Final = "control"
D_CONTACT: Final = "contact"
D_FOOT_POS: Final = "foot_pos"
D_BOARD_POS: Final = "board_pos"
D_ZMP: Final = "zmp"  # humanoid: the zero-moment point (K, 2)
D_CONTACT_POINT: Final = "contact_point"  # humanoid: the representative contact point (K, 3)
D_STEP_INDEX: Final = "step_index"  # humanoid: which step each sample belongs to (K,)
D_NODES_T: Final = "nodes_t"  # humanoid: per step, the GPM node times (S, N+2)
D_NODES_STATE: Final = "nodes_state"  # humanoid: per step, the states at tau_0..tau_N and the end (S, N+2, 6)
D_NODES_CONTROL: Final = "nodes_control"  # humanoid: per step, the controls at the LG nodes (S, N, 3)
D_NODES_CONTACT_POINT: Final = "nodes_contact_point"  # humanoid: per step, the contact point at the nodes
# Since 1.3, a humanoid entry whose COM motion holds also has its whole body:
D_JOINTS: Final = "joints"  # (K, 12) joint angles [rad], columns the URDF's joint names
D_JOINT_VELOCITIES: Final = "joint_velocities"  # (K, 12) [rad/s]
D_BASE_POSE: Final = "base_pose"  # (K, 7) waist position [m] and quaternion x, y, z, w
D_FEET: Final = "feet"  # (K, 10) right then left sole: x, y, z [m], yaw, pitch [rad] (before 1.5: no pitch, (K, 8))
D_COM_REFERENCE: Final = "com_reference"  # (K, 3) the COM after the dynamics filter [m]
D_ZMP_UNFILTERED: Final = "zmp_unfiltered"  # (K, 2) multibody ZMP of inverse kinematics on the GPM's COM [m]
D_ZMP_WHOLEBODY: Final = "zmp_wholebody"  # (K, 2) multibody ZMP after the filter [m]
A_WHOLEBODY: Final = "wholebody_json"  # the whole body's figures (errors, ZMP before and after, times)
A_PHYSICS: Final = "physics_json"  # an entry's independent physics figures
A_CLOSED_LOOP: Final = "closed_loop_json"  # an entry's closed-loop verdict (validate --closed-loop)
A_CLOSED_LOOP_TWIN: Final = "closed_loop_twin_json"  # its verdict on the twin (validate --closed-loop --plant mujoco)
A_CACHE_KEY: Final = "cache_key"  # the build cache's key of the entry
A_PLAN: Final = "plan_json"  # humanoid: the steps the entry was solved for
A_STEPS: Final = "steps_json"  # humanoid: each step's status, iterations and time
A_COLUMNS: Final = "columns"
A_UNITS: Final = "units"
A_TARGET_VELOCITY: Final = "target_velocity_mps"  # the entry's label [m/s]
A_N_STRIDES: Final = "n_strides"
A_FROM_VELOCITY: Final = "from_velocity_mps"  # since 1.4: a transition's start speed; absent or 0: from rest
A_SUCCESS: Final = "success"
A_STATUS: Final = "status"  # the solver's status, or the failed check
A_ITERATIONS: Final = "iterations"
A_SOLVE_TIME: Final = "solve_time_s"
A_OBJECTIVE: Final = "objective"
A_MAX_VIOLATION: Final = "max_constraint_violation"
ENTRY_ATTRS: Final = (A_TARGET_VELOCITY, A_N_STRIDES, A_SUCCESS, A_STATUS, A_ITERATIONS, A_SOLVE_TIME, A_OBJECTIVE,
                      A_MAX_VIOLATION)
ENTRY_DATASETS: Final = {
    "quadruped": (D_T, D_STATE, D_CONTROL, D_CONTACT, D_FOOT_POS, D_BOARD_POS),
    "humanoid": (D_T, D_STATE, D_CONTROL),
}


# Every entry key is a plain name: it names an HDF5 group under /entries and, in exports, a file in
# the output folder. What skatelib writes (entry_key, humanoid_key) always matches.
ENTRY_KEY_PATTERN: Final = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}")
ENTRY_KEY_RULE: Final = "letters, digits, '.', '_' and '-', starting with a letter or a digit, at most 64"


def entry_key_problem(key: object) -> str:
    """Why ``key`` cannot be an entry key ("" when it can); shows the key escaped (``repr``), so
    that no control character of a file reaches the terminal."""
    if not isinstance(key, str):
        return f"entry key {key!r} is not a string"
    if ENTRY_KEY_PATTERN.fullmatch(key) is None:
        return f"entry key {key!r} is not a plain name ({ENTRY_KEY_RULE})"
    return ""


def entry_key(target_velocity_mps: float, n_strides: int, from_velocity_mps: float = 0.0) -> str:
    """Canonical quadruped entry name: ``v0.50_s2`` for a start-up from rest to 0.5 m/s in two strides,
    ``v0.50-0.80_s2`` for a transition riding from 0.5 to 0.8 m/s (``v0.50-0.00_s1``: a stop)."""
    if from_velocity_mps > 0.0:
        return f"v{from_velocity_mps:.2f}-{target_velocity_mps:.2f}_s{n_strides}"
    return f"v{target_velocity_mps:.2f}_s{n_strides}"


def humanoid_key(motion: str, velocity_mps: float, n_steps: int) -> str:
    """Humanoid entry name: ``walk_v0.375_n6`` (six walking steps between start and stop; the speed
    with two decimals, three when it needs them) or ``skate_v1.00`` (one push, slide and stop)."""
    speed = f"{velocity_mps:.2f}" if abs(round(velocity_mps, 2) - velocity_mps) < 1e-9 else f"{velocity_mps:.3f}"
    return f"walk_v{speed}_n{n_steps}" if motion == "walk" else f"{motion}_v{speed}"
