"""One humanoid skating push step (10 Legendre-Gauss nodes): CasADi's SQP (the default) and IPOPT
against scipy SLSQP with finite-difference gradients on the same NLP (the paper's solver)."""

from __future__ import annotations

import dataclasses
import statistics
import time
from typing import Any

from skatelib.pipeline.config import load_config
from skatelib.pipeline.humanoid.config import HumanoidConfig

from benchmarks.figures import Figure, Measured

STEP = Figure("humanoid-step", "humanoid skating push step, 10 LG nodes (SQP)", "ms", 5.0,
              "scipy SLSQP, finite differences (the paper's)")
WHOLE = Figure("humanoid-wholebody",
               "humanoid walk, per phase (about 0.8 s of motion): GPM + feet + IK + dynamics filter", "ms", 800.0,
               "the GPM (COM) stage alone")
FIGURES = (STEP, WHOLE)


def measure(repeats: int = 21) -> list[Measured]:
    return [_step(repeats), _whole_body()]


def _whole_body() -> Measured:
    """The walk's whole pipeline per walking step (the paper claims its COM part runs faster than
    the step lasts), with each stage's time; the 1.0 m/s skate's beside it."""
    walk_s, gpm_s, n, m, f = _pipeline("hrp2_walk.toml", None)
    skate_s, _, n_skate, skate, _ = _pipeline("hrp2_skate.toml", 1.0)
    note = (f"{n} phases of {m.t[-1]:.1f} s: GPM {gpm_s / n * 1e3:.1f}, feet {f['feet_s'] / n * 1e3:.2f}, "
            f"IK + filter {f['ik_and_filter_s'] / n * 1e3:.0f} ms per phase; skate 1.0 m/s: "
            f"{skate_s / n_skate * 1e3:.0f} ms per phase ({n_skate} over {skate.t[-1]:.1f} s)")
    return Measured(WHOLE, walk_s / n * 1e3, gpm_s / n * 1e3, note)


def _pipeline(config: str, velocity: float | None) -> tuple[float, float, int, Any, dict[str, float]]:
    """GPM and whole body of one motion of a shipped config (its first velocity when None): total
    and GPM seconds, phases, the motion and the whole body's figures."""
    from skatelib.pipeline.config import CONFIG_DIR
    from skatelib.pipeline.humanoid.body import robot_for, whole_body
    from skatelib.pipeline.humanoid.motion import solve_motion

    c = load_config(CONFIG_DIR / config, HumanoidConfig)
    t0 = time.perf_counter()
    m = solve_motion(c, c.sweep.velocities_mps[0] if velocity is None else velocity)
    t_gpm = time.perf_counter() - t0
    body = whole_body(c, m, robot_for(c))
    if body.figures["com_error_max_m"] > 1e-6:
        raise RuntimeError(f"humanoid benchmark: {config} misses its whole body")
    return time.perf_counter() - t0, t_gpm, len(m.steps), m, body.figures


def _step(repeats: int) -> Measured:
    import casadi as ca
    import numpy as np
    from scipy.optimize import minimize
    from skatelib.pipeline.config import CONFIG_DIR
    from skatelib.pipeline.humanoid.motion import skating_steps, step_model
    from skatelib.pipeline.humanoid.step import solve_step, step_problem

    c = load_config(CONFIG_DIR / "hrp2_skate.toml", HumanoidConfig)
    h = c.humanoid
    x0, specs = skating_steps(c, 1.0)
    push = specs[0]
    rows: dict[str, tuple[float, int, float]] = {}
    for solver in ("sqp", "ipopt"):
        times = []
        for _ in range(repeats):
            r = solve_step(push, x0, 0.0, dataclasses.replace(step_model(c), solver=solver))
            assert r.success, r.status
            times.append(r.solve_time_s)
        rows[solver] = (statistics.median(times), r.iterations, r.objective)
    prob = step_problem(c.gpm.nodes, "skate", "ipopt")
    p, _, _ = prob.parameters(push, x0, h.gravity_mps2, h.leg_min_m, h.leg_max_m)
    f = ca.Function("f", [prob.nlp["x"], prob.nlp["p"]], [prob.nlp["f"]])
    g = ca.Function("g", [prob.nlp["x"], prob.nlp["p"]], [prob.nlp["g"]])
    n_eq = prob.n_eq
    lb, ub = prob.lbg[n_eq:], prob.ubg[n_eq:]
    finite_ub = np.isfinite(ub)

    def fun(w: np.ndarray) -> float:
        return float(f(w, p))

    def eq(w: np.ndarray) -> np.ndarray:
        return np.asarray(g(w, p)).reshape(-1)[:n_eq]

    def ineq(w: np.ndarray) -> np.ndarray:
        gi = np.asarray(g(w, p)).reshape(-1)[n_eq:]
        return np.concatenate([gi - lb, (ub - gi)[finite_ub]])

    w0 = prob.initial_guess(x0, push)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        res = minimize(fun, w0, method="SLSQP", constraints=[{"type": "eq", "fun": eq}, {"type": "ineq", "fun": ineq}],
                       options={"maxiter": 500, "ftol": 1e-10})
        times.append(time.perf_counter() - t0)
    rows["scipy SLSQP, finite differences (paper)"] = (statistics.median(times), res.nit, res.fun)
    if not res.success:
        raise RuntimeError(f"humanoid benchmark: SLSQP did not converge ({res.message})")
    sqp_s, sqp_it, _ = rows["sqp"]
    note = f"{sqp_it} SQP iterations; IPOPT {rows['ipopt'][0] * 1e3:.1f} ms; {prob.n_w} variables"
    return Measured(STEP, sqp_s * 1e3, rows["scipy SLSQP, finite differences (paper)"][0] * 1e3, note)
