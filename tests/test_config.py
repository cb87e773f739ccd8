"""Config validation: errors name the file and key; extends merges tables."""

from __future__ import annotations

from pathlib import Path

import pytest
from skatelib.library.errors import ConfigError
from skatelib.pipeline.config import CONFIG_DIR, load_config


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "c.toml"
    p.write_text(f'extends = "{(CONFIG_DIR / "cyberdog2.toml").as_posix()}"\n' + text)
    return p


def test_default_config_loads(cfg):
    """The shipped default config validates and points at an existing URDF."""
    assert cfg.urdf_path.is_file()
    assert 0.3 in cfg.sweep.velocities_mps and 0.5 in cfg.sweep.velocities_mps and 0.7 in cfg.sweep.velocities_mps


def test_extends_overrides_one_key(tmp_path):
    """A config extending the default changes only what it sets."""
    c = load_config(_write(tmp_path, "[sweep]\nvelocities_mps = [0.4]\nstrides = [1]\n"))
    assert c.sweep.velocities_mps == (0.4,)
    assert c.board.mass_kg == load_config().board.mass_kg


def test_unknown_key_names_file_key_and_allowed(tmp_path):
    """A misspelt key is refused with the file, the dotted key and the allowed keys."""
    p = _write(tmp_path, "[board]\nmass_kilo = 2.0\n")
    with pytest.raises(ConfigError) as e:
        load_config(p)
    assert e.value.path == p and e.value.key == "board.mass_kilo"
    assert "mass_kg" in str(e.value)


def test_out_of_range_value_is_refused(tmp_path):
    """A negative mass is out of range and the message gives the range."""
    with pytest.raises(ConfigError, match=r"board\.mass_kg.*out of range"):
        load_config(_write(tmp_path, "[board]\nmass_kg = -1.0\n"))


def test_wrong_type_is_refused(tmp_path):
    """A string where a number belongs is refused."""
    with pytest.raises(ConfigError, match="must be a number"):
        load_config(_write(tmp_path, '[robot]\nfriction_mu = "high"\n'))


def test_missing_file_lists_shipped_configs(tmp_path):
    """A config path that does not exist names the shipped configs."""
    with pytest.raises(ConfigError, match=r"cyberdog2\.toml"):
        load_config(tmp_path / "nope.toml")


@pytest.mark.parametrize(("text", "key"), [
    ("[robot]\nfriction_mu = nan\n", "robot.friction_mu"),
    ("[optimization]\ndt_s = inf\n", "optimization.dt_s"),
    ("[sweep]\nvelocities_mps = [0.3, nan]\nstrides = [2]\n", r"sweep.velocities_mps\[1\]"),
])
def test_nan_and_inf_are_refused_with_the_key(tmp_path, text, key):
    """NaN and inf pass every range test (comparisons with NaN are false): refused by name instead."""
    with pytest.raises(ConfigError, match=f"{key}.*finite"):
        load_config(_write(tmp_path, text))


def test_speeds_that_name_the_same_entry_are_refused(tmp_path):
    """0.501 and 0.504 m/s would both be entry v0.50: refused at load, before any solve."""
    with pytest.raises(ConfigError, match=r"sweep\.velocities_mps.*0\.501 and 0\.504.*v0\.50"):
        load_config(_write(tmp_path, "[sweep]\nvelocities_mps = [0.501, 0.504]\nstrides = [2]\n"))
    with pytest.raises(ConfigError, match=r"sweep\.velocities_mps.*0\.3 and 0\.3"):
        load_config(_write(tmp_path, "[sweep]\nvelocities_mps = [0.3, 0.3]\nstrides = [2]\n"))
    with pytest.raises(ConfigError, match=r"sweep\.strides.*repeats"):
        load_config(_write(tmp_path, "[sweep]\nvelocities_mps = [0.3]\nstrides = [2, 2]\n"))


def test_one_loader_for_every_kind_and_the_kind_a_command_needs(tmp_path):
    """load_config reads either kind from meta.kind; with the class a command needs, another kind
    is refused naming meta.kind; config_from_json rebuilds either kind from a library's JSON."""
    from skatelib.pipeline.config import config_from_json
    from skatelib.pipeline.humanoid.config import HumanoidConfig
    from skatelib.pipeline.quadruped.config import QuadrupedConfig

    quad, walk = load_config(None), load_config(CONFIG_DIR / "hrp2_walk.toml")
    assert isinstance(quad, QuadrupedConfig) and isinstance(walk, HumanoidConfig)
    with pytest.raises(ConfigError, match=r"hrp2_walk\.toml.*meta\.kind.*expected 'quadruped'"):
        load_config(CONFIG_DIR / "hrp2_walk.toml", QuadrupedConfig)
    assert config_from_json(walk.resolved_json(), tmp_path / "lib.h5") == walk.__class__(
        path=tmp_path / "lib.h5", text="",
        **{k: getattr(walk, k) for k in ("meta", "humanoid", "gpm", "walk", "skate", "wholebody", "sweep")})
    back = config_from_json(quad.resolved_json(), tmp_path / "lib.h5", quad.urdf_path, QuadrupedConfig)
    assert back.problem_json() == quad.problem_json()
    bad = tmp_path / "k.toml"
    bad.write_text('[meta]\nkind = "hexapod"\nname = "x"\n')
    with pytest.raises(ConfigError, match=r"meta\.kind.*hexapod"):
        load_config(bad)


