"""One tick's sensor readings as the estimator takes them."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
from skatelib.control.feedback import check_arrays
from skatelib.runtime.references import real


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


class ReadingError(ValueError):
    """A reading the estimator cannot take: a field of another shape, a NaN or an inf, a time that
    is not finite or goes back. The estimator's state is unchanged; the caller skips the reading
    (a dropped sample) or stops."""


SHAPES = {"gyro": (3,), "accel": (3,), "q": (12,), "qd": (12,)}


def check_reading(reading: Reading, last_t: float | None) -> None:
    """Refuse a reading that would make the estimate NaN for good (its filters integrate it).

    Raises:
        ReadingError: Naming the field and what is wrong.
    """
    t = reading.t
    if not real(t) or (last_t is not None and t < last_t):
        raise ReadingError(f"reading.t = {t!r}: a finite time in seconds, not before the last reading's ({last_t})")
    check_arrays("reading", {name: (getattr(reading, name), shape) for name, shape in SHAPES.items()}, ReadingError)


def check_still(still: Sequence[Reading]) -> None:
    """Readings to calibrate on: at least one, each one the estimator can take.

    Raises:
        ReadingError: Naming what is wrong.
    """
    if not still:
        raise ReadingError("calibrate(still): no reading; give the readings of some ticks standing still")
    for reading in still:
        check_reading(reading, None)
