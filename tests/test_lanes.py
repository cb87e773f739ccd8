"""Stage functions in lanes (:mod:`skatelib.pipeline.ocp.lanes`) give the scalar compiled code's
values to the bit, in every lane, whole and compiled in parts; a function with a statement that
is not arithmetic is kept scalar; the NLP assembled from lanes equals the one assembled stage by
stage, also where the stages do not fill the last lanes."""

from __future__ import annotations

import shutil
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from skatelib.pipeline.ocp import codegen, lanes, stagewise
from skatelib.pipeline.ocp.expressions import StageExpressions

CC = shutil.which("gcc") or shutil.which("cc")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler")


def _function() -> ca.Function:
    """A stage-like function: trigonometry, tanh, atan, sqrt, squares, a division, constants, a
    shared scalar input, a sparse and a dense output."""
    x, p, s = ca.SX.sym("x", 5), ca.SX.sym("p", 2), ca.SX.sym("s")
    y = [ca.sin(x[i]) * ca.cos(x[(i + 1) % 5]) + p[0] * x[i] ** 2 / (1.5 + x[i] ** 2) for i in range(5)]
    z = [ca.tanh(y[i] * y[(i + 2) % 5]) + ca.atan(p[1] * y[i]) - 0.25 * ca.sqrt(1 + x[i] ** 2) for i in range(5)]
    H = ca.triu(ca.hessian(s * sum(z[i] * y[4 - i] for i in range(5)), x)[0])
    return ca.Function("toy_stage", [x, p, s], [H, ca.vertcat(*z)], {"cse": True})


def _scalar_and_lanes(fn: ca.Function, n_lanes: int, folder: Path, monkeypatch, cut: bool = False
                      ) -> tuple[ca.Function, ca.Function]:
    """``fn`` compiled as it is and in ``n_lanes`` lanes (its third input shared)."""
    monkeypatch.setattr(codegen, "SPLIT_STATEMENTS", 0 if cut else 10**9)
    monkeypatch.setattr(codegen, "_cores", lambda: 2)
    plain = codegen.generated(fn)
    text = lanes.lane_source(fn, plain.text, n_lanes, (2,))
    assert text is not None
    folder.mkdir()
    lib = folder / "lib.so"
    source = codegen.CSource(f"{fn.name()}_lanes", text, lanes.prelude(n_lanes))
    codegen.compile_library([plain, source], CC or "cc", ("-O1",), lib)
    return ca.external(fn.name(), str(lib)), ca.external(f"{fn.name()}_lanes", str(lib))


@pytest.mark.parametrize(("n_lanes", "cut"), [(2, False), (4, False), (8, False), (4, True)])
def test_every_lane_gives_the_scalar_codes_values_to_the_bit(tmp_path, monkeypatch, n_lanes, cut):
    fn = _function()
    scalar, in_lanes = _scalar_and_lanes(fn, n_lanes, tmp_path / "lib", monkeypatch, cut)
    assert in_lanes.size_in(0) == (5, n_lanes) and in_lanes.size_in(2) == (1, 1)
    rng = np.random.default_rng(5)
    for _ in range(30):
        X, P, s = rng.normal(size=(5, n_lanes)) * 2, rng.normal(size=(2, n_lanes)), float(rng.normal())
        H, z = in_lanes(X, P, s)
        for lane in range(n_lanes):
            h1, z1 = scalar(X[:, lane], P[:, lane], s)
            assert np.array_equal(np.asarray(H[:, 5 * lane:5 * lane + 5].nonzeros()), np.asarray(h1.nonzeros()))
            assert np.array_equal(np.asarray(z[:, lane]).ravel(), np.asarray(z1).ravel())


def test_a_lane_that_reads_another_lanes_input_is_seen(tmp_path, monkeypatch):
    """Negative control: an interface that gives every lane the first stage's window."""
    real = lanes._interface

    def first_lane(name, f, n_lanes, shared):
        return [ln.replace("[l * 5 + k]", "[k]") for ln in real(name, f, n_lanes, shared)]

    monkeypatch.setattr(lanes, "_interface", first_lane)
    scalar, in_lanes = _scalar_and_lanes(_function(), 4, tmp_path / "lib", monkeypatch)
    X, P = np.random.default_rng(1).normal(size=(5, 4)), np.ones((2, 4))
    h1, _ = scalar(X[:, 2], P[:, 2], 1.0)
    assert not np.array_equal(np.asarray(in_lanes(X, P, 1.0)[0][:, 10:15].nonzeros()), np.asarray(h1.nonzeros()))


