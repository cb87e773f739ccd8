"""The quadruped's build config: robot, board, stance, schedule, optimization, riding end state
and sweep tables (``configs/cyberdog2.toml``), loaded by :func:`skatelib.pipeline.config.load_config`."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from skatelib.library.channels import LEGS
from skatelib.library.errors import ConfigError
from skatelib.pipeline.config_tables import MetaConfig, build_section, check_unique_keys, sections
from skatelib.pipeline.config_tables import setting as _f
from skatelib.pipeline.quadruped.board_config import BoardConfig, ContactConfig
from skatelib.pipeline.quadruped.ride_config import TerminalConfig, TransitionsConfig
from skatelib.proving.certify.spec import CertifySpec, check_spec

FRICTION_MODELS = ("cone", "polygon8")


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
class StanceConfig:
    base_height_above_deck_m: float = _f(0.05, 0.5, "Trunk origin height above the deck top [m].")
    foot_x_front_m: float = _f(0.0, 0.5, "Front feet x in the board frame [m].")
    foot_x_rear_m: float = _f(-0.5, 0.0, "Rear feet x in the board frame [m].")
    foot_y_m: float = _f(0.01, 0.5, "Feet |y| in the board frame [m].")
    base_x_offset_m: float = _f(-0.3, 0.3, "Trunk origin x in the board frame at rest [m].")
    push_foot_y_m: float = _f(0.0, 0.6, "Pushing foot |y| from the board centre line on the ground [m].")
    push_clearance_m: float = _f(0.0, 0.2, "Lateral clearance of the pushing foot from the deck edge [m].")
    swing_height_m: float = _f(0.0, 0.2, "Least foot lift at mid-swing [m].")
    ride_load_fraction: float = _f(0.0, 0.33, "Riding with the push foot lifted, each deck foot carries at least this "
                                   "share of the weight: where the body sits over the deck [-].", default=0.2)


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
    bound_mult_init: float = _f(1e-9, 1e3, "IPOPT bound_mult_init_val of a cold solve (IPOPT's: 1) [-].", default=1.0)
    mu_max: float = _f(1e-6, 1e5, "IPOPT mu_max, the adaptive barrier's ceiling in a cold solve (IPOPT's: 1e5) [-].",
                       default=1e5)
    mu_min: float = _f(1e-15, 1e-4, "IPOPT mu_min, the barrier's floor (IPOPT's: 1e-11) [-].", default=1e-11)
    warm_mu_strategy: str = _f(doc="IPOPT barrier strategy of a warm-started solve: 'monotone' or 'adaptive'.",
                               default="adaptive")
    warm_mu_init: float = _f(1e-12, 1.0, "IPOPT initial barrier parameter of a warm-started solve [-].", default=1e-4)
    warm_bound_push: float = _f(1e-12, 0.1, "IPOPT warm_start_(mult_)bound_push of a warm-started solve [-].",
                                default=1e-6)
    warm_predictor: bool = _f(doc="Move a warm start's primal point from the speeds it was solved for to the "
                                  "target's by the change of the cold guess between them.", default=False)
    compile: bool = _f(doc="Compile the stage functions with the C compiler (cached on disk).", default=True)
    compile_native: bool = _f(doc="Compile them for this CPU (-march=native: faster; the CPU is part of the cache "
                                  "key) rather than as portable code for any CPU of its architecture.", default=True)
    friction_model: str = _f(
        doc="Friction constraint of every contact: 'cone' (exact Coulomb cone, mu^2 f_n^2 >= |f_t|^2, f_n >= 0) "
            "or 'polygon8' (inscribed 8-facet pyramid, inside the cone).", default="cone")
    friction_margin: float = _f(0.5, 1.0, "Planning margin: the TO uses mu_plan = margin x mu [-].", default=1.0)
    rolling_friction_factor: float = _f(
        1.0, 5.0, "The TO plans against this multiple of the board's rolling resistance; on a board that rolls "
        "easier the controller pushes less (docs/closed-loop.md) [-].", default=1.0)
    joint_limit_margin_rad: float = _f(0.0, 0.3, "The TO keeps joint angles this far inside their limits [rad].",
                                       default=0.0)
    weights: WeightsConfig = _f(doc="Cost weights of Eq. (16).", default_factory=lambda: WeightsConfig(
        **{f.name: 0.0 for f in dataclasses.fields(WeightsConfig)}))


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
    contact: ContactConfig
    schedule: ScheduleConfig
    optimization: OptimizationConfig
    terminal: TerminalConfig
    sweep: SweepConfig
    transitions: TransitionsConfig
    certify: CertifySpec  # what skatelib certify draws (not part of the build)

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
        d.pop("certify")
        for key in ("speeds_mps", "stops", "strides", "twin_judge", "twin_speed_share"):  # built and judged, not posed
            d["transitions"].pop(key)
        d["optimization"].pop("compile")
        d["optimization"].pop("compile_native")
        d["robot"]["urdf"] = hashlib.sha256(self.urdf_path.read_bytes()).hexdigest()
        return json.dumps(d, sort_keys=True)


_SECTIONS: dict[str, type] = {
    "meta": MetaConfig, "robot": RobotConfig, "board": BoardConfig, "stance": StanceConfig,
    "contact": ContactConfig, "schedule": ScheduleConfig, "optimization": OptimizationConfig,
    "terminal": TerminalConfig, "sweep": SweepConfig, "transitions": TransitionsConfig,
    "certify": CertifySpec,
}


def from_toml(path: Path, data: dict[str, Any], text: str) -> QuadrupedConfig:
    data = {**data, "transitions": data.get("transitions", {}), "certify": data.get("certify", {})}  # optional
    cfg = QuadrupedConfig(path=path.resolve(), text=text, **sections(path, data, _SECTIONS))
    check_spec(cfg.certify, path)
    _check_cross_fields(cfg)
    return cfg


def from_json(data: dict[str, Any], origin: Path, urdf: Path | None) -> QuadrupedConfig:
    if urdf is None:
        raise ConfigError(origin, "robot.urdf", "a quadruped config needs its robot description")
    data["robot"]["urdf"] = str(urdf)
    data.setdefault("terminal", {})  # format 1.0 libraries predate the riding end state
    data.setdefault("transitions", {})  # libraries before 1.4 hold start-ups only
    data.setdefault("certify", {})  # libraries before 1.6 had no [certify] table
    sections = {name: build_section(origin, name, cls, data[name]) for name, cls in _SECTIONS.items()}
    cfg = QuadrupedConfig(path=Path(origin), text="", **sections)
    _check_cross_fields(cfg)
    return cfg


def _check_cross_fields(cfg: QuadrupedConfig) -> None:
    p = cfg.path
    for key, value, allowed in (
        ("schedule.push_leg", cfg.schedule.push_leg, LEGS), ("meta.kind", cfg.meta.kind, ("quadruped",)),
        ("optimization.integrator", cfg.optimization.integrator, ("etdrk4", "rk4")),
        ("optimization.friction_model", cfg.optimization.friction_model, FRICTION_MODELS),
        ("optimization.mu_strategy", cfg.optimization.mu_strategy, ("monotone", "adaptive")),
        ("optimization.warm_mu_strategy", cfg.optimization.warm_mu_strategy, ("monotone", "adaptive")),
    ):
        if value not in allowed:
            raise ConfigError(p, key, f"{value!r}: use one of {', '.join(map(repr, allowed))}")
    for key, names, n, what in (("robot.joint_names", cfg.robot.joint_names, 12, "names (FL FR RL RR x abad hip knee)"),
                                ("robot.foot_frames", cfg.robot.foot_frames, 4, "frame names (FL FR RL RR)")):
        if len(names) != n:
            raise ConfigError(p, key, f"needs {n} {what}")
    b = cfg.board
    parts: tuple[tuple[str, float, float, str], ...] = (
        ("board.roll_axis_height_m", b.roll_axis_height_m, b.deck_height_m, "deck_height_m"),
        ("board.deck_mass_kg", b.deck_mass_kg, b.mass_kg, "mass_kg"),
        ("board.wheel_track_m", b.wheel_track_m, b.truck_width_m, "truck_width_m"))
    for name, part, whole, what in parts:
        if part > whole:
            raise ConfigError(p, name, f"{part} is more than board.{what} ({whole}); it is part of it")
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
    check_unique_keys(p, cfg.transitions.speeds_mps, "transitions.speeds_mps")
    if len(set(cfg.transitions.strides)) != len(cfg.transitions.strides) or not cfg.transitions.strides:
        raise ConfigError(p, "transitions.strides", f"{list(cfg.transitions.strides)}: list each stride count once")
    if len(set(cfg.sweep.strides)) != len(cfg.sweep.strides):
        raise ConfigError(p, "sweep.strides", f"{list(cfg.sweep.strides)} repeats a stride count; list each once")
    steps = cfg.schedule.period_s / cfg.optimization.dt_s
    if abs(steps - round(steps)) > 1e-6:
        raise ConfigError(p, "optimization.dt_s", f"must divide schedule.period_s ({cfg.schedule.period_s} s)")

