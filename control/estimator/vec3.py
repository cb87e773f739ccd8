"""Small fixed-size algebra written out for the estimator's hot path (500 Hz in Python): numpy's
general routines (``np.cross``, ``np.linalg.lstsq``) spend tens of microseconds on argument
handling for three-vectors; these compute the same products with the same operations."""

from __future__ import annotations

import math

import numpy as np


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of two 3-vectors, or column-wise of (3, n) arrays (one broadcasting against the other),
    with numpy's ``np.cross`` operation order (a1 b2 - a2 b1, ...)."""
    return np.array((a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]))


def exp_so3(w: np.ndarray) -> np.ndarray:
    """Rodrigues' formula: the rotation of rotation vector ``w``."""
    x, y, z = float(w[0]), float(w[1]), float(w[2])
    a2 = x * x + y * y + z * z
    if a2 < 1e-18:
        return np.array([[1.0, -z, y], [z, 1.0, -x], [-y, x, 1.0]])
    a = math.sqrt(a2)
    s, c = math.sin(a) / a, (1.0 - math.cos(a)) / a2
    # I + s K + c K^2, with K^2 = w w^T - |w|^2 I written out
    return np.array([[1.0 - c * (y * y + z * z), c * x * y - s * z, c * x * z + s * y],
                     [c * x * y + s * z, 1.0 - c * (x * x + z * z), c * y * z - s * x],
                     [c * x * z - s * y, c * y * z + s * x, 1.0 - c * (x * x + y * y)]])
