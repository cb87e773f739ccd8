"""Humanoid GPM steps (Takasugi et al.): the paper's figures, every constraint by independent
code, and the library round trip."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from skatelib.library.errors import ConfigError, SkatelibError
from skatelib.pipeline.build.contract import BuildOptions
from skatelib.pipeline.build.orchestrate import build_library
from skatelib.pipeline.config import CONFIG_DIR, load_config
from skatelib.pipeline.humanoid.motion import skating_steps, solve_motion, step_model, walking_steps
from skatelib.pipeline.humanoid.verify import check_steps, failures
from skatelib.runtime import MotionLibrary

from tests.helpers import copy_of

WALK, SKATE = CONFIG_DIR / "hrp2_walk.toml", CONFIG_DIR / "hrp2_skate.toml"


@pytest.fixture(scope="module")
def walk(hrp2_walk_motion):
    return hrp2_walk_motion


@pytest.fixture(scope="module")
def skate():
    c = load_config(SKATE)
    return c, solve_motion(c, 1.0)


def _report(c, m):
    plan = (walking_steps if c.sweep.motion == "walk" else skating_steps)(c, m.velocity_mps)[1]
    nodes_t = np.stack([r.t0 + np.concatenate([(np.concatenate([[-1.0], np.polynomial.legendre.leggauss(
        len(r.U))[0]]) + 1) / 2 * r.spec.duration_s, [r.spec.duration_s]]) for r in m.steps])
    nodes_X = np.stack([np.vstack([r.X, r.Xf]) for r in m.steps])
    return plan, nodes_t, nodes_X, np.stack([r.U for r in m.steps]), step_model(c)


def test_skate_push_reaches_one_metre_per_second_at_one_second(skate):
    """Paper Sec. V-B: 0 -> 1.0 m/s in the 1.0 s push; the COM from 0.80 m over the ground to the
    transition's height over the deck (0.70 m over a 0.10 m deck; the paper's 0.73 m is over level
    feet)."""
    c, m = skate
    assert m.success
    push = m.steps[0]
    assert push.spec.duration_s == pytest.approx(1.0)
    assert push.Xf[3] == pytest.approx(1.0, abs=1e-9)
    deck = c.board.deck_height_m
    assert push.X[0, 2] == pytest.approx(0.80)
    assert push.Xf[2] == pytest.approx(deck + c.skate.transition_com_height_m, abs=1e-9)
    k = int(np.argmin(np.abs(m.t - 1.0)))
    assert m.state[k, 3] == pytest.approx(1.0, abs=1e-6)  # the stored samples agree
    assert np.abs(m.state[m.t > 1.0, 3] - 1.0).max() < 1e-6  # no friction along the board afterwards


def test_walking_reaches_0_4_metres_per_second(walk):
    """Paper Sec. V-A: six 0.3 m steps of 0.8 s; the COM reaches about 0.40 m/s at 0.80 m height."""
    _, m = walk
    assert m.success and len(m.steps) == 8
    assert 0.38 <= m.state[:, 3].max() <= 0.42
    assert np.abs(m.state[:, 2] - 0.80).max() < 0.02
    assert m.state[-1, 3:6] == pytest.approx(np.zeros(3), abs=1e-6)  # stopped


@pytest.mark.parametrize("motion", ["walk", "skate"])
def test_every_constraint_holds_by_independent_check(motion, walk, skate):
    """Dynamics, quadrature, continuity, unilateral, ZMP, friction, skating, reach and every
    terminal condition hold at the nodes, checked with scipy interpolation."""
    c, m = walk if motion == "walk" else skate
    plan, nt, nx, nu, model = _report(c, m)
    rep = check_steps(plan, nt, nx, nu, model)
    assert failures(rep) == [], rep
    expected = {"dynamics_position", "zmp_in_polygon", "friction", "reach", "continuity", "stop", "dcm_terminal"}
    assert expected <= set(rep)


def test_checker_catches_a_perturbed_node(skate):
    """Moving one node's acceleration by 0.05 m/s^2 is reported (the check can fail)."""
    c, m = skate
    plan, nt, nx, nu, model = _report(c, m)
    nu = nu.copy()
    nu[0, 4, 0] += 0.05
    assert any("dynamics_velocity" in f for f in failures(check_steps(plan, nt, nx, nu, model)))


