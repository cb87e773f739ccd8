"""Rerun inspection: the .rrd read back with rerun's own reader matches the library."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

rr = pytest.importorskip("rerun")
from rerun.chunk import RrdReader  # noqa: E402
from skatelib.pipeline.views.rerun_inspect import inspect_library  # noqa: E402
from skatelib.runtime import MotionLibrary  # noqa: E402


def _columns(rrd: Path) -> dict[str, dict[str, list]]:
    """entity path -> {column name: values}, concatenated over chunks, from rerun's reader."""
    out: dict[str, dict[str, list]] = {}
    import pyarrow as pa

    for chunk in RrdReader(str(rrd)).store().stream():
        rb = chunk.to_record_batch()
        dst = out.setdefault(chunk.entity_path, {})
        for field, col in zip(rb.schema, rb.columns, strict=True):
            if pa.types.is_duration(field.type):
                col = col.cast(pa.int64())  # nanoseconds
            dst.setdefault(field.name, []).extend(col.to_pylist())
    return out


@pytest.fixture(scope="module")
def quad_lib(tiny_build):
    return tiny_build.path


def test_quadruped_recording_has_robot_board_forces_and_plots(quad_lib, tmp_path):
    """Entity paths, time points and values of the board speed and a force arrow match the library."""
    out = tmp_path / "q.rrd"
    roots = inspect_library(quad_lib, None, out, spawn=False, overlay=False)
    lib = MotionLibrary.open(quad_lib)
    cols = _columns(out)
    e = lib["v0.30_s1"]
    root = "/v0.30_s1"
    assert root in roots
    for sub in ("board", "board/deck", "board/wheels", "board/trucks", "ground", "board_path", "foot_trails",
                "footholds", "robot/trunk_0", "forces/RL", "plots/board_speed/actual",
                "plots/board_speed/target",
                "plots/margins/friction_N", "plots/joints/q_FL_knee"):
        path = f"{root}/{sub}"
        assert path in cols, sorted(cols)
    speed = cols[f"{root}/plots/board_speed/actual"]
    assert len(speed["time"]) == len(e.t)
    got = np.array([v[0] for v in speed["Scalars:scalars"]])
    yaw = e.state[:, 5]
    assert np.allclose(got, np.cos(yaw) * e.state[:, 24] + np.sin(yaw) * e.state[:, 25], atol=1e-12)
    arrows = cols[f"{root}/forces/RL"]
    assert len(arrows["time"]) == len(e.t) - 1
    vec = np.array([v[0] for v in arrows["Arrows3D:vectors"]])
    assert np.allclose(vec[3], e.control[3, 6:9] * 0.004, atol=1e-6)
    margins = np.array([v[0] for v in cols[f"{root}/plots/margins/friction_N"]["Scalars:scalars"]])
    assert margins.min() >= -1e-4  # the friction cones hold on the logged data
    # the entry's tab says which entry it is and how it did
    summary = cols[f"{root}/summary"]["TextDocument:text"][0][0]
    momentum = json.loads(e.attrs["physics_json"])["momentum_speed_mps"]
    assert summary.startswith("**v0.30_s1**: 0.30 m/s x 1") and f"rides at {momentum:.3f} m/s" in summary
    # every series names itself, with its unit, in the legend
    names = {sub: cols[f"{root}/plots/{sub}"]["SeriesLines:names"][0][0]
             for sub in ("board_roll", "joints/q_FL_knee", "normal_force/RL")}
    assert names == {"board_roll": "deck roll [rad]", "joints/q_FL_knee": "FL knee [rad]",
                     "normal_force/RL": "RL normal force [N]"}


def test_humanoid_recording_has_com_zmp_and_soles(hrp2_skate_build, tmp_path):
    """A humanoid library logs COM, ZMP, soles and plots with one time point per sample."""
    from skatelib.pipeline.humanoid.motion import PUSH_SEGMENTS

    lib_path = hrp2_skate_build.path
    out = tmp_path / "h.rrd"
    inspect_library(lib_path, ["skate_v1.00"], out, spawn=False, overlay=False)
    cols = _columns(out)
    e = MotionLibrary.open(lib_path)["skate_v1.00"]
    com = cols["/skate_v1.00/com"]
    assert len(com["time"]) == len(e.t)
    assert np.allclose(np.array([p[0] for p in com["Points3D:positions"]])[:, 2], e.state[:, 2], atol=1e-6)
    assert "/skate_v1.00/zmp" in cols and "/skate_v1.00/soles" in cols and "/skate_v1.00/plots/com_vx" in cols
    (strips,) = cols["/skate_v1.00/support_polygons"]["LineStrips3D:strips"]  # one static row
    assert len(strips) == PUSH_SEGMENTS + 2  # the push's segments, the slide, the stop
    assert "/v1.00_s0" not in cols


