"""A stage-wise NLP whose derivatives are assembled from per-stage derivative functions.

Direct multiple shooting produces an NLP in which stage k's cost and constraints depend only on
the window ``z_k = w[k n : k n + 2 n]`` (state and control of knots k and k+1). Building one flat
expression graph and letting CasADi differentiate it costs tens of seconds; instead one SX
function per stage is differentiated once (gradient, constraint Jacobian, Lagrangian Hessian),
mapped over the stages, and the results are put together by sparse products with a constant
0/1 window matrix W (``w -> [z_0; ...; z_{N-1}]``): the gradient is ``W' g``, the Jacobian
``blockdiag(J_k) W`` and the Hessian ``W' blockdiag(H_k) W`` (docs/design-notes.md). The stage
functions can be compiled to C once and cached on disk by content hash.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library import trust
from skatelib.library.compiled import cached_or_compiled, held_or_loaded
from skatelib.pipeline.ocp.codegen import CSource, compile_library, generated, host_cpu, load_private
from skatelib.pipeline.ocp.curvature import lagrangian_hessian
from skatelib.pipeline.ocp.expressions import StageExpressions
from skatelib.pipeline.ocp.lanes import lane_source, lane_width, one_stage, over_stages, prelude


@dataclass(frozen=True)
class StageFunctions:
    """The per-stage functions: value, gradient, Jacobian and Hessian of the Lagrangian."""

    value: ca.Function  # (z, p) -> (l, g)
    grad: ca.Function  # (z, p) -> dl/dz
    jac: ca.Function  # (z, p) -> dg/dz (sparse)
    hess: ca.Function  # (z, p, sigma, lam) -> triu hessian of sigma l + lam' g (sparse)
    # Compiled, jac and hess may evaluate several stages at once (:mod:`.lanes`, :func:`.lanes.lanes_of`):
    # z, p and lam of that many stages side by side, sigma shared, their results side by side.

    def jacobian_at(self, z: Any, p: Any) -> ca.DM:
        """One stage's constraint Jacobian, in lanes or not."""
        return one_stage(self.jac, (z, p), ())

    def hessian_at(self, z: Any, p: Any, sigma: float, lam: Any) -> ca.DM:
        """One stage's Lagrangian Hessian, in lanes or not."""
        return one_stage(self.hess, (z, p, sigma, lam), HESS_SHARED)


def stage_functions(stage: StageExpressions, cse: bool = False) -> StageFunctions:
    """Differentiate one stage's cost and constraints symbolically (SX); ``cse``: each common
    subexpression computed once (the same values: for the C code, where the Hessian then has 7 %
    fewer operations; CasADi's interpreter runs such functions slower). The rows in ``stage.exact``
    have their Lagrangian Hessian given (:func:`~skatelib.pipeline.ocp.curvature.lagrangian_hessian`)."""
    z, p, cost, cons = stage.z, stage.p, stage.cost, stage.cons
    sigma = ca.SX.sym("sigma")
    lam = ca.SX.sym("lam", cons.shape[0])
    H = lagrangian_hessian(z, p, (sigma * cost, cons), lam, stage.exact)
    opts = {"cse": cse}
    return StageFunctions(
        value=ca.Function("stage_value", [z, p], [cost, cons], opts),
        grad=ca.Function("stage_grad", [z, p], [ca.gradient(cost, z)], opts),
        jac=ca.Function("stage_jac", [z, p], [ca.jacobian(cons, z)], opts),
        hess=ca.Function("stage_hess", [z, p, sigma, lam], [ca.triu(H)], opts),
    )


# Bump when stage_functions changes how derivatives are formed: it is part of the cache key.
_DERIVATIVES_VERSION = "5"
# the Jacobian and the Hessian in lanes where the compiler and their code allow, else one stage at a time
_NAMES = ("stage_value", "stage_grad", ("stage_jac_lanes", "stage_jac"), ("stage_hess_lanes", "stage_hess"))
HESS_SHARED = (2,)  # the Hessian's input that is one value for all stages: sigma


def c_compiler() -> str | None:
    """The C compiler the stage functions are built with ($CC, gcc or cc), or None."""
    return shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")


