"""CasADi's ``fatrop`` (a structure-exploiting interior point) against IPOPT + MUMPS on the push-off
NLP (0.5 m/s, 2 strides), ``python -m benchmarks.run fatrop``.

fatrop needs the optimal-control structure: per stage ``k`` a state and a control, gap-closing rows
``x_{k+1} = F(x_k, u_k)`` and path rows that see only ``(x_k, u_k)``. The push-off's stage rows and
costs see the window ``(x_k, u_k, x_{k+1}, u_{k+1})`` (foot displacement over an interval, force and
joint-speed rates), so the NLP is handed to it *lifted*: stage ``k >= 1`` carries the previous knot
in its state, ``z_k = (x_k, x_{k-1}, u_{k-1})``, the gap-closing rows copy it forward, and stage
``k``'s path rows and cost are the original stage ``k - 1``'s. That is the same optimization
problem (the copies are equal at every feasible point), with 84 states per stage instead of 30.
Both solvers get the same lifted NLP (an MX graph over the interpreted stage function), and IPOPT
also the production one; the table splits each solve into the time spent evaluating functions
(the same CasADi code for both) and the solver's own time (its linear algebra and logic).
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.channels import NU
from skatelib.pipeline.ocp.shooting import window_stage
from skatelib.pipeline.quadruped.problem.knots import N_PARAMS, NXA
from skatelib.pipeline.quadruped.problem.problem import PushoffProblem
from skatelib.pipeline.quadruped.problem.terms import DynamicsDefect

from benchmarks.figures import Figure, Measured


@dataclasses.dataclass(frozen=True)
class Lifted:
    """The lifted NLP: the problem dict, its start point and bounds, and fatrop's stage sizes."""

    nlp: dict[str, ca.MX]
    x0: np.ndarray
    bounds: dict[str, np.ndarray]
    structure: dict[str, Any]

    def point(self, knots: np.ndarray) -> np.ndarray:
        """The lifted vector of (K, 54) knots [x_k, u_k]: each stage's state carries the previous knot."""
        parts = [knots[0, :NXA], knots[0, NXA:]]
        for k in range(1, len(knots)):
            parts += [knots[k, :NXA], knots[k - 1], knots[k, NXA:]]
        return np.concatenate(parts)

    def knots(self, w: np.ndarray) -> np.ndarray:
        """The (K, 54) knots [x_k, u_k] of a lifted solution vector."""
        out, at = [], 0
        for nz in self.structure["nx"]:
            out.append(np.concatenate([w[at:at + NXA], w[at + nz:at + nz + NU]]))
            at += nz + NU
        return np.array(out)


def lift(prob: PushoffProblem, v: float) -> Lifted:
    """The push-off NLP for target ``v`` in fatrop's stage structure (module docstring)."""
    N, nx, nu, n = prob.schedule.n_intervals, NXA, NU, NXA + NU
    z, p, st = window_stage((nx, nu, N_PARAMS), prob.config.optimization.dt_s)
    dynamics, *path = prob.constraints
    assert isinstance(dynamics, DynamicsDefect)
    lo, hi = (np.concatenate(b, axis=1) for b in zip(*(t.bounds(N) for t in path), strict=True))
    keep = np.isfinite(lo) | np.isfinite(hi)
    stage = ca.Function("stage", [z, p], [sum((c.cost(st) for c in prob.costs), ca.SX(0)),
                                          ca.vertcat(*[t.rows(st) for t in path])])
    P = prob.parameters(0.0, v).reshape(N, N_PARAMS)
    bounds = prob.bounds(0.0)
    lbx, ubx = bounds[0].reshape(N + 1, n), bounds[1].reshape(N + 1, n)
    guess = prob.initial_guess(0.0, v, "ramp").reshape(N + 1, n)
    Z = [ca.MX.sym("z0", nx)] + [ca.MX.sym(f"z{k}", nx + n) for k in range(1, N + 1)]
    U = [ca.MX.sym(f"u{k}", nu) for k in range(N + 1)]
    w, w0, wlb, wub, g, glb, gub = [], [], [], [], [], [], []
    f: Any = 0
    for k in range(N + 1):
        copies = np.full(0 if k == 0 else n, np.inf)
        w += [Z[k], U[k]]
        w0 += [guess[k, :nx] if k == 0 else np.concatenate([guess[k, :nx], guess[k - 1]]), guess[k, nx:]]
        wlb += [lbx[k, :nx], -copies, lbx[k, nx:]]
        wub += [ubx[k, :nx], copies, ubx[k, nx:]]
        if k < N:  # gap closing into stage k+1: the step, and the copies of (x_k, u_k)
            xk = Z[k][:nx]
            g.append(Z[k + 1] - ca.vertcat(dynamics.step(xk, U[k]), xk, U[k]))
            glb.append(np.zeros(nx + n))
            gub.append(np.zeros(nx + n))
        if k >= 1:  # the original stage k-1, on (x_{k-1}, u_{k-1}, x_k, u_k)
            cost, rows = stage(ca.vertcat(Z[k][nx:], Z[k][:nx], U[k]), P[k - 1])
            f += cost
            kept = keep[k - 1]
            g.append(rows[np.flatnonzero(kept).tolist()])
            glb.append(lo[k - 1][kept])
            gub.append(hi[k - 1][kept])
    # The rows are in fatrop's order: per stage k, the gap into k+1, then stage k's path rows.
    structure = {"N": N, "nx": [nx] + [nx + n] * N, "nu": [nu] * (N + 1),
                 "ng": [0] + [int(keep[k].sum()) for k in range(N)]}
    return Lifted({"x": ca.vertcat(*w), "f": f, "g": ca.vertcat(*g)}, np.concatenate(w0),
                  {"lbx": np.concatenate(wlb), "ubx": np.concatenate(wub), "lbg": np.concatenate(glb),
                   "ubg": np.concatenate(gub)}, structure)


