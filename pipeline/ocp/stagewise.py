"""A stage-wise NLP whose derivatives are assembled from per-stage derivative functions.

Direct multiple shooting produces an NLP in which stage k's cost and constraints depend only on
the window ``z_k = w[k n : k n + 2 n]`` (state and control of knots k and k+1). Building one flat
expression graph and letting CasADi differentiate it costs tens of seconds; instead one SX
function per stage is differentiated once (gradient, constraint Jacobian, Lagrangian Hessian),
mapped over the stages, and the results are scattered into the global sparse matrices by
constant index maps (SOLVER_NOTES: 0.5 s build instead of 29 s). The stage functions can be
compiled to C once and cached on disk by content hash.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.atomic import remove_stale_temporaries

CACHE_ENV = "SKATELIB_CACHE_DIR"


def cache_dir() -> Path:
    """Where compiled stage functions are kept (``$SKATELIB_CACHE_DIR`` or ~/.cache/skatelib)."""
    base = os.environ.get(CACHE_ENV) or os.path.join(os.path.expanduser("~"), ".cache", "skatelib")
    return Path(base)


@dataclass(frozen=True)
class StageFunctions:
    """The per-stage functions: value, gradient, Jacobian and Hessian of the Lagrangian."""

    value: ca.Function  # (z, p) -> (l, g)
    grad: ca.Function  # (z, p) -> dl/dz
    jac: ca.Function  # (z, p) -> dg/dz (sparse)
    hess: ca.Function  # (z, p, sigma, lam) -> triu hessian of sigma l + lam' g (sparse)


def stage_functions(z: ca.SX, p: ca.SX, cost: ca.SX, cons: ca.SX) -> StageFunctions:
    """Differentiate one stage's cost and constraints symbolically (SX)."""
    sigma = ca.SX.sym("sigma")
    lam = ca.SX.sym("lam", cons.shape[0])
    lag = sigma * cost + ca.dot(lam, cons)
    H, _ = ca.hessian(lag, z)
    return StageFunctions(
        value=ca.Function("stage_value", [z, p], [cost, cons]),
        grad=ca.Function("stage_grad", [z, p], [ca.gradient(cost, z)]),
        jac=ca.Function("stage_jac", [z, p], [ca.jacobian(cons, z)]),
        hess=ca.Function("stage_hess", [z, p, sigma, lam], [ca.triu(H)]),
    )


# Bump when stage_functions changes how derivatives are formed: it is part of the cache key.
_DERIVATIVES_VERSION = "1"
_NAMES = ("stage_value", "stage_grad", "stage_jac", "stage_hess")


def c_compiler() -> str | None:
    """The C compiler the stage functions are built with ($CC, gcc or cc), or None."""
    return shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")


def serialized_stage(z: ca.SX, p: ca.SX, cost: ca.SX, cons: ca.SX) -> str:
    """The stage value function ``(z, p) -> (cost, cons)`` serialized: what determines every
    stage function (derivatives follow from it)."""
    return ca.Function("stage_value", [z, p], [cost, cons]).serialize()


def compiled_stage_functions(z: ca.SX, p: ca.SX, cost: ca.SX, cons: ca.SX, flags: str = "-O1",
                             serialized: str | None = None) -> StageFunctions:
    """The four stage functions compiled to C in one shared library, cached by content hash.

    The key is :func:`serialized_stage` (``serialized``, when the caller has it already), so a
    cache hit costs neither differentiation nor code generation. Without a C compiler, returns the
    symbolic functions.
    """
    cc = c_compiler()
    if cc is None:
        return stage_functions(z, p, cost, cons)
    text = serialized if serialized is not None else serialized_stage(z, p, cost, cons)
    key_src = text + flags + ca.CasadiMeta.version() + _DERIVATIVES_VERSION
    lib = cache_dir() / f"stage_{hashlib.sha256(key_src.encode()).hexdigest()[:20]}.so"
    if not lib.exists():
        fns = stage_functions(z, p, cost, cons)
        gen = ca.CodeGenerator("skatelib_stage.c", {"with_header": False})
        for f in (fns.value, fns.grad, fns.jac, fns.hess):
            gen.add(f)
        lib.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_temporaries(lib.parent, "compile")  # a compile killed earlier left its stage.c
        with tempfile.TemporaryDirectory(prefix=f"compile-{os.getpid()}-", dir=lib.parent) as tmp:
            c_file = Path(tmp) / "stage.c"
            c_file.write_text(gen.dump())
            so_tmp = Path(tmp) / "stage.so"
            subprocess.run([cc, flags, "-shared", "-fPIC", str(c_file), "-o", str(so_tmp)], check=True,
                           capture_output=True)
            os.replace(so_tmp, lib)  # atomic: parallel workers never load a half-written library
    return StageFunctions(*(ca.external(name, str(lib)) for name in _NAMES))


