"""A run on the twin as a video: the plant's configurations at the MPC's rate (30 per second)
rendered offscreen by MuJoCo, a camera following the deck from the side and behind, written as
an MP4 (``imageio-ffmpeg``) or an animated GIF (``pillow``): extra ``[video]``.

Rendering needs an OpenGL context: with no display, ``MUJOCO_GL=egl`` renders through Mesa (the
package sets it, :mod:`skatelib.sim`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

FORMATS = (".mp4", ".gif")


def render_frames(m: Any, qpos: Sequence[np.ndarray], size: tuple[int, int] = (640, 360)) -> list[np.ndarray]:
    """One RGB frame per configuration, the camera 1.2 m from the deck, looking at it."""
    import mujoco

    d = mujoco.MjData(m)
    deck = m.body("deck").id
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.distance, cam.azimuth, cam.elevation = 1.2, -125.0, -20.0
    frames = []
    with mujoco.Renderer(m, size[1], size[0]) as r:
        for q in qpos:
            d.qpos[:] = q
            mujoco.mj_forward(m, d)
            cam.lookat[:] = d.xpos[deck] + np.array([0.0, 0.0, 0.1])
            r.update_scene(d, cam)
            frames.append(r.render().copy())
    return frames


def write_video(frames: Sequence[np.ndarray], out: Path, fps: float) -> Path:
    """Write ``frames`` to ``out`` (.mp4 or .gif) through a temporary file moved into place."""
    from skatelib.library.atomic import atomic_path

    suffix = out.suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(f"{out}: a video is {' or '.join(FORMATS)}")
    with atomic_path(out) as tmp:
        if suffix == ".gif":
            from PIL import Image

            images = [Image.fromarray(f) for f in frames]
            images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:],
                           duration=round(1000 / fps), loop=0)
        else:
            import imageio_ffmpeg

            h, w = frames[0].shape[:2]
            writer = imageio_ffmpeg.write_frames(str(tmp), (w, h), fps=fps, codec="libx264", macro_block_size=8,
                                                 output_params=["-f", "mp4"])
            writer.send(None)
            for f in frames:
                writer.send(np.ascontiguousarray(f))
            writer.close()
    return out


def write_run(m: Any, qpos: Sequence[np.ndarray], out: Path, fps: float) -> Path:
    """A run's configurations (at ``fps``) as ``out``: an MP4 at 640 x 360 and every frame, a GIF
    (for a README) at 320 x 180 and every second frame."""
    if out.suffix.lower() == ".gif":
        return write_video(render_frames(m, qpos[::2], (320, 180)), out, fps / 2)
    return write_video(render_frames(m, qpos), out, fps)
