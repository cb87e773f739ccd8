"""Files that appear whole or not at all: a temporary file in the target folder, then
``os.replace`` (libraries, cached entries, recordings, figures), and the clean-up of what a killed
writer left behind."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path


@contextlib.contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yield a temporary path in ``path``'s folder; on success it replaces ``path``, on error it is removed."""
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
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


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