def _scatter(block_sp: ca.Sparsity, n_stages: int, row_step: int, col_step: int, shape: tuple[int, int],
             row_map: np.ndarray | None = None) -> tuple[ca.Sparsity, np.ndarray, np.ndarray]:
    """Global sparsity of stacked stage blocks and where each block nonzero goes.

    ``row_map`` maps full rows to kept rows (-1: dropped). Returns (sparsity, kept, index):
    ``kept`` marks block nonzeros that survive, ``index`` their global nonzero positions.
    """
    rows, cols = (np.asarray(a, dtype=np.int64) for a in block_sp.get_triplet())
    k = np.repeat(np.arange(n_stages), len(rows))
    R = np.tile(rows, n_stages) + k * row_step
    C = np.tile(cols, n_stages) + k * col_step
    kept = np.ones(len(R), dtype=bool)
    if row_map is not None:
        R = row_map[R]
        kept = R >= 0
    keys = C[kept] * shape[0] + R[kept]  # column-major order, as CasADi stores nonzeros
    uniq, index = _unique_inverse(keys)
    return _compressed(shape, uniq // shape[0], uniq % shape[0]), kept, index


def _unique_inverse(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(keys, return_inverse=True)`` by a stable sort: the stage blocks arrive almost in
    order (sorted runs), which a stable sort merges about 5x faster than np.unique's quicksort."""
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    first = np.empty(len(keys), dtype=bool)
    first[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    index = np.empty(len(keys), dtype=np.int64)
    index[order] = np.cumsum(first) - 1
    return ordered[first], index


def _compressed(shape: tuple[int, int], cols: np.ndarray, rows: np.ndarray) -> ca.Sparsity:
    """The sparsity of nonzeros already in storage order (by column, then row), built from its
    compressed columns (no sort, unlike ``Sparsity.triplet``)."""
    colind = np.searchsorted(cols, np.arange(shape[1] + 1))
    return ca.Sparsity(shape[0], shape[1], colind.tolist(), rows.tolist())


def _assemble(sp: ca.Sparsity, nz: ca.MX, kept: np.ndarray, index: np.ndarray) -> ca.MX:
    """A global sparse matrix from stacked stage nonzeros: dropped entries removed, overlapping
    entries (shared knots of neighbouring windows) summed."""
    if not kept.all():
        nz = nz[np.flatnonzero(kept).tolist()]
    if sp.nnz() == len(index):  # no overlaps: a permutation
        perm = np.empty(len(index), dtype=np.int64)
        perm[index] = np.arange(len(index))
        return ca.MX(sp, nz[perm.tolist()])
    # Summing matrix: block nonzero j adds into global nonzero index[j] (one entry per column).
    A = ca.DM(_compressed((sp.nnz(), len(index)), np.arange(len(index)), index), 1.0)
    return ca.MX(sp, ca.mtimes(A, nz))


@dataclass(frozen=True)
class StagewiseNLP:
    """The NLP functions IPOPT needs, built from mapped stage functions.

    Attributes:
        nlp: ``{"x": w, "p": P, "f": f, "g": g}`` as MX (g holds the kept rows only).
        options: nlpsol options: the assembled ``grad_f``, ``jac_g``, ``hess_lag``; ``no_nlp_grad``, no ``lam_p``.
        kept_rows: Indices of the stage rows (stage-major) that are in g.
    """

    nlp: dict[str, ca.MX]
    options: dict[str, Any]
    n_w: int
    n_g: int
    kept_rows: np.ndarray


def build_stagewise_nlp(fns: StageFunctions, n_stages: int, keep: np.ndarray | None = None) -> StagewiseNLP:
    """Assemble the NLP over ``w = [v_0, ..., v_N]`` and stage windows ``z_k = [v_k, v_{k+1}]``;
    the parameter is the (n_p x N) matrix of per-stage parameters. The sizes (n of each v, n_p,
    the rows per stage) are those of ``fns.value(z, p) -> (l, g)``.

    f and g evaluate ``fns.value`` itself (compiled, when the stage functions are): IPOPT gets every
    derivative from the assembled functions in ``options``, and ``no_nlp_grad`` keeps CasADi from
    differentiating f and g at set-up (a compiled function has no derivatives; the interpreted SX
    version it needed before took 0.3 s of a 2.3 s push-off solve). So there is no ``lam_p``.

    Args:
        keep: Boolean mask over all stage rows (stage-major); rows left out (free rows with
            infinite bounds on both sides) never reach the solver.
    """
    n, n_p, n_g_stage = fns.value.size1_in(0) // 2, fns.value.size1_in(1), fns.value.size1_out(1)
    n_w = n * (n_stages + 1)
    n_full = n_g_stage * n_stages
    keep = np.ones(n_full, dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    kept_rows = np.flatnonzero(keep)
    n_g = len(kept_rows)
    row_map = np.full(n_full, -1, dtype=np.int64)
    row_map[kept_rows] = np.arange(n_g)

    w = ca.MX.sym("w", n_w)
    p = ca.MX.sym("p", n_p * n_stages)
    P = ca.reshape(p, n_p, n_stages)
    window = (np.arange(2 * n)[:, None] + n * np.arange(n_stages)[None, :]).flatten(order="F")
    Z = ca.reshape(w[window.tolist()], 2 * n, n_stages)
    mode = "serial"
    L, G = fns.value.map(n_stages, mode)(Z, P)
    f = ca.sum2(L)
    g = ca.vec(G)[kept_rows.tolist()]

    # Gradient: windows overlap, so contributions to shared knots add up.
    GR = fns.grad.map(n_stages, mode)(Z, P)
    g_sp, g_kept, g_idx = _scatter(ca.Sparsity.dense(2 * n, 1), n_stages, n, 0, (n_w, 1))
    grad = _assemble(g_sp, ca.vec(GR), g_kept, g_idx)

    # Constraint Jacobian: stage k's rows touch only its window; dropped rows are left out.
    J_blocks = fns.jac.map(n_stages, mode)(Z, P)
    j_sp, j_kept, j_idx = _scatter(fns.jac.sparsity_out(0), n_stages, n_g_stage, n, (n_g, n_w), row_map)
    J = _assemble(j_sp, _nonzeros(J_blocks), j_kept, j_idx)

    # Hessian of the Lagrangian (upper triangle): dropped rows get zero multipliers.
    sigma = ca.MX.sym("lam_f")
    lam = ca.MX.sym("lam_g", n_g)
    S = ca.DM(ca.Sparsity.triplet(n_full, n_g, kept_rows.tolist(), list(range(n_g))), 1.0)
    lam_full = ca.reshape(ca.mtimes(S, lam), n_g_stage, n_stages)
    H_blocks = fns.hess.map(n_stages, mode)(Z, P, sigma, lam_full)
    h_sp, h_kept, h_idx = _scatter(fns.hess.sparsity_out(0), n_stages, n, n, (n_w, n_w))
    H = _assemble(h_sp, _nonzeros(H_blocks), h_kept, h_idx)

    grad_f = ca.Function("nlp_grad_f", [w, p], [f, grad], ["x", "p"], ["f", "grad_f_x"])
    jac_g = ca.Function("nlp_jac_g", [w, p], [g, J], ["x", "p"], ["g", "jac_g_x"])
    hess_lag = ca.Function("nlp_hess_l", [w, p, sigma, lam], [H],
                           ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
    return StagewiseNLP(nlp={"x": w, "p": p, "f": f, "g": g},
                        options={"grad_f": grad_f, "jac_g": jac_g, "hess_lag": hess_lag,
                                 "no_nlp_grad": True, "calc_lam_p": False},
                        n_w=n_w, n_g=n_g, kept_rows=kept_rows)


def _nonzeros(M: ca.MX) -> ca.MX:
    """The nonzeros of a sparse MX as a column, in storage order."""
    return M.nz[0:M.nnz()]
