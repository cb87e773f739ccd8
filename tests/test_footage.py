"""A twin run's footage: the ghost is the plan (its feet where the entry puts them, by MuJoCo's
kinematics of the ghost's configuration; after the entry riding on at the plan's last speed), the
speed on screen is the deck's forward speed, and ``track --video`` writes a 1280 x 720 MP4 whose
last frames show the verdict that the command printed."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
import skatelib.sim  # noqa: F401  (before MuJoCo: with no display it renders through EGL)

pytest.importorskip("mujoco")
pytest.importorskip("pinocchio")

from skatelib.control.params import SkateParams
from skatelib.proving.twin import footage
from skatelib.proving.twin.footage import board_speeds, plan_qpos
from skatelib.runtime import MotionLibrary
from skatelib.sim.figures import TwinFigures
from skatelib.sim.overlay import FAIL_RGBA, PASS_RGBA
from skatelib.sim.plant import TwinPlant
from skatelib.sim.robot import LEGS

from tests.helpers import CLI

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"
TRANSFER_S = 0.4


@pytest.fixture(scope="module")
def setup():
    lib = MotionLibrary.open(REFERENCE)
    body = (SkateParams.from_library(lib).com_offset_m, lib.quadruped_model.arrays.stance_q_board_rad, TRANSFER_S)
    return lib, TwinPlant(TwinFigures.from_library(lib)).m, body


def _feet(m, qpos: np.ndarray) -> np.ndarray:
    """(N, 4, 3) the foot spheres' centres by MuJoCo's kinematics."""
    import mujoco

    d, ids = mujoco.MjData(m), [m.geom(f"{leg}_foot").id for leg in LEGS]
    out = []
    for q in qpos:
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        out.append(d.geom_xpos[ids].copy())
    return np.array(out)


def _feet_error(lib, m, body) -> tuple[float, float]:
    """The ghost's feet against the entry's at its knots: worst horizontal error, worst error in
    the change of height from the first knot [m]."""
    e = lib["v0.40_s1"]
    ghost = _feet(m, plan_qpos(m, e, np.asarray(e.t), np.zeros(m.nq), body))
    planned = np.asarray(e.foot_pos)
    rise = (ghost[:, :, 2] - ghost[0, :, 2]) - (planned[:, :, 2] - planned[0, :, 2])
    return float(np.abs(ghost[:, :, :2] - planned[:, :, :2]).max()), float(np.abs(rise).max())


def test_the_ghost_puts_its_feet_where_the_plan_does(setup, monkeypatch):
    """At every knot of an entry the ghost's feet (MuJoCo's kinematics of its configuration) are
    within 3 mm of the entry's foot positions (heights up to the constant the twin's start sets).
    Negative control: the trunk's attitude turned the wrong way (the quaternion's conjugate)
    puts them centimetres off."""
    lib, m, body = setup
    across, rise = _feet_error(lib, m, body)
    assert across < 3e-3 and rise < 1e-3
    monkeypatch.setattr(footage, "quat_wxyz", _conjugate)
    assert max(_feet_error(lib, m, body)) > 1e-2


def _conjugate(R: np.ndarray) -> np.ndarray:
    from skatelib.control.feedback import quat_wxyz

    return np.r_[1, -1, -1, -1] * quat_wxyz(R)


def test_after_the_entry_the_plan_rides_on(setup):
    """After the entry's end the ghost's deck moves at the plan's last board speed and its legs
    reach the riding stance once the transfer is over."""
    lib, m, body = setup
    e = lib["v0.40_s1"]
    end = float(e.t[-1])
    times = end + np.arange(1, 40) / 30
    ghost = plan_qpos(m, e, times, np.zeros(m.nq), body)
    speeds = board_speeds(m, ghost, 1 / 30)
    assert np.allclose(speeds, np.linalg.norm(np.asarray(e.state)[-1, 24:26]), atol=1e-9)
    joints = [m.joint(n).qposadr[0] for n in ("FL_abad", "RR_knee")]
    assert np.allclose(ghost[-1, joints], np.asarray(body[1])[[0, 11]])


def test_the_speed_is_the_decks_forward_speed(setup):
    """A deck heading 0.3 rad moving 0.5 m/s along its heading reads 0.5 m/s; moving sideways, 0."""
    _, m, _ = setup
    a = m.joint("deck_free").qposadr[0]
    yaw, t = 0.3, np.arange(10) / 30
    for direction, expected in ((yaw, 0.5), (yaw + np.pi / 2, 0.0)):
        q = np.tile(np.array(m.key("stance").qpos), (10, 1))
        q[:, a] = 0.5 * t * np.cos(direction)
        q[:, a + 1] = 0.5 * t * np.sin(direction)
        q[:, a + 3:a + 7] = [np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]
        assert np.allclose(board_speeds(m, q, 1 / 30), expected, atol=1e-9)


@pytest.mark.slow  # a ride on the twin, rendered
def test_track_writes_a_720p_video_ending_on_its_verdict(tmp_path):
    """`track --plant mujoco --video run.mp4`: read back (imageio-ffmpeg), 1280 x 720, one frame
    per MPC update and 3 s held at the end; the held frame's bottom banner is in the colour of the
    verdict the command printed (exit 0: green, exit 1: red) and the frames before it have none."""
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    out = tmp_path / "run.mp4"
    r = subprocess.run([*CLI, "track", str(REFERENCE), "--plant", "mujoco", "-e", "v0.30_s1", "--perturb", "none",
                        "--video", str(out), "--no-progress", "-j", "1"], capture_output=True, text=True,
                       timeout=900, env={**os.environ, "COLUMNS": "200"})
    assert r.returncode in (0, 1), r.stdout + r.stderr
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = next(reader)
    assert tuple(meta["size"]) == (1280, 720)
    frames = [np.frombuffer(f, dtype=np.uint8).reshape(720, 1280, 3) for f in reader]
    e = MotionLibrary.open(REFERENCE)["v0.30_s1"]
    updates = round((float(e.t[-1]) - float(e.t[0]) + TRANSFER_S + 1.5) * 30)
    assert len(frames) == pytest.approx(updates + 90, abs=2)
    banner = np.median(frames[-1][-30:-15, 40:-40].reshape(-1, 3), axis=0)
    own, other = (PASS_RGBA, FAIL_RGBA) if r.returncode == 0 else (FAIL_RGBA, PASS_RGBA)
    assert np.linalg.norm(banner - own[:3]) < 60 < np.linalg.norm(banner - other[:3])
    before = np.median(frames[len(frames) - 95][-30:-15, 40:-40].reshape(-1, 3), axis=0)
    assert np.linalg.norm(before - own[:3]) > 60


def test_a_chained_rides_label_is_its_stages_target():
    """The label on screen follows a chained ride's stages (the ride's last target only after them);
    an entry's is its own label throughout."""
    from types import SimpleNamespace

    from skatelib.proving.twin.footage import _label

    result = SimpleNamespace(target_velocity_mps=0.0)
    stages = ((2.0, 0.5), (4.0, 0.8), (6.0, 0.3))
    assert [_label(t, result, stages) for t in (0.0, 2.0, 3.0, 5.9, 7.0)] == [0.5, 0.5, 0.8, 0.3, 0.0]
    assert _label(3.0, SimpleNamespace(target_velocity_mps=0.7), ()) == 0.7
