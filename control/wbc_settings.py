"""The whole-body controller's settings (:class:`WbcSettings`): the targets' gains, the tasks'
weights and the QP's bounds and backend, one frozen record shared by the targets
(:mod:`skatelib.control.wbc_targets`), the tasks (:mod:`skatelib.control.wbc_tasks`), the
constraints (:mod:`skatelib.control.wbc_constraints`) and the QP (:mod:`skatelib.control.wbc`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

NV = 18  # the floating-base model's velocity (and joint-acceleration) dimension: base 6 + joints 12


@dataclass(frozen=True)
class WbcSettings:
    """Gains [1/s^2, 1/s], weights and bounds of the whole-body QP.

    Attributes:
        stance_gain: The stance feet's velocity feedback toward their deck point's [1/s].
        w_force: The force task's weight [per N^2].
        regularization: Every decision variable's own weight (keeps the QP strictly convex).
        normal_min_N / normal_max_N: A stance foot's normal force bounds [N].
        friction_rows: Hold the forces in the friction pyramid (False only for the negative
            control that shows the rows matter).
        qp_solver: A backend of :data:`skatelib.control.qp.SOLVERS`.
        compiled: Make the targets and assemble the default tasks' and constraints' QP in C
            (:mod:`skatelib.control.wbc_native`; the Python path when False, or without a C
            compiler).
    """

    kp_com: float = 100.0
    kd_com: float = 20.0
    kp_attitude: float = 100.0
    kd_attitude: float = 20.0
    kp_swing: float = 400.0
    kd_swing: float = 40.0
    kp_posture: float = 50.0
    kd_posture: float = 5.0
    stance_gain: float = 10.0
    w_com: float = 1.0
    w_attitude: float = 1.0
    w_swing: float = 1.0
    w_force: float = 1e-1
    w_posture: float = 1e-3
    regularization: float = 1e-6
    normal_min_N: float = 1.0
    normal_max_N: float = 150.0
    friction_rows: bool = True
    qp_solver: str = "daqp"
    compiled: bool = True

    def __post_init__(self) -> None:
        """Raises:
            ValueError: A gain or weight that is negative or not finite, a regularization of 0 or
                below, normal force bounds that cross, a backend that is not in the table.
        """
        from skatelib.control.qp import SOLVERS

        for name, value in vars(self).items():
            if isinstance(value, float) and not (math.isfinite(value) and value >= 0):
                raise ValueError(f"WbcSettings({name}={value!r}): a finite value of at least 0")
        if not self.regularization > 0:
            raise ValueError(f"WbcSettings(regularization={self.regularization!r}): above 0 (a strictly convex QP)")
        if not 0 <= self.normal_min_N <= self.normal_max_N:
            raise ValueError(f"WbcSettings(normal_min_N={self.normal_min_N!r}, normal_max_N={self.normal_max_N!r}): "
                             "0 <= normal_min_N <= normal_max_N")
        if self.qp_solver not in SOLVERS:
            raise ValueError(f"WbcSettings(qp_solver={self.qp_solver!r}): one of {', '.join(SOLVERS)}")
