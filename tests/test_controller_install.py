"""The controller a robot runs (skatelib.control) apart from its proving ground: a tick on a
library entry gives torques within the motors' limit and contact forces that carry the robot, and
the controller's extra installed alone into a fresh venv (no build, no twin, no viewer) runs it."""

from __future__ import annotations

import subprocess
import sys
import venv
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
LIBRARY = ROOT / "tests" / "data" / "tiny-reference.h5"
EXAMPLE = ROOT / "examples" / "controller_tick.py"
HARNESS = ("casadi", "mujoco", "typer", "joblib", "rerun", "skatelib.proving", "skatelib.pipeline", "skatelib.sim")


def test_a_tick_on_the_plan_carries_the_robot_within_the_torque_limit():
    """On the entry's first knot, standing on the deck: the whole-body QP's forces carry the robot's
    weight (the MPC asks for its planned acceleration besides: within 20 %), the torques stay
    inside the limit, and the MPC's state is the plan's."""
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

    lib = MotionLibrary.open(LIBRARY)
    entry = lib["v0.30_s1"]
    p = SkateParams.from_library(lib)
    ref = EntryReference(lib, entry, p, TrackSettings())
    kin = LegKinematics.from_library(lib)
    ctrl = SkateController(lib, ref, BodyPlan(ref, kin.foot_radius_m), p, MpcConfig(), WbcSettings(), Rates())
    tick = ctrl.tick(ref.t0, planned_state(entry, 0, p.com_offset_m), update=True)
    assert tick.x is not None and np.allclose(tick.x[12:24], entry.state[0][12:24])
    assert np.all(np.isfinite(tick.out.tau)) and np.max(np.abs(tick.out.tau)) <= kin.torque_limit_Nm + 1e-6
    weight = p.mass_kg * p.gravity_mps2
    assert 0.8 * weight < tick.out.forces.sum(axis=1)[2] < 1.2 * weight
    nxt = ctrl.tick(ref.t0 + Rates().tick_s, planned_state(entry, 0, p.com_offset_m))
    assert nxt.x is None and nxt.mpc_s is None  # between updates, the whole-body QP alone


