"""Files that appear whole or not at all: a temporary file in the target folder (named as
:mod:`skatelib.library.temporaries` names skatelib's), then ``os.replace`` (libraries, cached
entries, recordings, figures); folders of files all or none (exports); and output file names taken
from a file's content, kept inside their folder."""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
from collections.abc import Iterator
from pathlib import Path

from skatelib.library.errors import OutputError
from skatelib.library.temporaries import MARKER, new_file, temporary_folder

# A write that fails for want of room: a full device, a quota, a file-size limit.
NO_ROOM = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


def _free_bytes(folder: Path) -> int | None:
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return None


def no_room(path: Path, needed: int | None, error: OSError | None = None) -> OutputError:
    """The error for a file (or a folder's files) that does not fit: the path, what it needs and
    what is free."""
    free = _free_bytes(path if path.is_dir() else path.parent)
    need = f"about {needed / 1e6:.2f} MB" if needed is not None else "more space"
    have = f"{free / 1e6:.2f} MB are free there" if free is not None else "the free space is unknown"
    why = f" ({error.strerror})" if error is not None and error.strerror else ""
    return OutputError(path, f"cannot be written: it needs {need} and {have}{why}; nothing was written and any "
                             "old file is untouched. Free some space, or choose another folder")


@contextlib.contextmanager
def atomic_path(path: Path, mode: int | None = None) -> Iterator[Path]:
    """Yield a temporary path in ``path``'s folder; on success it replaces ``path``, on error it is removed.

    Args:
        mode: The file's permission bits; None: an ordinary file's (0666 less the umask).

    Raises:
        OutputError: The device (or a quota or a file-size limit) had no room for the file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # Named as skatelib's, with the writer's pid: a later run removes a dead writer's leftover
    # (kill -9) and nothing else (temporaries.remove_stale_temporaries).
    tmp = new_file(path.parent, path.name)
    try:
        yield Path(tmp)
        if mode is None:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask  # mkstemp makes 0600; a library is an ordinary file
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException as e:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(e, OSError) and e.errno in NO_ROOM:
            raise no_room(path, None, e) from e
        raise


@contextlib.contextmanager
def atomic_folder(out: Path) -> Iterator[Path]:
    """Yield an empty staging folder for the files of the folder ``out``, all or none: when the
    block ends without error the staging folder becomes ``out`` (when ``out`` did not exist) or its
    files move into ``out``; on error (an interrupt included) it is removed, and so is every folder
    made for ``out``: nothing is left that was not there.

    Raises:
        OutputError: The device (or a quota or a file-size limit) had no room for the files.
    """
    out = Path(out)
    missing = []  # out and its ancestors that do not exist yet, deepest first
    p = out
    while not p.exists() and p != p.parent:
        missing.append(p)
        p = p.parent
    home = out.parent if missing else out  # the staging folder's place: beside a new out, inside an old one
    try:
        home.mkdir(parents=True, exist_ok=True)
        with temporary_folder(home, out.name) as staging:
            yield staging
            for f in staging.iterdir():
                _flush(f)
            if missing:
                (staging / MARKER).unlink()
                umask = os.umask(0)
                os.umask(umask)
                os.chmod(staging, 0o777 & ~umask)  # mkdtemp makes 0700; out is an ordinary folder
                os.rename(staging, out)
            else:
                staged = sorted(f for f in staging.iterdir() if f.name != MARKER)
                for f in staged:
                    _refuse_foreign(out / f.name, f)
                for f in staged:
                    os.replace(f, out / f.name)
    except BaseException as e:
        for d in missing:
            with contextlib.suppress(OSError):
                d.rmdir()  # only an empty one: what this call made
        if isinstance(e, OSError) and e.errno in NO_ROOM:
            raise no_room(out, None, e) from e
        raise


def head(path: Path, n: int) -> bytes:
    """The first ``n`` bytes of a file (empty when it cannot be read): where a format's signature is."""
    try:
        with open(path, "rb") as f:
            return f.read(n)
    except OSError:
        return b""


def _refuse_foreign(old: Path, new: Path) -> None:
    """Refuse to replace a file that is not of the kind of its replacement (their first four bytes,
    a format's signature, differ): a file of the user's own that happens to bear an output's name.

    Raises:
        OutputError: Naming the file; nothing has been moved yet.
    """
    if not old.exists():
        return
    if not old.is_file() or head(old, 4) != head(new, 4):
        raise OutputError(old, f"exists and is not a {new.suffix or 'plain'} file this command writes; refusing to "
                               "overwrite it (move it away, or choose another folder)")


def _flush(path: Path) -> None:
    """Write a file's data out to the device (a full one may refuse it only then)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def confined(folder: Path, name: str) -> Path:
    """``folder / name`` for a file name that comes from a file's content (an entry key): refused
    unless it is one plain name whose resolved path stays inside ``folder``.

    Raises:
        OutputError: The name is a path, empty, ``.`` or ``..``, or leads outside ``folder``.
    """
    folder = Path(folder)
    plain = name not in ("", ".", "..") and Path(name).name == name and "\\" not in name and "\0" not in name
    real = folder.resolve()
    if not plain or (real / name).parent != real:
        raise OutputError(folder, f"refusing to write {name!r}: a file name from the library that leads outside "
                                  "this folder; the library is not skatelib's or was altered (skatelib validate)")
    return folder / name


def write_atomic(path: Path, data: bytes | bytearray, mode: int | None = None) -> Path:
    """Write ``data`` to ``path`` whole or not at all (with permission bits ``mode``, as
    :func:`atomic_path`), refusing before writing a byte when the folder has less free space than
    the data needs.

    Raises:
        OutputError: No room for it (the path, the size and the free space named).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    free = _free_bytes(path.parent)
    if free is not None and free < len(data):
        raise no_room(path, len(data))
    with atomic_path(path, mode) as tmp, open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())  # a full device can refuse the data only when it is written out
    return path
