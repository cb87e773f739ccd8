"""Stage functions as C: generated, compiled into one shared library beside its SHA-256 record,
under a lock so that processes started together compile once (:mod:`.stagewise` decides when)."""

from __future__ import annotations

import contextlib
import fcntl
import os
import subprocess
from collections.abc import Iterator, Sequence
from pathlib import Path

import casadi as ca
from skatelib.library.temporaries import remove_stale_temporaries, temporary_folder
from skatelib.pipeline.build import trust


@contextlib.contextmanager
def locked(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` (created) while the block runs; others wait for it."""
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def compile_library(functions: Sequence[ca.Function], cc: str, flags: Sequence[str], lib: Path) -> None:
    """``functions`` as C, compiled with ``cc flags`` into ``lib`` with its SHA-256 record beside it."""
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
        record = Path(tmp) / "stage.sha256"
        record.write_text(trust.sha256_of(so_tmp) + "\n")
        os.replace(record, trust.digest_record(lib))  # the record first: a reader never trusts a
        os.replace(so_tmp, lib)  # half-written library, and parallel workers load a whole one
