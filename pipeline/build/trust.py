"""Who may have written what the cache serves. A build loads compiled stage functions (native code)
and solved entries from its cache folder, so it uses only material no one else could have put
there:

* the user's own cache (``SKATELIB_CACHE_DIR``, default ``~/.cache/skatelib``): the folder, its
  subfolders and every file read from it belong to the user and carry no group or world write bit;
* a shared cache prepared by a trusted account, named in ``SKATELIB_TRUSTED_CACHE``: read only,
  its folder and files not writable by the current user nor by group or world. Nothing is ever
  written to it; what a build solves or compiles goes to the user's own cache.

(Like ssh with its key files and git's ``safe.directory``: refuse, name the place, say what to do.)
"""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path

from skatelib.library.errors import OutputError

TRUSTED_ENV = "SKATELIB_TRUSTED_CACHE"
_OTHERS_WRITE = stat.S_IWGRP | stat.S_IWOTH


def trusted_cache() -> Path | None:
    """The shared read-only cache named in ``$SKATELIB_TRUSTED_CACHE``, if any."""
    value = os.environ.get(TRUSTED_ENV)
    return Path(value) if value else None


def own_problem(path: Path) -> str:
    """Why ``path`` (in the user's own cache) must not be used, or "" when it may."""
    try:
        st = path.stat()
    except OSError as e:
        return f"cannot be checked ({e.strerror})"
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return f"belongs to another user (uid {st.st_uid})"
    if st.st_mode & _OTHERS_WRITE:
        return f"can be written by others (mode {stat.filemode(st.st_mode)})"
    return ""


def shared_problem(path: Path) -> str:
    """Why ``path`` (in the trusted shared cache) must not be used, or "" when it may."""
    try:
        st = path.stat()
    except OSError as e:
        return f"cannot be checked ({e.strerror})"
    if st.st_mode & _OTHERS_WRITE:
        return f"can be written by others (mode {stat.filemode(st.st_mode)})"
    if os.access(path, os.W_OK):
        return f"can be written by you: a shared cache in {TRUSTED_ENV} must be read-only to its users"
    return ""


def file_problem(path: Path) -> str:
    """Why a cached file must not be loaded ("" when it may): by the rules of the cache it is in,
    for the file and the folder that holds it."""
    shared = trusted_cache()
    rule = shared_problem if shared is not None and _inside(path, shared) else own_problem
    why = rule(path)
    if why:
        return why
    folder = rule(path.parent)
    return f"is in a folder that {folder}" if folder else ""


def check_own(folder: Path) -> None:
    """The user's cache folder and its subfolders pass :func:`own_problem`.

    Raises:
        OutputError: Naming the folder and saying what to do.
    """
    for d in _folders(folder):
        why = own_problem(d)
        if why:
            raise OutputError(d, f"the cache folder {why}: whoever can write it can run code in your builds. "
                                 f"Fix it (chmod go-w {d}), point SKATELIB_CACHE_DIR to a folder of your own, "
                                 "or pass --no-cache")


def check_shared(folder: Path) -> None:
    """The trusted shared cache, when named, exists and passes :func:`shared_problem`.

    Raises:
        OutputError: Naming the folder and ``$SKATELIB_TRUSTED_CACHE``.
    """
    for d in _folders(folder):
        why = shared_problem(d)
        if why:
            raise OutputError(d, f"the shared cache named in ${TRUSTED_ENV} {why}. Have its owner make it "
                                 f"read-only (chmod -R a-w {folder}), or unset {TRUSTED_ENV}")


def _folders(cache: Path) -> tuple[Path, ...]:
    """A cache folder and its ``entries`` folder, when it has one."""
    entries = cache / "entries"
    return (cache, entries) if entries.exists() else (cache,)


def _inside(path: Path, folder: Path) -> bool:
    try:
        path.resolve().relative_to(folder.resolve())
    except ValueError:
        return False
    return True


class CacheNote(UserWarning):
    """Something in the cache was not used and was made again (the message says what and why)."""


def digest_record(lib: Path) -> Path:
    """Where the SHA-256 of a compiled library, recorded when it was built, is kept."""
    return lib.with_name(lib.name + ".sha256")


def sha256_of(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def library_problem(lib: Path) -> str:
    """Why a compiled library must not be loaded ("" when it may): its folder's rules
    (:func:`file_problem`, for the library and its record) and the SHA-256 recorded when it was built."""
    record = digest_record(lib)
    why = file_problem(lib) or (file_problem(record) if record.exists() else "has no recorded SHA-256")
    if why:
        return why
    if record.read_text().strip() != sha256_of(lib):
        return "changed after it was built (its SHA-256 differs from the one recorded then)"
    return ""


def usable_library(own: Path) -> tuple[Path | None, str]:
    """The compiled library to load for ``own`` (its path in the user's cache): that one, or the
    same name in the trusted shared cache, or None (compile it); and a note when ``own`` existed but
    was refused."""
    note = ""
    if own.exists():
        why = library_problem(own)
        if not why:
            return own, ""
        note = f"compiled stage library {own} {why}: not loaded, compiled again"
    shared = trusted_cache()
    if shared is not None and (shared / own.name).exists() and not library_problem(shared / own.name):
        return shared / own.name, note
    return None, note
