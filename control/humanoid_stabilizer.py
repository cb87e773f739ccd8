"""The humanoid's balance stabilizer (the last box of Takasugi et al.'s Fig. 5): Kajita et al.
2010's linear-inverted-pendulum tracking, for a robot whose joints are position servoed (HRP-2),
in its DCM form:

* landing detection: the contact phase by the ankle sensors' force near a planned touchdown, not
  the clock alone (:meth:`LipStabilizer.phase`);
* estimate: the COM by kinematics from the joint encoders and the waist IMU's attitude, anchored
  on the plan's support soles (the robot does not know where it is otherwise), its velocity by
  a filtered difference; the ZMP measured by the ankles' force/torque sensors; and the COM's
  offset that kinematics cannot see (a link heavier, a payload) from the two by the
  pendulum: the measured ZMP against the one the estimated COM's motion implies;
* DCM feedback: the desired ZMP p_d = p_ref + (1 + k / omega) (xi - xi_ref), held inside the
  plan's support polygon (less a margin);
* the COM command: a shift dc of the planned COM at the velocity dc' = -k_c (xi - xi_ref)
  (``com_mode`` "velocity", the default). The pendulum-shaped command of Kajita's LIP tracking,
  dc'' = omega^2 ((c - c_ref) - (p_d - p_ref)) (``com_mode`` "lip"), decays the DCM error at k
  on a robot that follows its command exactly; on the twin the servoed robot follows it 0.1-0.2 s
  late, the loop rocked from the first double support and the walk fell (docs/humanoid-twin.md);
* ankle damping control: each support sole tilts by dtheta' = (tau_measured - tau_desired) / D
  - dtheta / T, so that its ankle torque follows the share of the desired ZMP it carries;
* swing height control: each swing sole's measured height driven to the plan's;
* joint targets: the plan's angles plus the linearised whole-body correction that moves the COM
  by dc, tilts the soles and lifts the swing soles, the rest held in place
  (:mod:`.humanoid_kinematics`).

With ``enabled`` False it passes the plan's joint angles through (the estimate still runs).
The tick's arithmetic after the kinematics runs in C (:mod:`.humanoid_native`) unless
``compiled`` is False or no C compiler is there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from skatelib.control import humanoid_native
from skatelib.control.feedback import StateError, check_arrays
from skatelib.control.humanoid_gains import StabilizerGains as StabilizerGains  # this module's API too
from skatelib.control.humanoid_kinematics import HumanoidKinematics, solve_rows
from skatelib.control.humanoid_reference import ReferenceSample
from skatelib.runtime.references import real

MIN_LOAD_N = 30.0  # a sole carrying less is not in the measured ZMP
TOE_OFF_RAD = 0.01  # a support sole planned pitched more than this stands on its toe
QUAT_NORM_TOL = 1e-3  # the IMU's quaternion this close to unit length (pinocchio does not normalize it)


@dataclass(frozen=True)
class StabilizerOutput:
    q_target: np.ndarray  # (n,) joint angle targets [rad]
    com: np.ndarray  # (3,) estimated COM [m]
    dcm: np.ndarray  # (2,) estimated DCM [m]
    zmp_measured: np.ndarray  # (2,) from the force/torque sensors (NaN with no sole loaded) [m]
    zmp_desired: np.ndarray  # (2,) [m]
    com_shift: np.ndarray  # (2,) dc [m]
    support: np.ndarray  # (2,) the soles the stabilizer took as support (the plan's, and any landed early)


def _mean(rows: list[np.ndarray]) -> np.ndarray:
    """The mean of one or two rows (as ``np.mean(rows, axis=0)``, without its cost at every tick)."""
    return rows[0] if len(rows) == 1 else (rows[0] + rows[1]) / 2


def _anchors(r: ReferenceSample) -> np.ndarray:
    """The soles anchoring the estimate.

    Raises:
        ValueError: None (a reference with no support sole: nothing tells where the robot is).
    """
    sup = r.anchors
    if not sup.any():
        raise ValueError("the reference has no support sole to anchor the stabilizer's estimate")
    return sup


def _unit(quat_xyzw: np.ndarray) -> np.ndarray:
    """The IMU's attitude normalized (pinocchio would scale the body by its squared norm: a COM
    estimate off by decimetres).

    Raises:
        StateError: Beyond :data:`QUAT_NORM_TOL` of unit length (a zero one is no attitude, not upright).
    """
    n = math.hypot(*quat_xyzw.tolist())  # a fifth of numpy's norm on four numbers
    if not abs(n - 1.0) <= QUAT_NORM_TOL:
        raise StateError(f"sensors.quat_xyzw is not a unit quaternion ({quat_xyzw!r}: norm {n:.6g}, 1 +- "
                         f"{QUAT_NORM_TOL:g} expected): the IMU's attitude is wrong; skip it, hold the last command "
                         "or stop (nothing has used it)")
    return quat_xyzw if abs(n - 1.0) <= 1e-12 else quat_xyzw / n  # an IMU's unit quaternion as it came


class LipStabilizer:
    """One robot's stabilizer state, ticked at a fixed rate (with the C tick, :attr:`native`
    holds the state and the attributes here stay at their start)."""

    def __init__(self, kin: HumanoidKinematics, dt: float, gains: StabilizerGains | None = None):
        """``dt``: the tick's period [s]; a ValueError if not finite, not above 0 (the filters divide
        by it) or beyond the gains' time constants (their decays, one explicit step a tick, would overshoot)."""
        self.kin, self.dt, self.g = kin, dt, gains or StabilizerGains()
        shortest = min(self.g.ankle_return_s, self.g.swing_return_s)
        if not (real(dt) and 0.0 < dt <= shortest):
            raise ValueError(f"LipStabilizer(dt={dt!r}): the tick's period, a finite number of seconds above 0 and at "
                             f"most {shortest:g} (the gains' ankle_return_s, swing_return_s)")
        self.dc, self.dv, self.acc, self.offset, self.lift = (np.zeros(2) for _ in range(5))
        self.tilt = np.zeros((2, 2))
        self.swing_z = np.zeros(2)  # the soles' heights by kinematics, anchored on the support soles
        self.rel_prev: np.ndarray | None = None
        self.support_prev: tuple[bool, bool] = (True, True)
        self.v = np.zeros(3)  # the COM's velocity relative to the anchor soles
        self.v_world = np.zeros(3)
        # the tick in C (its own state): for the square correction of a model of 18 degrees of freedom
        self.native: humanoid_native.CompiledTick | None = None
        lib = humanoid_native.tick_library() if self.g.compiled and kin.model.nv == 18 else None
        if lib is not None:
            g = self.g
            self.native = humanoid_native.CompiledTick(lib, {
                "dt": dt, "dcm_gain": g.dcm_gain_per_s, "velocity_cutoff_hz": g.velocity_cutoff_hz,
                "offset_rate": g.offset_rate_per_s, "polygon_margin": g.polygon_margin_m,
                "ankle_damping": g.ankle_damping_Nms_per_rad, "ankle_return": g.ankle_return_s,
                "ankle_tilt_max": g.ankle_tilt_max_rad, "com_shift_max": g.com_shift_max_m, "lip": g.com_mode == "lip",
                "com_velocity_gain": g.com_velocity_gain_per_s, "swing_height_gain": g.swing_height_gain_per_s,
                "swing_return": g.swing_return_s, "enabled": g.enabled, "min_load": MIN_LOAD_N,
                "toe_off": TOE_OFF_RAD}, kin.model.nv)

    def _estimate(self, r: ReferenceSample, qfull: np.ndarray, force: np.ndarray, torque: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The COM (world, anchored on the support soles), the measured ZMP and each sole's load and
        CoP relative to its centre (foot frame: x, y)."""
        c, soles, pts, rots = self.kin.measure(qfull)
        sup = _anchors(r)
        anchor = _mean([r.soles[s] - soles[s] for s in (0, 1) if sup[s]])
        rel = c - _mean([soles[s] for s in (0, 1) if sup[s]])
        self.swing_z = soles[:, 2] + anchor[2]
        if self.rel_prev is not None and tuple(sup) == self.support_prev:
            a = 1.0 - math.exp(-2 * math.pi * self.g.velocity_cutoff_hz * self.dt)
            self.v += a * ((rel - self.rel_prev) / self.dt - self.v)
        self.rel_prev, self.support_prev = rel, (bool(sup[0]), bool(sup[1]))
        # The COM's velocity over the anchor soles, plus theirs as planned (a board sole rides at
        # the board's speed): the estimate's frame moves as the anchor soles' planned places do.
        self.v_world = self.v + _mean([r.sole_vel[s] for s in (0, 1) if sup[s]])
        fz, num = 0.0, np.zeros(2)
        loads, cops = np.zeros(2), np.zeros((2, 2))
        for s in (0, 1):
            fw, nw = rots[s] @ force[s], rots[s] @ torque[s]
            if fw[2] < MIN_LOAD_N:
                continue
            p = pts[s] + anchor
            h = p[2] - r.soles[s][2]  # the sensor over its sole
            zmp = np.array([p[0] - (nw[1] + h * fw[0]) / fw[2], p[1] - (h * fw[1] - nw[0]) / fw[2]])
            fz, num = fz + fw[2], num + fw[2] * zmp
            loads[s] = fw[2]
            cops[s] = (rots[s].T @ np.append(zmp - r.soles[s][0:2], 0.0))[0:2]
        zmp_meas = num / fz if fz > 0 else np.full(2, np.nan)
        return c + anchor, zmp_meas, loads, cops

    def tick(self, r: ReferenceSample, q: np.ndarray, quat_xyzw: np.ndarray, force: np.ndarray,
             torque: np.ndarray) -> StabilizerOutput:
        """Joint targets from the sensors (``force``, ``torque``: (2, 3) the ground side's wrench on
        each foot at its ankle sensor, foot frame; any array-like) and the reference at this instant;
        a ``StateError`` naming a sensor of another shape, not finite, or an attitude that is no unit
        quaternion (nothing of it used)."""
        q, quat_xyzw, force, torque = np.asarray(q), np.asarray(quat_xyzw), np.asarray(force), np.asarray(torque)
        check_arrays("sensors", {"q": (q, (self.kin.model.nq - 7,)), "quat_xyzw": (quat_xyzw, (4,)),
                                 "force": (force, (2, 3)), "torque": (torque, (2, 3))})
        quat_xyzw = _unit(quat_xyzw)
        if self.native is not None:
            return self._tick_native(self.native, r, q, quat_xyzw, force, torque)
        g, dt = self.g, self.dt
        r = self.phase(r, force)
        qfull = self.kin.configuration(quat_xyzw, q)
        com, zmp_meas, loads, cops = self._estimate(r, qfull, force, torque)
        omega = math.sqrt(r.gravity / max(r.com[2] - r.ground_z, 0.2))
        c = com[0:2] + self.offset
        if not np.isnan(zmp_meas).any():  # the ZMP the COM's deviation implies against the measured one's
            implied = (c - r.com[0:2]) - self.acc / omega**2  # the plan's ZMP is its multibody one
            self.offset += g.offset_rate_per_s * dt * ((zmp_meas - r.zmp) - implied)
        xi = c + self.v_world[0:2] / omega
        xi_ref = r.com[0:2] + r.com_vel[0:2] / omega
        p_d = r.zmp + (1 + g.dcm_gain_per_s / omega) * (xi - xi_ref)
        p_d = r.clamp(p_d, g.polygon_margin_m)
        if g.enabled:
            if g.com_mode == "lip":
                self.acc = omega**2 * ((c - r.com[0:2]) - (p_d - r.zmp))
                self.dv += self.acc * dt
            else:
                v_new = -g.com_velocity_gain_per_s * (xi - xi_ref)
                self.acc, self.dv = (v_new - self.dv) / dt, v_new
            self.dc += self.dv * dt
            n = float(np.linalg.norm(self.dc))
            if n > g.com_shift_max_m:
                self.dc *= g.com_shift_max_m / n
                self.dv[:] = 0.0
            self._ankles(r, p_d, loads, cops)
            self._swing_height(r)
        base = self.kin.configuration(r.base_quat_xyzw, r.q, r.base_pos)
        dq = (self.kin.correction(base, np.append(self.dc, 0.0), self.tilt, self.lift) if g.enabled
              else np.zeros(len(r.q)))
        return StabilizerOutput(r.q + dq, com, xi, zmp_meas, p_d, self.dc.copy(), r.support.copy())

    def _tick_native(self, native: humanoid_native.CompiledTick, r: ReferenceSample, q: np.ndarray,
                     quat_xyzw: np.ndarray, force: np.ndarray, torque: np.ndarray) -> StabilizerOutput:
        """:meth:`tick` with its arithmetic after the kinematics in C."""
        r = self.phase(r, force)
        _anchors(r)
        measured = self.kin.measure(self.kin.configuration(quat_xyzw, q))
        rows = self.kin.rows(self.kin.configuration(r.base_quat_xyzw, r.q, r.base_pos)) if self.g.enabled else None
        o, n = native(r, measured, force, torque, rows), humanoid_native
        dq = o[n.OUT_FIXED + 6:]
        if o[n.O_SINGULAR] and rows is not None:  # the least-norm change, as the Python path's
            st = native.state
            dq = solve_rows(*rows, np.append(st[n.S_DC:n.S_DC + 2], 0.0), st[n.S_TILT:n.S_TILT + 4].reshape(2, 2),
                            st[n.S_LIFT:n.S_LIFT + 2])
        return StabilizerOutput(r.q + dq, o[n.O_COM:n.O_COM + 3], o[n.O_XI:n.O_XI + 2], o[n.O_ZMP:n.O_ZMP + 2],
                                o[n.O_PD:n.O_PD + 2], o[n.O_DC:n.O_DC + 2], r.support.copy())

    def _swing_height(self, r: ReferenceSample) -> None:
        """Swing height control: each swing sole's height, measured by kinematics anchored on the
        support soles with the IMU's attitude, driven to the plan's by lifting its target. Under an
        unmodelled load the stance ankle's servo gives a few mrad, the robot leans and a swing
        foot 0.3 m ahead comes down a millimetre low, touching down early."""
        g, dt = self.g, self.dt
        for s in (0, 1):
            if r.support[s]:
                self.lift[s] *= 1.0 - dt / g.swing_return_s
            else:
                self.lift[s] += g.swing_height_gain_per_s * dt * (r.soles[s][2] - self.swing_z[s])

    def phase(self, r: ReferenceSample, force: np.ndarray) -> ReferenceSample:
        """The landing detection: the contact phase by the measured foot force, not the clock alone. A
        sole the plan still swings but has within ``landing_window_m`` of its foothold, whose ankle
        sensor carries ``landing_load_N``, has landed (a foot 1 mm lower than planned touches down
        some 10 ms early); it supports from then on, at its planned place."""
        if not self.g.landing:
            return r
        return r.with_landed(force[:, 2], self.g.landing_load_N, self.g.landing_window_m)

    def _ankles(self, r: ReferenceSample, p_d: np.ndarray, loads: np.ndarray, cops: np.ndarray) -> None:
        """Damping control of each loaded support sole's tilt towards its share of the desired ZMP."""
        g, dt = self.g, self.dt
        for s in (0, 1):
            # A sole on its toe (a skate's toe-off) presses where its toe is: nothing to tilt towards.
            if not r.support[s] or loads[s] <= 0.0 or abs(r.sole_pitch[s]) > TOE_OFF_RAD:
                self.tilt[s] *= 1.0 - dt / g.ankle_return_s
                continue
            want = r.foot_cop(s, p_d)  # the desired CoP on this sole, foot frame
            # torque about the sole's x (roll) and y (pitch) axes: tau_x = f y, tau_y = -f x
            err = loads[s] * np.array([cops[s, 1] - want[1], -(cops[s, 0] - want[0])])
            rate = err / g.ankle_damping_Nms_per_rad - self.tilt[s] / g.ankle_return_s
            self.tilt[s] = np.clip(self.tilt[s] + rate * dt, -g.ankle_tilt_max_rad, g.ankle_tilt_max_rad)
