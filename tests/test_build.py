"""End to end: `skatelib build` on a tiny config really solves, writes a valid library, resumes
from its cache, records failures, and gives the same library through a dask cluster."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess

import numpy as np
import pytest
from skatelib.library.reader import read_library
from skatelib.pipeline.build import sweep
from skatelib.pipeline.build.contract import BuildOptions
from skatelib.pipeline.build.orchestrate import build_library
from skatelib.pipeline.config import load_config
from skatelib.pipeline.quadruped.problem.attempts import retry_ladder
from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, WarmStart, solver_options
from skatelib.runtime import MotionLibrary

from tests.helpers import CLI, TINY


@pytest.fixture(scope="module")
def cache(tiny_build):
    """The entry cache the session's tiny build filled, the cache of this module's builds."""
    old = os.environ.get("SKATELIB_CACHE_DIR")
    os.environ["SKATELIB_CACHE_DIR"] = str(tiny_build.cache)
    yield tiny_build.cache
    if old is None:
        os.environ.pop("SKATELIB_CACHE_DIR")
    else:
        os.environ["SKATELIB_CACHE_DIR"] = old


@pytest.fixture(scope="module")
def built(tiny_build):
    """`skatelib build tests/configs/tiny.toml --jobs 2`: the library and what the command printed."""
    return tiny_build.path, tiny_build.stdout


def test_build_writes_a_complete_library(built):
    """Both entries converge to their targets; the file carries model, provenance and columns."""
    out, stdout = built
    lib = MotionLibrary.open(out)
    assert sorted(lib.keys()) == ["v0.30_s1", "v0.40_s1"]
    for e in lib:
        assert e.success and e.attrs["status"] == "Solve_Succeeded"
        assert abs(e.channel("board_vx")[-1] - e.target_velocity_mps) < 0.02 * e.target_velocity_mps
    assert lib.model["robot_mass_kg"] == pytest.approx(8.5184)
    assert "<robot" in lib.urdf and lib.attrs["config_toml"].startswith("# A small build")
    assert lib.attrs["ipopt_version"].count(".") == 2
    read_library(out, full=True)
    assert "v0.40_s1" in stdout and "wrote" in stdout


def test_info_and_validate_commands(built):
    """`skatelib info` lists the entries; `skatelib validate` re-checks physics and exits 0."""
    out, _ = built
    env = {**os.environ, "COLUMNS": "200"}
    info = subprocess.run([*CLI, "info", str(out)], capture_output=True, text=True, env=env, check=True).stdout
    wide = subprocess.run([*CLI, "info", str(out), "--wide"], capture_output=True, text=True, env=env,
                          check=True).stdout
    assert "v0.30_s1" in info and "board_roll_stiffness_Nm_per_rad" in wide  # the model: --wide's
    # the figures a user checks, from the stored physics: momentum speed and how far off the label [%]
    from skatelib.runtime import MotionLibrary

    e = MotionLibrary.open(out)["v0.30_s1"]
    momentum = json.loads(e.attrs["physics_json"])["momentum_speed_mps"]
    for shown in (info, wide):
        row = next(line for line in shown.splitlines() if "v0.30_s1" in line)
        assert "2 entries" in shown and f"{momentum:.3f}" in row and f"{100 * (momentum - 0.3) / 0.3:+.2f}" in row
    val = subprocess.run([*CLI, "validate", str(out)], capture_output=True, text=True, env=env)
    assert val.returncode == 0, val.stdout
    assert "all entries valid" in val.stdout


def test_info_and_validate_print_json(built):
    """`info --json` and `validate --json` print one JSON document each, with the figures of the
    stored physics and of the re-check, so a CI script can read them; the digest is the file's."""
    from skatelib.library.digest import file_digest

    out, _ = built
    env = {**os.environ, "COLUMNS": "80"}  # narrow: JSON must not be wrapped
    info = json.loads(subprocess.run([*CLI, "info", str(out), "--json"], capture_output=True, text=True, env=env,
                                     check=True).stdout)
    assert info["kind"] == "quadruped" and [e["key"] for e in info["entries"]] == ["v0.30_s1", "v0.40_s1"]
    model = info["model"]
    assert model["board_rolling_friction_plan_N"] == pytest.approx(2 * model["board_rolling_friction_N"])
    digest = info["content_sha256"]
    assert file_digest(out.read_bytes(), digest.encode()) == digest  # what the reader verifies
    val = subprocess.run([*CLI, "validate", str(out), "--json"], capture_output=True, text=True, env=env)
    doc = json.loads(val.stdout)
    assert val.returncode == 0 and doc["valid"] and {e["status"] for e in doc["entries"]} == {"ok"}
    stored = {e["key"]: e["physics"]["momentum_speed_mps"] for e in info["entries"]}
    for e in doc["entries"]:  # the re-check measures what the build stored
        assert e["momentum_speed_mps"] == pytest.approx(stored[e["key"]], rel=1e-9)


