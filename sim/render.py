"""Frames of the twin rendered offscreen by MuJoCo: a camera that follows the robot from the side
(the trunk's path smoothed, never the deck's yaw, so the checkered floor moves past) and, when
given, a second configuration drawn into the same scene as a translucent ghost (the plan's pose:
``mjv_addGeoms`` adds the robot's and the board's geoms of a second ``MjData``, recoloured).

Rendering needs an OpenGL context: with no display, ``MUJOCO_GL=egl`` renders through Mesa (the
package sets it, :mod:`skatelib.sim`)."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # mujoco is imported where the twin is built (the [sim] extra)
    import mujoco

GHOST_RGBA = (0.35, 0.85, 1.0, 0.3)  # the plan's pose: cyan, 30 % opaque


@dataclass(frozen=True)
class View:
    """Frame size and the following camera.

    Attributes:
        width / height: Frame size [px] (at most :data:`skatelib.sim.scene.OFFSCREEN_SIZE`).
        distance_m: Camera to the point it looks at [m].
        azimuth_deg: Direction it looks in, from the world's x axis (90: from the robot's right
            side, square to a run along x) [deg].
        elevation_deg: Below the horizon [deg].
        smooth_s: Standard deviation of the Gaussian that smooths the trunk's path [s].
        height_m: Height of the point looked at above the deck's top (the floor without a board) [m].
        follow: The body whose path the camera follows (the quadruped's trunk, the humanoid's waist).
    """

    width: int = 1280
    height: int = 720
    distance_m: float = 1.5
    azimuth_deg: float = 72.0
    elevation_deg: float = -14.0
    smooth_s: float = 0.5
    height_m: float = 0.12
    follow: str = "trunk"


def follow(path: np.ndarray, fps: float, smooth_s: float) -> np.ndarray:
    """``path`` (N, 2) smoothed by a Gaussian of ``smooth_s`` [s] over frames at ``fps``: centred
    (no lag: the whole run is known before it is filmed), the ends extended by odd reflection so
    that a path at constant speed is kept as it is up to its ends."""
    path = np.asarray(path, dtype=np.float64)
    sigma = max(smooth_s * fps, 1e-9)
    half = min(int(np.ceil(3 * sigma)), len(path) - 1)
    k = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma) ** 2)
    k /= k.sum()
    padded = np.pad(path, ((half, half), (0, 0)), mode="reflect", reflect_type="odd")
    return np.column_stack([np.convolve(padded[:, i], k, mode="valid") for i in range(path.shape[1])])


def render_frames(m: mujoco.MjModel, qpos: np.ndarray | Sequence[np.ndarray], view: View, fps: float,
                  ghost: np.ndarray | Sequence[np.ndarray] | None = None) -> Iterator[np.ndarray]:
    """One RGB frame (height, width, 3) per configuration, with ``ghost[k]`` (a configuration of the
    same model) drawn translucent in frame k; the camera follows the trunk (:func:`follow`)."""
    import mujoco

    d = mujoco.MjData(m)
    trunk = m.body(view.follow).id
    deck = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "deck")  # -1: no board (a humanoid's walk)
    path = np.empty((len(qpos), 2))
    for k, q in enumerate(qpos):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        path[k] = d.xpos[trunk][:2]
    lookat = follow(path, fps, view.smooth_s)
    d.qpos[:] = qpos[0]
    mujoco.mj_kinematics(m, d)
    z = (float(d.xpos[deck][2]) if deck >= 0 else 0.0) + view.height_m
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.distance, cam.azimuth, cam.elevation = view.distance_m, view.azimuth_deg, view.elevation_deg
    plan = mujoco.MjData(m) if ghost is not None else None
    option, perturb = mujoco.MjvOption(), mujoco.MjvPerturb()
    with mujoco.Renderer(m, view.height, view.width) as r:
        for k, q in enumerate(qpos):
            d.qpos[:] = q
            mujoco.mj_forward(m, d)
            cam.lookat[:] = (*lookat[k], z)
            r.update_scene(d, cam)
            if plan is not None and ghost is not None:
                plan.qpos[:] = ghost[k]
                mujoco.mj_kinematics(m, plan)
                add_ghost(m, plan, r.scene, (option, perturb))
            yield r.render().copy()


def add_ghost(m: mujoco.MjModel, plan: mujoco.MjData, scene: mujoco.MjvScene,
              how: tuple[mujoco.MjvOption, mujoco.MjvPerturb], rgba: tuple[float, ...] = GHOST_RGBA) -> int:
    """Add the moving bodies' geoms (robot and board) of ``plan`` to ``scene`` in ``rgba``; returns
    how many were added."""
    import mujoco

    before = scene.ngeom
    mujoco.mjv_addGeoms(m, plan, how[0], how[1], mujoco.mjtCatBit.mjCAT_DYNAMIC, scene)
    for i in range(before, scene.ngeom):
        scene.geoms[i].rgba[:] = rgba
    return int(scene.ngeom - before)
