"""``skatelib track HUMANOID_LIB --plant mujoco`` as a user runs it: the walk executed on the twin
with its verdict's figures per entry, the humanoid's model errors, and what it refuses."""

from __future__ import annotations

import re

import pytest

from tests.helpers import run_cli

pytest.importorskip("mujoco")


def _row(out: str, key: str) -> list[str]:
    line = next(x for x in out.splitlines() if key in x and "│" in x)
    return [c.strip() for c in line.split("│")[1:-1]]


@pytest.mark.slow
def test_the_walk_as_planned_passes_with_its_figures(hrp2_walk_path):
    """As planned the walk does not fall, its contact ZMP never leaves the planned polygon, its
    COM stays within 2 cm and its ZMP within 5 cm RMS of the plan, and no sole slips 1 cm."""
    r = run_cli(["track", str(hrp2_walk_path), "--plant", "mujoco", "--perturb", "none", "--no-progress"])
    assert r.returncode == 0, r.stdout + r.stderr
    cells = _row(r.stdout, "walk_v0.375_n6")
    fell, out, zmp, com, slip = cells[1], float(cells[2].split()[0]), cells[3], cells[4], float(cells[5])
    zmp_rms, com_max = float(zmp.split("/")[0]), float(com.split("/")[1])
    assert fell == "no" and out == 0.0 and zmp_rms < 5.0 and com_max < 2.0 and slip < 1.0, cells
    assert cells[7] == "-" and cells[-1] == "pass"  # no board in a walk


def test_the_humanoid_keys_are_checked_and_the_quadrupeds_refused(hrp2_walk_path):
    """A quadruped's error key is refused naming the humanoid's, a shove after the run's end too; the
    model plant, --ride and the MPC's options (--state, --solver, --mpc-mu) too."""
    r = run_cli(["track", str(hrp2_walk_path), "--plant", "mujoco", "--perturb", "kb=-20%", "--no-progress"])
    assert r.returncode == 2 and "com_x" in r.stderr, r.stderr
    r = run_cli(["track", str(hrp2_walk_path), "--no-progress"])
    assert r.returncode != 0 and "--plant mujoco" in r.stdout + r.stderr
    r = run_cli(["track", str(hrp2_walk_path), "--plant", "mujoco", "--ride", "0:0.5"])
    assert r.returncode != 0 and re.search(r"--ride", r.stdout + r.stderr)
    r = run_cli(["track", str(hrp2_walk_path), "--plant", "mujoco", "--perturb", "shove=300,shove_t=30"])
    assert r.returncode == 2 and "ends at 7.60 s" in " ".join(r.stderr.split()), r.stderr  # a shove after the run
    for option in (["--state", "true"], ["--solver", "osqp"], ["--mpc-mu", "0.3"]):  # the MPC's, not the stabilizer's
        r = run_cli(["track", str(hrp2_walk_path), "--plant", "mujoco", *option, "--no-progress"])
        assert r.returncode != 0 and option[0] in " ".join((r.stdout + r.stderr).split()), option


def test_a_humanoid_library_without_a_solved_entry_is_not_tracked(hrp2_walk_path, tmp_path):
    """Every entry stored as failed: exit 1 saying so, as for a quadruped's library (not an empty
    table and exit 0)."""
    from skatelib.library.reader import read_library
    from skatelib.library.writer import write_library

    data = read_library(hrp2_walk_path)
    failed = [type(e)(e.key, {**e.attrs, "success": False, "status": "test: failed"}, e.arrays, e.columns, e.units)
              for e in data.entries.values()]
    keep = {k: v for k, v in data.attrs.items() if k not in ("format", "format_version", "content_sha256")}
    lib = write_library(tmp_path / "failed.h5", keep, data.model_attrs, data.model_arrays, data.model_text, failed)
    r = run_cli(["track", str(lib), "--plant", "mujoco", "--no-progress"])
    assert r.returncode == 1 and "no entry of this library was solved" in r.stdout + r.stderr, r.stdout + r.stderr


