"""The reachable-speed frontier: per stride count, the fastest label that converges and passes the
independent physics checks.

Per stride count, a warm-start chain climbs in steps of ``step_mps`` from ``start_mps`` until a
speed fails (IPOPT does not converge from the warm start nor cold, or the physics checks refuse
the result); then it bisects between the last success and the first failure, warm-starting from
the last success, until the gap is at most ``resolution_mps``. Stride counts run in parallel
processes, like the sweep.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace

from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.pushoff import PushoffSpec, SolveResult, WarmStart, solve
from skatelib.pipeline.quadruped.verify import judge


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
class FrontierPoint:
    """The frontier of one stride count.

    Attributes:
        n_strides: Push strides.
        fastest_mps: Fastest label that converged and validated (0 when even the start failed).
        first_failure_mps: Slowest label tried that failed above it (``None``: ``max_mps`` was reached).
        limit: The status of that failure (what stopped it), or ``"search limit"``.
        probes: Every label tried, in order.
    """

    n_strides: int
    fastest_mps: float
    first_failure_mps: float | None
    limit: str
    probes: tuple[Probe, ...]


def _try(config: QuadrupedConfig, v: float, strides: int, warm: WarmStart | None) -> tuple[SolveResult, Probe]:
    """Solve warm (when given) and else cold; judge the converged result with the physics checks."""
    result = solve(PushoffSpec(config, v, strides, warm=warm))
    if not result.success and warm is not None:
        result = solve(PushoffSpec(config, v, strides))
    judged, physics = judge(config, result)
    probe = Probe(v, judged.success, judged.status, result.iterations, physics.get("momentum_speed_mps", float("nan")))
    return result, probe


def frontier_for(config: QuadrupedConfig, strides: int, search: FrontierSearch) -> FrontierPoint:
    """Climb, then bisect, along one warm-start chain (a module-level function for worker processes)."""
    probes: list[Probe] = []
    best, best_warm, fail, limit = 0.0, None, None, "search limit"
    v = search.start_mps
    while v <= search.max_mps + 1e-9:
        result, probe = _try(config, v, strides, best_warm)
        probes.append(probe)
        if not probe.ok:
            fail, limit = v, probe.status
            break
        best, best_warm = v, result.warm
        v = round(v + search.step_mps, 6)
    lo = best
    while fail is not None and fail - lo > search.resolution_mps:
        mid = round((lo + fail) / 2, 6)
        result, probe = _try(config, mid, strides, best_warm)
        probes.append(probe)
        if probe.ok:
            lo, best, best_warm = mid, mid, result.warm
        else:
            fail, limit = mid, probe.status
    return FrontierPoint(strides, best, fail, limit, tuple(probes))


def find_frontier(config: QuadrupedConfig, strides: Sequence[int], search: FrontierSearch = FrontierSearch(),
                  jobs: int = 2, done: Callable[[FrontierPoint, int], None] | None = None) -> list[FrontierPoint]:
    """The frontier of every stride count, one worker process per stride count; ``done(point,
    finished)`` is called as each stride count finishes."""
    from joblib import Parallel, delayed, parallel_config

    cfg = replace(config, sweep=replace(config.sweep, strides=tuple(strides)))
    points: list[FrontierPoint] = []
    with parallel_config(backend="loky", inner_max_num_threads=1):  # BLAS/OpenMP at 1 thread in the workers only
        for point in Parallel(n_jobs=min(jobs, len(strides)), backend="loky", return_as="generator_unordered")(
                delayed(frontier_for)(cfg, s, search) for s in sorted(strides, reverse=True)):
            points.append(point)
            if done is not None:
                done(point, len(points))
    return sorted(points, key=lambda p: p.n_strides)


def frontier_json(points: Sequence[FrontierPoint], search: FrontierSearch) -> str:
    """The frontier as stored in a library's ``frontier_json`` attribute."""
    return json.dumps({"search": asdict(search), "points": [asdict(p) for p in points]}, sort_keys=True)