# -O2 doubles the push-off stage code's compile for a Hessian a tenth faster; -march=native (where the compiler
# takes it) evaluates faster with results identical to the last bit (docs/design-notes.md). The
# library then runs only on this kind of CPU, so the host CPU is part of the cache key.
# gcc spends most of a long stage function's compile allocating its registers: LEAN_FLAGS make
# that cheaper and skip three analyses; the push-off's stage code then compiles in about 10 % less
# CPU time, with results identical to the last bit and as fast to evaluate (docs/design-notes.md).
LEAN_FLAGS = ("-fira-region=one", "-fira-algorithm=priority", "-fno-dse", "-fno-tree-pta", "-fno-dce")
_FLAGS = ("-O1", "-march=native", *LEAN_FLAGS)
PORTABLE_FLAGS = ("-O1", *LEAN_FLAGS)  # code for any CPU of the architecture
_OPTIONAL = ("-march=native", *LEAN_FLAGS)  # only optimizations: left out where the compiler rejects them
COMPILE_LOG = logging.getLogger("skatelib.compile")  # says when (and only when) code is compiled


def _takes(cc: str, flags: Sequence[str]) -> bool:
    """Whether ``cc`` compiles an empty file with ``flags`` without an error or a warning."""
    probe = subprocess.run([cc, *flags, "-Werror", "-x", "c", "-c", "-", "-o", os.devnull], input=b"",
                           capture_output=True)
    return probe.returncode == 0


def _accepted(cc: str, flags: tuple[str, ...]) -> tuple[str, ...]:
    """``flags`` without the optional ones (``-march=native``, :data:`LEAN_FLAGS`) the compiler
    rejects or ignores (another compiler than gcc): they are only optimizations."""
    optional = [f for f in flags if f in _OPTIONAL]
    if not optional or _takes(cc, optional):
        return flags
    return tuple(f for f in flags if f not in _OPTIONAL or _takes(cc, [f]))


@dataclass(frozen=True)
class CompileTarget:
    """Where compiled stage functions are kept (the caller's cache folder) and the compiler flags."""

    folder: Path
    flags: tuple[str, ...] = _FLAGS


def compiled_stage_functions(stage: StageExpressions, target: CompileTarget) -> StageFunctions:
    """The four stage functions compiled to C in one shared library in ``target.folder``, cached by
    content hash, with its SHA-256 recorded beside it. A cached library is read once and checked (a
    symlink, a library that changed, or one others can write, is compiled again with a
    :class:`~skatelib.library.trust.CacheNote`), and the bytes checked are what is loaded, from a
    private copy (:mod:`skatelib.library.compiled`). The key is the stage's
    :attr:`~StageExpressions.key` (its serialized text and the rows with a given Hessian), the
    flags, CasADi's version and, for ``-march=native``, :func:`host_cpu`: a cache hit costs neither
    differentiation nor code generation, and a second hit in this process reads nothing
    (:func:`~skatelib.library.compiled.held_or_loaded`). Without a C compiler, the symbolic functions.

    Raises:
        OutputError: ``target.folder``, or a folder above it, can be changed by someone else.
    """
    cc = c_compiler()
    if cc is None:
        return stage_functions(stage)
    flags = target.flags
    native = host_cpu() if "-march=native" in flags else ""
    key_src = stage.key + " ".join(flags) + native + ca.CasadiMeta.version() + _DERIVATIVES_VERSION
    lib = target.folder / f"stage_{hashlib.sha256(key_src.encode()).hexdigest()[:20]}.so"

    def compile_now() -> bytes:
        COMPILE_LOG.info("compiling the stage functions with %s (about a minute, once per model and CPU; "
                         "kept in %s)", cc, lib.parent)
        fns, accepted = stage_functions(stage, cse=True), _accepted(cc, flags)
        lanes = lane_width(cc, accepted)
        jac, hess = (_in_lanes(f, lanes, shared) for f, shared in ((fns.jac, ()), (fns.hess, HESS_SHARED)))
        return compile_library((fns.value, fns.grad, jac, hess), cc, accepted, lib)

    return held_or_loaded(lib, lambda: StageFunctions(*load_private(  # the bytes checked, not the path
        cached_or_compiled(lib, trust.compile_advice(), compile_now), target.folder, _NAMES)))