def test_validate_rejects_a_corrupt_file(built, tmp_path):
    """A library with a damaged byte fails `skatelib validate` with exit 3 (a bad library file) and
    a message on stderr naming the file."""
    out, _ = built
    bad = tmp_path / "bad.h5"
    data = bytearray(out.read_bytes())
    data[len(data) // 3] ^= 0xFF
    bad.write_bytes(bytes(data))
    r = subprocess.run([*CLI, "validate", str(bad)], capture_output=True, text=True,
                       env={**os.environ, "COLUMNS": "300"})
    assert r.returncode == 3
    assert "bad.h5" in r.stderr and "checksum" in r.stderr and r.stdout == ""


def _threads_here() -> tuple[object, ...]:
    from skatelib.pipeline.ocp.threads import stage_threads

    return (*(os.environ.get(v) for v in sweep.THREAD_VARS), stage_threads())


def test_workers_compute_on_one_thread_whatever_the_caller_sets(monkeypatch):
    """The pool's workers (in order and as they finish: the build's, the frontier's and certify's)
    start with BLAS and OpenMP at one thread, so a solve there evaluates its stage derivatives on
    one; the caller keeps its own setting."""
    monkeypatch.setenv("OMP_NUM_THREADS", "7")
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "7")
    assert sweep.run_calls([_threads_here, _threads_here], 2) == [("1", "1", "1", 1)] * 2
    assert list(sweep.in_workers([_threads_here, _threads_here], 2)) == [("1", "1", "1", 1)] * 2
    assert os.environ["OMP_NUM_THREADS"] == "7"


def test_resume_uses_the_cache_and_gives_the_same_library(built, cache, tmp_path):
    """A second build finds every entry in the cache and writes identical trajectories."""
    out, _ = built
    cfg = load_config(TINY)
    events: list[tuple[str, bool]] = []
    threads = {v: os.environ.get(v) for v in sweep.THREAD_VARS}
    report = build_library(cfg, tmp_path / "again.h5", BuildOptions(jobs=1),
                           on_entry=lambda ev: events.append((ev.key, not ev.done)))
    assert {v: os.environ.get(v) for v in sweep.THREAD_VARS} == threads  # a serial build leaves the caller's env
    assert all(o.cached for o in report.outcomes)
    # The progress hears of each entry as it starts (in flight) and as it ends, in that order.
    assert events == [("v0.30_s1", True), ("v0.30_s1", False), ("v0.40_s1", True), ("v0.40_s1", False)]
    a, b = MotionLibrary.open(out), MotionLibrary.open(report.path)
    for e in a:
        assert np.array_equal(e.state, b[e.key].state)


