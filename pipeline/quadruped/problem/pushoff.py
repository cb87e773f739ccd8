"""Push-off trajectory optimization (paper Sec. IV-B): from rest on the board to a target speed
by pushing with one leg for a number of 1.2 s strides, or from riding at one speed to another
(a transition: pushes to speed up, brakes with the foot planted to slow down or stop). Direct
multiple shooting + IPOPT.

``solve(spec) -> SolveResult`` is a pure, picklable module-level function; the built NLP and
solver are cached per process (keyed by the config and the stride count), so a worker that
solves a chain of velocities builds once.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from skatelib.library.margins import forward_speed
from skatelib.pipeline.build import interrupt
from skatelib.pipeline.ocp.threads import stage_threads
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.problem.problem import START_UP, PushoffProblem, Window, system_for, transition_window


@dataclass(frozen=True)
class WarmStart:
    """A previous solution to start from: primal w and multipliers of g and of the bounds, and the
    start and target speeds it was solved for [m/s]. ``guess``: its problem's cold guess at those
    speeds where its solve made one (``guess_of`` names the problem, :func:`problem_key`), which a
    warm start's predictor (:func:`warm_point`) then reads instead of making it again."""

    w: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    from_velocity_mps: float
    target_velocity_mps: float
    guess: np.ndarray | None = None
    guess_of: str = ""


@dataclass(frozen=True)
class PushoffSpec:
    """One push-off problem.

    Attributes:
        config: The validated build config.
        target_velocity_mps: Board speed to reach at the end [m/s].
        n_strides: Number of push cycles.
        warm: Optional warm start (a neighbouring solution of the same stride count).
        guess: Initial-guess kind when cold: ``"ramp"`` (static stance, board speed ramp) or
            ``"hold"`` (static stance at rest), used by the retry ladder.
        ipopt: Extra IPOPT options as (name, value) pairs.
        from_velocity_mps: The speed riding starts at (a transition); 0: a start-up from rest.
    """

    config: QuadrupedConfig
    target_velocity_mps: float
    n_strides: int
    warm: WarmStart | None = field(default=None, repr=False, compare=False)
    guess: str = "ramp"
    ipopt: tuple[tuple[str, Any], ...] = ()
    from_velocity_mps: float = 0.0

    @property
    def window(self) -> Window:
        v0, v1 = self.from_velocity_mps, self.target_velocity_mps
        if v0 <= 0:
            return START_UP
        tr, period = self.config.transitions, self.config.schedule.period_s
        drive = system_for(self.config).drive(v0, v1, tr.touchdown_s + self.n_strides * period)
        return transition_window(self.config, v0, v1, drive)


@dataclass(frozen=True)
class SolveResult:
    """The outcome of one solve, successful or not (a failure carries its IPOPT status)."""

    target_velocity_mps: float
    n_strides: int
    success: bool
    status: str
    iterations: int
    build_time_s: float
    solve_time_s: float
    objective: float
    max_constraint_violation: float
    t: np.ndarray  # (K,) [s]
    state: np.ndarray  # (K, 28)
    control: np.ndarray  # (K-1, 24)
    contact: np.ndarray  # (K, 4) int8
    foot_pos: np.ndarray  # (K, 4, 3) world contact points [m]
    board_pos: np.ndarray  # (K, 4) board origin x, y, z [m] and yaw [rad]
    final_velocity_mps: float
    warm: WarmStart | None = field(default=None, repr=False)
    ipopt_options: dict[str, Any] = field(default_factory=dict)
    from_velocity_mps: float = 0.0

    @property
    def final_velocity_error(self) -> float:
        """Relative error of the final board speed against the target; for a stop, the final speed
        over 1 m/s [-]."""
        return abs(self.final_velocity_mps - self.target_velocity_mps) / (self.target_velocity_mps or 1.0)


_PROBLEMS: dict[tuple[str, int, Window, int], PushoffProblem] = {}


def problem_for(config: QuadrupedConfig, n_strides: int, window: Window = START_UP) -> PushoffProblem:
    """The cached problem of this process for (config, strides, window), its stage derivatives on
    :func:`~skatelib.pipeline.ocp.threads.stage_threads` threads; built on first use."""
    return _cached_problem(config, n_strides, window)[0]


def _cached_problem(config: QuadrupedConfig, n_strides: int, window: Window) -> tuple[PushoffProblem, bool]:
    """:func:`problem_for`'s problem, and whether this call built it."""
    key = (config.resolved_json(), n_strides, window, stage_threads())
    built = key not in _PROBLEMS
    if built:
        _PROBLEMS[key] = PushoffProblem(config, n_strides, window, threads=key[3])
    return _PROBLEMS[key], built


# MUMPS's workspace: its own estimate and 100 % more. IPOPT's 1000 % has MUMPS allocate some 108 MB for
# the push-off's 25 MB, pages the kernel clears at every factorization: the push-off 7 % slower, the same
# iterates (docs/design-notes.md). Where the estimate falls short IPOPT enlarges it and factorizes again.
MUMPS_MEM_PERCENT = 100


