"""skatelib's temporary files and folders in the folders it writes to, and the clean-up of those a
killed process left behind.

Output folders are the user's, so a temporary must be recognisable as skatelib's beyond doubt
before a later run removes it: its name is ``.skatelib-tmp.<pid>.<8 random characters>.<what>``
(the writer's pid, so that a dead writer's leftover is told from a live one's work in progress),
and a temporary folder holds the marker file ``.skatelib-temporary``, written first. The sweep
removes only files and folders of that exact name, owned by this user, of a process that no
longer exists, and folders only with their marker: never another name, a symlink or a folder
without the marker.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

PREFIX = ".skatelib-tmp."
MARKER = ".skatelib-temporary"
# tempfile's random part: 8 characters of "abcdefghijklmnopqrstuvwxyz0123456789_"
_NAME = re.compile(r"\.skatelib-tmp\.(?P<pid>[1-9][0-9]{0,9})\.[a-z0-9_]{8}\.(?P<what>[^/\0]+)")


def prefix() -> str:
    """The name prefix of this process's temporaries (``tempfile``'s ``prefix``)."""
    return f"{PREFIX}{os.getpid()}."


def suffix(what: str) -> str:
    """The name suffix of a temporary for ``what`` (the file it becomes, or its purpose)."""
    return "." + (what[:100] or "tmp")


def new_file(folder: Path, what: str) -> Path:
    """A new empty temporary file in ``folder`` (mode 0600) for ``what``."""
    fd, name = tempfile.mkstemp(prefix=prefix(), suffix=suffix(what), dir=folder)
    os.close(fd)
    return Path(name)


@contextlib.contextmanager
def temporary_folder(folder: Path, what: str) -> Iterator[Path]:
    """A new private folder in ``folder``, marked as skatelib's, removed with its content when the
    block ends (left behind only by a killed process, for :func:`remove_stale_temporaries`)."""
    d = Path(tempfile.mkdtemp(prefix=prefix(), suffix=suffix(what), dir=folder))
    try:
        (d / MARKER).write_bytes(b"")  # first, so that a sweep can tell the folder is skatelib's
        yield d
    finally:
        shutil.rmtree(d, ignore_errors=True)


def stale(path: Path) -> bool:
    """Whether ``path`` is a temporary of skatelib's whose writer is gone: the exact name, owned by
    this user, a regular file or a real folder holding the marker, its pid no live process."""
    m = _NAME.fullmatch(path.name)
    if m is None:
        return False
    try:
        st = path.lstat()
        if hasattr(os, "getuid") and st.st_uid != os.getuid():
            return False
        if stat.S_ISDIR(st.st_mode):
            if not stat.S_ISREG((path / MARKER).lstat().st_mode):
                return False
        elif not stat.S_ISREG(st.st_mode):
            return False  # a symlink, a fifo: not something skatelib makes
    except OSError:
        return False
    return not _alive(int(m["pid"]))


def remove_stale_temporaries(folder: Path) -> list[Path]:
    """Remove the temporaries of dead skatelib processes in ``folder`` (:func:`stale`); returns them."""
    removed: list[Path] = []
    if not folder.is_dir():
        return removed
    for p in folder.iterdir():
        if not stale(p):
            continue
        with contextlib.suppress(OSError):
            if stat.S_ISDIR(p.lstat().st_mode):
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
    except (PermissionError, OverflowError):
        return True  # another user's process, or no pid at all: not ours to judge
    return True
