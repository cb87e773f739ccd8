"""Build configurations: TOML files read with tomllib, validated into frozen dataclasses.

Every physical field carries its unit in its name. An unknown key, a wrong type or a value out
of range raises :class:`ConfigError` naming the file, the dotted key and the allowed values.
A config may start from another with ``extends = "other.toml"`` (path relative to the file);
tables are merged key by key, the extending file winning.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from skatelib.library.channels import LEGS
from skatelib.library.errors import ConfigError
from skatelib.library.schema import HDF5_SIGNATURE

# The checkout's configs/ (editable install) or the installed package skatelib.configs (package
# data of a wheel): the same place relative to this file.
CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"
DEFAULT_CONFIG = "cyberdog2.toml"
FRICTION_MODELS = ("cone", "polygon8")


def _f(lo: float | None = None, hi: float | None = None, doc: str = "", **kw: Any) -> Any:
    """A dataclass field with an allowed range [lo, hi] and a one-line description."""
    return field(metadata={"lo": lo, "hi": hi, "doc": doc}, **kw)


@dataclass(frozen=True)
class MetaConfig:
    kind: str = _f(doc="Problem family: 'quadruped' (CyberDog2 skateboard) or 'humanoid' (GPM steps).")
    name: str = _f(doc="Library name, stored in the file.")


@dataclass(frozen=True)
class RobotConfig:
    urdf: str = _f(doc="URDF path, relative to the config file or absolute.")
    foot_radius_m: float = _f(0.0, 0.2, "Foot sphere radius [m].")
    friction_mu: float = _f(0.05, 2.0, "Coulomb friction coefficient of feet on deck and ground [-].")
    gravity_mps2: float = _f(0.0, 30.0, "Gravity magnitude [m/s^2].")
    torque_limit_Nm: float = _f(0.1, 500.0, "Joint torque limit, all joints [N m].")
    joint_velocity_limit_radps: float = _f(0.1, 200.0, "Joint velocity limit [rad/s].")
    joint_names: tuple[str, ...] = _f(
        doc="URDF joint names in channel order FL FR RL RR x abad hip knee (12 names).",
        default=tuple(f"{leg}_{j}" for leg in LEGS for j in ("abad", "hip", "knee")),
    )
    foot_frames: tuple[str, ...] = _f(
        doc="URDF frames at the foot sphere centres, legs FL FR RL RR.",
        default=tuple(f"{leg}_foot" for leg in LEGS),
    )
    source: str = _f(doc="Where the figures come from.", default="")


@dataclass(frozen=True)
class BoardConfig:
    deck_length_m: float = _f(0.1, 2.0, "Deck length [m] (paper Sec. II-B: 0.74).")
    deck_width_m: float = _f(0.05, 1.0, "Deck width [m] (paper: 0.265).")
    deck_height_m: float = _f(0.0, 0.5, "Height of the deck's top surface above the ground [m].")
    truck_distance_m: float = _f(0.05, 2.0, "Distance between front and rear truck pivots [m] (0.49).")
    truck_width_m: float = _f(0.05, 1.0, "Truck (axle) width [m] (0.24).")
    mass_kg: float = _f(0.1, 50.0, "Whole skateboard mass m_B of Eq. (9b) [kg].")
    roll_inertia_kgm2: float = _f(1e-5, 10.0, "Deck roll inertia I_Bx of Eq. (7) [kg m^2].")
    rake_front_rad: float = _f(0.05, 1.52, "Front truck rake angle gamma_f from horizontal, Eq. (11) [rad].")
    rake_rear_rad: float = _f(0.05, 1.52, "Rear truck rake angle gamma_r from horizontal, Eq. (11) [rad].")
    calibration_roll_rad: float = _f(
        0.01, 0.5, "Steady roll [rad] when the robot's weight rests on one side's feet; K_B is set so."
    )
    roll_damping_ratio: float = _f(0.05, 10.0, "Damping ratio of the free deck roll; sets B_B of Eq. (6) [-].")
    rolling_friction_coeff: float = _f(0.0, 0.2, "Rolling resistance f_fri / total weight, Eq. (9b) [-].")
    tanh_scale_s_per_m: float = _f(1.0, 1e4, "Scale k of the tanh smoothing of sign(v), Eq. (10) [s/m].")
    roll_limit_rad: float = _f(0.01, 0.6, "Largest allowed deck roll |phi_B| [rad].")
    source: str = _f(doc="Where the figures come from.", default="")


@dataclass(frozen=True)
class StanceConfig:
    base_height_above_deck_m: float = _f(0.05, 0.5, "Trunk origin height above the deck top [m].")
    foot_x_front_m: float = _f(0.0, 0.5, "Front feet x in the board frame [m].")
    foot_x_rear_m: float = _f(-0.5, 0.0, "Rear feet x in the board frame [m].")
    foot_y_m: float = _f(0.01, 0.5, "Feet |y| in the board frame [m].")
    base_x_offset_m: float = _f(-0.3, 0.3, "Trunk origin x in the board frame at rest [m].")
    push_foot_y_m: float = _f(0.0, 0.6, "Pushing foot |y| from the board centre line on the ground [m].")
    push_clearance_m: float = _f(0.0, 0.2, "Lateral clearance of the pushing foot from the deck edge [m].")
    swing_height_m: float = _f(0.0, 0.2, "Least foot lift at mid-swing [m].")


@dataclass(frozen=True)
class ScheduleConfig:
    period_s: float = _f(0.2, 5.0, "Push cycle period [s] (paper: 1.2).")
    push_duty: float = _f(0.1, 0.9, "Fraction of a cycle the pushing foot is on the ground [-].")
    push_leg: str = _f(doc="Leg that pushes on the ground: one of FL FR RL RR (paper: RL).")
    balance_s: float = _f(0.0, 10.0, "Four-leg balancing before and after the pushes [s].", default=0.5)
    transfer_s: float = _f(0.0, 5.0, "Three-leg phase moving the push leg board<->ground [s].", default=0.4)


@dataclass(frozen=True)
class WeightsConfig:
    board_velocity: float = _f(0.0, 1e6, "Eq. (16a) weight on board velocity error [(m/s)^-2].")
    board_roll: float = _f(0.0, 1e6, "Eq. (16a) weight on deck roll [rad^-2].")
    base_position: float = _f(0.0, 1e6, "Eq. (16b) weight on trunk position error relative to the board [m^-2].")
    base_orientation: float = _f(0.0, 1e6, "Eq. (16b) weight on trunk roll/pitch/yaw [rad^-2].")
    base_velocity: float = _f(0.0, 1e6, "Eq. (16b) weight on trunk velocity relative to the board [(m/s)^-2].")
    base_angular_velocity: float = _f(0.0, 1e6, "Eq. (16b) weight on trunk angular velocity [(rad/s)^-2].")
    joint_position: float = _f(0.0, 1e6, "Eq. (16b) weight on joint angles from the stance [rad^-2].")
    force: float = _f(0.0, 1e6, "Eq. (16c) weight on contact forces [N^-2].")
    joint_velocity: float = _f(0.0, 1e6, "Eq. (16c) weight on joint velocities [(rad/s)^-2].")
    force_rate: float = _f(0.0, 1e6, "Eq. (16d) weight on force changes between knots [N^-2].")
    joint_velocity_rate: float = _f(0.0, 1e6, "Eq. (16d) weight on joint-velocity changes [(rad/s)^-2].")
    terminal_velocity: float = _f(0.0, 1e9, "Weight on the final board speed error [(m/s)^-2].")


@dataclass(frozen=True)
class OptimizationConfig:
    dt_s: float = _f(0.005, 0.1, "Shooting interval [s].")
    integrator: str = _f(doc="Integrator per shooting interval: 'etdrk4' (exact for the deck roll) or 'rk4'.")
    substeps: int = _f(1, 20, "Integrator steps per shooting interval [-].")
    max_iter: int = _f(1, 10000, "IPOPT iteration limit [-].")
    tol: float = _f(1e-12, 1e-2, "IPOPT tolerance [-].")
    final_velocity_tol: float = _f(0.0, 0.5, "Allowed relative error of the final board speed [-].")
    mu_strategy: str = _f(doc="IPOPT barrier strategy: 'monotone' or 'adaptive'.", default="monotone")
    mu_init: float = _f(1e-9, 1e3, "IPOPT initial barrier parameter [-].", default=0.01)
    compile: bool = _f(doc="Compile the stage functions with the C compiler (cached on disk).", default=True)
    friction_model: str = _f(
        doc="Friction constraint of every contact: 'cone' (exact Coulomb cone, mu^2 f_n^2 >= |f_t|^2, f_n >= 0) "
            "or 'polygon8' (inscribed 8-facet pyramid, inside the cone).", default="cone")
    friction_margin: float = _f(0.5, 1.0, "Planning margin: the TO uses mu_plan = margin x mu [-].", default=1.0)
    rolling_friction_factor: float = _f(
        1.0, 5.0, "The TO plans against this multiple of the board's rolling resistance; on a board that rolls "
        "easier the controller pushes less (README 'Closed loop') [-].", default=1.0)
    joint_limit_margin_rad: float = _f(0.0, 0.3, "The TO keeps joint angles this far inside their limits [rad].",
                                       default=0.0)
    weights: WeightsConfig = _f(doc="Cost weights of Eq. (16).", default_factory=lambda: WeightsConfig(
        **{f.name: 0.0 for f in dataclasses.fields(WeightsConfig)}))


@dataclass(frozen=True)
class TerminalConfig:
    """The riding state every push-off ends in, from which three-leg transfer and balancing begin."""

    relative_speed_tol_mps: float = _f(1e-4, 0.5, "Largest lateral COM speed relative to the board at the end [m/s].",
                                       default=0.005)
    vertical_speed_tol_mps: float = _f(1e-4, 0.5, "Largest |vertical COM speed| at the end [m/s].", default=0.005)
    angular_speed_tol_radps: float = _f(1e-4, 1.0, "Largest |body angular velocity| per axis at the end [rad/s].",
                                    default=0.005)
    height_tol_m: float = _f(1e-4, 0.1, "Largest COM height error from the riding stance at the end [m].", default=0.01)
    attitude_tol_rad: float = _f(1e-4, 0.5, "Largest |body roll| and |pitch| at the end [rad].", default=0.03)
    joint_velocity_tol_radps: float = _f(1e-3, 10.0, "Largest |joint velocity| over the last interval [rad/s].",
                                         default=0.05)
    push_foot_height_m: float = _f(0.0, 0.2, "Push foot's lift-off clearance above the ground at the end [m].",
                                   default=0.02)


@dataclass(frozen=True)
class SweepConfig:
    velocities_mps: tuple[float, ...] = _f(0.05, 3.0, "Target board speeds [m/s].")
    strides: tuple[int, ...] = _f(1, 20, "Stride counts [-].")
    warm_start: bool = _f(doc="Warm-start each solve from the neighbouring velocity's.", default=True)


@dataclass(frozen=True)
class QuadrupedConfig:
    """A complete quadruped motion-library build."""

    path: Path
    text: str
    meta: MetaConfig
    robot: RobotConfig
    board: BoardConfig
    stance: StanceConfig
    schedule: ScheduleConfig
    optimization: OptimizationConfig
    terminal: TerminalConfig
    sweep: SweepConfig

    @property
    def urdf_path(self) -> Path:
        p = Path(self.robot.urdf)
        return p if p.is_absolute() else (self.path.parent / p).resolve()

    def resolved_json(self) -> str:
        """The validated config as JSON (what the build used, after ``extends``)."""
        d = dataclasses.asdict(self)
        d.pop("path")
        d.pop("text")
        return json.dumps(d, sort_keys=True, default=str)

    def problem_json(self) -> str:
        """The part of the config that determines a solved entry, as JSON: no name, no sweep list,
        no compile switch, and the URDF by the SHA-256 of its bytes instead of its path (so a moved
        checkout hits the same cache entries and an edited URDF misses them)."""
        d = json.loads(self.resolved_json())
        d.pop("meta")
        d.pop("sweep")
        d["optimization"].pop("compile")
        d["robot"]["urdf"] = hashlib.sha256(self.urdf_path.read_bytes()).hexdigest()
        return json.dumps(d, sort_keys=True)


@dataclass(frozen=True)
class HumanoidModelConfig:
    mass_kg: float = _f(1.0, 500.0, "Robot mass M [kg] (HRP-2: about 58).")
    gravity_mps2: float = _f(0.0, 30.0, "Gravity magnitude [m/s^2].")
    com_height_m: float = _f(0.2, 2.0, "COM height when walking and at rest [m] (paper: 0.80).")
    foot_length_m: float = _f(0.05, 0.6, "Sole length [m] (HRP-2: about 0.24).")
    foot_width_m: float = _f(0.03, 0.4, "Sole width [m] (HRP-2: about 0.14).")
    step_width_m: float = _f(0.05, 0.6, "Lateral distance between the feet [m].")
    friction_mu: float = _f(0.05, 2.0, "Static friction coefficient of the soles [-].")
    leg_min_m: float = _f(0.1, 2.0, "Least COM-to-contact distance r_min, Eq. (21) [m].")
    leg_max_m: float = _f(0.1, 2.0, "Largest COM-to-contact distance r_max, Eq. (21) [m].")
    source: str = _f(doc="Where the figures come from.", default="")


@dataclass(frozen=True)
class GpmConfig:
    nodes: int = _f(2, 60, "Legendre-Gauss nodes per step [-] (paper: 10).")
    solver: str = _f(doc="NLP solver: 'ipopt' or 'sqp' (CasADi sqpmethod with qrqp).", default="ipopt")
    sample_dt_s: float = _f(0.001, 0.1, "Spacing of the stored trajectory samples [s].", default=0.01)


@dataclass(frozen=True)
class WalkConfig:
    steps: int = _f(1, 50, "Walking steps [-] (paper: 6).")
    single_support_s: float = _f(0.05, 5.0, "Single-support time per step [s] (paper: 0.6).")
    double_support_s: float = _f(0.0, 5.0, "Double-support time per step [s] (paper: 0.2).")
    start_s: float = _f(0.05, 5.0, "Initial double-support phase [s].")
    stop_s: float = _f(0.05, 5.0, "Final stopping phase [s].")


@dataclass(frozen=True)
class SkateConfig:
    push_s: float = _f(0.05, 5.0, "Accelerating (push) phase [s] (paper: 1.0).")
    slide_s: float = _f(0.05, 10.0, "Sliding phase [s] (paper: 2.0).")
    stop_s: float = _f(0.05, 5.0, "Stop and return to the initial posture [s] (paper: 1.0).")
    transition_com_height_m: float = _f(0.2, 2.0, "COM height of the DCM at the push-to-slide transition [m] (0.73).")


@dataclass(frozen=True)
class HumanoidSweepConfig:
    motion: str = _f(doc="'walk' or 'skate'.")
    velocities_mps: tuple[float, ...] = _f(0.01, 5.0, "Walking: step length / step period; skating: board speed [m/s].")


@dataclass(frozen=True)
class HumanoidConfig:
    """A complete humanoid (GPM) motion-library build."""

    path: Path
    text: str
    meta: MetaConfig
    humanoid: HumanoidModelConfig
    gpm: GpmConfig
    walk: WalkConfig
    skate: SkateConfig
    sweep: HumanoidSweepConfig

    def resolved_json(self) -> str:
        d = dataclasses.asdict(self)
        d.pop("path")
        d.pop("text")
        return json.dumps(d, sort_keys=True, default=str)


_HUMANOID_SECTIONS: dict[str, type] = {
    "meta": MetaConfig, "humanoid": HumanoidModelConfig, "gpm": GpmConfig, "walk": WalkConfig,
    "skate": SkateConfig, "sweep": HumanoidSweepConfig,
}


def _humanoid(path: Path, data: dict[str, Any], text: str) -> HumanoidConfig:
    cfg = HumanoidConfig(path=path.resolve(), text=text, **_sections(path, data, _HUMANOID_SECTIONS))
    if cfg.sweep.motion not in ("walk", "skate"):
        raise ConfigError(path, "sweep.motion", f"{cfg.sweep.motion!r}: use 'walk' or 'skate'")
    if cfg.gpm.solver not in ("ipopt", "sqp"):
        raise ConfigError(path, "gpm.solver", f"{cfg.gpm.solver!r}: use 'ipopt' or 'sqp'")
    if cfg.humanoid.leg_min_m >= cfg.humanoid.leg_max_m:
        raise ConfigError(path, "humanoid.leg_min_m", "must be below humanoid.leg_max_m")
    if not cfg.sweep.velocities_mps:
        raise ConfigError(path, "sweep.velocities_mps", "is empty: list at least one speed")
    check_unique_keys(path, cfg.sweep.velocities_mps)
    return cfg


def _humanoid_from_json(data: dict[str, Any], origin: Path, urdf: Path | None) -> HumanoidConfig:
    sections = {name: build_section(origin, name, cls, data[name]) for name, cls in _HUMANOID_SECTIONS.items()}
    return HumanoidConfig(path=Path(origin), text="", **sections)


_SECTIONS: dict[str, type] = {
    "meta": MetaConfig, "robot": RobotConfig, "board": BoardConfig, "stance": StanceConfig,
    "schedule": ScheduleConfig, "optimization": OptimizationConfig, "terminal": TerminalConfig,
    "sweep": SweepConfig,
}


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def read_toml(path: Path, chain: tuple[Path, ...] = ()) -> tuple[dict[str, Any], str]:
    """Read a TOML file, following ``extends`` chains; returns (merged table, own text).

    Raises:
        ConfigError: When the file is missing, a folder, not UTF-8 text (a library file, say), not
            valid TOML, or its ``extends`` chain comes back to a file already in it.
    """
    path = Path(path)
    if path.resolve() in chain:
        names = " -> ".join(p.name for p in (*chain, path.resolve()))
        raise ConfigError(chain[0], "extends", f"the extends chain is a cycle: {names}; break it")
    try:
        raw = path.read_bytes()
    except OSError as e:
        what = "is a folder, not a config file" if path.is_dir() else f"cannot be read ({e.strerror})"
        raise ConfigError(path, "-", f"{what}; "
                          f"shipped configs: {', '.join(sorted(p.name for p in CONFIG_DIR.glob('*.toml')))}") from e
    if raw.startswith(HDF5_SIGNATURE):
        raise ConfigError(path, "-", "is an HDF5 file (a motion library?), not a TOML config; "
                          "'skatelib info' and 'skatelib validate' read libraries")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(path, "-", f"is not UTF-8 text (byte {e.start}); a config is a TOML text file") from e
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(path, "-", f"not valid TOML: {e}") from e
    robot = data.get("robot")
    if isinstance(robot, dict) and isinstance(robot.get("urdf"), str):
        # Paths are relative to the file that names them, also through ``extends``.
        robot["urdf"] = str((path.parent / robot["urdf"]).resolve())
    parent = data.pop("extends", None)
    if parent is not None:
        if not isinstance(parent, str):
            raise ConfigError(path, "extends", "must be a file name (string)")
        base, _ = read_toml((path.parent / parent).resolve(), (*chain, path.resolve()))
        data = _merge(base, data)
    return data, text


# Scalar types of config fields: what a TOML value must be, and the words for a wrong one.
_SCALARS: dict[type, tuple[Any, str]] = {
    float: (lambda v: isinstance(v, int | float) and not isinstance(v, bool), "a number"),
    int: (lambda v: isinstance(v, int) and not isinstance(v, bool), "an integer"),
    bool: (lambda v: isinstance(v, bool), "true or false"),
    str: (lambda v: isinstance(v, str), "a string"),
}


def _convert(path: Path, key: str, tp: Any, value: Any, meta: typing.Mapping[str, Any]) -> Any:
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise ConfigError(path, key, f"must be a table, got {value!r}")
        return build_section(path, key, tp, value)
    if typing.get_origin(tp) is tuple:
        if not isinstance(value, list):
            raise ConfigError(path, key, f"must be a list, got {value!r}")
        (inner,) = set(typing.get_args(tp)) - {Ellipsis}
        return tuple(_convert(path, f"{key}[{i}]", inner, v, meta) for i, v in enumerate(value))
    if tp in _SCALARS:
        valid, words = _SCALARS[tp]
        if not valid(value):
            raise ConfigError(path, key, f"must be {words}, got {value!r}")
    if tp is float:
        value = float(value)
        if not math.isfinite(value):
            raise ConfigError(path, key, f"must be a finite number, got {value!r} ({meta.get('doc', '')})")
    if tp in (float, int):
        _check_range(path, key, value, meta)
    return value


def _check_range(path: Path, key: str, value: float, meta: typing.Mapping[str, Any]) -> None:
    lo, hi = meta.get("lo"), meta.get("hi")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ConfigError(path, key, f"{value!r} is out of range [{lo}, {hi}] ({meta.get('doc', '')})")


def build_section(path: Path, prefix: str, cls: type, data: dict[str, Any]) -> Any:
    """Validate one TOML table into the frozen dataclass ``cls``.

    Raises:
        ConfigError: On unknown or missing keys, wrong types or values out of range.
    """
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = typing.get_type_hints(cls)
    unknown = set(data) - set(fields)
    if unknown:
        raise ConfigError(path, f"{prefix}.{sorted(unknown)[0]}",
                          f"unknown key; allowed keys in [{prefix}]: {', '.join(fields)}")
    kwargs: dict[str, Any] = {}
    for name, f in fields.items():
        key = f"{prefix}.{name}"
        if name not in data:
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise ConfigError(path, key, f"missing; {f.metadata.get('doc', '')}")
            continue
        tp = hints[name]
        if isinstance(tp, types.UnionType):
            tp = typing.get_args(tp)[0]
        kwargs[name] = _convert(path, key, tp, data[name], f.metadata)
    return cls(**kwargs)


def _sections(path: Path, data: dict[str, Any], tables: dict[str, type]) -> dict[str, Any]:
    """Validate every table of a config; unknown or missing tables are errors."""
    unknown = set(data) - set(tables)
    if unknown:
        raise ConfigError(path, sorted(unknown)[0], f"unknown table; allowed: {', '.join(tables)}")
    out = {}
    for name, cls in tables.items():
        if name not in data:
            raise ConfigError(path, name, f"missing table [{name}]")
        out[name] = build_section(path, name, cls, data[name])
    return out


def _quadruped(path: Path, data: dict[str, Any], text: str) -> QuadrupedConfig:
    cfg = QuadrupedConfig(path=path.resolve(), text=text, **_sections(path, data, _SECTIONS))
    _check_cross_fields(cfg)
    return cfg


def _quadruped_from_json(data: dict[str, Any], origin: Path, urdf: Path | None) -> QuadrupedConfig:
    if urdf is None:
        raise ConfigError(origin, "robot.urdf", "a quadruped config needs its robot description")
    data["robot"]["urdf"] = str(urdf)
    data.setdefault("terminal", {})  # format 1.0 libraries predate the riding end state
    sections = {name: build_section(origin, name, cls, data[name]) for name, cls in _SECTIONS.items()}
    cfg = QuadrupedConfig(path=Path(origin), text="", **sections)
    _check_cross_fields(cfg)
    return cfg


AnyConfig = QuadrupedConfig | HumanoidConfig
C = typing.TypeVar("C", QuadrupedConfig, HumanoidConfig)
# meta.kind -> (config class, from a TOML file's tables, from a library's resolved JSON)
_KINDS: dict[str, tuple[type, Any, Any]] = {
    "quadruped": (QuadrupedConfig, _quadruped, _quadruped_from_json),
    "humanoid": (HumanoidConfig, _humanoid, _humanoid_from_json),
}


def _kind(path: Path, name: Any, expect: type | None) -> tuple[type, Any, Any]:
    if name not in _KINDS:
        raise ConfigError(path, "meta.kind", f"{name!r}: use one of {', '.join(map(repr, _KINDS))}")
    row = _KINDS[name]
    if expect is not None and row[0] is not expect:
        wanted = next(k for k, r in _KINDS.items() if r[0] is expect)
        raise ConfigError(path, "meta.kind", f"expected {wanted!r}, got {name!r}: this command takes {wanted} configs")
    return row


@typing.overload
def load_config(path: Path | str | None = None) -> AnyConfig: ...
@typing.overload
def load_config(path: Path | str | None, expect: type[C]) -> C: ...
def load_config(path: Path | str | None = None, expect: type | None = None) -> Any:
    """Load and validate a build config of any kind (``meta.kind``), the shipped default when
    ``path`` is None; with ``expect``, one of that config class only.

    Raises:
        ConfigError: On any invalid field, naming the file and key.
    """
    path = Path(path) if path is not None else CONFIG_DIR / DEFAULT_CONFIG
    data, text = read_toml(path)
    _, from_toml, _ = _kind(path, _meta(path, data).get("kind"), expect)
    return from_toml(path, data, text)


@typing.overload
def config_from_json(text: str, origin: Path, urdf: Path | None = None) -> AnyConfig: ...
@typing.overload
def config_from_json(text: str, origin: Path, urdf: Path | None, expect: type[C]) -> C: ...
def config_from_json(text: str, origin: Path, urdf: Path | None = None, expect: type | None = None) -> Any:
    """Rebuild a config from its ``resolved_json()`` (as stored in a library), a quadruped one
    with the robot description at ``urdf``. Errors name ``origin``."""
    data = json.loads(text)
    _, _, from_json = _kind(Path(origin), data.get("meta", {}).get("kind"), expect)
    return from_json(data, Path(origin), urdf)


def _check_cross_fields(cfg: QuadrupedConfig) -> None:
    p = cfg.path
    for key, value, allowed in (
        ("schedule.push_leg", cfg.schedule.push_leg, LEGS), ("meta.kind", cfg.meta.kind, ("quadruped",)),
        ("optimization.integrator", cfg.optimization.integrator, ("etdrk4", "rk4")),
        ("optimization.friction_model", cfg.optimization.friction_model, FRICTION_MODELS),
        ("optimization.mu_strategy", cfg.optimization.mu_strategy, ("monotone", "adaptive")),
    ):
        if value not in allowed:
            raise ConfigError(p, key, f"{value!r}: use one of {', '.join(map(repr, allowed))}")
    for key, names, n, what in (("robot.joint_names", cfg.robot.joint_names, 12, "names (FL FR RL RR x abad hip knee)"),
                                ("robot.foot_frames", cfg.robot.foot_frames, 4, "frame names (FL FR RL RR)")):
        if len(names) != n:
            raise ConfigError(p, key, f"needs {n} {what}")
    if cfg.urdf_path.is_dir():
        raise ConfigError(p, "robot.urdf", f"{cfg.urdf_path} is a folder; name the URDF file in it")
    if not cfg.urdf_path.is_file():
        raise ConfigError(p, "robot.urdf", f"file {cfg.urdf_path} does not exist")
    _check_sweep(cfg)


def _check_sweep(cfg: QuadrupedConfig) -> None:
    p = cfg.path
    if not cfg.sweep.velocities_mps or not cfg.sweep.strides:
        raise ConfigError(p, "sweep", "velocities_mps and strides must not be empty")
    check_unique_keys(p, cfg.sweep.velocities_mps)
    if len(set(cfg.sweep.strides)) != len(cfg.sweep.strides):
        raise ConfigError(p, "sweep.strides", f"{list(cfg.sweep.strides)} repeats a stride count; list each once")
    steps = cfg.schedule.period_s / cfg.optimization.dt_s
    if abs(steps - round(steps)) > 1e-6:
        raise ConfigError(p, "optimization.dt_s", f"must divide schedule.period_s ({cfg.schedule.period_s} s)")


def check_unique_keys(path: Path, velocities: tuple[float, ...]) -> None:
    """Refuse speeds that repeat or that name the same entry (keys keep 2 decimals: 0.501 and 0.504
    are both ``v0.50``), before anything is solved.

    Raises:
        ConfigError: Naming both speeds and the key they share.
    """
    seen: dict[str, float] = {}
    for v in velocities:
        key = f"{v:.2f}"
        if key in seen:
            raise ConfigError(path, "sweep.velocities_mps",
                              f"{seen[key]} and {v} m/s both name entry speed v{key} (entry keys keep 2 decimals); "
                              "list speeds that differ by at least 0.01 m/s, each once")
        seen[key] = v


def field_range(cls: type, name: str) -> tuple[float, float]:
    """The allowed [lo, hi] of a config field, as declared once in its dataclass."""
    meta = {f.name: f.metadata for f in dataclasses.fields(cls)}[name]
    return float(meta["lo"]), float(meta["hi"])


def _meta(path: Path, data: dict[str, Any]) -> dict[str, Any]:
    meta = data.get("meta", {})
    if not isinstance(meta, dict):
        raise ConfigError(path, "meta", f"must be a table ([meta] with kind and name), got {meta!r}")
    return meta
