"""The stage-wise NLP: assembled derivatives equal CasADi's own on the flat problem, and the
solve matches a plain nlpsol, also with free rows left out."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from skatelib.pipeline.ocp.expressions import StageExpressions
from skatelib.pipeline.ocp.stagewise import build_stagewise_nlp, stage_functions

N_V, N_STAGES = 3, 12  # window v = [position, velocity, acceleration]


def _toy(keep=None, threads=1):
    z, p = ca.SX.sym("z", 2 * N_V), ca.SX.sym("p", 1)
    x0, u0, x1 = z[0:2], z[2], z[3:5]
    dt = 0.1
    cost = u0**2 + p[0] * (x1[0] - 1) ** 2 + 0.1 * (z[5] - u0) ** 2 + ca.sin(x0[0]) * x0[1] ** 2
    cons = ca.vertcat(x1[0] - (x0[0] + dt * x0[1]), x1[1] - (x0[1] + dt * u0), x1[0] ** 3 - x1[1], ca.cos(u0))
    return build_stagewise_nlp(stage_functions(StageExpressions(z, p, cost, cons)), N_STAGES, keep=keep,
                               threads=threads)


@pytest.mark.parametrize("drop", [False, True])
def test_assembled_derivatives_equal_casadi_ad(drop):
    """Gradient, Jacobian and Hessian of the Lagrangian equal CasADi's on the flat f and g."""
    keep = None
    if drop:
        keep = np.ones(4 * N_STAGES, dtype=bool)
        keep[3::4] = False  # the cos(u) rows
        keep[2] = False
    S = _toy(keep)
    w, pp = S.nlp["x"], S.nlp["p"]
    lam = ca.MX.sym("lam", S.n_g)
    rng = np.random.default_rng(0)
    wv, pv, lv = rng.normal(size=S.n_w), rng.uniform(0.5, 2, N_STAGES), rng.normal(size=S.n_g)
    ref_grad = ca.Function("a", [w, pp], [ca.gradient(S.nlp["f"], w)])(wv, pv)
    ref_jac = ca.Function("b", [w, pp], [ca.jacobian(S.nlp["g"], w)])(wv, pv)
    ref_hess = ca.Function("c", [w, pp, lam], [ca.triu(ca.hessian(0.7 * S.nlp["f"] + ca.dot(lam, S.nlp["g"]), w)[0])])(
        wv, pv, lv)
    assert np.allclose(np.asarray(S.options["grad_f"](wv, pv)[1]), np.asarray(ref_grad), atol=1e-12)
    assert np.allclose(np.asarray(ca.densify(S.options["jac_g"](wv, pv)[1])), np.asarray(ca.densify(ref_jac)),
                       atol=1e-12)
    assert np.allclose(np.asarray(ca.densify(S.options["hess_lag"](wv, pv, 0.7, lv))),
                       np.asarray(ca.densify(ref_hess)), atol=1e-12)


@pytest.mark.parametrize(("threads", "used"), [(2, 2), (5, 4), (40, 12)])
def test_threaded_derivatives_equal_serial_to_the_bit(threads, used):
    """On several threads (also more than stages: as many as give each the same share of the 12) the
    Jacobian and Hessian are the serial ones exactly."""
    serial, threaded = _toy(), _toy(threads=threads)
    for name in ("jac_g", "hess_lag"):
        maps = [f.name() for f in threaded.options[name].find_functions() if f.class_name() == "ThreadMap"]
        assert len(maps) == 1 and maps[0].startswith(f"threadmap{used}_"), maps
        assert not [f for f in serial.options[name].find_functions() if f.class_name() == "ThreadMap"]
    rng = np.random.default_rng(1)
    for _ in range(3):
        wv, pv, lv = rng.normal(size=serial.n_w), rng.uniform(0.5, 2, N_STAGES), rng.normal(size=serial.n_g)
        for name, args in (("jac_g", (wv, pv)), ("hess_lag", (wv, pv, 0.7, lv))):
            a, b = serial.options[name](*args), threaded.options[name](*args)
            a, b = (a[1], b[1]) if name == "jac_g" else (a, b)
            assert a.sparsity() == b.sparsity()
            assert np.array_equal(np.asarray(a.nonzeros()), np.asarray(b.nonzeros()))