def test_cli_save_then_rerun_verify(quad_lib, tmp_path):
    """`skatelib inspect LIB --save x.rrd` then `rerun rrd verify x.rrd` both succeed."""
    out = tmp_path / "x.rrd"
    cli = [sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()"]
    r = subprocess.run([*cli, "inspect", str(quad_lib), "--save", str(out)], capture_output=True, text=True,
                       env={**os.environ, "COLUMNS": "200"})
    assert r.returncode == 0, r.stdout + r.stderr
    rerun_bin = Path(sys.executable).parent / "rerun"
    v = subprocess.run([str(rerun_bin), "rrd", "verify", str(out)], capture_output=True, text=True)
    assert v.returncode == 0, v.stdout + v.stderr


def test_unknown_entry_writes_nothing(quad_lib, tmp_path):
    """Asking for an entry that does not exist fails before any file is written."""
    from skatelib.runtime import EntryNotFound

    with pytest.raises(EntryNotFound, match=r"v0\.30_s1"):
        inspect_library(quad_lib, ["v9.99_s9"], tmp_path / "y.rrd", spawn=False, overlay=False)
    assert list(tmp_path.iterdir()) == []


def test_track_save_puts_the_run_beside_its_reference(quad_lib, tmp_path):
    """`skatelib track LIB --save x.rrd`: each entry's reference and closed-loop run under
    /<key>/reference and /<key>/closed_loop; the run starts where the reference starts, lasts the
    entry plus transfer and ride at the MPC's 30 Hz, and `rerun rrd verify` accepts the file."""
    pytest.importorskip("daqp")
    out = tmp_path / "t.rrd"
    cli = [sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()"]
    r = subprocess.run([*cli, "track", str(quad_lib), "-e", "v0.30_s1", "--perturb", "none", "--save", str(out)],
                       capture_output=True, text=True, env={**os.environ, "COLUMNS": "200"})
    assert r.returncode == 0 and out.exists(), r.stdout + r.stderr  # the exact plant: the entry passes
    cols = _columns(out)
    e = MotionLibrary.open(quad_lib)["v0.30_s1"]
    ref = np.array([v[0] for v in cols["/v0.30_s1/reference/plots/board_speed/actual"]["Scalars:scalars"]])
    run = np.array([v[0] for v in cols["/v0.30_s1/closed_loop/plots/board_speed/actual"]["Scalars:scalars"]])
    assert len(ref) == len(e.t)
    assert abs(len(run) - round((e.duration_s + 0.4 + 1.5) * 30)) <= 1
    assert abs(run[0] - ref[0]) < 0.01 and "/v0.30_s1/closed_loop/robot/trunk_0" in cols
    # the legend says which is which: they share the entry's tab
    assert cols["/v0.30_s1/closed_loop/plots/board_roll"]["SeriesLines:names"][0][0] == "closed loop deck roll [rad]"
    assert cols["/v0.30_s1/reference/plots/board_roll"]["SeriesLines:names"][0][0] == "reference deck roll [rad]"
    v = subprocess.run([str(Path(sys.executable).parent / "rerun"), "rrd", "verify", str(out)],
                       capture_output=True, text=True)
    assert v.returncode == 0, v.stdout + v.stderr


def test_spawn_finds_the_viewer_installed_beside_python(monkeypatch):
    """`inspect --spawn` with the venv not activated: the SDK looks for `rerun` on PATH, and the
    viewer installed with it (beside this Python) is put there first."""
    import shutil

    from skatelib.pipeline.views.rerun_inspect import put_viewer_on_path

    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    beside = Path(sys.executable).parent / "rerun"
    if not beside.exists():
        pytest.skip("no rerun viewer installed beside this Python")
    assert shutil.which("rerun") != str(beside)  # negative control: not found that way before
    put_viewer_on_path()
    assert shutil.which("rerun") == str(beside)
