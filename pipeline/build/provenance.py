"""Where a library came from: the root attributes of every library file, whatever the robot
(package versions, git commit and state, the config as written and resolved, solver options)."""

from __future__ import annotations

import datetime as dt
import json
import re
import subprocess
from importlib import metadata
from pathlib import Path
from typing import Any

import casadi as ca
import pinocchio as pin
from skatelib.library import schema


def ipopt_version() -> str:
    """Version of the IPOPT library bundled with CasADi (from its file name)."""
    folder = Path(ca.__file__).parent
    versions = sorted(m.group(1) for p in folder.glob("libipopt*.so.*")
                      if (m := re.search(r"libipopt\.so\.(\d+\.\d+\.\d+)$", p.name)))
    return versions[-1] if versions else "unknown"


def git_provenance() -> tuple[str, bool]:
    """(commit, dirty) of the skatelib source checkout, or ("unknown", False) outside git."""
    src = Path(__file__).resolve().parent
    try:
        commit = subprocess.run(["git", "-C", str(src), "rev-parse", "HEAD"], capture_output=True, text=True,
                                check=True, timeout=10).stdout.strip()
        dirty = bool(subprocess.run(["git", "-C", str(src), "status", "--porcelain", "--untracked-files=no"],
                                    capture_output=True, text=True, check=True, timeout=10).stdout.strip())
        return commit, dirty
    except (OSError, subprocess.SubprocessError):
        return "unknown", False


def root_attributes(kind: str, name: str, config_text: str, config_json: str,
                    solver_options: dict[str, Any]) -> dict[str, Any]:
    commit, dirty = git_provenance()
    return {
        schema.A_KIND: kind, schema.A_NAME: name,
        schema.A_SKATELIB_VERSION: metadata.version("skatelib"),
        schema.A_CREATED: dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        schema.A_GIT_COMMIT: commit, schema.A_GIT_DIRTY: dirty,
        schema.A_CONFIG_TOML: config_text, schema.A_CONFIG_RESOLVED: config_json,
        schema.A_CASADI: ca.CasadiMeta.version(), schema.A_IPOPT: ipopt_version(),
        schema.A_PINOCCHIO: pin.__version__,
        schema.A_SOLVER_OPTIONS: json.dumps(solver_options, sort_keys=True, default=str),
    }
