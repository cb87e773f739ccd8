"""A run on the twin as a video: the plant's configurations at the MPC's rate (30 per second)
rendered offscreen by MuJoCo, a camera following the deck from the side and behind, written as
an MP4 (``imageio-ffmpeg``) or an animated GIF (``pillow``): extra ``[video]``.

Rendering needs an OpenGL context: with no display, ``MUJOCO_GL=egl`` renders through Mesa (the
package sets it, :mod:`skatelib.sim`)."""

from __future__ import annotations

import os
import signal
import subprocess
import tempfile
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import IO, TYPE_CHECKING, cast

import numpy as np
from skatelib.library.errors import OutputError

if TYPE_CHECKING:  # mujoco is imported where the twin is built (the [sim] extra)
    import mujoco

FORMATS = (".mp4", ".gif")
CRF = 25  # x264's quality, as imageio-ffmpeg's default quality 5 sets it (0 lossless .. 51 worst)


def render_frames(m: mujoco.MjModel, qpos: Sequence[np.ndarray], size: tuple[int, int] = (640, 360)
                  ) -> list[np.ndarray]:
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
    """Write ``frames`` to ``out`` (.mp4 or .gif) through a temporary file in its folder, moved into
    place only when the encoder finished without error and the bytes are on the device.

    Raises:
        OutputError: The encoder failed (ffmpeg's exit status and last words) or the device had no
            room; nothing is left at ``out`` (an old file there is untouched).
    """
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
            encode_mp4(frames, tmp, fps, out)
        _settled(tmp, out)
    return out


def encode_mp4(frames: Sequence[np.ndarray], path: Path, fps: float, named: Path) -> None:
    """H.264 in MP4 by imageio-ffmpeg's ffmpeg, the command ``imageio_ffmpeg.write_frames`` runs
    (whose writer never looks at ffmpeg's exit status: on a full device it left a truncated file).

    Raises:
        OutputError: ffmpeg stopped early or exited with an error (naming ``named``, the video).
    """
    import imageio_ffmpeg

    h, w = frames[0].shape[:2]
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-f", "rawvideo", "-vcodec", "rawvideo", "-s", f"{w}x{h}",
           "-pix_fmt", "rgb24", "-r", str(Fraction(fps).limit_denominator()), "-i", "-", "-an",
           "-vcodec", "libx264", "-pix_fmt", "yuv420p", "-crf", str(CRF), "-v", "error", "-f", "mp4", str(path)]
    with tempfile.TemporaryFile() as log:
        p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=log, bufsize=0)
        try:
            _feed(cast("IO[bytes]", p.stdin), frames)
        except BaseException:
            p.kill()  # an interrupt: the file is not finished
            p.wait()
            raise
        status = p.wait()
        if status != 0:
            log.seek(0)
            words = log.read().decode(errors="replace").strip().splitlines()
            how = f"was stopped by {signal.Signals(-status).name}" if status < 0 else f"failed (exit status {status})"
            raise OutputError(named, f"the video encoder (ffmpeg) {how}{': ' + words[-1] if words else ''}; nothing "
                                     "was written and any old file is untouched")


def _feed(stdin: IO[bytes], frames: Sequence[np.ndarray]) -> None:
    """Write the frames to ffmpeg and close its input; a closed pipe is left to its exit status."""
    try:
        for f in frames:
            stdin.write(np.ascontiguousarray(f, dtype=np.uint8).tobytes())
    except BrokenPipeError:
        pass  # ffmpeg stopped reading: its exit status says why
    finally:
        stdin.close()


def _settled(path: Path, named: Path) -> None:
    """Flush ``path`` to the device (a full one may refuse the data only then) and refuse an empty
    file.

    Raises:
        OSError: The device refused the data.
        OutputError: The encoder wrote nothing (naming ``named``, the video).
    """
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
        empty = os.fstat(fd).st_size == 0
    finally:
        os.close(fd)
    if empty:
        raise OutputError(named, "the video encoder wrote an empty file; nothing was written")


def write_run(m: mujoco.MjModel, qpos: Sequence[np.ndarray], out: Path, fps: float) -> Path:
    """A run's configurations (at ``fps``) as ``out``: an MP4 at 640 x 360 and every frame, a GIF
    (for a README) at 320 x 180 and every second frame."""
    if out.suffix.lower() == ".gif":
        return write_video(render_frames(m, qpos[::2], (320, 180)), out, fps / 2)
    return write_video(render_frames(m, qpos), out, fps)
