"""The same argument rules across commands: a worker count below one is refused by every command
that takes one, and a ``--perturb`` key given twice is refused naming the key (the parser kept the
last one silently)."""

from __future__ import annotations

import subprocess

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
