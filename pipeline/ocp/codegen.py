"""Stage functions as C: generated, compiled into one shared library beside its SHA-256 record,
under a lock so that processes started together compile once (:mod:`.stagewise` decides when).

Each function is generated in its own file, and a long one's body is cut in parts, each in a file
of its own (:mod:`.c_split`): gcc's time on one function grows faster than its length, and the
files compile at once on the machine's cores, then link into the one library."""

from __future__ import annotations

import logging
import os
import platform
import subprocess
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
from skatelib.library.compiled import private_copy, record_and_place
from skatelib.library.temporaries import remove_stale_temporaries, temporary_folder
from skatelib.pipeline.ocp.c_split import SCALAR_PRELUDE, split_source

SPLIT_STATEMENTS = 200_000  # a function with more statements than this is compiled in parts
# Where its body is cut (fractions of its statements): twenty equal parts. gcc's time on a part
# grows faster than its length: the push-off's Hessian (formed by the chain rule) takes 1.4-5.4 s a
# part, 58 s of one core; cut in six parts as for CasADi's own Hessian, 103 s, one part 72 s
# (docs/design-notes.md).
CUTS = tuple(k / 20 for k in range(1, 20))
MAX_JOBS = 4  # compilers at once (a part takes gcc up to 1 GB)
LOG = logging.getLogger("skatelib.compile")


@dataclass(frozen=True)
class CSource:
    """A function's generated C: its name, the file's text and what each part's file starts with
    when it is cut (:func:`~skatelib.pipeline.ocp.c_split.split_source`)."""

    name: str
    text: str
    prelude: str = SCALAR_PRELUDE


def generated(f: ca.Function) -> CSource:
    """CasADi's C for ``f``, a file of its own."""
    gen = ca.CodeGenerator(f"{f.name()}.c", {"with_header": False})
    gen.add(f)
    return CSource(f.name(), gen.dump())


def _sources(src: CSource, cut: bool) -> list[tuple[str, str]]:
    """``src``'s C files (name, text): one, or (``cut``) a long function's driver and its parts."""
    long = cut and src.text.count("\n") > SPLIT_STATEMENTS
    split = split_source(src.text, src.name, CUTS, src.prelude) if long else None
    if split is None:
        if long:
            LOG.info("%s: generated code of a form the splitter does not know, compiled whole", src.name)
        return [(f"{src.name}.c", src.text)]
    return [(f"{src.name}.c", split.main), *((f"{src.name}_part{k}.c", p) for k, p in enumerate(split.parts))]


def _cores() -> int:
    """The compilers run at once: the cores this process may use, at most ``MAX_JOBS``."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return max(1, min(cores, MAX_JOBS))


def _compile(cc: str, flags: Sequence[str], src: Path) -> Path:
    obj = src.with_suffix(".o")
    try:
        subprocess.run([cc, *flags, "-fPIC", "-Werror=implicit-function-declaration", "-c", str(src), "-o",
                        str(obj)], check=True, capture_output=True)
    except subprocess.CalledProcessError as e:
        e.add_note(f"{src.name}: {(e.stderr or b'').decode(errors='replace')[-2000:]}")
        raise
    return obj


def compile_library(functions: Sequence[ca.Function | CSource], cc: str, flags: Sequence[str], lib: Path) -> bytes:
    """``functions`` (CasADi's, or C already generated) compiled with ``cc flags`` into ``lib`` with
    its SHA-256 record beside it; returns the compiled bytes (read in this process's private folder,
    before they are moved). Each
    file is compiled as soon as it is written, on as many cores as the machine gives this process
    (the long function last in ``functions`` is cut while the others compile)."""
    remove_stale_temporaries(lib.parent)  # a compile killed earlier left its sources
    cores = _cores()
    with temporary_folder(lib.parent, "compile") as tmp, ThreadPoolExecutor(max_workers=cores) as pool:
        folder, jobs = Path(tmp), []
        for f in functions:  # on one core the parts would only add up to more than the whole
            for name, text in _sources(f if isinstance(f, CSource) else generated(f), cores > 1):
                (folder / name).write_text(text)
                jobs.append(pool.submit(_compile, cc, flags, folder / name))
        try:
            objects = [job.result() for job in jobs]
        except BaseException:
            pool.shutdown(cancel_futures=True)  # the files not started yet are not compiled
            raise
        so_tmp = folder / "stage.so"
        subprocess.run([cc, *flags, "-shared", *map(str, objects), "-o", str(so_tmp)], check=True, capture_output=True)
        return record_and_place(so_tmp, lib)


def load_private(code: bytes, folder: Path, names: Sequence[str | tuple[str, ...]]) -> list[ca.Function]:
    """The functions ``names`` of the compiled library whose bytes are ``code`` (checked by the
    caller), loaded from a private copy: a new file in a new folder of this process (mode 0700) in
    ``folder``, removed once loaded (the loaded code stays mapped). What runs is what was checked,
    whatever happens to the cached file meanwhile. A tuple of names: the first the library has."""
    with private_copy(code, folder, "stage.so") as so:
        return [_first(str(so), (name,) if isinstance(name, str) else name) for name in names]


def _first(so: str, names: tuple[str, ...]) -> ca.Function:
    """The first function of ``names`` that the library ``so`` has."""
    for name in names[:-1]:
        try:
            return ca.external(name, so)
        except RuntimeError:  # not in this library
            continue
    return ca.external(names[-1], so)


def host_cpu() -> str:
    """The processor a ``-march=native`` library is built for: architecture, model and feature flags
    (from /proc/cpuinfo on Linux; elsewhere only the platform's machine and processor names)."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        lines = []
    wanted = ("model name", "flags", "Features", "CPU implementer", "CPU part")
    described = sorted({ln.strip() for ln in lines if ln.split(":")[0].strip() in wanted})
    return "\n".join([platform.machine(), platform.processor(), *described])
