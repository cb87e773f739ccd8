"""The whole-body QP's tasks: each a weighted least-squares term w |A x - b|^2 of the decision
vector x = (qdd, f) (the joint accelerations, then the stance feet's forces), summed by the QP's
assembly (:mod:`skatelib.control.wbc`) as pink and mink sum theirs: a task gives its Jacobian A and
its target b, the assembly the rest.

A task either has dense rows over qdd (the centre of mass, the swinging feet: the assembly stacks
every dense task's rows into one matrix and forms A'A once) or selects some entries of x (its A
the identity on them: the attitude, the posture, the forces; its Hessian a fixed diagonal, filled
once per stance set, its gradient -w b on those entries).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from skatelib.control.multibody import DynamicsTerms
from skatelib.control.wbc_settings import NV, WbcSettings
from skatelib.control.wbc_targets import StanceSet, WbcTargets


class Task(Protocol):
    """One weighted least-squares term w |A x - b|^2 of the whole-body QP."""

    @property
    def weight(self) -> float:
        """w (a dense task's rows are scaled by its square root)."""
        ...

    def columns(self, stance: StanceSet) -> slice | np.ndarray | None:
        """The entries of x the task selects (A their identity), or None: dense rows over qdd."""
        ...

    def size(self, stance: StanceSet) -> int:
        """Its rows for this stance set."""
        ...

    def jacobian(self, T: DynamicsTerms, stance: StanceSet) -> np.ndarray:
        """A: (size, NV) over qdd for a dense task; a selecting task's identity (size, size)."""
        ...

    def target(self, T: DynamicsTerms, tg: WbcTargets, stance: StanceSet) -> np.ndarray:
        """b: (size,) this tick's target."""
        ...


class _Selecting:
    """A task whose A is the identity on its columns of x."""

    weight: float

    def size(self, stance: StanceSet) -> int:
        raise NotImplementedError

    def jacobian(self, T: DynamicsTerms, stance: StanceSet) -> np.ndarray:
        return np.eye(self.size(stance))


class ComTask:
    """The model COM point's acceleration: J_com qdd = com_acc - Jdot_com v."""

    def __init__(self, s: WbcSettings):
        self.weight = s.w_com

    def columns(self, stance: StanceSet) -> None:
        return None

    def size(self, stance: StanceSet) -> int:
        return 3

    def jacobian(self, T: DynamicsTerms, stance: StanceSet) -> np.ndarray:
        return T.J_com

    def target(self, T: DynamicsTerms, tg: WbcTargets, stance: StanceSet) -> np.ndarray:
        return tg.com_acc - T.dJv_com


class SwingFeetTask:
    """Each swinging foot's acceleration along its path: J_i qdd = swing_acc_i - Jdot_i v."""

    def __init__(self, s: WbcSettings):
        self.weight = s.w_swing

    def columns(self, stance: StanceSet) -> None:
        return None

    def size(self, stance: StanceSet) -> int:
        return 3 * len(stance.swing)

    def jacobian(self, T: DynamicsTerms, stance: StanceSet) -> np.ndarray:
        return T.J_feet[stance.swing].reshape(-1, NV)

    def target(self, T: DynamicsTerms, tg: WbcTargets, stance: StanceSet) -> np.ndarray:
        swing = stance.swing
        return (tg.swing_acc[:, swing] - T.dJv_feet[swing].T).T.ravel()


class AttitudeTask(_Selecting):
    """The trunk's angular acceleration (the base's angular coordinates of qdd, trunk frame)."""

    def __init__(self, s: WbcSettings):
        self.weight = s.w_attitude

    def columns(self, stance: StanceSet) -> slice:
        return slice(3, 6)

    def size(self, stance: StanceSet) -> int:
        return 3

    def target(self, T: DynamicsTerms, tg: WbcTargets, stance: StanceSet) -> np.ndarray:
        return tg.angular_acc


class PostureTask(_Selecting):
    """The joints' accelerations toward the posture (``joints``: their columns of qdd, channel order)."""

    def __init__(self, s: WbcSettings, joints: slice | np.ndarray):
        self.weight, self.joints = s.w_posture, joints

    def columns(self, stance: StanceSet) -> slice | np.ndarray:
        return self.joints

    def size(self, stance: StanceSet) -> int:
        return 12

    def target(self, T: DynamicsTerms, tg: WbcTargets, stance: StanceSet) -> np.ndarray:
        return tg.posture_acc


class ForceTask(_Selecting):
    """The stance feet's contact forces toward the MPC's [N]."""

    def __init__(self, s: WbcSettings):
        self.weight = s.w_force

    def columns(self, stance: StanceSet) -> slice:
        return slice(NV, NV + stance.n_forces)

    def size(self, stance: StanceSet) -> int:
        return stance.n_forces

    def target(self, T: DynamicsTerms, tg: WbcTargets, stance: StanceSet) -> np.ndarray:
        return tg.forces[:, stance.legs].T.ravel()


def default_tasks(s: WbcSettings, joints: slice | np.ndarray) -> list[Task]:
    """The paper's tasks, in the order the QP stacks them (dense rows: the COM's, then the swinging feet's)."""
    return [ComTask(s), SwingFeetTask(s), AttitudeTask(s), PostureTask(s, joints), ForceTask(s)]
