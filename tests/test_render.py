"""The twin's frames: the plan's ghost is drawn where the plan's robot is (a pixel test against a
projection of the ghost's trunk computed here from the camera's figures), and the camera follows
the trunk's path smoothly."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import skatelib.sim  # noqa: F401  (before MuJoCo: with no display it renders through EGL)

pytest.importorskip("mujoco")

from skatelib.runtime import MotionLibrary
from skatelib.sim.figures import TwinFigures
from skatelib.sim.plant import TwinPlant
from skatelib.sim.render import View, follow, render_frames

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"
VIEW = View(640, 360)


@pytest.fixture(scope="module")
def twin():
    return TwinPlant(TwinFigures.from_library(MotionLibrary.open(REFERENCE))).m


def _shifted(m, qpos: np.ndarray, dx: float) -> np.ndarray:
    """``qpos`` with robot and board moved ``dx`` [m] along x."""
    out = qpos.copy()
    for joint in ("trunk_free", "deck_free"):
        out[m.joint(joint).qposadr[0]] += dx
    return out


def _pixel(m, point: np.ndarray, lookat: np.ndarray, view: View) -> np.ndarray:
    """Where ``point`` appears in a frame of ``view`` looking at ``lookat``: a pinhole camera with
    MuJoCo's free-camera convention (looking along azimuth/elevation, z up) and the model's fovy."""
    az, el = np.radians(view.azimuth_deg), np.radians(view.elevation_deg)
    forward = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    eye = lookat - view.distance_m * forward
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    rel = point - eye
    f = 0.5 * view.height / np.tan(np.radians(m.vis.global_.fovy) / 2)
    depth = rel @ forward
    return np.array([view.width / 2 + f * (rel @ right) / depth, view.height / 2 - f * (rel @ up) / depth])


def _window(mask: np.ndarray, centre: np.ndarray, half: int = 20) -> float:
    """The share of ``mask`` set in a square of ``half`` pixels around ``centre`` (x, y)."""
    x, y = np.round(centre).astype(int)
    return float(mask[max(y - half, 0):y + half, max(x - half, 0):x + half].mean())


def test_the_ghost_is_drawn_where_the_plan_is(twin):
    """A ghost 0.4 m ahead of the robot changes the pixels around its trunk's projection and not
    those around the robot's own trunk. Negative control: the ghost 0.4 m behind leaves the spot
    ahead untouched, so the check looks at where the ghost is, not only whether something changed."""
    import mujoco

    m = twin
    start = np.array(m.key("stance").qpos)
    d = mujoco.MjData(m)
    d.qpos[:] = start
    mujoco.mj_kinematics(m, d)
    trunk = d.xpos[m.body("trunk").id].copy()
    lookat = np.r_[trunk[:2], d.xpos[m.body("deck").id][2] + VIEW.height_m]
    plain = next(render_frames(m, [start], VIEW, 30.0)).astype(int)
    ahead, behind = (next(render_frames(m, [start], VIEW, 30.0, ghost=[_shifted(m, start, dx)])).astype(int)
                     for dx in (0.4, -0.4))
    changed = np.abs(ahead - plain).sum(axis=2) > 30
    spot_ahead = _pixel(m, trunk + np.array([0.4, 0.0, 0.0]), lookat, VIEW)
    assert _window(changed, spot_ahead) > 0.3
    assert _window(changed, _pixel(m, trunk, lookat, VIEW)) < 0.05
    changed_behind = np.abs(behind - plain).sum(axis=2) > 30
    assert _window(changed_behind, spot_ahead) < 0.05 and changed_behind.mean() > 0.005


def test_the_camera_follows_smoothly():
    """A path at constant speed (5 cm a frame at 30 fps) is kept to its ends (no lag: the robot
    stays centred); a 0.3 m jump becomes a ramp with no step above 1 cm. Negative control: the
    ends held instead of reflected would lag 0.3 m at the first frame."""
    line = np.column_stack([0.05 * np.arange(90), np.zeros(90)])
    assert np.allclose(follow(line, 30.0, 0.5), line, atol=1e-9)
    assert np.allclose(follow(line[:10], 30.0, 0.5), line[:10], atol=1e-9)  # shorter than the kernel
    jump = np.column_stack([np.r_[np.zeros(45), 0.3 * np.ones(45)], np.zeros(90)])
    steps = np.diff(follow(jump, 30.0, 0.5)[:, 0])
    assert steps.max() < 0.01 and np.isclose(steps.sum(), 0.3, atol=1e-3)