def solver_options(spec: PushoffSpec) -> dict[str, Any]:
    """The IPOPT options a solve of ``spec`` uses: the config's, warm-start settings, then ``spec.ipopt``."""
    opt = spec.config.optimization
    options: dict[str, Any] = {"max_iter": opt.max_iter, "tol": opt.tol, "mu_strategy": opt.mu_strategy,
                               "mu_init": opt.mu_init, "mu_min": opt.mu_min, "mumps_mem_percent": MUMPS_MEM_PERCENT}
    if spec.warm is None:
        options.update({"bound_mult_init_val": opt.bound_mult_init, "mu_max": opt.mu_max})
    else:
        options.update({"warm_start_init_point": "yes", "mu_strategy": opt.warm_mu_strategy,
                        "mu_init": opt.warm_mu_init, "warm_start_bound_push": opt.warm_bound_push,
                        "warm_start_mult_bound_push": opt.warm_bound_push})
    options.update(dict(spec.ipopt))
    return options


def problem_key(config: QuadrupedConfig, n_strides: int, window: Window) -> str:
    """What a problem's cold guesses are made from: its config, stride count and knot window (hashed)."""
    return hashlib.sha256(f"{config.resolved_json()}|{n_strides}|{window!r}".encode()).hexdigest()


def warm_point(prob: PushoffProblem, spec: PushoffSpec, warm: WarmStart) -> np.ndarray:
    """The primal point a solve of ``spec`` warm-started from ``warm`` starts from: its solution, with
    ``[optimization] warm_predictor`` moved by the difference of the problem's cold guesses at the
    spec's speeds and at the speeds ``warm`` was solved for (the same problem: the speed the pushes
    give, the push force that gives it, the start state; a first-order step along the targets)."""
    if not spec.config.optimization.warm_predictor:
        return warm.w
    here = prob.initial_guess(spec.from_velocity_mps, spec.target_velocity_mps, "ramp")
    carried = warm.guess is not None and warm.guess_of == problem_key(spec.config, spec.n_strides, spec.window)
    there = warm.guess if carried else prob.initial_guess(warm.from_velocity_mps, warm.target_velocity_mps, "ramp")
    return warm.w + (here - there)


def solve(spec: PushoffSpec) -> SolveResult:
    """Solve one push-off problem. Never raises on solver failure: the result says so."""
    t_build = time.perf_counter()
    prob, built = _cached_problem(spec.config, spec.n_strides, spec.window)
    build_time = time.perf_counter() - t_build if built else 0.0
    v, v0 = spec.target_velocity_mps, spec.from_velocity_mps
    options = solver_options(spec)
    solver = prob.solver(options)
    P = prob.parameters(v0, v)
    bounds = prob.bounds(v0)
    lbx, ubx, lbg, ubg = bounds
    args: dict[str, Any] = {"p": P, "lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg}
    if spec.warm is not None:
        args.update(x0=warm_point(prob, spec, spec.warm), lam_g0=spec.warm.lam_g, lam_x0=spec.warm.lam_x)
    else:
        args["x0"] = prob.initial_guess(v0, v, spec.guess)
    t0 = time.perf_counter()
    sol = solver(**args)
    interrupt.check()  # CasADi turns Ctrl-C into a failed solve; it stops the command
    solve_time = time.perf_counter() - t0
    stats = solver.stats()
    w = np.asarray(sol["x"]).reshape(-1)
    arrays = prob.extract(w)
    viol = prob.violation(w, P, bounds)
    final_v = float(forward_speed(arrays["state"][-1]))
    status = str(stats.get("return_status", "unknown"))
    return SolveResult(
        target_velocity_mps=v, n_strides=spec.n_strides, success=bool(stats.get("success", False)),
        status=status, iterations=int(stats.get("iter_count", -1)), build_time_s=build_time,
        solve_time_s=solve_time, objective=float(sol["f"]), max_constraint_violation=viol,
        final_velocity_mps=final_v,
        warm=WarmStart(w=w, lam_g=np.asarray(sol["lam_g"]).reshape(-1), lam_x=np.asarray(sol["lam_x"]).reshape(-1),
                       from_velocity_mps=v0, target_velocity_mps=v, **_guess_made(prob, spec)),
        ipopt_options=options, from_velocity_mps=v0, **arrays,
    )


def _guess_made(prob: PushoffProblem, spec: PushoffSpec) -> dict[str, Any]:
    """The cold guess at the spec's speeds, for its warm start, where this solve made it (cold from
    the ramp guess, or warm with the predictor)."""
    made = spec.guess == "ramp" if spec.warm is None else spec.config.optimization.warm_predictor
    if not made:
        return {}
    guess = prob.initial_guess(spec.from_velocity_mps, spec.target_velocity_mps, "ramp")
    return {"guess": guess, "guess_of": problem_key(spec.config, spec.n_strides, spec.window)}
