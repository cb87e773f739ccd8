"""A compiled library from the cache (the build's stage functions, the estimator's tick), checked
and loaded as one thing: its bytes are read once, through a descriptor that follows no symlink, and
checked (the rules of its cache, :mod:`.trust`, for the file, its folder and every folder above it;
the SHA-256 recorded when it was built). The loader gets those very bytes, written to a private
copy (:func:`private_copy`), so a file replaced or relinked after the check is never what runs.
Standard library only: the robot's controller uses it as the build does."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import mmap
import os
import stat
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar, cast

from skatelib.library import trust
from skatelib.library.errors import OutputError
from skatelib.library.temporaries import temporary_folder

T = TypeVar("T")
_HELD: dict[Path, tuple[tuple[int, ...], Any]] = {}  # held_or_loaded's: by library, its status and what was loaded
_OPEN = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)  # a fifo does not block


def read_nofollow(path: Path) -> tuple[bytes, os.stat_result]:
    """The bytes and the status of the regular file at ``path``, from one descriptor.

    Raises:
        OSError: ``ELOOP`` when ``path`` is a symbolic link, ``EINVAL`` when it is no regular file,
            or why it cannot be opened or read.
    """
    fd = os.open(path, _OPEN)
    with os.fdopen(fd, "rb") as f:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise OSError(errno.EINVAL, "not a regular file")
        return f.read(), st


def _unreadable(path: Path, e: OSError) -> str:
    if e.errno == errno.ELOOP:
        return (f"is a symbolic link{'' if path.suffix == '.so' else ' (its SHA-256 record)'}: a compiled library is "
                "loaded only from a file of its own in the cache folder")
    if isinstance(e, FileNotFoundError) and path.suffix != ".so":
        return "has no recorded SHA-256"
    return f"cannot be read ({e.strerror})"


def checked_code(lib: Path) -> tuple[bytes | None, str]:
    """The bytes of the compiled library ``lib`` when they may be loaded, else None and why: a
    symlink (the library or its record), a file or folder of its cache that others could change
    (:func:`trust.file_problem`, :func:`trust.above_problem`), or bytes whose SHA-256 is not the
    one recorded when it was built."""
    shared = trust.trusted_cache()
    in_shared = shared is not None and trust.inside(lib, shared)
    if lib.is_symlink():
        return None, _unreadable(lib, OSError(errno.ELOOP, "symbolic link"))
    why = trust.file_problem(lib)
    if why:
        return None, why
    owner = shared.stat().st_uid if shared is not None and in_shared else None  # the shared cache's account
    above = trust.above_problem(lib.parent, owner)
    if above is not None:
        return None, f"is inside {above[0]}, which {above[1]}"
    record = trust.digest_record(lib)
    try:
        code, st = read_nofollow(lib)
    except OSError as e:
        return None, _unreadable(lib, e)
    try:
        recorded, record_st = read_nofollow(record)
    except OSError as e:
        return None, _unreadable(record, e)
    for what, s in (("", st), (" (its SHA-256 record)", record_st)):  # as opened, not as checked before
        why = (f"can be written by others (mode {stat.filemode(s.st_mode)})" if s.st_mode & trust.OTHERS_WRITE
               else "") if in_shared else trust.own_rule(s)
        if why:
            return None, why + what
    if recorded.decode(errors="replace").strip() != hashlib.sha256(code).hexdigest():
        return None, "changed after it was built (its SHA-256 differs from the one recorded then)"
    return code, ""


def usable_code(own: Path) -> tuple[bytes | None, str]:
    """The checked bytes to load for ``own`` (a compiled library's path in the user's cache): its
    own, or those of the same name in the trusted shared cache, or None (compile it); and a note
    when ``own`` existed but was refused."""
    note = ""
    if os.path.lexists(own):
        code, why = checked_code(own)
        if code is not None:
            return code, ""
        note = f"compiled library {own} {why}: not loaded, compiled again"
    shared = trust.trusted_cache()
    if shared is not None and os.path.lexists(shared / own.name):
        code, _ = checked_code(shared / own.name)
        if code is not None:
            return code, note
    return None, note


def cached_or_compiled(lib: Path, advice: str, compile: Callable[[], bytes]) -> bytes:
    """The checked bytes of the compiled library ``lib``: from the cache (:func:`usable_code`) or,
    when there are none to load, from ``compile()`` (which writes ``lib`` and its record,
    :func:`record_and_place`), under a lock so that processes started together compile once and
    the others load its library. ``lib``'s folder is created private and must pass
    :func:`trust.check_own` (``advice``: what else the user can do); a cached library refused says
    why in a :class:`trust.CacheNote`.

    Raises:
        OutputError: The folder, or one above it, can be changed by someone else.
    """
    lib.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    trust.check_own(lib.parent, advice)  # code is compiled, copied and loaded there
    code, note = usable_code(lib)  # only from a folder no one else can write, as built
    if note:
        warnings.warn(note, trust.CacheNote, stacklevel=3)
    if code is None:
        with locked(lib.with_suffix(".lock")):
            code, _ = usable_code(lib)
            if code is None:
                code = compile()
    return code


def held_or_loaded(lib: Path, load: Callable[[], T]) -> T:
    """What ``load()`` gives (it checks the compiled library ``lib`` and loads its bytes), once per
    process while ``lib`` and its SHA-256 record are the files they were when it ran: another
    problem of the same model in this process reads and checks nothing from the disk again. A hit
    reads nothing from the disk, so what runs is still what was checked; a file changed or replaced
    since (a new status: inode, size, times) is checked and loaded anew."""
    before = _status(lib)
    held = _HELD.get(lib)
    if held is not None and before is not None and held[0] == before:
        return cast(T, held[1])
    value = load()
    after = _status(lib)
    if after is not None and before in (None, after):  # not replaced while it was loaded
        _HELD[lib] = (after, value)
    return value


def _status(lib: Path) -> tuple[int, ...] | None:
    try:
        st, rec = os.lstat(lib), os.lstat(trust.digest_record(lib))
    except OSError:
        return None
    fields = ("st_dev", "st_ino", "st_size", "st_mtime_ns", "st_ctime_ns")
    return tuple(getattr(s, f) for s in (st, rec) for f in fields)


def record_and_place(code_file: Path, lib: Path) -> bytes:
    """Move the freshly compiled ``code_file`` (in a private folder beside ``lib``) to ``lib`` with
    its SHA-256 record; returns its bytes, read before the move. The record goes first: a reader
    never trusts a half-written library, and processes started together load a whole one."""
    code = code_file.read_bytes()
    record = code_file.with_name(code_file.name + ".sha256")
    record.write_text(hashlib.sha256(code).hexdigest() + "\n")
    os.replace(record, trust.digest_record(lib))
    os.replace(code_file, lib)
    return code


@contextlib.contextmanager
def locked(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` (created) while the block runs; others wait for it."""
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


