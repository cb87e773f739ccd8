"""A stage function evaluated for several stages at once, one stage in each lane of a SIMD vector.

Every stage of a multiple-shooting NLP runs the same code on its own window: the push-off's
Lagrangian Hessian is some 400,000 scalar operations a stage. Its lane version is the same C with
every value a vector of ``lanes`` doubles (the vector extensions of gcc and clang): each operation
of the stage's code then runs on ``lanes`` stages in one instruction (the push-off's Hessian 3.9x
faster in 4 lanes and 5.4x in 8 on an AVX-512 CPU, 1.9x in 2 lanes of portable SSE2 code,
docs/design-notes.md). Each lane performs the
scalar code's operations in its order, so a lane gives the scalar function's value to the bit
(tests/test_lanes.py).

The lane file is made from CasADi's generated C of the function (:func:`lane_source`): the
statements are kept, with three rewrites (an input read without CasADi's check for a null input,
a constant spread over the lanes, C's math functions applied lane by lane). A function with any
other kind of statement (a comparison, a branch) is not made in lanes. The file has CasADi's
external-function interface with double arguments: input i holds the stages' values side by side
(``n_i x lanes``) or, for a shared input, one value for all; the output holds the stages' outputs
side by side: what ``f.map(lanes)`` of the scalar function takes and gives.
"""

from __future__ import annotations

import os
import re
import subprocess
from collections.abc import Sequence
from typing import Any

import casadi as ca
from skatelib.pipeline.ocp.c_split import parse
from skatelib.pipeline.ocp.codegen import generated
from skatelib.pipeline.ocp.threads import mapped

UNARY = ("sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh", "asinh", "acosh", "atanh", "exp",
         "log", "log1p", "expm1", "sqrt", "fabs", "floor", "ceil", "erf")
BINARY = ("atan2", "pow", "fmin", "fmax", "copysign", "hypot", "fmod")
_INPUT = re.compile(r"arg\[(\d+)\]\? arg\[\1\]\[(\d+)\] : 0")
_CONSTANT = re.compile(r"-?(\d+\.?\d*(e[-+]?\d+)?)")
_TOKEN = re.compile(r"arg\[\d+\]\[\d+\]|a\d+|\d+\.?\d*(?:e[-+]?\d+)?|[A-Za-z_]\w*|[()+\-*/,]")
_OUTPUT = re.compile(r"^  if \(res\[\d+\]!=0\) res\[\d+\]\[\d+\]=a\d+;$")
_HELPERS = {"casadi_sq": "casadi_real casadi_sq(casadi_real x) { return x*x;}"}  # those made in lanes
_SPREAD = "casadi_real casadi_spread(double x) { casadi_real v = {0}; return v + x;}"  # a constant in every lane
_WIDTHS = ((8, "__AVX512F__"), (4, "__AVX__"))  # lanes: the doubles in one vector register where the macro is set


def prelude(lanes: int) -> str:
    """What a lane file (or a part of one) starts with: the vector type as ``casadi_real`` and C's
    math functions taking and giving vectors, lane by lane."""
    wrap = [f"static inline casadi_real casadi_v_{f}(casadi_real x) {{ casadi_real r; "
            f"for (int l = 0; l < {lanes}; ++l) r[l] = {f}(x[l]); return r; }}" for f in UNARY]
    wrap += [f"static inline casadi_real casadi_v_{f}(casadi_real x, casadi_real y) {{ casadi_real r; "
             f"for (int l = 0; l < {lanes}; ++l) r[l] = {f}(x[l], y[l]); return r; }}" for f in BINARY]
    names = [f"#define {f}(...) casadi_v_{f}(__VA_ARGS__)" for f in (*UNARY, *BINARY)]
    return "\n".join(["#include <math.h>", f"typedef double casadi_lanes __attribute__((vector_size({8 * lanes})));",
                      "#define casadi_real casadi_lanes", *wrap, *names])


