"""One tick of the robot side's controller on a library entry, with the controller's extra alone
(``pip install 'skatelib[control]'``: numpy, h5py, pinocchio, scipy and the QP solvers).

The state is the entry's first planned knot (as the robot's estimator would report it were the
robot exactly on the plan); on a robot, the estimator's state replaces it at every tick, and the
torques go to the motors. Usage: ``python examples/controller_tick.py LIBRARY [ENTRY]``.
"""

from __future__ import annotations

import sys

import numpy as np
from skatelib.control.body_plan import BodyPlan
from skatelib.control.controller import Rates, SkateController
from skatelib.control.feedback import planned_state
from skatelib.control.kinematics import LegKinematics
from skatelib.control.mpc import MpcConfig
from skatelib.control.params import SkateParams
from skatelib.control.reference import EntryReference
from skatelib.control.settings import TrackSettings
from skatelib.control.wbc_settings import WbcSettings
from skatelib.runtime import MotionLibrary


def main(path: str, key: str | None = None) -> None:
    lib = MotionLibrary.open(path)
    entry = lib[key] if key else lib.select(0.5, 2)
    model = SkateParams.from_library(lib)
    ref = EntryReference(lib, entry, model, TrackSettings())
    plan = BodyPlan(ref, LegKinematics.from_library(lib).foot_radius_m)
    ctrl = SkateController(lib, ref, plan, model, MpcConfig(), WbcSettings(), Rates())
    tick = ctrl.tick(ref.t0, planned_state(entry, 0, model.com_offset_m), update=True)
    np.set_printoptions(precision=3, suppress=True)
    print(f"{entry.key}: torques [N m] {tick.out.tau}")
    weight = model.mass_kg * model.gravity_mps2
    print(f"contact forces' sum [N] {tick.out.forces.sum(axis=1)} (robot's weight {weight:.1f} N)")


if __name__ == "__main__":
    main(*sys.argv[1:3])