@contextlib.contextmanager
def private_copy(code: bytes, folder: Path, name: str = "lib.so") -> Iterator[Path]:
    """``code`` (checked by the caller) as a file of this process's own, named ``name`` in a new
    folder of this process (mode 0700) in ``folder``, for the block to load; removed when it ends
    (loaded code stays mapped). What runs is what was checked, whatever happens to the cached file
    meanwhile. Where the system has anonymous memory files (Linux's ``memfd_create``) and executes
    them, the code is one of them and the name a link to it: nothing is written to the disk.

    Raises:
        OutputError: The copy cannot be written (a full disk, a file-size limit), naming ``folder``.
    """
    with temporary_folder(folder, "load") as private, _in_memory(code, name) as memory:
        so = private / name
        if memory is not None:
            so.symlink_to(memory)
            yield so
            return
        try:
            fd = os.open(so, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
            with os.fdopen(fd, "wb") as f:
                f.write(code)
        except OSError as e:
            raise OutputError(folder, f"the compiled code ({len(code):,} bytes) cannot be copied there to be "
                                      f"loaded ({e.strerror}): make room on its disk, or point {trust.COMPILE_ENV} "
                                      "to a folder on another") from e
        yield so


@contextlib.contextmanager
def _in_memory(code: bytes, name: str) -> Iterator[str | None]:
    """The path of an anonymous memory file of this process holding ``code`` while the block runs,
    or None where there is none (no ``memfd_create``, no ``/proc``, or the system refuses one, or
    refuses to execute it: Linux's ``vm.memfd_noexec``)."""
    fd = -1
    if hasattr(os, "memfd_create") and os.path.isdir("/proc/self/fd"):
        try:
            fd = os.memfd_create(name, os.MFD_CLOEXEC)
            with os.fdopen(os.dup(fd), "wb") as f:
                f.write(code)
            mmap.mmap(fd, len(code), prot=mmap.PROT_READ | mmap.PROT_EXEC).close()  # as the loader maps it
        except (OSError, ValueError):  # ValueError: empty code cannot be mapped
            if fd >= 0:
                os.close(fd)
            fd = -1
    try:
        yield f"/proc/self/fd/{fd}" if fd >= 0 else None
    finally:
        if fd >= 0:
            os.close(fd)
