"""Files that appear whole or not at all: a temporary file in the target folder, then
``os.replace`` (libraries, cached entries, recordings, figures), and the clean-up of what a killed
writer left behind."""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from skatelib.library.errors import OutputError

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
def atomic_path(path: Path) -> Iterator[Path]:
    """Yield a temporary path in ``path``'s folder; on success it replaces ``path``, on error it is removed.

    Raises:
        OutputError: The device (or a quota or a file-size limit) had no room for the file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # The writer's pid is in the name, so a later run can tell a dead writer's leftover (kill -9)
    # from a concurrent writer's file in progress (remove_stale_temporaries).
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; a library is an ordinary file
        os.replace(tmp, path)
    except BaseException as e:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(e, OSError) and e.errno in NO_ROOM:
            raise no_room(path, None, e) from e
        raise


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


def write_atomic(path: Path, data: bytes | bytearray) -> Path:
    """Write ``data`` to ``path`` whole or not at all, refusing before writing a byte when the
    folder has less free space than the data needs.

    Raises:
        OutputError: No room for it (the path, the size and the free space named).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    free = _free_bytes(path.parent)
    if free is not None and free < len(data):
        raise no_room(path, len(data))
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())  # a full device can refuse the data only when it is written out
    return path


def remove_stale_temporaries(folder: Path, prefix: str = "") -> list[Path]:
    """Remove temporary files and folders (``.NAME.PID.*.tmp`` of :func:`atomic_path`, or
    ``PREFIX-PID-*`` folders) left in ``folder`` by processes that no longer exist; returns them."""
    removed: list[Path] = []
    if not folder.is_dir():
        return removed
    for p in folder.iterdir():
        parts = p.name.split(".") if p.name.endswith(".tmp") else p.name.split("-")
        is_ours = p.name.endswith(".tmp") and p.name.startswith(".") and len(parts) >= 5
        is_ours = is_ours or bool(prefix and p.name.startswith(f"{prefix}-") and len(parts) >= 3)
        pid_part = parts[-3] if p.name.endswith(".tmp") else parts[1] if len(parts) > 1 else ""
        if not is_ours or not pid_part.isdigit() or _alive(int(pid_part)):
            continue
        with contextlib.suppress(OSError):
            if p.is_dir():
                shutil.rmtree(p)
            else:
                p.unlink()
            removed.append(p)
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
