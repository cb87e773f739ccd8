"""Cold initial guesses of the push-off NLP: the static stance riding a board whose speed rises from
the start speed to the target while the push foot is on the ground (``"ramp"``) or holds the start
speed (``"hold"``), with the push leg posed by inverse kinematics, and after the last push the trunk
and joints moving into the riding stance the last knot is bounded to. Never random: the same problem
always starts from the same point."""

from __future__ import annotations

import functools
from collections.abc import Callable

import casadi as ca
import numpy as np
from skatelib.library.channels import GROUND, NU, S_BOARD_V, S_POS, S_Q, S_VEL, SWING, U_F, U_QD
from skatelib.pipeline.quadruped.model.ik import DampedNewton, Evaluated
from skatelib.pipeline.quadruped.model.robot import foot_position_leg
from skatelib.pipeline.quadruped.model.schedule import KnotSchedule
from skatelib.pipeline.quadruped.model.system import SkateSystem
from skatelib.pipeline.quadruped.problem.knots import I_BOARD_XY, NXA


def initial_guess(system: SkateSystem, schedule: KnotSchedule, x0: np.ndarray, from_velocity_mps: float,
                  target_velocity_mps: float, kind: str) -> np.ndarray:
    """The knot vectors (K, NXA + NU), flattened: ``x0`` carried at a speed that the pushes take from
    ``from_velocity_mps`` to ``target_velocity_mps`` [m/s] and that holds between them (or at
    ``from_velocity_mps``), the push leg by IK, contact forces that carry that momentum, and joint
    speeds that move the joints from knot to knot. After the last push the trunk moves over the deck
    and the joints into the riding stance, inside the bounds of the riding end (the end's narrow
    bands: a guess outside them has IPOPT's first steps cut short by the fraction to the boundary)."""
    sch, v0, v = schedule, from_velocity_mps, target_velocity_mps
    K = len(sch.t)
    guess = np.tile(np.concatenate([x0, np.zeros(NU)]), (K, 1))
    dt = np.diff(sch.t)
    pushing = sch.contact[:-1, system.push_index] == GROUND
    acc = pushing * (v - v0) / max(float(dt @ pushing), 1e-9) if kind == "ramp" else np.zeros(K - 1)
    speed = v0 + np.concatenate([[0.0], np.cumsum(acc * dt)])
    guess[:, S_BOARD_V.start] = guess[:, S_VEL.start] = speed
    travel = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * dt)])
    guess[:, S_POS.start] += travel
    guess[:, I_BOARD_XY.start] = travel
    ease = _into_riding(sch, system.push_index)
    guess[:, S_POS.start:S_POS.start + 2] += np.outer(ease, system.riding_com_m[:2] - (x0[S_POS][:2] - x0[I_BOARD_XY]))
    joints = x0[S_Q] + np.outer(ease, system.stance.q_ride - x0[S_Q])
    guess[:, S_Q] = _push_leg_joints(system, sch, guess[:, S_POS] - system.srb.com_offset_m, joints)
    guess[:-1, NXA + U_F.start:NXA + U_F.stop] = _forces(system, sch, acc)
    guess[:-1, NXA + U_QD.start:NXA + U_QD.stop] = np.diff(guess[:, S_Q], axis=0) / dt[:, None]
    guess[-1, NXA:] = 0.0
    return guess.reshape(-1)


MakeGuess = Callable[[float, float, str], np.ndarray]  # (start speed, target speed, kind) -> guess


def memoized(make: MakeGuess, keep: int = 64) -> MakeGuess:
    """``make`` (start speed, target speed, kind) -> guess, each guess made once and read-only
    (their inverse kinematics take some 25 ms); the ``keep`` used last are kept."""

    @functools.lru_cache(maxsize=keep)
    def guess(from_velocity_mps: float, target_velocity_mps: float, kind: str) -> np.ndarray:
        made = make(from_velocity_mps, target_velocity_mps, kind)
        made.setflags(write=False)
        return made

    return guess


def _into_riding(sch: KnotSchedule, push: int) -> np.ndarray:
    """Per knot, how far the guess has moved from the start's stance into the riding stance: 0 until
    the last push ends, then a smootherstep to 1 at the last knot but one (the last interval holds
    still, as the end's joint-speed bound asks; a schedule whose last push ends at that knot leaves
    the move to the last interval)."""
    K = len(sch.t)
    runs = sch.stance_intervals(push, GROUND)
    k1 = runs[-1][1] if runs else 0
    s = np.clip((np.arange(K) - k1) / max(K - 2 - k1, 1), 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2)


