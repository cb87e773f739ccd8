"""What was checked is what is loaded: a compiled stage library replaced after its SHA-256 check
does not run (the loader gets a private copy of the bytes checked); a symlinked library, and a
cache inside a folder others can write, are refused; a process loads a library once, until it
changes."""

from __future__ import annotations

import os
import shutil
import subprocess
import warnings
from pathlib import Path

import casadi as ca
import pytest
from skatelib.library import compiled, trust
from skatelib.library.errors import OutputError
from skatelib.pipeline.ocp.expressions import StageExpressions
from skatelib.pipeline.ocp.stagewise import CompileTarget, c_compiler, compiled_stage_functions

pytestmark = pytest.mark.skipif(c_compiler() is None, reason="no C compiler")
FLAGS = ("-O0",)


@pytest.fixture(autouse=True)
def _no_shared_cache(monkeypatch):
    monkeypatch.delenv(trust.TRUSTED_ENV, raising=False)


def _stage(weight: float = 1.0) -> StageExpressions:
    z, p = ca.SX.sym("z", 2), ca.SX.sym("p", 1)
    return StageExpressions(z, p, (z[0] - p[0]) ** 2 + weight * z[1] ** 2, ca.vertcat(z[0] * z[1]))


def _value(fns) -> float:
    return float(fns.value(ca.DM([1.0, 2.0]), ca.DM([0.5]))[0])  # 0.25 + weight * 4


def _planted(folder: Path, marker: Path) -> Path:
    """Another library with the same functions (weight 3: value 12.25) and a constructor that
    writes ``marker`` when the library is loaded: what someone swapping the file would plant."""
    stage = _stage(3.0)
    z, p, cost, cons = stage.z, stage.p, stage.cost, stage.cons
    gen = ca.CodeGenerator("planted.c", {"with_header": False})
    for name, out in (("stage_value", [cost, cons]), ("stage_grad", [ca.gradient(cost, z)]),
                      ("stage_jac", [ca.jacobian(cons, z)]), ("stage_hess", [ca.SX.zeros(2, 2)])):
        gen.add(ca.Function(name, [z, p] if name != "stage_hess" else [z, p, ca.SX.sym("s"), ca.SX.sym("l")], out))
    source = folder / "planted.c"
    source.write_text(gen.dump() + '\n#include <stdio.h>\n__attribute__((constructor)) static void planted(void) '
                      f'{{ FILE* f = fopen("{marker}", "w"); if (f) fclose(f); }}\n')
    so = folder / "planted.so"
    subprocess.run([c_compiler(), "-O0", "-shared", "-fPIC", str(source), "-o", str(so)], check=True)
    return so


def _private(tmp_path: Path) -> Path:
    folder = tmp_path / "cache"
    folder.mkdir(mode=0o700)
    return folder


def test_a_library_swapped_after_the_check_is_not_what_runs(tmp_path, monkeypatch):
    """The cached library passes its check; at the moment of loading (``ca.external`` is called)
    it is replaced by a planted one. The functions loaded are the checked ones (value 4.25, not the
    planted 12.25) and the planted constructor never runs; the next build sees the changed file
    and compiles again. (Loading by path, the planted library ran.)"""
    folder = _private(tmp_path)
    assert _value(compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))) == pytest.approx(4.25)
    (lib,) = folder.glob("stage_*.so")
    marker = tmp_path / "planted-code-ran"
    planted = _planted(tmp_path, marker)
    real_external = ca.external
    swaps = []

    def swap_then_load(name: str, path: str) -> ca.Function:
        if not swaps:
            shutil.copyfile(planted, tmp_path / "swap.so")
            os.replace(tmp_path / "swap.so", lib)
            swaps.append(path)
        return real_external(name, path)

    monkeypatch.setattr(ca, "external", swap_then_load)
    monkeypatch.setattr(compiled, "_HELD", {})  # not the functions this process loaded: load them again
    fns = compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))
    assert swaps, "the library was not loaded"
    assert not marker.exists(), "the planted library's constructor ran"
    assert _value(fns) == pytest.approx(4.25)
    assert lib.read_bytes() == planted.read_bytes()  # the swap did happen
    monkeypatch.setattr(ca, "external", real_external)
    with pytest.warns(trust.CacheNote, match="changed after it was built"):
        again = compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))
    assert _value(again) == pytest.approx(4.25) and not marker.exists()
    assert not list(folder.glob(".skatelib-tmp.*"))  # the private copies are gone


