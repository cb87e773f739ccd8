"""One entry's attempts: the retry ladder of a solve that fails."""

from __future__ import annotations

from dataclasses import replace

from skatelib.library import schema
from skatelib.pipeline.build import interrupt
from skatelib.pipeline.build.profile import profiled, span
from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, SolveResult, solve


def retry_ladder(spec: PushoffSpec) -> list[PushoffSpec]:
    """The specs tried in order when a solve fails: as given, cold ramp, cold hold, then a longer
    adaptive-barrier run from IPOPT's own initial bound multipliers, barrier ceiling and floor."""
    cold = replace(spec, warm=None)
    ladder = [spec] if spec.warm is None else [spec, cold]
    ladder.append(replace(cold, guess="hold"))
    last_rung = (("mu_strategy", "adaptive"), ("bound_mult_init_val", 1.0), ("mu_max", 1e5), ("mu_min", 1e-11))
    ladder.append(replace(cold, ipopt=(*spec.ipopt, *last_rung, ("max_iter", 2 * spec.config.optimization.max_iter))))
    return ladder


def solve_with_retries(spec: PushoffSpec) -> tuple[SolveResult, int]:
    """Solve, walking the retry ladder until one converges; the last failure is returned as is.
    Its ``build_time_s`` and ``solve_time_s`` are the entry's own: every attempt's, added up."""
    result = None
    ladder = retry_ladder(spec)
    build = total = 0.0
    attempts = 0
    for s in ladder:
        interrupt.check()  # an interrupted attempt is no failure to retry
        with span("attempt", n=attempts + 1) as fields:
            result = solve(s)
            if profiled():
                fields.update(key=_key(spec), task="transition" if spec.from_velocity_mps else "start-up",
                              success=result.success, iterations=result.iterations)
        attempts += 1
        build, total = build + result.build_time_s, total + result.solve_time_s
        if result.success:
            break
    assert result is not None
    return replace(result, build_time_s=build, solve_time_s=total), attempts


def _key(spec: PushoffSpec) -> str:
    return schema.entry_key(spec.target_velocity_mps, spec.n_strides, spec.from_velocity_mps)
