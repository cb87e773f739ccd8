"""Entries ridden in full physics: the MPC over the whole-body controller on the MuJoCo twin
(``skatelib track --plant mujoco``), with a negative control for each thing the verdict and the
controller guard: friction rows, the plan's support margin, the steering model."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
from pathlib import Path

import pytest

pytest.importorskip("mujoco")
pytest.importorskip("daqp")

from skatelib.control.params import SkateParams
from skatelib.control.steering import SteeringGains
from skatelib.control.wbc_settings import WbcSettings
from skatelib.library import schema
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.twin.loop import TwinLoop, TwinLoopSettings
from skatelib.proving.twin.verdict import HEADING_LIMIT_RAD, SLIP_LIMIT_M, twin_result
from skatelib.runtime import MotionLibrary
from skatelib.sim.errors import DEFAULT_TWIN_PERTURBATION, parse_twin_perturbation
from skatelib.sim.figures import TwinFigures
from skatelib.sim.plant import TwinPlant

from tests.helpers import CLI, TINY, interpreted_tiny

pytestmark = pytest.mark.slow  # make test-fast leaves this module out


def _solve(tmp: Path, cache: Path, name: str, velocity: float, strides: int, extra: str = "") -> Path:
    cfg = interpreted_tiny(tmp / f"{name}.toml", extra) if extra else TINY  # another model: interpreted
    out = tmp / f"{name}.h5"
    env = {**os.environ, "COLUMNS": "200", "SKATELIB_CACHE_DIR": str(cache)}
    r = subprocess.run([*CLI, "solve", "--config", str(cfg), "--velocity", str(velocity), "--strides", str(strides),
                        "-o", str(out)], capture_output=True, text=True, env=env, timeout=900)
    assert r.returncode == 0, r.stdout + r.stderr
    return out


@pytest.fixture(scope="module")
def libs(tmp_path_factory, tiny_v04):
    tmp, cache = tmp_path_factory.mktemp("twin"), tmp_path_factory.mktemp("cache")
    return {
        "one": tiny_v04.path,  # the tiny config's 0.4 m/s one-stride start-up (the session's)
        "margin": _solve(tmp, cache, "margin", 0.7, 2),
        "edge": _solve(tmp, cache, "edge", 0.7, 2,
                       "[contact]\nmin_deck_load_fraction = 0.0\n[stance]\nride_load_fraction = 0.0\n"),
        # The public truck's pivot (1.1904 rad from the ground) read as the angle from the vertical,
        # as configs once were: the plan steers with K_board = 0.613 m, the truck with 0.098 m.
        "old_steering": _solve(tmp, cache, "old", 0.5, 3, "[board]\npivot_from_horizontal_rad = 0.3804\n"),
    }


def _ride(path: Path, perturb: str = "", wbc: WbcSettings | None = None, figures: TwinFigures | None = None,
          keeper: bool = True):
    lib = MotionLibrary.open(path)
    key = lib.keys()[0]
    p = SkateParams.from_library(lib)
    plant = TwinPlant(figures or TwinFigures.from_library(lib), parse_twin_perturbation(perturb, p.mu))
    settings = TwinLoopSettings(wbc=wbc or WbcSettings(), steering=SteeringGains() if keeper else None)
    run = TwinLoop(lib, key, ClosedLoop(p, p), plant, settings).ride()
    return twin_result(key, float(lib[key].attrs[schema.A_TARGET_VELOCITY]), run)


@pytest.fixture(scope="module")
def tracked(libs, tmp_path_factory):
    """`skatelib track ONE --plant mujoco --perturb none --video OUT.gif --save OUT.rrd`: the
    command's output, the GIF and the recording (one ride serves the table and the files)."""
    d = tmp_path_factory.mktemp("tracked")
    gif, rrd = d / "run.gif", d / "run.rrd"
    r = subprocess.run([*CLI, "track", str(libs["one"]), "--plant", "mujoco", "--perturb", "none", "--jobs", "1",
                        "--video", str(gif), "--save", str(rrd)], capture_output=True, text=True,
                       env={**os.environ, "COLUMNS": "250"}, timeout=600)
    return r, gif, rrd


