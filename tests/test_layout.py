"""The layout rules (tools/check_layout.py, run by make lint) hold, and the checker finds a breach."""

from __future__ import annotations

import shutil
from pathlib import Path

from tests.helpers import load_tool

ROOT = Path(__file__).resolve().parents[1]


def _checker():
    return load_tool("check_layout")


def test_repository_keeps_its_layout():
    assert _checker().problems(ROOT) == []


def test_checker_reports_long_modules_long_functions_and_wrong_imports(tmp_path):
    """A doctored tree: a 300-line runtime module with a 70-line function, the runtime importing
    the pipeline, the engine importing a robot; each is named with its file."""
    check = _checker()
    for top in ("pipeline", "library", "runtime", "control"):
        shutil.copytree(ROOT / top, tmp_path / top, ignore=shutil.ignore_patterns("__pycache__", "cpp"))
    body = "\n".join(f"    x{i} = {i}" for i in range(70))
    (tmp_path / "runtime" / "long.py").write_text(
        "import skatelib.pipeline.build.orchestrate\n\n\ndef f():\n" + body + "\n" + "# pad\n" * 230)
    (tmp_path / "pipeline" / "ocp" / "bad.py").write_text("from skatelib.pipeline.quadruped import robot\n")
    found = check.problems(tmp_path)
    assert any(f.startswith("runtime/long.py: 304 lines (at most 250)") for f in found)
    assert any(f.startswith("runtime/long.py:4: function f has 71 lines") for f in found)
    assert any(f.startswith("runtime/long.py:1: imports skatelib.pipeline.build.orchestrate") for f in found)
    assert any(f.startswith("pipeline/ocp/bad.py:1: imports skatelib.pipeline.quadruped") for f in found)
    assert len(found) == 4, found


def test_checker_keeps_the_controller_apart_from_its_proving_ground(tmp_path):
    """A doctored tree: the controller importing the proving ground, the twin and casadi; the twin
    importing the controller; the proving ground importing the pipeline. Each is a breach."""
    check = _checker()
    for top in ("control", "sim", "proving"):
        shutil.copytree(ROOT / top, tmp_path / top, ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "control" / "bad.py").write_text(
        "from skatelib.proving.twin.loop import TwinLoop\nimport skatelib.sim.plant\nimport casadi\nimport pinocchio\n")
    (tmp_path / "sim" / "bad.py").write_text("from skatelib.control.wbc import WholeBodyController\n")
    (tmp_path / "proving" / "bad.py").write_text("from skatelib.pipeline.cli import app\nimport skatelib.sim\n")
    found = check.problems(tmp_path)
    assert any(f.startswith("control/bad.py:1: imports skatelib.proving.twin.loop (control/ must not)") for f in found)
    assert any(f.startswith("control/bad.py:2: imports skatelib.sim.plant (control/ must not)") for f in found)
    assert any(f.startswith("control/bad.py:3: imports casadi (control/ is installed on the robot") for f in found)
    assert any(f.startswith("sim/bad.py:1: imports skatelib.control.wbc (sim/ must not)") for f in found)
    assert any(f.startswith("proving/bad.py:1: imports skatelib.pipeline.cli (proving/ must not)") for f in found)
    assert len(found) == 5, found  # pinocchio in control/ and the twin in proving/ are allowed


def test_checker_keeps_the_library_file_names_in_library(tmp_path):
    """A doctored tree: /model attribute names and a root attribute name as literal keys in the
    controller and the pipeline are breaches; the same words as plain values are not."""
    check = _checker()
    (tmp_path / "control").mkdir()
    (tmp_path / "pipeline").mkdir()
    (tmp_path / "control" / "bad.py").write_text(
        'def f(lib):\n    return lib.model["board_mass_kg"], lib.model.get("board_tanh_scale_s_per_m", 50.0)\n')
    (tmp_path / "pipeline" / "bad.py").write_text(
        'def f(lib):\n    return {"config_resolved_json": lib.attrs}, "board_mass_kg"\n')
    found = check.problems(tmp_path)
    assert sorted(f.split(" as a literal")[0] for f in found) == [
        "control/bad.py:2: the library file's name 'board_mass_kg'",
        "control/bad.py:2: the library file's name 'board_tanh_scale_s_per_m'",
        "pipeline/bad.py:2: the library file's name 'config_resolved_json'"], found


def test_checker_finds_an_import_cycle_hidden_by_a_local_import(tmp_path):
    """A doctored tree: a.py imports b at the top, b.py imports a inside a function and c under
    TYPE_CHECKING, c imports b: one cycle of three modules, however the imports hide."""
    check = _checker()
    (tmp_path / "control").mkdir()
    (tmp_path / "control" / "a.py").write_text("from skatelib.control.b import f\n")
    (tmp_path / "control" / "b.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from skatelib.control import c\n\n\n"
        "def f():\n    from skatelib.control.a import f as g\n    return g\n")
    (tmp_path / "control" / "c.py").write_text("import skatelib.control.b\n")
    (tmp_path / "control" / "d.py").write_text("import skatelib.control.a\n")  # imports into the cycle: not in it
    found = check.problems(tmp_path)
    assert found == ["import cycle: skatelib.control.a -> skatelib.control.b -> skatelib.control.c "
                     "(move what they share into a module of its own)"], found