def solve_lifted(lifted: Lifted, solver: str, ipopt_options: dict[str, Any]) -> dict[str, Any]:
    """Solve the lifted NLP with ``"ipopt"`` (the production options) or ``"fatrop"`` (its defaults,
    the same tolerance and iteration limit); returns iterations, times (total, function
    evaluations), objective and knots."""
    if solver == "fatrop":
        limits = {"tol": ipopt_options["tol"], "max_iter": ipopt_options["max_iter"]}
        opts: dict[str, Any] = {"structure_detection": "manual", **lifted.structure,
                                "fatrop": {"print_level": 0, **limits}}
    else:
        opts = {"ipopt.print_level": 0, "ipopt.sb": "yes", **{f"ipopt.{k}": v for k, v in ipopt_options.items()}}
    fn = ca.nlpsol(solver, solver, lifted.nlp, {"print_time": False, **opts})
    t0 = time.perf_counter()
    sol = fn(x0=lifted.x0, **lifted.bounds)
    total = time.perf_counter() - t0
    stats = fn.stats()
    return {"success": bool(stats["success"]), "iterations": int(stats.get("iter_count", -1)), "total_s": total,
            "evaluations_s": _evaluations(stats), "objective": float(sol["f"]),
            "knots": lifted.knots(np.asarray(sol["x"]).ravel())}


def _evaluations(stats: dict[str, Any]) -> float:
    """Seconds CasADi spent evaluating the NLP's functions during a solve (its ``t_wall_nlp_*``)."""
    return float(sum(v for k, v in stats.items() if k.startswith("t_wall_nlp_")))


FATROP = Figure("fatrop", "fatrop's own time per iteration over IPOPT's, lifted push-off NLP", "x", 1.0,
                 "IPOPT + MUMPS on the same lifted NLP")
FIGURES = (FATROP,)


def measure() -> list[Measured]:
    """The table of the module docstring, for 0.5 m/s x 2 strides (interpreted stage functions, so that
    both solvers evaluate the same CasADi code). The figure: fatrop's own time per iteration as a
    multiple of IPOPT's (the target: at most IPOPT's, to make it the default)."""
    from skatelib.library.margins import forward_speed
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.quadruped.config import QuadrupedConfig
    from skatelib.pipeline.quadruped.problem import pushoff

    base = load_config(None, QuadrupedConfig)
    cfg = dataclasses.replace(base, optimization=dataclasses.replace(base.optimization, compile=False))
    v, strides = 0.5, 2
    spec = pushoff.PushoffSpec(cfg, v, strides)
    production = pushoff.solve(spec)
    lifted = lift(pushoff.problem_for(cfg, strides), v)
    rows: dict[str, dict[str, Any]] = {"IPOPT + MUMPS, production NLP": {
        "success": production.success, "iterations": production.iterations, "total_s": production.solve_time_s,
        "evaluations_s": _evaluations(pushoff.problem_for(cfg, strides).solver(pushoff.solver_options(spec)).stats()),
        "objective": production.objective, "knots": np.hstack(
            [production.state, np.zeros((len(production.t), 2)), np.vstack([production.control, np.zeros(NU)])])}}
    for solver in ("ipopt", "fatrop"):
        name = f"{'IPOPT + MUMPS' if solver == 'ipopt' else 'fatrop'}, lifted NLP"
        rows[name] = solve_lifted(lifted, solver, pushoff.solver_options(spec))
    print(f"\nfatrop against IPOPT, push-off {v} m/s x {strides} strides (lifted: {lifted.nlp['x'].numel()} variables, "
          f"{lifted.nlp['g'].numel()} rows)")
    print(f"{'solver, NLP':34s} {'ok':>4s} {'iter':>5s} {'solve [s]':>10s} {'evals [s]':>10s} {'own [s]':>8s} "
          f"{'own/iter [ms]':>14s} {'objective':>10s} {'end speed':>10s}")
    for name, r in rows.items():
        own = r["total_s"] - r["evaluations_s"]
        end = float(forward_speed(r["knots"][-1, :28]))
        print(f"{name:34s} {r['success']!s:>4s} {r['iterations']:5d} {r['total_s']:10.2f} {r['evaluations_s']:10.2f} "
              f"{own:8.2f} {1e3 * own / max(r['iterations'], 1):14.1f} {r['objective']:10.6f} {end:10.4f}")
    print("evals: CasADi evaluating the NLP's functions (the same code for both solvers on the lifted NLP); own: the "
          "rest of the solve, the solver's linear algebra and logic")

    def own_ms(name: str) -> float:
        r = rows[name]
        return 1e3 * (r["total_s"] - r["evaluations_s"]) / max(r["iterations"], 1)

    fat, ipo = own_ms("fatrop, lifted NLP"), own_ms("IPOPT + MUMPS, lifted NLP")
    r = rows["fatrop, lifted NLP"]
    note = (f"fatrop {fat:.0f} ms x {r['iterations']} iterations ({'converged' if r['success'] else 'FAILED'}), "
            f"IPOPT {ipo:.0f} ms; IPOPT on the production NLP {own_ms('IPOPT + MUMPS, production NLP'):.0f} ms")
    return [Measured(FATROP, fat / ipo, 1.0, note)]