def test_track_plant_mujoco_rides_an_entry(libs, tracked):
    """`skatelib track --plant mujoco` rides an entry, the transfer and the ride in physics and
    passes; a two-stride entry passes with the default model errors too (robot 10 % heavier, floor
    mu 0.5, trucks 20 % softer, rolling resistance doubled): speed within 5 %, no fall, slip under
    1 cm per stance, no unplanned floor contact, no wheel off the floor, heading within 0.1 rad."""
    r, _, _ = tracked
    assert r.returncode == 0, r.stdout + r.stderr
    assert "v0.40_s1" in r.stdout and "pass" in r.stdout and "full physics" in r.stdout
    res = _ride(libs["margin"], DEFAULT_TWIN_PERTURBATION)
    assert res.passed, res.reasons
    assert abs(res.speed_error) < 0.05 and res.max_slip_m < SLIP_LIMIT_M and res.touchdowns >= 4
    assert res.floor_touch_ticks == 0 and res.wheel_lift_ticks == 0 and res.min_wheel_load_N > 1.0
    assert abs(res.heading_error_rad) < HEADING_LIMIT_RAD and not res.fall
    json.dumps(res.as_dict())


def test_a_wbc_without_friction_rows_slips(libs):
    """On a floor of mu 0.5 the whole-body QP's pyramid (the plan's mu 0.45) keeps every stance
    within a few millimetres; without those rows the push foot slides over a centimetre and the
    run fails."""
    held = _ride(libs["one"], "mu=0.5")
    assert held.max_slip_m < 0.006 and held.passed, held.reasons
    free = _ride(libs["one"], "mu=0.5", WbcSettings(friction_rows=False))
    assert free.max_slip_m > SLIP_LIMIT_M and not free.passed
    assert "slipped" in free.reasons


def test_a_plan_balanced_on_an_edge_tips_over(libs):
    """An entry planned without the deck support margin ends its push with the body on the line
    between two feet on the deck, the third nearly unloaded: the single rigid body holds it, the
    twin's swinging leg tips it during the transfer (over, or onto one side's wheels, lifting the
    other's for over a tenth of a second). The same entry planned with the margin (each deck foot
    at least 10 % of the weight) rides through."""
    edge = _ride(libs["edge"])
    assert not edge.passed, edge
    assert edge.fall or ("wheel left the floor" in edge.reasons and edge.wheel_lift_ticks > 50), edge
    margin = _ride(libs["margin"])
    assert margin.passed, margin.reasons


def test_a_plan_with_the_old_steering_model_drifts(libs):
    """Planned with the old reading of the truck's pivot (steering 6 times softer than the truck
    does) and ridden without the line keeper, the board's heading leaves the plan's by more than
    0.1 rad in physics; the line keeper halves that but cannot make the wrong plan ridable (the
    twin still refuses it); on trucks as planned the heading stays within 0.03 rad."""
    lib = MotionLibrary.open(libs["old_steering"])
    f = TwinFigures.from_library(lib)
    public_truck = dataclasses.replace(f, board=dataclasses.replace(f.board, pivot_from_horizontal_rad=1.1904))
    drift = _ride(libs["old_steering"], figures=public_truck, keeper=False)
    assert abs(drift.heading_error_rad) > HEADING_LIMIT_RAD and not drift.passed
    assert "heading" in drift.reasons
    kept = _ride(libs["old_steering"], figures=public_truck)
    assert abs(kept.heading_error_rad) < abs(drift.heading_error_rad) and not kept.passed, kept
    planned = _ride(libs["old_steering"])
    assert abs(planned.heading_error_rad) < 0.03, planned


