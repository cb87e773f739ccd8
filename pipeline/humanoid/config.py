"""The humanoid's build config: point-mass model, GPM, walk, skate and sweep tables
(``configs/hrp2_walk.toml``), loaded by :func:`skatelib.pipeline.config.load_config`."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from skatelib.library.errors import ConfigError
from skatelib.pipeline.config_tables import CONFIG_DIR, MetaConfig, build_section, check_unique_keys, sections
from skatelib.pipeline.config_tables import setting as _f


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
    push_foothold_m: float = _f(-0.5, 0.5, "Where the pushing foot stands, ahead of the board foot's start [m] "
                                           "(0: beside it).", default=0.0)
    toe_off_s: float = _f(0.0, 5.0, "Toe-off: the pushing foot's heel rises over the push's last toe_off_s [s], its "
                                    "toe edge on the ground (the support polygon's part of that foot); 0: flat.",
                          default=0.0)
    toe_off_rad: float = _f(0.0, 1.2, "Toe-off: the pushing sole's pitch (heel up) at lift-off [rad].", default=0.0)
    landing_behind_m: float = _f(0.0, 1.0, "Where the pushing foot lands on the deck: its centre this far behind the "
                                           "board foot's, on the deck's centre line [m] (0: beside the board foot, "
                                           "the plan of a deck-less board).", default=0.0)


@dataclass(frozen=True)
class HumanoidBoardConfig:
    """The skateboard of a humanoid skate: the deck's height is in the plan (the board foot stands
    on it, the pushing foot lands on it), the rest is what the twin builds the board from."""

    deck_height_m: float = _f(0.0, 0.5, "The deck's top above the ground [m].")
    deck_length_m: float = _f(0.2, 2.0, "Deck length [m].")
    deck_width_m: float = _f(0.05, 0.6, "Deck width [m].")
    foot_ahead_m: float = _f(-1.0, 1.0, "The board foot's centre ahead of the deck's centre [m].")
    l_front_m: float = _f(0.05, 1.0, "Front axle ahead of the deck's centre [m].")
    l_rear_m: float = _f(0.05, 1.0, "Rear axle behind the deck's centre [m].")
    wheel_radius_m: float = _f(0.01, 0.2, "Wheel radius [m] (the axles' height).")
    wheel_track_m: float = _f(0.05, 0.6, "Between the left and right wheels' centres [m].")
    mass_kg: float = _f(0.5, 20.0, "The whole board's mass [kg].")
    deck_mass_kg: float = _f(0.2, 20.0, "The deck's share of the mass [kg] (the rest: hangers and wheels).")
    pivot_from_horizontal_rad: float = _f(0.1, 1.5, "The trucks' pivot axis angle from the ground [rad].")
    roll_stiffness_Nm_per_rad: float = _f(1.0, 1e5, "The deck's roll stiffness on its trucks' bushings [N m/rad].")
    roll_damping_Nms_per_rad: float = _f(0.0, 1e4, "The deck's roll damping [N m s/rad].")
    rolling_coeff: float = _f(0.0, 0.1, "Rolling resistance over the wheels' load [-].")
    deck_mu: float = _f(0.1, 3.0, "Friction coefficient of a sole on the deck's grip tape [-].")
    source: str = _f(doc="Where the figures come from.", default="")


@dataclass(frozen=True)
class WholebodyConfig:
    """The stages after the COM optimization (the paper's Fig. 5); the table may be left out."""

    urdf: str = _f(doc="Robot description (URDF), relative to the config file or absolute; empty: the shipped "
                       "HRP-2-class model.", default="")
    swing_height_m: float = _f(0.0, 0.5, "Swing foot's highest point over its path [m].", default=0.05)
    skate_swing_s: float = _f(0.05, 5.0, "Skating: the pushing foot's swing onto the board [s].", default=0.6)
    preview_s: float = _f(0.05, 5.0, "Dynamics filter's preview of the ZMP reference [s] (Kajita: 1.6).",
                          default=1.6)

    def urdf_path(self, config: Path) -> Path:
        if not self.urdf:
            return CONFIG_DIR / "robots" / SHIPPED_URDF
        p = Path(self.urdf)
        return p if p.is_absolute() else config.parent / p


SHIPPED_URDF = "hrp2_class.urdf"


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
    wholebody: WholebodyConfig
    board: HumanoidBoardConfig | None = None  # a skate's [board] (None: none given)

    def resolved_json(self) -> str:
        d = dataclasses.asdict(self)
        d.pop("path")
        d.pop("text")
        return json.dumps(d, sort_keys=True, default=str)

    def problem_json(self) -> str:
        """The part of the config that determines a COM motion, as JSON: no name, no velocity list
        and no whole-body stage (as the quadruped's ``problem_json``, the config part of an entry's
        cache key; the whole-body stage runs after the cache)."""
        d = json.loads(self.resolved_json())
        d.pop("meta")
        d.pop("wholebody")
        d["sweep"].pop("velocities_mps")
        if d.get("board") is None:  # a config without a board: the key of a plan from before boards
            d.pop("board", None)
        return json.dumps(d, sort_keys=True)

DECK_THICKNESS_M = 0.015  # a 7-ply maple deck, as the twin builds it (skatelib.sim.figures)

_HUMANOID_SECTIONS: dict[str, type] = {
    "meta": MetaConfig, "humanoid": HumanoidModelConfig, "gpm": GpmConfig, "walk": WalkConfig,
    "skate": SkateConfig, "sweep": HumanoidSweepConfig, "wholebody": WholebodyConfig,
}


def _board(path: Path, data: dict[str, Any]) -> HumanoidBoardConfig | None:
    if "board" not in data:
        return None
    if not isinstance(data["board"], dict):
        raise ConfigError(path, "board", f"must be a table, got {data['board']!r}")
    board: HumanoidBoardConfig = build_section(path, "board", HumanoidBoardConfig, data["board"])
    return board


def from_toml(path: Path, data: dict[str, Any], text: str) -> HumanoidConfig:
    data = {**data, "wholebody": data.get("wholebody", {})}  # an optional table: its defaults
    board = _board(path, data)
    data = {k: v for k, v in data.items() if k != "board"}
    tables = sections(path, data, _HUMANOID_SECTIONS, ("board",))
    cfg = HumanoidConfig(path=path.resolve(), text=text, **tables, board=board)
    urdf = cfg.wholebody.urdf_path(cfg.path)
    if not urdf.is_file():
        raise ConfigError(path, "wholebody.urdf", f"{urdf} is not a file; name a URDF, or leave the key out for "
                                                  "the shipped HRP-2-class model")
    if cfg.sweep.motion not in ("walk", "skate"):
        raise ConfigError(path, "sweep.motion", f"{cfg.sweep.motion!r}: use 'walk' or 'skate'")
    if cfg.gpm.solver not in ("ipopt", "sqp"):
        raise ConfigError(path, "gpm.solver", f"{cfg.gpm.solver!r}: use 'ipopt' or 'sqp'")
    if cfg.humanoid.leg_min_m >= cfg.humanoid.leg_max_m:
        raise ConfigError(path, "humanoid.leg_min_m", "must be below humanoid.leg_max_m")
    _check_reach(path, cfg)
    if cfg.skate.toe_off_s > cfg.skate.push_s:
        raise ConfigError(path, "skate.toe_off_s", f"{cfg.skate.toe_off_s} s is longer than the push "
                                                   f"(skate.push_s = {cfg.skate.push_s} s): the heel rises within it")
    if cfg.sweep.motion == "skate":
        _check_skate(path, cfg)
    if not cfg.sweep.velocities_mps:
        raise ConfigError(path, "sweep.velocities_mps", "is empty: list at least one speed")
    check_unique_keys(path, cfg.sweep.velocities_mps)
    return cfg


def _check_reach(path: Path, cfg: HumanoidConfig) -> None:
    """Standing, the COM is its height over the sole it stands on: a height outside the legs' reach
    (Eq. 21's r_min to r_max) has no plan, which the solver would spend its iterations finding out."""
    h = cfg.humanoid
    for key, height in (("humanoid.com_height_m", h.com_height_m),
                        ("skate.transition_com_height_m", cfg.skate.transition_com_height_m)):
        if not h.leg_min_m < height < h.leg_max_m:
            raise ConfigError(path, key, f"{height} m is outside the legs' reach, humanoid.leg_min_m to leg_max_m "
                                         f"({h.leg_min_m} to {h.leg_max_m} m): the COM stands that high over its sole")


def _check_skate(path: Path, cfg: HumanoidConfig) -> None:
    """A skate plan needs its board, and its feet must fit on the deck: the pushing foot stands
    beside it on the ground and lands on it behind the board foot."""
    b, h = cfg.board, cfg.humanoid
    if b is None:
        raise ConfigError(path, "board", "a skate needs its [board] table (deck height, length and width, the "
                                         "board foot's place, trucks and wheels): see configs/hrp2_skate.toml")
    if cfg.skate.landing_behind_m < h.foot_length_m:
        raise ConfigError(path, "skate.landing_behind_m", f"{cfg.skate.landing_behind_m} m: the pushing foot lands on "
                                                          f"the deck behind the board foot, at least a sole's length "
                                                          f"({h.foot_length_m} m) behind it")
    front = b.foot_ahead_m + h.foot_length_m / 2
    rear = b.foot_ahead_m - cfg.skate.landing_behind_m - h.foot_length_m / 2
    if front > b.deck_length_m / 2 or rear < -b.deck_length_m / 2:
        raise ConfigError(path, "board.foot_ahead_m", f"the soles span {rear:+.3f} to {front:+.3f} m along the deck "
                                                      f"(its ends at +-{b.deck_length_m / 2:.3f} m): move the board "
                                                      "foot, or change skate.landing_behind_m or the deck's length")
    if b.deck_height_m < b.wheel_radius_m + DECK_THICKNESS_M:
        raise ConfigError(path, "board.deck_height_m", f"{b.deck_height_m} m: the deck's top stands a deck's "
                                                       f"thickness ({DECK_THICKNESS_M} m) at least above the axles "
                                                       f"(board.wheel_radius_m = {b.wheel_radius_m} m)")
    if h.foot_width_m > b.deck_width_m:
        raise ConfigError(path, "board.deck_width_m", f"{b.deck_width_m} m is narrower than a sole "
                                                      f"({h.foot_width_m} m): widen the deck")
    gap = h.step_width_m - h.foot_width_m / 2 - b.deck_width_m / 2
    if gap <= 0.0:
        raise ConfigError(path, "board.deck_width_m", f"the pushing foot on the ground (humanoid.step_width_m = "
                                                      f"{h.step_width_m} m beside the board foot) overlaps the deck "
                                                      f"by {-gap * 100:.1f} cm: narrow the deck or widen the step")


def from_json(data: dict[str, Any], origin: Path, urdf: Path | None) -> HumanoidConfig:
    data = {**data, "wholebody": data.get("wholebody", {})}  # libraries written before the table
    sections = {name: build_section(origin, name, cls, data[name]) for name, cls in _HUMANOID_SECTIONS.items()}
    board = build_section(origin, "board", HumanoidBoardConfig, data["board"]) if data.get("board") else None
    return HumanoidConfig(path=Path(origin), text="", **sections, board=board)
