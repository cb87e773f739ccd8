"""``skatelib build --profile``: a build's time cut into phases that add up to its workers' time,
checked on spans of known length and on the session's tiny build (whose worker's spans must reach
the profile)."""

from __future__ import annotations

import dataclasses
import json
import os

import pytest
from skatelib.pipeline.build.contract import BuildOptions
from skatelib.pipeline.build.profile import ENV, profiling, span, summarize
from skatelib.pipeline.build.sweep import run_sweep

from tests.helpers import TINY, run_cli


def _span(phase: str, start: float, end: float, pid: int, **fields: object) -> dict[str, object]:
    return {"phase": phase, "start": start, "end": end, "pid": pid, **fields}


def test_the_phases_of_known_spans():
    """A 10 s build on two workers: worker 1 solves a start-up (3 s) and checks it (1 s) in a task
    of 8 s; worker 2 tries a transition in one stride (solved in 1 s, refused by the twin after a
    1 s ride), then in two (a failed attempt of 1 s, the converged one of 1 s, checks 0.5 s, a
    ride 0.5 s) in a task of 5 s."""
    s = [_span("build", 0, 10, 1), _span("prepare", 0, 1, 1), _span("sweep", 1, 9, 1), _span("write", 9, 10, 1),
         _span("task", 1, 9, 2), _span("attempt", 1, 4, 2, success=True, task="start-up"),
         _span("checks", 4, 5, 2),
         _span("task", 1, 6, 3),
         _span("candidate", 1, 3, 3, accepted=False), _span("attempt", 1, 2, 3, success=True, task="transition"),
         _span("twin", 2, 3, 3, refused=True),
         _span("candidate", 3, 6, 3, accepted=True), _span("attempt", 3, 4, 3, success=False, task="transition"),
         _span("attempt", 4, 5, 3, success=True, task="transition"), _span("checks", 5, 5.5, 3),
         _span("twin", 5.5, 6, 3, refused=False)]
    rows, wall = summarize(s, jobs=2)
    got = {r.phase.split(" (")[0]: round(r.seconds, 9) for r in rows}
    assert wall == 10
    assert got == {"compile": 1, "start-up solves": 3, "transition solves": 1, "failed attempts": 1,
                   "physics checks": 1.5, "twin rides": 0.5, "refused candidates": 2, "other work in tasks": 4,
                   "workers idle": 3, "writing": 1}
    sweep_rows = [r.seconds for r in rows if not r.phase.endswith("process)")]
    assert sum(sweep_rows) == pytest.approx(2 * 8)  # two workers through the 8 s sweep


def test_a_profile_without_a_build_span_is_refused():
    with pytest.raises(ValueError, match="no build span"):
        summarize([_span("task", 0, 1, 2)], jobs=1)


def test_the_tiny_builds_profile_adds_up(tiny_build):
    """The session's tiny build (``--jobs 2 --profile``, one task: joblib runs it in the build's
    process): both entries' attempts were recorded inside the task; the phases add up to the sweep's
    worker time; the table was printed."""
    doc = json.loads((tiny_build.path.parent / "profile.json").read_text())
    spans = doc["spans"]
    (build,) = [s for s in spans if s["phase"] == "build"]
    tasks = [s for s in spans if s["phase"] == "task"]
    attempts = [s for s in spans if s["phase"] == "attempt"]
    assert len(tasks) == 1
    assert sorted(a["key"] for a in attempts if a["success"]) == ["v0.30_s1", "v0.40_s1"]
    assert all(any(a["pid"] == t["pid"] and t["start"] <= a["start"] <= a["end"] <= t["end"] for t in tasks)
               for a in attempts)
    phases = {p["phase"]: p["seconds"] for p in doc["phases"]}
    (sweep,) = [s for s in spans if s["phase"] == "sweep"]
    in_sweep = sum(v for k, v in phases.items() if not k.endswith("process)"))
    assert in_sweep == pytest.approx(len(tasks) * (sweep["end"] - sweep["start"]), rel=1e-9)
    assert phases["start-up solves"] > 0 and phases["workers idle"] >= 0
    assert doc["wall_s"] == pytest.approx(build["end"] - build["start"])
    assert "where the build's time went" in tiny_build.stdout


@dataclasses.dataclass(frozen=True)
class _Spanned:
    """A build task that records one span and returns its process."""

    name: str
    n_entries: int = 1

    def run(self, use_cache: bool, events: object) -> list[int]:
        with span(self.name):
            return [os.getpid()]


def test_the_workers_spans_reach_the_profile():
    """Spans recorded in the sweep's loky workers are in the profile, also when the workers were
    started before it (loky reuses them); after it, they record nothing."""
    tasks = [_Spanned("a"), _Spanned("b")]
    run_sweep(tasks, BuildOptions(jobs=2, cache=False))  # workers started outside any profile
    with profiling() as spans:
        pids = run_sweep(tasks, BuildOptions(jobs=2, cache=False))
    assert os.getpid() not in pids
    mine = [s for s in spans if s["phase"] in ("a", "b")]
    assert sorted(s["pid"] for s in mine) == sorted(pids) and len({s["phase"] for s in mine}) == 2
    assert sorted(s["pid"] for s in spans if s["phase"] == "task") == sorted(pids)
    assert ENV not in os.environ
    with profiling() as after:
        pass
    run_sweep(tasks, BuildOptions(jobs=2, cache=False))
    assert after == []


def test_a_profile_of_a_cluster_build_is_refused(tmp_path):
    r = run_cli(["build", str(TINY), "-o", str(tmp_path / "x.h5"), "--profile", str(tmp_path / "p.json"),
                 "--backend", "dask", "--scheduler", "tcp://127.0.0.1:1"])
    assert r.returncode == 2 and "--profile" in r.stderr and "dask" in r.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("case", ["the library", "the config", "a foreign file", "a folder", "under a file"])
def test_a_profile_file_that_cannot_be_written_is_refused_before_the_build(tmp_path, case):
    """Every file the build would write is checked before any solve: the profile may not replace the
    library it profiles, the config, or a file of another type, nor go where nothing can be written."""
    lib, foreign = tmp_path / "x.h5", tmp_path / "notes.txt"
    foreign.write_text("mine")
    config = tmp_path / "tiny.toml"
    config.write_text(TINY.read_text().replace('extends = "../../', f'extends = "{TINY.parents[2]}/'))
    profile = {"the library": lib, "the config": config, "a foreign file": foreign, "a folder": tmp_path,
               "under a file": foreign / "p.json"}[case]
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    r = run_cli(["build", str(config), "-o", str(lib), "--profile", str(profile), "--no-progress"])
    assert r.returncode == 2, r.stderr
    assert str(profile.name) in r.stderr and "Traceback" not in r.stderr
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before  # nothing built, nothing replaced
