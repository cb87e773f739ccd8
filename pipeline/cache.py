"""The entry cache of a build: each solved entry under a key of what determines it, checksummed,
so that an interrupted build resumes and a changed problem (code, config, URDF, options) never
gets an old trajectory. The folder is the compiled-code cache's (``SKATELIB_CACHE_DIR``)."""

from __future__ import annotations

import hashlib
import json
import pickle
from pathlib import Path

from skatelib.library import schema
from skatelib.library.atomic import atomic_path
from skatelib.pipeline.ocp.stagewise import cache_dir
from skatelib.pipeline.quadruped.pushoff import PushoffSpec, SolveResult, problem_for, solver_options

CACHE_VERSION = "2"
_MAGIC = b"skatelib-entry-cache 2\n"


def entry_key(spec: PushoffSpec, predecessor: str | None) -> str:
    """Cache key of an entry: what determines its solution.

    The problem's fingerprint (stage function, problem config with the URDF by content, parameters,
    bounds, cold guess), the IPOPT options, target and strides, the key of the entry whose solution
    warm-starts it (``None`` when cold), the library format and :data:`CACHE_VERSION`.
    """
    prob = problem_for(spec.config, spec.n_strides)
    v = spec.target_velocity_mps
    src = json.dumps([CACHE_VERSION, schema.FORMAT_VERSION_STR, prob.fingerprint(v, spec.guess),
                      solver_options(spec), round(v, 9), spec.n_strides, predecessor], sort_keys=True, default=str)
    return hashlib.sha256(src.encode()).hexdigest()[:32]


def cache_file(key: str) -> Path:
    """Where the entry of ``key`` is cached."""
    return cache_dir() / "entries" / f"{key}.pkl"


def load_cached(path: Path) -> tuple[SolveResult, int] | str | None:
    """The cached (result, attempts), ``None`` when absent, or a message when the file is damaged."""
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
        obj = pickle.loads(payload)
        return obj["result"], obj["attempts"]
    except (pickle.UnpicklingError, EOFError, KeyError, AttributeError, ImportError, TypeError) as e:
        return f"cache entry {path} cannot be loaded ({type(e).__name__})"


def store(path: Path, result: SolveResult, attempts: int) -> None:
    """Cache a result (checksummed; written atomically)."""
    payload = pickle.dumps({"result": result, "attempts": attempts})
    blob = _MAGIC + hashlib.sha256(payload).hexdigest().encode() + b"\n" + b"-" * 8 + b"\n" + payload
    with atomic_path(path) as tmp:  # parallel workers never read a half-written entry
        tmp.write_bytes(blob)
