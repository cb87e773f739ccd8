"""Walking and skating step sequences of the humanoid paper (Sec. V), and their sampling into
library entries.

Walking: a double-support start, ``steps`` steps of single support then double support on the
new foot (footsteps ``step_length`` apart, alternating feet), and a stop over both feet.
Skating: the left foot pushes on the ground (static contact, the representative point) while the
right foot rides the board; at the push-to-slide transition the DCM sits above the board foot at
the transition height, moving with the board; the slide rides the board foot alone with no
friction along the board; the stop brings the COM back over both feet on the board.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.pipeline.humanoid.config import HumanoidConfig
from skatelib.pipeline.humanoid.geometry import Support, convex_hull, rectangle
from skatelib.pipeline.humanoid.step import StepModel, StepResult, StepSpec, solve_sequence
from skatelib.pipeline.ocp.gpm import GaussPseudospectral

PUSH_SEGMENTS = 20


def _rect(c: HumanoidConfig, foot: np.ndarray, ref: np.ndarray) -> tuple[tuple[float, float], ...]:
    h = c.humanoid
    return rectangle(float(foot[0] - ref[0]), float(foot[1] - ref[1]), h.foot_length_m, h.foot_width_m)


def _hull(c: HumanoidConfig, feet: list[np.ndarray], ref: np.ndarray) -> tuple[tuple[float, float], ...]:
    return convex_hull(np.vstack([np.asarray(_rect(c, f, ref)) for f in feet]))


def _toe_edge(c: HumanoidConfig, foot: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """(2, 2) the ends of a sole's toe edge (facing +x), relative to ``ref``: all of it on the
    ground once its heel rises."""
    h = c.humanoid
    x, y = float(foot[0] - ref[0]) + h.foot_length_m / 2, float(foot[1] - ref[1])
    return np.array([[x, y - h.foot_width_m / 2], [x, y + h.foot_width_m / 2]])


def walking_steps(c: HumanoidConfig, velocity: float) -> tuple[np.ndarray, list[StepSpec]]:
    """Initial state and steps for walking at ``velocity`` (step length = velocity x step period)."""
    h, w = c.humanoid, c.walk
    mu, z = h.friction_mu, h.com_height_m
    length = velocity * (w.single_support_s + w.double_support_s)
    right, left = np.array([0.0, -h.step_width_m / 2, 0.0]), np.array([0.0, h.step_width_m / 2, 0.0])
    mid = (right + left) / 2
    start = Support(tuple(mid), (0, 0, 0), _hull(c, [right, left], mid), mu, mu)
    steps = [StepSpec("start", w.start_s, ((0.0, start),), "walk", tuple(right), dz_vrp_m=z, mu_next=mu)]
    stance, swing = right, left
    for j in range(1, w.steps + 1):
        landed = np.array([j * length, swing[1], 0.0])
        mid = (stance + landed) / 2
        segs = ((0.0, Support(tuple(stance), (0, 0, 0), _rect(c, stance, stance), mu, mu)),
                (w.single_support_s, Support(tuple(mid), (0, 0, 0), _hull(c, [stance, landed], mid), mu, mu)))
        steps.append(StepSpec(f"step{j}", w.single_support_s + w.double_support_s, segs, "walk", tuple(landed),
                              dz_vrp_m=z, mu_next=mu))
        stance, swing = landed, stance
    mid = (stance + swing) / 2
    steps.append(StepSpec("stop", w.stop_s, ((0.0, Support(tuple(mid), (0, 0, 0), _hull(c, [stance, swing], mid),
                                                          mu, mu)),), "stop", tuple(mid + np.array([0.0, 0.0, z]))))
    return np.array([0.0, 0.0, z, 0.0, 0.0, 0.0]), steps


def deck_height(c: HumanoidConfig) -> float:
    """The deck's top above the ground [m] (0 without a board)."""
    return c.board.deck_height_m if c.board is not None else 0.0


