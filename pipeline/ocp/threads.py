"""How many threads a solve evaluates its stage derivatives on.

The stage Jacobians and Lagrangian Hessians of one solve are independent of each other, so CasADi
evaluates them on several threads at once (``map(n, "thread", threads)``); the results are the
same to the bit. The Hessian is about half of an IPOPT iteration of the push-off, so a solve with a
second core takes about a fifth less time (docs/design-notes.md). The rest of the iteration (MUMPS)
stays on one thread.
"""

from __future__ import annotations

import os

import casadi as ca
from skatelib.library.errors import SkatelibError

ENV = "OMP_NUM_THREADS"  # the usual setting; the build's workers and joblib's loky set it to their share of the cores


def stage_threads() -> int:
    """``OMP_NUM_THREADS`` if set (its first entry where it lists several levels), else the cores
    this process may run on."""
    value = os.environ.get(ENV, "").split(",")[0].strip()
    if value:
        if not value.isdigit() or int(value) < 1:
            raise SkatelibError(f"environment variable {ENV}={os.environ[ENV]!r}: expected a whole number of "
                                f"threads, at least 1; set it so or unset it (then all cores this process may use)")
        return int(value)
    affinity = getattr(os, "sched_getaffinity", None)
    return len(affinity(0)) if affinity is not None else os.cpu_count() or 1


def mapped(fn: ca.Function, n_stages: int, threads: int) -> ca.Function:
    """``fn`` mapped over the stages on ``threads`` threads (serially for one)."""
    return fn.map(n_stages, "thread", min(threads, n_stages)) if threads > 1 else fn.map(n_stages, "serial")
