"""The building blocks of a build configuration: the TOML reader (with ``extends``), a field's
allowed range (``setting``), one table validated into its frozen dataclass (``build_section``),
the tables of a config (``sections``) and the checks every kind shares. Each robot kind's tables
use them (``quadruped/config.py``, ``humanoid/config.py``); :mod:`skatelib.pipeline.config`
loads a config of any kind."""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from skatelib.library.errors import ConfigError
from skatelib.library.schema import HDF5_SIGNATURE

# The checkout's configs/ (editable install) or the installed package skatelib.configs (package
# data of a wheel): the same place relative to this file.
CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"
DEFAULT_CONFIG = "cyberdog2.toml"
# ``extends = "skatelib:cyberdog2.toml"`` names a shipped config, wherever skatelib is installed.
SHIPPED = "skatelib:"
MAX_CONFIG_BYTES = 2**20  # a config is a short text; a longer file is something else


def setting(lo: float | None = None, hi: float | None = None, doc: str = "", **kw: Any) -> Any:
    """A dataclass field with an allowed range [lo, hi] and a one-line description."""
    return field(metadata={"lo": lo, "hi": hi, "doc": doc}, **kw)


@dataclass(frozen=True)
class MetaConfig:
    kind: str = setting(doc="Problem family: 'quadruped' (CyberDog2 skateboard) or 'humanoid' (GPM steps).")
    name: str = setting(doc="Library name, stored in the file.")


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def read_toml(path: Path, chain: tuple[Path, ...] = ()) -> tuple[dict[str, Any], str]:
    """Read a TOML file, following ``extends`` chains; returns (merged table, own text).

    Raises:
        ConfigError: When the file is missing, a folder, not UTF-8 text (a library file, say), not
            valid TOML, or its ``extends`` chain comes back to a file already in it.
    """
    path = Path(path)
    if path.resolve() in chain:
        names = " -> ".join(p.name for p in (*chain, path.resolve()))
        raise ConfigError(chain[0], "extends", f"the extends chain is a cycle: {names}; break it")
    text = _read_text(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(path, "-", f"not valid TOML: {e}") from e
    robot = data.get("robot")
    if isinstance(robot, dict) and isinstance(robot.get("urdf"), str):
        # Paths are relative to the file that names them, also through ``extends``.
        robot["urdf"] = str((path.parent / robot["urdf"]).resolve())
    parent = data.pop("extends", None)
    if parent is not None:
        data = _merge(_read_base(path, parent, chain), data)
    return data, text


def _read_text(path: Path) -> str:
    """A config file's text: at most a megabyte of UTF-8 (a device such as /dev/zero has no end)."""
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_CONFIG_BYTES + 1)
    except OSError as e:
        what = "is a folder, not a config file" if path.is_dir() else f"cannot be read ({e.strerror})"
        raise ConfigError(path, "-", f"{what}; "
                          f"shipped configs: {', '.join(sorted(p.name for p in CONFIG_DIR.glob('*.toml')))}") from e
    if raw.startswith(HDF5_SIGNATURE):
        raise ConfigError(path, "-", "is an HDF5 file (a motion library?), not a TOML config; "
                          "'skatelib info' and 'skatelib validate' read libraries")
    if len(raw) > MAX_CONFIG_BYTES:
        raise ConfigError(path, "-", f"is larger than {MAX_CONFIG_BYTES // 2**20} MB, not a config; a config is a "
                                     "short TOML text file (configs/cyberdog2.toml)")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(path, "-", f"is not UTF-8 text (byte {e.start}); a config is a TOML text file") from e


def base_of(path: Path, parent: str) -> Path:
    """The file the config ``path`` extends: ``parent`` relative to it, or a shipped config."""
    shipped = parent.startswith(SHIPPED)
    return (CONFIG_DIR / parent.removeprefix(SHIPPED) if shipped else path.parent / parent).resolve()


def _read_base(path: Path, parent: Any, chain: tuple[Path, ...]) -> dict[str, Any]:
    """The merged table of the config ``path`` extends (``parent``: its ``extends`` value); a base
    that cannot be read is named by the ``extends`` key of ``path``."""
    if not isinstance(parent, str):
        raise ConfigError(path, "extends", "must be a file name (string)")
    base_path = base_of(path, parent)
    try:
        return read_toml(base_path, (*chain, path.resolve()))[0]
    except ConfigError as e:
        if e.key != "-" or e.path != base_path:
            raise
        raise ConfigError(path, "extends", f"{parent!r} ({e.path}) {e.message}") from e


