"""The wheels' rolling resistance, applied as a torque on each wheel's hinge: c_rr times the
wheel's load on the floor, times the radius, against the wheel's rolling, through a smooth sign
``tanh(v / v_eps)`` of its rolling speed v = omega r (v_eps 5 mm/s).

MuJoCo's own rolling friction (a contact's condim 6) is a soft constraint: below some tenths of a
metre per second it acts like a damper, and a board loaded with the robot coasting at 0.1 m/s
slowed at 0.037 m/s^2 where its 0.01 x g is 0.098 (at 0.5 m/s and above it was right). A
urethane wheel's resistance is hysteresis in the tyre: about proportional to the load and nearly
independent of the speed, which this torque is.

Every stepping of the twin goes through :func:`step` (the torque follows the loads of the last step).
"""

from __future__ import annotations

from typing import Any

import numpy as np

WHEELS = ("wheel_fl", "wheel_fr", "wheel_rl", "wheel_rr")
SMOOTHING_MPS = 0.005  # v_eps of the smooth sign: near Coulomb, without chatter at rest


class RollingResistance:
    """The rolling torques of a compiled twin (its wheel actuators ``rolling_<wheel>``)."""

    def __init__(self, m: Any, coefficient: float):
        self.m = m
        self.coefficient = coefficient
        self.geoms = np.array([m.geom(w).id for w in WHEELS])
        self.dofs = np.array([m.joint(w).dofadr[0] for w in WHEELS])
        self.actuators = np.array([m.actuator(f"rolling_{w}").id for w in WHEELS])
        self.radius = np.array([m.geom_size[g][0] for g in self.geoms])
        self.floor = m.geom("floor").id
        self.wheel_of = np.full(m.ngeom, -1)  # each geom's wheel (-1: none)
        self.wheel_of[self.geoms] = np.arange(len(WHEELS))
        self._force = np.zeros(6)

    def floor_forces(self, d: Any) -> tuple[np.ndarray, np.ndarray]:
        """(4,) each wheel's normal force on the floor [N] and (3,) the floor's force on all four
        wheels, world frame (contacts of the last step)."""
        import mujoco

        loads, total = np.zeros(4), np.zeros(3)
        if d.ncon == 0:
            return loads, total
        con = d.contact
        g1, g2 = con.geom1, con.geom2
        # the contacts of a wheel with the floor, picked from the arrays (a Python loop over every
        # contact of a robot on a board costs more than the physics step)
        w1, w2 = self.wheel_of[g1], self.wheel_of[g2]
        picked = np.nonzero(((g1 == self.floor) & (w2 >= 0)) | ((g2 == self.floor) & (w1 >= 0)))[0]
        if len(picked) == 0:
            return loads, total
        frames = con.frame
        for k in picked:
            hit = int(max(w1[k], w2[k]))
            mujoco.mj_contactForce(self.m, d, int(k), self._force)
            loads[hit] += self._force[0]
            force = frames[k].reshape(3, 3).T @ self._force[:3]  # on geom2 (the wheel, or the floor)
            total += force if w2[k] == hit else -force
        return loads, total

    def apply(self, d: Any) -> None:
        v = d.qvel[self.dofs] * self.radius
        loads, _ = self.floor_forces(d)
        d.ctrl[self.actuators] = -self.coefficient * self.radius * loads * np.tanh(v / SMOOTHING_MPS)


def add_rolling_actuators(spec: Any) -> None:
    """One unlimited torque actuator per wheel hinge, for :class:`RollingResistance`."""
    import mujoco

    for w in WHEELS:
        spec.add_actuator(name=f"rolling_{w}", target=w, trntype=mujoco.mjtTrn.mjTRN_JOINT)


def step(m: Any, d: Any, rolling: RollingResistance, n: int = 1) -> None:
    """``n`` steps with the rolling torques updated before each."""
    import mujoco

    for _ in range(n):
        rolling.apply(d)
        mujoco.mj_step(m, d)
