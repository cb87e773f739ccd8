"""Stage functions as C: generated, compiled into one shared library beside its SHA-256 record,
under a lock so that processes started together compile once (:mod:`.stagewise` decides when)."""

from __future__ import annotations

import subprocess
from collections.abc import Sequence
from pathlib import Path

import casadi as ca
from skatelib.library.compiled import private_copy, record_and_place
from skatelib.library.temporaries import remove_stale_temporaries, temporary_folder


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
        return record_and_place(so_tmp, lib)


def load_private(code: bytes, folder: Path, names: Sequence[str]) -> list[ca.Function]:
    """The functions ``names`` of the compiled library whose bytes are ``code`` (checked by the
    caller), loaded from a private copy: a new file in a new folder of this process (mode 0700) in
    ``folder``, removed once loaded (the loaded code stays mapped). What runs is what was checked,
    whatever happens to the cached file meanwhile."""
    with private_copy(code, folder, "stage.so") as so:
        return [ca.external(name, str(so)) for name in names]