def defining_file(path: Path, key: str) -> Path | None:
    """The file of ``path``'s ``extends`` chain that writes the dotted ``key`` (``"board.mass_kg"``,
    ``"sweep.strides[1]"``): ``path`` itself when it does, else the nearest base that does; None
    when no file of the chain does (a key that is missing) or a file cannot be read."""
    parts = re.sub(r"\[\d+\]", "", key).split(".")
    seen: set[Path] = set()
    at: Path | None = Path(path).resolve()
    while at is not None and at not in seen:
        seen.add(at)
        try:
            data = tomllib.loads(at.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            return None
        table: Any = data
        for part in parts:
            table = table.get(part) if isinstance(table, dict) else None
        if table is not None:
            return at
        parent = data.get("extends")
        if not isinstance(parent, str):
            return None
        at = base_of(at, parent)
    return None


# Scalar types of config fields: what a TOML value must be, and the words for a wrong one.
_SCALARS: dict[type, tuple[Any, str]] = {
    float: (lambda v: isinstance(v, int | float) and not isinstance(v, bool), "a number"),
    int: (lambda v: isinstance(v, int) and not isinstance(v, bool), "an integer"),
    bool: (lambda v: isinstance(v, bool), "true or false"),
    str: (lambda v: isinstance(v, str), "a string"),
}


def _convert(path: Path, key: str, tp: Any, value: Any, meta: typing.Mapping[str, Any]) -> Any:
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise ConfigError(path, key, f"must be a table, got {value!r}")
        return build_section(path, key, tp, value)
    if typing.get_origin(tp) is tuple:
        if not isinstance(value, list):
            raise ConfigError(path, key, f"must be a list, got {value!r}")
        (inner,) = set(typing.get_args(tp)) - {Ellipsis}
        return tuple(_convert(path, f"{key}[{i}]", inner, v, meta) for i, v in enumerate(value))
    if tp in _SCALARS:
        valid, words = _SCALARS[tp]
        if not valid(value):
            raise ConfigError(path, key, f"must be {words}, got {value!r}")
    if tp is float:
        value = float(value)
        if not math.isfinite(value):
            raise ConfigError(path, key, f"must be a finite number, got {value!r} ({meta.get('doc', '')})")
    if tp in (float, int):
        _check_range(path, key, value, meta)
    return value


def _check_range(path: Path, key: str, value: float, meta: typing.Mapping[str, Any]) -> None:
    lo, hi = meta.get("lo"), meta.get("hi")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ConfigError(path, key, f"{value!r} is out of range [{lo}, {hi}] ({meta.get('doc', '')})")


def build_section(path: Path, prefix: str, cls: type, data: dict[str, Any]) -> Any:
    """Validate one TOML table into the frozen dataclass ``cls``.

    Raises:
        ConfigError: On unknown or missing keys, wrong types or values out of range.
    """
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = typing.get_type_hints(cls)
    unknown = set(data) - set(fields)
    renamed: dict[str, str] = getattr(cls, "RENAMED", {})  # a key of an earlier format -> what to write now
    for key in sorted(unknown & set(renamed)):
        raise ConfigError(path, f"{prefix}.{key}", renamed[key])
    if unknown:
        raise ConfigError(path, f"{prefix}.{sorted(unknown)[0]}",
                          f"unknown key; allowed keys in [{prefix}]: {', '.join(fields)}")
    kwargs: dict[str, Any] = {}
    for name, f in fields.items():
        key = f"{prefix}.{name}"
        if name not in data:
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise ConfigError(path, key, f"missing; {f.metadata.get('doc', '')}")
            continue
        tp = hints[name]
        if isinstance(tp, types.UnionType):
            tp = typing.get_args(tp)[0]
        kwargs[name] = _convert(path, key, tp, data[name], f.metadata)
    return cls(**kwargs)


def sections(path: Path, data: dict[str, Any], tables: dict[str, type], optional: tuple[str, ...] = ()
             ) -> dict[str, Any]:
    """Validate every table of a config; unknown or missing tables are errors. ``optional``: the
    tables the caller reads itself (taken out of ``data``), named among the allowed ones."""
    unknown = set(data) - set(tables)
    if unknown:
        raise ConfigError(path, sorted(unknown)[0], f"unknown table; allowed: {', '.join([*tables, *optional])}")
    out = {}
    for name, cls in tables.items():
        if name not in data:
            raise ConfigError(path, name, f"missing table [{name}]")
        out[name] = build_section(path, name, cls, data[name])
    return out


def check_unique_keys(path: Path, velocities: tuple[float, ...], field: str = "sweep.velocities_mps") -> None:
    """Refuse speeds that repeat or that name the same entry (keys keep 2 decimals: 0.501 and 0.504
    are both ``v0.50``), before anything is solved.

    Raises:
        ConfigError: Naming both speeds and the key they share.
    """
    seen: dict[str, float] = {}
    for v in velocities:
        key = f"{v:.2f}"
        if key in seen:
            raise ConfigError(path, field,
                              f"{seen[key]} and {v} m/s both name entry speed v{key} (entry keys keep 2 decimals); "
                              "list speeds that differ by at least 0.01 m/s, each once")
        seen[key] = v


def field_range(cls: type, name: str) -> tuple[float, float]:
    """The allowed [lo, hi] of a config field, as declared once in its dataclass."""
    meta = {f.name: f.metadata for f in dataclasses.fields(cls)}[name]
    return float(meta["lo"]), float(meta["hi"])