@pytest.mark.slow
def test_by_default_the_walk_runs_under_the_humanoid_error_set_and_stands(hrp2_walk_path):
    """Without --perturb the run takes mass +5 %, the COM 2 cm off, mu 0.4 and sensor noise (named
    in the title), does not fall and keeps its ZMP within 2 cm of the soles down (measured 0.0 cm;
    9.6 cm against the plan's clock alone, touchdowns 2-12 ms early)."""
    r = run_cli(["track", str(hrp2_walk_path), "--plant", "mujoco", "--no-progress"])
    assert r.returncode == 0, r.stdout + r.stderr
    assert "mass=+5%,com_x=0.02,mu=0.4,noise=1" in r.stdout
    cells = _row(r.stdout, "walk_v0.375_n6")
    out = float(cells[2].split()[0])
    assert cells[1] == "no" and out <= 2.0 and cells[-1] == "pass", cells


@pytest.mark.slow
def test_validate_closed_loop_stores_the_twin_verdicts_and_info_shows_them(hrp2_walk_path, tmp_path):
    """`validate --closed-loop --plant mujoco` on a humanoid library stores each entry's verdict on
    the twin in the file, with the figures of the same run made here in-process (the loop and the
    verdict called directly); `info` counts them and `info --wide` shows their figures."""
    import json

    from skatelib.proving.humanoid.loop import run_entry
    from skatelib.proving.humanoid.verdict import verdict
    from skatelib.runtime import MotionLibrary

    from tests.helpers import copy_of

    path = copy_of(hrp2_walk_path, tmp_path)
    r = run_cli(["validate", str(path), "--closed-loop", "--plant", "mujoco", "--perturb", "none", "-j", "1"])
    assert r.returncode == 0 and "stored 1 closed-loop verdicts" in r.stdout, r.stdout + r.stderr
    lib = MotionLibrary.open(path)
    stored = json.loads(str(lib["walk_v0.375_n6"].attrs["closed_loop_twin_json"]))
    assert lib.attrs["closed_loop_twin_plant"] == "none"
    v = verdict(run_entry(lib, "walk_v0.375_n6"))
    assert stored["passed"] is True and stored["reasons"] == "" and stored["delivered_mps"] is None
    for k in ("zmp_rms_m", "zmp_max_m", "com_rms_m", "zmp_outside_m", "slip_m", "torque_ratio"):
        assert stored[k] == pytest.approx(getattr(v, k), rel=1e-12), k
    info = run_cli(["info", str(path)])
    assert "closed loop on the twin: 1 of 1 stored verdict pass (plant errors none" in info.stdout, info.stdout
    row = _row(run_cli(["info", str(path), "--wide"]).stdout.split("balance stabilizer")[1], "walk_v0.375_n6")
    assert row[1] == "no" and row[6] == f"{100 * v.zmp_rms_m:.1f}/{100 * v.zmp_max_m:.1f}" and row[8] == "pass", row


def test_validate_closed_loop_on_a_humanoid_refuses_the_model_plant_and_quadruped_keys(hrp2_walk_path, tmp_path):
    """A humanoid library's closed loop is its twin's: the model plant is refused naming --plant
    mujoco, a quadruped's error key names the humanoid's; neither rides nor touches the file."""
    from tests.helpers import copy_of

    path = copy_of(hrp2_walk_path, tmp_path)
    before = path.read_bytes()
    r = run_cli(["validate", str(path), "--closed-loop"])
    assert r.returncode != 0 and "--plant mujoco" in r.stderr and "walk_v0.375_n6" not in r.stdout, r.stdout + r.stderr
    r = run_cli(["validate", str(path), "--closed-loop", "--plant", "mujoco", "--perturb", "kb=-20%"])
    assert r.returncode == 2 and "com_x" in r.stderr, r.stderr
    assert path.read_bytes() == before
