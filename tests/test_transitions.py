"""Transitions from riding (speed-ups, slow-downs, stops), the riding stance they start from, chain
continuity, the route and the chained ride, against independent references: statics and pinocchio
for the stance, the stored arrays (momentum, the Coulomb cone) for the entries, and a real build of
``tests/configs/tiny_ride.toml`` (start-ups to 0.3 and 0.4 m/s, a speed-up, a slow-down and a stop
from each speed, one stride each)."""

from __future__ import annotations

import dataclasses
import subprocess
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from skatelib.library.channels import BOARD, GROUND, SWING
from skatelib.library.margins import momentum_speed
from skatelib.pipeline.build.contract import BuildOptions
from skatelib.pipeline.build.orchestrate import build_library
from skatelib.pipeline.config import load_config
from skatelib.pipeline.quadruped.checks.chain import chain_gaps
from skatelib.pipeline.quadruped.checks.verify import Trajectory, check_trajectory
from skatelib.pipeline.quadruped.model.riding import barycentric
from skatelib.pipeline.quadruped.model.schedule import knot_schedule
from skatelib.pipeline.quadruped.problem.problem import transition_window
from skatelib.runtime import EntryNotFound, MotionLibrary

from tests.helpers import CLI

TINY_RIDE = Path(__file__).parent / "configs" / "tiny_ride.toml"


@pytest.fixture(scope="module")
def ride_path(tmp_path_factory):
    out = tmp_path_factory.mktemp("ride") / "ride.h5"
    build_library(load_config(TINY_RIDE), out, BuildOptions(jobs=2, cache=False, progress=False))
    return out


@pytest.fixture(scope="module")
def ride_lib(ride_path):
    return MotionLibrary.open(ride_path)


def test_a_transition_window_starts_in_the_air_and_plants_the_foot_briefly_at_speed(cfg):
    """The lead-in has the push foot in the air; at 1 m/s a push plants it for 0.30 m / 1 m/s, a brake
    for 0.26 m / 1 m/s; slow speeds keep the schedule's push time."""
    w = transition_window(cfg, 0.8, 1.0, 1.0)
    assert w.lead_s == pytest.approx(0.3) and w.ground_s == pytest.approx(0.30)
    assert transition_window(cfg, 1.0, 0.3, -1.0).ground_s == pytest.approx(0.24)  # 8 whole knots of 0.03 s
    assert transition_window(cfg, 0.3, 0.0, -1.0).ground_s == pytest.approx(0.54)
    sch = knot_schedule(cfg.schedule, 2, 0.03, w.lead_s, w.ground_s)
    p = 2  # RL
    assert len(sch.t) == 10 + 2 * 40 + 1
    assert (sch.contact[:10, p] == SWING).all() and (sch.contact[10:20, p] == GROUND).all()
    assert (sch.contact[20:50, p] == SWING).all() and (sch.contact[50:60, p] == GROUND).all()
    assert sch.contact[-1, p] == SWING and (sch.contact[:, [0, 1, 3]] == BOARD).all()


def test_the_riding_stance_loads_every_deck_foot_by_statics_and_pinocchio(cfg, system):
    """Pinocchio's forward kinematics at the riding stance put the three deck feet on their deck points
    and the push foot at its lifted point; a statics solve of the three feet's vertical loads under
    pinocchio's centre of mass gives each at least ``ride_load_fraction`` of the weight."""
    robot, st = system.robot, system.stance
    x, y, roll, pitch = st.ride_trunk
    model = pin.buildModelFromUrdf(str(cfg.urdf_path), pin.JointModelFreeFlyer())
    data = model.createData()
    R = pin.rpy.rpyToMatrix(roll, pitch, 0.0)
    trunk = np.array([x, y, st.trunk_height_m - cfg.board.deck_height_m])
    q = robot.pin_configuration(trunk, R, st.q_ride)
    pin.framesForwardKinematics(model, data, q)
    feet = np.array([data.oMf[model.getFrameId(f)].translation for f in cfg.robot.foot_frames])
    r = cfg.robot.foot_radius_m
    deck = [0, 1, 3]
    assert np.allclose(feet[deck, 0:2], st.cr[:, deck].T, atol=1e-6)
    assert np.allclose(feet[deck, 2], r, atol=1e-6)
    lift = cfg.terminal.push_foot_height_m
    assert feet[2, 2] == pytest.approx(r - cfg.board.deck_height_m + lift + 0.01, abs=1e-6)
    com = pin.centerOfMass(model, data, q)
    # The model's single rigid body keeps the four-leg stance's COM offset; the lifted leg moves the
    # whole body's COM by a few millimetres (the optimizer's model error, stated here).
    assert np.allclose(com, system.riding_com_m, atol=6e-3)
    A = np.vstack([np.ones(3), feet[deck, 0] - com[0], feet[deck, 1] - com[1]])
    loads = np.linalg.solve(A, [1.0, 0.0, 0.0])  # shares of the weight, no moment about the COM
    assert loads.min() >= cfg.stance.ride_load_fraction - 0.02
    assert np.allclose(barycentric(feet[deck, 0:2], com[0:2]), loads, atol=1e-9)


