"""``skatelib track HUMANOID_LIB --plant mujoco --save OUT.rrd --video OUT.gif``: the recording read
back with rerun's own reader holds the twin beside the plan (the twin's ZMP and COM as the same
run made in-process has them, its board for a skate), and the video has the run's frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import skatelib.sim  # noqa: F401  (sets MUJOCO_GL before MuJoCo is first imported: other tests render)

from tests.helpers import run_cli

pytest.importorskip("mujoco")
pytest.importorskip("rerun")
pytest.importorskip("PIL")
KEY = "skate_v1.00"


@pytest.fixture(scope="module")
def skate(hrp2_skate_v100):
    """The shipped skate config's 1.0 m/s entry alone, as a library (tests/conftest.py)."""
    return hrp2_skate_v100


@pytest.fixture(scope="module")
def tracked(skate, tmp_path_factory):
    """The 1.0 m/s skate tracked as planned with a recording and a GIF."""
    d = tmp_path_factory.mktemp("outputs")
    rrd, gif = d / "run.rrd", d / "run.gif"
    r = run_cli(["track", str(skate), "--plant", "mujoco", "--perturb", "none", "--no-progress", "--save", str(rrd),
                 "--video", str(gif)], timeout=600)
    return r, rrd, gif


def _scalars(cols: dict, path: str) -> np.ndarray:
    return np.array([v[0] for v in cols[path]["Scalars:scalars"]])


@pytest.mark.slow
def test_the_recording_holds_the_twin_beside_the_plan(skate, tracked):
    """The twin's ZMP and COM height plots are the run's (made again here in-process: the same
    physics, the same figures), and differ from the plan's beside them; the twin's robot, soles,
    COM, ZMP and board are drawn."""
    from skatelib.proving.humanoid.loop import run_entry
    from skatelib.runtime import MotionLibrary

    from tests.test_inspect_rerun import _columns

    r, rrd, _ = tracked
    assert r.returncode == 0 and f"wrote {rrd}" in r.stdout.replace("\n", ""), r.stdout + r.stderr
    cols = _columns(rrd)
    twin, plan = f"/{KEY}/twin", f"/{KEY}/plan"
    for sub in ("com", "zmp", "right_sole", "left_sole", "board", "robot/waist_0", "plots/zmp_x", "plots/com_z",
                "plots/com_vx/board"):
        assert f"{twin}/{sub}" in cols, sorted(c for c in cols if c.startswith(twin))
    assert f"{plan}/plots/zmp_x" in cols and f"{plan}/robot/waist_0" in cols
    run = run_entry(MotionLibrary.open(skate), KEY)
    got = _scalars(cols, f"{twin}/plots/zmp_x")
    assert len(got) == len(run.t) and np.allclose(got, run.zmp[:, 0], atol=1e-9, equal_nan=True)
    assert np.allclose(_scalars(cols, f"{twin}/plots/com_z"), run.com[:, 2], atol=1e-9)
    planned = _scalars(cols, f"{plan}/plots/zmp_x")
    assert not np.allclose(np.interp(run.t, np.linspace(0, run.t[-1], len(planned)), planned), got, atol=1e-3)


@pytest.mark.slow
def test_the_video_has_the_runs_frames_and_its_verdict(tracked):
    """A GIF of one frame per 80 ms of the run (every second one of the 25 fps footage) and its last
    frame held 2 s with the verdict; a few MB; its first and last frames differ (the robot moved)."""
    from PIL import Image

    r, _, gif = tracked
    assert r.returncode == 0 and Path(gif).stat().st_size < 8e6
    with Image.open(gif) as im:
        n = im.n_frames
        first = np.asarray(im.convert("RGB"))
        im.seek(n - 1)
        last = np.asarray(im.convert("RGB"))
        held_ms = im.info["duration"]
    run_s = 5.0  # the skate's 4 s and the 1 s hold
    # pillow writes the held frames as one frame shown that long
    assert n == pytest.approx(run_s * 12.5 + 1, abs=2) and held_ms == pytest.approx(2000, abs=100)
    assert first.shape == (360, 640, 3) and np.abs(first.astype(int) - last.astype(int)).mean() > 1.0