def lane_width(cc: str, flags: Sequence[str]) -> int:
    """The stages a lane function evaluates at once with ``cc flags``: the doubles in one vector
    register, 8 where the code may use AVX-512, 4 with AVX, else 2 (SSE2, NEON); 1 (no lanes) where
    the compiler does not compile a small function's lane file. Wider vectors than the registers
    evaluate no faster and take gcc far longer: portable x86-64 code (SSE2) evaluates the push-off's
    Hessian in 19.6 ms in 2 lanes and 19.7 ms in 4 (37 ms scalar), compiled whole in 68 s and 303 s
    (58 s scalar)."""
    def compiles(text: str) -> bool:
        run = subprocess.run([cc, *flags, "-Werror=implicit-function-declaration", "-x", "c", "-c", "-", "-o",
                              os.devnull], input=text.encode(), capture_output=True)  # as the build compiles
        return run.returncode == 0

    lanes = next((n for n, macro in _WIDTHS if compiles(f"#ifndef {macro}\n#error narrower\n#endif\n")), 2)
    return lanes if compiles(_probe(lanes)) else 1


def _probe(lanes: int) -> str:
    """A small function's lane file: every kind of statement and the whole interface a compiler
    must take for the stage functions to be compiled in lanes."""
    x, s = ca.SX.sym("x", 2), ca.SX.sym("s")
    f = ca.Function("probe", [x, s], [ca.vertcat(ca.sin(x[0]) * s + 2.0, ca.atan2(x[1] ** 2, x[0]) / x[0])])
    text = lane_source(f, generated(f).text, lanes, (1,))
    return prelude(lanes) if text is None else text


def _lane_statement(text: str, helpers: set[str]) -> str | None:
    """A statement's right-hand side in lanes, or None when it is not arithmetic, the helpers and
    C's math on values, inputs and constants."""
    text = _INPUT.sub(r"arg[\1][\2]", text)
    if _CONSTANT.fullmatch(text):
        return f"casadi_spread({text})"
    tokens = _TOKEN.findall(text)
    if "".join(tokens) != text.replace(" ", ""):
        return None  # something else: a comparison, a ternary, a cast
    names = {t for t in tokens if re.fullmatch(r"[A-Za-z_]\w*", t) and not re.fullmatch(r"a\d+", t)}
    return text if names <= set(UNARY) | set(BINARY) | helpers else None


def _array(name: str, values: Sequence[int]) -> str:
    return f"static const long long int {name}[{len(values)}] = {{{', '.join(map(str, values))}}};"


def _interface(name: str, f: ca.Function, lanes: int, shared: tuple[int, ...]) -> list[str]:
    """The lane function's CasADi external interface (double arguments): inputs and outputs moved
    between the stages side by side and the vectors the lane code computes on."""
    sizes_in, sizes_out = [f.nnz_in(i) for i in range(f.n_in())], [f.nnz_out(j) for j in range(f.n_out())]
    out = [_array(f"{name}_in{i}", ca.Sparsity.dense(f.size1_in(i), 1 if i in shared else lanes).compress())
           for i in range(f.n_in())]
    out += [_array(f"{name}_out{j}", ca.horzcat(*[f.sparsity_out(j)] * lanes).compress()) for j in range(f.n_out())]
    body = [f"int {name}(const double** arg, double** res, long long int* iw, double* w, int mem) {{"]
    body += [f"  casadi_real x{i}[{n}];" for i, n in enumerate(sizes_in)]
    body += [f"  casadi_real y{j}[{n}];" for j, n in enumerate(sizes_out)]
    for i, n in enumerate(sizes_in):
        at = "k" if i in shared else f"l * {n} + k"
        body.append(f"  for (int k = 0; k < {n}; ++k) for (int l = 0; l < {lanes}; ++l) "
                    f"x{i}[k][l] = arg[{i}] ? arg[{i}][{at}] : 0;")
    body.append(f"  const casadi_real* a[{f.n_in()}] = {{{', '.join(f'x{i}' for i in range(f.n_in()))}}};")
    body.append(f"  casadi_real* r[{f.n_out()}] = {{{', '.join(f'y{j}' for j in range(f.n_out()))}}};")
    body.append("  casadi_f0(a, r, 0, 0, 0);")
    for j, n in enumerate(sizes_out):
        body.append(f"  if (res[{j}]) for (int k = 0; k < {n}; ++k) for (int l = 0; l < {lanes}; ++l) "
                    f"res[{j}][l * {n} + k] = y{j}[k][l];")
    body += ["  return 0;", "}"]

    def table(kind: str, count: int) -> list[str]:
        cases = " ".join(f"case {i}: return {name}_{kind}{i};" for i in range(count))
        return [f"const long long int* {name}_sparsity_{kind}(long long int i) {{ switch (i) {{ {cases} "
                "default: return 0; } }"]

    return [*out, *body, f"long long int {name}_n_in(void) {{ return {f.n_in()}; }}",
            f"long long int {name}_n_out(void) {{ return {f.n_out()}; }}", *table("in", f.n_in()),
            *table("out", f.n_out()),
            f"int {name}_work(long long int* sz_arg, long long int* sz_res, long long int* sz_iw, long long int* sz_w) "
            f"{{ if (sz_arg) *sz_arg = {f.n_in()}; if (sz_res) *sz_res = {f.n_out()}; if (sz_iw) *sz_iw = 0; "
            "if (sz_w) *sz_w = 0; return 0; }"]


