"""A chained ride in closed loop: stages such as 0 -> 0.5 -> 0.8 -> 0.3 -> 0 m/s, each ridden by the
library's entries (``MotionLibrary.route``: one entry when one gets there), joined end to start into
one reference and driven through the closed loop of :mod:`skatelib.proving.closed_loop` as one
entry (on the twin: ``skatelib.proving.twin.ride``, the same joined entry through the twin's
loop). Between stages the robot rides on three feet with the push foot lifted beside the deck (the
next entry starts where the last one ends: the riding stance of ``[terminal]``); after the last
stage come the transfer of the push leg onto the deck and four-leg riding, as after any entry.

Each stage is judged at its end by the plant's momentum speed (robot and board together) against
its target: within 5 %, a stop below 0.05 m/s; the whole ride by the entry verdict
(:mod:`skatelib.proving.verdict`: no fall, no slip, torques and reach).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from skatelib.control.reference import STAGE_ENDS
from skatelib.library import schema
from skatelib.proving.closed_loop import run_entry
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.verdict import TrackResult, speed_verdict
from skatelib.runtime import Entry, MotionLibrary

if TYPE_CHECKING:  # the twin's verdict (a ride on the twin: proving.twin.ride); no import at run time
    from skatelib.proving.twin.verdict import TwinResult


def parse_ride(text: str) -> list[tuple[float, float]]:
    """``"0:0.5,0.5:0.8,0.8:0"`` as stages [(0, 0.5), (0.5, 0.8), (0.8, 0)] [m/s].

    Raises:
        ValueError: A stage that is not FROM:TO, a negative or repeated speed, or a stage that does
            not start where the one before ends.
    """
    stages: list[tuple[float, float]] = []
    for part in text.split(","):
        try:
            a, b = (float(x) for x in part.split(":"))
        except ValueError:
            raise ValueError(f"--ride {text!r}: stage {part!r} is not FROM:TO in m/s (e.g. 0:0.5,0.5:0)") from None
        if a < 0 or b < 0 or a == b or not (np.isfinite(a) and np.isfinite(b)):
            raise ValueError(f"--ride {text!r}: stage {part!r} needs two different speeds of at least 0 m/s")
        if stages and abs(stages[-1][1] - a) > 1e-9:
            raise ValueError(f"--ride {text!r}: stage {part!r} starts at {a} m/s, the one before ends at "
                             f"{stages[-1][1]} m/s")
        stages.append((a, b))
    return stages


def _rot(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s], [s, c]])


def _moved(e: Entry, anchor: np.ndarray, yaw: float, t0: float) -> dict[str, np.ndarray]:
    """``e``'s arrays turned by ``yaw`` about its first board position, moved there to ``anchor`` and
    in time to start at ``t0``."""
    R, origin = _rot(yaw), np.asarray(e.board_pos)[0, 0:2]

    def place(xy: np.ndarray) -> np.ndarray:
        return anchor + (xy - origin) @ R.T

    state = np.array(e.state, dtype=np.float64)
    state[:, 0:2] = place(state[:, 0:2])
    state[:, 5] += yaw
    state[:, 6:8] = state[:, 6:8] @ R.T
    state[:, 24:26] = state[:, 24:26] @ R.T
    control = np.array(e.control, dtype=np.float64)
    forces = control[:, :12].reshape(len(control), 4, 3)
    forces[:, :, 0:2] = forces[:, :, 0:2] @ R.T
    control[:, :12] = forces.reshape(len(control), 12)
    feet = np.array(e.foot_pos, dtype=np.float64)
    feet[:, :, 0:2] = place(feet[:, :, 0:2])
    board = np.array(e.board_pos, dtype=np.float64)
    board[:, 0:2] = place(board[:, 0:2])
    board[:, 3] += yaw
    t = np.asarray(e.t, dtype=np.float64) - float(e.t[0]) + t0
    return {schema.D_T: t, schema.D_STATE: state, schema.D_CONTROL: control,
            schema.D_CONTACT: np.asarray(e.contact), schema.D_FOOT_POS: feet, schema.D_BOARD_POS: board}


def chain(entries: list[Entry], key: str) -> tuple[Entry, list[float]]:
    """One entry that rides ``entries`` back to back (each turned and moved to start where the one
    before ends; the joint knot is the earlier entry's last), and the times the entries end [s]."""
    parts = [_moved(entries[0], np.asarray(entries[0].board_pos)[0, 0:2], 0.0, float(entries[0].t[0]))]
    for e in entries[1:]:
        last = parts[-1]
        yaw = float(last[schema.D_BOARD_POS][-1, 3] - np.asarray(e.board_pos)[0, 3])
        parts.append(_moved(e, last[schema.D_BOARD_POS][-1, 0:2], yaw, float(last[schema.D_T][-1])))
    ends = [float(p[schema.D_T][-1]) for p in parts]
    arrays = {name: np.concatenate([parts[0][name]] + [p[name][1:] for p in parts[1:]])
              for name in (schema.D_T, schema.D_STATE, schema.D_CONTACT, schema.D_FOOT_POS, schema.D_BOARD_POS)}
    arrays[schema.D_CONTROL] = np.concatenate([p[schema.D_CONTROL] for p in parts])
    attrs = {schema.A_TARGET_VELOCITY: entries[-1].target_velocity_mps, schema.A_SUCCESS: True,
             schema.A_FROM_VELOCITY: entries[0].from_velocity_mps, STAGE_ENDS: np.array(ends),
             schema.A_N_STRIDES: sum(e.n_strides for e in entries),
             schema.A_STATUS: "a ride of " + " + ".join(e.key for e in entries)}
    return Entry(key, attrs, arrays, dict(entries[0].columns), dict(entries[0].units)), ends


@dataclass(frozen=True)
class RidePlan:
    """A ride's stages, the entries of each (a route), the joined entry and when each stage ends [s]."""

    key: str
    stages: tuple[tuple[float, float], ...]
    routes: tuple[tuple[Entry, ...], ...]
    entry: Entry
    ends: tuple[float, ...]


def plan_ride(lib: MotionLibrary, stages: list[tuple[float, float]]) -> RidePlan:
    """The entries that ride ``stages`` (``MotionLibrary.route`` per stage), joined.

    Raises:
        EntryNotFound: A stage no chain of the library's entries rides (naming what can be reached).
    """
    routes = tuple(tuple(lib.route(a, b)) for a, b in stages)
    flat = [e for r in routes for e in r]
    key = "ride_" + "_".join(f"{v:g}" for v in [stages[0][0], *(b for _, b in stages)])
    joined, ends = chain(flat, key)
    stage_ends, i = [], 0
    for r in routes:
        i += len(r)
        stage_ends.append(ends[i - 1])
    return RidePlan(key, tuple(stages), routes, joined, tuple(stage_ends))


@dataclass(frozen=True)
class StageResult:
    """One stage of a ride: its entries, its target and the momentum speed at its end."""

    from_velocity_mps: float
    target_velocity_mps: float
    keys: tuple[str, ...]
    t_end_s: float
    momentum_at_end_mps: float
    passed: bool


@dataclass(frozen=True)
class RideResult:
    """A ride's stages and the whole run's verdict (the entry verdict of either plant, the last
    stage's speed); with ``keep_trace`` the run as an entry (for a recording) and the joined
    reference."""

    stages: tuple[StageResult, ...]
    run: TrackResult | TwinResult
    entry: Entry | None = None
    reference: Entry | None = None

    @property
    def passed(self) -> bool:
        return bool(self.run.passed) and all(s.passed for s in self.stages)


def stage_passed(target: float, speed: float) -> bool:
    """A stage's end speed against its target: within 5 %, or below 0.05 m/s for a stop."""
    return not speed_verdict(target, speed)[1]


def judge_stages(plan: RidePlan, speeds: list[float]) -> tuple[StageResult, ...]:
    """Each stage against its target at its end (``speeds``: the plant's momentum speed then; a
    run that stopped early has fewer, its missing stages fail)."""
    out = []
    for n, ((a, b), r, t_end) in enumerate(zip(plan.stages, plan.routes, plan.ends, strict=True)):
        v = speeds[n] if n < len(speeds) else float("nan")
        out.append(StageResult(a, b, tuple(e.key for e in r), t_end, v, stage_passed(b, v)))
    return tuple(out)


def ride(lib: MotionLibrary, stages: list[tuple[float, float]], loop: ClosedLoop, keep_trace: bool = False
         ) -> RideResult:
    """Ride ``stages`` in closed loop on the model plant (see the module docstring).

    Raises:
        EntryNotFound: A stage no chain of the library's entries rides (naming what can be reached).
    """
    plan = plan_ride(lib, stages)
    result, run = run_entry(lib, plan.entry, loop, keep_trace)
    kept = run.trace.as_entry(plan.key, stages[-1][1], loop.settings.plant_substeps) if run.trace is not None else None
    return RideResult(judge_stages(plan, run.stage_speeds_mps), result, kept, plan.entry)
