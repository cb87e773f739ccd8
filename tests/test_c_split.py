"""A generated function compiled in parts (:mod:`skatelib.pipeline.ocp.c_split`) computes what it
computes whole, to the bit: a stage-like SX function (trigonometry, squares, values read long after
they are made, several outputs) compiled whole and cut at several places, evaluated on random
inputs. A part that hands on a wrong value is seen; a file the splitter does not know is left
whole."""

from __future__ import annotations

import shutil
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from skatelib.pipeline.ocp import c_split, codegen

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None,
                                reason="no C compiler")


def _function() -> ca.Function:
    """An SX function whose early values are read at its end (as a Hessian's forward sweep is)."""
    x, p = ca.SX.sym("x", 6), ca.SX.sym("p", 2)
    s, c = ca.sin(x), ca.cos(x)
    y = [s[i] * c[(i + 1) % 6] + p[0] * x[i] ** 2 for i in range(6)]
    z = [ca.tanh(y[i] * y[(i + 2) % 6]) + ca.atan(p[1] * s[i]) for i in range(6)]
    w = [z[i] * s[5 - i] + c[i] * y[i] - ca.sqrt(1 + x[i] ** 2) for i in range(6)]
    H = ca.hessian(sum(w[i] * z[i] for i in range(6)), x)[0]
    return ca.Function("toy_hess", [x, p], [H, ca.vertcat(*w)])


def _build(fn: ca.Function, folder: Path, cuts: tuple[float, ...] | None, monkeypatch) -> ca.Function:
    """``fn`` compiled (cut at ``cuts``; None: whole) and loaded."""
    monkeypatch.setattr(codegen, "SPLIT_STATEMENTS", 0 if cuts else 10**9)
    monkeypatch.setattr(codegen, "CUTS", cuts or ())
    monkeypatch.setattr(codegen, "_cores", lambda: 2)
    lib = folder / "lib.so"
    folder.mkdir()
    codegen.compile_library([fn], shutil.which("gcc") or "cc", ("-O1",), lib)
    return ca.external(fn.name(), str(lib))


def _same(a: ca.Function, b: ca.Function, n: int = 200) -> bool:
    rng = np.random.default_rng(3)
    for _ in range(n):
        args = [rng.normal(size=a.size_in(i)) * 2.0 for i in range(a.n_in())]
        if not all(np.array_equal(np.array(u), np.array(v)) for u, v in zip(a.call(args), b.call(args), strict=True)):
            return False
    return True


def test_a_function_compiled_in_parts_gives_its_values_to_the_bit(tmp_path, monkeypatch):
    fn = _function()
    whole = _build(fn, tmp_path / "whole", None, monkeypatch)
    text = ca.CodeGenerator("toy_hess.c", {"with_header": False})
    text.add(fn)
    for k, cuts in enumerate(((0.5,), (0.1, 0.2, 0.9), (1 / 12, 2 / 12, 3 / 12, 1 / 2, 3 / 4))):
        split = c_split.split_source(text.dump(), "toy_hess", cuts)
        assert split is not None and len(split.parts) == len(cuts) + 1
        assert all("s[" in p for p in split.parts)  # values handed on between the parts
        parts = _build(fn, tmp_path / f"cut{k}", cuts, monkeypatch)
        assert _same(whole, parts), cuts


def test_a_part_that_hands_on_a_wrong_value_is_seen(tmp_path, monkeypatch):
    fn = _function()
    whole = _build(fn, tmp_path / "whole", None, monkeypatch)
    real = c_split._part

    def forgetful(name, body, live, slots, helpers, prelude):  # the first value handed on is stored one off
        text = real(name, body, live, slots, helpers, prelude)
        return text.replace("  s[0]=", "  s[0]=1+", 1)

    monkeypatch.setattr(c_split, "_part", forgetful)
    broken = _build(fn, tmp_path / "broken", (0.5,), monkeypatch)
    assert not _same(whole, broken, n=20)


def test_a_file_the_splitter_does_not_know_is_left_whole():
    gen = ca.CodeGenerator("toy_hess.c", {"with_header": False})
    gen.add(_function())
    text = gen.dump()
    assert c_split.split_source(text, "toy_hess", (0.5,)) is not None
    # a statement of another form, a name it does not know (the work vector), no body at all
    first = next(ln for ln in text.split("\n") if ln.startswith("  a") and "=" in ln and "arg" not in ln)
    var = first.split("=")[0]
    assert c_split.split_source(text.replace(first, f"  for (;;) {var}=0;", 1), "toy_hess", (0.5,)) is None
    assert c_split.split_source(text.replace(first, f"{var}=w[0];", 1), "toy_hess", (0.5,)) is None
    assert c_split.split_source(text.replace("static int casadi_f0(", "static int other(", 1), "toy_hess",
                                (0.5,)) is None
