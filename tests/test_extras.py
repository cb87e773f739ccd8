"""The optional extras of pyproject.toml against the code they serve: every third-party package a
module imports (at the top or inside a function) is a base dependency or comes with the extras of
the commands that module serves, and every package an extra declares is imported by a module it
serves (no missing and no dead requirement)."""

from __future__ import annotations

import ast
import re
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# A distribution's import names, where they differ from its name.
# dask[distributed]: the backend imports dask.distributed as `distributed`.
IMPORT_NAMES = {"pin": ("pinocchio",), "rerun-sdk": ("rerun",), "dask": ("distributed",), "pillow": ("PIL",),
                "mcap-ros2-support": ("mcap_ros2",)}

# Module groups (globs under the repository) -> the extras a user has who runs them. The first
# matching group counts. Rerun and matplotlib views are commands of the pipeline: build comes too.
GROUPS: list[tuple[str, tuple[str, ...]]] = [
    ("control/**/*.py", ("control",)),
    ("proving/twin/*.py", ("control", "sim")),  # track --plant mujoco, its rides and maneuvers
    ("proving/humanoid/*.py", ("control", "sim")),  # the humanoid's rides on its twin
    ("proving/certify/*.py", ("control", "sim")),  # certify: rides on the twin under drawn errors
    ("proving/*.py", ("control",)),  # track on the model plant, rides, the steering experiment
    ("sim/video.py", ("sim", "video")),
    ("sim/overlay.py", ("sim", "video")),
    ("sim/*.py", ("sim",)),
    ("sim/humanoid/*.py", ("sim",)),
    ("pipeline/views/rerun_*.py", ("build", "viz")),
    ("pipeline/*/rerun.py", ("build", "viz")),
    ("pipeline/views/figures.py", ("build", "plot")),
    ("pipeline/views/track_report.py", ("build", "control", "plot")),  # track --report
    ("pipeline/*/plots.py", ("build", "plot")),
    ("pipeline/build/sweep.py", ("build", "dask")),  # the dask backend, imported only when asked
    ("pipeline/certify_run.py", ("build", "control", "sim", "dask")),  # certify (dask when asked)
    ("pipeline/quadruped/transitions/twin_judge.py", ("build", "control", "sim")),  # [transitions] twin_judge
    ("pipeline/exports.py", ("build", "export")),  # export --format mcap
    ("pipeline/ros_bag.py", ("build", "export")),  # export --format mcap
    ("pipeline/**/*.py", ("build",)),
    ("library/*.py", ()),
    ("runtime/*.py", ()),
    ("api/*.py", ()),  # the package itself (import skatelib): the robot's base install
]


def _names(requirement: str) -> tuple[str, ...]:
    dist = re.split(r"[<>=!~\[; ]", requirement, maxsplit=1)[0].strip().lower()
    return IMPORT_NAMES.get(dist, (dist.replace("-", "_"),))


def _project() -> tuple[set[str], dict[str, set[str]]]:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    base = {n for r in meta["dependencies"] for n in _names(r)}
    raw: dict[str, list[str]] = meta["optional-dependencies"]

    def resolve(extra: str) -> set[str]:
        out: set[str] = set()
        for r in raw[extra]:
            m = re.fullmatch(r"skatelib\[(.+)\]", r)
            out |= set().union(*(resolve(e) for e in m.group(1).split(","))) if m else set(_names(r))
        return out

    return base, {e: resolve(e) for e in raw}


def _imports(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module.split(".")[0])
    return {n for n in found if n not in sys.stdlib_module_names and n != "skatelib"}


def _group(rel: str) -> tuple[str, ...]:
    extras = next((extras for pattern, extras in GROUPS
                   if rel in {p.relative_to(ROOT).as_posix() for p in ROOT.glob(pattern)}), None)
    assert extras is not None, f"{rel} is in no group of GROUPS: add the extras a user of it has"
    return extras


def _modules() -> list[str]:
    tops = ("api", "pipeline", "library", "runtime", "control", "sim", "proving")
    return sorted(p.relative_to(ROOT).as_posix() for t in tops for p in (ROOT / t).rglob("*.py"))


def test_every_import_comes_with_the_extras_of_its_commands():
    """Each module's third-party imports are base dependencies or in its group's extras."""
    base, extras = _project()
    missing = []
    for rel in _modules():
        provided = base.union(*(extras[e] for e in _group(rel)))
        missing += [f"{rel} imports {n}, which no extra of {_group(rel) or 'the base install'} brings"
                    for n in sorted(_imports(ROOT / rel) - provided)]
    assert not missing, "\n".join(missing)


def test_every_declared_requirement_is_imported():
    """Each package an extra declares is imported by a module that extra serves."""
    _, extras = _project()
    used: dict[str, set[str]] = {e: set() for e in extras}
    for rel in _modules():
        for e in _group(rel):
            used[e] |= _imports(ROOT / rel)
    direct = {e: names for e, names in extras.items() if e in {x for _, g in GROUPS for x in g}}
    dead = [f"[{e}] declares {n}, which no module it serves imports" for e, names in direct.items()
            for n in sorted(names - used[e] - _project()[0])]
    assert not dead, "\n".join(dead)


def test_the_check_sees_a_missing_requirement(monkeypatch):
    """Negative control: without pinocchio in the control extra, the controller's kinematics is
    reported."""
    base, extras = _project()
    extras["control"] = extras["control"] - {"pinocchio"}
    monkeypatch.setattr(sys.modules[__name__], "_project", lambda: (base, extras))
    try:
        test_every_import_comes_with_the_extras_of_its_commands()
    except AssertionError as e:
        assert "control/kinematics.py imports pinocchio" in str(e)
    else:
        raise AssertionError("a missing requirement went unnoticed")
