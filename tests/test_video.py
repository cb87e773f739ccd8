"""A video is written whole or not at all: when the encoder fails (a full device, ffmpeg stopping
part-way) the command says so, exits 2 and leaves no file, and an old video stays as it was. The
failures are made two ways: a file-size limit (RLIMIT_FSIZE) that the real ffmpeg runs into, and a
stand-in ffmpeg (``IMAGEIO_FFMPEG_EXE``) that reads part of the frames, writes a few bytes and
exits 1, as ffmpeg does on a full device."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import skatelib.sim  # noqa: F401  (before MuJoCo: with no display it renders through EGL)

from tests.helpers import CLI

pytest.importorskip("imageio_ffmpeg")
REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"

# Encodes 30 random 640 x 360 frames to argv[1], under a file-size limit when argv[2] == "limit".
WRITER = textwrap.dedent("""
    import resource, signal, sys
    from pathlib import Path
    import numpy as np
    from skatelib.library.errors import OutputError
    from skatelib.sim.video import write_video
    frames = [np.random.default_rng(i).integers(0, 255, (360, 640, 3), dtype=np.uint8) for i in range(30)]
    if sys.argv[2] == "limit":
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))
    try:
        write_video(frames, Path(sys.argv[1]), 30.0)
    except OutputError as e:
        print(e)
        sys.exit(2)
""")


def _fake_ffmpeg(folder: Path) -> Path:
    """An 'ffmpeg' that reads 1 MB of frames, leaves 7 bytes in its output file and fails."""
    exe = folder / "ffmpeg"
    exe.write_text("#!/bin/sh\nfor a in \"$@\"; do out=\"$a\"; done\nhead -c 1000000 >/dev/null\n"
                   "printf partial > \"$out\"\necho 'av_interleaved_write_frame(): No space left on device' >&2\n"
                   "exit 1\n")
    exe.chmod(0o755)
    return exe


def _write(out: Path, limited: bool, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", WRITER, str(out), "limit" if limited else "room"],
                          capture_output=True, text=True, timeout=120, env={**os.environ, **(env or {})})


@pytest.mark.parametrize("name", ["run.mp4", "run.gif"])
@pytest.mark.slow
def test_a_video_that_does_not_fit_is_not_left(tmp_path, name):
    """The real encoders against a 20 kB file-size limit: OutputError naming the video, no file and
    no temporary; an old video of that name is untouched. Negative control: with room it is written."""
    out = tmp_path / name
    r = _write(out, limited=True)
    assert r.returncode == 2 and str(out) in r.stdout, r.stdout + r.stderr
    assert list(tmp_path.iterdir()) == []
    out.write_bytes(b"old video")
    assert _write(out, limited=True).returncode == 2
    assert out.read_bytes() == b"old video" and list(tmp_path.iterdir()) == [out]
    r = _write(out, limited=False)
    assert r.returncode == 0, r.stdout + r.stderr
    assert out.stat().st_size > 20_000 and list(tmp_path.iterdir()) == [out]


def test_an_encoder_that_fails_part_way_leaves_nothing(tmp_path):
    """ffmpeg exiting 1 after part of the frames: the error carries its last words, no file is left."""
    out = tmp_path / "out" / "run.mp4"
    r = _write(out, limited=False, env={"IMAGEIO_FFMPEG_EXE": str(_fake_ffmpeg(tmp_path))})
    assert r.returncode == 2, r.stdout + r.stderr
    assert "ffmpeg" in r.stdout and "No space left on device" in r.stdout
    assert list(out.parent.iterdir()) == []


@pytest.mark.slow
def test_track_says_the_video_failed_and_exits_2(tmp_path):
    """`track --plant mujoco --video` with a failing encoder: exit 2, one message naming the video
    and the encoder, no traceback, no 'wrote', no file (the old code printed 'wrote run.mp4' over a
    truncated file)."""
    pytest.importorskip("mujoco")
    out = tmp_path / "run.mp4"
    r = subprocess.run([*CLI, "track", str(REFERENCE), "--plant", "mujoco", "-e", "v0.30_s1", "--video", str(out),
                        "--no-progress", "-j", "1"], capture_output=True, text=True, timeout=600,
                       env={**os.environ, "IMAGEIO_FFMPEG_EXE": str(_fake_ffmpeg(tmp_path)), "COLUMNS": "200"})
    assert r.returncode == 2, r.stdout + r.stderr
    assert str(out) in r.stderr and "video encoder" in r.stderr and "Traceback" not in r.stderr
    assert "wrote" not in r.stdout and not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ffmpeg"]


def _footage(frames: int):
    """A few frames of the tiny library's twin rolling forward, the ghost 0.2 m ahead, a caption
    each and a verdict."""
    from skatelib.runtime import MotionLibrary
    from skatelib.sim.figures import TwinFigures
    from skatelib.sim.overlay import Caption
    from skatelib.sim.plant import TwinPlant
    from skatelib.sim.video import Footage

    m = TwinPlant(TwinFigures.from_library(MotionLibrary.open(REFERENCE))).m
    qpos = np.tile(np.array(m.key("stance").qpos), (frames, 1))
    for joint in ("trunk_free", "deck_free"):
        qpos[:, m.joint(joint).qposadr[0]] += 0.02 * np.arange(frames)
    ghost = qpos.copy()
    for joint in ("trunk_free", "deck_free"):
        ghost[:, m.joint(joint).qposadr[0]] += 0.2
    captions = tuple(Caption((f"t = {k / 30:.2f} s",)) for k in range(frames))
    return m, Footage(qpos, 30.0, captions, ghost, Caption(("end",), "PASS: as planned", True), hold_s=1.0)


@pytest.mark.parametrize(("name", "size", "frames"), [("run.mp4", (1280, 720), 4 + 30), ("run.gif", (640, 360), 2 + 1)])
def test_a_run_is_filmed_at_its_size(tmp_path, name, size, frames):
    """A run of 4 frames read back: the MP4 (imageio-ffmpeg) 1280 x 720 with every frame and the
    verdict held 1 s at 30 fps; the GIF (pillow) 640 x 360 with every second frame and the verdict
    as one frame shown 1 s."""
    pytest.importorskip("mujoco")
    from PIL import Image
    from skatelib.sim.video import write_run

    m, footage = _footage(4)
    out = write_run(m, footage, tmp_path / name)
    if name.endswith(".gif"):
        gif = Image.open(out)
        assert gif.size == size and gif.n_frames == frames
        gif.seek(frames - 1)
        assert gif.info["duration"] == pytest.approx(1000, abs=70)
        return
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(out))
    assert tuple(next(reader)["size"]) == size and sum(1 for _ in reader) == frames
