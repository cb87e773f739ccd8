"""The same argument rules across commands: a worker count below one is refused by every command
that takes one, a ``--perturb`` key given twice is refused naming the key (the parser kept the
last one silently), every numeric option refuses NaN, infinities and values beyond its range, and a
``--perturb`` that names nothing or a value out of range is refused before any work."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from tests.helpers import CLI


@pytest.mark.parametrize("command", [["build"], ["track", "lib.h5"], ["validate", "lib.h5", "--closed-loop"]])
@pytest.mark.parametrize("jobs", ["0", "-1"])
def test_a_worker_count_below_one_is_refused(tmp_path, command, jobs):
    run = subprocess.run([*CLI, *command, "-j", jobs], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert run.returncode == 2, run.stderr
    assert "-j" in run.stderr or "--jobs" in run.stderr


def test_a_twin_perturbation_key_given_twice_is_refused():
    pytest.importorskip("mujoco")
    from skatelib.sim.errors import TwinPerturbationError, parse_twin_perturbation

    with pytest.raises(TwinPerturbationError, match="kb is given twice"):
        parse_twin_perturbation("kb=-20%,mass=+10%,kb=-30%", 0.6)
    assert parse_twin_perturbation("kb=-20%,mass=+10%", 0.6) is not None


REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"
LIB = "LIB"  # a copy of the reference (validate --closed-loop would write into the file, were it to run)


@pytest.fixture
def lib_copy(tmp_path):
    path = tmp_path / "lib.h5"
    shutil.copyfile(REFERENCE, path)
    return str(path)


@pytest.mark.parametrize(("args", "option"), [
    (["frontier", "-s", "0"], "--strides"),  # an IndexError
    (["frontier", "-s", "21"], "--strides"),
    (["frontier", "--from", "nan"], "--from"),
    (["frontier", "--start", "inf"], "--start"),
    (["solve", "-V", "nan", "-s", "1"], "--velocity"),
    (["solve", "-V", "0.5", "-s", "0"], "--strides"),
    (["track", LIB, "--seed", "-1"], "--seed"),  # numpy's error, after the command had started
    (["track", LIB, "--mpc-mu", "nan"], "--mpc-mu"),
    (["track", LIB, "-j", "100000"], "--jobs"),
    (["diff", LIB, LIB, "--atol", "nan"], "--atol"),
    (["diff", LIB, LIB, "--atol", "inf"], "--atol"),
    (["diff", LIB, LIB, "--rtol", "-1"], "--rtol"),
    (["build", "--check", LIB, "--rtol", "nan"], "--rtol"),
    (["validate", LIB, "--closed-loop", "-j", "1000"], "--jobs"),
])
def test_a_number_out_of_its_range_is_a_usage_error(args, option, lib_copy):
    """Each numeric option refuses NaN, infinities and values beyond its stated range: exit 2 naming
    the option, before any work."""
    from skatelib.pipeline.cli.app import app
    from typer.testing import CliRunner

    r = CliRunner().invoke(app, [lib_copy if a == LIB else a for a in args])
    assert r.exit_code == 2, r.output
    assert option in r.output and "Traceback" not in r.output


@pytest.mark.parametrize("command", [["track", LIB], ["validate", LIB, "--closed-loop"]])
@pytest.mark.parametrize("text", ["", " ", ",", " , "])
def test_a_perturbation_naming_nothing_is_refused(command, text, lib_copy):
    """`--perturb ''` ran the plant as planned and passed: exit 2 saying to write 'none' for that."""
    from skatelib.pipeline.cli.app import app
    from typer.testing import CliRunner

    r = CliRunner().invoke(app, [lib_copy if a == LIB else a for a in command] + ["--perturb", text])
    assert r.exit_code == 2 and "--perturb" in r.output and "'none'" in r.output, r.output


def test_a_perturbation_out_of_range_is_refused_before_any_ride():
    """`track --perturb noise=-1` (taken as no noise) and `mass=1e308` (a speed of nan): exit 2,
    one message naming the key, the value and the range, on either plant."""
    for plant in ("model", "mujoco"):
        for text, says in (("noise=-1", "noise would be -1"), ("mass=1e308", "mass would be")):
            r = subprocess.run([*CLI, "track", str(REFERENCE), "--plant", plant, "--perturb", text],
                               capture_output=True, text=True, timeout=120)
            assert r.returncode == 2, r.stdout + r.stderr
            assert says in r.stderr and "allowed:" in r.stderr and "Traceback" not in r.stderr


def test_validate_refuses_a_bad_perturbation_before_checking(lib_copy):
    """`validate --closed-loop --perturb noise=-1`: exit 2 before the physics checks and any ride
    (the perturbation was read after them), the file untouched."""
    before = Path(lib_copy).read_bytes()
    r = subprocess.run([*CLI, "validate", lib_copy, "--closed-loop", "--perturb", "noise=-1"], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 2 and "noise would be -1" in r.stderr, r.stdout + r.stderr
    assert "valid" not in r.stdout and Path(lib_copy).read_bytes() == before


def test_the_twin_rides_on_the_estimate_unless_told_and_refuses_noise_it_would_not_read(lib_copy):
    """`track --plant mujoco` and `skatelib.track(plant="mujoco")` feed the controller the estimate
    unless `--state true`; there `--perturb noise=`/`delay=` (noise and delay on the twin's own
    state, which the estimate never reads) are refused naming the sensors' keys, exit 2, before any
    ride; with `--state true` they are accepted (the command goes on to its entries, stopped here by
    an unknown entry key)."""
    import inspect

    import skatelib
    from skatelib.pipeline.cli.app import app
    from skatelib.pipeline.cli.track_commands import StateKind, track
    from typer.testing import CliRunner

    assert inspect.signature(track).parameters["state"].default is StateKind.estimate
    assert inspect.signature(skatelib.track).parameters["state"].default == "estimate"
    for text, instead in (("noise=0.001", "imu_noise"), ("mass=+5%,delay=0.004", "sensor_delay")):
        r = subprocess.run([*CLI, "track", lib_copy, "--plant", "mujoco", "--perturb", text], capture_output=True,
                           text=True, timeout=120)
        assert r.returncode == 2 and instead in r.stderr and "--state true" in r.stderr, r.stdout + r.stderr
        with pytest.raises(skatelib.SkatelibError, match=instead):
            skatelib.track(lib_copy, plant="mujoco", perturb=text)
        told = CliRunner().invoke(app, ["track", lib_copy, "--plant", "mujoco", "--state", "true", "--perturb", text,
                                        "-e", "v9.99_s9"])
        assert "v9.99_s9" in str(told.exception) + told.output and instead not in told.output, told.output


@pytest.mark.parametrize(("args", "words"), [
    (["--plant", "mujoco", "-e", "v0.30_s1", "--draw", "5", "--save", "x.rrd"], "leave out --save"),
    (["--plant", "mujoco", "-e", "v0.30_s1", "--draw", "5", "--perturb", "mu=0.4", "--seed", "3"],
     "leave out --perturb, --seed"),
    (["--plant", "mujoco", "-e", "v0.30_s1", "--draw", "5", "--report", "r.html"], "leave out --report"),
    (["--maneuver", "steer", "--save", "x.rrd"], "records none: leave out --save"),
    (["--maneuver", "steer", "-e", "v0.30_s1"], "leave out --entry"),
    (["--plant", "mujoco", "--maneuver", "steer", "-e", "v0.30_s1"], "leave out --entry"),
    (["-e", "v0.30_s1", "--state", "true"], "add --plant mujoco"),
])
def test_options_a_ride_would_leave_unused_are_refused(tmp_path, args, words):
    """A certificate's draw rides as drawn (its errors, noise, state; no recording or report), the
    steering maneuver rides no entry and records nothing, the model plant feeds its own state:
    each option they would leave unused is refused, named, before any ride (it was dropped
    without a word)."""
    pytest.importorskip("mujoco")
    lib = tmp_path / "lib.h5"
    shutil.copyfile(REFERENCE, lib)
    r = subprocess.run([*CLI, "track", str(lib), *args], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 2 and words in " ".join(r.stderr.split()), r.stdout + r.stderr
    assert not (tmp_path / "x.rrd").exists() and not (tmp_path / "r.html").exists()


@pytest.mark.parametrize(("command", "words"), [
    (["validate", "LIB", "--plant", "mujoco"], "add --closed-loop"),
    (["validate", "LIB", "--perturb", "mu=0.3"], "add --closed-loop"),
    (["certify", "LIB", "-e", "v0.30_s1", "--samples", "1", "--scheduler", "tcp://127.0.0.1:8786"],
     "add --backend dask"),
    (["build", "--scheduler", "tcp://127.0.0.1:8786"], "add --backend dask"),
    (["track", "LIB", "-e", "v0.30_s1", "--save", "ride.txt"], "ending in .rrd"),
])
def test_an_option_of_another_mode_is_refused_naming_what_to_add(tmp_path, command, words):
    """Options whose help says what they go with, given without it (the closed loop's plant and
    errors, a dask scheduler, a recording not named .rrd), are refused, not left unused."""
    lib = tmp_path / "lib.h5"
    shutil.copyfile(REFERENCE, lib)
    line = [str(lib) if a == "LIB" else a for a in command]
    r = subprocess.run([*CLI, *line], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 2 and words in " ".join(r.stderr.split()), r.stdout + r.stderr
    assert not (tmp_path / "ride.txt").exists()
