"""Support geometry of a humanoid step: contact segments with their support polygons (Eq. 18), as
half-planes for the ZMP constraint, and the rectangles and convex hulls they are made of."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

MAX_EDGES = 8


@dataclass(frozen=True)
class Support:
    """Contact during part of a step.

    Attributes:
        p0: Representative contact point at the segment's start [m] (world).
        velocity: Its constant velocity [m/s] (zero on the ground, the board's on a skateboard).
        polygon: (M, 2) support polygon vertices relative to P0, counter-clockwise [m].
        mu_x, mu_y: Static friction coefficients along x and y (0 along a skating direction).
    """

    p0: tuple[float, float, float]
    velocity: tuple[float, float, float]
    polygon: tuple[tuple[float, float], ...]
    mu_x: float
    mu_y: float



def edges(polygon: tuple[tuple[float, float], ...]) -> np.ndarray:
    """Rows (a, b, c) with a x + b y + c >= 0 inside a counter-clockwise polygon; padded with the
    trivial (0, 0, 1) so every node has MAX_EDGES rows."""
    v = np.asarray(polygon, dtype=float)
    rows = []
    for i in range(len(v)):
        (x0, y0), (x1, y1) = v[i], v[(i + 1) % len(v)]
        ex, ey = x1 - x0, y1 - y0
        rows.append((-ey, ex, ey * x0 - ex * y0))
    if len(rows) > MAX_EDGES:
        raise ValueError(f"support polygons have at most {MAX_EDGES} edges")
    rows += [(0.0, 0.0, 1.0)] * (MAX_EDGES - len(rows))
    return np.asarray(rows)


def rectangle(cx: float, cy: float, length: float, width: float) -> tuple[tuple[float, float], ...]:
    """Counter-clockwise rectangle centred at (cx, cy)."""
    hx, hy = length / 2, width / 2
    return ((cx - hx, cy - hy), (cx + hx, cy - hy), (cx + hx, cy + hy), (cx - hx, cy + hy))


def convex_hull(points: np.ndarray) -> tuple[tuple[float, float], ...]:
    """Counter-clockwise convex hull (monotone chain)."""
    pts = sorted({(round(float(x), 12), round(float(y), 12)) for x, y in points})

    def cross(o: Any, a: Any, b: Any) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[Any] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[Any] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return tuple(lower[:-1] + upper[:-1])