def test_the_steering_maneuver_in_physics(libs):
    """The four-leg maneuver (deck roll on a 0.1 rad sine, 3 s period) on the twin at 0.5 m/s,
    shortened to 4.5 s: roll within 0.03 rad RMS, no foot off the deck, no wheel off the floor;
    On trucks half as stiff, the shift that follows the stiffness measured while rolling keeps the
    error to less than half of what the model's K_B throughout gives (which misses the bound by
    far, a foot leaving the deck)."""
    from skatelib.proving.twin.steer import SteerRun, steer_twin

    lib = MotionLibrary.open(libs["one"])
    p = SkateParams.from_library(lib)
    f = TwinFigures.from_library(lib)
    short = SteerRun(duration_s=4.5)
    r = steer_twin(lib, ClosedLoop(p, p), TwinPlant(f), 0.5, short)
    assert r.passed, r.reasons
    assert r.roll_rms_error_rad < 0.03 and r.unloaded_steps == 0 and r.min_normal_N > 0.0
    soft = parse_twin_perturbation("kb=-50%", p.mu)
    adapted = steer_twin(lib, ClosedLoop(p, p), TwinPlant(f, soft), 0.5, short)
    fixed = steer_twin(lib, ClosedLoop(p, p), TwinPlant(f, soft), 0.5, SteerRun(duration_s=4.5, adapt_stiffness=False))
    assert not fixed.passed and "deck roll error" in fixed.reasons
    assert adapted.roll_rms_error_rad < 0.5 * fixed.roll_rms_error_rad


def test_video_and_stored_verdicts(libs, tracked, tmp_path):
    """`track --plant mujoco --video OUT.gif --save OUT.rrd` renders the run (one frame per two MPC
    updates, then the verdict, one frame held 3 s) and records it beside the plan in Rerun;
    `validate --closed-loop --plant mujoco` stores the verdict in the file (checksum still valid);
    --video without the twin, or of an unknown format, is refused before any run."""
    from PIL import Image
    from skatelib.pipeline.build.preflight import is_rerun_recording

    env = {**os.environ, "COLUMNS": "250"}
    r, gif, rrd = tracked
    assert r.returncode == 0, r.stdout + r.stderr
    assert is_rerun_recording(rrd) and rrd.stat().st_size > 10_000
    lib = MotionLibrary.open(libs["one"])
    ref_duration = float(lib[lib.keys()[0]].t[-1]) + 0.4 + 1.5
    assert Image.open(gif).n_frames == pytest.approx(ref_duration * 30 / 2 + 1, abs=2)  # + the verdict, held 3 s
    for args, message in ((["--video", str(tmp_path / "a.gif")], "--plant mujoco"),
                          (["--plant", "mujoco", "--video", str(tmp_path / "a.avi")], ".mp4 or .gif")):
        bad = subprocess.run([*CLI, "track", str(libs["one"]), *args], capture_output=True, text=True, env=env,
                             timeout=300)
        assert bad.returncode != 0 and message in bad.stdout + bad.stderr, bad.stdout + bad.stderr
    copy = tmp_path / "one.h5"
    copy.write_bytes(libs["one"].read_bytes())
    r = subprocess.run([*CLI, "validate", str(copy), "--closed-loop", "--plant", "mujoco", "--perturb", "none"],
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    stored = MotionLibrary.open(copy)  # verifies the checksum
    verdict = json.loads(str(stored[stored.keys()[0]].attrs[schema.A_CLOSED_LOOP_TWIN]))
    assert verdict["passed"] and verdict["max_slip_m"] < SLIP_LIMIT_M


@pytest.fixture(scope="module")
def shove_lib(tmp_path_factory, cfg, system, shove_0p3):
    """The old terminal shove (only the board's final speed constrained, no riding end state; see
    tests/test_physics_checks.py) judged by the physics checks as a build judges it and written as a
    library."""
    from skatelib.pipeline.quadruped.checks.verify import judge
    from skatelib.pipeline.quadruped.entries import entry_from_result, write_quadruped_library

    judged, physics = judge(cfg, shove_0p3)
    out = tmp_path_factory.mktemp("shove") / "shove.h5"
    return write_quadruped_library(out, cfg, system, [entry_from_result(judged, physics=physics)], {})


def test_the_terminal_shove_fails_in_physics(shove_lib):
    """The shove's board reaches the label and its robot does not; the physics checks refuse the
    entry, and ridden on the twin robot and board together are far from the label when the entry
    ends (and the robot falls after it): the run fails on its speed."""
    lib = MotionLibrary.open(shove_lib)
    assert not lib[lib.keys()[0]].success  # refused by the independent checks
    res = _ride(shove_lib)
    assert not res.passed and "delivered speed" in res.reasons, res
    assert res.momentum_at_end_mps < 0.95 * res.target_velocity_mps, res
