"""Stage functions as C: generated, compiled into one shared library beside its SHA-256 record,
under a lock so that processes started together compile once (:mod:`.stagewise` decides when)."""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import subprocess
from collections.abc import Iterator, Sequence
from pathlib import Path

import casadi as ca
from skatelib.library.temporaries import remove_stale_temporaries, temporary_folder
from skatelib.pipeline.ocp import trust


@contextlib.contextmanager
def locked(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` (created) while the block runs; others wait for it."""
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def compile_library(functions: Sequence[ca.Function], cc: str, flags: Sequence[str], lib: Path) -> bytes:
    """``functions`` as C, compiled with ``cc flags`` into ``lib`` with its SHA-256 record beside it;
    returns the compiled bytes (read in this process's private folder, before they are moved)."""
    gen = ca.CodeGenerator("skatelib_stage.c", {"with_header": False})
    for f in functions:
        gen.add(f)
    remove_stale_temporaries(lib.parent)  # a compile killed earlier left its stage.c
    with temporary_folder(lib.parent, "compile") as tmp:
        c_file = Path(tmp) / "stage.c"
        c_file.write_text(gen.dump())
        so_tmp = Path(tmp) / "stage.so"
        subprocess.run([cc, *flags, "-shared", "-fPIC", str(c_file), "-o", str(so_tmp)], check=True,
                       capture_output=True)
        code = so_tmp.read_bytes()
        record = Path(tmp) / "stage.sha256"
        record.write_text(hashlib.sha256(code).hexdigest() + "\n")
        os.replace(record, trust.digest_record(lib))  # the record first: a reader never trusts a
        os.replace(so_tmp, lib)  # half-written library, and parallel workers load a whole one
    return code


def load_private(code: bytes, folder: Path, names: Sequence[str]) -> list[ca.Function]:
    """The functions ``names`` of the compiled library whose bytes are ``code`` (checked by the
    caller), loaded from a private copy: a new file in a new folder of this process (mode 0700) in
    ``folder``, removed once loaded (the loaded code stays mapped). What runs is what was checked,
    whatever happens to the cached file meanwhile."""
    with temporary_folder(folder, "load") as private:
        so = private / "stage.so"
        fd = os.open(so, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(code)
        return [ca.external(name, str(so)) for name in names]