def lane_source(f: ca.Function, text: str, lanes: int, shared: tuple[int, ...]) -> str | None:
    """The C file of ``f`` (an SX function, ``text`` its CasADi-generated C) evaluating ``lanes``
    stages at once, as the external function ``{name}_lanes``; ``shared``: the inputs that are one
    value for all stages. None when a statement is of a kind not made in lanes, or an input is not a
    dense column: the caller keeps the scalar function."""
    parsed = parse(text)
    if parsed is None or any(not f.sparsity_in(i).is_dense() or f.size2_in(i) != 1 for i in range(f.n_in())):
        return None
    known = {h for h in _HELPERS if h in text}
    statements = []
    for lhs, rhs, _ in parsed.body:
        if lhs is None:
            if not _OUTPUT.match(rhs):
                return None
            statements.append(rhs)
            continue
        lane = _lane_statement(rhs, known | {"casadi_spread"})
        if lane is None:
            return None
        statements.append(f"  {lhs}={lane};")
    name = f"{f.name()}_lanes"
    own = [f"#define {h} {name}_{h}" for h in (*sorted(known), "casadi_spread")]  # not exported as they are
    return "\n".join([prelude(lanes), "#define casadi_int long long int", *own, *(_HELPERS[h] for h in sorted(known)),
                      _SPREAD, parsed.lines[parsed.head],
                      *parsed.declarations, *statements, "  return 0;", "}", *_interface(name, f, lanes, shared), ""])


def lanes_of(fn: ca.Function) -> int:
    """The stages a stage function evaluates at once: the columns of its first input (the window)."""
    return int(fn.size2_in(0))


def one_stage(fn: ca.Function, args: tuple[Any, ...], shared: tuple[int, ...]) -> ca.DM:
    """``fn`` at one stage's ``args``: in every lane, the first lane's result."""
    lanes = lanes_of(fn)
    side = [a if i in shared else ca.repmat(ca.DM(a), 1, lanes) for i, a in enumerate(args)]
    out = fn(*side)
    return out if lanes == 1 else out[:, :fn.size1_in(0)]


def over_stages(fn: ca.Function, n_stages: int, threads: int, args: list[ca.MX], shared: tuple[int, ...] = ()
                ) -> tuple[ca.MX, ca.Sparsity]:
    """``fn`` (a stage function, in lanes or not) mapped over the stages' ``args`` (one column per
    stage; ``shared``: one value for all): its outputs side by side, lanes past the last stage
    holding that stage's again (unread), and one stage's output sparsity."""
    lanes = lanes_of(fn)
    groups = -(-n_stages // lanes)
    padded = [*range(n_stages), *[n_stages - 1] * (groups * lanes - n_stages)]
    if len(padded) > n_stages:
        args = [a if i in shared else a[:, padded] for i, a in enumerate(args)]
    block = fn.sparsity_out(0) if lanes == 1 else ca.DM.ones(fn.sparsity_out(0))[:, :fn.size1_in(0)].sparsity()
    return mapped(fn, groups, threads)(*args), block
