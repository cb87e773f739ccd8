"""Who may have written what the cache serves. A build loads compiled stage functions (native code)
and solved entries from its cache folder, the estimator its compiled tick, so they use only
material no one else could have put there:

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

CACHE_ENV = "SKATELIB_CACHE_DIR"
COMPILE_ENV = "SKATELIB_COMPILE_DIR"
TRUSTED_ENV = "SKATELIB_TRUSTED_CACHE"
OTHERS_WRITE = stat.S_IWGRP | stat.S_IWOTH


def cache_dir() -> Path:
    """The user's own cache folder (``$SKATELIB_CACHE_DIR`` or ~/.cache/skatelib): a build's entries
    and compiled stage functions, the estimator's compiled tick (``native/``)."""
    base = os.environ.get(CACHE_ENV) or os.path.join(os.path.expanduser("~"), ".cache", "skatelib")
    return Path(base)


def compile_dir() -> Path:
    """Where compiled code is kept: ``$SKATELIB_COMPILE_DIR``, else the cache folder. Each library in
    it is named by a hash of what it computes, the compiler's flags and the CPU, so one folder serves
    any number of entry caches (a fresh ``SKATELIB_CACHE_DIR`` per experiment compiles nothing again)."""
    own = os.environ.get(COMPILE_ENV)
    return Path(own) if own else cache_dir()


def trusted_cache() -> Path | None:
    """The shared read-only cache named in ``$SKATELIB_TRUSTED_CACHE``, if any."""
    value = os.environ.get(TRUSTED_ENV)
    return Path(value) if value else None


def own_rule(st: os.stat_result) -> str:
    """Why a file or folder of this status must not be used from the user's own cache ("" when it may)."""
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return f"belongs to another user (uid {st.st_uid})"
    if st.st_mode & OTHERS_WRITE:
        return f"can be written by others (mode {stat.filemode(st.st_mode)})"
    return ""


def own_problem(path: Path) -> str:
    """Why ``path`` (in the user's own cache) must not be used, or "" when it may."""
    try:
        return own_rule(path.stat())
    except OSError as e:
        return f"cannot be checked ({e.strerror})"


def shared_problem(path: Path) -> str:
    """Why ``path`` (in the trusted shared cache) must not be used, or "" when it may."""
    try:
        st = path.stat()
    except OSError as e:
        return f"cannot be checked ({e.strerror})"
    if st.st_mode & OTHERS_WRITE:
        return f"can be written by others (mode {stat.filemode(st.st_mode)})"
    if os.access(path, os.W_OK):
        return f"can be written by you: a shared cache in {TRUSTED_ENV} must be read-only to its users"
    return ""


def above_problem(folder: Path, owner: int | None = None) -> tuple[Path, str] | None:
    """A folder above ``folder`` through which someone else could replace it, and why; None when
    there is none. Each folder of its real path (no symlink is left in it) must belong to root,
    the user or ``owner`` (a shared cache's account), and be writable by no one else unless it
    has the sticky bit (as /tmp has: others cannot rename what they do not own there)."""
    owners = {0, owner, os.getuid()} if hasattr(os, "getuid") else set()
    for d in folder.resolve().parents:
        try:
            st = d.lstat()
        except OSError as e:
            return d, f"cannot be checked ({e.strerror})"
        if owners and st.st_uid not in owners:
            return d, f"belongs to another user (uid {st.st_uid})"
        if st.st_mode & OTHERS_WRITE and not st.st_mode & stat.S_ISVTX:
            return d, f"can be written by others (mode {stat.filemode(st.st_mode)})"
    return None


def file_problem(path: Path) -> str:
    """Why a cached file must not be loaded ("" when it may): by the rules of the cache it is in,
    for the file and the folder that holds it."""
    shared = trusted_cache()
    rule = shared_problem if shared is not None and inside(path, shared) else own_problem
    why = rule(path)
    if why:
        return why
    folder = rule(path.parent)
    return f"is in a folder that {folder}" if folder else ""


OWN_ADVICE = "point SKATELIB_CACHE_DIR to a folder of your own, or pass --no-cache"
# Compiled code is kept in the folder of compiled code (compile_dir) even with --no-cache (solve, frontier too).
def compile_advice() -> str:
    """What to do when the folder of compiled code may not be used (it names the variable in force)."""
    env = COMPILE_ENV if os.environ.get(COMPILE_ENV) else CACHE_ENV
    return f"point {env} to a folder of your own, or set [optimization] compile = false"


def check_own(folder: Path, advice: str = OWN_ADVICE) -> None:
    """The user's cache folder and its subfolders pass :func:`own_problem`, the folders above it
    :func:`above_problem`.

    Args:
        advice: What else the user can do (the command's options).

    Raises:
        OutputError: Naming the folder at fault and saying what to do.
    """
    for d in _folders(folder):
        why = own_problem(d)
        if why:
            raise OutputError(d, f"the cache folder {why}: whoever can write it can run code in your builds "
                                 f"and controller. Fix it (chmod go-w {d}), or {advice}")
    above = above_problem(folder)
    if above is not None:
        d, why = above
        raise OutputError(folder, f"the cache folder is inside {d}, which {why}: whoever can write there can "
                                  f"replace the cache and run code in your builds and controller. Fix that folder, "
                                  f"or {advice}")


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
    above = above_problem(folder, folder.stat().st_uid)
    if above is not None:
        d, why = above
        raise OutputError(folder, f"the shared cache named in ${TRUSTED_ENV} is inside {d}, which {why}: "
                                  f"whoever can write there can replace it. Unset {TRUSTED_ENV}")


def _folders(cache: Path) -> tuple[Path, ...]:
    """A cache folder and its ``entries`` folder, when it has one."""
    entries = cache / "entries"
    return (cache, entries) if entries.exists() else (cache,)


def inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` (followed) lies in ``folder``."""
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