def test_a_function_that_is_not_arithmetic_is_kept_scalar(tmp_path):
    """A comparison (CasADi's if_else) is not made in lanes: the compiled stage functions keep
    their scalar Jacobian and Hessian, with the right values."""
    z, p = ca.SX.sym("z", 3), ca.SX.sym("p", 1)
    cons = ca.vertcat(ca.if_else(z[0] > 0, z[0] ** 3, -z[0] ** 2), z[1] * z[2])
    stage = StageExpressions(z, p, p[0] * ca.sumsqr(z), cons)
    fns = stagewise.stage_functions(stage, cse=True)
    assert lanes.lane_source(fns.hess, codegen.generated(fns.hess).text, 4, stagewise.HESS_SHARED) is None
    comp = stagewise.compiled_stage_functions(stage, stagewise.CompileTarget(tmp_path))
    assert lanes.lanes_of(comp.hess) == 1 and lanes.lanes_of(comp.jac) == 1
    zv, pv, lam = np.array([0.7, -0.2, 0.4]), np.array([2.0]), np.array([1.5, -0.5])
    assert np.allclose(np.asarray(ca.densify(comp.hessian_at(zv, pv, 1.0, lam))),
                       np.asarray(ca.densify(fns.hess(zv, pv, 1.0, lam))), atol=1e-14)


@pytest.mark.parametrize("n_stages", [3, 8, 13])
def test_the_nlp_from_lanes_equals_the_nlp_stage_by_stage(tmp_path, monkeypatch, n_stages):
    """The assembled Jacobian and Hessian from the compiled lane functions equal those from the
    scalar compiled functions to the bit, whether or not the stages fill the last lanes."""
    z, p = ca.SX.sym("z", 4), ca.SX.sym("p", 1)
    stage = StageExpressions(z, p, p[0] * ca.sumsqr(z) + ca.sin(z[0]) * z[3],
                             ca.vertcat(z[0] * z[1] - z[2], ca.exp(z[3]) - z[1] ** 2, ca.tanh(z[2] * z[0])))
    comp = stagewise.compiled_stage_functions(stage, stagewise.CompileTarget(tmp_path))
    n_lanes = lanes.lane_width(stagewise.c_compiler() or "cc", stagewise._FLAGS)
    assert lanes.lanes_of(comp.hess) == lanes.lanes_of(comp.jac) == n_lanes
    monkeypatch.setattr(stagewise, "lane_width", lambda cc, flags: 1)  # the same flags, one stage at a time
    one = stagewise.compiled_stage_functions(stage, stagewise.CompileTarget(tmp_path / "scalar"))
    assert lanes.lanes_of(one.hess) == 1
    a, b = stagewise.build_stagewise_nlp(comp, n_stages), stagewise.build_stagewise_nlp(one, n_stages)
    rng = np.random.default_rng(2)
    w, P, lam = rng.normal(size=a.n_w), rng.normal(size=n_stages), rng.normal(size=a.n_g)
    for f, args in (("jac_g", (w, P)), ("hess_lag", (w, P, 0.7, lam))):
        x, y = a.options[f](*args), b.options[f](*args)
        x, y = (x[-1], y[-1]) if isinstance(x, list | tuple) else (x, y)
        assert x.sparsity() == y.sparsity() and np.array_equal(np.asarray(x.nonzeros()), np.asarray(y.nonzeros()))



def test_a_compiler_without_vector_extensions_compiles_one_stage_at_a_time(tmp_path, monkeypatch):
    """A compiler that refuses the vector code (as one without gcc's vector extensions would) gives
    lane width 1, and the stage functions are compiled scalar, with the right values."""
    fake = tmp_path / "cc-without-vectors"
    fake.write_text('#!/bin/sh\nstdin=no\nfor a in "$@"; do [ "$a" = - ] && stdin=yes\n'
                    '  [ -f "$a" ] && grep -q vector_size "$a" && exit 1; done\n'
                    f'[ $stdin = no ] && exec {CC} "$@"\n'
                    'input=$(cat)\necho "$input" | grep -q vector_size && exit 1\n'
                    f'echo "$input" | exec {CC} "$@"\n')
    fake.chmod(0o755)
    flags = stagewise._accepted(str(fake), stagewise._FLAGS)
    assert lanes.lane_width(str(fake), flags) == 1 and lanes.lane_width(CC or "cc", flags) > 1
    monkeypatch.setenv("CC", str(fake))
    z, p = ca.SX.sym("z", 3), ca.SX.sym("p", 1)
    stage = StageExpressions(z, p, p[0] * ca.sumsqr(z), ca.vertcat(ca.sin(z[0]) * z[1], z[1] * z[2]))
    comp = stagewise.compiled_stage_functions(stage, stagewise.CompileTarget(tmp_path / "cache"))
    assert lanes.lanes_of(comp.hess) == lanes.lanes_of(comp.jac) == 1
    sym = stagewise.stage_functions(stage)
    zv, pv, lam = np.array([0.7, -0.2, 0.4]), np.array([2.0]), np.array([1.5, -0.5])
    assert np.allclose(np.asarray(ca.densify(comp.hessian_at(zv, pv, 1.0, lam))),
                       np.asarray(ca.densify(sym.hess(zv, pv, 1.0, lam))), atol=1e-14)