def test_interrupted_build_leaves_no_file(cache, tmp_path, monkeypatch):
    """Ctrl-C during the sweep leaves no library file behind."""
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("skatelib.pipeline.build.orchestrate.run_sweep", interrupted)
    with pytest.raises(KeyboardInterrupt):
        build_library(load_config(TINY), tmp_path / "x.h5")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_failed_entry_is_recorded_and_exit_code_is_nonzero(cache, tmp_path):
    """An unreachable target is stored with success=false and its status; the command exits 1,
    or 0 with --allow-failures."""
    cfg_path = tmp_path / "fail.toml"
    cfg_path.write_text(f'extends = "{TINY.as_posix()}"\n[optimization]\nmax_iter = 3\n'
                        '[sweep]\nvelocities_mps = [0.3]\nstrides = [1]\n')
    out = tmp_path / "fail.h5"
    env = {**os.environ, "COLUMNS": "200"}
    r = subprocess.run([*CLI, "build", str(cfg_path), "-o", str(out), "--no-progress", "--no-cache"],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "failed" in r.stdout
    row = next(line for line in r.stdout.splitlines() if "v0.30_s1" in line and "Maximum" in line)
    cells = [c.strip() for c in row.split("│")[1:-1]]
    assert cells[-6:] == ["-"] * 6  # a failed row shows its status, not speeds or an off-label figure
    e = MotionLibrary.open(out)["v0.30_s1"]
    assert not e.success and e.attrs["status"] == "Maximum_Iterations_Exceeded"
    assert e.attrs["attempts"] == 3
    r2 = subprocess.run([*CLI, "build", str(cfg_path), "-o", str(out), "--no-progress", "--no-cache",
                         "--allow-failures"], capture_output=True, text=True, env=env)
    assert r2.returncode == 0
    # A library with no solved entry is of no use: validate and track say so and exit 1 (both
    # passed it: "all entries valid", an empty table).
    v = subprocess.run([*CLI, "validate", str(out)], capture_output=True, text=True, env=env)
    assert v.returncode == 1 and "no entry of this library was solved" in v.stdout, v.stdout + v.stderr
    t = subprocess.run([*CLI, "track", str(out)], capture_output=True, text=True, env=env)
    assert t.returncode == 1 and "nothing to track" in t.stderr, t.stdout + t.stderr
    # plot draws no failed trajectory as if it were a motion; inspect marks it FAILED.
    p = subprocess.run([*CLI, "plot", str(out), "-o", str(tmp_path / "fig")], capture_output=True, text=True, env=env)
    assert p.returncode == 1 and "no entry of this library was solved" in p.stdout, p.stdout + p.stderr
    assert not (tmp_path / "fig").exists()  # nothing drawn: no folder made (figures are all or none)
    rrd = tmp_path / "fail.rrd"
    i = subprocess.run([*CLI, "inspect", str(out), "--save", str(rrd)], capture_output=True, text=True, env=env)
    assert i.returncode == 0 and "marked FAILED" in i.stdout and "v0.30_s1" in i.stdout, i.stdout + i.stderr
    assert b"**FAILED**" in rrd.read_bytes()


@pytest.mark.slow
def test_dask_cluster_gives_the_same_library(built, cache, tmp_path):
    """The sweep on a dask LocalCluster (loopback) writes the same trajectories as loky."""
    distributed = pytest.importorskip("distributed")
    out, _ = built
    cfg = load_config(TINY)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        report = build_library(cfg, tmp_path / "dask.h5",
                               BuildOptions(backend="dask", scheduler=cluster.scheduler_address, cache=False))
    a, b = MotionLibrary.open(out), MotionLibrary.open(report.path)
    for e in a:
        assert np.allclose(e.state, b[e.key].state, atol=1e-9)
    assert not any(o.cached for o in report.outcomes)


def test_retry_ladder_goes_cold_then_other_guesses():
    """The ladder after a warm start: warm, cold ramp, cold hold, longer adaptive run from IPOPT's
    own bound multipliers, barrier ceiling and floor (the config's are for a first try)."""
    cfg = load_config(TINY)
    spec = PushoffSpec(cfg, 0.3, 1, warm=WarmStart(np.zeros(1), np.zeros(1), np.zeros(1), 0.0, 0.2))
    ladder = retry_ladder(spec)
    assert [s.warm is not None for s in ladder] == [True, False, False, False]
    assert [s.guess for s in ladder] == ["ramp", "ramp", "hold", "ramp"]
    assert ("mu_strategy", "adaptive") in ladder[-1].ipopt
    assert solver_options(ladder[-1])["bound_mult_init_val"] == 1.0
    assert solver_options(ladder[-1])["mu_max"] == 1e5
    assert solver_options(ladder[-1])["mu_min"] == 1e-11
    assert solver_options(ladder[1])["mu_max"] == cfg.optimization.mu_max
    assert solver_options(ladder[1])["mu_min"] == cfg.optimization.mu_min == 1e-8
    assert solver_options(ladder[1])["bound_mult_init_val"] == cfg.optimization.bound_mult_init


def test_solve_command_writes_a_one_entry_library(cache, tmp_path):
    """`skatelib solve --velocity 0.35 --strides 1 --config tiny -o x.h5` writes one valid entry."""
    out = tmp_path / "one.h5"
    r = subprocess.run([*CLI, "solve", "--velocity", "0.35", "--strides", "1", "--config", str(TINY), "-o", str(out)],
                       capture_output=True, text=True, env={**os.environ, "COLUMNS": "200"})
    assert r.returncode == 0, r.stdout + r.stderr
    lib = MotionLibrary.open(out)
    assert lib.keys() == ["v0.35_s1"] and lib["v0.35_s1"].success
    assert lib["v0.35_s1"].channel("board_vx")[-1] == pytest.approx(0.35, rel=0.02)


@pytest.mark.slow
def test_build_without_a_c_compiler_warns_and_still_solves(tmp_path):
    """No C compiler on PATH ($CC pointing nowhere): the build says so on stderr, solves with the
    interpreted stage functions and writes the library."""
    cfg = tmp_path / "compiled.toml"
    cfg.write_text(f'extends = "{TINY.as_posix()}"\n[optimization]\ncompile = true\n[sweep]\nvelocities_mps = [0.3]\n')
    env = {**os.environ, "COLUMNS": "200", "SKATELIB_CACHE_DIR": str(tmp_path / "cache"),
           "CC": str(tmp_path / "no-cc"), "PATH": str(tmp_path)}
    r = subprocess.run([*CLI, "build", str(cfg), "-o", str(tmp_path / "a.h5"), "--no-progress"],
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "no C compiler found" in r.stderr and MotionLibrary.open(tmp_path / "a.h5")["v0.30_s1"].success


@pytest.mark.slow
def test_build_with_frontier_stores_the_search(cache, tmp_path, monkeypatch):
    """`build --frontier` (BuildOptions.frontier) searches each stride count's fastest passing label
    and stores it: the fastest is a probe that passed, the first failure one that did not, and they
    bracket within the resolution (a coarse search here, to keep the test short: one climb past the
    frontier and one bisection; the finer search is tests/test_transitions.py's)."""
    from skatelib.pipeline.quadruped import frontier as frontier_module
    from skatelib.pipeline.quadruped.frontier import FrontierSearch

    monkeypatch.setattr(frontier_module, "FrontierSearch",
                        lambda: FrontierSearch(start_mps=0.75, step_mps=0.5, resolution_mps=0.3, max_mps=1.75))
    cfg = load_config(TINY)  # a probe past the frontier runs to the iteration limit: a lower one keeps it short
    cfg = dataclasses.replace(cfg, optimization=dataclasses.replace(cfg.optimization, max_iter=60))
    report = build_library(cfg, tmp_path / "f.h5", BuildOptions(jobs=1, frontier=True))
    stored = json.loads(MotionLibrary.open(report.path).attrs["frontier_json"])
    (point,) = stored["points"]
    ok = {p["velocity_mps"] for p in point["probes"] if p["ok"]}
    bad = {p["velocity_mps"] for p in point["probes"] if not p["ok"]}
    assert point["n_strides"] == 1 and point["fastest_mps"] in ok and point["first_failure_mps"] in bad
    assert 0 < point["first_failure_mps"] - point["fastest_mps"] <= 0.3
    assert len(point["probes"]) == 3  # 0.75 passes, 1.25 fails, the bisection's 1.0 fails
    assert report.frontier is not None and report.frontier[0].fastest_mps == point["fastest_mps"]