@pytest.mark.slow
def test_every_transition_validates_and_starts_where_it_says(ride_lib, system):
    """Every entry solved and passes the independent checks; a transition starts riding at its start
    speed (momentum), ends at its target; the stops brake with the foot planted and end below 0.02 m/s."""
    keys = {"v0.30_s1", "v0.40_s1", "v0.30-0.40_s1", "v0.40-0.30_s1", "v0.30-0.00_s1", "v0.40-0.00_s1"}
    assert set(ride_lib.keys()) == keys
    m, mb = system.srb.mass_kg, system.board.mass_kg
    for e in ride_lib:
        assert e.success, (e.key, e.attrs["status"])
        rep = check_trajectory(system, Trajectory.of(e), e.target_velocity_mps, from_velocity_mps=e.from_velocity_mps)
        assert rep.failures(system) == [], (e.key, rep.failures(system))
        v = momentum_speed(np.asarray(e.state), m, mb)
        assert v[0] == pytest.approx(e.from_velocity_mps, abs=1e-9)
        assert v[-1] == pytest.approx(e.target_velocity_mps, abs=0.02 * max(e.target_velocity_mps, 1.0))
    for key in ("v0.30-0.00_s1", "v0.40-0.00_s1"):
        e = ride_lib[key]
        planted = np.asarray(e.contact)[:-1, 2] == GROUND
        yaw = np.asarray(e.state)[:-1, 5][planted]
        f = np.asarray(e.control)[planted, 6:8]
        along = f[:, 0] * np.cos(yaw) + f[:, 1] * np.sin(yaw)  # the ground's force along the heading
        assert planted.any() and along.min() < -1.0 and along.max() <= 1e-6  # it brakes, never pushes
        assert abs(momentum_speed(np.asarray(e.state[-1]), m, mb)) < 0.02


@pytest.mark.slow
def test_chain_continuity_of_every_junction(ride_lib):
    """Every end at 0.3 or 0.4 m/s meets every transition from that speed within the end's tolerances."""
    gaps = chain_gaps(ride_lib)
    assert len(gaps) == 8
    assert [g.failures() for g in gaps if g.failures()] == []
    assert max(g.gaps["board_speed_mps"] for g in gaps) > 0.0  # measured, not assumed


def _doctored(e, **change):
    return dataclasses.replace(Trajectory.of(e), **{k: np.array(getattr(e, k)) for k in change} | change)


