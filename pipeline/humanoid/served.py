"""Independent checks of the arrays a humanoid entry serves a controller (``t``, ``state``,
``control``, ``zmp``, ``contact_point``, ``step_index``): laws the optimizer was not given in this
form, and agreement with the GPM nodes that :func:`.verify.check_steps` verifies.

Within a step the served knots sample polynomials (``motion.sample``): the COM state one of degree
N through the step's start and its N nodes, the acceleration one of degree N - 1; at a step
boundary the acceleration jumps. So every rule here is the Lagrange polynomial through N + 1
(state) or N (acceleration) neighbouring knots of one step, exact on what a correct entry serves,
and never reaches across a boundary: the interval from a step's last knot to the next step's first
is covered by extrapolating the step's own. A step with fewer knots than that (a coarse
``sample_dt_s``) is left to the checks that need no rule. Nothing of the GPM transcription is used.

Tolerances (TOLERANCES) against the worst values measured on the shipped libraries
(``configs/hrp2_walk.toml``, ``configs/hrp2_skate.toml``: all four entries, 10 ms knots):

- velocity: at every knot, against the step's first velocity plus the integral of ``control``
  since; worst 6.7e-15 m/s, tolerance 1e-6 m/s (a 1 m/s^2 error held for one knot: 1e-2 m/s).
- position: against the integral of the velocity; worst 6.1e-5 m, tolerance 5e-4 m. Not round-off:
  between its nodes the derivative of the GPM's position polynomial is not its velocity polynomial
  (their difference is a multiple of P_N, whose integral vanishes only over the whole step); it
  grows with speed (3.0e-5, 4.6e-5, 6.1e-5 m for the skates at 0.5, 0.75, 1 m/s).
- nodes: ``state`` and ``control`` interpolated at ``nodes_t`` against ``nodes_state`` and
  ``nodes_control``: worst 6.0e-13 (m, m/s) and 3.6e-15 m/s^2, tolerances 1e-6 (a thousand times
  the solvers' 1e-9 on the collocation they satisfy).
- zmp: the cart-table ZMP of the served COM over ``contact_point`` (the planner's relation: the
  ground point about which F = a + [0, 0, g] at the COM has no moment, Eq. (15)-(16)); worst
  2.0e-14 m (the last knot, its acceleration extrapolated; 4.4e-16 m elsewhere), tolerance 1e-9 m.
- contact points: ``contact_point`` at every knot and ``nodes_contact_point`` at every node
  against the plan's point (fixed, or riding the board at constant velocity); worst 4.4e-16 m,
  tolerance 1e-9 m. The point is linear in time within a plan segment, so both holding is
  ``contact_point`` agreeing with ``nodes_contact_point`` at the node times.
- times: ``t``, ``nodes_t`` and the plan's durations agree to 1e-9 s (knot times are sums of
  durations and multiples of the sampling interval: worst 2.2e-16 s).

The same holds with IPOPT, 14 nodes and 5 ms knots (velocity 2.9e-15 m/s, position 1.9e-5 m).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.channels import HUMANOID_CONTROL_NAMES, HUMANOID_STATE_NAMES, POINT_NAMES, ZMP_NAMES
from skatelib.pipeline.humanoid.step import StepSpec

TIME_TOL_S = 1e-9
TOLERANCES = {"velocity": 1e-6, "position": 5e-4, "nodes_state": 1e-6, "nodes_control": 1e-6, "zmp": 1e-9,
              "contact_point": 1e-9, "nodes_contact_point": 1e-9}
"""The largest deviation each check allows, in the units of ``_WHAT`` (the module's docstring: why)."""
_WHAT = {
    "velocity": ("state {} is not the time integral of control (the COM acceleration)", "m/s"),
    "position": ("state {} is not the time integral of the COM velocity in state", "m"),
    "nodes_state": ("state {} differs from nodes_state at nodes_t", "m"),
    "nodes_control": ("control {} differs from nodes_control at nodes_t", "m/s^2"),
    "zmp": ("zmp {} is not the ZMP of the COM motion (state, control) over contact_point", "m"),
    "contact_point": ("contact_point {} differs from the plan's contact point", "m"),
    "nodes_contact_point": ("nodes_contact_point {} differs from the plan's contact point", "m"),
}


@dataclass(frozen=True)
class Served:
    """An entry's served arrays and its GPM nodes, as stored (``docs/library-format.md``)."""

    t: np.ndarray
    state: np.ndarray
    control: np.ndarray
    zmp: np.ndarray
    contact_point: np.ndarray
    step_index: np.ndarray
    nodes_t: np.ndarray
    nodes_state: np.ndarray
    nodes_control: np.ndarray
    nodes_contact_point: np.ndarray

    @staticmethod
    def of(arrays: Mapping[str, Any]) -> Served:
        """From an entry's arrays (its datasets, named as the fields)."""
        names = (schema.D_T, schema.D_STATE, schema.D_CONTROL, schema.D_ZMP, schema.D_CONTACT_POINT,
                 schema.D_STEP_INDEX, schema.D_NODES_T, schema.D_NODES_STATE, schema.D_NODES_CONTROL,
                 schema.D_NODES_CONTACT_POINT)
        return Served(*(np.asarray(arrays[name]) for name in names))


@dataclass(frozen=True)
class Worst:
    """The largest deviation of one check, the time [s] it is at and its column."""

    value: float
    t: float
    column: str

    def over(self, err: np.ndarray, t: float, names: Sequence[str]) -> Worst:
        j = int(np.argmax(err))
        return Worst(float(err[j]), t, names[j]) if err[j] > self.value else self


def physics_failures(s: Served, plan: Sequence[StepSpec], g: float) -> list[str]:
    """The checks with a tolerance that fail, each message naming the array, the column, how far
    off and where (arrays whose shapes and times hold: :func:`.verify.served_failures`)."""
    found = []
    for name, w in measure(s, plan, g).items():
        if not w.value <= TOLERANCES[name]:
            what, unit = _WHAT[name]
            unit = "m/s" if w.column in HUMANOID_STATE_NAMES[3:6] else unit
            found.append(f"{what.format(w.column)}: off by {w.value:.2e} {unit} at t = {w.t:.3f} s "
                         f"(tolerance {TOLERANCES[name]:.0e})")
    return found


def measure(s: Served, plan: Sequence[StepSpec], g: float) -> dict[str, Worst]:
    """The worst deviation of every check with a tolerance (on arrays whose shapes and times hold)."""
    steps = steps_of(s.t, s.nodes_t)
    k = _Knots(s.t, [np.flatnonzero(steps == j) for j in range(len(s.nodes_t))])
    N = s.nodes_control.shape[1]
    pos, vel = s.state[:, 0:3], s.state[:, 3:6]
    names = (HUMANOID_STATE_NAMES[0:3], HUMANOID_STATE_NAMES[3:6])
    return {
        "velocity": _integral_worst(k, vel, (s.control, N), names[1]),
        "position": _integral_worst(k, pos, (vel, N + 1), names[0]),
        "nodes_state": _node_worst(k, (s.state, N + 1), s.nodes_t, s.nodes_state, HUMANOID_STATE_NAMES),
        "nodes_control": _node_worst(k, (s.control, N), s.nodes_t[:, 1:-1], s.nodes_control, HUMANOID_CONTROL_NAMES),
        "zmp": _zmp_worst(s, k, g),
        "contact_point": _contact_worst(s.t[:, None], steps, s.contact_point[:, None], s.nodes_t, plan),
        "nodes_contact_point": _contact_worst(s.nodes_t[:, 1:-1], np.arange(len(plan)), s.nodes_contact_point,
                                              s.nodes_t, plan),
    }


def steps_of(t: np.ndarray, nodes_t: np.ndarray) -> np.ndarray:
    """The step each knot lies in by ``nodes_t``: from its start up to the next's (the last its end too)."""
    return np.clip(np.searchsorted(nodes_t[:, 0], t + TIME_TOL_S, side="right") - 1, 0, len(nodes_t) - 1)


@dataclass(frozen=True)
class _Knots:
    """The served knot times and, per step, the knots in it."""

    t: np.ndarray
    of_step: list[np.ndarray]

    def rule(self, step: int, samples: tuple[np.ndarray, int], lo: float, hi: float | None = None
             ) -> tuple[np.ndarray, np.ndarray] | None:
        """The ``n`` knots of ``step`` with a row in ``samples = (rows, n)`` centred on [lo, hi],
        and the weights on them of their polynomial's value at ``lo`` or, with ``hi``, of its
        integral over [lo, hi]; None when the step has fewer such knots."""
        rows, n = samples
        own = self.of_step[step][self.of_step[step] < len(rows)]
        if len(own) < n:
            return None
        p = int(np.searchsorted(self.t[own], (lo + (lo if hi is None else hi)) / 2, side="right")) - 1
        at = own[min(max(p - (n // 2 - 1), 0), len(own) - n):][:n]
        x = self.t[at]
        h, powers = float(x[-1] - x[0]) or 1.0, np.arange(n)
        a = (lo - x[0]) / h
        row = a**powers if hi is None else h * (((hi - x[0]) / h) ** (powers + 1) - a ** (powers + 1)) / (powers + 1)
        return at, np.linalg.solve((((x - x[0]) / h)[:, None] ** powers).T, row)


def _integral_worst(k: _Knots, y: np.ndarray, rate: tuple[np.ndarray, int], names: Sequence[str]) -> Worst:
    """``y`` at every knot against ``y`` at its step's first knot plus the integral of the rate
    ``(rows, rule points)`` since, through the next step's first knot."""
    worst = Worst(0.0, float(k.t[0]), names[0])
    for j, own in enumerate(k.of_step):
        total = np.zeros(y.shape[1])
        for i in own[own + 1 < len(k.t)]:
            rule = k.rule(j, rate, k.t[i], k.t[i + 1])
            if rule is None:
                break
            total += rule[1] @ rate[0][rule[0]]
            worst = worst.over(np.abs(y[i + 1] - y[own[0]] - total), float(k.t[i + 1]), names)
    return worst


def _node_worst(k: _Knots, y: tuple[np.ndarray, int], nodes_t: np.ndarray, nodes_y: np.ndarray,
                names: Sequence[str]) -> Worst:
    """``y = (rows, rule points)`` interpolated within each step at its node times against its node values."""
    worst = Worst(0.0, float(k.t[0]), names[0])
    for j in range(len(k.of_step)):
        for tq, want in zip(nodes_t[j], nodes_y[j], strict=True):
            rule = k.rule(j, y, float(tq))
            if rule is not None:
                worst = worst.over(np.abs(rule[1] @ y[0][rule[0]] - want), float(tq), names)
    return worst


def _zmp_worst(s: Served, k: _Knots, g: float) -> Worst:
    """Served ``zmp`` against x - (z - p_z) F_xy / F_z with F = a + [0, 0, g] (COM x, y, z; the
    contact point's height p_z): no moment about the ZMP. The last knot, which has no ``control``
    row, takes its step's acceleration extrapolated (or is skipped)."""
    rule = k.rule(len(k.of_step) - 1, (s.control, s.nodes_control.shape[1]), float(s.t[-1]))
    acc = s.control if rule is None else np.vstack([s.control, rule[1] @ s.control[rule[0]]])
    F = acc + np.array([0.0, 0.0, g])
    if (F[:, 2] <= 0).any():
        i = int(np.flatnonzero(F[:, 2] <= 0)[0])
        return Worst(np.inf, float(s.t[i]), "(undefined: control com_az at or below -g)")
    x = s.state[: len(F)]
    err = np.abs(x[:, 0:2] - (x[:, 2:3] - s.contact_point[: len(F), 2:3]) * F[:, 0:2] / F[:, 2:3] - s.zmp[: len(F)])
    i = int(np.argmax(err.max(axis=1)))
    return Worst(0.0, 0.0, "").over(err[i], float(s.t[i]), ZMP_NAMES)


def _contact_worst(times: np.ndarray, steps: np.ndarray, points: np.ndarray, nodes_t: np.ndarray,
                   plan: Sequence[StepSpec]) -> Worst:
    """``points`` (rows, cols, 3) at ``times`` (rows, cols) of ``steps`` (rows,) against the
    plan's contact point: the support's p0, moved at its velocity since its segment began."""
    worst = Worst(0.0, float(times.flat[0]), POINT_NAMES[0])
    for row, j in enumerate(steps):
        for tq, have in zip(times[row], points[row], strict=True):
            local = tq - nodes_t[j, 0]
            start, sup = [seg for seg in plan[j].segments if seg[0] <= local + TIME_TOL_S][-1]
            want = np.asarray(sup.p0) + np.asarray(sup.velocity) * (local - start)
            worst = worst.over(np.abs(have - want), float(tq), POINT_NAMES)
    return worst
