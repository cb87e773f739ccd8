"""Independent checks of humanoid GPM steps: everything from stored node values and the step
plan, with scipy's barycentric interpolation and numpy polynomials (not skatelib's GPM code); and
of the arrays an entry serves a controller: their shapes, times and step indices here, their
physics in :mod:`.served`."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from scipy.interpolate import BarycentricInterpolator
from skatelib.pipeline.humanoid.config import HumanoidConfig
from skatelib.pipeline.humanoid.motion import Motion, served_arrays, step_model
from skatelib.pipeline.humanoid.served import TIME_TOL_S, Served, physics_failures, steps_of
from skatelib.pipeline.humanoid.step import StepModel, StepSpec


def _lg_nodes(n: int) -> np.ndarray:
    return np.polynomial.legendre.leggauss(n)[0]


class _Worst(dict[str, float]):
    """The largest violation noted per constraint."""

    def note(self, name: str, value: float | np.floating) -> None:
        self[name] = max(self.get(name, 0.0), float(value))


def check_steps(specs: list[StepSpec], nodes_t: np.ndarray, nodes_state: np.ndarray, nodes_control: np.ndarray,
                model: StepModel, tol: float = 1e-6) -> dict[str, float]:
    """Largest violation of each constraint of the humanoid paper over all steps (0 = holds), with
    the model's gravity and leg reach."""
    worst = _Worst()
    for s, spec in enumerate(specs):
        ts, X, U = nodes_t[s], nodes_state[s], nodes_control[s]
        span = (float(ts[0]), spec.duration_s)
        t_nodes = span[0] + (_lg_nodes(len(U)) + 1) / 2 * span[1]
        pos = BarycentricInterpolator(ts[:-1], X[:-1, 0:3])
        vel = BarycentricInterpolator(ts[:-1], X[:-1, 3:6])
        _check_dynamics(worst, (pos, vel), span, X, U)
        if s > 0:
            worst.note("continuity", np.abs(nodes_state[s - 1][-1] - X[0]).max())  # Eq. (22)
        for k, tk in enumerate(t_nodes):
            _check_node(worst, spec, tk - span[0], pos(tk), U[k], model)
        u_end = BarycentricInterpolator(t_nodes, U)(span[0] + span[1])
        _check_terminal(worst, spec, X[-1], u_end, model.g)
    return dict(worst)


def _check_dynamics(worst: _Worst, interp: tuple[Any, Any], span: tuple[float, float], X: np.ndarray,
                    U: np.ndarray) -> None:
    """Eq. (8), (12): the state interpolant's derivatives at the LG nodes; Eq. (6): the end state is
    the start plus the exact integral of [V, A] over the step."""
    pos, vel = interp
    t0, T = span
    t_nodes = t0 + (_lg_nodes(len(U)) + 1) / 2 * T
    worst.note("dynamics_position", np.abs(pos.derivative(t_nodes) - vel(t_nodes)).max())
    worst.note("dynamics_velocity", np.abs(vel.derivative(t_nodes) - U).max())
    for cols, vals in ((slice(0, 3), vel(t_nodes)), (slice(3, 6), U)):
        for j in range(3):
            p = np.polynomial.Polynomial.fit(t_nodes, vals[:, j], len(U) - 1)
            integral = p.integ()(t0 + T) - p.integ()(t0)
            worst.note("terminal_quadrature", abs(X[0, cols][j] + integral - X[-1, cols][j]))


