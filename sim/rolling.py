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

import math
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
        # for each pair of geoms (geom1, geom2) of a contact: the wheel of a wheel on the floor (-1: none)
        self.pair_wheel = np.full((m.ngeom, m.ngeom), -1)
        self.pair_wheel[self.floor, self.geoms] = self.pair_wheel[self.geoms, self.floor] = np.arange(len(WHEELS))
        self._force = np.zeros(6)

    def _picked(self, d: Any) -> tuple[list[int], list[int], list[bool]]:
        """The contacts of a wheel with the floor (the last step's), each one's wheel, and whether
        the wheel is its geom2 (the contact's force is on geom2)."""
        if d.ncon == 0:
            return [], [], []
        con = d.contact
        g1, g2 = con.geom1, con.geom2
        # picked from the arrays: a Python loop over every contact of a robot on a board costs more
        # than the physics step
        wheel = self.pair_wheel[g1, g2]
        picked = np.nonzero(wheel >= 0)[0]
        return picked.tolist(), wheel[picked].tolist(), (g2[picked] != self.floor).tolist()

    def wheel_loads(self, d: Any) -> np.ndarray:
        """(4,) each wheel's normal force on the floor [N] (contacts of the last step)."""
        import mujoco

        loads = np.zeros(4)
        picked, wheels, _ = self._picked(d)
        for k, hit in zip(picked, wheels, strict=True):
            mujoco.mj_contactForce(self.m, d, k, self._force)
            loads[hit] += self._force[0]
        return loads

    def floor_forces(self, d: Any) -> tuple[np.ndarray, np.ndarray]:
        """(4,) each wheel's normal force on the floor [N] and (3,) the floor's force on all four
        wheels, world frame (contacts of the last step)."""
        import mujoco

        loads, total = np.zeros(4), np.zeros(3)
        picked, wheels, on_geom2 = self._picked(d)
        if not picked:
            return loads, total
        frames = d.contact.frame
        for k, hit, second in zip(picked, wheels, on_geom2, strict=True):
            mujoco.mj_contactForce(self.m, d, k, self._force)
            loads[hit] += self._force[0]
            fr, f = frames[k], self._force
            force = fr[0:3] * f[0] + fr[3:6] * f[1] + fr[6:9] * f[2]  # on geom2 (the wheel, or the floor)
            total += force if second else -force
        return loads, total

    def apply(self, d: Any, loads: np.ndarray | None = None) -> None:
        """The rolling torques from the contacts of the last step (``loads``: their wheel loads, when
        already read from them)."""
        v = d.qvel[self.dofs] * self.radius
        if loads is None:
            loads = self.wheel_loads(d)
        # the C library's tanh, as the compiled twin's (numpy's own differs in the last bit)
        smooth = np.array([math.tanh(x) for x in v / SMOOTHING_MPS])
        d.ctrl[self.actuators] = -self.coefficient * self.radius * loads * smooth


def add_rolling_actuators(spec: Any) -> None:
    """One unlimited torque actuator per wheel hinge, for :class:`RollingResistance`."""
    import mujoco

    for w in WHEELS:
        spec.add_actuator(name=f"rolling_{w}", target=w, trntype=mujoco.mjtTrn.mjTRN_JOINT)


def step(m: Any, d: Any, rolling: RollingResistance, n: int = 1, loads: np.ndarray | None = None) -> None:
    """``n`` steps with the rolling torques updated before each (``loads``: the wheels' loads of the
    contacts as they are, when already read from them)."""
    import mujoco

    for k in range(n):
        rolling.apply(d, loads if k == 0 else None)
        mujoco.mj_step(m, d)