def test_warm_start_barrier_comes_from_the_config(tmp_path):
    """A warm-started solve runs IPOPT with the config's warm barrier and bound push, a cold one with
    the cold barrier, the config's initial bound multipliers and barrier ceiling, and both the
    config's barrier floor; an unknown warm strategy is refused by its key."""
    import numpy as np
    from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, WarmStart, solver_options

    c = load_config(_write(tmp_path, '[optimization]\nwarm_mu_strategy = "adaptive"\nwarm_mu_init = 3e-5\n'
                                     'bound_mult_init = 2e-3\nwarm_bound_push = 3e-5\nmu_max = 0.5\nmu_min = 3e-9\n'))
    warm = WarmStart(w=np.zeros(3), lam_g=np.zeros(2), lam_x=np.zeros(3), from_velocity_mps=0.0,
                     target_velocity_mps=0.45)
    w_opts, c_opts = solver_options(PushoffSpec(c, 0.5, 2, warm=warm)), solver_options(PushoffSpec(c, 0.5, 2))
    assert (w_opts["mu_strategy"], w_opts["mu_init"], w_opts["warm_start_init_point"]) == ("adaptive", 3e-5, "yes")
    assert (c_opts["mu_strategy"], c_opts["mu_init"]) == (c.optimization.mu_strategy, c.optimization.mu_init)
    assert "warm_start_init_point" not in c_opts
    assert c_opts["bound_mult_init_val"] == 2e-3 and "bound_mult_init_val" not in w_opts
    assert c_opts["mu_max"] == 0.5 and "mu_max" not in w_opts
    assert c_opts["mu_min"] == w_opts["mu_min"] == 3e-9
    assert w_opts["warm_start_bound_push"] == w_opts["warm_start_mult_bound_push"] == 3e-5
    with pytest.raises(ConfigError, match=r"optimization\.warm_mu_strategy.*'fast'"):
        load_config(_write(tmp_path, '[optimization]\nwarm_mu_strategy = "fast"\n'))


@pytest.mark.parametrize("name", ["", "../evil", "a/b", ".hidden", "with space", "x" * 65])
def test_a_name_that_is_no_plain_file_name_is_refused(tmp_path, name):
    """``[meta] name`` makes the default output out/<name>.h5: a name that would put it elsewhere
    (a path, a hidden file, no name) is refused naming the key; the shipped names pass."""
    cfg = tmp_path / "n.toml"
    cfg.write_text('extends = "skatelib:cyberdog2.toml"\n\n[meta]\nkind = "quadruped"\n'
                   f'name = "{name}"\n')
    with pytest.raises(ConfigError, match=r"meta\.name.*plain file name") as e:
        load_config(cfg)
    assert e.value.path == cfg
    for shipped in CONFIG_DIR.glob("*.toml"):
        load_config(shipped)


def test_a_config_without_its_kind_says_what_to_write(tmp_path):
    empty = tmp_path / "empty.toml"
    empty.write_text("")
    with pytest.raises(ConfigError, match=r"meta\.kind.*missing.*kind = one of 'quadruped'"):
        load_config(empty)


def test_an_error_in_a_base_config_names_the_base(tmp_path):
    """A bad key that a file of the ``extends`` chain writes is blamed on that file, not on the
    config that extends it; one the extending config writes stays its own."""
    base, child = tmp_path / "base.toml", tmp_path / "child.toml"
    base.write_text('extends = "skatelib:cyberdog2.toml"\n\n[optimization]\ndt_s = -0.03\n')
    child.write_text('extends = "base.toml"\n\n[meta]\nkind = "quadruped"\nname = "c"\n')
    with pytest.raises(ConfigError, match=r"optimization\.dt_s.*child\.toml extends") as e:
        load_config(child)
    assert e.value.path == base.resolve()
    child.write_text(child.read_text() + "\n[board]\nmass_kgg = 2.0\n")
    base.write_text('extends = "skatelib:cyberdog2.toml"\n')
    with pytest.raises(ConfigError, match=r"board\.mass_kgg") as e:
        load_config(child)
    assert e.value.path == child


def test_a_base_that_cannot_be_read_is_named_by_the_extends_key(tmp_path):
    child = tmp_path / "child.toml"
    child.write_text('extends = "nope.toml"\n\n[meta]\nkind = "quadruped"\nname = "c"\n')
    with pytest.raises(ConfigError, match=r"'nope\.toml'.*cannot be read") as e:
        load_config(child)
    assert (e.value.path, e.value.key) == (child, "extends")


def test_a_device_is_not_read_without_end():
    """/dev/zero as a config: refused after a megabyte, not read until memory runs out."""
    with pytest.raises(ConfigError, match="larger than 1 MB"):
        load_config("/dev/zero")