def _in_lanes(f: ca.Function, lanes: int, shared: tuple[int, ...]) -> CSource:
    """``f``'s C in ``lanes`` (inputs ``shared`` one value for all stages), or as it is where it
    cannot be (one lane, or code of a kind :func:`~.lanes.lane_source` does not make in lanes)."""
    plain = generated(f)
    text = lane_source(f, plain.text, lanes, shared) if lanes > 1 else None
    return plain if text is None else CSource(f"{f.name()}_lanes", text, prelude(lanes))


def _block_diagonal(stacked: ca.MX, block: ca.Sparsity, n_blocks: int) -> ca.MX:
    """The block-diagonal matrix of the first ``n_blocks`` blocks a mapped function returns side by
    side (``[B_0, ..., B_{N-1}, ...]``, each of sparsity ``block``): in column-major storage both
    hold the same nonzeros in the same order, so this only reinterprets them."""
    return ca.MX(ca.diagcat(*[block] * n_blocks), stacked.nz[0:block.nnz() * n_blocks])


def _selection(n_rows: int, n_cols: int, cols: np.ndarray) -> ca.DM:
    """The 0/1 matrix whose row i picks column ``cols[i]``: ``S @ v == v[cols]``, and ``S.T @ y``
    adds every y_i into position ``cols[i]``."""
    return ca.DM(ca.Sparsity.triplet(n_rows, n_cols, list(range(n_rows)), np.asarray(cols).tolist()), 1.0)


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


def build_stagewise_nlp(fns: StageFunctions, n_stages: int, keep: np.ndarray | None = None, threads: int = 1
                        ) -> StagewiseNLP:
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
        threads: Threads the stage Jacobians and Hessians are evaluated on (the same values).
    """
    n, n_p, n_g_stage = fns.value.size1_in(0) // 2, fns.value.size1_in(1), fns.value.size1_out(1)
    n_w = n * (n_stages + 1)
    n_full = n_g_stage * n_stages
    keep = np.ones(n_full, dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    kept_rows = np.flatnonzero(keep)
    n_g = len(kept_rows)

    w = ca.MX.sym("w", n_w)
    p = ca.MX.sym("p", n_p * n_stages)
    P = ca.reshape(p, n_p, n_stages)
    window = (np.arange(2 * n)[:, None] + n * np.arange(n_stages)[None, :]).flatten(order="F")
    Z = ca.reshape(w[window.tolist()], 2 * n, n_stages)
    # The stacked windows are W @ w; W.T adds stage contributions back onto the knots, summing
    # where neighbouring windows share a knot.
    W = _selection(2 * n * n_stages, n_w, window)
    L, G = fns.value.map(n_stages, "serial")(Z, P)
    f = ca.sum2(L)
    g = ca.vec(G)[kept_rows.tolist()]

    grad = ca.mtimes(W.T, ca.vec(fns.grad.map(n_stages, "serial")(Z, P)))

    # Constraint Jacobian: the stage blocks on the diagonal, the kept rows, the columns moved onto the knots.
    J_blocks, J_block = over_stages(fns.jac, n_stages, threads, [Z, P])
    J = ca.mtimes(_block_diagonal(J_blocks, J_block, n_stages)[kept_rows.tolist(), :], W)

    # Hessian of the Lagrangian (upper triangle, which W.T (.) W keeps): dropped rows get zero multipliers.
    sigma = ca.MX.sym("lam_f")
    lam = ca.MX.sym("lam_g", n_g)
    lam_full = ca.reshape(ca.mtimes(_selection(n_g, n_full, kept_rows).T, lam), n_g_stage, n_stages)
    H_blocks, H_block = over_stages(fns.hess, n_stages, threads, [Z, P, sigma, lam_full], shared=HESS_SHARED)
    H = ca.mtimes(W.T, ca.mtimes(_block_diagonal(H_blocks, H_block, n_stages), W))

    grad_f = ca.Function("nlp_grad_f", [w, p], [f, grad], ["x", "p"], ["f", "grad_f_x"])
    jac_g = ca.Function("nlp_jac_g", [w, p], [g, J], ["x", "p"], ["g", "jac_g_x"])
    hess_lag = ca.Function("nlp_hess_l", [w, p, sigma, lam], [H],
                           ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
    return StagewiseNLP(nlp={"x": w, "p": p, "f": f, "g": g},
                        options={"grad_f": grad_f, "jac_g": jac_g, "hess_lag": hess_lag,
                                 "no_nlp_grad": True, "calc_lam_p": False},
                        n_w=n_w, n_g=n_g, kept_rows=kept_rows)
