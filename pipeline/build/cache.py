"""The entry cache of a build, for every robot kind: each solved entry under a key of what
determines it (each kind says what that is), checksummed, so that an interrupted build resumes and
a changed problem (code, config, URDF, options) never gets an old trajectory. The folder is the
user's cache (``SKATELIB_CACHE_DIR``, :func:`skatelib.library.trust.cache_dir`).

A payload is stored in a form that runs no code when read (:mod:`skatelib.pipeline.build.codec`:
arrays and a JSON manifest); files of the older pickled form (``*.pkl``) are never opened. Entries
are read only from folders and files :mod:`skatelib.library.trust` allows: the user's own
cache, then a shared read-only one named in ``SKATELIB_TRUSTED_CACHE``; new entries go to the
user's own."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from skatelib.library import schema, trust
from skatelib.library.atomic import atomic_path
from skatelib.library.trust import cache_dir
from skatelib.pipeline.build import codec

# Bump when a kind's retry ladder, the solve's post-processing or the cached payload changes: the
# keys cover the problems themselves (stage functions, bounds, guesses, plans, options), not that code.
CACHE_VERSION = "4"
_MAGIC = b"skatelib-entry-cache 3\n"

def cache_key(*parts: Any) -> str:
    """The key of an entry determined by ``parts`` (JSON-serializable), the library format and
    :data:`CACHE_VERSION`; 32 hex digits."""
    src = json.dumps([CACHE_VERSION, schema.FORMAT_VERSION_STR, *parts], sort_keys=True, default=str)
    return hashlib.sha256(src.encode()).hexdigest()[:32]


def cache_file(key: str, folder: Path | None = None) -> Path:
    """Where the entry of ``key`` is cached (in the user's cache, or in ``folder``)."""
    return (cache_dir() if folder is None else folder) / "entries" / f"{key}.entry"


def load_cached(path: Path, fields: tuple[str, ...]) -> dict[str, Any] | str | None:
    """The cached payload (a dict with ``fields``), ``None`` when absent, or a message when the
    file is damaged or not such a payload."""
    if not path.exists():
        return None
    why = trust.file_problem(path)
    if why:
        return f"cache entry {path} {why}, not trusted"
    try:
        blob = path.read_bytes()
    except FileNotFoundError:
        return None
    except OSError as e:
        return f"cache entry {path} unreadable ({e.strerror})"
    head, sep, payload = blob.partition(b"\n" + b"-" * 8 + b"\n")
    if not sep or not head.startswith(_MAGIC) or head[len(_MAGIC):].decode(errors="replace") != (
            hashlib.sha256(payload).hexdigest()):
        return f"cache entry {path} is damaged (checksum mismatch)"
    try:
        obj = codec.decode(payload)
        if not isinstance(obj, dict) or not set(fields) <= set(obj):
            raise codec.PayloadError(f"a {type(obj).__name__} without the fields {', '.join(fields)}")
        return obj
    except (codec.PayloadError, TypeError) as e:
        return f"cache entry {path} cannot be loaded ({e})"


def store(path: Path, payload_obj: dict[str, Any]) -> None:
    """Cache an entry's payload (checksummed; written atomically)."""
    payload = codec.encode(payload_obj)
    blob = _MAGIC + hashlib.sha256(payload).hexdigest().encode() + b"\n" + b"-" * 8 + b"\n" + payload
    with atomic_path(path) as tmp:  # parallel workers never read a half-written entry
        tmp.write_bytes(blob)


def cached_or_solved(key: str, fields: tuple[str, ...], solve: Callable[[], dict[str, Any]],
                     use_cache: bool) -> tuple[dict[str, Any], bool, str]:
    """The payload cached under ``key`` (a dict with ``fields``), or ``solve()``'s, which is then
    cached. Returns it, whether it came from the cache, and a note for the user when a damaged or
    unreadable cache entry was solved again (and so repaired)."""
    path = cache_file(key)
    hit = load_cached(path, fields) if use_cache else None
    shared = trust.trusted_cache()
    if use_cache and hit is None and shared is not None:
        hit = load_cached(cache_file(key, shared), fields)
    if isinstance(hit, dict):
        return hit, True, ""
    payload = solve()
    if use_cache:
        store(path, payload)
    return payload, False, f"{hit}; solved again" if isinstance(hit, str) else ""
