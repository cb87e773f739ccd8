"""The reachable-speed frontier: per stride count, the fastest label that converges and passes the
independent physics checks; for transitions, per start speed the fastest speed-up, and the fastest
speed a stop of so many strides stops from.

Each lane (:class:`Lane`: the start-ups, the speed-ups from one riding speed, or the stops) and
stride count is one search: it climbs in steps of ``step_mps`` from ``start_mps`` (a speed-up: from
its start speed plus a step) until a speed fails (IPOPT does not converge, or the physics checks
refuse the result); then it bisects between the last success (a speed-up: at first its start
speed) and the first failure until the gap is at most ``resolution_mps``. Start-ups warm-start
along the search (and cold when that fails); transitions solve cold with the build's retry ladder
(their knot window changes with the speeds, and with it the multipliers a warm start would carry).
Searches run in parallel processes, like the sweep. The twin does not judge here (``[transitions]
twin_judge`` judges a build's candidates): the frontier is the plan's reach.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from functools import partial

from skatelib.pipeline.build.sweep import in_workers
from skatelib.pipeline.quadruped.checks.verify import judge
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.problem.attempts import solve_with_retries
from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, SolveResult, WarmStart, solve


@dataclass(frozen=True)
class Probe:
    """One tried label: its speed, whether it converged and validated, and its status."""

    velocity_mps: float
    ok: bool
    status: str
    iterations: int
    momentum_speed_mps: float


@dataclass(frozen=True)
class FrontierSearch:
    """How to search: start, step, resolution and the highest speed tried [m/s]."""

    start_mps: float = 0.5
    step_mps: float = 0.25
    resolution_mps: float = 0.02
    max_mps: float = 3.0


@dataclass(frozen=True)
class Lane:
    """What a search varies: a start-up's label (the default), a speed-up's target from
    ``from_mps``, or (``stop``) the speed a stop starts from."""

    from_mps: float = 0.0
    stop: bool = False

    @property
    def start_up(self) -> bool:
        """The start-ups' lane (the only one that warm-starts along its search)."""
        return not self.stop and not self.from_mps

    @property
    def label(self) -> str:
        return "stop (from)" if self.stop else f"speed-up from {self.from_mps:.2f}" if self.from_mps else "start-up"

    def spec(self, config: QuadrupedConfig, v: float, strides: int, warm: WarmStart | None) -> PushoffSpec:
        """The problem of the probe at ``v``."""
        if self.stop:
            return PushoffSpec(config, 0.0, strides, from_velocity_mps=v)
        return PushoffSpec(config, v, strides, warm=warm, from_velocity_mps=self.from_mps)

    @property
    def floor(self) -> float:
        """Where a bisection's lower end starts: a speed-up's start speed (it is no speed-up below)."""
        return 0.0 if self.stop else self.from_mps

    def start(self, search: FrontierSearch) -> float:
        return round(self.from_mps + search.step_mps, 6) if self.from_mps and not self.stop else search.start_mps


@dataclass(frozen=True)
class FrontierPoint:
    """The frontier of one lane and stride count.

    Attributes:
        n_strides: Push strides.
        fastest_mps: Fastest label that converged and validated (0, or a speed-up's start speed, when
            even the first failed); for a stop, the fastest start speed.
        first_failure_mps: Slowest label tried that failed above it (``None``: ``max_mps`` was reached).
        limit: The status of that failure (what stopped it), or ``"search limit"``.
        probes: Every label tried, in order.
        from_mps / stop: The lane (:class:`Lane`).
    """

    n_strides: int
    fastest_mps: float
    first_failure_mps: float | None
    limit: str
    probes: tuple[Probe, ...]
    from_mps: float = 0.0
    stop: bool = False

    @property
    def lane(self) -> Lane:
        return Lane(self.from_mps, self.stop)


def _try(config: QuadrupedConfig, v: float, strides: int, warm: WarmStart | None, lane: Lane
         ) -> tuple[SolveResult, Probe]:
    """Solve a start-up warm (when given) and else cold, a transition with the build's retries;
    judge the converged result with the physics checks."""
    if lane.start_up:
        result = solve(lane.spec(config, v, strides, warm))
        if not result.success and warm is not None:
            result = solve(lane.spec(config, v, strides, None))
    else:  # cold: the build's retry ladder, so that the frontier holds what a build would solve
        result, _ = solve_with_retries(lane.spec(config, v, strides, None))
    judged, physics = judge(config, result)
    probe = Probe(v, judged.success, judged.status, result.iterations, physics.get("momentum_speed_mps", float("nan")))
    return result, probe


def frontier_for(config: QuadrupedConfig, strides: int, search: FrontierSearch, lane: Lane = Lane()) -> FrontierPoint:
    """Climb, then bisect, one lane and stride count (a module-level function for worker processes)."""
    probes: list[Probe] = []
    best, best_warm, fail, limit = lane.floor, None, None, "search limit"
    v = lane.start(search)
    while v <= search.max_mps + 1e-9:
        result, probe = _try(config, v, strides, best_warm, lane)
        probes.append(probe)
        if not probe.ok:
            fail, limit = v, probe.status
            break
        best, best_warm = v, result.warm if lane.start_up else None
        v = round(v + search.step_mps, 6)
    lo = best
    while fail is not None and fail - lo > search.resolution_mps:
        mid = round((lo + fail) / 2, 6)
        result, probe = _try(config, mid, strides, best_warm, lane)
        probes.append(probe)
        if probe.ok:
            lo, best, best_warm = mid, mid, result.warm if lane.start_up else None
        else:
            fail, limit = mid, probe.status
    return FrontierPoint(strides, best, fail, limit, tuple(probes), lane.from_mps, lane.stop)


def find_frontier(config: QuadrupedConfig, searches: Sequence[tuple[Lane, int]],
                  search: FrontierSearch = FrontierSearch(), jobs: int = 2,
                  done: Callable[[FrontierPoint, int], None] | None = None) -> list[FrontierPoint]:
    """The frontier of every (lane, stride count) of ``searches``, one worker process each;
    ``done(point, finished)`` is called as each finishes."""
    points: list[FrontierPoint] = []
    order = sorted(searches, key=lambda ls: -ls[1])  # most strides first: the longest solves
    for point in in_workers([partial(frontier_for, config, s, search, lane) for lane, s in order], jobs):
        points.append(point)
        if done is not None:
            done(point, len(points))
    return sorted(points, key=lambda p: (p.stop, p.from_mps, p.n_strides))


def library_searches(config: QuadrupedConfig) -> list[tuple[Lane, int]]:
    """What ``build --frontier`` searches: the start-ups of every sweep stride count, and with
    transitions the speed-ups from each riding speed and the stops, of every transition stride count."""
    out = [(Lane(), s) for s in sorted(config.sweep.strides)]
    t = config.transitions
    if t.speeds_mps:
        out += [(Lane(v), s) for v in sorted(t.speeds_mps) for s in t.strides]
        out += [(Lane(stop=True), s) for s in t.strides] if t.stops else []
    return out


def frontier_json(points: Sequence[FrontierPoint], search: FrontierSearch) -> str:
    """The frontier as stored in a library's ``frontier_json`` attribute."""
    return json.dumps({"search": asdict(search), "points": [asdict(p) for p in points]}, sort_keys=True)
