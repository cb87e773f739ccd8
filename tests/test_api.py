"""The Python API (``import skatelib``): light to import, typed arguments checked as the command
line checks them, the command's errors for the command's mistakes, and the command line running
the same functions."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import skatelib
from skatelib.library.errors import ConfigError, LibraryFormatError, OutputError, SkatelibError

from tests.helpers import run_cli

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"
HEAVY = ("casadi", "pinocchio", "typer", "rich", "joblib", "rerun", "mujoco")


def _flat(text: str) -> str:
    return " ".join(text.split())


def test_import_skatelib_stays_light():
    """``import skatelib`` and the runtime under it load none of the build's packages; naming the API's
    functions loads none either (they import what they need when called)."""
    code = ("import sys, skatelib, skatelib.runtime; before = [m for m in sys.modules if m.split('.')[0] in HEAVY]; "
            "skatelib.build, skatelib.validate, skatelib.track; "
            "after = [m for m in sys.modules if m.split('.')[0] in HEAVY]; print(before, after); "
            "sys.exit(1 if before or after else 0)")
    r = subprocess.run([sys.executable, "-c", f"HEAVY = {HEAVY!r}; " + code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_public_names_resolve():
    """Every name of ``skatelib.__all__`` is one of the lazy table's and resolves to its object; an
    unknown name is an AttributeError listing the public ones."""
    import skatelib as pkg

    assert sorted(pkg.__all__) == sorted(pkg._EXPORTS)
    for name in pkg.__all__:
        assert getattr(pkg, name).__name__ == name
    with pytest.raises(AttributeError, match=r"public names: .*build"):
        pkg.no_such_thing  # noqa: B018


def _bad_config(tmp_path: Path) -> Path:
    cfg = tmp_path / "bad.toml"
    cfg.write_text('extends = "skatelib:cyberdog2.toml"\n[sweep]\nvelocity_mps = [0.3]\n')
    return cfg


def test_a_wrong_config_key_is_the_commands_error(tmp_path):
    """A misspelt key: ``skatelib.build`` raises the ConfigError naming the file and the key whose
    message is what ``skatelib build`` prints (exit 2), and writes nothing."""
    cfg = _bad_config(tmp_path)
    with pytest.raises(ConfigError) as caught:
        skatelib.build(cfg, tmp_path / "lib.h5")
    e = caught.value
    assert e.path == cfg and e.key == "sweep.velocity_mps" and "velocities_mps" in e.message
    cli = run_cli(["build", str(cfg), "-o", str(tmp_path / "lib.h5")])
    assert cli.returncode == 2
    assert _flat(str(e)) in _flat(cli.stderr)
    assert list(tmp_path.iterdir()) == [cfg]


def test_the_shipped_config_by_name_loads(tmp_path):
    """Negative control of the test above: with the key spelt right, the same config loads, its
    ``extends`` naming the shipped default (``skatelib:``) from any folder."""
    from skatelib.pipeline.config import load_config

    cfg = tmp_path / "good.toml"
    cfg.write_text('extends = "skatelib:cyberdog2.toml"\n[sweep]\nvelocities_mps = [0.3]\n')
    assert load_config(cfg).sweep.velocities_mps == (0.3,)
    missing = tmp_path / "missing.toml"
    missing.write_text('extends = "skatelib:nope.toml"\n')
    with pytest.raises(ConfigError, match=r"shipped configs: cyberdog2\.toml"):
        load_config(missing)


@pytest.mark.parametrize(("call", "message"), [
    (lambda p: skatelib.build(None, p, jobs=0), "jobs=0.*1 to 256"),
    # (mypy refuses these three: the choices are Literal types; at run time they are checked too)
    (lambda p: skatelib.build(None, p, backend="ray"), "backend is one of 'loky', 'dask'"),  # type: ignore[arg-type]
    (lambda p: skatelib.track(REFERENCE, plant="bullet"), "plant is one of 'model', 'mujoco'"),  # type: ignore[arg-type]
    (lambda p: skatelib.track(REFERENCE, solver="qp"), "solver is one of 'daqp'"),  # type: ignore[arg-type]
    (lambda p: skatelib.track(REFERENCE, seed=-1), "seed=-1"),
    (lambda p: skatelib.track(REFERENCE, mpc_mu=float("nan")), "mpc_mu=nan"),
    (lambda p: skatelib.validate(REFERENCE, jobs=True), "jobs=True"),
    (lambda p: skatelib.track(REFERENCE, []), "entries: an empty list asks for no entry"),  # not every entry
    (lambda p: skatelib.certify(shutil.copy(REFERENCE, p.with_name("c.h5")), []), "entries: an empty list asks"),
])
def test_arguments_out_of_range_are_named(tmp_path, call, message):
    """A wrong value of a typed argument is a ValueError naming the argument and what is allowed,
    before any work (no file written)."""
    with pytest.raises(ValueError, match=message):
        call(tmp_path / "lib.h5")
    assert not (tmp_path / "lib.h5").exists()


def test_an_output_that_is_a_folder_is_refused(tmp_path):
    """The command's output check: a folder as ``out`` is an OutputError naming it."""
    with pytest.raises(OutputError, match=str(tmp_path)):
        skatelib.build(None, tmp_path)


