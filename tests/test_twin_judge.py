"""The physical twin as the build's judge of transitions (``[transitions] twin_judge``): a real build
of one speed-up and one slow-down (0.3 <-> 0.4 m/s, one stride), judged on the MuJoCo twin under
the default model-error set, then under a floor too slippery to push or brake on (the negative
control: the twin refuses both and the build stores them failed, with the twin's reasons)."""

from __future__ import annotations

from pathlib import Path

import pytest
from skatelib.library.errors import ConfigError
from skatelib.pipeline.build.contract import BuildOptions
from skatelib.pipeline.build.orchestrate import build_library
from skatelib.pipeline.config import load_config
from skatelib.pipeline.quadruped.transitions.twin_judge import TWIN_REFUSED, check_twin_judge
from skatelib.runtime import MotionLibrary

pytest.importorskip("mujoco")
from skatelib.sim.errors import DEFAULT_TWIN_PERTURBATION

TINY_RIDE = Path(__file__).parent / "configs" / "tiny_ride.toml"


def _config(tmp_path: Path, judge: list[str]):
    path = tmp_path / f"judge{len(list(tmp_path.glob('*.toml')))}.toml"
    sets = ", ".join(f'"{s}"' for s in judge)
    path.write_text(f'extends = "{TINY_RIDE}"\n\n[meta]\nname = "judge"\n\n[transitions]\nstops = false\n'
                    f"twin_judge = [{sets}]\n")
    return load_config(path)


def test_a_bad_error_set_is_refused_before_any_solve(tmp_path):
    cfg = _config(tmp_path, ["mass=+10%", "gravity=2"])
    with pytest.raises(ConfigError, match=r"transitions\.twin_judge.*gravity") as e:
        check_twin_judge(cfg)
    assert str(cfg.path) in str(e.value)


@pytest.mark.parametrize(("judge", "says"), [("", "names no model error"), (" , ", "names no model error"),
                                            ("mass=1e308", "allowed: 0.1x to 10x")])
def test_an_empty_or_out_of_range_error_set_is_refused(tmp_path, judge, says):
    """An error set naming nothing (it judged on the twin as planned under the name '') or a value
    out of its range: refused naming the config and the field."""
    cfg = _config(tmp_path, [judge])
    with pytest.raises(ConfigError, match=rf"transitions\.twin_judge.*{says}"):
        check_twin_judge(cfg)


@pytest.mark.slow
def test_the_twin_keeps_what_it_rides_and_refuses_what_it_cannot(tmp_path, monkeypatch):
    monkeypatch.setenv("SKATELIB_CACHE_DIR", str(tmp_path / "cache"))  # the second build reuses the solves
    opts = BuildOptions(jobs=1, cache=True, progress=False)
    good = build_library(_config(tmp_path, [DEFAULT_TWIN_PERTURBATION]), tmp_path / "good.h5", opts)
    lib = MotionLibrary.open(good.path)
    keys = ["v0.30-0.40_s1", "v0.40-0.30_s1"]
    assert all(lib[k].success for k in keys), [lib[k].attrs["status"] for k in keys]
    slippery = build_library(_config(tmp_path, ["mu=0.05"]), tmp_path / "bad.h5", opts)
    lib = MotionLibrary.open(slippery.path)
    for k in keys:
        status = str(lib[k].attrs["status"])
        assert not lib[k].success and status.startswith(f"{TWIN_REFUSED}: mu=0.05: "), status
    assert any("the twin refused 1 stride" in o.note for o in slippery.outcomes)


def _verdict(target: float, delivered: float):
    from types import SimpleNamespace

    err = (delivered - target) / target if target else delivered
    return SimpleNamespace(target_velocity_mps=target, delivered_mps=delivered, speed_error=err)


@pytest.mark.parametrize(("target", "delivered", "share", "refused"), [
    (0.8, 0.8 * (1 - 0.0498), 0.8, True),  # the one-stride 0.3 -> 0.8 of the default build: -4.98 %
    (0.8, 0.8 * (1 - 0.0378), 0.8, False),  # the one-stride 0.7 -> 1.0's -3.78 %, scaled
    (0.8, 0.8 * (1 + 0.041), 0.8, True),  # too fast alike
    (0.8, 0.8 * (1 - 0.0498), 1.0, False),  # the whole tolerance: the verdict's own bound
    (0.0, 0.045, 0.8, True),  # a stop still riding at 0.045 m/s: within track's 0.05, beyond 0.04
    (0.0, -0.045, 0.8, True),
    (0.0, 0.03, 0.8, False),
])
def test_the_judge_keeps_a_margin_inside_the_verdicts_speed_bound(target, delivered, share, refused):
    """A candidate the verdict passes is kept only with its delivered speed within ``twin_speed_share``
    of the verdict's tolerance (5 % of the label, a stop 0.05 m/s); the refusal says by how much."""
    from skatelib.pipeline.quadruped.transitions.twin_judge import speed_margin_refusal

    why = speed_margin_refusal(_verdict(target, delivered), share)
    assert bool(why) == refused, why
    if refused:
        assert f"twin_speed_share {share}" in why and "within track's" in why, why


@pytest.mark.parametrize("share", [0.0, 1.5])
def test_a_speed_share_out_of_range_is_refused(tmp_path, share):
    path = tmp_path / "share.toml"
    path.write_text(f'extends = "{TINY_RIDE}"\n\n[meta]\nname = "share"\n\n[transitions]\ntwin_speed_share = {share}\n')
    with pytest.raises(ConfigError, match=r"transitions\.twin_speed_share"):
        load_config(path)
