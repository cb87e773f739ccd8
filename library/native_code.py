"""The C code shipped in the package (the controller's: the estimator's tick, the whole-body and
the humanoid stabilizer's ticks; the twin's step and readout): a C file, built once by the
system's C compiler (``$CC``, else gcc or cc; :data:`FLAGS`) into the cache folder
(``$SKATELIB_CACHE_DIR`` or ~/.cache/skatelib, ``native/``), kept and loaded under the rules the
build's compiled code follows (:mod:`skatelib.library.compiled`: a folder of the user's own that
no one else can write, a lock, a SHA-256 record checked before each load, a private copy of the
checked bytes loaded), and called through ctypes: numpy and the standard library only.
"""

from __future__ import annotations

import ctypes
import hashlib
import importlib.resources
import os
import platform
import shlex
import shutil
import subprocess
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import trust
from skatelib.library.compiled import cached_or_compiled, private_copy, record_and_place
from skatelib.library.errors import OutputError
from skatelib.library.temporaries import remove_stale_temporaries, temporary_folder

# -ffp-contract=off: no fused multiply-adds (ARM's compilers fuse by default), so that the C code
# rounds as numpy does, operation for operation
FLAGS = ("-O2", "-ffp-contract=off", "-shared", "-fPIC")
COMPILE_TIMEOUT_S = 120


def cache_dir() -> Path:
    """Where the compiled code is kept: ``native/`` in the folder of compiled code
    (:func:`skatelib.library.trust.compile_dir`, the user's cache folder unless set apart)."""
    return trust.compile_dir() / "native"


def compiler() -> list[str] | None:
    """The C compiler's command: ``$CC`` (with its own arguments, as in ``ccache gcc``) when set,
    else gcc, else cc; None when the one asked for is not on the PATH."""
    wanted = shlex.split(os.environ.get("CC", ""))
    if wanted:
        found = shutil.which(wanted[0])
        return [found, *wanted[1:]] if found else None
    found = shutil.which("gcc") or shutil.which("cc")
    return [found] if found else None


class CompileFailed(Exception):
    """The C compiler did not build the code (the message says why)."""


def load(package: str, name: str, stem: str, advice: str, functions: dict[str, Sequence[Any]],
         extra: Sequence[str] = ()) -> tuple[ctypes.CDLL | None, str]:
    """The C file ``name`` of ``package`` compiled (or loaded from the cache, as ``stem`` and a
    hash of the source, the compiler and the ``extra`` arguments: include folders, libraries to
    link) with ``functions``' argument types set (their results void), and ''; or None and why not
    (no compiler, a failed compile, a cache folder it may not use: ``advice`` says what to do then)."""
    source = importlib.resources.files(package).joinpath(name).read_bytes()
    cc = compiler()
    if cc is None:
        asked = os.environ.get("CC")
        return None, f"$CC={asked!r} is not on the PATH" if asked else "no C compiler: neither gcc nor cc on the PATH"
    key = " ".join((*cc, *FLAGS, *extra, platform.machine(), platform.system(), str(ctypes.sizeof(ctypes.c_void_p))))
    folder = cache_dir()
    target = folder / f"{stem}_{hashlib.sha256(source + key.encode()).hexdigest()[:20]}.so"
    try:
        code = cached_or_compiled(target, advice, lambda: _compile(source, name, cc, target, extra))
        remove_stale_temporaries(folder)  # what a killed process left: a compile's folder, a private copy
        with private_copy(code, folder, f"{Path(name).stem}.so") as so:
            lib = ctypes.CDLL(str(so))
    except (OutputError, CompileFailed) as e:
        return None, str(e)
    except OSError as e:
        return None, f"cannot write or load in {folder}: {e}"
    for fn_name, args in functions.items():
        fn = getattr(lib, fn_name)
        fn.argtypes, fn.restype = list(args), None
    return lib, ""


def load_once(slot: list[ctypes.CDLL | None], source: tuple[str, str, str], advice: str,
              functions: dict[str, Sequence[Any]], unavailable: str, extra: Sequence[str] = ()) -> ctypes.CDLL | None:
    """:func:`load` of ``source`` (package, C file, stem) once per process (kept in ``slot``): the
    library, or None with a warning ``unavailable`` (what is not available, then what runs
    instead) with why and what to do."""
    if not slot:
        lib, why = load(*source, advice, functions, extra)
        if lib is None:
            what, instead = unavailable.split(": ", 1)
            warnings.warn(f"{what} ({why}): {instead}; install a C compiler (or set $CC to one)", RuntimeWarning,
                          stacklevel=3)
        slot.append(lib)
    return slot[0]


def _compile(source: bytes, name: str, cc: list[str], target: Path, extra: Sequence[str] = ()) -> bytes:
    """``source`` compiled into ``target`` (``extra``: include folders and libraries, after the
    source, so that the libraries it needs are linked) with its SHA-256 record (in a private folder
    beside it, then moved); its bytes.

    Raises:
        CompileFailed: The compiler failed or timed out.
    """
    with temporary_folder(target.parent, "compile") as tmp:
        src, out = tmp / name, tmp / f"{Path(name).stem}.so"
        src.write_bytes(source)
        try:
            done = subprocess.run([*cc, *FLAGS, "-o", str(out), str(src), *extra, "-lm"], capture_output=True,
                                  text=True, timeout=COMPILE_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            raise CompileFailed(f"{' '.join(cc)} took more than {COMPILE_TIMEOUT_S} s on {name}") from None
        if done.returncode != 0:
            raise CompileFailed(f"{' '.join(cc)} failed on {name}: {done.stderr.strip()[:500]}")
        return record_and_place(out, target)


def set_field(s: ctypes.Structure, name: str, values: Any) -> None:
    """Copy ``values`` (raveled, as doubles) into the array field ``name`` of the C struct ``s``.

    Raises:
        ValueError: Not as many values as the field holds.
    """
    field = getattr(s, name)
    flat = np.ascontiguousarray(values, dtype=float).ravel()
    if len(flat) != len(field):
        raise ValueError(f"{name}: {len(flat)} values for a field of {len(field)}")
    ctypes.memmove(field, flat.ctypes.data, flat.nbytes)
