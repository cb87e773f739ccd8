"""The humanoid's build tasks: one motion (a walk or a skate at one velocity) per task, solved step
by step, cached under a key of what determines it and judged by the independent step checks."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

from skatelib.library import schema
from skatelib.pipeline.build import codec
from skatelib.pipeline.build.cache import cache_key, cached_or_solved
from skatelib.pipeline.build.contract import EntryEvent, EventSink
from skatelib.pipeline.humanoid.body import BodyMotion, body_failures, robot_for, whole_body
from skatelib.pipeline.humanoid.config import HumanoidConfig
from skatelib.pipeline.humanoid.geometry import Support
from skatelib.pipeline.humanoid.motion import Motion, plan_for, plan_json, solve_motion, step_model
from skatelib.pipeline.humanoid.step import SOLVER_OPTIONS, StepResult, StepSpec, step_problem
from skatelib.pipeline.humanoid.verify import judge

codec.register(Motion, StepResult, StepSpec, Support)  # what the entry cache holds


def entry_name(config: HumanoidConfig, velocity_mps: float) -> tuple[str, int]:
    """The entry key of a motion and its strides: walking steps between start and stop, or one
    skating push (``n_phases`` keeps the number of GPM phases)."""
    strides = config.walk.steps if config.sweep.motion == "walk" else 1
    return schema.humanoid_key(config.sweep.motion, velocity_mps, strides), strides


def motion_key(config: HumanoidConfig, velocity_mps: float, plan: list[StepSpec]) -> str:
    """Cache key of a motion: the problem config, the plan (every step's segments, supports and
    terminal targets), each step NLP's expressions and its solver's options, and the velocity."""
    model = step_model(config)
    nlp = hashlib.sha256()
    for terminal in sorted({spec.terminal for spec in plan}):
        prob = step_problem(model.n_nodes, terminal, model.solver)
        nlp.update(f"{terminal}\n{prob.nlp['f']}\n{prob.nlp['g']}\n".encode())
    return cache_key("humanoid", config.problem_json(), plan_json(plan), nlp.hexdigest(),
                     SOLVER_OPTIONS[model.solver], round(velocity_mps, 9))


@dataclass(frozen=True)
class EntryOutcome:
    """A finished motion: the solved motion, the independent checks' failures (none: it holds),
    cache origin and key, and any note for the user."""

    key: str
    motion: Motion
    failures: tuple[str, ...]
    cached: bool
    cache_key: str = ""
    note: str = ""
    body: BodyMotion | None = None  # the whole body (when the COM motion was solved and holds)

    @property
    def success(self) -> bool:
        return self.motion.success and not self.failures

    @property
    def status(self) -> str:
        if self.failures:
            return "Physics_Check_Failed: " + "; ".join(self.failures)
        steps = self.motion.steps
        return "Solve_Succeeded" if self.motion.success else "; ".join(f"{r.spec.name}: {r.status}" for r in steps)

    def event(self) -> EntryEvent:
        return EntryEvent(self.key, True, self.status, self.success, self.cached)


@dataclass(frozen=True)
class BuildTask:
    """One velocity of a humanoid sweep."""

    config: HumanoidConfig
    velocity_mps: float

    @property
    def n_entries(self) -> int:
        return 1

    def run(self, use_cache: bool, events: EventSink | None) -> list[EntryOutcome]:
        """Solve (or read from the cache) and judge the motion (a task of
        :func:`skatelib.pipeline.build.sweep.run_sweep`)."""
        cfg, v = self.config, self.velocity_mps
        name = entry_name(cfg, v)[0]
        if events is not None:
            events.put(EntryEvent(name, done=False))
        key = motion_key(cfg, v, plan_for(cfg, v)[1])
        payload, cached, note = cached_or_solved(key, ("motion",), lambda: {"motion": solve_motion(cfg, v)}, use_cache)
        motion = payload["motion"]
        failures = judge(cfg, motion)
        body = None
        if motion.success and not failures:  # the whole body of a motion that holds (not cached: it is quick)
            robot = robot_for(cfg)
            body = whole_body(cfg, motion, robot)
            deck = (cfg.board, cfg.humanoid.foot_width_m / 2) if cfg.board is not None else None
            checks = body_failures(robot, list(motion.plan), motion.t, body, cfg.humanoid.foot_length_m / 2, deck)
            failures = tuple(f"whole body: {f}" for f in checks)
        outcome = EntryOutcome(name, motion, failures, cached, key, note, body)
        if events is not None:
            events.put(outcome.event())
        return [outcome]
