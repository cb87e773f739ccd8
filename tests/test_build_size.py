"""A build's size is estimated before any work and a build beyond the bounds is refused unless
``--yes``: a config with every figure in range (a 5 s period at 5 ms steps over 20 strides, 20
substeps) is 20,001 knots, a million variables in one solve; it had used 1.8 GB within 40 s while
still compiling, without a word, and 5,920 entries were accepted as readily. The refusal (exit 2)
names the config, the estimate, the bounds and --yes; with --yes the build goes on to its work
(stopped here where the sweep would start). The shipped configs pass without --yes."""

from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path

import pytest
from skatelib.pipeline.build.contract import BuildOptions
from skatelib.pipeline.build.size import MAX_ENTRIES, MAX_SOLVE_VARIABLES, BuildTooLarge, check_size
from skatelib.pipeline.config import load_config
from skatelib.pipeline.kinds import kind_of
from skatelib.pipeline.quadruped.size import VARIABLES_PER_KNOT, build_size, knots

from tests.helpers import CLI

ROOT = Path(__file__).parents[1]
SHIPPED = sorted((ROOT / "configs").glob("*.toml")) + sorted((ROOT / "tests" / "configs").glob("*.toml"))
HUGE_SOLVE = """
[schedule]
period_s = 5.0

[optimization]
dt_s = 0.005
substeps = 20

[sweep]
strides = [20]
"""
# 296 speeds (every key with two decimals from 0.05 to 3.00 m/s) x 20 stride counts
MANY_ENTRIES = f"""
[sweep]
velocities_mps = [{", ".join(f"{v / 100:.2f}" for v in range(5, 301))}]
strides = [{", ".join(str(s) for s in range(1, 21))}]

[transitions]
speeds_mps = []
"""


def _config(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "big.toml"
    path.write_text(f'extends = "{ROOT / "configs" / "cyberdog2.toml"}"\n\n[meta]\nkind = "quadruped"\n'
                    f'name = "big"\n{text}')
    return path


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_the_shipped_configs_are_within_the_bounds(path):
    cfg = load_config(path)
    if cfg.meta.kind == "quadruped":
        size = build_size(cfg)
        assert size.entries <= MAX_ENTRIES and size.largest_variables <= MAX_SOLVE_VARIABLES
        check_size(cfg.path, size, yes=False)
    else:
        kind_of(cfg).check(cfg, BuildOptions())


def test_the_estimate_counts_knots_as_the_schedule_does(tmp_path):
    """The default: 18 start-ups and 25 transitions; its largest solve a 4-stride transition, 0.3 s
    of lead-in and 4 periods of 1.2 s at 0.03 s (171 knots, as the transitions' schedule has)."""
    from skatelib.pipeline.quadruped.model.schedule import knot_schedule

    cfg = load_config(ROOT / "configs" / "cyberdog2.toml")
    size = build_size(cfg)
    assert size.entries == 43 and size.largest_knots == 171 and VARIABLES_PER_KNOT == 52
    assert knots(cfg, 3) == len(knot_schedule(cfg.schedule, 3, cfg.optimization.dt_s).t)
    big = build_size(load_config(_config(tmp_path, HUGE_SOLVE)))
    assert big.largest_knots == 20 * 1000 + 1  # a 20-stride start-up: 1000 knots a period at 5 ms


@pytest.mark.parametrize(("text", "says"), [(HUGE_SOLVE, "20,001 knots x 52 variables"),
                                            (MANY_ENTRIES, "5,920 entries")])
def test_a_build_beyond_the_bounds_is_refused_at_once(tmp_path, text, says):
    """`skatelib build` of it: exit 2 within a minute (the import and the config), one message with
    the estimate, the bounds and --yes; no library, nothing compiled."""
    cache = tmp_path / "cache"
    t0 = time.monotonic()
    r = subprocess.run([*CLI, "build", str(_config(tmp_path, text)), "-o", str(tmp_path / "big.h5"), "--no-progress"],
                       capture_output=True, text=True, timeout=300,
                       env={**os.environ, "SKATELIB_CACHE_DIR": str(cache), "COLUMNS": "200"})
    assert r.returncode == 2, r.stdout + r.stderr
    assert time.monotonic() - t0 < 60
    assert says in r.stderr and "100,000" in r.stderr and "500" in r.stderr and "--yes" in r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "big.h5").exists()
    assert not list(cache.rglob("stage_*"))


class _WorkStarts(Exception):
    """Raised where the build's work (compile, sweep) would start."""


@pytest.mark.parametrize("command", [["build"], ["solve", "-V", "0.5", "-s", "20"], ["frontier", "-s", "20"]])
def test_yes_goes_on_to_the_work(tmp_path, monkeypatch, command):
    """Without --yes the command refuses (BuildTooLarge); with --yes it reaches the point where the
    work starts (stopped there)."""
    from skatelib.pipeline.build import orchestrate
    from skatelib.pipeline.cli.app import app
    from skatelib.pipeline.quadruped import frontier
    from typer.testing import CliRunner

    def stop(*args: object, **kw: object) -> None:
        raise _WorkStarts

    monkeypatch.setenv("SKATELIB_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(orchestrate, "build_library", stop)
    monkeypatch.setattr(frontier, "find_frontier", stop)
    config = str(_config(tmp_path, HUGE_SOLVE))
    args = [*command, config, "-o", str(tmp_path / "out.h5" if command[0] != "frontier" else tmp_path / "f.json")]
    if command[0] == "build":
        args.append("--no-progress")
    refused = CliRunner().invoke(app, args)
    assert isinstance(refused.exception, BuildTooLarge), refused.output
    assert "--yes" in str(refused.exception) and config in str(refused.exception)
    went_on = CliRunner().invoke(app, [*args, "--yes"])
    assert isinstance(went_on.exception, _WorkStarts), (went_on.output, went_on.exception)