def skating_steps(c: HumanoidConfig, velocity: float) -> tuple[np.ndarray, list[StepSpec]]:
    """Initial state and the push, slide and stop phases for a board speed ``velocity``. The board
    foot stands on the deck (its support point at the deck's height, the pendulum's heights
    measured from it); the pushing foot on the ground beside the board, then on the deck behind
    the board foot (``skate.landing_behind_m``; 0: beside it, a board without a deck)."""
    h, s = c.humanoid, c.skate
    mu, z = h.friction_mu, h.com_height_m
    deck = deck_height(c)
    ground = np.array([s.push_foothold_m, h.step_width_m / 2, 0.0])
    board = np.array([0.0, -h.step_width_m / 2, deck])
    v = np.array([velocity, 0.0, 0.0])
    board_end = board + v * s.push_s / 2  # the board speeds up evenly from rest during the push
    # Both soles carry the robot during the push: the support polygon is the hull of the ground foot
    # and the board foot where the board has rolled to (updated in PUSH_SEGMENTS pieces); a piece
    # that ends in the toe-off has only the ground foot's toe edge.
    segs = []
    heel_up = s.push_s - s.toe_off_s if s.toe_off_s > 0.0 and s.toe_off_rad > 0.0 else np.inf
    for i in range(PUSH_SEGMENTS):
        t_mid = (i + 0.5) * s.push_s / PUSH_SEGMENTS
        on_board = board + v * t_mid**2 / (2 * s.push_s)
        toe_off = (i + 1) * s.push_s / PUSH_SEGMENTS > heel_up + 1e-9
        ground_part = _toe_edge(c, ground, ground) if toe_off else np.asarray(_rect(c, ground, ground))
        polygon = convex_hull(np.vstack([ground_part, np.asarray(_rect(c, on_board, ground))]))
        segs.append((i * s.push_s / PUSH_SEGMENTS, Support(tuple(ground), (0, 0, 0), polygon, mu, mu)))
    push = StepSpec("push", s.push_s, tuple(segs), "skate", tuple(board_end), tuple(v),
                    dz_vrp_m=s.transition_com_height_m, mu_next=0.0)
    foot_b = board_end + v * s.slide_s
    # The pushing foot steps onto the board: behind the board foot on the deck, or beside it.
    foot_g = foot_b - np.array([s.landing_behind_m, 0.0, 0.0]) if s.landing_behind_m > 0.0 else \
        np.array([foot_b[0], ground[1], deck])
    mid = (foot_b + foot_g) / 2
    # The slide ends with its DCM over the stance to come (both feet on the board), at walking height.
    slide = StepSpec("slide", s.slide_s, ((0.0, Support(tuple(board_end), tuple(v), _rect(c, board_end, board_end),
                                                       0.0, mu)),), "dcm_on_board", tuple(mid), tuple(v), dz_vrp_m=z)
    stop = StepSpec("stop", s.stop_s, ((0.0, Support(tuple(mid), tuple(v), _hull(c, [foot_b, foot_g], mid), 0.0, mu)),),
                    "stop_on_board", tuple(mid + v * s.stop_s + np.array([0.0, 0.0, z])), tuple(v))
    return np.array([0.0, 0.0, z, 0.0, 0.0, 0.0]), [push, slide, stop]


@dataclass(frozen=True)
class Motion:
    """A solved motion: its steps, sampled trajectory and totals."""

    velocity_mps: float
    steps: list[StepResult]
    t: np.ndarray
    state: np.ndarray
    control: np.ndarray
    zmp: np.ndarray
    contact_point: np.ndarray
    step_index: np.ndarray
    n_planned: int = 0  # steps in the plan; fewer results mean a step failed and the rest was not tried
    plan: tuple[StepSpec, ...] = ()  # every planned step, solved or not (stored with the entry)

    @property
    def success(self) -> bool:
        return bool(self.steps) and all(r.success for r in self.steps) and len(self.steps) == self.n_planned


def step_model(c: HumanoidConfig) -> StepModel:
    """The config's node count, gravity, leg reach and solver, shared by every step."""
    h = c.humanoid
    return StepModel(c.gpm.nodes, h.gravity_mps2, h.leg_min_m, h.leg_max_m, c.gpm.solver)


def plan_for(c: HumanoidConfig, velocity: float) -> tuple[np.ndarray, list[StepSpec]]:
    """The initial state and the steps of the config's motion (walk or skate) at ``velocity``."""
    return (walking_steps if c.sweep.motion == "walk" else skating_steps)(c, velocity)


def solve_motion(c: HumanoidConfig, velocity: float) -> Motion:
    """Plan and solve a walk or a skate at ``velocity``, step by step, then sample it."""
    x0, specs = plan_for(c, velocity)
    h = c.humanoid
    results = solve_sequence(specs, x0, step_model(c))
    t, X, U, Z, P, S = sample(results, c.gpm.sample_dt_s, h.gravity_mps2)
    return Motion(velocity, results, t, X, U, Z, P, S, n_planned=len(specs), plan=tuple(specs))


def plan_json(plan: Sequence[StepSpec]) -> str:
    """A plan as stored with its entry (``plan_json``): steps, contact segments with their support
    polygons and friction, terminal kinds and targets."""
    return json.dumps([dataclasses.asdict(spec) for spec in plan])