def _push_leg_joints(system: SkateSystem, sch: KnotSchedule, trunk: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """Joint angles per knot: ``joints`` (K, 12) for the deck legs, the push foot held where it
    touched down while the trunk rides on, and between pushes the foot on a swing that leaves and
    meets the ground gently (:func:`_swing`), by inverse kinematics; after the last push it rises to
    where the riding stance holds it beside the trunk, arriving there riding along with it a knot
    before the end."""
    p, K = system.push_index, len(sch.t)
    leg = slice(3 * p, 3 * p + 3)
    q = joints.copy()
    runs = sch.stance_intervals(p, GROUND)
    margin = system.joint_limit_margin_rad  # the plan's limits, as the NLP's bounds have them
    lo, hi = system.robot.lower_limits[leg] + margin, system.robot.upper_limits[leg] - margin
    fk, newton = _leg_fk(system), DampedNewton(damping=1e-6, tol=1e-9, max_iter=20)
    push_foot = np.asarray(system.robot.foot_positions_body(system.stance.q_push))[:, p]
    ride_foot = np.asarray(system.robot.foot_positions_body(system.stance.q_ride))[:, p]
    holds = []
    for k0, k1 in runs:
        foot_world = trunk[k0] + push_foot
        holds.append(foot_world)
        q_leg = system.stance.q_push[leg].copy()
        for k in range(k0, k1 + 1):
            q_leg, _ = newton.solve(fk, foot_world - trunk[k], q_leg, (lo, hi))
            q[k, leg] = q_leg
    if runs and runs[0][0] > 0:  # a lead-in: from the riding pose (the first knot's) down to the first hold
        k0 = runs[0][0]
        start = trunk[0] + ride_foot
        q_leg = system.stance.q_ride[leg].copy()
        q[0, leg] = q_leg
        for k in range(1, k0):
            target = _swing(start, holds[0], k / k0, system.extra.get("swing_apex_m", 0.06), False)
            target[2] = start[2] + (holds[0][2] - start[2]) * (k / k0) ** 2  # down, not over an apex
            q_leg, _ = newton.solve(fk, target - trunk[k], q_leg, (lo, hi))
            q[k, leg] = q_leg
    for j, (_, k1) in enumerate(runs):
        last = j + 1 == len(runs)
        k2 = K - 1 if last else runs[j + 1][0]
        start = holds[j]
        q_leg = q[k1, leg].copy()
        for k in range(k1 + 1, k2 + (1 if last else 0)):
            end = trunk[k] + ride_foot if last else holds[j + 1]  # the last swing ends riding along
            phase = min((k - k1) / max(k2 - k1 - int(last), 1), 1.0)  # the last swing arrives a knot early
            target = _swing(start, end, phase, system.extra.get("swing_apex_m", 0.06), last)
            q_leg, _ = newton.solve(fk, target - trunk[k], q_leg, (lo, hi))
            q[k, leg] = q_leg
    return q


def _swing(start: np.ndarray, end: np.ndarray, s: float, apex_m: float, rising: bool) -> np.ndarray:
    """A foot point along a swing at phase ``s`` in [0, 1]: forward by a smootherstep (no speed at
    either end, its first two derivatives zero), up by a half sine to ``apex_m`` (by a quarter sine
    to the end's height when ``rising``): near the ground the foot moves mostly up or down."""
    ease = s**3 * (10 - 15 * s + 6 * s**2)
    point = start + ease * (end - start)
    lift = apex_m * np.sin(np.pi * s) if not rising else (end[2] - start[2]) * np.sin(0.5 * np.pi * s)
    point[2] = start[2] + (lift if rising else lift + ease * (end[2] - start[2]))
    return point


def _forces(system: SkateSystem, sch: KnotSchedule, acc: np.ndarray) -> np.ndarray:
    """Forces (K - 1, 12): weight shared by the feet in contact, the push foot's force along the
    heading accelerating robot and board together at ``acc`` (K - 1,) [m/s^2], the deck feet
    accelerating the board."""
    p = system.push_index
    m_r, m_b = system.srb.mass_kg, system.board.mass_kg
    f = np.zeros((len(sch.t) - 1, 12))
    for k in range(len(sch.t) - 1):
        on = [i for i in range(4) if sch.contact[k, i] != SWING]
        for i in on:
            f[k, 3 * i + 2] = m_r * system.gravity_mps2 / len(on)
            f[k, 3 * i] = (m_r + m_b) * acc[k] if i == p else -m_b * acc[k] / 3
    return f


def _leg_fk(system: SkateSystem) -> Evaluated:
    """Push-leg foot position in the trunk frame and its 3x3 Jacobian, from the leg's joints (built
    once per guess, about a millisecond; evaluated some 1,200 times by a guess's inverse kinematics)."""
    q_leg = ca.SX.sym("q", 3)
    pos = foot_position_leg(system.robot.chains[system.push_index], q_leg)
    return Evaluated(ca.Function("leg_fk", [q_leg], [pos, ca.densify(ca.jacobian(pos, q_leg))]))

