"""Command line: the model summary and error handling, run as a user would."""

from __future__ import annotations

import enum
import os
import subprocess
from pathlib import Path
from typing import Any

import pytest
from skatelib.pipeline.config import CONFIG_DIR

from tests.helpers import CLI

SKATELIB = CLI


def test_model_prints_srb_beside_vendor_figures():
    """`skatelib model` prints the URDF-derived SRB mass next to the vendor's 8.3644 kg."""
    env = {**os.environ, "COLUMNS": "200"}
    out = subprocess.run([*SKATELIB, "model"], capture_output=True, text=True, check=True, env=env).stdout
    assert "8.5184" in out and "8.3644" in out and "mass [kg]" in out


@pytest.mark.parametrize("bad", ["missing.toml", "bad_key.toml"])
def test_bad_config_exits_nonzero_with_file_and_key(tmp_path: Path, bad: str):
    """A missing file or an unknown key exits with code 2 and a message on stderr naming the file."""
    path = tmp_path / bad
    if bad == "bad_key.toml":
        path.write_text(f'extends = "{(CONFIG_DIR / "cyberdog2.toml").as_posix()}"\n[board]\nmass_kilo = 1\n')
    env = {**os.environ, "COLUMNS": "300"}
    r = subprocess.run([*SKATELIB, "model", str(path)], capture_output=True, text=True, env=env)
    assert r.returncode == 2
    assert bad in r.stderr and r.stdout == ""
    if bad == "bad_key.toml":
        assert "board.mass_kilo" in r.stderr


@pytest.mark.parametrize("command, unit", [("frontier", "[m/s]"), ("track", "0.5"), ("solve", "m/s")])
def test_help_keeps_units_and_brackets(command: str, unit: str):
    """Help texts are printed as written: a unit in brackets such as [m/s] is not taken for markup
    and dropped (rich markup ate it before), and no stray type placeholders like <bool> appear."""
    env = {**os.environ, "COLUMNS": "200"}
    out = subprocess.run([*SKATELIB, command, "--help"], capture_output=True, text=True, check=True, env=env).stdout
    assert unit in out and "<bool>" not in out


def test_version_prints_the_installed_version():
    from importlib import metadata

    out = subprocess.run([*SKATELIB, "--version"], capture_output=True, text=True, check=True).stdout
    assert out.strip() == f"skatelib {metadata.version('skatelib')}"


@pytest.mark.slow
def test_solve_verbose_prints_the_ipopt_log(tmp_path: Path):
    """`solve -v` shows IPOPT's iteration log (one line per iteration); without it there is none.
    The config is given as an option or, as for `build`, as the argument."""
    tiny = Path(__file__).parent / "configs" / "tiny.toml"
    env = {**os.environ, "COLUMNS": "200", "SKATELIB_CACHE_DIR": str(tmp_path / "cache")}
    logs = []
    for config, flags in ((["--config", str(tiny)], ["-v"]), ([str(tiny)], [])):
        r = subprocess.run([*SKATELIB, "solve", *config, "--velocity", "0.3", "-s", "1",
                            "-o", str(tmp_path / f"v{len(flags)}.h5"), *flags],
                           capture_output=True, text=True, env=env, timeout=600)
        assert r.returncode == 0, r.stdout + r.stderr
        logs.append(r.stdout)
    assert "inf_pr" in logs[0] and "EXIT: Optimal Solution Found" in logs[0]
    assert "inf_pr" not in logs[1]


def test_solve_cuts_the_config_to_the_one_start_up_it_names(cfg):
    """The config ``solve`` builds from the default one (18 start-ups, 25 transitions) has exactly
    one entry: the start-up named, no transitions."""
    from skatelib.pipeline.quadruped.builder import one_start_up, tasks

    assert sum(t.n_entries for t in tasks(cfg)) == 43
    one = one_start_up(cfg, 0.5, 2)
    assert [(type(t).__name__, t.n_entries) for t in tasks(one)] == [("BuildTask", 1)]
    assert one.sweep.velocities_mps == (0.5,) and one.sweep.strides == (2,) and one.transitions.pairs() == []