def test_stage_threads_follow_omp_num_threads(monkeypatch):
    """OMP_NUM_THREADS sets the threads (its first level); unset, the cores this process may use;
    at most MAX_THREADS; a value that is no count of threads is an error naming the variable."""
    import joblib
    from skatelib.library.errors import SkatelibError
    from skatelib.pipeline.ocp import threads
    from skatelib.pipeline.ocp.threads import stage_threads

    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    assert stage_threads() == 3
    monkeypatch.setenv("OMP_NUM_THREADS", "2,1")
    assert stage_threads() == 2
    monkeypatch.setenv("OMP_NUM_THREADS", "64")
    assert stage_threads() == threads.MAX_THREADS
    monkeypatch.delenv("OMP_NUM_THREADS")
    for cores, expected in ((3, 3), (1, 1), (96, threads.MAX_THREADS)):
        monkeypatch.setattr(joblib, "cpu_count", lambda cores=cores: cores)
        assert stage_threads() == expected
    for bad in ("0", "four", "-2"):
        monkeypatch.setenv("OMP_NUM_THREADS", bad)
        with pytest.raises(SkatelibError, match="OMP_NUM_THREADS"):
            stage_threads()


def test_solution_equals_plain_nlpsol():
    """IPOPT with the assembled derivatives finds the same optimum as with CasADi's own."""
    keep = np.ones(4 * N_STAGES, dtype=bool)
    keep[3::4] = False
    S = _toy(keep)
    lbg = np.zeros(S.n_g)
    ubg = np.zeros(S.n_g)
    ubg[2::3] = np.inf  # x^3 - v >= 0 rows
    lbx, ubx = np.full(S.n_w, -5.0), np.full(S.n_w, 5.0)
    lbx[:2] = ubx[:2] = 0.0
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"}
    args = {"x0": 0.1, "p": np.ones(N_STAGES), "lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg}
    r1 = ca.nlpsol("a", "ipopt", S.nlp, {**opts, **S.options})(**args)
    r2 = ca.nlpsol("b", "ipopt", S.nlp, opts)(**args)
    assert float(r1["f"]) == pytest.approx(float(r2["f"]), rel=1e-8)
    assert np.allclose(np.asarray(r1["x"]), np.asarray(r2["x"]), atol=1e-6)


def _toy_stage() -> StageExpressions:
    z, p = ca.SX.sym("z", 4), ca.SX.sym("p", 1)
    return StageExpressions(z, p, p[0] * ca.sumsqr(z) + ca.sin(z[0]) * z[3],
                            ca.vertcat(z[0] * z[1] - z[2], ca.exp(z[3]) - z[1] ** 2))


def test_compiled_stage_functions_equal_symbolic(tmp_path, monkeypatch):
    """The C-compiled stage functions (cached by hash) give the symbolic ones' values; a second
    call loads the cached library instead of compiling."""
    import shutil

    from skatelib.pipeline.ocp import stagewise

    if shutil.which("gcc") is None and shutil.which("cc") is None:
        pytest.skip("no C compiler")
    stage = _toy_stage()
    sym = stagewise.stage_functions(stage)
    comp = stagewise.compiled_stage_functions(stage, stagewise.CompileTarget(tmp_path))
    libs = list(tmp_path.glob("stage_*.so"))
    assert len(libs) == 1
    zv, pv, lam = np.array([0.3, -1.2, 0.5, 0.9]), np.array([1.7]), np.array([0.4, -2.0])
    for a, b, args in ((sym.value, comp.value, (zv, pv)), (sym.grad, comp.grad, (zv, pv)),
                       (sym.jac, comp.jacobian_at, (zv, pv)), (sym.hess, comp.hessian_at, (zv, pv, 0.8, lam))):
        for x, y in zip(a(*args) if a.n_out() > 1 else [a(*args)], b(*args) if a.n_out() > 1 else [b(*args)],
                        strict=True):
            assert np.allclose(np.asarray(ca.densify(x)), np.asarray(ca.densify(y)), atol=1e-12)
    mtime = libs[0].stat().st_mtime_ns
    stagewise.compiled_stage_functions(stage, stagewise.CompileTarget(tmp_path))
    assert libs[0].stat().st_mtime_ns == mtime


def test_native_code_is_keyed_on_the_host_cpu(tmp_path, monkeypatch):
    """A library compiled with -march=native is not served to another CPU sharing the cache folder."""
    from skatelib.pipeline.ocp import stagewise

    if stagewise.c_compiler() is None:
        pytest.skip("no C compiler")
    stagewise.compiled_stage_functions(_toy_stage(), stagewise.CompileTarget(tmp_path))
    monkeypatch.setattr(stagewise, "host_cpu", lambda: "another processor")
    stagewise.compiled_stage_functions(_toy_stage(), stagewise.CompileTarget(tmp_path))
    assert len(list(tmp_path.glob("stage_*.so"))) == 2
    portable = stagewise.CompileTarget(tmp_path, stagewise.PORTABLE_FLAGS)  # no CPU in its key
    stagewise.compiled_stage_functions(_toy_stage(), portable)
    monkeypatch.setattr(stagewise, "host_cpu", lambda: "a third processor")
    stagewise.compiled_stage_functions(_toy_stage(), portable)
    assert len(list(tmp_path.glob("stage_*.so"))) == 3


def test_the_config_chooses_native_or_portable_code(monkeypatch):
    """``[optimization] compile_native``: the push-off's stage functions are compiled with
    -march=native (true, the default) or as portable code (false)."""
    import dataclasses

    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.ocp import shooting, stagewise
    from skatelib.pipeline.quadruped.problem.problem import PushoffProblem

    seen: list[stagewise.CompileTarget] = []

    def record(stage, target):
        seen.append(target)
        return stagewise.stage_functions(stage)

    monkeypatch.setattr(shooting, "compiled_stage_functions", record)
    cfg = load_config()
    for native in (True, False):
        opt = dataclasses.replace(cfg.optimization, compile=True, compile_native=native)
        PushoffProblem(dataclasses.replace(cfg, optimization=opt), 1)
    assert "-march=native" in seen[0].flags and seen[1].flags == stagewise.PORTABLE_FLAGS


@pytest.mark.parametrize("rejected", ["-march=native", "-fira-region=one"])
def test_compiler_without_an_optional_flag_still_compiles(tmp_path, monkeypatch, rejected):
    """A compiler that rejects -march=native or one of the lean flags (they are only
    optimizations) compiles without it, and with the other optional flags."""
    from skatelib.pipeline.ocp import stagewise

    real = stagewise.c_compiler()
    if real is None:
        pytest.skip("no C compiler")
    fake = tmp_path / "cc-without-native"
    calls = tmp_path / "calls.txt"
    fake.write_text(f'#!/bin/sh\necho "$@" >> {calls}\nfor a in "$@"; do [ "$a" = {rejected} ] && exit 1; done\n'
                    f'exec {real} "$@"\n')
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    stage = _toy_stage()
    comp = stagewise.compiled_stage_functions(stage, stagewise.CompileTarget(tmp_path / "cache"))
    sym = stagewise.stage_functions(stage)
    zv, pv, lam = np.array([0.3, -1.2, 0.5, 0.9]), np.array([1.7]), np.array([0.4, -2.0])
    assert np.allclose(np.asarray(ca.densify(comp.hessian_at(zv, pv, 0.8, lam))),
                       np.asarray(ca.densify(sym.hess(zv, pv, 0.8, lam))), atol=1e-12)
    compiles = [ln for ln in calls.read_text().splitlines() if "-shared" in ln]
    assert len(compiles) == 1 and rejected not in compiles[0].split()
    kept = [f for f in ("-march=native", *stagewise.LEAN_FLAGS) if f != rejected and stagewise._takes(real, [f])]
    assert all(f in compiles[0].split() for f in kept)


def test_builds_started_together_compile_once(tmp_path):
    """Two processes asking for the same stage functions at once in an empty folder: one compiles
    (the compiler is run once with -shared, and one 'compiling' line is logged), the other waits
    for it and loads the same library; a second run logs nothing (a cache hit says nothing)."""
    import subprocess
    import sys

    from skatelib.pipeline.ocp import stagewise

    real = stagewise.c_compiler()
    if real is None:
        pytest.skip("no C compiler")
    slow = tmp_path / "slow-cc"
    calls = tmp_path / "calls.txt"
    slow.write_text(f'#!/bin/sh\necho "$@" >> {calls}\nsleep 1\nexec {real} "$@"\n')
    slow.chmod(0o755)
    script = (
        "import logging, sys\n"
        "from pathlib import Path\n"
        "from tests.test_stagewise import _toy_stage\n"
        "from skatelib.pipeline.ocp import stagewise as s\n"
        "logging.basicConfig(level=logging.INFO, format='%(name)s %(message)s', stream=sys.stdout)\n"
        f"f = s.compiled_stage_functions(_toy_stage(), s.CompileTarget(Path({str(tmp_path / 'cache')!r}), ('-O0',)))\n"
        "print('value', f.value([0.3, -1.2, 0.5, 0.9], [1.7]))\n")
    env = {**__import__("os").environ, "CC": str(slow)}
    procs = [subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=env)
             for _ in range(2)]
    outs = [p.communicate(timeout=120)[0] for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    assert sum(o.count("skatelib.compile compiling") for o in outs) == 1, outs
    assert len({o.split("value")[1] for o in outs}) == 1
    assert sum("-shared" in line for line in calls.read_text().splitlines()) == 1
    again = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=120)
    assert again.returncode == 0 and "compiling" not in again.stdout, again.stdout + again.stderr
