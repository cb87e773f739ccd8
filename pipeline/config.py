"""Build configurations: TOML files read with tomllib, validated into frozen dataclasses (each
robot kind's tables in its own ``config`` module: ``quadruped/config.py``, ``humanoid/config.py``).

Every physical field carries its unit in its name. An unknown key, a wrong type or a value out
of range raises :class:`ConfigError` naming the file, the dotted key and the allowed values.
A config may start from another with ``extends = "other.toml"`` (path relative to the file) or
from a shipped one, ``extends = "skatelib:cyberdog2.toml"``; tables are merged key by key, the
extending file winning.
"""

from __future__ import annotations

import json
import re
import typing
from pathlib import Path
from typing import Any

from skatelib.library.errors import ConfigError
from skatelib.pipeline.config_tables import (
    CONFIG_DIR,
    DEFAULT_CONFIG,
    MetaConfig,
    build_section,
    check_unique_keys,
    defining_file,
    field_range,
    read_toml,
    sections,
    setting,
)
from skatelib.pipeline.kinds import KINDS, RobotKind

__all__ = ["CONFIG_DIR", "DEFAULT_CONFIG", "AnyConfig", "MetaConfig", "build_section", "check_unique_keys",
           "config_from_json", "field_range", "load_config", "read_toml", "sections", "setting"]


if typing.TYPE_CHECKING:
    from skatelib.pipeline.humanoid.config import HumanoidConfig
    from skatelib.pipeline.quadruped.config import QuadrupedConfig

AnyConfig = typing.Union["QuadrupedConfig", "HumanoidConfig"]
C = typing.TypeVar("C", "QuadrupedConfig", "HumanoidConfig")
NAME_RE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9._-]{0,63}")  # [meta] name: out/<name>.h5 stays in out/


def _kind(path: Path, name: Any, expect: type | None) -> RobotKind:
    """The kind of a config's ``meta.kind`` (from the kind table), checked against ``expect``."""
    if name is None:
        raise ConfigError(path, "meta.kind", f"missing: a config starts with [meta] kind = one of "
                                             f"{', '.join(map(repr, KINDS))} (configs/cyberdog2.toml)")
    if name not in KINDS:
        raise ConfigError(path, "meta.kind", f"{name!r}: use one of {', '.join(map(repr, KINDS))}")
    kind = KINDS[name].load()
    if expect is not None and kind.config_class is not expect:
        wanted = next(k for k, row in KINDS.items() if row.load().config_class is expect)
        raise ConfigError(path, "meta.kind", f"expected {wanted!r}, got {name!r}: this command takes {wanted} configs")
    return kind


@typing.overload
def load_config(path: Path | str | None = None) -> AnyConfig: ...
@typing.overload
def load_config(path: Path | str | None, expect: type[C]) -> C: ...
def load_config(path: Path | str | None = None, expect: type | None = None) -> Any:
    """Load and validate a build config of any kind (``meta.kind``), the shipped default when
    ``path`` is None; with ``expect``, one of that config class only.

    Raises:
        ConfigError: On any invalid field, naming the file and key.
    """
    path = Path(path) if path is not None else CONFIG_DIR / DEFAULT_CONFIG
    data, text = read_toml(path)
    try:
        return _kind(path, _meta(path, data).get("kind"), expect).from_toml(path, data, text)
    except ConfigError as e:
        origin = defining_file(path, e.key) if e.path == path else None
        if origin is None or origin == path.resolve():
            raise
        raise ConfigError(origin, e.key, f"{e.message} (in the config that {path.name} extends)") from e


@typing.overload
def config_from_json(text: str, origin: Path, urdf: Path | None = None) -> AnyConfig: ...
@typing.overload
def config_from_json(text: str, origin: Path, urdf: Path | None, expect: type[C]) -> C: ...
def config_from_json(text: str, origin: Path, urdf: Path | None = None, expect: type | None = None) -> Any:
    """Rebuild a config from its ``resolved_json()`` (as stored in a library), a quadruped one
    with the robot description at ``urdf``. Errors name ``origin``."""
    data = json.loads(text)
    return _kind(Path(origin), data.get("meta", {}).get("kind"), expect).from_json(data, Path(origin), urdf)


def _meta(path: Path, data: dict[str, Any]) -> dict[str, Any]:
    meta = data.get("meta", {})
    if not isinstance(meta, dict):
        raise ConfigError(path, "meta", f"must be a table ([meta] with kind and name), got {meta!r}")
    name = meta.get("name")
    if isinstance(name, str) and not NAME_RE.fullmatch(name):
        raise ConfigError(path, "meta.name", f"{name!r}: the default library file is out/<name>.h5, so a name is one "
                                             "plain file name of letters, digits, '.', '_' and '-' (at most 64, not "
                                             "starting with '.' or '-'), e.g. 'cyberdog2-default'")
    return meta