def test_the_controller_imports_no_harness():
    """Imported and ticked in a fresh interpreter, the controller loads none of the build's, the
    twin's, the viewer's or the proving ground's modules."""
    code = (f"import runpy, sys; sys.argv = ['x', {str(LIBRARY)!r}, 'v0.30_s1']; "
            f"runpy.run_path({str(EXAMPLE)!r}, run_name='__main__'); "
            f"bad = sorted(m for m in sys.modules if m.startswith({HARNESS!r})); print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.mark.slow
def test_the_controller_extra_alone_runs_a_tick(tmp_path):
    """The wheel with the [control] extra into a fresh venv: the packages installed are the
    controller's and its solvers' alone (no casadi, mujoco, typer, rerun), and a tick runs, its
    whole-body targets and assembly in C (the source shipped in the wheel)."""
    dist = tmp_path / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", str(dist),
                    str(ROOT)], check=True, capture_output=True)
    (wheel,) = dist.glob("skatelib-*.whl")
    env_dir = tmp_path / "robot"
    venv.create(env_dir, with_pip=True)
    py = env_dir / "bin" / "python"
    r = subprocess.run([str(py), "-m", "pip", "install", "-q", f"{wheel}[control]"], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    listed = subprocess.run([str(py), "-m", "pip", "list", "--format=freeze"], capture_output=True, text=True,
                            check=True).stdout.lower()
    names = {line.split("==")[0].replace("_", "-") for line in listed.split()}
    assert "pin" in names and "daqp" in names
    # (joblib comes as OSQP's dependency, for its code generation; the controller does not import it)
    assert not names & {"casadi", "mujoco", "typer", "rerun-sdk", "rich", "dask", "distributed", "matplotlib"}, names
    out = subprocess.run([str(py), str(EXAMPLE), str(LIBRARY), "v0.30_s1"], capture_output=True, text=True,
                         cwd=tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "torques [N m]" in out.stdout
    assert "not available" not in out.stderr, out.stderr  # the whole-body tick's C code came with the wheel


@pytest.mark.parametrize("field", ["trunk_v", "q", "deck_R", "foot_touch", "contact_points"])
def test_a_bad_reading_is_refused_and_leaves_the_controller_as_it_was(field):
    """A NaN in any field of the state (an unknown touch code for the feet): the tick raises naming
    the field instead of commanding NaN torques, and the next good tick commands what it would
    have commanded had the bad one never come (the controller's state untouched)."""
    import dataclasses

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

    lib = MotionLibrary.open(LIBRARY)
    entry = lib["v0.30_s1"]
    p = SkateParams.from_library(lib)
    ref = EntryReference(lib, entry, p, TrackSettings())
    plan = BodyPlan(ref, LegKinematics.from_library(lib).foot_radius_m)
    good = planned_state(entry, 0, p.com_offset_m)
    ticks = []
    for bad_first in (False, True):
        ctrl = SkateController(lib, ref, plan, p, MpcConfig(), WbcSettings(), Rates())
        if bad_first:
            value = np.array(getattr(good, field), dtype=float)
            value.flat[0] = 7.0 if field == "foot_touch" else np.nan
            with pytest.raises(ValueError, match=f"state.{field}"):
                ctrl.tick(ref.t0, dataclasses.replace(good, **{field: value}), update=True)
        ticks.append(ctrl.tick(ref.t0, good, update=True))
    assert np.isfinite(ticks[1].out.tau).all()
    np.testing.assert_array_equal(ticks[1].out.tau, ticks[0].out.tau)


def test_settings_out_of_range_and_a_first_tick_without_the_mpc_are_refused():
    """MpcConfig and WbcSettings name a setting out of its range when made; a first tick that would
    aim at MPC forces not yet computed is refused."""
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

    for kw, name in (({"mu": 0.0}, "mu"), ({"facets": 3}, "facets"), ({"f_min_N": 500.0}, "f_min_N"),
                     ({"r_weights": (1.0,) * 23}, "r_weights"), ({"solver": "gurobi"}, "solver")):
        with pytest.raises(ValueError, match=rf"MpcConfig\({name}="):
            MpcConfig(**kw)
    for kw, name in (({"kp_com": float("nan")}, "kp_com"), ({"normal_min_N": 200.0}, "normal_min_N")):
        with pytest.raises(ValueError, match=rf"WbcSettings\({name}="):
            WbcSettings(**kw)
    lib = MotionLibrary.open(LIBRARY)
    entry = lib["v0.30_s1"]
    p = SkateParams.from_library(lib)
    ref = EntryReference(lib, entry, p, TrackSettings())
    ctrl = SkateController(lib, ref, BodyPlan(ref, LegKinematics.from_library(lib).foot_radius_m), p, MpcConfig(),
                           WbcSettings(), Rates())
    with pytest.raises(ValueError, match="update=True on the first tick"):
        ctrl.tick(ref.t0, planned_state(entry, 0, p.com_offset_m))


def test_a_library_of_another_kind_is_named_as_such(hrp2_walk_path):
    from skatelib.control.kinematics import LegKinematics
    from skatelib.control.multibody import RobotDynamics
    from skatelib.control.params import SkateParams
    from skatelib.library.errors import LibraryFormatError
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(hrp2_walk_path)
    for make in (LegKinematics.from_library, RobotDynamics.from_library, SkateParams.from_library):
        with pytest.raises(LibraryFormatError, match="a humanoid library has no quadruped model"):
            make(lib)


def test_the_humanoid_kinematics_name_what_a_robot_lacks():
    """A quadruped's URDF given to the humanoid stabilizer's kinematics: the missing soles, waist
    and ankle sensors named when it is made, not a pinocchio error at the first tick."""
    from skatelib.control.humanoid_kinematics import HumanoidKinematics
    from skatelib.runtime import MotionLibrary

    with pytest.raises(ValueError, match="has no R_sole, L_sole, waist"):
        HumanoidKinematics(MotionLibrary.open(LIBRARY).urdf, ())
