"""The contact ZMP's distance inside the support polygon, for every tick of a run at once: the
polygon is the convex hull of the support soles' rectangles, found here as the edges between two
corners that have every corner on their left (a supporting line), not by the controller's hull
(:mod:`skatelib.control.humanoid_reference`), so that the verdict does not share the controller's
geometry; measured after the run over all its ticks, where a per-tick hull in Python cost more
than the physics step it judged."""

from __future__ import annotations

import numpy as np

_CORNERS = np.array([(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)])
CHUNK = 2048  # ticks a pass (its arrays: CHUNK x 8 x 8 x 8 doubles)
COLLINEAR_M = 1e-12  # a corner this close to an edge's line, outside, still lets the edge bound the hull


def corners(centres: np.ndarray, yaw: np.ndarray, size: tuple[float, float]) -> np.ndarray:
    """Each sole's rectangle's corners (N, 2, 4, 2) from its centre (N, 2, 2), yaw (N, 2) and the
    soles' (length, width)."""
    d = _CORNERS * (np.asarray(size) / 2)  # (4, 2)
    c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    return np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]], axis=-1) + centres[:, :, None, :]


def margins(centres: np.ndarray, yaw: np.ndarray, on: np.ndarray, size: tuple[float, float], zmp: np.ndarray
            ) -> np.ndarray:
    """The distance (N,) of ``zmp`` (N, 2) inside the convex hull of the soles ``on`` (N, 2) [m]: the
    least over the hull's edges of its signed distance to the edge's line (negative: outside); inf
    without a support sole, -inf where the ZMP is NaN (nothing touches)."""
    out = np.empty(len(zmp))
    for a in range(0, len(zmp), CHUNK):
        b = min(a + CHUNK, len(zmp))
        out[a:b] = _margins(corners(centres[a:b], yaw[a:b], size).reshape(-1, 8, 2),
                            np.repeat(np.asarray(on[a:b], bool), 4, axis=1), zmp[a:b])
    return out


def _margins(p: np.ndarray, on: np.ndarray, z: np.ndarray) -> np.ndarray:
    e = p[:, None, :, :] - p[:, :, None, :]  # (n, i, j, 2): corner j from corner i, the edge i -> j
    length = np.hypot(e[..., 0], e[..., 1])
    side = e[:, :, :, None, 0] * e[:, :, None, :, 1] - e[:, :, :, None, 1] * e[:, :, None, :, 0]  # (n, i, j, k)
    left = (side >= -COLLINEAR_M * length[..., None]) | ~on[:, None, None, :]
    edge = on[:, :, None] & on[:, None, :] & (length > 0.0) & left.all(axis=-1)
    rz = z[:, None, :] - p  # (n, i, 2): the ZMP from corner i
    with np.errstate(invalid="ignore", divide="ignore"):
        d = (e[..., 0] * rz[:, :, None, 1] - e[..., 1] * rz[:, :, None, 0]) / length
    m = np.where(edge, d, np.inf).min(axis=(1, 2))
    return np.where(np.isnan(z).any(axis=1), -np.inf, m)
