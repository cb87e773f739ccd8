"""A humanoid library entry as the stabilizer's reference: at any time, the planned joints and
waist, both soles, which soles support the robot, the COM (the dynamics filter's, with its
velocity and acceleration) and the plan's ZMP, and the support polygon (the convex hull of the
support soles' rectangles) that holds the desired ZMP."""

from __future__ import annotations

import bisect
import itertools
import math
from dataclasses import dataclass, field, replace

import numpy as np
from skatelib.library import schema
from skatelib.library.model import HumanoidModel
from skatelib.runtime.entry import Entry
from skatelib.runtime.references import real

GROUND_M = 0.002  # a planned sole this close to the ground supports
# The arrays a humanoid entry holds of its whole body (format 1.3 on, where its COM motion held).
WHOLE_BODY = (schema.D_JOINTS, schema.D_BASE_POSE, schema.D_FEET, schema.D_COM_REFERENCE, schema.D_ZMP)


def _cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull (monotone chain) of (N, 2) points."""
    pts = sorted(set(map(tuple, np.round(points, 12).tolist())))
    lower: list[tuple[float, float]] = []
    upper: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and _cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and _cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def polygon_margin(poly: np.ndarray, p: np.ndarray) -> float:
    """The distance of ``p`` inside the counter-clockwise polygon (negative: outside) [m]."""
    e = np.empty_like(poly)
    e[:-1] = poly[1:] - poly[:-1]
    e[-1:] = poly[:1] - poly[-1:]
    d = (e[:, 0] * (p[1] - poly[:, 1]) - e[:, 1] * (p[0] - poly[:, 0])) / np.sqrt(e[:, 0] ** 2 + e[:, 1] ** 2)
    return float(d.min()) if len(d) else float("inf")


HULLS_KEPT = 16  # a reference keeps its last hulls, by their soles
_CORNERS = np.array([(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)])  # a sole's corners, in half sizes


@dataclass(frozen=True)
class ReferenceSample:
    """The reference at one instant (world frame)."""

    q: np.ndarray
    base_pos: np.ndarray
    base_quat_xyzw: np.ndarray
    soles: np.ndarray  # (2, 3) right, left sole centres
    sole_yaw: np.ndarray  # (2,)
    support: np.ndarray  # (2,) bool
    com: np.ndarray
    com_vel: np.ndarray
    com_acc: np.ndarray
    zmp: np.ndarray
    gravity: float
    sole_size: tuple[float, float]
    ground_z: float = 0.0  # the support soles' plane (the ground's 0, a skate's deck on the board)
    sole_plane: np.ndarray = field(default_factory=lambda: np.zeros(2))  # (2,) the surface under each sole [m]
    anchored: np.ndarray | None = None  # (2,) the soles whose planned place anchors the estimate (None: support)
    sole_vel: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))  # (2, 3) the soles' planned velocity
    sole_pitch: np.ndarray = field(default_factory=lambda: np.zeros(2))  # (2,) heel up: a toe-off [rad]
    # the hulls made (read-only; shared by the samples of one reference and their replacements)
    hulls: dict[tuple, np.ndarray] = field(default_factory=dict, repr=False, compare=False)

    @property
    def anchors(self) -> np.ndarray:
        """The soles whose planned place the robot takes as known (the support soles; on a skate's
        push the one on the ground alone: the board under the other rolls where it rolls)."""
        return self.support if self.anchored is None else self.anchored

    def polygon(self, margin: float = 0.0) -> np.ndarray:
        """The support soles' convex hull, each sole shrunk by ``margin`` (the same soles give the
        same hull: kept, a few of them, for the ticks that stand on them)."""
        key = (self.support.tobytes(), self.soles.tobytes(), self.sole_yaw.tobytes(), margin, self.sole_size)
        hull = self.hulls.get(key)
        if hull is None:
            if len(self.hulls) >= HULLS_KEPT:
                self.hulls.pop(next(iter(self.hulls)))
            hull = self.hulls[key] = self._polygon(margin)
        return hull

    def _polygon(self, margin: float) -> np.ndarray:
        half = np.array([self.sole_size[0] / 2 - margin, self.sole_size[1] / 2 - margin])
        on = np.nonzero(self.support)[0]
        if len(on) == 0:
            return np.zeros((0, 2))
        d = _CORNERS * half  # (4, 2)
        c, sn = np.cos(self.sole_yaw[on])[:, None], np.sin(self.sole_yaw[on])[:, None]
        corners = np.stack([c * d[:, 0] - sn * d[:, 1], sn * d[:, 0] + c * d[:, 1]], axis=-1)  # (k, 4, 2)
        hull = _hull((self.soles[on, None, 0:2] + corners).reshape(-1, 2))
        hull.setflags(write=False)
        return hull

    def with_landed(self, load_N: np.ndarray, min_load_N: float, window_m: float) -> ReferenceSample:
        """This sample with the soles landed early among its support: those the plan still swings
        but has within ``window_m`` of the ground, carrying ``min_load_N`` of ``load_N`` (2,)."""
        if self.support[0] and self.support[1]:
            return self  # both down: none to land
        landed = (~self.support) & (self.soles[:, 2] - self.sole_plane < window_m) & (np.asarray(load_N) > min_load_N)
        return replace(self, support=self.support | landed) if landed.any() else self

    def clamp(self, p: np.ndarray, margin: float) -> np.ndarray:
        """``p`` held inside the support polygon less ``margin`` (the nearest point of it)."""
        poly = self.polygon(margin)
        if polygon_margin(poly, p) >= 0.0:
            return p
        best, dist = p, np.inf
        for i in range(len(poly)):
            a, b = poly[i], poly[(i + 1) % len(poly)]
            t = float(np.clip(np.dot(p - a, b - a) / max(float(np.dot(b - a, b - a)), 1e-12), 0.0, 1.0))
            x = a + t * (b - a)
            if np.linalg.norm(p - x) < dist:
                best, dist = x, float(np.linalg.norm(p - x))
        return np.asarray(best)

    def foot_cop(self, s: int, p_d: np.ndarray) -> np.ndarray:
        """The desired centre of pressure on sole ``s`` (its frame: x, y): in single support the
        desired ZMP; in double support the desired ZMP's offset from the segment between the two
        soles' centres, on each sole."""
        if self.support.all():
            a, b = self.soles[0][0:2], self.soles[1][0:2]
            t = float(np.clip(np.dot(p_d - a, b - a) / max(float(np.dot(b - a, b - a)), 1e-12), 0.0, 1.0))
            d = p_d - (a + t * (b - a))
        else:
            d = p_d - self.soles[s][0:2]
        c, sn = np.cos(self.sole_yaw[s]), np.sin(self.sole_yaw[s])
        local = np.array([c * d[0] + sn * d[1], -sn * d[0] + c * d[1]])
        return np.clip(local, [-self.sole_size[0] / 2, -self.sole_size[1] / 2],
                       [self.sole_size[0] / 2, self.sole_size[1] / 2])