@pytest.mark.slow
def test_solve_of_the_default_config_writes_one_entry(tmp_path: Path):
    """`skatelib solve -V 0.5 -s 2` of the default config (its transitions included) writes the one
    push-off, in seconds: it solved the 25 transitions too, over ten minutes."""
    from skatelib.runtime import MotionLibrary

    env = {**os.environ, "COLUMNS": "200", "SKATELIB_CACHE_DIR": str(tmp_path / "cache")}
    out = tmp_path / "one.h5"
    r = subprocess.run([*SKATELIB, "solve", "-V", "0.5", "-s", "2", "-o", str(out)],
                       capture_output=True, text=True, env=env, timeout=180)
    assert r.returncode == 0, r.stdout + r.stderr
    assert MotionLibrary.open(out).keys() == ["v0.50_s2"]


def test_advice_names_only_the_options_the_command_has(tmp_path: Path):
    """An output file of another kind: ``solve``, ``frontier`` and ``export`` (no ``--force``) say to
    choose another file or remove it; ``build`` (which has it) names ``--force``. A cache folder
    others can write, with ``build --no-cache`` of a compiled config: the advice is not
    ``--no-cache``, which was given. Each exits 2 and leaves the file as it was."""
    tiny = Path(__file__).parent / "configs" / "tiny.toml"
    reference = Path(__file__).parent / "data" / "tiny-reference.h5"
    notes = tmp_path / "notes.txt"
    notes.write_text("keep me")
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    env = {**os.environ, "COLUMNS": "200", "SKATELIB_CACHE_DIR": str(cache)}
    without = (["solve", "-V", "0.3", "-s", "1", "--config", str(tiny), "-o", str(notes)],
               ["frontier", str(tiny), "-s", "1", "-o", str(notes)],
               ["export", str(reference), "-f", "mcap", "-o", str(notes)])
    for args in (*without, ["build", str(tiny), "-o", str(notes), "--no-progress"]):
        r = subprocess.run([*SKATELIB, *args], capture_output=True, text=True, env=env, timeout=120)
        err = " ".join(r.stderr.split())  # the message wraps where a long temporary path ends
        assert r.returncode == 2 and "refusing to overwrite" in err, (args[0], r.stderr)
        has_force = args[0] == "build"
        assert ("--force" in err) == has_force and ("remove that one" in err) != has_force, r.stderr
    assert notes.read_text() == "keep me"
    compiled = tmp_path / "compiled.toml"
    compiled.write_text(f'extends = "{tiny.as_posix()}"\n[optimization]\ncompile = true\n')
    cache.chmod(0o777)
    env.pop("SKATELIB_COMPILE_DIR", None)  # the compiled code kept in the cache folder
    r = subprocess.run([*SKATELIB, "build", str(compiled), "-o", str(tmp_path / "x.h5"), "--no-cache",
                        "--no-progress"], capture_output=True, text=True, env=env, timeout=120)
    err = " ".join(r.stderr.split())
    assert r.returncode == 2 and "can be written by others" in err, r.stderr
    assert "--no-cache" not in err and "compile = false" in err


def test_model_of_a_humanoid_config_prints_the_lip_time_constant():
    """`skatelib model` on a humanoid config: its point-mass figures and omega = sqrt(g / z_com),
    the analytic LIP frequency (3.502 1/s for g 9.81 and z 0.80)."""
    env = {**os.environ, "COLUMNS": "200"}
    out = subprocess.run([*SKATELIB, "model", str(CONFIG_DIR / "hrp2_walk.toml")], capture_output=True, text=True,
                         check=True, env=env).stdout
    assert "com_height_m" in out and f"{(9.81 / 0.8) ** 0.5:.4g}" in out and "[1/s]" in out


def test_shell_completion_is_offered():
    """`skatelib --show-completion bash` prints a completion function for the command."""
    out = subprocess.run([*SKATELIB, "--show-completion", "bash"], capture_output=True, text=True,
                         env={**os.environ, "_TYPER_COMPLETE_TEST_DISABLE_SHELL_DETECTION": "1"})
    assert out.returncode == 0 and "complete" in out.stdout, out.stdout + out.stderr


def _options() -> list[tuple[str, Any, Any]]:
    """(command, its click command, option) of every option of every command."""
    import typer
    from skatelib.pipeline.cli.app import app

    group = typer.main.get_command(app)
    return [(name, cmd, p) for name, cmd in group.commands.items() for p in cmd.params  # type: ignore[attr-defined]
            if p.param_type_name == "option"]