def _check_node(worst: _Worst, spec: StepSpec, tk: float, com: np.ndarray, acc: np.ndarray, model: StepModel) -> None:
    """Eq. (17)-(21) at one node (``tk`` into the step): unilateral, ZMP in the support polygon (in
    metres outside), friction, leg reach."""
    start, sup = [seg for seg in spec.segments if seg[0] <= tk + 1e-12][-1]
    r = com - (np.asarray(sup.p0) + np.asarray(sup.velocity) * (tk - start))
    F = acc + np.array([0.0, 0.0, model.g])
    worst.note("unilateral", -F[2])
    zmp = r[0:2] - r[2] * F[0:2] / F[2]  # relative to P0
    poly = np.asarray(sup.polygon)
    for i in range(len(poly)):
        a, b = poly[i], poly[(i + 1) % len(poly)]
        cross = (b[0] - a[0]) * (zmp[1] - a[1]) - (b[1] - a[1]) * (zmp[0] - a[0])
        worst.note("zmp_in_polygon", -cross / max(np.linalg.norm(b - a), 1e-12))
    worst.note("friction", max(abs(F[0]) - sup.mu_x * F[2], abs(F[1]) - sup.mu_y * F[2]))
    dist = np.linalg.norm(r)
    worst.note("reach", max(model.rmin - dist, dist - model.rmax))


def _check_terminal(worst: _Worst, spec: StepSpec, x_end: np.ndarray, u_end: np.ndarray, g: float) -> None:
    """The step kind's terminal conditions, Eq. (23)-(32)."""
    Pf, Vf = x_end[0:3], x_end[3:6]
    ps, vs = np.asarray(spec.p_step), np.asarray(spec.v_step)
    b = np.sqrt(spec.dz_vrp_m / g)
    dcm = Pf + b * (Vf - vs) - ps - np.array([0.0, 0.0, spec.dz_vrp_m])
    checks = {
        "walk": [("dcm_terminal", np.abs(dcm).max()),  # Eq. (25)-(27)
                 ("terminal_friction", abs(Pf[0] - ps[0]) - spec.mu_next * Pf[2])],  # Eq. (30)
        "skate": [("dcm_terminal", np.abs(dcm).max()), ("skate_alignment", abs(Pf[0] - ps[0])),  # Eq. (31)
                  ("smooth_transition", abs(u_end[0])), ("transition_vertical_speed", abs(Vf[2]))],  # Eq. (32)
        "dcm_on_board": [("dcm_terminal", np.abs(dcm[1:]).max())],
        "stop": [("stop", max(np.abs(Pf - ps).max(), np.abs(Vf - vs).max()))],  # Eq. (23)-(24)
        "stop_on_board": [("stop", max(np.abs(Pf - ps)[1:].max(), np.abs(Vf - vs)[1:].max()))],
    }
    for name, value in checks.get(spec.terminal, []):
        worst.note(name, value)


def failures(report: dict[str, float], tol: float = 1e-6) -> list[str]:
    return [f"{k} violated by {v:.2e}" for k, v in sorted(report.items()) if v > tol]


def judge(config: HumanoidConfig, motion: Motion) -> tuple[str, ...]:
    """The independent checks (``skatelib validate``'s) on a solved motion: its node values and the
    arrays the library will serve."""
    if not motion.success:
        return ()
    served = Served.of(served_arrays(motion, config.gpm.nodes))
    model = step_model(config)
    return tuple(failures(check_steps(list(motion.plan), served.nodes_t, served.nodes_state, served.nodes_control,
                                      model))
                 + served_failures(served, list(motion.plan), model.g))


def served_failures(s: Served, plan: list[StepSpec], g: float) -> list[str]:
    """What is wrong with the arrays an entry serves (empty: they hold), each message naming the
    array: shapes and finite numbers first, then times (the physics interpolates in them), then
    ``step_index`` and the physics of :mod:`.served`."""
    found = _shape_failures(s, len(plan)) or _finite_failures(s)
    found = found or _time_failures(s, plan)
    if found:
        return found
    return _step_index_failures(s, steps_of(s.t, s.nodes_t)) + physics_failures(s, plan, g)