def test_sqp_and_ipopt_reach_the_same_optimum(skate):
    """Both NLP solvers give the same cost per step of the 1.0 m/s skate."""
    c, a = skate
    b = solve_motion(dataclasses.replace(c, gpm=dataclasses.replace(c.gpm, solver="ipopt")), 1.0)
    for x, y in zip(a.steps, b.steps, strict=True):
        assert x.objective == pytest.approx(y.objective, rel=1e-6)


def test_library_round_trip_and_cli(hrp2_skate_build, tmp_path):
    """`skatelib build` on the skating config (the session's, exit 0) writes a humanoid library that
    validates, every push with its whole body; with the pushing foot flat beside the board foot (no
    toe-off) the 0.75 and 1.0 m/s pushes end beyond the legs' reach (the 0.75 m/s whole body misses
    its targets by the push's end, the 1.0 m/s push's COM step has no solution within the reach of
    Eq. 21; the 0.5 m/s one fails in its swing onto the deck, the ankle at its limit): stored as
    failed, so that build exits 1 unless --allow-failures."""
    out = hrp2_skate_build.path
    env = {**os.environ, "COLUMNS": "200"}
    cli = [sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()"]
    lib = MotionLibrary.open(out)
    assert lib.kind == "humanoid" and lib.keys() == ["skate_v0.50", "skate_v0.75", "skate_v1.00"]
    assert [e.success for e in lib] == [True, True, True]
    flat = tmp_path / "flat.toml"
    flat.write_text(f'extends = "{SKATE.as_posix()}"\n[skate]\npush_foothold_m = 0.0\ntoe_off_s = 0.0\n'
                    'toe_off_rad = 0.0\n[sweep]\nvelocities_mps = [0.5, 0.75, 1.0]\n')
    r = subprocess.run([*cli, "build", str(flat), "-o", str(tmp_path / "flat.h5")], capture_output=True, text=True,
                       env=env)
    assert r.returncode == 1 and "3 entries failed" in r.stdout, r.stdout + r.stderr
    flat_lib = MotionLibrary.open(tmp_path / "flat.h5")
    assert [e.success for e in flat_lib] == [False, False, False]
    status = str(flat_lib["skate_v0.75"].attrs["status"])  # the push's end: the leg cannot follow
    assert "miss the body's targets from t = 0.9" in status, status
    assert str(flat_lib["skate_v1.00"].attrs["status"]).startswith("push: ")  # beyond the COM's reach
    e = lib["skate_v1.00"]
    assert e.columns["state"] == ("com_x", "com_y", "com_z", "com_vx", "com_vy", "com_vz")
    assert e.columns["zmp"] == ("zmp_x", "zmp_y")
    assert e.sample(1.0).state[3] == pytest.approx(1.0, abs=1e-6)
    assert e.sample(1.0)["com_vx"] == pytest.approx(1.0, abs=1e-6)
    assert e.sample(1.0).contact is None and e.window(0.0, 3, 0.1).contact is None  # no made-up feet
    v = subprocess.run([*cli, "validate", str(out)], capture_output=True, text=True, env=env)
    assert v.returncode == 0 and "all entries valid" in v.stdout


@pytest.mark.slow
def test_a_motion_that_fails_before_its_whole_body_is_stored_as_failed(tmp_path):
    """A reach limit the 1.0 m/s push cannot keep (the COM within 0.82 m of the feet): its GPM step
    fails, so it has no whole body while the 0.5 m/s entry has one; the library is still written,
    that entry stored failed with the step's status and the whole body's datasets empty, and it
    validates as failed."""
    p = tmp_path / "reach.toml"
    p.write_text(f'extends = "{SKATE.as_posix()}"\n[humanoid]\nleg_max_m = 0.82\n'
                 '[sweep]\nvelocities_mps = [0.5, 1.0]\n')
    rep = build_library(load_config(p), tmp_path / "r.h5", BuildOptions(jobs=1, cache=False))
    lib = MotionLibrary.open(rep.path)
    assert lib["skate_v0.50"].success and not lib["skate_v1.00"].success
    assert str(lib["skate_v1.00"].attrs["status"]).startswith("push: ")
    assert lib["skate_v1.00"].arrays["joints"].shape == (0, lib["skate_v0.50"].arrays["joints"].shape[1])
    env = {**os.environ, "COLUMNS": "200"}
    cli = [sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()"]
    v = subprocess.run([*cli, "validate", str(rep.path)], capture_output=True, text=True, env=env)
    assert v.returncode == 0 and "skate_v1.00: stored as failed" in v.stdout, v.stdout + v.stderr
    assert "1 solved entry valid; 1 entry stored as failed (skipped)" in v.stdout  # not "all entries valid"


def test_build_report_marks_all_entries(hrp2_walk_path):
    """The walking build (the session's, its report without a failure) writes one successful entry:
    six walking steps between start and stop (eight GPM phases), named for what it is."""
    lib = MotionLibrary.open(hrp2_walk_path)
    e = lib.select(0.375)
    assert lib.keys() == ["walk_v0.375_n6"] and e.success
    assert e.key == "walk_v0.375_n6" and e.n_strides == 6 and e.attrs["n_phases"] == 8
    with pytest.raises(SkatelibError, match="humanoid library: select"):  # nothing of its to check a blend by
        lib.blend(0.375)


def test_unknown_motion_is_a_config_error(tmp_path):
    """A motion other than walk or skate names the key."""
    p = tmp_path / "x.toml"
    p.write_text(f'extends = "{WALK.as_posix()}"\n[sweep]\nmotion = "run"\nvelocities_mps = [1.0]\n')
    with pytest.raises(ConfigError, match=r"sweep\.motion"):
        load_config(p)
    assert Path(WALK).exists()


def test_a_toe_off_longer_than_the_push_is_a_config_error(tmp_path):
    p = tmp_path / "x.toml"
    p.write_text(f'extends = "{SKATE.as_posix()}"\n[skate]\ntoe_off_s = 1.5\n')
    with pytest.raises(ConfigError, match=r"skate\.toe_off_s.*skate\.push_s"):
        load_config(p)


@pytest.mark.parametrize(("extra", "field"), [
    ("[board]\ndeck_height_m = 0.0\n", r"board\.deck_height_m.*above the axles"),  # the deck on the floor
    ("[board]\ndeck_height_m = 0.04\n", r"board\.deck_height_m"),  # below the axles and a deck's thickness
    ("[humanoid]\ncom_height_m = 1.5\n", r"humanoid\.com_height_m.*outside the legs' reach"),
    ("[skate]\ntransition_com_height_m = 0.4\n", r"skate\.transition_com_height_m.*0\.45 to 0\.92"),
    ("[boardd]\ndeck_height_m = 0.1\n", r"boardd.*allowed: .*board"),  # the board among the allowed tables
])
def test_a_skate_that_cannot_stand_is_a_config_error(tmp_path, extra, field):
    """A deck on the floor or under its axles, a COM out of the legs' reach (standing or at the
    transition), a misspelt table: refused before any solve, naming the field and why."""
    p = tmp_path / "x.toml"
    p.write_text(f'extends = "{SKATE.as_posix()}"\n{extra}')
    with pytest.raises(ConfigError, match=field):
        load_config(p)


def test_humanoid_build_goes_the_one_build_path(hrp2_skate_build, tmp_path):
    """`skatelib build` of a humanoid config runs through the same sweep as a quadruped's: its motions
    solve as tasks in worker processes (-j 2, the session's build from an empty cache), a second
    build is served from the entry cache (every step marked c) with the same arrays, and --frontier
    is refused (exit 2, nothing written)."""
    env = {**os.environ, "COLUMNS": "200", "SKATELIB_CACHE_DIR": str(hrp2_skate_build.cache)}
    cli = [sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()"]
    out = tmp_path / "s.h5"
    r = subprocess.run([*cli, "build", str(SKATE), "-o", str(out), "--frontier"], capture_output=True, text=True,
                       env=env)
    assert r.returncode == 2 and "--frontier" in r.stderr and "humanoid" in r.stderr and not out.exists()
    again = subprocess.run([*cli, "build", str(SKATE), "-o", str(out), "-j", "2", "--no-progress", "--allow-failures"],
                           capture_output=True, text=True, env=env)
    assert again.returncode == 0, again.stdout + again.stderr
    cached = [sum(" c " in line for line in stdout.splitlines() if line.startswith("│ skate_"))
              for stdout in (hrp2_skate_build.stdout, again.stdout)]
    assert cached == [0, 9]  # three motions of three steps each
    first = MotionLibrary.open(hrp2_skate_build.path)
    lib = MotionLibrary.open(out)
    for e in first:  # served from the cache: the same arrays
        assert np.array_equal(e.state, lib[e.key].state)
    assert lib.keys() == ["skate_v0.50", "skate_v0.75", "skate_v1.00"] and lib["skate_v0.50"].success
    assert all(len(e.attrs["cache_key"]) == 32 for e in lib)


def test_motion_cache_key_follows_the_problem(monkeypatch):
    """The key ignores the library's name and velocity list, and changes with the velocity and with
    the step NLP's code (a constraint row added in code)."""
    from skatelib.pipeline.humanoid import step, tasks
    from skatelib.pipeline.humanoid.motion import plan_for

    cfg = load_config(SKATE)
    plan = plan_for(cfg, 1.0)[1]
    key = tasks.motion_key(cfg, 1.0, plan)
    renamed = dataclasses.replace(cfg, meta=dataclasses.replace(cfg.meta, name="other"),
                                  sweep=dataclasses.replace(cfg.sweep, velocities_mps=(0.2,)))
    assert tasks.motion_key(renamed, 1.0, plan) == key
    assert tasks.motion_key(cfg, 0.9, plan_for(cfg, 0.9)[1]) != key
    original = step.node_rows

    def with_extra_row(s, k, rows):
        original(s, k, rows)
        rows.add(s.U[k, 0], -10.0, 10.0)

    monkeypatch.setattr(step, "node_rows", with_extra_row)
    monkeypatch.setattr(step, "_PROBLEMS", {})
    assert tasks.motion_key(cfg, 1.0, plan) != key


def test_build_judges_each_motion_with_the_independent_checks(walk):
    """A solved walk passes the step checks; the same walk with one step's accelerations scaled by
    1.5 (its states left as they were) fails them, and its entry is stored as failed with the check."""
    from skatelib.pipeline.humanoid.entries import entry_from_motion
    from skatelib.pipeline.humanoid.tasks import EntryOutcome
    from skatelib.pipeline.humanoid.verify import judge

    c, m = walk
    assert judge(c, m) == ()
    bad = dataclasses.replace(m.steps[2], U=m.steps[2].U * 1.5)
    doctored = dataclasses.replace(m, steps=[*m.steps[:2], bad, *m.steps[3:]])
    found = judge(c, doctored)
    assert found and any("dynamics" in f for f in found), found
    record = entry_from_motion(EntryOutcome("walk_v0.375_n6", doctored, found, False), c)
    assert record.attrs["success"] is False and record.attrs["status"].startswith("Physics_Check_Failed")


def test_each_entry_stores_its_plan_and_validate_checks_against_it(hrp2_walk_path, tmp_path):
    """The plan an entry was solved for is stored with it (``plan_json``, exact round trip) and
    `validate` checks the nodes against that plan, not one rebuilt with today's code: a stored plan
    whose first step lasts 10 % longer fails the check."""
    import json

    from skatelib.library.amend import amend_library
    from skatelib.pipeline.humanoid.motion import plan_from_json, walking_steps
    from skatelib.pipeline.validate import validate_library

    cfg = load_config(WALK)
    path = copy_of(hrp2_walk_path, tmp_path, "w.h5")
    e = MotionLibrary.open(path)["walk_v0.375_n6"]
    assert plan_from_json(e.attrs["plan_json"]) == walking_steps(cfg, 0.375)[1]
    verdicts: list[str] = []
    assert validate_library(path, lambda key, status, msg, fig: verdicts.append(status)) == 0 and verdicts == ["ok"]
    doctored = json.loads(e.attrs["plan_json"])
    doctored[0]["duration_s"] *= 1.1
    amend_library(path, {}, {e.key: {"plan_json": json.dumps(doctored)}})
    messages: list[str] = []
    assert validate_library(path, lambda key, status, msg, fig: messages.append(msg)) == 1
    assert "ok" not in messages
