"""Cache payloads in a form that runs no code when read: a JSON manifest of the payload's structure
and its numpy arrays, together in one ``.npz`` that is read with ``allow_pickle=False``.

The manifest holds None, booleans, numbers, strings, lists, and tagged values: ``{"$a": name}`` an
array, ``{"$g": name}`` a numpy scalar (a 0-d array), ``{"$t": [...]}`` a tuple, ``{"$d": {...}}``
a dict with string keys, ``{"$c": type, "f": {...}}`` a dataclass. Only dataclasses registered with
:func:`register` (by their module and qualified name) are rebuilt; a manifest that names any other
type, an object array, or a malformed node is refused with :class:`PayloadError`.
"""

from __future__ import annotations

import dataclasses
import io
import json
import zipfile
from typing import Any

import numpy as np

_TYPES: dict[str, type] = {}
_MANIFEST = "manifest"


class PayloadError(ValueError):
    """A payload that cannot be written or read in the safe form (the message says what)."""


def _name(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def register(*types: type) -> None:
    """Allow these dataclasses in payloads (the kinds register what they cache)."""
    for cls in types:
        if not dataclasses.is_dataclass(cls):
            raise TypeError(f"{cls!r} is not a dataclass")
        _TYPES[_name(cls)] = cls


def encode(obj: Any) -> bytes:
    """``obj`` as the bytes of an ``.npz`` (module docstring).

    Raises:
        PayloadError: A value of a kind the format does not hold (an object array, an
            unregistered class, a dict with non-string keys).
    """
    w = _Writer()
    manifest = json.dumps(w.node(obj)).encode()
    buf = io.BytesIO()
    members: dict[str, Any] = {_MANIFEST: np.frombuffer(manifest, dtype=np.uint8), **w.arrays}
    np.savez(buf, **members)
    return buf.getvalue()


class _Writer:
    """The manifest of one payload, collecting its arrays."""

    def __init__(self) -> None:
        self.arrays: dict[str, np.ndarray] = {}

    def node(self, o: Any) -> Any:
        if o is None or isinstance(o, (bool, str)) or (isinstance(o, (int, float)) and not isinstance(o, np.generic)):
            return o
        if isinstance(o, (np.ndarray, np.generic)):
            return self._array(o)
        if isinstance(o, (tuple, list, dict)):
            return self._container(o)
        if dataclasses.is_dataclass(o) and not isinstance(o, type):
            name = _name(type(o))
            if _TYPES.get(name) is not type(o):
                raise PayloadError(f"{name} is not registered for the cache (skatelib.pipeline.build.codec.register)")
            return {"$c": name, "f": {f.name: self.node(getattr(o, f.name)) for f in dataclasses.fields(o)}}
        raise PayloadError(f"a {type(o).__name__} cannot be cached safely")

    def _array(self, o: np.ndarray | np.generic) -> dict[str, str]:
        a = np.asarray(o)
        if a.dtype.hasobject:
            raise PayloadError("an object array cannot be cached safely")
        name = f"a{len(self.arrays)}"
        self.arrays[name] = a
        return {"$a" if isinstance(o, np.ndarray) else "$g": name}

    def _container(self, o: tuple[Any, ...] | list[Any] | dict[Any, Any]) -> Any:
        if isinstance(o, tuple):
            return {"$t": [self.node(v) for v in o]}
        if isinstance(o, list):
            return [self.node(v) for v in o]
        if not all(isinstance(k, str) for k in o):
            raise PayloadError("a dict with keys other than strings cannot be cached safely")
        return {"$d": {k: self.node(v) for k, v in o.items()}}


def decode(blob: bytes) -> Any:
    """The object :func:`encode` wrote into ``blob``.

    Raises:
        PayloadError: Not such a payload, or one that names an unregistered type.
    """
    try:
        with np.load(io.BytesIO(blob), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as e:  # not an npz, damaged, or pickled objects
        raise PayloadError(f"not a cache payload ({e})") from e
    try:
        manifest = json.loads(bytes(arrays.pop(_MANIFEST)).decode())
    except (KeyError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise PayloadError(f"no readable manifest ({type(e).__name__})") from e
    return _dec(manifest, arrays)


def _dec(node: Any, arrays: dict[str, np.ndarray]) -> Any:
    if node is None or isinstance(node, (bool, int, float, str)):
        return node
    if isinstance(node, list):
        return [_dec(v, arrays) for v in node]
    if not isinstance(node, dict) or len(node) not in (1, 2):
        raise PayloadError("a malformed manifest node")
    if "$a" in node or "$g" in node:
        name = node.get("$a", node.get("$g"))
        if name not in arrays:
            raise PayloadError(f"the manifest names a missing array {name!r}")
        return arrays[name] if "$a" in node else arrays[name][()]
    if "$t" in node:
        return tuple(_dec(v, arrays) for v in node["$t"])
    if "$d" in node and isinstance(node["$d"], dict):
        return {k: _dec(v, arrays) for k, v in node["$d"].items()}
    if "$c" in node and isinstance(node.get("f"), dict):
        cls = _TYPES.get(node["$c"])
        if cls is None:
            raise PayloadError(f"the payload names a type that is not registered: {node['$c']!r}")
        return cls(**{k: _dec(v, arrays) for k, v in node["f"].items()})
    raise PayloadError("a malformed manifest node")
