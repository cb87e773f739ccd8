"""One tick's sensor readings as the estimator takes them."""

from __future__ import annotations

from typing import Protocol

import numpy as np


class Reading(Protocol):
    """One tick's sensor readings (IMU frame; joints in channel order)."""

    @property
    def t(self) -> float: ...

    @property
    def gyro(self) -> np.ndarray: ...

    @property
    def accel(self) -> np.ndarray: ...

    @property
    def q(self) -> np.ndarray: ...

    @property
    def qd(self) -> np.ndarray: ...
