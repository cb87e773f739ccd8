"""Chains of entries from one riding speed to another (``MotionLibrary.route``): the library's
successful entries are the edges of a graph whose nodes are speeds (0: at rest), each entry
leading from its start speed (0 for a start-up) to its target; the route is the chain that takes
the least time, the fewest entries on ties (Dijkstra). Numpy-free and small: the robot plans a
ride with it."""

from __future__ import annotations

import heapq
from collections.abc import Iterable

from skatelib.runtime.entry import Entry, EntryNotFound
from skatelib.runtime.references import real


def speed_key(v: float) -> float:
    """A speed as entry keys name it (two decimals) [m/s]."""
    return round(float(v), 2)


def _ends(from_velocity_mps: float, target_velocity_mps: float) -> tuple[float, float]:
    """The two speeds as keys, or the ValueError that says what two speeds a route takes."""
    ok = real(from_velocity_mps) and real(target_velocity_mps)
    a, b = (speed_key(from_velocity_mps), speed_key(target_velocity_mps)) if ok else (-1.0, -1.0)
    if not (a >= 0 and b >= 0) or a == b:
        raise ValueError(f"route({from_velocity_mps!r}, {target_velocity_mps!r}): two different finite speeds of at "
                         "least 0 m/s")
    return a, b


def route(entries: Iterable[Entry], from_velocity_mps: float, target_velocity_mps: float,
          where: str = "") -> list[Entry]:
    """The chain of entries (in riding order) from ``from_velocity_mps`` to ``target_velocity_mps``
    [m/s] that takes the least time.

    Raises:
        ValueError: When the speeds are equal, negative or not finite.
        EntryNotFound: When no chain of successful entries leads there (the message lists the speeds
            that can be reached from ``from_velocity_mps``).
    """
    a, b = _ends(from_velocity_mps, target_velocity_mps)
    edges: dict[float, list[Entry]] = {}
    for e in entries:
        if e.success:
            edges.setdefault(speed_key(e.from_velocity_mps), []).append(e)
    best: dict[float, tuple[float, int]] = {a: (0.0, 0)}
    came: dict[float, Entry] = {}
    heap: list[tuple[float, int, float]] = [(0.0, 0, a)]
    while heap:
        t, n, v = heapq.heappop(heap)
        if (t, n) > best.get(v, (float("inf"), 0)):
            continue
        for e in edges.get(v, []):
            w, cost = speed_key(e.target_velocity_mps), (t + e.duration_s, n + 1)
            if cost < best.get(w, (float("inf"), 0)):
                best[w], came[w] = cost, e
                heapq.heappush(heap, (*cost, w))
    if b not in came:
        reach = sorted(v for v in best if v != a)
        raise EntryNotFound(f"{where}no chain of successful entries rides from {a} to {b} m/s; from {a} m/s the "
                            f"library reaches {reach} m/s")
    chain = [came[b]]
    while speed_key(chain[-1].from_velocity_mps) != a:
        chain.append(came[speed_key(chain[-1].from_velocity_mps)])
    return chain[::-1]