def _ground_anchors(on: tuple[bool, bool], levels: tuple[float, float]) -> np.ndarray | None:
    """The support soles on the ground when the others stand on a board (a skate's push), else
    None (all support soles anchor)."""
    ground = (on[0] and levels[0] == 0.0, on[1] and levels[1] == 0.0)
    deck = (on[0] and levels[0] > 0.0) or (on[1] and levels[1] > 0.0)
    return np.array(ground) if (ground[0] or ground[1]) and deck else None


class HumanoidReference:
    """An entry's whole body sampled at any time (linear between knots, clamped at the ends)."""

    def __init__(self, entry: Entry, model: HumanoidModel):
        """Raises:
            ValueError: For an entry without a humanoid's whole body (a quadruped's, or a humanoid's
                whose COM motion failed), naming it and the arrays it lacks.
        """
        a = entry.arrays
        missing = [d for d in WHOLE_BODY if d not in a]
        if missing:
            what = ("a quadruped's entry, not a humanoid's" if entry.board_pos is not None else
                    "a humanoid entry without its whole body (its COM motion failed, or a library before format 1.3)")
            raise ValueError(f"HumanoidReference: {entry.key!r} is {what}: it has no {', '.join(missing)}; take an "
                             "entry of a humanoid library whose whole body was solved")
        self.t = np.asarray(entry.t, dtype=float)
        self.q = np.asarray(a[schema.D_JOINTS])
        self.base = np.asarray(a[schema.D_BASE_POSE])
        self.feet = np.asarray(a[schema.D_FEET]).reshape(len(self.t), 2, -1)
        self.com = np.asarray(a[schema.D_COM_REFERENCE])
        self.com_vel = np.gradient(self.com, self.t, axis=0)
        self.com_acc = np.gradient(self.com_vel, self.t, axis=0)
        self.zmp = np.asarray(a[schema.D_ZMP])
        self.model = model
        self.hulls: dict[tuple, np.ndarray] = {}  # its samples' support polygons, by their soles
        self.duration_s = float(self.t[-1])
        # The surface under each sole at each knot: a skate's deck where the sole is over it (under
        # the board sole, where its deck is), else the ground; a planned sole on it supports.
        self.plane = np.zeros((len(self.t), 2))
        if model.board is not None:
            over = model.board.over_deck(self.feet[:, :, 0:2], self.feet[:, None, 0, 0:2])
            self.plane = np.where(over, model.board.deck_height_m, 0.0)
        self.support = self._lowest(self.feet) - self.plane < GROUND_M
        # A sole on the ground stands still; one on a deck rides at the board's planned speed.
        self.sole_vel = np.where((self.plane > 0.0)[:, :, None], np.gradient(self.feet[:, :, 0:3], self.t, axis=0), 0.0)
        # every knot's sampled rows side by side: one interpolation a sample (each column as alone)
        parts = (self.q, self.base, self.feet.reshape(len(self.t), -1), self.com, self.com_vel, self.com_acc,
                 self.zmp, self.sole_vel.reshape(len(self.t), -1))
        self._knots = np.hstack(parts)
        cols = np.cumsum([0, *(x.shape[1] for x in parts)]).tolist()
        self._slices = tuple(slice(a, b) for a, b in itertools.pairwise(cols))
        self._width = self.feet.shape[2]
        self._times = self.t.tolist()  # a sample's search in a list: a tenth of numpy's on one value
        self._planes = [(float(a), float(b)) for a, b in self.plane]

    def _lowest(self, feet: np.ndarray) -> np.ndarray:
        """Each sole's lowest edge (..., 2): its toe on a heel raised (pitched) sole."""
        pitch = feet[..., 4] if feet.shape[-1] > 4 else np.zeros(feet.shape[:-1])
        return np.asarray(feet[..., 2] - self.model.foot_length_m / 2 * np.abs(np.sin(pitch)))

    def _knot(self, t: float) -> tuple[int, float, int]:
        """The knot interval ``t`` [s] falls in, the weight of its end (clamped to the entry) and the
        last knot at or before ``t``."""
        times = self._times
        after = bisect.bisect_right(times, t) - 1
        k = min(max(after, 0), len(times) - 2)
        span = times[k + 1] - times[k]
        w = min(max((t - times[k]) / span, 0.0), 1.0) if span > 0.0 else 1.0
        return k, w, min(max(after, 0), len(times) - 1)

    def sample(self, t: float) -> ReferenceSample:
        """The reference at ``t`` [s]; from the end on, the static hold of the last knot: no motion,
        the ZMP under the COM (a plan's last knots may still have it elsewhere). A ValueError for
        a ``t`` that is not one finite real number."""
        if not real(t):
            raise ValueError(f"sample(t): t must be a finite time in seconds, got {t!r}")
        k, w, last = self._knot(t)
        x = (1 - w) * self._knots[k] + w * self._knots[k + 1]
        q, base, feet, com, com_vel, com_acc, zmp, sole_vel = map(x.__getitem__, self._slices)
        feet = feet.reshape(2, self._width)
        m = self.model
        still = t >= self.duration_s
        plane = self.plane[last]
        support = self._lowest(feet) - plane < GROUND_M
        on = (bool(support[0]), bool(support[1]))
        levels = self._planes[last]
        quat = base[3:7]
        return ReferenceSample(q=q, base_pos=base[0:3], base_quat_xyzw=quat / math.sqrt(quat.dot(quat)),
            soles=feet[:, 0:3], sole_yaw=feet[:, 3], support=support,
            com=com, com_vel=np.zeros(3) if still else com_vel,
            com_acc=np.zeros(3) if still else com_acc,
            zmp=self.com[-1, 0:2].copy() if still else zmp, gravity=m.gravity_mps2,
            sole_size=(m.foot_length_m, m.foot_width_m), ground_z=_ground(on, levels),
            sole_pitch=feet[:, 4].copy() if feet.shape[1] > 4 else np.zeros(2),
            sole_vel=np.zeros((2, 3)) if still else sole_vel.reshape(2, 3), sole_plane=plane.copy(),
            anchored=_ground_anchors(on, levels), hulls=self.hulls)


def _ground(on: tuple[bool, bool], levels: tuple[float, float]) -> float:
    """The support soles' plane: the mean of the surfaces under them (0: none supports)."""
    if on[0] and on[1]:
        return (levels[0] + levels[1]) / 2
    return levels[0] if on[0] else levels[1] if on[1] else 0.0