def test_a_symlinked_library_is_refused(tmp_path):
    """``stage_<key>.so`` a symlink to a file with the very bytes recorded, in a folder anyone can
    write: not loaded (a note says it is a symbolic link), compiled again into a file of its own."""
    folder = _private(tmp_path)
    compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))
    (lib,) = folder.glob("stage_*.so")
    public = tmp_path / "public"
    public.mkdir()
    public.chmod(0o777)
    shutil.move(lib, public / lib.name)
    lib.symlink_to(public / lib.name)
    code, why = compiled.checked_code(lib)
    assert code is None and "is a symbolic link" in why
    with pytest.warns(trust.CacheNote, match="is a symbolic link"):
        fns = compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))
    assert _value(fns) == pytest.approx(4.25)
    assert not lib.is_symlink() and lib.is_file()
    with warnings.catch_warnings():
        warnings.simplefilter("error", trust.CacheNote)  # a file of its own, as built: loaded without a note
        compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))


def test_a_cache_inside_a_folder_others_can_write_is_refused(tmp_path):
    """A private cache folder inside a folder anyone can write (without the sticky bit: they can
    rename the cache and put their own in its place) is refused naming that folder; inside a
    sticky one (as /tmp) it is used."""
    public = tmp_path / "public"
    public.mkdir()
    public.chmod(0o777)
    folder = public / "cache"
    folder.mkdir(mode=0o700)
    with pytest.raises(OutputError, match=r"is inside .*public, which can be written by others") as e:
        compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))
    assert "compile = false" in str(e.value) and "--no-cache" not in str(e.value)
    public.chmod(0o1777)
    assert _value(compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))) == pytest.approx(4.25)


def test_the_private_copy_is_in_memory_where_the_system_allows(tmp_path, monkeypatch):
    """Where there are anonymous memory files (Linux) the loader's copy is one: its folder holds a
    link to it with the code's bytes, nothing written to the disk; without them, or where they may
    not be executed, the copy is a file of its own with those bytes. Either is gone when the block
    ends."""
    code = b"\x7fELF" + os.urandom(4096)
    folder = _private(tmp_path)
    with compiled.private_copy(code, folder, "x.so") as so:
        if hasattr(os, "memfd_create") and os.path.isdir("/proc/self/fd"):
            assert so.is_symlink() and os.readlink(so).startswith("/proc/self/fd/")
        assert so.read_bytes() == code
    monkeypatch.setattr(compiled.mmap, "mmap", _refused)  # a system that does not execute memory files
    with compiled.private_copy(code, folder, "x.so") as so:
        assert not so.is_symlink() and so.read_bytes() == code
    monkeypatch.delattr(os, "memfd_create", raising=False)
    with compiled.private_copy(code, folder, "x.so") as so:
        assert not so.is_symlink() and so.read_bytes() == code
    assert not list(folder.iterdir())


def _refused(*args, **kwargs):
    raise PermissionError(1, "Operation not permitted")


def test_a_second_problem_in_a_process_reads_nothing_until_the_library_changes(tmp_path, monkeypatch):
    """The stage functions loaded once are served again in the same process without reading or
    checking the library; a library replaced since (a new inode) is checked again, and refused."""
    folder = _private(tmp_path)
    monkeypatch.setattr(compiled, "_HELD", {})
    first = compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))
    reads = []
    real = compiled.read_nofollow
    monkeypatch.setattr(compiled, "read_nofollow", lambda path: reads.append(path) or real(path))
    again = compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))
    assert again is first and not reads
    (lib,) = folder.glob("stage_*.so")
    replaced = tmp_path / "replaced.so"
    replaced.write_bytes(lib.read_bytes() + b"\0")
    os.replace(replaced, lib)
    with pytest.warns(trust.CacheNote, match="changed after it was built"):
        third = compiled_stage_functions(_stage(), CompileTarget(folder, FLAGS))
    assert reads and third is not first and _value(third) == pytest.approx(4.25)