def test_validate_returns_the_commands_verdicts():
    """``skatelib.validate`` gives each entry the status and message ``skatelib validate --json``
    prints, and the same validity."""
    report = skatelib.validate(REFERENCE)
    cli = run_cli(["validate", str(REFERENCE), "--json"])
    doc = json.loads(cli.stdout)
    assert [(v.key, v.status, v.message) for v in report.entries] == \
        [(v["key"], v["status"], v["message"]) for v in doc["entries"]]
    assert report.valid == doc["valid"] and report.failed == 0 and report.valid


def test_validate_refuses_a_damaged_library(tmp_path):
    """Negative control: a library with a flipped byte in its data is refused (LibraryFormatError,
    as the command exits 3), not validated."""
    bad = tmp_path / "bad.h5"
    shutil.copy(REFERENCE, bad)
    data = bytearray(bad.read_bytes())
    data[len(data) // 2] ^= 0xFF
    bad.write_bytes(bytes(data))
    with pytest.raises(LibraryFormatError):
        skatelib.validate(bad)
    assert run_cli(["validate", str(bad)]).returncode == 3


def test_track_on_the_model_plant_and_its_errors():
    """One entry on the model plant as planned: its verdict passes and delivers the label within
    5 %; an unknown entry and a bad perturbation are the command's errors, naming what exists."""
    (r,) = skatelib.track(REFERENCE, ["v0.30_s1"], perturb="none", jobs=1)
    assert isinstance(r, skatelib.TrackResult) and r.key == "v0.30_s1" and r.passed
    assert abs(r.delivered_mps - 0.30) <= 0.05 * 0.30
    with pytest.raises(SkatelibError, match=r"v0\.30_s1, v0\.40_s1"):
        skatelib.track(REFERENCE, ["v9.99_s1"])
    with pytest.raises(SkatelibError, match=r"'bogus=1': expected KEY=VALUE with KEY one of mass"):
        skatelib.track(REFERENCE, ["v0.30_s1"], perturb="bogus=1")


def _no_run(*args, **kwargs):
    raise AssertionError("a run started")


@pytest.mark.parametrize("plant", ["model", "mujoco"])
@pytest.mark.parametrize("perturb", ["", " , ", None])
def test_a_perturbation_that_names_no_error_is_refused(monkeypatch, plant, perturb):
    """``perturb`` empty (or commas alone) or not a text is a ValueError naming ``perturb`` before any
    run, on either plant, as the command refuses ``--perturb ''`` (not the plant as planned, nor an
    AttributeError)."""
    monkeypatch.setattr("skatelib.pipeline.api.run_jobs", _no_run)
    with pytest.raises(ValueError, match=r"skatelib\.track\(perturb=\.\.\.\): .*give KEY=VALUE,\.\.\. or 'none'"):
        skatelib.track(REFERENCE, ["v0.30_s1"], plant=plant, perturb=perturb, jobs=1)


@pytest.mark.parametrize("perturb", ["", None])
def test_validate_refuses_a_perturbation_that_names_no_error(tmp_path, perturb):
    """``validate(closed_loop=True)`` refuses the same ``perturb`` values, naming it, before any
    check or ride: the file is unchanged."""
    lib = tmp_path / "lib.h5"
    shutil.copy(REFERENCE, lib)
    with pytest.raises(ValueError, match=r"skatelib\.validate\(perturb=\.\.\.\)"):
        skatelib.validate(lib, closed_loop=True, perturb=perturb)
    assert lib.read_bytes() == REFERENCE.read_bytes()


def test_track_refuses_an_impulse_after_a_run_before_any_run(monkeypatch):
    """An ``impulse_t`` at or after an entry's run ends (3.10 s for the 1.2 s entries) is refused
    naming it, the entry and the end, before any entry rides."""
    monkeypatch.setattr("skatelib.pipeline.api.run_jobs", _no_run)
    with pytest.raises(ValueError, match=r"impulse_t=30: the run of v0\.30_s1 ends at 3\.10 s"):
        skatelib.track(REFERENCE, ["v0.30_s1", "v0.40_s1"], perturb="impulse=20,impulse_t=30", jobs=1)


def test_track_on_the_twin_reports_progress():
    """``plant="mujoco"``: a TwinResult per entry, and the progress callback hears (done, total)."""
    heard: list[tuple[int, int]] = []
    (r,) = skatelib.track(REFERENCE, ["v0.30_s1"], plant="mujoco", perturb="none", jobs=1,
                          progress=lambda done, total: heard.append((done, total)))
    assert isinstance(r, skatelib.TwinResult) and r.key == "v0.30_s1" and r.passed
    assert heard == [(1, 1)]


def test_the_build_command_runs_the_api(tmp_path, monkeypatch):
    """``skatelib build`` calls ``skatelib.build`` (no second implementation): replaced by a stub
    that records its arguments, the command hands it the options it was given."""
    from skatelib.pipeline import api
    from skatelib.pipeline.cli.app import app
    from typer.testing import CliRunner

    seen: dict[str, object] = {}

    class Called(Exception):
        pass

    def stub(config: object, out: object, **kw: object) -> None:
        seen.update(kw, out=out)
        raise Called

    monkeypatch.setattr(api, "build", stub)
    r = CliRunner().invoke(app, ["build", str(Path(__file__).parent / "configs" / "tiny.toml"), "-o",
                                 str(tmp_path / "x.h5"), "-j", "3", "--no-cache", "--no-progress"])
    assert isinstance(r.exception, Called), r.output
    assert seen["jobs"] == 3 and seen["cache"] is False and seen["out"] == tmp_path / "x.h5"


def test_progress_true_draws_the_commands_bar(tmp_path, monkeypatch):
    """``progress=True`` hands the build the command line's bar (which hears every entry), a
    function hands it that function; the sweep itself replaced by one that reports two entries."""
    from skatelib.pipeline.build import orchestrate
    from skatelib.pipeline.build.contract import EntryEvent
    from skatelib.pipeline.views.progress import BuildBar

    heard: list[object] = []

    def sweep(cfg: object, out: object, opts: object, on_entry: object = None) -> str:
        heard.append(on_entry)
        for key in ("v0.30_s1", "v0.40_s1"):
            on_entry(EntryEvent(key, False))  # type: ignore[operator]
            on_entry(EntryEvent(key, True, "Solve_Succeeded", True))  # type: ignore[operator]
        return "report"

    monkeypatch.setenv("SKATELIB_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(orchestrate, "build_library", sweep)
    tiny = Path(__file__).parent / "configs" / "tiny.toml"
    assert skatelib.build(tiny, tmp_path / "x.h5", progress=True) == "report"
    bar = heard[-1]
    assert isinstance(bar, BuildBar) and bar.done == ["v0.30_s1", "v0.40_s1"]
    events: list[EntryEvent] = []
    skatelib.build(tiny, tmp_path / "x.h5", progress=events.append)
    assert heard[-1] == events.append and [e.key for e in events if e.done] == ["v0.30_s1", "v0.40_s1"]


def test_validate_closed_loop_stores_the_verdicts(tmp_path):
    """``closed_loop=True`` rides every successful entry, returns each verdict and stores it in the
    library, as ``validate --closed-loop`` does (the file read back holds them)."""
    from skatelib.library import schema
    from skatelib.runtime import MotionLibrary

    lib = tmp_path / "lib.h5"
    shutil.copy(REFERENCE, lib)
    report = skatelib.validate(lib, closed_loop=True, perturb="none", jobs=1)
    assert [r.key for r in report.closed_loop] == ["v0.30_s1", "v0.40_s1"]
    assert all(isinstance(r, skatelib.TrackResult) for r in report.closed_loop)
    stored = {e.key: json.loads(e.attrs[schema.A_CLOSED_LOOP]) for e in MotionLibrary.open(lib)}
    assert {k: v["passed"] for k, v in stored.items()} == {r.key: r.passed for r in report.closed_loop}


def test_a_runtime_only_install_is_told_what_to_install(tmp_path, monkeypatch):
    """Without the build pipeline's packages (here one named that does not exist), each function
    refuses at once with an ImportError naming the package and the extra, writing nothing."""
    from skatelib.pipeline import api

    monkeypatch.setattr(api, "PIPELINE_MODULES", (*api.PIPELINE_MODULES, "no_such_package_here"))
    for call in (lambda: skatelib.build(None, tmp_path / "x.h5"), lambda: skatelib.validate(REFERENCE),
                 lambda: skatelib.track(REFERENCE)):
        with pytest.raises(ImportError, match=r"missing: no_such_package_here; pip install 'skatelib\[pipeline\]'"):
            call()
    assert list(tmp_path.iterdir()) == []


def test_one_entry_key_as_a_string_is_a_type_error():
    """``entries="v0.30_s1"`` (one key where a list is asked): a TypeError saying to give a list of
    one, before any run (it was ridden letter by letter: no entry 'v')."""
    with pytest.raises(TypeError, match=r"a list of entry keys, not the string 'v0.30_s1'"):
        skatelib.track(REFERENCE, "v0.30_s1")
