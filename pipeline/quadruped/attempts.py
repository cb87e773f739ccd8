"""One entry's attempts: the retry ladder of a solve that fails, and the physics verdict on the
result (the independent checks of ``verify.py``)."""

from __future__ import annotations

from dataclasses import replace

from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.pushoff import PushoffSpec, SolveResult, problem_for, solve
from skatelib.pipeline.quadruped.verify import Trajectory, check_trajectory


def judge(config: QuadrupedConfig, r: SolveResult) -> tuple[SolveResult, dict[str, float]]:
    """Run the independent physics checks on a converged result; a result that fails them is
    returned with ``success = False`` and the failed checks as its status."""
    if not r.success:
        return r, {}
    system = problem_for(config, r.n_strides).system
    report = check_trajectory(system, Trajectory.of(r), r.target_velocity_mps)
    failures = report.failures(system)
    if failures:
        r = replace(r, success=False, status=f"Physics_Check_Failed: {'; '.join(failures)}")
    return r, report.as_dict()


def retry_ladder(spec: PushoffSpec) -> list[PushoffSpec]:
    """The specs tried in order when a solve fails: as given, cold ramp, cold hold, then a longer
    adaptive-barrier run from IPOPT's own initial bound multipliers."""
    cold = replace(spec, warm=None)
    ladder = [spec] if spec.warm is None else [spec, cold]
    ladder.append(replace(cold, guess="hold"))
    ladder.append(replace(cold, ipopt=(*spec.ipopt, ("mu_strategy", "adaptive"), ("bound_mult_init_val", 1.0),
                                       ("max_iter", 2 * spec.config.optimization.max_iter))))
    return ladder


def solve_with_retries(spec: PushoffSpec) -> tuple[SolveResult, int]:
    """Solve, walking the retry ladder until one converges; the last failure is returned as is."""
    result = None
    ladder = retry_ladder(spec)
    for attempt, s in enumerate(ladder, 1):
        result = solve(s)
        if result.success:
            return result, attempt
    assert result is not None
    return result, len(ladder)
