"""Independent checks of humanoid GPM steps: everything from stored node values and the step
plan, with scipy's barycentric interpolation and numpy polynomials (not skatelib's GPM code)."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import BarycentricInterpolator
from skatelib.pipeline.humanoid.step import StepModel, StepSpec


def _lg_nodes(n: int) -> np.ndarray:
    return np.polynomial.legendre.leggauss(n)[0]


def check_steps(specs: list[StepSpec], nodes_t: np.ndarray, nodes_state: np.ndarray, nodes_control: np.ndarray,
                model: StepModel, tol: float = 1e-6) -> dict[str, float]:
    """Largest violation of each constraint of the humanoid paper over all steps (0 = holds), with
    the model's gravity and leg reach."""
    g, rmin, rmax = model.g, model.rmin, model.rmax
    worst: dict[str, float] = {}

    def note(name: str, value: float | np.floating) -> None:
        worst[name] = max(worst.get(name, 0.0), float(value))

    for s, spec in enumerate(specs):
        ts, X, U = nodes_t[s], nodes_state[s], nodes_control[s]
        N = len(U)
        t0, T = ts[0], spec.duration_s
        t_nodes = t0 + (_lg_nodes(N) + 1) / 2 * T
        support_t, support_X, X_end = ts[:-1], X[:-1], X[-1]
        pos = BarycentricInterpolator(support_t, support_X[:, 0:3])
        vel = BarycentricInterpolator(support_t, support_X[:, 3:6])
        note("dynamics_position", np.abs(pos.derivative(t_nodes) - vel(t_nodes)).max())  # Eq. (8), (12)
        note("dynamics_velocity", np.abs(vel.derivative(t_nodes) - U).max())
        # Eq. (6): end state = start + integral of [V, A] over the step (exact polynomial integral).
        for cols, vals in ((slice(0, 3), vel(t_nodes)), (slice(3, 6), U)):
            for j in range(3):
                p = np.polynomial.Polynomial.fit(t_nodes, vals[:, j], N - 1)
                integral = p.integ()(t0 + T) - p.integ()(t0)
                note("terminal_quadrature", abs(X[0, cols][j] + integral - X_end[cols][j]))
        if s > 0:
            note("continuity", np.abs(nodes_state[s - 1][-1] - X[0]).max())  # Eq. (22)
        for k, tk in enumerate(t_nodes - t0):
            start, sup = [seg for seg in spec.segments if seg[0] <= tk + 1e-12][-1]
            p0 = np.asarray(sup.p0) + np.asarray(sup.velocity) * (tk - start)
            r = pos(t_nodes[k]) - p0
            F = U[k] + np.array([0.0, 0.0, g])
            note("unilateral", -F[2])  # Eq. (17)
            zmp = r[0:2] - r[2] * F[0:2] / F[2]  # ZMP relative to P0
            poly = np.asarray(sup.polygon)
            for i in range(len(poly)):
                a, b = poly[i], poly[(i + 1) % len(poly)]
                cross = (b[0] - a[0]) * (zmp[1] - a[1]) - (b[1] - a[1]) * (zmp[0] - a[0])
                note("zmp_in_polygon", -cross / max(np.linalg.norm(b - a), 1e-12))  # Eq. (18), metres outside
            note("friction", max(abs(F[0]) - sup.mu_x * F[2], abs(F[1]) - sup.mu_y * F[2]))  # Eq. (19), (20)
            dist = np.linalg.norm(r)
            note("reach", max(rmin - dist, dist - rmax))  # Eq. (21)
        Pf, Vf = X_end[0:3], X_end[3:6]
        ps, vs = np.asarray(spec.p_step), np.asarray(spec.v_step)
        b = np.sqrt(spec.dz_vrp_m / g)
        dcm = Pf + b * (Vf - vs) - ps - np.array([0.0, 0.0, spec.dz_vrp_m])
        if spec.terminal in ("walk", "skate"):
            note("dcm_terminal", np.abs(dcm).max())  # Eq. (25)-(27)
        if spec.terminal == "dcm_on_board":
            note("dcm_terminal", np.abs(dcm[1:]).max())
        if spec.terminal == "walk":
            note("terminal_friction", abs(Pf[0] - ps[0]) - spec.mu_next * Pf[2])  # Eq. (30)
        if spec.terminal == "skate":
            note("skate_alignment", abs(Pf[0] - ps[0]))  # Eq. (31)
            u_end = BarycentricInterpolator(t_nodes, U)(t0 + T)
            note("smooth_transition", abs(u_end[0]))  # Eq. (32)
            note("transition_vertical_speed", abs(Vf[2]))
        if spec.terminal == "stop":
            note("stop", max(np.abs(Pf - ps).max(), np.abs(Vf - vs).max()))  # Eq. (23)-(24)
        if spec.terminal == "stop_on_board":
            note("stop", max(np.abs(Pf - ps)[1:].max(), np.abs(Vf - vs)[1:].max()))
    return worst


def failures(report: dict[str, float], tol: float = 1e-6) -> list[str]:
    return [f"{k} violated by {v:.2e}" for k, v in sorted(report.items()) if v > tol]
