"""The shape of a library's index (``/packed/index``), checked once when a file is opened and before
anything in it is used: every reader (``read_library``, and through it ``MotionLibrary``, the
command line's ``info``, ``export``, ``plot``, ``track``, ``validate``) gets an index whose
entries are objects with plain, unique keys, so that no key names a path outside a folder, reaches
the terminal as control characters or breaks a reader with a traceback."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from skatelib.library import schema
from skatelib.library.errors import LibraryFormatError

FIELD = f"/{schema.G_PACKED}/{schema.D_INDEX}"
ENTRY_FIELDS = ("key", "attrs", "rows", "columns", "units")
_ALTERED = "the file was not written by skatelib, or was altered after; do not use it: rebuild it with 'skatelib build'"


def check_index(path: Path, index: Any) -> None:
    """Refuse an index of another shape than the writer's (docs/library-format.md, "Storage").

    Raises:
        LibraryFormatError: Naming the file, the entry (its key escaped) and what is wrong.
    """
    if not isinstance(index, dict):
        raise LibraryFormatError(path, FIELD, f"the index is not a JSON object; {_ALTERED}")
    for name, kind in (("root", dict), ("model", dict), ("entries", list)):
        if name not in index:
            raise LibraryFormatError(path, FIELD, f"index lacks {name!r}; {_ALTERED}")
        if not isinstance(index[name], kind):
            raise LibraryFormatError(path, FIELD, f"the index's {name!r} is not a JSON {_JSON[kind]}; {_ALTERED}")
    _check_model(path, index)
    seen: set[str] = set()
    for i, meta in enumerate(index["entries"]):
        key = _check_entry(path, i, meta)
        if key in seen:
            raise LibraryFormatError(path, f"/{schema.G_ENTRIES}/{key}",
                                     f"the index names this entry twice; keys are unique in a library; {_ALTERED}")
        seen.add(key)


_JSON = {dict: "object", list: "list", str: "string"}


def _check_entry(path: Path, i: int, meta: Any) -> str:
    """One entry of the index: an object with every field, a plain key and fields of their types;
    returns its key."""
    where = f"{FIELD} entries[{i}]"
    if not isinstance(meta, dict):
        raise LibraryFormatError(path, where, f"is not a JSON object with {', '.join(ENTRY_FIELDS)}; {_ALTERED}")
    missing = [f for f in ENTRY_FIELDS if f not in meta]
    if missing:
        raise LibraryFormatError(path, where, f"lacks {', '.join(missing)}; {_ALTERED}")
    why = schema.entry_key_problem(meta["key"])
    if why:
        raise LibraryFormatError(path, where, f"{why}; {_ALTERED}")
    key: str = meta["key"]
    base = f"/{schema.G_ENTRIES}/{key}"
    if not isinstance(meta["attrs"], dict):
        raise LibraryFormatError(path, base, f"its attributes are not a JSON object; {_ALTERED}")
    for name in ("columns", "units"):
        table = meta[name]
        if not isinstance(table, dict) or not all(_strings(v) for v in table.values()):
            raise LibraryFormatError(path, base, f"its {name} are not lists of strings by dataset; {_ALTERED}")
    rows = meta["rows"]
    if not isinstance(rows, dict) or not all(_row_range(v) for v in rows.values()):
        raise LibraryFormatError(path, base, f"its rows are not [start, stop] pairs by dataset; {_ALTERED}")
    return key


def _check_model(path: Path, index: dict[str, Any]) -> None:
    """The mirrors of /model: arrays as {dtype, shape, data}, texts as strings."""
    arrays, texts = index.get("model_arrays", {}), index.get("model_text", {})
    if not isinstance(arrays, dict) or not all(
            isinstance(a, dict) and isinstance(a.get("dtype"), str) and isinstance(a.get("shape"), list)
            and all(_integer(n) for n in a["shape"]) and "data" in a for a in arrays.values()):
        raise LibraryFormatError(path, FIELD, f"the index's 'model_arrays' are not {{dtype, shape, data}} objects; "
                                              f"{_ALTERED}")
    if not isinstance(texts, dict) or not _strings(list(texts.values())):
        raise LibraryFormatError(path, FIELD, f"the index's 'model_text' is not strings by name; {_ALTERED}")


def _integer(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _strings(v: Any) -> bool:
    return isinstance(v, list) and all(isinstance(s, str) for s in v)


def _row_range(v: Any) -> bool:
    return isinstance(v, list) and len(v) == 2 and all(_integer(n) for n in v)