def plan_from_json(text: str) -> list[StepSpec]:
    """The plan an entry was solved for, from its ``plan_json`` (floats round-trip exactly)."""

    def support(d: dict[str, Any]) -> Support:
        return Support(tuple(d["p0"]), tuple(d["velocity"]), tuple(tuple(v) for v in d["polygon"]),
                       d["mu_x"], d["mu_y"])

    return [StepSpec(d["name"], d["duration_s"], tuple((t0, support(s)) for t0, s in d["segments"]), d["terminal"],
                     tuple(d["p_step"]), tuple(d["v_step"]), d["dz_vrp_m"], d["mu_next"]) for d in json.loads(text)]


def stored_plan(lib: Any, e: Any) -> list[StepSpec]:
    """The entry's stored plan; a library from before plans were stored (no ``plan_json``) gets
    it rebuilt from its stored config with today's code."""
    if schema.A_PLAN in e.attrs:
        return plan_from_json(str(e.attrs[schema.A_PLAN]))
    from skatelib.pipeline.config import config_from_json
    from skatelib.pipeline.humanoid.config import HumanoidConfig

    cfg = config_from_json(str(lib.attrs[schema.A_CONFIG_RESOLVED]), lib.path, None, HumanoidConfig)
    return plan_for(cfg, e.target_velocity_mps)[1]


def sample(results: list[StepResult], dt: float, g: float) -> tuple[np.ndarray, ...]:
    """Uniform samples of every solved step: state (Lagrange through the support points and the
    quadrature end state), acceleration (through the LG nodes), ZMP and contact point."""
    ts, xs, us, zs, ps, si = [], [], [], [], [], []
    for j, r in enumerate(results):
        T = r.spec.duration_s
        gpm = GaussPseudospectral(len(r.U))
        last = j == len(results) - 1
        local = np.arange(0.0, T + (dt / 2 if last else -dt / 2), dt)
        tau = gpm.to_tau(local, 0.0, T)
        X = gpm.interpolate_state(r.X, tau)
        X[-1] = r.Xf if last and abs(local[-1] - T) < 1e-9 else X[-1]
        A = gpm.interpolate_control(r.U, tau)
        P0 = np.array([_contact_at(r, tt) for tt in local])
        rel = X[:, 0:3] - P0
        F = A + np.array([0.0, 0.0, g])
        zmp = P0[:, 0:2] + rel[:, 0:2] - rel[:, 2:3] * F[:, 0:2] / F[:, 2:3]
        ts.append(r.t0 + local)
        xs.append(X)
        us.append(A)
        zs.append(zmp)
        ps.append(P0)
        si.append(np.full(len(local), j, dtype=np.int16))
    t = np.concatenate(ts)
    return (t, np.vstack(xs), np.vstack(us)[:-1], np.vstack(zs), np.vstack(ps), np.concatenate(si))


def _contact_at(r: StepResult, t: float) -> np.ndarray:
    start, s = [seg for seg in r.spec.segments if seg[0] <= t + 1e-12][-1]
    return np.asarray(s.p0) + np.asarray(s.velocity) * (t - start)


__all__ = ["Motion", "deck_height", "plan_from_json", "plan_json", "skating_steps", "solve_motion",
           "stored_plan", "walking_steps"]


def node_arrays(m: Motion, n_nodes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every solved step's node times (S, N+2), states at tau_0..tau_N and the end (S, N+2, 6) and
    controls at the LG nodes (S, N, 3)."""
    support = GaussPseudospectral(n_nodes).support
    nodes_t = np.stack([r.t0 + np.concatenate([(support + 1) / 2 * r.spec.duration_s, [r.spec.duration_s]])
                        for r in m.steps])
    nodes_state = np.stack([np.vstack([r.X, r.Xf]) for r in m.steps])
    return nodes_t, nodes_state, np.stack([r.U for r in m.steps])


def served_arrays(m: Motion, n_nodes: int) -> dict[str, np.ndarray]:
    """The datasets of a solved motion that an entry stores and serves (the sampled COM motion, its
    ZMP, contact points and step index, every step's node values), by their dataset names: what
    the library writes and the build's judge checks."""
    nodes_t, nodes_state, nodes_control = node_arrays(m, n_nodes)
    return {schema.D_T: m.t, schema.D_STATE: m.state, schema.D_CONTROL: m.control, schema.D_ZMP: m.zmp,
            schema.D_CONTACT_POINT: m.contact_point, schema.D_STEP_INDEX: m.step_index, schema.D_NODES_T: nodes_t,
            schema.D_NODES_STATE: nodes_state, schema.D_NODES_CONTROL: nodes_control,
            schema.D_NODES_CONTACT_POINT: np.stack([r.P0 for r in m.steps])}