def test_every_help_shows_defaults_choices_and_units():
    """Every command's --help, as printed: each option with a default shows it (``-o`` included,
    whose default is a rule), each choice option its choices, each speed or other physical number
    its unit; no value named by a Python type (``<float range>``, ``<list[str]>``); and every
    command is reachable with --help (exit 0)."""
    from skatelib.control.qp import SOLVERS
    from skatelib.pipeline.cli.app import app
    from skatelib.pipeline.cli.library_commands import QpSolver
    from typer._click.core import Context  # typer's own click
    from typer.testing import CliRunner

    runner = CliRunner()
    seen = set()
    choice_options = set()
    for name, cmd, p in _options():
        if name not in seen:
            seen.add(name)
            r = runner.invoke(app, [name, "--help"], env={"COLUMNS": "200"})
            assert r.exit_code == 0 and "<bool>" not in r.output, (name, r.output)
        record = p.get_help_record(Context(cmd))
        assert record is not None, (name, p.opts)
        names, text = record
        assert " range>" not in names and "list[" not in names, (name, names)  # a user's words, not Python's types
        if (p.default not in (None, False) and not p.is_flag) or (p.opts[0] == "-o" and name in ("build", "solve")):
            assert "[default: " in text, (name, p.opts, text)
        kind = p.type_descriptor.annotation
        choices = [m.value for m in kind] if isinstance(kind, type) and issubclass(kind, enum.Enum) else None
        if choices:  # a choice: all of them listed, in the order the option declares them
            choice_options.add(p.name)
            assert "<" + "|".join(str(c) for c in choices) + ">" in names, (name, p.opts, names)
        if p.name in ("atol", "rtol"):  # a comparison's tolerance: in each channel's own unit, or relative
            assert "tolerance" in text, (name, p.opts, text)
        elif "<float" in names and p.name != "mpc_mu":  # a physical number: its unit
            assert "m/s" in text, (name, p.opts, text)
    assert "<daqp|proxqp|osqp>" in " ".join(p.get_help_record(Context(c))[0] for _, c, p in _options()
                                             if p.name == "solver")
    assert set(QpSolver) == set(SOLVERS)
    assert {"solver", "plant", "state", "backend"} <= choice_options, choice_options
    assert seen == {"build", "frontier", "solve", "info", "validate", "inspect", "plot", "track", "model", "diff",
                    "export", "certify"}


def test_h_is_help_for_every_command():
    """``-h`` prints the same help as ``--help``, for the program and every command."""
    from skatelib.pipeline.cli.app import app
    from typer.testing import CliRunner

    runner = CliRunner()
    names = sorted({name for name, _, _ in _options()})
    for args in ([], *([n] for n in names)):
        short, long = (runner.invoke(app, [*args, flag], env={"COLUMNS": "200"}) for flag in ("-h", "--help"))
        assert short.exit_code == 0 and short.output == long.output and "Usage:" in short.output, (args, short.output)


def test_help_reads_as_a_terminal_help():
    """The program's help lists every command with a whole summary (click cut its own at about 45
    characters with "..."); usage lines name arguments in capitals, required bare and optional in
    brackets (typer wrote a required one as ``{library}``); no reStructuredText quotes in any help."""
    from skatelib.pipeline.cli.app import SUMMARIES, app
    from typer.testing import CliRunner

    runner = CliRunner()
    top = runner.invoke(app, ["--help"], env={"COLUMNS": "80"})
    assert top.exit_code == 0 and "..." not in top.output.split("Commands:")[1], top.output
    names = sorted({name for name, _, _ in _options()})
    assert set(SUMMARIES) == set(names)
    for summary in SUMMARIES.values():
        assert " ".join(summary.split()) in " ".join(top.output.split()), summary
    usage = {n: runner.invoke(app, [n, "--help"], env={"COLUMNS": "200"}).output for n in names}
    assert "info [OPTIONS] LIBRARY\n" in usage["info"], usage["info"]
    assert "build [OPTIONS] [CONFIG]\n" in usage["build"], usage["build"]
    assert "diff [OPTIONS] A B\n" in usage["diff"], usage["diff"]
    for name, text in usage.items():
        assert "{" not in text.splitlines()[0] and "``" not in text, (name, text)


def test_a_frontier_search_that_would_try_nothing_is_refused(tmp_path: Path):
    """--start above --max-speed: exit 2 naming --start, before any config is read or solve made."""
    r = subprocess.run([*SKATELIB, "frontier", "--start", "2.0", "--max-speed", "1.0", "-o", str(tmp_path / "f.json")],
                       capture_output=True, text=True, env={**os.environ, "COLUMNS": "200"}, timeout=60)
    assert r.returncode == 2 and "--start" in r.stderr and "max-speed" in r.stderr, r.stderr
    assert list(tmp_path.iterdir()) == []
