"""The quadruped's build tasks: entries of one stride count form a warm-start chain along velocity,
solved in one worker from a low speed outwards; each finished entry is cached under a key of
what determines it and judged by the independent physics checks."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

from skatelib.library import schema
from skatelib.pipeline.build import codec
from skatelib.pipeline.build.cache import cache_key, cached_or_solved
from skatelib.pipeline.build.contract import EntryEvent, EventSink
from skatelib.pipeline.build.profile import span
from skatelib.pipeline.quadruped.checks.verify import judge
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.problem.attempts import solve_with_retries
from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, SolveResult, WarmStart, problem_for, solver_options

codec.register(SolveResult, WarmStart)  # what the entry cache holds


def entry_key(spec: PushoffSpec, predecessor: str | None) -> str:
    """Cache key of an entry: what determines its solution.

    The problem's fingerprint (stage function, problem config with the URDF by content, parameters,
    bounds, cold guess), the IPOPT options, target and strides, the key of the entry whose solution
    warm-starts it (``None`` when cold), the library format and the cache version.
    """
    prob = problem_for(spec.config, spec.n_strides, spec.window)
    v, v0 = spec.target_velocity_mps, spec.from_velocity_mps
    parts = (round(v, 9), spec.n_strides, predecessor) + ((round(v0, 9),) if v0 else ())
    return cache_key(prob.fingerprint(v0, v, spec.guess), solver_options(spec), *parts)


@dataclass(frozen=True)
class EntryOutcome:
    """A finished sweep entry: the result (without warm-start data), attempts, cache origin, the
    independent physics measurements, the cache key it is stored under and any note for the user."""

    result: SolveResult
    attempts: int
    cached: bool
    physics: dict[str, float]
    cache_key: str = ""
    note: str = ""

    @property
    def key(self) -> str:
        r = self.result
        return schema.entry_key(r.target_velocity_mps, r.n_strides, r.from_velocity_mps)

    @property
    def success(self) -> bool:
        return self.result.success

    def event(self) -> EntryEvent:
        """The finished event of this entry (what the progress display hears)."""
        r = self.result
        return EntryEvent(self.key, True, r.status, r.success, self.cached)


def solve_order(velocities: Iterable[float]) -> list[tuple[float, float | None]]:
    """(speed, the speed whose solution warm-starts it or None) in solving order: cold at the speed a
    third of the way up (0.3 m/s of the default grid), then down to the slowest and up to the
    fastest, each from its neighbour towards that start. The slowest speed's cold solve is the
    hardest, and the fast cold solves of long pushes are dear (docs/design-notes.md)."""
    v = sorted(velocities)
    if not v:
        return []
    mid = (len(v) - 1) // 3
    down = [(v[i], v[i + 1]) for i in range(mid - 1, -1, -1)]
    up = [(v[i], v[i - 1]) for i in range(mid + 1, len(v))]
    return [(v[mid], None), *down, *up]


@dataclass(frozen=True)
class BuildTask:
    """Entries of one stride count, solved in :func:`solve_order`."""

    config: QuadrupedConfig
    n_strides: int
    velocities: tuple[float, ...]
    ipopt: tuple[tuple[str, Any], ...] = ()  # extra IPOPT options of every solve (e.g. its log level)

    @property
    def n_entries(self) -> int:
        return len(self.velocities)

    @property
    def weight(self) -> float:
        """Its rough cost in seconds of one core, to start the longest tasks first: about 1.1 s a
        stride of each entry."""
        return 1.1 * self.n_strides * len(self.velocities)

    def run(self, use_cache: bool, events: EventSink | None) -> list[EntryOutcome]:
        """Solve the chain in :func:`solve_order`, each entry warm-started from the nearest success on
        its way to the starting speed, cold when there is none (a task of
        :func:`skatelib.pipeline.build.sweep.run_sweep`); cached entries are read instead of solved."""
        out: list[EntryOutcome] = []
        order = solve_order(self.velocities)
        source = dict(order)
        solved: dict[float, tuple[WarmStart | None, str]] = {}
        for v, src in order:
            while src is not None and src not in solved:
                src = source[src]
            warm, warm_key = solved[src] if src is not None else (None, None)
            use_warm = warm if self.config.sweep.warm_start else None
            spec = PushoffSpec(self.config, v, self.n_strides, warm=use_warm, ipopt=self.ipopt)
            key = entry_key(spec, warm_key if use_warm is not None else None)
            if events is not None:
                events.put(EntryEvent(schema.entry_key(v, self.n_strides), done=False))
            payload, cached, note = cached_solve(spec, key, use_cache)
            result, attempts = payload["result"], payload["attempts"]
            if result.success:
                solved[v] = (result.warm, key)
            with span("checks", key=schema.entry_key(v, self.n_strides)):
                judged, physics = judge(self.config, result)
            outcome = EntryOutcome(replace(judged, warm=None), attempts, cached, physics, key, note)
            out.append(outcome)
            if events is not None:
                events.put(outcome.event())
        return out


def _solve(spec: PushoffSpec) -> dict[str, Any]:
    result, attempts = solve_with_retries(spec)
    return {"result": result, "attempts": attempts}


def cached_solve(spec: PushoffSpec, key: str, use_cache: bool) -> tuple[dict[str, Any], bool, str]:
    """The entry of ``spec`` cached under ``key`` (its ``result`` and ``attempts``), or solved with
    the retry ladder and cached; whether it came from the cache, and a note for the user."""
    return cached_or_solved(key, ("result", "attempts"), partial(_solve, spec), use_cache)


def tasks_for(config: QuadrupedConfig, ipopt: tuple[tuple[str, Any], ...] = ()) -> list[BuildTask]:
    """One chain per stride count, longest-running (most strides) first for load balance."""
    v = tuple(sorted(config.sweep.velocities_mps))
    return [BuildTask(config, s, v, ipopt) for s in sorted(config.sweep.strides, reverse=True)]


def ordered(outcomes: Iterable[EntryOutcome]) -> list[EntryOutcome]:
    """The library's entry order: start-ups by strides, then speed; then transitions by start speed,
    then target speed."""
    def order(o: EntryOutcome) -> tuple[float, int, float]:
        r = o.result
        return (r.from_velocity_mps, 0 if r.from_velocity_mps else r.n_strides, r.target_velocity_mps)

    return sorted(outcomes, key=order)