@pytest.mark.slow
def test_negative_controls_refuse_doctored_transitions(ride_lib, system):
    """A braking force outside the Coulomb cone, a braking foot that pushes, a transition that starts at
    another speed, and a stop that still rolls at its end: each refused."""
    e = ride_lib["v0.40-0.00_s1"]
    planted = np.flatnonzero(np.asarray(e.contact)[:-1, 2] == GROUND)
    k = planted[len(planted) // 2]
    u = np.array(e.control)
    u[k, 6] = -0.9 * u[k, 8]  # mu 0.9 > 0.6: outside the cone
    rep = check_trajectory(system, _doctored(e, control=u), 0.0, from_velocity_mps=0.4)
    assert any("Coulomb" in f for f in rep.failures(system))
    u = np.array(e.control)
    u[k, 6] = 2.0  # forward: the brake pushes
    rep = check_trajectory(system, _doctored(e, control=u), 0.0, from_velocity_mps=0.4)
    assert any("braking foot pushes" in f for f in rep.failures(system))
    rep = check_trajectory(system, Trajectory.of(e), 0.0, from_velocity_mps=0.5)
    assert any("starts riding at" in f for f in rep.failures(system))
    x = np.array(e.state)
    x[-1, [6, 24]] += 0.05  # robot and board still roll at 5 cm/s at the end
    rep = check_trajectory(system, _doctored(e, state=x), 0.0, from_velocity_mps=0.4)
    assert any(f.startswith("still rides at 0.0") and "a stop ends below 0.020 m/s" in f for f in rep.failures(system))
    honest = check_trajectory(system, Trajectory.of(e), 0.0, from_velocity_mps=0.4)
    assert honest.failures(system) == []


@pytest.mark.slow
def test_chain_check_refuses_an_end_off_the_riding_stance(ride_path, tmp_path):
    """An end moved 3 cm over the deck no longer meets the transitions from its speed: validate fails,
    naming the junctions."""
    from skatelib.library import schema
    from skatelib.library.reader import read_library
    from skatelib.library.records import EntryRecord
    from skatelib.library.writer import write_library

    data = read_library(ride_path)
    entries = []
    for r in data.entries.values():
        arrays = dict(r.arrays)
        if r.key == "v0.30_s1":
            arrays["state"] = np.array(arrays["state"])
            arrays["state"][-1, 0] += 0.03
        entries.append(EntryRecord(key=r.key, attrs=dict(r.attrs), arrays=arrays, columns=dict(r.columns),
                                   units=dict(r.units)))
    protected = {schema.A_FORMAT, schema.A_FORMAT_VERSION, schema.A_CHECKSUM}
    bad = tmp_path / "bad.h5"
    write_library(bad, {k: v for k, v in data.attrs.items() if k not in protected}, data.model_attrs,
                  data.model_arrays, data.model_text, entries)
    gaps = [g for g in chain_gaps(MotionLibrary.open(bad)) if g.end == "v0.30_s1"]
    assert len(gaps) == 2 and all(any("com_xy_m" in f for f in g.failures()) for g in gaps)
    out = subprocess.run([*CLI, "validate", str(bad)], capture_output=True, text=True)
    assert out.returncode == 1 and "com_xy_m" in out.stdout


@pytest.mark.slow
def test_select_and_route(ride_lib):
    """select by start speed; route chains entries where no single one gets there, in the least time."""
    assert ride_lib.select(0.3, from_velocity_mps=0.4).key == "v0.40-0.30_s1"
    assert ride_lib.select(0.35).key in {"v0.30_s1", "v0.40_s1"}
    with pytest.raises(EntryNotFound, match="entries start at"):
        ride_lib.select(0.3, from_velocity_mps=0.7)
    assert [e.key for e in ride_lib.route(0.4, 0.0)] == ["v0.40-0.00_s1"]
    assert [e.key for e in ride_lib.route(0.0, 0.3)] == ["v0.30_s1"]
    with pytest.raises(ValueError):
        ride_lib.route(0.3, 0.3)
    with pytest.raises(EntryNotFound, match="reaches"):
        ride_lib.route(0.0, 0.5)


@pytest.mark.slow
def test_route_takes_the_fastest_chain(ride_lib):
    """Without a direct entry the route goes through another speed: 0 -> 0.4 -> 0.3 when 0.3 has no start-up."""
    from skatelib.runtime.routes import route

    entries = [e for e in ride_lib if e.key != "v0.30_s1"]
    assert [e.key for e in route(entries, 0.0, 0.3)] == ["v0.40_s1", "v0.40-0.30_s1"]


@pytest.mark.slow
def test_a_chained_ride_passes_in_closed_loop(ride_path, tmp_path):
    """0 -> 0.4 -> 0.3 -> 0 on the model plant with the default model errors: each stage within 5 % of
    its target, the stop below 0.05 m/s, no fall, no slip (the command's exit code and table); the
    joined reference beside the run in a Rerun recording."""
    pytest.importorskip("rerun")
    rrd = tmp_path / "ride.rrd"
    out = subprocess.run([*CLI, "track", str(ride_path), "--ride", "0:0.4,0.4:0.3,0.3:0", "--no-progress",
                          "--save", str(rrd)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout.count("pass") >= 4 and "v0.40-0.30_s1" in out.stdout
    assert rrd.stat().st_size > 10_000


@pytest.mark.slow
def test_ride_arguments_are_checked(ride_path):
    """A malformed stage is a usage error (exit 2); a stage the library cannot ride names what it reaches."""
    bad = subprocess.run([*CLI, "track", str(ride_path), "--ride", "0:0.4,0.3:0"], capture_output=True, text=True)
    assert bad.returncode == 2 and "starts at 0.3" in bad.stderr.replace("\n", " ")
    far = subprocess.run([*CLI, "track", str(ride_path), "--ride", "0:0.9"], capture_output=True, text=True)
    assert far.returncode != 0 and "reaches" in (far.stdout + far.stderr).replace("\n", " ")


@pytest.mark.slow
def test_a_chained_ride_passes_on_the_twin(ride_path):
    """The same ride in full physics (MuJoCo twin, whole-body controller, the default model errors):
    each stage within 5 % of its target at its end, the stop below 0.05 m/s, the twin's verdict
    (slip, floor contacts, wheel lift-off) passed."""
    pytest.importorskip("mujoco")
    out = subprocess.run([*CLI, "track", str(ride_path), "--ride", "0:0.4,0.4:0.3,0.3:0", "--plant", "mujoco"],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "MuJoCo" in out.stdout and out.stdout.count("pass") >= 4


@pytest.mark.slow
def test_the_frontier_of_speed_ups_brackets_the_fastest_and_agrees_with_the_build(ride_lib):
    """The fastest speed-up from 0.3 m/s in one stride (a coarse search, cold solves): the fastest is
    a probe that passed and the first failure one that did not, within the resolution; the build's
    own 0.3 -> 0.4 entry, which passed the same checks, lies below it."""
    import dataclasses as dc

    from skatelib.pipeline.quadruped.frontier import FrontierSearch, Lane, frontier_for

    cfg = load_config(TINY_RIDE)  # a probe past the frontier runs to the iteration limit: a lower one keeps it short
    cfg = dc.replace(cfg, optimization=dc.replace(cfg.optimization, max_iter=120))
    point = frontier_for(cfg, 1, FrontierSearch(step_mps=0.4, resolution_mps=0.2, max_mps=1.5), Lane(0.3))
    ok = {p.velocity_mps for p in point.probes if p.ok}
    bad = {p.velocity_mps for p in point.probes if not p.ok}
    assert point.lane.label == "speed-up from 0.30" and min(ok | bad) == pytest.approx(0.7)
    assert point.fastest_mps in ok and point.first_failure_mps in bad
    assert 0 < point.first_failure_mps - point.fastest_mps <= 0.2
    assert ride_lib["v0.30-0.40_s1"].success and point.fastest_mps >= 0.4


def test_the_transition_tasks_group_what_warm_starts_share():
    """Every transition of the default config is in exactly one task; within a task the
    transitions whose planted foot drives alike (push or brake) share their one-stride knot window
    (what a warm start within the task needs); a task holds the slow-downs from a speed or the
    speed-ups to one; the build starts the heaviest tasks first."""
    from skatelib.pipeline.quadruped import builder
    from skatelib.pipeline.quadruped.problem.problem import system_for
    from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec
    from skatelib.pipeline.quadruped.transitions.tasks import TransitionTask, transition_tasks

    cfg = load_config(None)
    tasks = transition_tasks(cfg)
    pairs = [p for t in tasks for p in t.pairs]
    assert sorted(pairs) == sorted(cfg.transitions.pairs())
    system, tr = system_for(cfg), cfg.transitions
    for t in tasks:
        windows: dict[bool, set] = {}
        for a, b in t.pairs:
            pushes = system.drive(a, b, tr.touchdown_s + cfg.schedule.period_s) > 0
            windows.setdefault(pushes, set()).add(PushoffSpec(cfg, b, 1, from_velocity_mps=a).window)
        assert all(len(w) == 1 for w in windows.values()), t.pairs
        assert len({a for a, _ in t.pairs}) == 1 or len({b for _, b in t.pairs}) == 1
        gaps = [abs(b - a) for a, b in t.pairs]
        assert gaps == sorted(gaps)  # nearest first: each warm-started from its neighbour
    every = builder.tasks(cfg)
    assert [t.weight for t in every] == sorted((t.weight for t in every), reverse=True)
    assert sum(isinstance(t, TransitionTask) for t in every) == len(tasks)
