"""Closed loop: the MPC fed by ``skatelib.runtime`` drives the plant through one library entry,
then through the push leg's transfer back onto the deck and four-leg riding, and a verdict.

Timeline (Sec. IV-A): the entry's strides; then ``transfer_s`` with the push leg swinging back to
the deck (three legs on the board, its foot on a Bezier curve, which carries no force in the
single-rigid-body plant); then four-leg riding at the speed reached, ``ride_s`` long.

The parts, one module each (the paper's Fig. 3): the reference
(:mod:`skatelib.control.reference`), the observers (:mod:`skatelib.control.observers`), the MPC
problem (:mod:`skatelib.control.mpc`) and its QP backends (:mod:`skatelib.control.qp`), the loop
that ticks them against the plant (:mod:`skatelib.proving.loop`) and the verdict
(:mod:`skatelib.proving.verdict`).
"""

from __future__ import annotations

import numpy as np
from skatelib.control.kinematics import LegKinematics
from skatelib.control.reference import EntryReference
from skatelib.library.channels import NX
from skatelib.proving.loop import simulate
from skatelib.proving.plant import NB
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.trace import Run, Trace
from skatelib.proving.verdict import TrackResult, track_result
from skatelib.runtime import Entry, MotionLibrary


def track_entry(lib: MotionLibrary, key: str, loop: ClosedLoop, keep_trace: bool = False
                ) -> tuple[TrackResult, Trace | None]:
    """Run one entry in closed loop and judge it (:mod:`skatelib.proving.verdict`); with
    ``keep_trace`` the run's time series too."""
    result, run = run_entry(lib, lib[key], loop, keep_trace)
    return result, run.trace


def run_entry(lib: MotionLibrary, entry: Entry, loop: ClosedLoop, keep_trace: bool = False) -> tuple[TrackResult, Run]:
    """Run ``entry`` (of ``lib``, or one made of its entries: :mod:`skatelib.proving.ride`) in closed
    loop: its verdict and what the run measured."""
    key = entry.key
    ref = EntryReference(lib, entry, loop.model, loop.settings)
    x_init = np.zeros(NB)
    x_init[:NX] = np.asarray(entry.state[0], dtype=np.float64)
    x_init[NX:NX + 3] = ref.board_pos[0, 0:3]
    kin = LegKinematics.from_library(lib)
    run = simulate(ref, x_init, loop, keep_trace, kin)
    return track_result(key, entry.target_velocity_mps, run, loop.plant, kin.torque_limit_Nm), run