def _shape_failures(s: Served, n_steps: int) -> list[str]:
    """Every array's shape against ``t``'s K knots and the plan's S steps of N nodes."""
    K, S = len(s.t), len(s.nodes_t)
    N = s.nodes_control.shape[1] if s.nodes_control.ndim == 3 else -1
    want = {"t": (K,), "state": (K, 6), "control": (K - 1, 3), "zmp": (K, 2), "contact_point": (K, 3),
            "step_index": (K,), "nodes_t": (S, N + 2), "nodes_state": (S, N + 2, 6), "nodes_control": (S, N, 3),
            "nodes_contact_point": (S, N, 3)}
    found = [f"{name}: shape {getattr(s, name).shape}, expected {shape} (K = {K} knots, S = {S} steps, "
             f"N = {N} nodes)" for name, shape in want.items() if getattr(s, name).shape != shape]
    if n_steps != S:
        found.append(f"nodes_t: {S} steps; the plan stored with the entry has {n_steps}")
    if K < 2 or S < 1:
        found.append(f"t: {K} knots and nodes_t {S} steps; a motion has at least 2 and 1")
    return found


def _finite_failures(s: Served) -> list[str]:
    """Every array of numbers, and finite."""
    found = []
    for f in dataclasses.fields(Served):
        a = getattr(s, f.name)
        if a.dtype.kind not in "iuf":
            found.append(f"{f.name}: dtype {a.dtype}, expected numbers")
        elif not np.isfinite(a).all():
            rows = np.flatnonzero(~np.isfinite(a.reshape(len(a), -1)).all(axis=1))
            found.append(f"{f.name}: not finite at row {int(rows[0])}")
    return found


def _time_failures(s: Served, plan: list[StepSpec]) -> list[str]:
    """``t`` strictly increasing from the first step's start to the last step's end; the steps'
    node times increasing, each step starting where the one before ended and lasting as planned."""
    found = []
    bad = np.flatnonzero(np.diff(s.t) <= 0)
    if len(bad):
        k = int(bad[0])
        found.append(f"t: not strictly increasing at knot {k + 1} (t[{k}] = {s.t[k]:.6f} s, t[{k + 1}] = "
                     f"{s.t[k + 1]:.6f} s)")
    nt = s.nodes_t
    for name, have, want in (("starts", s.t[0], nt[0, 0]), ("ends", s.t[-1], nt[-1, -1])):
        if abs(have - want) > TIME_TOL_S:
            found.append(f"t: {name} at {have:.6f} s, nodes_t at {want:.6f} s")
    late = np.abs(nt[1:, 0] - nt[:-1, -1]) > TIME_TOL_S
    long = np.abs(nt[:, -1] - nt[:, 0] - np.array([spec.duration_s for spec in plan])) > TIME_TOL_S
    for name, steps in (("are not increasing", (np.diff(nt, axis=1) <= 0).any(axis=1)),
                        ("do not start where the step before ends", np.r_[False, late]),
                        ("do not span the planned duration", long)):
        if steps.any():
            found.append(f"nodes_t: the times of step {int(np.argmax(steps))} {name}")
    return found


def _step_index_failures(s: Served, steps: np.ndarray) -> list[str]:
    """``step_index`` integer, non-decreasing, and the step ``nodes_t`` puts each knot in."""
    si = s.step_index
    if si.dtype.kind not in "iu":
        return [f"step_index: dtype {si.dtype}, expected integers"]
    found = []
    down = np.flatnonzero(np.diff(si) < 0)
    if len(down):
        k = int(down[0]) + 1
        found.append(f"step_index: decreases at knot {k} (t = {s.t[k]:.3f} s) from {si[k - 1]} to {si[k]}")
    wrong = np.flatnonzero(si != steps)
    if len(wrong):
        k = int(wrong[0])
        starts = ", ".join(f"{x:g}" for x in s.nodes_t[1:, 0])
        found.append(f"step_index: {si[k]} at knot {k} (t = {s.t[k]:.3f} s), nodes_t puts it in step {steps[k]} "
                     f"(steps change at t = {starts} s; {len(wrong)} knots differ)")
    return found
