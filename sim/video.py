"""A run on the twin as a video: frames rendered offscreen (:mod:`skatelib.sim.render`: the
camera following from the side, the plan's pose as a ghost) with a caption drawn on each
(:mod:`skatelib.sim.overlay`), written as an MP4 (``imageio-ffmpeg``) at 1280 x 720 and every
frame, or an animated GIF (``pillow``, for a README) at 640 x 360 and every second frame: extra
``[video]``. The last frame is held with the verdict."""

from __future__ import annotations

import os
import signal
import subprocess
import tempfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace
from fractions import Fraction
from pathlib import Path
from typing import IO, TYPE_CHECKING, cast

import numpy as np
from skatelib.library.errors import OutputError
from skatelib.sim.overlay import Caption, draw_caption
from skatelib.sim.render import View, render_frames

if TYPE_CHECKING:  # mujoco is imported where the twin is built (the [sim] extra)
    import mujoco

FORMATS = (".mp4", ".gif")
CRF = 25  # x264's quality, as imageio-ffmpeg's default quality 5 sets it (0 lossless .. 51 worst)
MP4_VIEW = View(1280, 720)
GIF_VIEW = View(640, 360)
GIF_STRIDE = 2  # a GIF shows every second frame: a README's file stays a few MB


@dataclass(frozen=True)
class Footage:
    """A run to film: configurations (N, nq) at ``fps``, the plan's at the same times (the ghost;
    None for none), a caption per frame; the last frame held ``hold_s`` [s] with ``ending``;
    ``camera``: the camera's settings (None: the quadruped's; the frame size is the format's)."""

    qpos: np.ndarray
    fps: float
    captions: tuple[Caption, ...]
    ghost: np.ndarray | None = None
    ending: Caption | None = None
    hold_s: float = 3.0
    camera: View | None = None


def write_video(frames: Iterable[np.ndarray], out: Path, fps: float) -> Path:
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


def encode_mp4(frames: Iterable[np.ndarray], path: Path, fps: float, named: Path) -> None:
    """H.264 in MP4 by imageio-ffmpeg's ffmpeg, the command ``imageio_ffmpeg.write_frames`` runs
    (whose writer never looks at ffmpeg's exit status: on a full device it left a truncated file).

    Raises:
        OutputError: ffmpeg stopped early or exited with an error (naming ``named``, the video).
    """
    import imageio_ffmpeg

    frames = iter(frames)
    first = next(frames)
    h, w = first.shape[:2]
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-f", "rawvideo", "-vcodec", "rawvideo", "-s", f"{w}x{h}",
           "-pix_fmt", "rgb24", "-r", str(Fraction(fps).limit_denominator()), "-i", "-", "-an",
           "-vcodec", "libx264", "-pix_fmt", "yuv420p", "-crf", str(CRF), "-v", "error", "-f", "mp4", str(path)]
    with tempfile.TemporaryFile() as log:
        p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=log, bufsize=0)
        try:
            _feed(cast("IO[bytes]", p.stdin), _chain(first, frames))
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


def _chain(first: np.ndarray, rest: Iterator[np.ndarray]) -> Iterator[np.ndarray]:
    yield first
    yield from rest


def _feed(stdin: IO[bytes], frames: Iterable[np.ndarray]) -> None:
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


def write_run(m: mujoco.MjModel, footage: Footage, out: Path) -> Path:
    """``footage`` of the twin ``m`` as ``out``: an MP4 at :data:`MP4_VIEW` and every frame, a GIF
    at :data:`GIF_VIEW` and every :data:`GIF_STRIDE`-th frame."""
    gif = out.suffix.lower() == ".gif"
    view, stride = (GIF_VIEW, GIF_STRIDE) if gif else (MP4_VIEW, 1)
    if footage.camera is not None:
        view = replace(footage.camera, width=view.width, height=view.height)
    return write_video(film(m, footage, view, stride), out, footage.fps / stride)


def film(m: mujoco.MjModel, footage: Footage, view: View, stride: int = 1) -> Iterator[np.ndarray]:
    """The captioned frames of ``footage`` (every ``stride``-th), then the last one held."""
    fps = footage.fps / stride
    ghost = None if footage.ghost is None else footage.ghost[::stride]
    raw = None
    captions = footage.captions[::stride]
    for raw, caption in zip(render_frames(m, footage.qpos[::stride], view, fps, ghost), captions, strict=True):
        yield draw_caption(raw, caption)
    if raw is not None and footage.ending is not None:
        held = draw_caption(raw, footage.ending)
        for _ in range(round(footage.hold_s * fps)):
            yield held
